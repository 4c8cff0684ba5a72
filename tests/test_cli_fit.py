"""`wbpower fit` as a user meets it: JSON contract, exit codes, -o files, errors in one line.

The segmenter is replaced by the simulator's truth phases here (monkeypatched), so these
tests check the command, not segmentation accuracy (tests/test_fit.py does the fit).
"""

from __future__ import annotations

import json

import pandas as pd
import pytest
from contract import RUNS_PARQUET_COLUMNS
from typer.testing import CliRunner

from wifibot_power.cli import app
from wifibot_power.model import load_model
from wifibot_power.phases import Phase, Segmentation
from wifibot_power.simulate import SimConfig, load_truth, write_simulation

runner = CliRunner()

SMALL = dict(
    speeds_mps=(0.3, 0.6, 0.9),
    trips=((2.0, 1), (3.0, 2)),
    repeats=1,
    mode_repeats=2,
    mode_duration_s=2.0,
    sample_period_s=0.01,
    idle_before_s=1.0,
    idle_between_s=1.0,
    idle_after_s=1.0,
    seed=21,
)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli_fit")
    write_simulation(SimConfig(**SMALL), out)
    return out


@pytest.fixture
def truth_segments(logs, monkeypatch):
    """Segment every run by the simulator's truth.json phases."""
    truth = {r["run_id"]: r for r in load_truth(logs / "truth.json")["runs"]}

    def segment(run):
        dt = run.sample_period_s
        phases = []
        for p in truth[run.meta.run_id]["phases"]:
            i0, i1 = round(p["t_start_s"] / dt), round(p["t_end_s"] / dt)
            mean = float(run.power_W[i0:i1].mean())
            phases.append(
                Phase(p["step"], p["phase"], i0, i1, i0 * dt, i1 * dt, mean, mean * (i1 - i0) * dt)
            )
        return Segmentation(run.meta.run_id, tuple(phases))

    monkeypatch.setattr("wifibot_power.segment.segment_run", segment)  # the default segmenter
    return truth


def invoke(*args):
    return runner.invoke(app, ["fit", *map(str, args)])


def test_help():
    result = invoke("--help")
    assert result.exit_code == 0 and "least squares" in result.output


