"""The drive model's per-run statistics as the workers compute them (drive/stats.py): the
noise of a speed column with missing samples, and a slow logger's bins with their surfaces.

Expected values are worked out by hand from the samples built here."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

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
    count_of = np.diff(np.r_[starts, which.size]).astype(float)
    got_power, got_speed, got_yaw = _bin_means(
        which[starts], starts, count_of, n_bins, power, speed, None
    )
    count = np.bincount(which, minlength=n_bins).astype(float)
    with np.errstate(invalid="ignore"):
        for got, values in ((got_power, power), (got_speed, speed)):
            expected = np.bincount(which, weights=values, minlength=n_bins) / count
            np.testing.assert_allclose(got, expected, rtol=1e-13)  # NaN where expected is
    assert np.isnan(got_power[count == 0]).all() and np.isfinite(got_power[count > 0]).all()
    assert not got_yaw.any() and got_yaw.size == n_bins


def _per_sample_starts(run, n_bins):
    """The reference: every sample's bin (`_bin_of` over `time_s - time_s[0]`) and where it
    changes."""
    from wifibot_power.drive.stats import _bin_of

    which = _bin_of(run.time_s - run.time_s[0], n_bins)
    starts = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    return which[starts], starts


def _fast_run(samples, period_s, stamps_s=None):
    meta = RunMeta(run_id="r", sample_period_s=period_s)
    return Run(file="r.csv", format="csv", meta=meta, stamps_s=stamps_s, power_W=np.ones(samples))


def _assert_settled_per_bin(run):
    """The bins found per bin are the per-sample bins, without the fallback."""
    from wifibot_power.drive.stats import _starts_per_bin

    n_bins = _bins_of(run)
    found = _starts_per_bin(run, n_bins)
    assert found is not None  # settled per bin (not by the fallback)
    present, starts = found
    expected_present, expected_starts = _per_sample_starts(run, n_bins)
    np.testing.assert_array_equal(starts, expected_starts)
    np.testing.assert_array_equal(present, expected_present)


def _bins_of(run):
    span_s = run.time_at(-1) + run.sample_period_s - run.time_at(0)
    return max(int(np.floor(span_s / BIN_S + 1e-9)), 1)


@settings(max_examples=300, deadline=None)
@given(
    samples=st.integers(1, 40_000),
    period_s=st.one_of(
        st.sampled_from([1e-4, 1.024e-4, 2e-4, 1e-3, 0.01, 0.0125, 0.005, 1 / 3000, 1 / 80]),
        st.floats(1e-5, 0.0125),
    ),
)
def test_bin_starts_without_a_time_column_are_the_per_sample_bins(samples, period_s):
    """A log without a time column: each bin's first sample found per bin is where the
    per-sample bins (`_bin_of` over `arange(n) * period`, as `Run.time_s` makes the axis)
    change, for any length and period of the fast-logger path (a period a whole fraction of
    the bin included: a sample on a bin's edge belongs to the bin it starts)."""
    run = _fast_run(samples, period_s)
    _assert_settled_per_bin(run)


@settings(max_examples=200, deadline=None)
@given(
    samples=st.integers(2, 30_000),
    period_s=st.sampled_from([1e-4, 1.024e-4, 1e-3, 0.005, 0.0125]),
    jitter=st.floats(0.0, 0.45),
    seed=st.integers(0, 2**32 - 1),
    start_s=st.sampled_from([0.0, 1234.5678, 1.7e9]),
)
def test_bin_starts_of_stamps_are_the_per_sample_bins(samples, period_s, jitter, seed, start_s):
    """Stamps that go forwards, jittered, with drop-outs (empty bins), some on a bin's edge
    exactly, from 0 or from an epoch: the bins found per bin (a binary search of the stamps
    and four samples around it) are the per-sample bins."""
    rng = np.random.default_rng(seed)
    step_s = period_s * (1 + jitter * rng.uniform(-1, 1, samples - 1))
    gaps = rng.random(samples - 1) < 0.001
    step_s[gaps] += rng.uniform(0.05, 0.5, int(gaps.sum()))  # drop-outs: bins without a sample
    stamps_s = start_s + np.r_[0.0, np.cumsum(step_s)]
    on_edge = rng.random(samples) < 0.01  # some stamps put on a bin's edge
    stamps_s[on_edge] = start_s + np.round((stamps_s[on_edge] - start_s) / BIN_S) * BIN_S
    stamps_s = np.maximum.accumulate(stamps_s)
    stamps_s = stamps_s[np.r_[True, np.diff(stamps_s) > 0]]  # strictly forwards (the reader's)
    run = _fast_run(stamps_s.size, period_s, stamps_s)
    _assert_settled_per_bin(run)


def test_bin_starts_fall_back_to_every_samples_bin_when_a_check_fails(monkeypatch):
    """Should the per-bin search not settle a start (its check fails), every sample's bin is
    found instead: the same answer."""
    from wifibot_power.drive import stats

    run = _fast_run(20_001, 1e-4)
    n_bins = _bins_of(run)
    monkeypatch.setattr(stats, "_bin_at", lambda run, index, n_bins: np.zeros(index.size, int))
    present, starts = stats._bin_starts(run, n_bins)
    expected_present, expected_starts = _per_sample_starts(run, n_bins)
    np.testing.assert_array_equal(starts, expected_starts)
    np.testing.assert_array_equal(present, expected_present)


def test_drive_stats_of_a_stampless_log_equal_the_stamped_ones():
    """The same 10 kHz samples with and without their time column (the axis index x period):
    the same bins, to the bit (the arithmetic starts and the per-sample bins agree), and a
    surface column's bins are each bin's first sample's."""
    rng = np.random.default_rng(5)
    samples, period_s = 123_457, 1e-4
    stamps_s = np.arange(samples, dtype=np.float64)
    stamps_s *= period_s
    power = 25 + rng.standard_normal(samples)
    speed = np.abs(np.sin(np.arange(samples) / 5000.0))
    surface = (np.arange(samples) % 3 == 1).astype(np.int16)  # a bin start on either

    def run(stamps):
        meta = RunMeta(run_id="r", sample_period_s=period_s)
        return Run(
            file="r.csv",
            format="csv",
            meta=meta,
            stamps_s=stamps,
            power_W=power,
            speed_mps=speed,
            surface_index=surface,
            surface_names=("a", "b"),
        )

    even, stamped = drive_stats(run(None)), drive_stats(run(stamps_s))
    for name in ("power_W", "speed_mps", "yaw_rate_radps", "surface_index"):
        assert getattr(even, name).tobytes() == getattr(stamped, name).tobytes(), name
    first = np.arange(even.bins) * 500  # 500 samples a bin
    np.testing.assert_array_equal(even.surface_index, surface[first])


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
