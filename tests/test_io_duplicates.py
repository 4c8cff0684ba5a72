"""The same log given twice in one batch (a copy, a renamed copy, the .csv and its .csv.gz)
is analysed once, with a warning naming both files (log-format.md "Bad input"; issue 12:
the same run as .csv, .csv.gz and a renamed copy was fitted as three runs)."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from wifibot_power.cache import ParseCache
from wifibot_power.fit import fit_logs
from wifibot_power.io import ReadOptions, read_log
from wifibot_power.io.discover import LogSource
from wifibot_power.pipeline import duplicates
from wifibot_power.pipeline.batch import map_runs
from wifibot_power.pipeline.duplicates import (
    batch_fingerprint,
    duplicate_keys,
    run_fingerprint,
    run_identity,
)
from wifibot_power.run import Run, RunMeta

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
#: six motion runs at three speeds and an idle log: enough for fit to fit both lines
RUNS = [
    "v0.30_d2_s1_r1",
    "v0.30_d2_s1_r2",
    "v0.60_d2_s1_r1",
    "v0.60_d2_s1_r2",
    "v0.90_d2_s1_r1",
    "v0.90_d2_s1_r2",
    "idle_r1",
]


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """The runs as plain .csv with their manifest, plus v0.60_d2_s1_r1 twice more: as its
    .csv.gz, and as a renamed copy (which the manifest does not name)."""
    if not all((SAMPLE_LOGS / f"{name}.csv.gz").is_file() for name in RUNS):
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    logs = tmp_path / "logs"
    logs.mkdir()
    rows = (SAMPLE_LOGS / "runs.csv").read_text().splitlines()
    kept = [rows[0]]
    for name in RUNS:
        text = gzip.decompress((SAMPLE_LOGS / f"{name}.csv.gz").read_bytes())
        (logs / f"{name}.csv").write_bytes(text)
        kept += [r.replace(".csv.gz", ".csv") for r in rows[1:] if r.startswith(f"{name}.csv")]
    (logs / "runs.csv").write_text("\n".join(kept) + "\n")
    shutil.copy(SAMPLE_LOGS / "v0.60_d2_s1_r1.csv.gz", logs / "v0.60_d2_s1_r1.csv.gz")
    shutil.copy(logs / "v0.60_d2_s1_r1.csv", logs / "copy of run.csv")
    return logs


def test_reproduction_fit_counts_a_run_given_three_times_once(folder: Path, wbpower) -> None:
    heard: list[tuple[str, str]] = []
    result = fit_logs([folder], on_problems=lambda f, ps: heard.extend((f, p.kind) for p in ps))
    # 6 motion runs at 3 speeds: each line is fitted on 6 runs, not 8
    assert result.summary()["accel"]["n_runs"] == 6
    assert result.summary()["cruise"]["n_runs"] == 6
    # the first of the three in the batch's (sorted) order is kept
    duplicates = sorted(Path(f).name for f, kind in heard if kind == "duplicate")
    assert duplicates == ["v0.60_d2_s1_r1.csv", "v0.60_d2_s1_r1.csv.gz"]
    cli = wbpower("fit", "--json", "--jobs", "2", folder)
    assert cli.exit_code == 0, cli.stderr  # a duplicate is a warning, not a skipped input
    assert json.loads(cli.stdout)["cruise"]["n_runs"] == 6
    warnings = [line for line in cli.stderr.splitlines() if "the same samples as" in line]
    assert len(warnings) == 2
    first = str(folder / "copy of run.csv")
    assert all(line.count(first) == 2 for line in warnings)  # it is named in each warning
    for other in ("v0.60_d2_s1_r1.csv:", "v0.60_d2_s1_r1.csv.gz:"):  # and so is the other
        assert sum(other in line for line in warnings) == 1


def test_inspect_lists_a_duplicate_once(folder: Path, wbpower) -> None:
    cli = wbpower("inspect", "--json", folder / "v0.60_d2_s1_r1.csv", folder / "copy of run.csv")
    assert cli.exit_code == 0, cli.stderr
    assert [Path(row["file"]).name for row in json.loads(cli.stdout)["logs"]] == [
        "v0.60_d2_s1_r1.csv"
    ]
    assert "warning" in cli.stderr and "copy of run.csv" in cli.stderr


@pytest.mark.parametrize("command", ["inspect", "fit"])
def test_a_file_named_twice_is_read_once_with_a_warning(folder: Path, wbpower, command) -> None:
    """The same path twice (or a file and its folder) was dropped silently; log-format.md
    asks for a warning."""
    log = folder / "v0.30_d2_s1_r1.csv"  # a run the folder holds no copy of
    args = [log, log] if command == "inspect" else [folder, log]
    cli = wbpower(command, "--json", *args)
    assert cli.exit_code == 0, cli.stderr
    assert f"{log}: given twice in this batch: analysed once" in cli.stderr
    if command == "inspect":
        assert len(json.loads(cli.stdout)["logs"]) == 1
    else:
        assert json.loads(cli.stdout)["cruise"]["n_runs"] == 6


def _renamed(text: str, run_id: str) -> str:
    """The log with `run_id` in its metadata: another run may not claim its original's
    run_id (test_io_run_ids.py)."""
    (line,) = [ln for ln in text.splitlines() if ln.startswith("# run_id: ")]
    return text.replace(line, f"# run_id: {run_id}", 1)


def test_different_runs_are_not_duplicates(folder: Path) -> None:
    # same metadata but the run_id, other samples: two runs
    text = (folder / "v0.30_d2_s1_r1.csv").read_text()
    other = _renamed(text.replace("\n23.3", "\n23.4", 1), "edited")
    assert other.count("\n23.4") == text.count("\n23.4") + 1
    (folder / "edited.csv").write_text(other)
    files = [folder / "v0.30_d2_s1_r1.csv", folder / "edited.csv"]
    runs, skipped = map_runs(files, ReadOptions(), lambda run: run.file)
    assert len(runs) == 2 and not skipped


def _swapped(text: str) -> str:
    """The log with the power readings of two data lines of different values swapped: the
    same readings in another order (a different run), so the same `run_fingerprint`."""
    lines = text.splitlines(keepends=True)
    data = [k for k, line in enumerate(lines) if line[:1].isdigit()]
    first = data[len(data) // 2]
    second = next(k for k in data[len(data) // 2 :] if lines[k] != lines[first])
    lines[first], lines[second] = lines[second], lines[first]
    return "".join(lines)


@pytest.mark.parametrize("cached", [False, True])
def test_same_fingerprint_other_samples_are_not_duplicates(
    folder: Path, tmp_path: Path, cached: bool
) -> None:
    """Two logs whose cheap fingerprints are equal but whose samples differ (two readings
    swapped: equal sums and xor of the bits) are two runs: the fingerprint only says which
    logs to compare in full."""
    original = folder / "v0.60_d2_s1_r1.csv"  # power_W alone: a line is one reading
    swapped = folder / "swapped.csv"
    swapped.write_text(_renamed(_swapped(original.read_text()), "swapped"))
    runs = [read_log(f, ReadOptions()) for f in (original, swapped)]
    assert not np.array_equal(runs[0].power_W, runs[1].power_W)
    assert run_fingerprint(runs[0]) == run_fingerprint(runs[1])  # the case this test is for
    assert run_identity(runs[0]) != run_identity(runs[1])
    cache = ParseCache(tmp_path / "cache") if cached else None
    heard: list[str] = []
    found, skipped = map_runs(
        [original, swapped, original.with_suffix(".csv.gz")],
        ReadOptions(),
        lambda run: run.file,
        cache=cache,
        on_problems=lambda f, ps: heard.extend(p.kind for p in ps),
    )
    assert not skipped
    assert found == [str(original), str(swapped)]  # the .csv.gz is the copy of the first
    # the swapped log shares nearly all its samples with the first: kept, said to overlap
    assert heard == ["overlap", "duplicate"]


def test_only_logs_sharing_a_fingerprint_are_digested(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The SHA-256 of the samples (~1.7 ms for 330 k samples; the fingerprint ~0.04 ms) is
    computed for the logs whose fingerprints are equal, and for no other."""
    digested: list[int] = []

    def counting(run):
        digested.append(run.samples)
        return original_identity(run)

    original_identity = duplicates.run_identity
    monkeypatch.setattr(duplicates, "run_identity", counting)
    distinct = [folder / f"{name}.csv" for name in RUNS]
    found, _ = map_runs(distinct, ReadOptions(), lambda run: run.file)
    assert len(found) == len(RUNS) and digested == []
    pair = [folder / "v0.60_d2_s1_r1.csv", folder / "v0.60_d2_s1_r1.csv.gz"]
    found, _ = map_runs([*distinct, pair[1]], ReadOptions(), lambda run: run.file)
    assert len(found) == len(RUNS) and len(digested) == 2


