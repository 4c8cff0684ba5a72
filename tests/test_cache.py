"""The parse cache: a hit gives exactly the `Run` a parse gives, skips the parse, and a changed
file never hits (content hash; stat taken as proof of no change only once it has settled)."""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from wifibot_power import cache as cache_module
from wifibot_power.cache import ParseCache
from wifibot_power.errors import LogError, UsageError
from wifibot_power.fit import FitResult, fit_logs
from wifibot_power.io import ReadOptions, read_log, reader
from wifibot_power.run import Run, RunMeta

LOG = """# wbpower-log: 1
# run_id: r1
# mode: motion
# speed_mps: 0.5
# distance_m: 2
# steps: 1
# started_at: 2015-06-01T09:00:00Z
time_s,voltage_V,current_A,power_W
0,12.0,2.0,24.0
0.001,12.0,2.1,25.2
0.002,12.0,2.2,26.4
0.003,12.0,2.0,24.0
"""


def assert_same_run(a: Run, b: Run) -> None:
    """Bitwise: a cached parse is the parse, not an approximation of it."""
    assert a.file == b.file and a.format == b.format
    assert a.meta == b.meta and a.problems == b.problems
    assert a.power_W.dtype == b.power_W.dtype == np.float64
    np.testing.assert_array_equal(a.power_W, b.power_W)
    np.testing.assert_array_equal(a.time_s, b.time_s)
    assert (a.speed_mps is None) == (b.speed_mps is None)
    if a.speed_mps is not None:
        assert a.speed_mps.dtype == b.speed_mps.dtype == np.float64
        np.testing.assert_array_equal(a.speed_mps, b.speed_mps)
    assert list(a.channels_W) == list(b.channels_W)
    for name, channel_W in a.channels_W.items():
        np.testing.assert_array_equal(channel_W, b.channels_W[name])