def test_json_contract_and_exit_0(logs, truth_segments):
    result = invoke(logs, "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)  # stdout holds one JSON document and nothing else
    assert summary["n_runs"] == len(truth_segments) == 14
    for part, (intercept, slope) in {"accel": (23.9, 14.8), "cruise": (23.9, 11.2)}.items():
        fit = summary[part]
        assert set(fit) >= {"intercept_W", "slope_W_per_mps", "intercept_ci95", "slope_ci95", "r2"}
        # issue 3 done-when tolerances (intercepts 0.3 W; slopes 0.8 / 0.4 W/(m/s))
        assert abs(fit["intercept_W"] - intercept) <= 0.3
        assert abs(fit["slope_W_per_mps"] - slope) <= (0.8 if part == "accel" else 0.4)
        assert len(fit["intercept_ci95"]) == 2 and len(fit["slope_ci95"]) == 2
    assert abs(summary["idle_W"] - 23.3) <= 0.1
    assert set(summary["components_W"]) == {"network", "video", "cpu"}
    assert summary["skipped"] == []


def test_table_shows_paper_values_and_silent_stderr(logs, truth_segments):
    result = invoke(logs, "--wide")  # headers whole on one line (a pipe is 80 columns)
    assert result.exit_code == 0
    for text in ("P_acc slope", "14.8", "P_v intercept", "23.9", "network", "4.4", "n runs"):
        assert text in result.stdout
    assert result.stderr == ""  # no progress bar when stderr is not a terminal


def test_markdown_prints_every_table(logs, truth_segments):
    """Every table fit prints (it printed the paper's alone, issue 28), each as Markdown
    under its bold title; the paper's table as the library's `to_markdown` writes it."""
    from wifibot_power.fit import fit_logs

    result = invoke(logs, "--markdown", "--runs")
    assert result.exit_code == 0
    text = result.stdout
    assert "┃" not in text and "│" not in text  # no rich table
    titles = [line for line in text.splitlines() if line.startswith("**")]
    plain = invoke(logs, "--runs", "--wide").stdout  # the same tables, drawn
    tables = [line for line in plain.splitlines() if line.startswith("┏")]
    assert len(titles) == len(tables) >= 3, (titles, plain)
    for title in titles:
        assert title.strip("*") in " ".join(plain.split()), title
    paper = fit_logs([logs]).to_markdown().splitlines()
    start = text.splitlines().index(paper[0])
    assert text.splitlines()[start : start + len(paper)] == paper
    for block in text.split("**")[2::2]:  # each table: a header, its alignment row, rows
        rows = [line for line in block.splitlines() if line.startswith("| ")]
        assert len(rows) >= 3 and set(rows[1]) <= set("| -:"), block
        assert len({row.count(" | ") for row in rows}) == 1, block  # one column count


def test_out_dir_writes_tables_and_a_model_that_loads(logs, truth_segments, tmp_path):
    result = invoke(logs, "-o", tmp_path / "out", "--json")
    assert result.exit_code == 0, result.output
    out = tmp_path / "out"
    runs = pd.read_parquet(out / "runs.parquet")
    assert RUNS_PARQUET_COLUMNS <= set(runs.columns)
    assert len(runs) == 14
    phases = pd.read_parquet(out / "phases.parquet")
    assert set(phases["run_id"]) == set(truth_segments)
    # a phase names its log too: two runs of one run_id would still be told apart
    assert list(phases.columns[:2]) == ["run_id", "file"]
    pairs = set(zip(phases["run_id"], phases["file"], strict=True))
    assert pairs == set(zip(runs["run_id"], runs["file"], strict=True))
    model = load_model(out / "model.json")
    summary = json.loads(result.stdout)
    assert model.accel.slope == summary["accel"]["slope_W_per_mps"]
    assert json.loads((out / "model.json").read_text())["format_version"] == 1


def test_skipped_inputs_give_exit_1_and_are_listed(logs, truth_segments, tmp_path):
    folder = tmp_path / "logs"
    folder.mkdir()
    for path in logs.glob("*.csv"):
        (folder / path.name).write_bytes(path.read_bytes())
    (folder / "broken.csv").write_text("time_s,power_W\n0.0,abc\n")
    result = invoke(folder, "--json")
    assert result.exit_code == 1
    summary = json.loads(result.stdout)
    assert [s["file"] for s in summary["skipped"]] == [str(folder / "broken.csv")]
    assert "skipped" in result.stderr and "broken.csv" in result.stderr
    assert summary["n_runs"] == 14


def test_single_unreadable_file_is_exit_2_in_one_line(tmp_path, truth_segments):
    bad = tmp_path / "bad.csv"
    bad.write_text("")
    result = invoke(bad)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.csv" in lines[0] and "Traceback" not in result.output


def test_no_usable_run_is_exit_2(tmp_path, truth_segments):
    # a log with no mode or speed: readable, but nothing to fit
    log = tmp_path / "level.csv"
    log.write_text("time_s,power_W\n" + "".join(f"{i * 0.01:.2f},25.0\n" for i in range(50)))
    result = invoke(log)
    assert result.exit_code == 2
    assert "no usable run" in result.stderr and "level.csv" in result.stderr


def test_a_log_turning_without_a_speed_column_is_told_the_drive_model_needs_one(tmp_path):
    # yaw_rate_radps but no speed_mps and no metadata: neither model can use it; the reason
    # says what the drive model lacks, a log without a turning column keeps its old reason
    turn, level = tmp_path / "turn.csv", tmp_path / "level.csv"
    turning = (f"{i * 0.01:.2f},{25 + 5 * (i > 100)},{0.5 * (i > 100)}\n" for i in range(300))
    turn.write_text("time_s,power_W,yaw_rate_radps\n" + "".join(turning))
    level.write_text("time_s,power_W\n" + "".join(f"{i * 0.01:.2f},25.0\n" for i in range(300)))
    result = invoke(turn, level, "--json")
    assert result.exit_code == 2, result.output
    reasons = {s["file"]: s["reason"] for s in json.loads(result.stdout)["skipped"]}
    paper = (
        "no mode or speed in its metadata, so it cannot be fitted "
        "(add mode/speed_mps/distance_m/steps to the file's '#' lines or to runs.csv)"
    )
    assert reasons[str(level)] == f"{level}: {paper}"
    assert reasons[str(turn)] == (
        f"{turn}: {paper}; the drive model needs a speed column (speed_mps, or two wheel "
        "speeds) besides the rate of turn"
    )
