"""A rate of turn in deg/s under a rad/s header that stays under the absurd-rate check's 30
(io/validate.py) is said through the lateral acceleration it makes with the speed, |v·ω|,
sustained beyond what tyres hold (io/lateral.py): read as logged, never quietly."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from wifibot_power.io import read_log
from wifibot_power.io.lateral import LATERAL_LIMIT_MPS2, WINDOW_S, lateral_problem

RATE_HZ = 20.0
#: an arc at 2 m/s turning at 0.4 rad/s (0.8 m/s^2): in deg/s 22.9, under the absurd 30
SPEED_MPS, TURN_RADPS = 2.0, 0.4


def _log(tmp_path, yaw_scale: float, glitch: float | None = None, name: str = "arc.csv"):
    n = int(20 * RATE_HZ)
    time_s = np.arange(n) / RATE_HZ
    moving = (time_s > 2) & (time_s < 18)
    speed = np.where(moving, SPEED_MPS, 0.0)
    yaw = np.where(moving, TURN_RADPS, 0.0) * yaw_scale
    if glitch is not None:
        yaw = np.zeros(n)
        yaw[n // 2] = glitch  # one sample
    power = 20.0 + 10.0 * speed
    rows = [
        f"{t:.2f},{p:.2f},{v:.3f},{w:.4f}"
        for t, p, v, w in zip(time_s, power, speed, yaw, strict=True)
    ]
    path = tmp_path / name
    path.write_text("time_s,power_W,speed_mps,yaw_rate_radps\n" + "\n".join(rows) + "\n")
    return path


def _said(run):
    return [p for p in run.problems if p.kind == "lateral"]


def test_deg_per_s_under_the_absurd_limit_is_said(tmp_path):
    run = read_log(_log(tmp_path, math.degrees(1.0)))
    assert run.yaw_rate_radps.max() < 30  # the absurd-rate check does not see it
    (said,) = _said(run)
    # 2 m/s x 22.9 "rad/s" = 45.8 m/s^2 (4.7 g), from the arc's first sample (2.05 s: line 43)
    assert "45.8 m/s^2" in said.message and "4.7 g" in said.message
    assert said.message.startswith("line 43:")
    assert "deg/s" in said.message and "speed_mps x yaw_rate_radps" in said.message


def test_rad_per_s_and_a_one_sample_glitch_say_nothing(tmp_path):
    assert _said(read_log(_log(tmp_path, 1.0))) == []
    # a gyro glitch of 25 rad/s at 2 m/s is 50 m/s^2 for one sample: 5 over the 0.5 s window
    glitch = read_log(_log(tmp_path, 1.0, glitch=25.0, name="glitch.csv"))
    assert glitch.yaw_rate_radps.max() == 25.0 and _said(glitch) == []


def test_the_bound_is_the_window_mean_over_3_g():
    period_s = 1 / RATE_HZ
    width = int(WINDOW_S / period_s)
    speed = np.full(100, 1.0)
    yaw = np.zeros(100)
    yaw[40 : 40 + width] = LATERAL_LIMIT_MPS2  # exactly at the bound over one window
    assert lateral_problem(speed, yaw, period_s, lambda i: i, ("v", "w")) is None
    yaw[40 : 40 + width] *= 1.01
    said = lateral_problem(speed, yaw, period_s, lambda i: i, ("v", "w"))
    assert said is not None and said.message.startswith("line 40:")
    assert "reaches 29.7 m/s^2 (3 g)" in said.message
    # one window less a sample over the bound is under it on average
    yaw[40] = 0.0
    yaw[40 + width - 1] = 0.0
    yaw[41 : 40 + width - 1] = LATERAL_LIMIT_MPS2 * width / (width - 2) * 0.999
    assert lateral_problem(speed, yaw, period_s, lambda i: i, ("v", "w")) is None
    # unknown samples count as none: an unknown speed before a turn over the bound leaves
    # the turn said (a NaN summed would hide every window after it)
    assert lateral_problem(np.full(100, np.nan), yaw, period_s, lambda i: i, ("v", "w")) is None
    speed[5] = np.nan
    yaw[60:90] = 2 * LATERAL_LIMIT_MPS2
    said = lateral_problem(speed, yaw, period_s, lambda i: i, ("v", "w"))
    assert said is not None and said.message.startswith("line 60:")


@pytest.mark.parametrize("command", ["fit", "inspect"])
def test_the_commands_say_it(tmp_path, wbpower, command):
    path = _log(tmp_path, math.degrees(1.0))
    document = json.loads(wbpower(command, path, "--json").stdout)
    text = json.dumps(document)
    assert "no tyre holds" in text and "deg/s" in text
