"""The same log given twice in one batch (a copy, a renamed copy, the .csv and its .csv.gz)
is analysed once, with a warning naming both files (log-format.md "Bad input"; issue 12:
the same run as .csv, .csv.gz and a renamed copy was fitted as three runs)."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import pytest

from wifibot_power.cache import ParseCache
from wifibot_power.fit import fit_logs
from wifibot_power.io import ReadOptions
from wifibot_power.io.batch import map_runs

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
    assert [Path(row["file"]).name for row in json.loads(cli.stdout)] == ["v0.60_d2_s1_r1.csv"]
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
        assert len(json.loads(cli.stdout)) == 1
    else:
        assert json.loads(cli.stdout)["cruise"]["n_runs"] == 6


def test_different_runs_are_not_duplicates(folder: Path) -> None:
    # same metadata, other samples: two runs
    text = (folder / "v0.30_d2_s1_r1.csv").read_text()
    other = text.replace("\n23.3", "\n23.4", 1)
    assert other != text
    (folder / "edited.csv").write_text(other)
    files = [folder / "v0.30_d2_s1_r1.csv", folder / "edited.csv"]
    runs, skipped = map_runs(files, ReadOptions(), lambda run: run.file)
    assert len(runs) == 2 and not skipped


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
        assert without[0]["meta"]["mode"] == "unknown"
        assert found[0]["run_id"] == "from_manifest" and found[0]["meta"]["speed_mps"] == 0.6
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
