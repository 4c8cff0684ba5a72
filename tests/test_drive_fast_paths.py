"""The drive model's faster ways to the same numbers (drivefast3 lane): each against the way it
replaced, written out here, bit for bit (docs/benchmarks.md, the drive shape)."""

from __future__ import annotations

import numpy as np

from wifibot_power.drive import drive_stats
from wifibot_power.drive.moving import motion_bins, trip_numbers
from wifibot_power.drive.regressors import (
    CLIP_DEVIATIONS,
    CLIP_ROUNDS,
    _row_extremes,
    gradient,
    row_means,
    row_shares,
    running_sums,
    sample_gain,
    speed_noise_per_sample,
)
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import BIN_S, GAP_FACTOR, _gap_bins, _sample_at_centres
from wifibot_power.drive.sums import _any_per_row, run_sums
from wifibot_power.drive.terms import TERMS
from wifibot_power.drive.windows import (
    REGRESSOR_OF,
    _finite,
    regressor_rows,
    run_windows,
)


def _field_windows(seed: int = 4):
    """Simulated free driving at field realism (drop-outs included) as each run's windows."""
    config = FreeDriveConfig(runs_per_surface=2, run_s=60.0, seed=seed)
    return [run_windows(drive_stats(as_run(r))) for r in simulate_free(config)]


def _gathered(rw, lags: np.ndarray, windows: np.ndarray) -> np.ndarray:
    """`power_at_lags` as it was: an index per window and lag into the span means."""
    means = rw._span_means
    start = (windows * rw.n)[:, None] + lags[None, :]
    out = means[np.minimum(start, means.size - 1)]
    out[start >= means.size] = np.nan
    return out


def test_power_at_lags_from_rows_of_spans_is_the_gathered_power() -> None:
    """Consecutive lags read each window's row of span means from a strided view: the same
    values, NaN past the run's end and over a drop-out, as one index per window and lag."""
    runs = _field_windows()
    assert any(np.isnan(rw.stats.power_W).any() for rw in runs)  # drop-outs are there
    for rw in runs:
        every = np.arange(rw.count)
        for lags in (np.arange(21), np.arange(3, 9), np.array([0]), np.array([7])):
            got = rw.power_at_lags(lags, every)
            assert np.array_equal(got, _gathered(rw, lags, every), equal_nan=True)
            assert np.isnan(got[-1, -1]) or lags[-1] < rw.n  # the last window runs out
        some = every[::3]
        got = rw.power_at_lags(np.arange(21), some)
        assert np.array_equal(got, _gathered(rw, np.arange(21), some), equal_nan=True)
        # not consecutive: the index per window and lag, as before
        odd = np.array([0, 2, 5])
        assert np.array_equal(
            rw.power_at_lags(odd, every), _gathered(rw, odd, every), equal_nan=True
        )
        # written into a given array (a block of a wider matrix, as run_sums does)
        for lags in (np.arange(21), odd):
            wide = np.zeros((some.size, lags.size + 3))
            got = rw.power_at_lags(lags, some, out=wide[:, 3:])
            assert np.shares_memory(got, wide) and (wide[:, :3] == 0).all()
            assert np.array_equal(wide[:, 3:], _gathered(rw, lags, some), equal_nan=True)


def test_row_extremes_are_max_and_min_of_each_row() -> None:
    rng = np.random.default_rng(2)
    bins = rng.normal(size=(500, 10))
    bins[[3, 70], [4, 9]] = np.nan  # a drop-out: the row's extremes are NaN
    bins[200, 0] = np.nan
    high, low = _row_extremes(bins)
    assert np.array_equal(high, bins.max(axis=1), equal_nan=True)
    assert np.array_equal(low, bins.min(axis=1), equal_nan=True)
    assert np.isnan(high[[3, 70, 200]]).all() and np.isnan(low[[3, 70, 200]]).all()
    one = bins[:, :1]
    assert np.array_equal(_row_extremes(one)[0], one[:, 0], equal_nan=True)