def test_logs_changed_or_gone_before_their_comparison_are_not_duplicates(folder: Path) -> None:
    """Logs whose fingerprints matched when analysed are compared by reading them again:
    one that cannot be read again, or whose samples changed meanwhile (here both were other
    samples when analysed, and are now the same), is not called a copy."""
    first, copy = folder / "v0.60_d2_s1_r1.csv", folder / "copy of run.csv"
    fingerprint = batch_fingerprint(read_log(first, ReadOptions()))
    sources = [LogSource(first), LogSource(copy)]

    def keys(analysed_as: str) -> list[str | None]:
        outcomes = [(True, ((), analysed_as, None))] * 2
        return duplicate_keys(sources, outcomes, ReadOptions(), 1, None)

    same = keys(fingerprint)
    assert same[0] == same[1] and same[0].startswith("identity ")
    changed = keys(batch_fingerprint(read_log(folder / "v0.30_d2_s1_r1.csv", ReadOptions())))
    assert changed[0] != changed[1]
    copy.unlink()  # gone
    gone = keys(fingerprint)
    assert gone[0] == same[0] and gone[1] != gone[0]
    first.unlink()  # both gone
    assert len(set(keys(fingerprint))) == 2


def test_fingerprint_reads_every_bit_the_identity_reads() -> None:
    """Equal identities give equal fingerprints (same bits), and a change anywhere in power,
    speed, or the time axis's ends or length changes the fingerprint."""
    rng = np.random.default_rng(7)
    power = rng.normal(23.3, 0.1, 1000)
    speed = rng.normal(0.3, 0.01, 1000)
    time = np.arange(1000) * 1e-3

    def run(t=time, p=power, v=speed) -> Run:
        return Run("x.csv", "canonical", RunMeta("x"), t, p, speed_mps=v)

    base = run_fingerprint(run())
    assert run_fingerprint(run(p=power.copy(), v=speed.copy())) == base
    flipped = power.copy()
    flipped[500] = np.nextafter(flipped[500], np.inf)  # one sample, one ulp
    slower = speed.copy()
    slower[999] = np.nextafter(slower[999], 0.0)
    later = time + 1e-3
    assert (
        len(
            {
                base,
                run_fingerprint(run(p=flipped)),
                run_fingerprint(run(v=slower)),
                run_fingerprint(run(t=later)),
                run_fingerprint(run(v=None)),
                run_fingerprint(run(t=time[:-1], p=power[:-1], v=speed[:-1])),
            }
        )
        == 6
    )


