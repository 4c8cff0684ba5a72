"""Reading turning (log-format.md, "Turning"): a rate-of-turn column, or two wheel speeds and a
track width, and a per-sample surface; the parse cache gives them back unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from wifibot_power.cache import ParseCache
from wifibot_power.errors import LogError
from wifibot_power.io.options import ReadOptions
from wifibot_power.io.reader import read_log

WHEELS = """# wbpower-log: 1
# surface: carpet
{track}time_s,power_W,speed_left_mps,speed_right_mps,surface
0,10,0,0,grass
0.1,12,0.2,0.4,grass
0.2,14,0.3,0.1,
0.3,15,-0.2,0.2,asphalt
"""


def _write(tmp_path, text: str, name: str = "run.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_wheel_speeds_give_speed_and_yaw_rate(tmp_path):
    run = read_log(_write(tmp_path, WHEELS.format(track="# track_m: 0.5\n")))
    # worked by hand: v = (l + r)/2, yaw = (r - l)/0.5 m
    assert_allclose(run.speed_mps, [0.0, 0.3, 0.2, 0.0], atol=1e-12)
    assert_allclose(run.yaw_rate_radps, [0.0, 0.4, -0.4, 0.8], atol=1e-12)
    assert run.surface_names == ("asphalt", "grass")
    assert_array_equal(run.surface_index, [1, 1, -1, 0])


def test_track_width_option_wins_and_is_needed(tmp_path):
    path = _write(tmp_path, WHEELS.format(track=""))
    run = read_log(path, ReadOptions(track_width_m=1.0))
    assert_allclose(run.yaw_rate_radps, [0.0, 0.2, -0.2, 0.4], atol=1e-12)
    # without a track width: the speed is the wheels' mean, the rate of turn is not read, and
    # a warning says so (not an error: logs with their own speed column, REGBOT's, have the
    # wheel pair and no track width, and read as before)
    run = read_log(path)
    assert run.yaw_rate_radps is None
    assert_allclose(run.speed_mps, [0.0, 0.3, 0.2, 0.0], atol=1e-12)
    (problem,) = [p for p in run.problems if p.kind == "turning_unread"]
    assert "--track-width" in problem.message
    with_speed = WHEELS.format(track="").replace("surface\n", "surface,speed_mps\n")
    with_speed = "\n".join(
        line + ",0.5" if line[:1].isdigit() else line for line in with_speed.splitlines()
    )
    run = read_log(_write(tmp_path, with_speed + "\n", "own.csv"))
    assert run.yaw_rate_radps is None and not run.problems
    assert_allclose(run.speed_mps, 0.5)
    bad = _write(tmp_path, WHEELS.format(track="# track_m: wide\n"), "bad.csv")
    with pytest.raises(LogError) as caught:
        read_log(bad)
    message = str(caught.value)
    assert str(bad) in message and "--track-width" in message and "\n" not in message


def test_yaw_rate_column_and_option(tmp_path):
    text = "# wbpower-log: 1\ntime_s,power_W,speed_mps,gyro_z\n0,5,0,0.1\n0.1,6,0.2,-0.3\n"
    path = _write(tmp_path, text)
    assert read_log(path).yaw_rate_radps is None  # not a name the format knows
    run = read_log(path, ReadOptions(yaw_rate_column="GYRO_Z"))
    assert_allclose(run.yaw_rate_radps, [0.1, -0.3])
    assert run.surface_index is None
    with pytest.raises(LogError, match="--yaw-rate-column"):
        read_log(path, ReadOptions(yaw_rate_column="nope"))


def test_yaw_rate_in_degrees_is_refused(tmp_path):
    text = "# wbpower-log: 1\ntime_s,power_W,yaw_rate_radps\n0,5,0\n0.1,6,90\n"
    with pytest.raises(LogError, match="rad/s"):
        read_log(_write(tmp_path, text))


def test_cache_round_trips_turning(tmp_path):
    path = _write(tmp_path, WHEELS.format(track="# track_m: 0.5\n"))
    cache = ParseCache(tmp_path / "cache")
    first = cache.read_log(path)
    again = cache.read_log(path)  # from the entry written by the first read
    assert (tmp_path / "cache").exists() and any((tmp_path / "cache").rglob("*.parquet"))
    assert_array_equal(again.yaw_rate_radps, first.yaw_rate_radps)
    assert_array_equal(again.speed_mps, first.speed_mps)
    assert_array_equal(again.surface_index, first.surface_index)
    assert again.surface_names == first.surface_names
    plain = _write(tmp_path, "# wbpower-log: 1\ntime_s,power_W\n0,1\n0.1,2\n", "plain.csv")
    cache.read_log(plain)
    kept = cache.read_log(plain)
    assert kept.yaw_rate_radps is None and kept.surface_index is None
    assert np.isfinite(kept.power_W).all()