def test_run_sums_design_is_the_assembled_design() -> None:
    """`run_sums` writes each window's regressors straight into its sums' matrix: its edge rows
    and its per-trip X'X are those of `regressor_rows` (the design as `assemble` makes it)."""
    for rw in _field_windows(seed=9):
        sums = run_sums(rw)
        rows = regressor_rows([rw], rw.stats.surfaces)
        edge = sums.edge_x.shape[0]
        assert edge  # some windows have a power at some lags only
        # the edge windows are the assembled rows whose power is not defined at every lag
        defined = np.isfinite(rw.power_at_lags(np.arange(sums.lags))).all(axis=1)[rw.ok]
        assert np.array_equal(sums.edge_x, rows.design[~defined])
        assert np.array_equal(sums.edge_r, rows.design_rate[~defined])
        assert np.array_equal(sums.edge_trip, rows.trip[~defined])
        assert np.array_equal(sums.edge_surface, rows.surface[~defined])
        X, trip = rows.design[defined], rows.trip[defined]
        p = X.shape[1]
        for t in np.unique(trip)[:5]:
            Xt = X[trip == t]
            np.testing.assert_allclose(sums.ww[t][:p, :p], Xt.T @ Xt, rtol=1e-12, atol=1e-9)


def test_design_columns_are_the_stacked_blocks() -> None:
    """`fill_design` (the design written column by column) against the design as it was made:
    each term's block stacked side by side, idle 1 (its rate 0), a per-surface term's
    regressor on its surface's column (one-hot times the regressor)."""
    runs = _field_windows(seed=3)
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    rows = regressor_rows(runs, surfaces)
    ok = np.concatenate([rw.ok for rw in runs])
    one_hot = rows.surface[:, None] == np.arange(len(surfaces))[None, :]

    def block(term, rate: bool) -> np.ndarray:
        name = REGRESSOR_OF[term.name]
        if name is None:
            return np.full((rows.size, 1), 0.0 if rate else 1.0)
        source = [rw.rates[name] if rate else rw.regressors()[name] for rw in runs]
        values = np.nan_to_num(np.concatenate(source)[ok])[:, None]
        return one_hot * values if term.per_surface else values

    for rate, made in ((False, rows.design), (True, rows.design_rate)):
        assert np.array_equal(made, np.hstack([block(term, rate) for term in TERMS]))
    assert (rows.design[:, 0] == 1).all() and (rows.design_rate[:, 0] == 0).all()


def test_the_noise_estimate_stops_clipping_once_nothing_moves() -> None:
    """`speed_noise_per_sample` stops its clipping rounds when a round keeps the values the
    last kept: the estimate of all `CLIP_ROUNDS` rounds, bit for bit (white noise, a few
    corners, a quantized speed; and values that keep shrinking round after round)."""
    rng = np.random.default_rng(11)
    white = rng.normal(0, 0.01, 20_000)
    corners = np.cumsum(rng.normal(0, 0.01, 20_000))
    corners[::500] += 2.0
    quantized = np.round(np.repeat(np.linspace(0, 1, 400), 50) + rng.normal(0, 0.01, 20_000), 2)
    heavy = rng.standard_cauchy(20_000)  # something is left out at every round
    holes = corners.copy()
    holes[rng.random(20_000) < 0.01] = np.nan  # (a bag's speed without a recent message)
    for speed in (white, corners, quantized, heavy, holes):
        for samples_per_bin in (1.0, 0.3):
            lag = 1 if samples_per_bin >= 1.0 else round(1.0 / samples_per_bin)
            second = speed[2 * lag :] - 2.0 * speed[lag:-lag] + speed[: -2 * lag]
            square = np.square(second[np.isfinite(second)])
            gain = sample_gain(
                np.array([1.0, -2.0, 1.0]), np.array([0.0, lag, 2.0 * lag]), samples_per_bin
            )
            mean_square = float(np.mean(square))
            for _ in range(CLIP_ROUNDS):  # every round, as before
                inside = square <= CLIP_DEVIATIONS**2 * mean_square
                mean_square = float(np.mean(square[inside])) if inside.any() else 0.0
            expected = float(np.sqrt(mean_square / gain))
            assert speed_noise_per_sample(speed, samples_per_bin) == expected


