"""`wbpower simulate --drive free`: canonical logs with speed, rate of turn and surface that the
reader reads back, runs.csv, and truth.json with the true terms."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from wifibot_power.cli import app
from wifibot_power.drive import fit_drive
from wifibot_power.drive.simulate import FreeDriveConfig, simulate_free
from wifibot_power.io.reader import read_log


def test_free_drive_logs_read_back(tmp_path):
    out = tmp_path / "free"
    result = CliRunner().invoke(
        app,
        [
            "simulate", "-o", str(out), "--drive", "free", "--realism", "field",
            "--repeats", "3", "--duration", "60", "--seed", "2", "--json",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["runs"] == 6
    truth = json.loads((out / "truth.json").read_text())
    assert truth["surfaces"]["grass"]["turning_Nm"] == 60.0 and truth["lag_s"] == 0.2
    manifest = (out / "runs.csv").read_text().splitlines()
    assert len(manifest) == 7 and manifest[0].startswith("file,run_id,mode")
    runs = [read_log(out / row["file"]) for row in truth["runs"]]
    assert all(r.yaw_rate_radps is not None and r.speed_mps is not None for r in runs)
    assert {r.meta.extra["surface"] for r in runs} == {"asphalt", "grass"}
    # the field logger: 20 Hz with drop-outs (gaps in the time stamps)
    steps = np.concatenate([np.diff(r.time_s) for r in runs])
    assert abs(np.median(steps) - 0.05) < 1e-9 and steps.max() > 0.09
    # the logs as written give the model the in-memory runs give (values rounded to 0.1 mW)
    model = fit_drive(runs)
    config = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=2)
    memory = fit_drive([_as_run(r) for r in simulate_free(config)])
    for name, term in memory.terms.items():
        assert abs(model.terms[name].value - term.value) < 0.05 * abs(term.value) + 0.05


def _as_run(free):
    from wifibot_power.drive.simulate import as_run

    return as_run(free)


def test_unknown_surface_and_realism_are_usage_errors(tmp_path):
    runner = CliRunner()
    bad = runner.invoke(app, ["simulate", "-o", str(tmp_path / "a"), "--drive", "free",
                              "--surfaces", "lava"])  # fmt: skip
    assert bad.exit_code == 2 and "lava" not in (tmp_path / "a").as_posix()
    bad = runner.invoke(app, ["simulate", "-o", str(tmp_path / "b"), "--drive", "free",
                              "--realism", "moon"])  # fmt: skip
    assert bad.exit_code == 2


def test_drop_outs_never_join_into_a_gap_the_reader_refuses():
    # drop-outs are 1 or 2 samples; two side by side would make a gap of more than 3 sample
    # periods, which the reader refuses (32 of make bench's 200 one-hour field runs were).
    # At 200 drop-outs a minute on 20 Hz logs, pairs are drawn often: none is made.
    config = FreeDriveConfig(
        runs_per_surface=2, run_s=120.0, seed=3, realism_overrides={"dropouts_per_min": 200.0}
    )
    for run in simulate_free(config):
        steps = np.diff(run.time_s)
        assert steps.max() <= 3 * 0.05 + 1e-9, steps.max()
        assert (steps > 0.06).sum() > 100  # the drop-outs are there
