"""The share of a window moving (`drive_on_W`'s regressor) and the |x| of a window that does
not turn (drive/windows.py `motion_bins`, drive/regressors.py `_window_abs`, `window_gain`;
docs/drive-model.md, "Validation")."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.drive.moving import motion_bins
from wifibot_power.drive.regressors import _window_abs, sample_gain, window_gain
from wifibot_power.drive.simulate import FreeRun, as_run
from wifibot_power.drive.stats import drive_stats
from wifibot_power.drive.windows import run_windows


def test_motion_follows_a_confirmed_stretch_down_to_its_leave_threshold():
    nan = np.nan
    values = np.array(
        # a start (0.5, 1.2 below 3, then beyond), a stop (2.0, 0.6 below 1), a reversal
        # (-1.5 alone: never beyond 3 on its side), a bump that never reaches 3, a drop-out
        [0.0, 0.5, 1.2, 3.5, 2.0, 1.1, 0.6, -1.5, -0.4, 0.0, 1.5, 2.5, 0.0, 4.0, nan, 1.2, 0.0]
    )
    expected = np.array(
        [0, 0, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0],
        dtype=bool,
    )
    assert np.array_equal(motion_bins(values, enter=3.0, leave=1.0), expected)
    # each side of 0 on its own: the same stretch the other way round
    assert np.array_equal(motion_bins(-values, enter=3.0, leave=1.0), expected)
    # with one threshold it is the plain test beyond `enter`
    assert np.array_equal(motion_bins(values, 3.0, 3.0), np.nan_to_num(values) > 3.0)


def _start_stop_share(period_s: float, seed: int, cycles: int = 20) -> tuple[float, float]:
    """A 20-cycle log of stops and trapezoids (2 s standing, 1 m/s^2 up to 0.5 m/s, 2 s, down
    again), speed logged as the mean over each period with 1 cm/s noise in 2 cm/s encoder steps
    (the simulator's field realism) and a rate of turn of noise alone: the windows' summed share
    moving, and the same of the true speed (the time it is not 0)."""
    dt, accel, top, hold, stop = 1e-3, 1.0, 0.5, 2.0, 2.0
    ramp = top / accel
    cycle_s = stop + 2 * ramp + hold
    clock = np.arange(int(round(cycles * cycle_s / dt))) * dt - stop
    into = clock % cycle_s
    speed = np.clip(np.minimum(accel * into, accel * (2 * ramp + hold - into)), 0.0, top)
    per = int(round(period_s / dt))
    count = speed.size // per
    logged = speed[: count * per].reshape(count, per).mean(axis=1)
    rng = np.random.default_rng(seed)
    logged = np.round((logged + 0.01 * rng.standard_normal(count)) / 0.02) * 0.02
    yaw = 0.03 * rng.standard_normal(count)
    time_s = np.arange(count) * per * dt
    run = FreeRun("r", "asphalt", time_s, np.full(count, 12.0), logged, yaw, 0.0, 1.0)
    windows = run_windows(drive_stats(as_run(run)))
    per_window = round(windows.n * windows.stats.bin_s / dt)
    true = (speed[: windows.count * per_window].reshape(windows.count, -1) > 0).mean(axis=1)
    return float(windows.moving.sum()), float(true.sum())


@pytest.mark.parametrize("period_s", [0.05, 1 / 6.5])
def test_share_moving_counts_the_ends_of_motion(period_s):
    # 40 ends of motion: cut at 3 noise deviations (stats.py's 6.3 cm/s at 20 Hz), each end
    # lost 50-65 ms of its ramp, 3.2-4.4% of the moving time (the drivers' step left to idle:
    # idle +1.4 standard errors at 6.5 Hz on the simulator); followed to one deviation,
    # within 1.5%
    for seed in range(3):
        moving, true = _start_stop_share(period_s, seed)
        assert abs(moving - true) < 0.02 * true, (seed, moving, true)


def test_straight_windows_turn_by_zero():
    # 20 Hz, 10 minutes straight at 0.5 m/s, a gyro's white noise (5 mrad/s) around a true 0:
    # with the window's noise taken for a bin's (sqrt(10) too small), two thirds of the
    # windows were read as turning both ways and their |yaw rate| as the mean of their bins'
    # |noise| (0.0021 rad/s on the simulator), which the drivers' step paid; 0 on average
    rng = np.random.default_rng(7)
    sigma, count = 0.005, 12_000
    time_s = np.arange(count) * 0.05
    speed = np.full(count, 0.5)
    yaw = sigma * rng.standard_normal(count)
    run = FreeRun("r", "asphalt", time_s, np.full(count, 12.0), speed, yaw, 0.0, 1.0)
    windows = run_windows(drive_stats(as_run(run)))
    window_noise = sigma / np.sqrt(windows.n)
    assert abs(np.mean(windows.abs_yaw_radps)) < 0.05 * window_noise


def test_window_abs_of_a_spin_reversed():
    # a window that turns both ways is the mean of its bins' |x|, not |its mean|
    both = np.concatenate((np.full((1, 5), 0.5), np.full((1, 5), -0.5)), axis=1)
    assert_allclose(_window_abs(both, both.mean(axis=1), 0.002, 0.005), 0.5, atol=1e-4)


def test_window_gain_of_a_fast_and_a_slow_logger():
    # a fast logger's bins average their samples: 1 / (samples in the window)
    assert_allclose(window_gain(10, 1.0), 0.1)
    assert_allclose(window_gain(10, 5.0), 0.02)
    # a 6.5 Hz logger's bins interpolate between samples: the variance of 10 bins' mean of
    # white samples so interpolated (stats.py `_held`), by 200,000 samples, not 1 / 3.25
    period_s, bin_s = 1 / 6.5, 0.05
    rng = np.random.default_rng(3)
    samples = rng.standard_normal(200_000)
    middles_s = (np.arange(samples.size) + 0.5) * period_s
    centres_s = (np.arange(int(samples.size * period_s / bin_s) - 20) + 0.5) * bin_s
    bins = np.interp(centres_s, middles_s, samples)
    means = bins[: bins.size // 10 * 10].reshape(-1, 10).mean(axis=1)
    gain = window_gain(10, bin_s / period_s)
    assert_allclose(gain, np.var(means), rtol=0.02)
    assert gain < 0.9 / 3.25
    assert_allclose(gain, sample_gain(np.full(10, 0.1), np.arange(10) + 0.5, bin_s / period_s))