def test_the_sample_at_each_centre_is_the_binary_searchs() -> None:
    """stats.py `_sample_at_centres` (from np.interp of the sample indices) against the binary
    search it replaced: stamps on the centres themselves, just after them (an interpolated
    index a rounding below the next stamp's), jittered, with gaps, starting after the first
    centres, and centres past the last stamp."""
    rng = np.random.default_rng(5)
    rounded_up = 0
    for period_s, n_samples in ((0.05, 80_000), (0.1538, 1500), (0.0125, 9000)):
        stamps = np.arange(n_samples) * period_s
        jittered = stamps + rng.uniform(-0.3, 0.3, n_samples) * period_s * (
            rng.random(n_samples) < 0.3
        )
        jittered = np.sort(np.delete(jittered, rng.choice(n_samples, 40, replace=False)))
        on_centres = (np.arange(n_samples) + 0.5) * BIN_S
        after = np.nextafter(on_centres, np.inf)  # each centre a rounding before a stamp
        before = np.nextafter(on_centres, -np.inf)
        # many stamps early, then one a rounding after each centre: the interpolated index
        # (large) cannot hold the fraction a rounding short of 1
        dense = np.concatenate((np.arange(100_000) * 1e-6, after[2:200]))
        cases = (stamps, jittered, on_centres, after, before, stamps + 0.07, dense)
        for offset_s in cases:
            n_bins = int(offset_s[-1] / BIN_S) + 3
            centres = (np.arange(n_bins) + 0.5) * BIN_S
            expected = np.clip(
                np.searchsorted(offset_s, centres, "right") - 1, 0, offset_s.size - 1
            )
            assert np.array_equal(_sample_at_centres(offset_s, n_bins), expected)
            index = np.interp(centres, offset_s, np.arange(offset_s.size, dtype=np.float64))
            rounded_up += int(np.sum(index.astype(np.intp) > expected))
    assert rounded_up > 100  # the interpolated index's rounding was there to take back


def _motion_by_labels(values: np.ndarray, enter: float, leave: float) -> np.ndarray:
    """windows.py `motion_bins` as it was: each side's stretches labelled by a running count, a
    stretch confirmed by any bin beyond `enter`, each bin's label looked up."""
    out = np.zeros(values.shape, dtype=bool)
    for sign in (1.0, -1.0):
        signed = sign * values
        candidate = signed > leave
        starts = candidate.copy()
        starts[1:] &= ~candidate[:-1]
        label = np.cumsum(starts)
        confirmed = np.zeros(int(label[-1]) + 1 if label.size else 1, dtype=bool)
        confirmed[label[candidate & (signed > enter)]] = True
        out |= candidate & confirmed[label]
    return out


def test_motion_per_stretch_is_the_labelled_motion() -> None:
    """windows.py `motion_bins` (both sides at once, per stretch) against the bins it labelled one
    side at a time: noise around 0, ramps, reversing, an encoder's quantized steps, NaN
    drop-outs, a stretch at either end, `enter` below `leave`, one bin, none."""
    rng = np.random.default_rng(21)
    t = np.arange(20_000) * BIN_S
    ramp = np.clip(np.sin(t / 7.0) * 1.5, -1.0, 1.0)
    noisy = ramp + rng.normal(0.0, 0.02, t.size)
    quantized = np.round(noisy / 0.02) * 0.02
    holes = noisy.copy()
    holes[rng.random(t.size) < 0.01] = np.nan
    cases = [noisy, quantized, holes, rng.normal(0.0, 0.01, t.size), noisy[:1], noisy[:0]]
    for values in cases:
        for enter, leave in ((0.06, 0.02), (0.03, 0.03), (0.001, 0.001), (0.01, 0.05)):
            assert np.array_equal(
                motion_bins(values, enter, leave), _motion_by_labels(values, enter, leave)
            )


