"""The drive model's per-run statistics as the workers compute them (drive/stats.py): the
noise of a speed column with missing samples, and a slow logger's bins with their surfaces.

Expected values are worked out by hand from the samples built here."""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.stats import BIN_S, _median, _median_between, _sample_noise, drive_stats
from wifibot_power.run import Run, RunMeta


def test_sample_noise_leaves_out_the_steps_next_to_a_missing_sample():
    # steps 1, (nan, nan), 0.5, 2, 0.5: the median of |1, 0.5, 2, 0.5| is 0.75
    values = np.array([0.0, 1.0, np.nan, 3.0, 3.5, 1.5, 2.0])
    assert _sample_noise(values) == 0.75 / 0.6745 / np.sqrt(2.0)
    assert _sample_noise(np.array([1.0, np.nan, np.nan])) == 0.0  # no step at all
    values = np.array([0.0, 2.0, 2.5, 2.5])  # steps 2, 0.5, 0: median 0.5, all finite
    assert _sample_noise(values) == 0.5 / 0.6745 / np.sqrt(2.0)


def test_a_slow_loggers_bins_take_the_surface_and_power_of_the_sample_they_fall_in():
    # 10 Hz (twice a bin): 10 samples, the last 4 on "grass" (a surface column), power 10 W
    # then 20 W from sample 5 on; bin k's centre (k + 0.5) x 50 ms falls in sample k // 2
    period_s = 0.1
    t = np.arange(10) * period_s
    power_W = np.where(np.arange(10) >= 5, 20.0, 10.0)
    meta = RunMeta(run_id="slow", sample_period_s=period_s)
    surface_index = np.array([0] * 6 + [1] * 4, dtype=np.int16)
    run = Run(
        "slow.csv", "wbpower-csv", meta, t, power_W, speed_mps=0 * t,
        surface_index=surface_index, surface_names=("asphalt", "grass"),
    )  # fmt: skip
    stats = drive_stats(run)
    assert stats.bins == round(10 * period_s / BIN_S) == 20
    assert stats.surfaces[:2] == ("asphalt", "grass")
    expected_surface = [0] * 12 + [1] * 8  # bins 12-19: samples 6-9
    assert stats.surface_index.tolist() == expected_surface
    # power interpolated between the middles of the sample periods (0.05 s + 0.1 s k): bins
    # 0-8 (centres up to 0.425 s, before the middle of sample 4 at 0.45 s) hold 10 W
    assert np.all(stats.power_W[:9] == 10.0)
    assert np.all(stats.power_W[11:] == 20.0)  # centres from 0.575 s: after sample 5's middle


def test_the_median_by_counting_is_the_median():
    # 130 steps, 60 of 0 then 70 of 0.02 (a quantized speed): the middle values (ranks 64 and
    # 65) are both 0.02; every 64th value (indices 0, 64, 128: 0, 0.02, 0.02) guesses 0.02
    steps = np.array([0.0] * 60 + [0.02] * 70)
    assert _median(steps.copy()) == 0.02
    assert _median(steps[::-1].copy()) == 0.02
    # 70 zeros and 60 of 0.02, zeros at every even index: every 64th is 0, the median
    alternating = np.where(np.arange(130) % 2 == 0, 0.0, 0.02)
    alternating[np.flatnonzero(alternating == 0.02)[:5]] = 0.0
    assert _median(alternating.copy()) == 0.0
    # a guess below the median: zeros where every 64th value looks (60 zeros, 70 of 0.02):
    # too many values above it, so not taken; the median is 0.02
    guessed_low = np.full(130, 0.02)
    guessed_low[[0, 64, 128]] = 0.0
    guessed_low[1:58] = 0.0
    assert _median(guessed_low.copy()) == 0.02
    # a guess above it: 0.02 where every 64th looks (60 of 0.02, 70 zeros): the median is 0
    guessed_high = np.zeros(130)
    guessed_high[[0, 64, 128]] = 0.02
    guessed_high[1:58] = 0.02
    assert _median(guessed_high.copy()) == 0.0
    # continuous values (none repeats): the sort, as np.median
    rng = np.random.default_rng(3)
    for size in (2, 3, 64, 65, 1001, 72_000):
        values = np.abs(rng.normal(size=size))
        assert _median(values.copy()) == np.median(values)


def test_bin_means_are_each_bins_mean_with_empty_bins_nan():
    """`_bin_means` sums each bin's stretch of samples: the same means as a weighted count
    over every sample (up to the order of summation), NaN where a bin has none (a drop-out),
    zeros for a missing column."""
    from wifibot_power.drive.stats import _bin_means

    rng = np.random.default_rng(3)
    which = np.sort(rng.integers(0, 400, 20_000))
    which = which[(which < 100) | (which > 120)]  # 21 empty bins in the middle
    n_bins = 420  # and 19 empty at the end
    power = 25 + rng.standard_normal(which.size)
    speed = rng.random(which.size)
    starts = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    got_power, got_speed, got_yaw = _bin_means(which, starts, n_bins, power, speed, None)
    count = np.bincount(which, minlength=n_bins).astype(float)
    with np.errstate(invalid="ignore"):
        for got, values in ((got_power, power), (got_speed, speed)):
            expected = np.bincount(which, weights=values, minlength=n_bins) / count
            np.testing.assert_allclose(got, expected, rtol=1e-13)  # NaN where expected is
    assert np.isnan(got_power[count == 0]).all() and np.isfinite(got_power[count > 0]).all()
    assert not got_yaw.any() and got_yaw.size == n_bins


def test_the_median_between_bounds_is_the_median():
    """`_median`'s second way (`_median_between`: the values between two of the sample's
    ranks, partitioned): np.median's value exactly, whether the bounds hold the middle ranks
    (continuous values) or miss them (a sample unlike the whole: the whole's partition)."""
    rng = np.random.default_rng(7)
    for size in (6_401, 6_400, 72_000, 72_001):
        values = np.abs(rng.normal(size=size))
        assert _median_between(values.copy(), values[::64].copy()) == np.median(values)
        assert _median(values.copy()) == np.median(values)
    # a sample from the lower half only: its bounds miss the middle ranks
    values = np.abs(rng.normal(size=10_000))
    low_sample = np.sort(values)[:2_000:10].copy()
    assert _median_between(values.copy(), low_sample) == np.median(values)
    # the bounds are used: the values between them alone give the median (a sample whose
    # bounds hold it, and ties at the bounds)
    steps = np.round(np.abs(rng.normal(size=20_001)), 2)
    assert _median_between(steps.copy(), steps[::64].copy()) == np.median(steps)
