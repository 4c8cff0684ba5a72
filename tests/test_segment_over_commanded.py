"""A step run's speed column far over its commanded (maximum) `speed_mps` is doubted
(segment/kinematic.py `_over_commanded`): a column in km/h or mph under a speed_mps header
makes every phase's speed, and the paper's lines fitted over them, that much off."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wifibot_power.io import read_log
from wifibot_power.segment import segment_run
from wifibot_power.segment.kinematic import OVER_COMMANDED


def _step_log(tmp_path, scale: float, name: str = "step.csv"):
    """A 1 m/s step run (idle, ramp up 1 s, cruise, ramp down, idle) at 100 Hz, its speed
    column times `scale`."""
    time_s = np.arange(0, 12, 0.01)
    speed = np.clip(np.minimum(time_s - 2, 9 - time_s), 0, 1)
    power = 20 + 10 * speed
    rows = [
        f"{t:.2f},{p:.3f},{v * scale:.4f}" for t, p, v in zip(time_s, power, speed, strict=True)
    ]
    head = "# mode: motion\n# speed_mps: 1.0\n# distance_m: 5\ntime_s,power_W,speed_mps\n"
    path = tmp_path / name
    path.write_text(head + "\n".join(rows) + "\n")
    return path


def _doubted(path) -> list[str]:
    return [d for d in segment_run(read_log(path)).doubts if "commanded" in d]


def test_a_column_in_km_h_is_doubted(tmp_path):
    (said,) = _doubted(_step_log(tmp_path, 3.6))
    assert "3.6x the commanded (maximum) speed_mps 1" in said and "km/h" in said


@pytest.mark.parametrize("scale", [1.0, 1.4])
def test_a_speed_at_or_a_little_over_the_commanded_is_not(tmp_path, scale):
    assert OVER_COMMANDED == 1.5
    assert _doubted(_step_log(tmp_path, scale)) == []


def test_mph_is_doubted_and_fit_leaves_the_run_out(tmp_path, wbpower):
    _step_log(tmp_path, 2.23694, "mph.csv")
    (said,) = _doubted(tmp_path / "mph.csv")
    assert "2.2x" in said
    document = json.loads(wbpower("fit", tmp_path, "--json").stdout)
    # the paper's fit leaves it out, saying why (the drive model still takes it: a warning)
    assert document["n_runs"] == 0
    said = " ".join(document["warnings"])
    assert "2.2x the commanded" in said and "--keep-doubtful" in said