def test_duplicates_found_from_the_cache_too(folder: Path, tmp_path: Path) -> None:
    """A warm cache keeps each run's identity with its kept result: still analysed once."""
    cache = ParseCache(tmp_path / "cache")
    for _ in range(2):  # cold, then warm
        heard: list[str] = []
        result = fit_logs([folder], cache=cache, on_problems=lambda f, ps, h=heard: h.append(f))
        assert result.summary()["cruise"]["n_runs"] == 6
        assert sorted(Path(f).name for f in heard if "v0.60_d2_s1_r1" in f) == [
            "v0.60_d2_s1_r1.csv",
            "v0.60_d2_s1_r1.csv.gz",
        ]


# -- a single file reads the runs.csv beside it (log-format.md, section 3) ---------------------


@pytest.mark.parametrize("command", ["inspect", "segment"])
def test_single_file_commands_read_the_manifest_beside_it(tmp_path: Path, wbpower, command):
    """A log without metadata lines: only the runs.csv beside it says it is a motion run at
    0.6 m/s (issue 12: `segment FILE` ignored it and segmented steady levels)."""
    if not (SAMPLE_LOGS / "v0.60_d2_s1_r1.csv.gz").is_file():
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    raw = gzip.decompress((SAMPLE_LOGS / "v0.60_d2_s1_r1.csv.gz").read_bytes()).decode()
    period = next(ln for ln in raw.splitlines() if ln.startswith("# sample_period_s"))
    bare = "\n".join([period] + [ln for ln in raw.splitlines() if not ln.startswith("#")])
    log = tmp_path / "bare.csv"
    log.write_text(bare + "\n")
    without = json.loads(wbpower(command, "--json", log).stdout)
    (tmp_path / "runs.csv").write_text(
        "file,run_id,mode,speed_mps,distance_m,steps\nbare.csv,from_manifest,motion,0.6,2,1\n"
    )
    result = wbpower(command, "--json", log)
    assert result.exit_code == 0, result.stderr
    found = json.loads(result.stdout)
    if command == "inspect":
        (without,), (found,) = without["logs"], found["logs"]
        assert without["meta"]["mode"] == "unknown"
        assert found["run_id"] == "from_manifest" and found["meta"]["speed_mps"] == 0.6
    else:
        assert {p["phase"] for p in without["phases"]} == {"level"}
        assert found["run_id"] == "from_manifest"
        assert {"accel", "cruise"} <= {p["phase"] for p in found["phases"]}


def test_segment_reads_a_single_file_whatever_its_name(tmp_path: Path, wbpower) -> None:
    log = tmp_path / "run.txt"  # not named like a log: still read when named alone
    log.write_text(
        "# mode: idle\ntime_s,power_W\n" + "".join(f"{k / 100},23.{k % 7}\n" for k in range(50))
    )
    result = wbpower("segment", "--json", log)
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["phases"]