def test_the_gap_bins_are_those_every_bin_tested_gives() -> None:
    """stats.py `_gap_bins` (the bins of the samples before a gap only) against every bin
    tested as before: gaps of 2-40 periods, jittered stamps, a slow and a 20 Hz logger, a
    gap after the first sample and before the last, none."""
    rng = np.random.default_rng(31)
    found = 0
    for period_s, n_samples in ((0.05, 6000), (0.1538, 900), (0.05, 50)):
        index = np.arange(n_samples, dtype=np.float64)
        for at, dropped in (
            (1, 3),
            (n_samples - 2, 5),
            *zip(rng.integers(2, n_samples - 2, 15), rng.integers(1, 40, 15), strict=True),
        ):
            index[at:] += dropped
        for stamps in (
            index * period_s,
            index * period_s * (1 + rng.uniform(-0.2, 0.2, n_samples) * 0.05),
            np.arange(n_samples) * period_s,
        ):
            offset_s = np.sort(stamps) - np.min(stamps)
            n_bins = int((offset_s[-1] + period_s) / BIN_S)
            centre_s = (np.arange(n_bins) + 0.5) * BIN_S
            at = _sample_at_centres(offset_s, n_bins)
            step_s = np.diff(offset_s, append=offset_s[-1] + period_s)
            every = (step_s[at] > GAP_FACTOR * period_s) & (centre_s - offset_s[at] > period_s)
            assert np.array_equal(
                _gap_bins(offset_s, at, period_s, centre_s), np.flatnonzero(every)
            )
            found += int(every.sum())
    assert found > 1000  # (gaps there were)


def test_row_means_are_numpys_means_bit_for_bit() -> None:
    """regressors.py `row_means` (numpy's pairwise order of additions, a column at a time) and
    `row_shares` against `mean(axis=1)`: rows of 1-40 values and the ends of the 8-accumulator
    blocks, NaN (a drop-out), infinities, -0.0 (a row of them: +0.0, as numpy's sum onto 0),
    values of very different sizes (where the order of additions shows), strided views, an
    F-ordered array (numpy's mean sums its rows in sequence: `row_means` then defers to it)."""
    rng = np.random.default_rng(41)
    for n in [*range(1, 41), 63, 64, 65, 127, 128, 129]:
        values = rng.normal(size=(2000, n)) * rng.choice([1e-3, 1.0, 1e3, 1e9], size=(2000, n))
        values[rng.random(values.shape) < 0.01] = np.nan
        values[rng.random(values.shape) < 0.02] = -0.0
        values[5] = -0.0
        values[7, 0], values[8, -1] = np.inf, -np.inf
        # F-ordered and transposed layouts too: numpy sums those rows in sequence (review)
        columns_first = np.asfortranarray(values)
        for view in (values, values[:, 1:], values[:, :-1], values[::3], columns_first):
            if not view.shape[1]:
                continue
            expected = view.mean(axis=1)
            got = row_means(view)
            assert np.array_equal(got, expected, equal_nan=True), n
            assert np.array_equal(np.signbit(got), np.signbit(expected)), n
            flags = view > 0.2
            assert np.array_equal(row_shares(flags), flags.mean(axis=1)), n
    # the order shows: summed in turn, a row of 10 differs from numpy's mean
    rows = rng.normal(size=(2000, 10)) * rng.choice([1e-3, 1.0, 1e9], size=(2000, 10))
    in_turn = rows[:, 0].copy()
    for k in range(1, 10):
        in_turn += rows[:, k]
    assert not np.array_equal(in_turn / 10, row_means(rows))


