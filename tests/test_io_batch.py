"""Batches through every log-reading command: good files processed, each bad one listed
(stderr and JSON `skipped`), exit 1; and `map_runs` never stops at one bad file."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import pytest

from wifibot_power.errors import LogError
from wifibot_power.io import ReadOptions
from wifibot_power.io.batch import map_runs

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
GOOD = [
    "v0.30_d2_s1_r1",
    "v0.30_d2_s1_r2",
    "v0.60_d2_s1_r1",
    "v0.60_d2_s1_r2",
    "v0.90_d2_s1_r1",
    "v0.90_d2_s1_r2",
    "idle_r1",
]


@pytest.fixture
def mixed_folder(tmp_path) -> tuple[Path, list[str]]:
    """Seven good sample logs, two bad logs and a manifest row for a missing file."""
    if not all((SAMPLE_LOGS / f"{name}.csv.gz").is_file() for name in GOOD):
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    for name in GOOD:
        shutil.copy(SAMPLE_LOGS / f"{name}.csv.gz", tmp_path)
    shutil.copy(SAMPLE_LOGS / "runs.csv", tmp_path)  # rows for the files copied, and others
    rows = (tmp_path / "runs.csv").read_text().splitlines()
    kept = [rows[0]] + [r for r in rows[1:] if r.split(",")[0].removesuffix(".csv.gz") in GOOD]
    kept.append("gone.csv,gone,motion,0.5,2,1,0,")
    (tmp_path / "runs.csv").write_text("\n".join(kept) + "\n")
    (tmp_path / "nan.csv").write_text("# mode: idle\ntime_s,power_W\n0,23.3\n0.0001024,nan\n")
    (tmp_path / "garbage.csv").write_bytes(bytes(range(256)))
    bad = [str(tmp_path / n) for n in ("gone.csv", "nan.csv", "garbage.csv")]
    return tmp_path, bad


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_batch_commands_keep_good_files_and_list_bad_ones(mixed_folder, wbpower, command):
    folder, bad = mixed_folder
    result = wbpower(command, "--json", folder)
    assert result.exit_code == 1, result.stderr
    report = json.loads(result.stdout)
    assert report["n_runs"] >= 6  # the motion runs (and idle, for fit) were all used
    assert sorted(s["file"] for s in report["skipped"]) == sorted(bad)
    skipped_lines = [ln for ln in result.stderr.splitlines() if ln.startswith("wbpower: skipped:")]
    assert len(skipped_lines) == 3
    assert any("runs.csv: line" in ln and "'gone.csv'" in ln for ln in skipped_lines)


def test_map_runs_lists_an_unexpected_failure_and_goes_on(tmp_path):
    for k, name in enumerate(("a", "b", "c")):  # other samples each: not one log thrice
        (tmp_path / f"{name}.csv").write_text(f"# run_id: {name}\npower_W\n23.3\n23.{4 + k}\n")

    def work(run):
        if run.meta.run_id == "b":
            raise ZeroDivisionError("a bug in a later stage")
        return run.meta.run_id

    results, skipped = map_runs([tmp_path], ReadOptions(), work)
    assert results == ["a", "c"]
    (only,) = skipped
    assert only.file == str(tmp_path / "b.csv")
    assert "internal error: ZeroDivisionError: a bug in a later stage" in only.reason


def test_single_file_failure_raises_for_exit_2(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("")
    with pytest.raises(LogError, match="the file is empty"):
        map_runs([path], ReadOptions(), lambda run: run)


# -- problems found while reading (short gaps): said by every batch command -------------------

GAP_LOG = "v0.30_d2_s1_r1"
DROPPED_ROWS = slice(5000, 5003)  # 3 rows of the 1.024 ms sample log: a 3.072 ms gap


@pytest.fixture
def folder_with_a_gap(tmp_path) -> tuple[Path, Path, str]:
    """The good sample logs, one rewritten with a time column and 3 rows dropped. Returns the
    folder, the gap log and the warning every command must print for it (worked out here)."""
    if not all((SAMPLE_LOGS / f"{name}.csv.gz").is_file() for name in GOOD):
        pytest.skip("sample_logs/ is not there (made by 'make sample-logs')")
    for name in GOOD:
        if name != GAP_LOG:
            shutil.copy(SAMPLE_LOGS / f"{name}.csv.gz", tmp_path)
    lines = gzip.decompress((SAMPLE_LOGS / f"{GAP_LOG}.csv.gz").read_bytes()).decode().splitlines()
    metadata = [ln for ln in lines if ln.startswith("#")]
    power_W = [ln for ln in lines if not ln.startswith("#")][1:]  # below the power_W header
    period_s = 0.001024
    rows = [f"{k * period_s:.7f},{p}" for k, p in enumerate(power_W)]
    del rows[DROPPED_ROWS]
    path = tmp_path / f"{GAP_LOG}.csv"
    path.write_text("\n".join([*metadata, "time_s,power_W", *rows]) + "\n")
    # the header is line len(metadata) + 1; row k (after the cut) is on line len(metadata) + 2 + k.
    # The row after the gap is row 5000, its time 5003 x 1.024 ms; the one before, 4999 x 1.024 ms.
    line = len(metadata) + 2 + 5000
    warning = (
        f"wbpower: warning: {path}: line {line}: 3.072 ms of samples dropped after "
        f"t = {4999 * period_s:.6g} s"
    )
    return tmp_path, path, warning


def test_map_runs_hands_problems_to_the_calling_process(folder_with_a_gap):
    folder, gap_log, _ = folder_with_a_gap
    said: list[tuple[str, tuple]] = []
    for jobs in (1, 2):  # 2: read in forked workers, said here
        said.clear()
        results, skipped = map_runs(
            [folder],
            ReadOptions(),
            lambda run: run.meta.run_id,
            jobs=jobs,
            on_problems=lambda file, problems: said.append((file, problems)),
        )
        assert len(results) == len(GOOD) and not skipped
        ((file, (gap,)),) = said
        assert file == str(gap_log)
        assert gap.kind == "gap"
        assert gap.duration_s == pytest.approx(3 * 0.001024, rel=1e-9)  # 3 dropped samples


def test_library_batches_pass_problems_to_their_caller(folder_with_a_gap):
    import wifibot_power as wb

    folder, gap_log, _ = folder_with_a_gap
    said: list[str] = []
    wb.fit_logs([folder], on_problems=lambda file, problems: said.append(file))
    wb.fit_logs([folder])  # no hook: nobody is told, nothing fails
    assert said == [str(gap_log)]


@pytest.mark.parametrize(
    "args",
    [
        ("fit", "--jobs", "1"),
        ("fit", "--jobs", "2"),
        ("diagnose",),
        ("segment",),  # one file: the gap log itself
        ("inspect",),  # already said it; must still say it once
    ],
)
def test_every_command_warns_about_reading_problems(folder_with_a_gap, wbpower, args):
    folder, gap_log, warning = folder_with_a_gap
    target = gap_log if args[0] == "segment" else folder
    result = wbpower(*args, target)
    assert result.exit_code == 0, result.stderr
    warnings = [ln for ln in result.stderr.splitlines() if ln.startswith("wbpower: warning:")]
    assert warnings.count(warning) == 1, result.stderr
    assert all(str(gap_log) in ln for ln in warnings if "samples dropped" in ln)


def test_fit_from_the_cache_still_warns(folder_with_a_gap, wbpower, tmp_path_factory):
    folder, _, warning = folder_with_a_gap
    cache = tmp_path_factory.mktemp("cache")
    for _ in range(2):  # filling the cache, then every result taken from it
        result = wbpower("fit", "--cache", cache, folder)
        assert result.exit_code == 0, result.stderr
        assert result.stderr.splitlines().count(warning) == 1, result.stderr


def test_reasons_in_brief_counts_each_reason_and_names_its_first_file():
    from wifibot_power.io.discover import Skipped, reasons_in_brief

    skipped = [
        Skipped("a.csv", "a.csv: bad header"),
        Skipped("b.csv", "b.csv: no distance"),
        Skipped("c.csv", "c.csv: no distance"),
        Skipped("d.csv", "odd"),  # a reason that does not start with its file stays whole
        Skipped("e.csv", "e.csv: too short"),
    ]
    assert reasons_in_brief(skipped) == (
        "2 x no distance (first: b.csv); 1 x bad header (first: a.csv); 2 for 2 other reasons"
    )
    assert reasons_in_brief(skipped[:4]).endswith("; 1 for 1 other reason")
    assert reasons_in_brief(skipped, most=5).endswith("1 x too short (first: e.csv)")
    assert "1 x odd (first: d.csv)" in reasons_in_brief(skipped, most=5)