class Spy:
    """Counts the parses the cache falls back to."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.calls = 0
        real = reader.read_log

        def counting(*args, **kwargs):
            self.calls += 1
            return real(*args, **kwargs)

        monkeypatch.setattr(reader, "read_log", counting)  # the cache imports it when it parses


@pytest.fixture
def settled(monkeypatch: pytest.MonkeyPatch) -> None:
    """Files are taken as settled at once (a test cannot wait for the 2 s settle time)."""
    monkeypatch.setattr(cache_module, "SETTLE_NS", -(10**9))  # even a ctime 1 s ahead


def test_hit_is_the_same_run_and_skips_the_parse(tmp_path: Path, monkeypatch, settled) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    spy = Spy(monkeypatch)
    first = cache.read_log(log)
    assert spy.calls == 1
    assert_same_run(first, read_log(log))
    second = cache.read_log(log)
    assert spy.calls == 1  # served from the cache
    assert_same_run(second, read_log(log))
    assert second.meta.started_at is not None and second.meta.speed_mps == 0.5
    # 4 samples of 24, 25.2, 26.4, 24 W at 1 ms: 99.6 W x 1 ms = 0.0996 J
    assert second.energy_J == pytest.approx(0.0996, rel=1e-12)


GAP_ROWS = "".join(f"{k / 1000:.3f},23.{k % 7}\n" for k in range(301) if k != 150)


@pytest.mark.parametrize(
    "name, text",
    [
        # power only, no time column: time is index x period, not stored
        ("p.csv", "# mode: idle\n# sample_period_s: 0.001\npower_W\n23.1\n23.3\n23.2\n"),
        # a short gap of one dropped sample in 300 (a Problem travels with the run)
        ("gap.csv", "# mode: idle\ntime_s,power_W\n" + GAP_ROWS),
        # semicolons and decimal commas
        ("comma.csv", "# mode: idle\ntime_s;power_W\n0;23,1\n0,001;23,3\n0,002;23,2\n"),
        # a speed column travels with the run
        ("speed.csv", "time_s,power_W,Speed_MPS\n0,23.1,0\n0.001,25.3,0.125\n0.002,26.2,0.25\n"),
        # two motors' channels, summed, each kept
        ("two.csv", "time_ms,power_left_W,power_right_W\n0,1.5,2\n1,1.25,2.5\n2,3,1\n"),
    ],
)
def test_hit_round_trips_every_kind_of_log(
    tmp_path: Path, name: str, text: str, monkeypatch, settled
) -> None:
    log = tmp_path / name
    log.write_text(text)
    cache = ParseCache(tmp_path / "cache")
    spy = Spy(monkeypatch)
    cache.read_log(log)
    assert_same_run(cache.read_log(log), read_log(log))
    assert spy.calls == 1  # the second read came from the cache
    assert bool(read_log(log).problems) == (name == "gap.csv")
    assert (cache.read_log(log).speed_mps is not None) == (name == "speed.csv")
    assert list(cache.read_log(log).channels_W) == (["left", "right"] * (name == "two.csv"))


def test_gzip_log(tmp_path: Path, monkeypatch, settled) -> None:
    log = tmp_path / "r1.csv.gz"
    log.write_bytes(gzip.compress(LOG.encode()))
    cache = ParseCache(tmp_path / "cache")
    spy = Spy(monkeypatch)
    cache.read_log(log)
    assert_same_run(cache.read_log(log), read_log(log))
    assert spy.calls == 1


def _rewrite_same_size_same_mtime(log: Path, old: str, new: str) -> None:
    """Change the content, keep the size and set the mtime back: what defeats a size+mtime key."""
    stat = log.stat()
    text = log.read_text()
    assert len(old) == len(new) and old in text
    log.write_text(text.replace(old, new))
    os.utime(log, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert log.stat().st_size == stat.st_size and log.stat().st_mtime_ns == stat.st_mtime_ns


def test_changed_file_never_hits_even_with_same_size_and_mtime(tmp_path: Path, settled) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    assert cache.read_log(log).power_W[1] == 25.2
    _rewrite_same_size_same_mtime(log, "25.2", "29.9")
    # the ctime moved (no program can set it back), so the content is hashed again: a miss
    run = cache.read_log(log)
    assert run.power_W[1] == 29.9
    assert_same_run(run, read_log(log))


def test_racy_entry_is_hashed_again(tmp_path: Path, monkeypatch) -> None:
    """A file changed within one timestamp tick keeps its whole stat; the entry written while
    the file was that fresh is unsettled, so its content is hashed again, and the change seen."""
    monkeypatch.setattr(cache_module, "_fingerprint", lambda stat: [stat.st_size])  # coarse clock
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    cache.read_log(log)  # the file is fresh: the entry is unsettled (real SETTLE_S)
    log.write_text(LOG.replace("25.2", "29.9"))
    assert cache.read_log(log).power_W[1] == 29.9


def test_settled_entry_trusts_stat_without_reading(tmp_path: Path, monkeypatch, settled) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    cache.read_log(log)
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail("read the file"))
    assert cache.read_log(log).power_W[1] == 25.2


def test_touched_file_same_content_hits_then_is_trusted_again(
    tmp_path: Path, monkeypatch, settled
) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    spy = Spy(monkeypatch)
    cache.read_log(log)
    os.utime(log, ns=(10**18, 10**18))  # touched: stat changed, content not
    cache.read_log(log)
    assert spy.calls == 1  # content hash matched: no parse
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail("hashed again"))
    cache.read_log(log)  # the new stat was recorded


def test_reading_options_and_manifest_values_are_part_of_the_key(tmp_path: Path, settled) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    cache.read_log(log)
    # current column x a 10 V supply, instead of the power column: 2.1 A x 10 V = 21 W
    options = ReadOptions(current_column="current_A", supply_voltage_V=10.0)
    assert cache.read_log(log, options).power_W[1] == pytest.approx(21.0, rel=1e-12)
    overridden = cache.read_log(log, overrides={"speed_mps": "0.7"}, origin="runs.csv line 2")
    assert overridden.meta.speed_mps == 0.7
    assert cache.read_log(log).meta.speed_mps == 0.5
    assert_same_run(cache.read_log(log, options), read_log(log, options))


def test_speed_is_kept_and_its_option_is_part_of_the_key(
    tmp_path: Path, monkeypatch, settled
) -> None:
    log = tmp_path / "wheels.csv"
    log.write_text("time_s,power_W,wheel_v\n0,23.1,0\n0.001,25.3,0.125\n0.002,26.2,0.25\n")
    cache = ParseCache(tmp_path / "cache")
    spy = Spy(monkeypatch)
    assert cache.read_log(log).speed_mps is None  # no speed_mps column: no speed
    options = ReadOptions(speed_column="wheel_v")
    assert cache.read_log(log, options).speed_mps.tolist() == [0.0, 0.125, 0.25]
    assert spy.calls == 2  # another entry
    assert cache.read_log(log, options).speed_mps.tolist() == [0.0, 0.125, 0.25]
    assert cache.read_log(log).speed_mps is None  # not the entry read with the option
    assert spy.calls == 2  # both served from the cache, the speed with them


def test_a_new_reader_reads_afresh(tmp_path: Path, monkeypatch) -> None:
    cache = ParseCache(tmp_path / "cache")
    before = cache.entry_path(tmp_path / "r1.csv", ReadOptions(), None, None)
    monkeypatch.setattr(cache_module, "reader_digest", lambda: "another reader")
    assert cache.entry_path(tmp_path / "r1.csv", ReadOptions(), None, None) != before


def test_broken_entry_is_a_miss(tmp_path: Path, settled) -> None:
    log = tmp_path / "r1.csv"
    log.write_text(LOG)
    cache = ParseCache(tmp_path / "cache")
    cache.read_log(log)
    entry = cache.entry_path(log, ReadOptions(), None, None)
    entry.write_bytes(entry.read_bytes()[:100])  # cut short
    assert_same_run(cache.read_log(log), read_log(log))


def test_bad_log_same_error_and_not_cached(tmp_path: Path) -> None:
    log = tmp_path / "bad.csv"
    log.write_text("# mode: idle\npower_W\n23.1\nabc\n")
    cache = ParseCache(tmp_path / "cache")
    with pytest.raises(LogError) as plain:
        read_log(log)
    with pytest.raises(LogError) as cached:
        cache.read_log(log)
    assert cached.value.one_line() == plain.value.one_line()
    assert list((tmp_path / "cache").iterdir()) == []


def test_cache_folder_that_cannot_be_made_is_a_usage_error(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(UsageError) as info:
        ParseCache(blocker / "cache")
    assert "--cache" in info.value.one_line() and str(blocker) in info.value.one_line()


def _corpus(folder: Path, trips: tuple = ((2.0, 1),)) -> Path:
    from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

    config = SimConfig(
        speeds_mps=(0.3, 0.9),
        trips=trips,
        repeats=1,
        modes=("idle",),
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=1.024e-3,
        seed=3,
    )
    write_simulation(config, folder, WriteOptions(columns="full"))
    return folder


def _raise_one_sample(log: Path) -> None:
    """5 W more on one sample of a motion log, in the middle of its first cruise (so the fit
    moves: a sample of an idle phase leaves the summary as it was)."""
    from wifibot_power.io.reader import read_log
    from wifibot_power.segment import segment_run

    cruise = next(p for p in segment_run(read_log(log)).phases if p.phase == "cruise")
    lines = log.read_text().split("\n")
    header = next(k for k, line in enumerate(lines) if line.startswith("time_s"))
    row = header + 1 + (cruise.i_start + cruise.i_end) // 2
    t, v, i, p = lines[row].split(",")
    lines[row] = f"{t},{v},{i},{float(p) + 5:.4f}"
    log.write_text("\n".join(lines))


def assert_same_fit(a, b) -> None:
    assert a.summary() == b.summary()
    pd.testing.assert_frame_equal(a.runs, b.runs)
    pd.testing.assert_frame_equal(a.phases, b.phases)
    assert a.skipped == b.skipped


def test_fit_with_cache_same_result_cold_and_warm(tmp_path: Path, wbpower, monkeypatch) -> None:
    corpus = _corpus(tmp_path / "logs")
    plain = fit_logs([corpus], jobs=1)
    cache = ParseCache(tmp_path / "cache")
    assert_same_fit(fit_logs([corpus], jobs=2, cache=cache), plain)  # fills it
    # 3 logs: 3 parses and 3 kept results (row + phases of each run)
    assert len(list((tmp_path / "cache").glob("*.result.json"))) == 3
    assert len(list((tmp_path / "cache").glob("*.parquet"))) == 3
    # warm: neither parsed nor segmented again, and exactly the same result
    monkeypatch.setattr(reader, "read_log", lambda *a, **k: pytest.fail("parsed"))
    monkeypatch.setattr("wifibot_power.segment.segment_run", lambda run: pytest.fail("segmented"))
    for jobs in (1, 2):
        assert_same_fit(fit_logs([corpus], jobs=jobs, cache=cache), plain)
    warm = wbpower("fit", corpus, "--json", "--cache", tmp_path / "cache")
    assert warm.exit_code == 0, warm.stderr
    document = json.loads(warm.stdout)
    assert document.pop("error") is None  # cli.md: every --json document has it
    assert document == json.loads(json.dumps(plain.summary()))


def test_fit_kept_results_follow_the_content(tmp_path: Path, settled) -> None:
    corpus = _corpus(tmp_path / "logs")
    cache = ParseCache(tmp_path / "cache")
    fit_logs([corpus], jobs=1, cache=cache)
    # a new content: 1 W more on every sample of the 0.9 m/s run
    log = corpus / "v0.90_d2_s1_r1.csv"
    lines = log.read_text().split("\n")
    header = next(k for k, line in enumerate(lines) if line.startswith("time_s"))
    bumped = []
    for line in lines[header + 1 : -1]:
        t, v, i, p = line.split(",")
        bumped.append(f"{t},{v},{i},{float(p) + 1:.4f}")
    text = "\n".join(lines[: header + 1] + bumped) + "\n"
    log.write_text(text)
    after = fit_logs([corpus], jobs=1, cache=cache)
    assert_same_fit(after, fit_logs([corpus], jobs=1))
    # the 0.9 m/s run's mean power moved by 1 W (every sample +1 W, rounding to 4 decimals)
    runs = after.runs.set_index("run_id")
    assert runs.loc["v0.90_d2_s1_r1", "mean_power_W"] == pytest.approx(
        np.mean([float(x.split(",")[3]) for x in bumped]), abs=1e-9
    )


def _json(value: object) -> str:
    """Exact text of JSON values (NaN as NaN, floats by repr): equal text, equal values."""
    return json.dumps(value, sort_keys=True)


@pytest.mark.parametrize(
    "shape",
    [
        # stop-and-go trips at 2 speeds (overheads with intervals), idle and a component
        # mode, a log that cannot be read (skipped), warnings (2 speed levels)
        {"speeds": (0.3, 0.9), "trips": ((2.0, 1), (2.0, 2)), "modes": ("idle", "network")},
        # one speed: an incomplete model (NaN slopes and intervals), a note, no idle run
        # (idle from the motion runs' idle phases), one component mode of a single run
        {"speeds": (0.5,), "trips": ((2.0, 1),), "modes": ("video",)},
    ],
)
def test_kept_fit_is_the_fit(tmp_path: Path, shape: dict) -> None:
    """What `fit --cache` keeps of a fit reads back to the same result, field by field: the
    `fit --json` document, the paper table, the model, every stop-and-go row, what was
    skipped, noted and warned."""
    from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

    config = SimConfig(
        speeds_mps=shape["speeds"],
        trips=shape["trips"],
        repeats=2,
        modes=shape["modes"],
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=1.024e-3,
        seed=5,
    )
    folder = tmp_path / "logs"
    write_simulation(config, folder, WriteOptions(columns="full"))
    (folder / "broken.csv").write_text("# mode: idle\npower_W\n23.1\nabc\n")
    fit = fit_logs([folder], jobs=1)
    back = FitResult.from_json(json.loads(_json(fit.to_json())), fit.tables)
    assert back.summary() == fit.summary()
    assert back.to_markdown() == fit.to_markdown()
    assert _json(back.table_rows()) == _json(fit.table_rows())
    assert _json(back.model.to_json()) == _json(fit.model.to_json())
    assert _json(back.to_json()) == _json(fit.to_json())
    assert back.skipped == fit.skipped and back.skipped
    assert back.warnings == fit.warnings and back.warnings
    assert back.model_complete == fit.model_complete
    if len(shape["speeds"]) == 1:
        assert not fit.model_complete and back.notes == fit.notes and back.notes
    else:
        assert len(back.stop_and_go) == 2 and back.stop_and_go == fit.stop_and_go


def test_warm_fit_is_kept_and_follows_every_input(tmp_path: Path, settled, monkeypatch) -> None:
    """A warm `fit_logs` whose runs are all unchanged takes the fit from the cache (it does
    not fit again); a changed log, another `keep_doubtful`, another folder fit again, and
    every answer is the uncached one."""
    from wifibot_power.models.paper import PaperFamily

    corpus = _corpus(tmp_path / "logs", trips=((2.0, 1), (2.0, 2)))
    cache = ParseCache(tmp_path / "cache")
    fits: list[int] = []
    real = PaperFamily.fit

    def counting(*args, **kwargs):
        fits.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(PaperFamily, "fit", counting)
    plain = fit_logs([corpus], jobs=1)
    assert len(fits) == 1
    assert_same_fit(fit_logs([corpus], jobs=1, cache=cache), plain)  # fills the cache
    assert len(fits) == 2 and len(list((tmp_path / "cache").glob("*.batch.json"))) == 1
    for keep_doubtful in (False, True):
        before = len(fits)
        warm = fit_logs([corpus], jobs=1, cache=cache, keep_doubtful=keep_doubtful)
        assert_same_fit(warm, fit_logs([corpus], jobs=1, keep_doubtful=keep_doubtful))
        # the uncached fit, and for True (another batch) the cached one: then kept
        assert len(fits) == before + 1 + keep_doubtful
        fit_logs([corpus], jobs=1, cache=cache, keep_doubtful=keep_doubtful)
        assert len(fits) == before + 1 + keep_doubtful
    # a copy of the folder is another batch (its runs' rows name other files)
    copy = tmp_path / "copy"
    copy.mkdir()
    for log in corpus.iterdir():
        (copy / log.name).write_bytes(log.read_bytes())
    before = len(fits)
    assert fit_logs([copy], jobs=1, cache=cache).summary() == plain.summary()
    assert len(fits) == before + 1
    # one log changed: its row changes, the fit is made again, and replaces the kept one
    _raise_one_sample(corpus / "v0.90_d2_s2_r1.csv")
    before = len(fits)
    changed = fit_logs([corpus], jobs=1, cache=cache)
    assert len(fits) == before + 1  # fitted again
    assert_same_fit(changed, fit_logs([corpus], jobs=1))
    assert changed.summary() != plain.summary()
    assert len(list((tmp_path / "cache").glob("*.batch.json"))) == 3  # replaced, not added


def test_broken_kept_fit_is_fitted_again(tmp_path: Path, settled) -> None:
    corpus = _corpus(tmp_path / "logs")
    cache = ParseCache(tmp_path / "cache")
    plain = fit_logs([corpus], jobs=1)
    fit_logs([corpus], jobs=1, cache=cache)
    (kept,) = (tmp_path / "cache").glob("*.batch.json")
    document = json.loads(kept.read_text())
    del document["result"]["fits"]["paper"]["model"]["accel"]  # another layout, or cut short
    kept.write_text(json.dumps(document))
    assert_same_fit(fit_logs([corpus], jobs=1, cache=cache), plain)
    kept.write_text(kept.read_text()[:100])
    assert_same_fit(fit_logs([corpus], jobs=1, cache=cache), plain)


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    power=hnp.arrays(np.float64, st.integers(1, 200), elements=finite),
    irregular=st.booleans(),
    period=st.sampled_from([0.1024e-3, 1e-3, 0.3]),
)
def test_entry_round_trip_is_bitwise(
    tmp_path: Path, power: np.ndarray, irregular: bool, period: float
) -> None:
    time_s = np.arange(power.size) * period
    if irregular:
        time_s = time_s + 1e-9  # a time column that must be stored
    meta = RunMeta("r", mode="idle", sample_period_s=period, extra={"k": "v"})
    run = Run("f.csv", "wbpower-csv", meta, time_s, power)
    entry = tmp_path / f"e{power.size}{irregular}{period}.parquet"
    cache_module._store(entry, run, {"fingerprint": [1], "content_sha256": "x", "settled": True})
    loaded = cache_module._load_run(entry, "x")
    assert loaded is not None
    assert_same_run(loaded, run)
    assert cache_module._load_run(entry, "other content") is None


# -- the warm path: nothing but the kept results, in the calling process -----------------------

WARM_RUN = r"""
import json, sys
corpus, cache, heavy, spy = sys.argv[1:5]
started = []
if spy == "spy":  # count the files sent to workers (the spy itself loads multiprocessing)
    from wifibot_power import parallel

    real = parallel.map_ordered
    def counting(items, task, **kwargs):
        started.extend(items)
        return real(items, task, **kwargs)
    parallel.map_ordered = counting