def test_trips_cut_per_stretch_are_the_loops() -> None:
    """moving.py `trip_numbers` (every stretch at once) against the loop over stretches it
    replaced: stops at either end (no cut), shorter than a stop, one window, none."""

    def by_loop(standing: np.ndarray, stop_windows: int) -> np.ndarray:
        if not standing.size:
            return np.zeros(0, dtype=np.intp)
        change = np.flatnonzero(np.diff(standing.astype(np.int8))) + 1
        bounds = np.concatenate(([0], change, [standing.size]))
        cuts = np.zeros(standing.size, dtype=np.intp)
        for start, end in zip(bounds[:-1], bounds[1:], strict=True):
            inside = 0 < start and end < standing.size
            if standing[start] and end - start >= stop_windows and inside:
                cuts[(start + end) // 2] = 1
        return np.cumsum(cuts)

    rng = np.random.default_rng(43)
    cases = [
        np.repeat(rng.random(400) < 0.5, rng.integers(1, 15, 400)),
        np.repeat([True, False, True, False, True], [10, 5, 10, 3, 12]),  # stops at the ends
        np.ones(30, dtype=bool),
        np.zeros(30, dtype=bool),
        np.array([True]),
        np.array([], dtype=bool),
    ]
    for standing in cases:
        for stop_windows in (1, 3, 6, 20):
            got = trip_numbers(standing, stop_windows)
            assert np.array_equal(got, by_loop(standing, stop_windows))
    assert trip_numbers(cases[0], 6)[-1] > 10  # (trips there were)


def test_running_sums_clean_only_the_undefined() -> None:
    """regressors.py `running_sums` against its sums of `np.nan_to_num(values)`: NaN 0, an
    infinity the largest float, the count of undefined values beside; all finite."""
    rng = np.random.default_rng(47)
    values = rng.normal(size=5000)
    values[rng.random(5000) < 0.02] = np.nan
    values[[10, 20]] = np.inf, -np.inf
    for case in (values, np.nan_to_num(values), values[:1], values[:0]):
        bad, total = running_sums(case)
        assert np.array_equal(total, np.concatenate(([0.0], np.cumsum(np.nan_to_num(case)))))
        expected_bad = np.concatenate(([0], np.cumsum(~np.isfinite(case))))
        assert np.array_equal(bad, expected_bad) and bad.dtype == np.intp


def test_every_windows_power_and_rows_any() -> None:
    """`power_at_lags` of every window (no index: the strided rows copied as they are) is the
    gathered power, written into a block of a wider matrix too; sums.py `_any_per_row` is
    `any(axis=1)`."""
    for rw in _field_windows(seed=5):
        every = np.arange(rw.count)
        for lags in (np.arange(21), np.arange(2, 7)):
            expected = _gathered(rw, lags, every)
            assert np.array_equal(rw.power_at_lags(lags), expected, equal_nan=True)
            wide = np.zeros((rw.count, lags.size + 2))
            rw.power_at_lags(lags, out=wide[:, 2:])
            assert np.array_equal(wide[:, 2:], expected, equal_nan=True)
            assert (wide[:, :2] == 0).all()
    rng = np.random.default_rng(53)
    for shape in ((500, 20), (500, 1), (0, 5), (500, 0)):
        flags = rng.random(shape) < 0.05
        assert np.array_equal(_any_per_row(flags), flags.any(axis=1))


def test_finite_in_place_is_nan_to_num() -> None:
    """windows.py `_finite` (the undefined values only) is `np.nan_to_num`: NaN 0, +-inf the
    largest float with its sign, -0.0 kept; all finite: the array itself, untouched."""
    rng = np.random.default_rng(59)
    values = rng.normal(size=3000)
    values[rng.random(3000) < 0.05] = np.nan
    values[[3, 4, 5]] = np.inf, -np.inf, -0.0
    got = _finite(values.copy())
    assert np.array_equal(got, np.nan_to_num(values))
    assert np.array_equal(np.signbit(got), np.signbit(np.nan_to_num(values)))
    clean = rng.normal(size=100)
    assert _finite(clean) is clean


def test_gradient_is_numpys() -> None:
    """windows.py `gradient` (a window's rate of change) is `np.gradient` bit for bit: 2, 3
    and thousands of values, NaN (a drop-out's window), spacings that do not round evenly."""
    rng = np.random.default_rng(61)
    for n in (2, 3, 4, 7201):
        values = rng.normal(size=n) * rng.choice([1e-3, 1.0, 1e6], n)
        values[rng.random(n) < 0.05] = np.nan
        for spacing in (0.5, 0.1, 1 / 3, 0.65):
            assert np.array_equal(
                gradient(values, spacing), np.gradient(values, spacing), equal_nan=True
            )
