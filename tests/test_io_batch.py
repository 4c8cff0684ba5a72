"""Batches through every log-reading command: good files processed, each bad one listed
(stderr and JSON `skipped`), exit 1; and `map_runs` never stops at one bad file."""

from __future__ import annotations

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
    for name in ("a", "b", "c"):
        (tmp_path / f"{name}.csv").write_text(f"# run_id: {name}\npower_W\n23.3\n23.4\n")

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