from wifibot_power.cli import main
sys.argv = ["wbpower", "fit", corpus, "--json", "--jobs", "2", "--cache", cache]
try:
    main()
except SystemExit:
    pass
loaded = sorted(m for m in heavy.split(",") if m in sys.modules)
print(json.dumps({"loaded": loaded, "worked_on": len(started)}), file=sys.stderr)
"""

#: What a warm `fit --json --cache` must not import, and why (measured with `-X importtime`
#: on this 2-core machine; docs/benchmarks.md, "Warm cache"): numpy (~0.1 s, the largest
#: part of a warm run: the fit itself is kept, `pipeline.batch_key`, so nothing is computed on
#: arrays) and the numerics (`stats`, `energy`, the causes), pandas, scipy, pyarrow (~0.8 s
#: together; the reader: `io.reader`), the segmenter and run table (only for a file worked
#: on), matplotlib (only a figure needs it), pydantic (typer >= 0.29 coerces options through
#: it: ~0.1 s, hence typer < 0.29 in pyproject.toml), rich (~30-60 ms: only human output
#: draws with it), multiprocessing and concurrent.futures (~15-30 ms: only for workers),
#: tempfile (only for writing) and `diagnose`.
WARM_UNLOADED = (
    "numpy",
    "wifibot_power.stats",
    "wifibot_power.energy",
    "pandas",
    "scipy",
    "pyarrow",
    "pydantic",
    "matplotlib",
    "rich",
    "multiprocessing",
    "concurrent.futures",
    "tempfile",
    "wifibot_power.io.reader",
    "wifibot_power.segment",
    "wifibot_power.runtable",
    "wifibot_power.parallel",
    "wifibot_power.causes",
    "wifibot_power.diagnose",
    "wifibot_power.figures",
)


def test_warm_fit_forks_no_worker_and_loads_no_parser(tmp_path: Path) -> None:
    """What makes a warm `fit --cache` >= 10x faster than a cold one (docs/benchmarks.md): no
    file goes to a worker, and none of `WARM_UNLOADED` is imported. The cold run, measured
    the same way, goes through the workers and loads pyarrow in this process before they
    fork; the warm one prints the same JSON."""
    import subprocess
    import sys

    # with steps, so the warm fit also computes the stop-and-go overheads (energy.py)
    corpus = _corpus(tmp_path / "logs", trips=((2.0, 1), (2.0, 2)))

    def run(spy: str) -> tuple[dict, dict]:
        done = subprocess.run(
            [
                sys.executable,
                "-c",
                WARM_RUN,
                str(corpus),
                str(tmp_path / "cache"),
                ",".join(WARM_UNLOADED),
                spy,
            ],
            capture_output=True,
            text=True,
            check=True,
        )
        document = json.loads(done.stdout)
        assert document.pop("error") is None  # cli.md: every --json document has it
        return document, json.loads(done.stderr.strip().splitlines()[-1])

    cold_summary, cold = run("spy")
    warm_summary, warm = run("spy")
    assert cold["worked_on"] == 5  # 5 logs parsed and segmented (pandas: in the workers)
    assert {"pyarrow", "wifibot_power.io.reader", "wifibot_power.segment"} <= set(cold["loaded"])
    assert warm["worked_on"] == 0
    assert "numpy" not in warm["loaded"]  # the fit kept by the cold run serves the first warm one
    warm_summary, warm = run("no spy")  # nothing loaded by the test itself
    assert warm == {"loaded": [], "worked_on": 0}
    assert warm_summary == cold_summary
    # the stop-and-go overheads were computed (by energy.py, without the causes) and kept
    assert len(warm_summary["stop_and_go"]) == 2  # 2 speeds, each in 1 and 2 steps
    assert all(s["model_overhead_pct"] is not None for s in warm_summary["stop_and_go"])
    # one log changed (one sample, 5 W more): that log alone is parsed again, and the fit
    # is the uncached fit of the changed folder
    _raise_one_sample(corpus / "v0.90_d2_s2_r1.csv")
    changed_summary, changed = run("spy")
    assert changed["worked_on"] == 1
    assert changed_summary != cold_summary
    assert changed_summary == json.loads(json.dumps(fit_logs([corpus], jobs=1).summary()))


def test_fit_tables_are_made_when_asked_for(tmp_path: Path) -> None:
    """FitResult.runs / .phases are pandas tables made on first use, then the same object."""
    result = fit_logs([_corpus(tmp_path / "logs")], jobs=1)
    assert "_frames" not in vars(result)
    runs = result.runs
    assert runs is result.runs and len(runs) == 3 and result.n_runs == 3
    assert list(result.phases.columns)[:4] == ["run_id", "file", "step", "phase"]


def test_component_modes_are_the_run_tables() -> None:
    from wifibot_power import fit, runtable

    assert fit.COMPONENT_MODES == runtable.COMPONENT_MODES == ("network", "video", "cpu")


# -- Student's t quantile without scipy (fit's intervals) --------------------------------------


def test_library_versions_in_the_code_digest_are_the_installed_ones() -> None:
    """The kept results' key names numpy/pandas/scipy/pyarrow versions without importing them:
    they must be what the package metadata says (a new pandas must recompute)."""
    from importlib.metadata import version

    for name in ("numpy", "pandas", "scipy", "pyarrow"):
        assert cache_module._installed_version(name) == version(name)
    assert cache_module._installed_version("no_such_distribution_here") == "absent"


def test_a_cache_keeps_only_what_this_version_can_read(tmp_path: Path, monkeypatch) -> None:
    """Every cache file is named by the code it is valid for, and a new `ParseCache` deletes
    the files of any other version (an upgrade would otherwise leave a corpus's worth of
    parses behind for good), the layout before tags and a killed writer's day-old temporary
    file; never a file that is not the cache's."""
    corpus = _corpus(tmp_path / "logs")
    folder = tmp_path / "cache"
    plain = fit_logs([corpus], jobs=1)
    fit_logs([corpus], jobs=1, cache=ParseCache(folder))
    version_a = sorted(p.name for p in folder.iterdir())
    assert len(version_a) == 3 * 3 + 1  # per log: parse, its validity, kept result; the batch
    theirs = ["notes.txt", "runs.json", "0123.parquet", "a" * 40 + ".csv"]
    for name in theirs:
        (folder / name).write_text("the user's")
    # named as the layout before tags, but not the cache's: kept
    (folder / ("a" * 40 + ".json")).write_text('{"the user": 1}')
    (folder / ("e" * 40 + ".parquet")).write_text("no cache document beside it")
    theirs += ["a" * 40 + ".json", "e" * 40 + ".parquet"]
    untagged = {
        "b" * 40 + ".json": '{"cache_format": 2, "content_sha256": "x"}',
        "b" * 40 + ".parquet": "the entry beside it",
        "b" * 40 + "." + "c" * 16 + ".result.json": '{"content_sha256": "x", "result": 1}',
        "d" * 40 + ".batch.json": '{"content_sha256": "x", "result": 1}',
    }
    for name, text in untagged.items():
        (folder / name).write_text(text)
    cache_like = version_a[0]
    fresh_tmp, old_tmp = folder / f".{cache_like}.123.tmp", folder / f".{cache_like}.456.tmp"
    theirs_tmp = folder / ".notes.txt.789.tmp"  # an editor's, two days old: not the cache's
    for tmp in (fresh_tmp, old_tmp, theirs_tmp):
        tmp.write_text("")
    two_days_ago = os.stat(old_tmp).st_mtime - 2 * 86400
    for tmp in (old_tmp, theirs_tmp):
        os.utime(tmp, (two_days_ago, two_days_ago))
    theirs.append(theirs_tmp.name)

    # the same version: nothing of it goes
    ParseCache(folder)
    assert set(version_a) <= {p.name for p in folder.iterdir()}

    # another version of the reader and of the code (an upgrade)
    monkeypatch.setattr(cache_module, "reader_digest", lambda: "f" * 64)
    monkeypatch.setattr(cache_module, "code_digest", lambda: "e" * 64)
    assert ParseCache(folder).directory == folder
    left = sorted(p.name for p in folder.iterdir())
    assert left == sorted([*theirs, fresh_tmp.name])
    assert_same_fit(fit_logs([corpus], jobs=1, cache=ParseCache(folder)), plain)
    version_b = sorted(set(p.name for p in folder.iterdir()) - set(left))
    assert len(version_b) == len(version_a) and not set(version_b) & set(version_a)
    assert all(name.startswith(("ffffffffffff-", "eeeeeeeeeeee-")) for name in version_b)

    # only the reader changed: its parses go, and the results made from them; the batch stays
    # (it is checked against every run's row when read)
    monkeypatch.setattr(cache_module, "reader_digest", lambda: "8" * 64)
    ParseCache(folder)
    kept = sorted(set(p.name for p in folder.iterdir()) - set(left))
    assert kept == [n for n in version_b if n.endswith(".batch.json")]
    # only the code changed (the reader did not): the parses stay, results and batch go
    monkeypatch.setattr(cache_module, "reader_digest", lambda: "f" * 64)
    fit_logs([corpus], jobs=1, cache=ParseCache(folder))
    assert sorted(set(p.name for p in folder.iterdir()) - set(left)) == version_b
    monkeypatch.setattr(cache_module, "code_digest", lambda: "9" * 64)
    ParseCache(folder)
    kept = sorted(set(p.name for p in folder.iterdir()) - set(left))
    assert kept == sorted(n for n in version_b if n.startswith("ffffffffffff-"))
    assert len(kept) == 3 * 2
