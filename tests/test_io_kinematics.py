"""What a log's motion columns cannot be (io/kinematics.py), said, read as logged:
- a rate of turn in deg/s under a rad/s header that stays under the absurd-rate check's 30
  (io/validate.py), through the lateral acceleration it makes with the speed, |v·ω|,
  sustained beyond what tyres hold;
- a speed sampled slower than every 2 s: a time column in ms read as seconds (every duration
  and energy 1000x too large), which the fit does not see."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from wifibot_power.io import ReadOptions, read_log
from wifibot_power.io.kinematics import (
    LATERAL_LIMIT_MPS2,
    SLOW_SPEED_S,
    WINDOW_S,
    lateral_problem,
    slow_speed_problem,
)

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
    # reversing, or turning right (w < 0) going forward, is as much sideways (|v w|)
    assert lateral_problem(-speed, -yaw, period_s, lambda i: i, ("v", "w")) is not None
    assert lateral_problem(speed, -yaw, period_s, lambda i: i, ("v", "w")) is not None
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


def _timed(tmp_path, step: float, *, speed: bool = True, name: str = "timed.csv"):
    """A log of 200 rows `step` apart in its time_s column (a 20 Hz log's steps in ms: 50)."""
    rows = [f"{k * step:g},20,{0.5 if 50 < k < 150 else 0}" for k in range(200)]
    header = "time_s,power_W,speed_mps" if speed else "time_s,power_W,other"
    path = tmp_path / name
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _slow(run):
    return [p for p in run.problems if p.kind == "slow_speed"]


def test_a_time_column_in_ms_is_said_and_the_fix_reads_it(tmp_path):
    path = _timed(tmp_path, 50.0)
    run = read_log(path)
    (said,) = _slow(run)
    assert "sampled every 50 s (time column 'time_s')" in said.message
    assert "1000x" in said.message and "--time-unit ms" in said.message
    # what it says to do reads it right, and says nothing more
    fixed = read_log(path, ReadOptions(time_unit="ms"))
    assert fixed.sample_period_s == pytest.approx(0.05) and _slow(fixed) == []
    assert fixed.duration_s == pytest.approx(run.duration_s / 1000)


def test_a_speed_sampled_within_the_bound_or_no_speed_says_nothing(tmp_path):
    assert SLOW_SPEED_S == 2.0
    assert _slow(read_log(_timed(tmp_path, 1.0, name="gps_1hz.csv"))) == []  # a 1 Hz GPS
    assert _slow(read_log(_timed(tmp_path, 2.0, name="at_bound.csv"))) == []
    assert len(_slow(read_log(_timed(tmp_path, 2.5, name="over.csv")))) == 1
    # a power-only log sampled slowly is a battery monitor, not a drive: nothing to judge
    assert _slow(read_log(_timed(tmp_path, 50.0, speed=False, name="monitor.csv"))) == []


def test_a_sample_period_in_ms_is_said_without_a_time_column(tmp_path):
    path = tmp_path / "no_time.csv"
    rows = "\n".join(f"20,{0.5 if 50 < k < 150 else 0}" for k in range(200))
    path.write_text("# sample_period_s: 50\npower_W,speed_mps\n" + rows + "\n")
    (said,) = _slow(read_log(path))
    assert "(sample_period_s)" in said.message and "give it in s" in said.message
    assert slow_speed_problem(0.05, "time_s") is None


def test_a_rate_from_wheel_speeds_is_not_judged(tmp_path):
    """Its scale is the track width's (a wrong track is not a deg/s column): the same arc as
    `_log`'s in deg/s, made from wheel speeds over a track 57x too small, says nothing."""
    rows = [f"{k / RATE_HZ:.2f},40,{2 - 0.04:.4f},{2 + 0.04:.4f}" for k in range(400)]
    head = "# track_m: 0.0035\ntime_s,power_W,speed_left_mps,speed_right_mps\n"
    path = tmp_path / "wheels.csv"
    path.write_text(head + "\n".join(rows) + "\n")
    run = read_log(path)
    assert float(np.max(run.speed_mps * run.yaw_rate_radps)) > 40  # over 3 g, were it judged
    assert _said(run) == []


def test_a_time_column_read_in_ms_is_not_told_to_be_read_in_ms(tmp_path):
    path = tmp_path / "ms.csv"
    rows = [f"{k * 2500},20,{0.5 if 50 < k < 150 else 0}" for k in range(200)]
    path.write_text("time_ms,power_W,speed_mps\n" + "\n".join(rows) + "\n")
    (said,) = _slow(read_log(path))
    assert "read in units of 0.001 s" in said.message and "give --time-unit" in said.message
    assert "--time-unit ms" not in said.message
