"""`wbpower energy` and `wbpower lifetime` end to end: JSON contract, hand values, errors, -o.

Expected numbers are worked out by hand here (see tests/test_energy.py and test_lifetime.py
for the derivations); rtol=1e-12 absorbs float rounding through JSON (repr round-trips).
"""

from __future__ import annotations

import json
from dataclasses import replace

import pandas as pd
import pytest
from numpy.testing import assert_allclose
from typer.testing import CliRunner

from wifibot_power.cli import app
from wifibot_power.model import paper_model
from wifibot_power.outputs import write_json

RTOL = 1e-12
ENERGY_KEYS = {
    "speed_mps",
    "distance_m",
    "steps",
    "energy_J",
    "time_s",
    "one_step_energy_J",
    "overhead_pct",
}
LIFETIME_KEYS = {
    "rate_mbps",
    "e0a_J",
    "e0b_J",
    "distance_m",
    "speed_mps",
    "lifetime_s",
    "baseline_s",
    "improvement_pct",
    "first_to_die",
}


def run(*args: str):
    return CliRunner().invoke(app, list(args))


def run_json(*args: str):
    result = run(*args, "--json")
    assert result.exit_code == 0, result.stderr
    return json.loads(result.stdout)


@pytest.mark.parametrize("command", ["energy", "lifetime"])
def test_help(command):
    result = run(command, "--help")
    assert result.exit_code == 0
    assert "--json" in result.stdout and "--model" in result.stdout


def test_energy_reference_command():
    # E_step = 35.74*1 + 32.86*(1 - 0.4)/0.8 = 60.385 J; 10 steps; one step 430.06 J
    out = run_json(
        "energy", "--speed", "0.8", "--dist", "10", "--steps", "10", "--model", "paper",
        "--t-acc", "1",
    )  # fmt: skip
    assert ENERGY_KEYS <= set(out)
    assert (out["speed_mps"], out["distance_m"], out["steps"]) == (0.8, 10.0, 10)
    assert_allclose(out["energy_J"], 603.85, rtol=RTOL)
    assert_allclose(out["time_s"], 10 * (1 + 0.75), rtol=RTOL)
    assert_allclose(out["one_step_energy_J"], 430.06, rtol=RTOL)
    assert_allclose(out["overhead_pct"], 100 * (603.85 / 430.06 - 1), rtol=RTOL)
    assert [p["phase"] for p in out["phases"]] == ["accel", "cruise"]


def test_energy_table_shows_phases_and_triangular_note():
    result = run("energy", "--speed", "0.8", "--dist", "2", "--steps", "10", "--t-acc", "1")
    assert result.exit_code == 0
    assert "accel" in result.stdout and "cruise" in result.stdout
    assert "triangular" in result.stdout


def test_energy_speed_sweep_json_and_parquet(tmp_path):
    out = run_json("energy", "--sweep", "speed", "--t-acc", "1", "-o", str(tmp_path))
    assert out["sweep"] == "speed" and len(out["rows"]) == 18
    assert all(ENERGY_KEYS <= set(row) for row in out["rows"])
    frame = pd.read_parquet(tmp_path / "energy_sweep_speed.parquet")
    assert len(frame) == 18 and ENERGY_KEYS <= set(frame.columns)


def test_energy_reads_a_model_file_with_extensions(tmp_path):
    # start_transient of 5 J per step on the reference trip: 603.85 + 10*5
    # A fitted model carries finite R² (the paper model's NaN R² does not survive JSON, see
    # the report on model.py), so give the fits one, as 'wbpower fit -o' would.
    paper = paper_model()
    model = replace(
        paper,
        accel=replace(paper.accel, r2=0.99),
        cruise=replace(paper.cruise, r2=0.99),
        t_acc=replace(paper.t_acc, r2=0.99),
    ).with_extensions({"start_transient": {"E_start_J": 5.0}}, source="test")
    path = write_json(tmp_path / "model.json", model.to_json())
    out = run_json(
        "energy", "--speed", "0.8", "--dist", "10", "--steps", "10", "--model", str(path),
        "--t-acc", "1",
    )  # fmt: skip
    assert_allclose(out["energy_J"], 603.85 + 50.0, rtol=RTOL)
    assert out["extensions"] == ["start_transient"]


def test_lifetime_reference_command():
    # P_A_high 34.5 W, P_A_low 33.42 W; B's trip 1 + 9.55/0.9 s; A dies first
    out = run_json("lifetime", "--rate", "100", "--model", "paper", "--t-acc", "1")
    assert LIFETIME_KEYS <= set(out)
    t_travel = 1 + 9.55 / 0.9
    e_a_switch = 480e3 - 34.5 * t_travel
    lifetime = t_travel + e_a_switch / 33.42
    assert (out["rate_mbps"], out["e0a_J"], out["e0b_J"]) == (100.0, 480e3, 480e3)
    assert (out["distance_m"], out["speed_mps"], out["first_to_die"]) == (10.0, 0.9, "A")
    assert_allclose(out["baseline_s"], 480e3 / 34.5, rtol=RTOL)
    assert_allclose(out["lifetime_s"], lifetime, rtol=RTOL)
    assert_allclose(out["improvement_pct"], 100 * (lifetime / (480e3 / 34.5) - 1), rtol=1e-9)


@pytest.mark.parametrize(("sweep", "n_rows"), [("e0a", 10), ("e0b", 13), ("dist", 10), ("rate", 3)])
def test_lifetime_sweeps(tmp_path, sweep, n_rows):
    args = ["lifetime", "--sweep", sweep, "--t-acc", "1", "-o", str(tmp_path)]
    if sweep != "rate":
        args += ["--rate", "54"]
    out = run_json(*args)
    assert out["sweep"] == sweep and len(out["rows"]) == n_rows
    assert all(LIFETIME_KEYS <= set(row) for row in out["rows"])
    frame = pd.read_parquet(tmp_path / f"lifetime_sweep_{sweep}.parquet")
    assert len(frame) == n_rows and LIFETIME_KEYS <= set(frame.columns)


def test_lifetime_table():
    # --wide: headers whole on one line (a pipe is 80 columns: "gain" / "%" otherwise)
    args = ("--rate", "54", "--embedded-scale", "0.5", "--e0b", "2e5", "--wide")
    result = run("lifetime", *args)
    assert result.exit_code == 0 and "gain %" in result.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["lifetime", "--rate", "11"], "Table 2"),
        (["lifetime"], "--rate"),
        (["lifetime", "--rate", "10", "--sweep", "speed"], "sweep"),
        (["energy", "--speed", "0.5"], "--dist"),
        (["energy", "--speed", "0", "--dist", "2"], "speed"),
        (["energy", "--speed", "0.5", "--dist", "2", "--steps", "0"], "steps"),
        (["energy", "--sweep", "dist"], "sweep"),
        (["energy", "--speed", "0.5", "--dist", "2", "--model", "missing.json"], "missing.json"),
    ],
)
def test_bad_input_is_one_line_exit_2(args, message):
    result = run(*args)
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wbpower: error:") and message in lines[0]
