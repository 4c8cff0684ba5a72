"""The lag search's criterion with noisy inertial regressors (drive/gram.py `corrected_gram`,
`noise_share`; docs/drive-model.md, "Lag"): the sum of squares of the corrected least squares,
X'X less the speeding-up and braking columns' noise, so that their noise does not move the
lag found."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from wifibot_power.drive.gram import FoldGrams, corrected_gram, noise_share, refine_lag
from wifibot_power.drive.identify import lag_search
from wifibot_power.drive.lagsums import SumsTable
from wifibot_power.drive.model import MOSTLY_NOISE, fit_drive_stats, inertial_noise_warning
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats
from wifibot_power.drive.sums import run_sums
from wifibot_power.drive.windows import run_windows

TRUE_LAG = 4  # bins


def _lagged_problem(seed: int, noise_sd: float):
    """Windows of a smooth speed (12 sinusoids, periods 2-20 s) and the power 10 + 8 v^2 +
    30 a v (+ 1 W of white noise) TRUE_LAG bins later, read at each whole lag 0..20; the a v
    column read with white noise of sd `noise_sd` and calibrated (regressors.py): X, Y, the
    reliability."""
    rng = np.random.default_rng(seed)
    n, dt = 20000, 0.05
    freq = rng.uniform(0.05, 0.5, 12)[:, None]
    phase = rng.uniform(0, 2 * np.pi, 12)[:, None]
    amp = rng.uniform(0.1, 0.3, 12)[:, None]

    def speed(t):
        return 0.2 + np.sum(amp * np.sin(2 * np.pi * freq * t + phase), axis=0)

    def accel(t):
        return np.sum(amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t + phase), axis=0)

    t = np.arange(n) * dt
    white = rng.standard_normal(n + 40)

    def power(t):
        return 10 + 8 * speed(t) ** 2 + 30 * speed(t) * accel(t)

    Y = np.column_stack(
        [power(t + (lag - TRUE_LAG) * dt) + white[lag : lag + n] for lag in range(21)]
    )
    read = speed(t) * accel(t) + noise_sd * rng.standard_normal(n)
    reliability = 1.0 - n * noise_sd**2 / float(read @ read)
    X = np.column_stack((np.ones(n), speed(t) ** 2, reliability * read))
    return X, Y, reliability


def _grams(X, Y, noise):
    yy = np.zeros((1, 2, Y.shape[1]))
    yy[0, 0] = np.sum(np.square(Y), axis=0)
    yy[0, 1, :-1] = np.sum(Y[:, :-1] * Y[:, 1:], axis=0)
    return FoldGrams(
        np.array([X.shape[0]]),
        (X.T @ X)[None],
        (X.T @ Y)[None],
        yy,
        np.arange(Y.shape[1]),
        None if noise is None else noise[None],
    )


def test_noisy_inertial_column_does_not_move_the_lag():
    # d(v^2)/dt = 2 a v: with the a v column attenuated by its noise, the plain sum of squares
    # is lower at a shorter lag, where v^2 shifted stands in for the a v it lost (2.7-3.7 bins
    # for 4 here); the corrected least squares' is not (3.99-4.03)
    for seed in range(3):
        X, Y, reliability = _lagged_problem(seed, 0.3)
        assert 0.6 < reliability < 0.9
        noise = np.array([0.0, 0.0, (1.0 - reliability) * float(X[:, 2] @ X[:, 2])])
        plain, _ = _grams(X, Y, None).search(-1)
        corrected, _ = _grams(X, Y, noise).search(-1)
        assert plain < TRUE_LAG - 0.2
        assert abs(corrected - TRUE_LAG) < 0.1


def test_noise_share_and_a_gram_not_positive_definite():
    columns = ("idle_W", "effective_mass_kg", "braking_mass_kg", "rolling_W_per_mps[a]")
    assert_allclose(noise_share(columns, (0.9, 0.25)), [0, 0.1, 0.75, 0])
    xx = np.array([[4.0, 2.0], [2.0, 1.1]])
    assert_allclose(corrected_gram(xx, np.array([0.0, 0.05])), [[4, 2], [2, 1.05]])
    # corrected into an indefinite matrix (more noise than the column holds apart from the
    # others): the plain Gram, not a criterion without a minimum
    assert_allclose(corrected_gram(xx, np.array([0.0, 0.5])), xx)


def _runs(seed: int, speed_noise_mps: float):
    config = FreeDriveConfig(
        seed=seed,
        runs_per_surface=3,
        run_s=90.0,
        realism="field",
        realism_overrides={"speed_noise_mps": speed_noise_mps, "speed_step_mps": 0.0},
    )
    return [drive_stats(as_run(r)) for r in simulate_free(config)]


def test_simulator_lag_with_a_noisy_speed_is_found():
    # field realism with 4 cm/s of speed noise (no quantization): the plain criterion found
    # 0.1876 s for the true 0.2 s (8 seeds, sd 0.002), the corrected one 0.1993 s (sd 0.002);
    # every path the fit takes: over the windows, from their sums (gram.py) and the whole fit
    for seed in (0, 1):
        stats = _runs(seed, 0.04)
        runs = [run_windows(s) for s in stats]
        assert all(0.8 < min(rw.reliability) < 0.97 for rw in runs)
        surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
        direct, _ = lag_search(runs, surfaces, gram=False)
        from_sums, _ = lag_search(runs, surfaces)
        table = SumsTable([run_sums(rw) for rw in runs], surfaces)
        grams = table.fold_grams(np.zeros(table.trips, int), 1, np.arange(table.lags))
        from_trips, _ = grams.search(-1)
        assert_allclose([from_sums, from_trips], direct, atol=1e-6)
        assert abs(direct * runs[0].stats.bin_s - 0.2) < 0.005
        model = fit_drive_stats(stats)
        assert abs(model.lag_s - 0.2) < 0.005


def test_warning_names_the_runs_whose_inertial_columns_are_mostly_noise():
    assert inertial_noise_warning([(1.0, 1.0), (0.5, 0.93)]) is None
    said = inertial_noise_warning([(1.0, 1.0), (0.3, 0.9), (0.8, 0.0)])
    assert said.startswith("2 of 3 run(s): their speeding-up or braking column is mostly noise")
    assert "1 of them all noise" in said
    # a fit whose runs' speed is noisy (30 cm/s a sample on 20 Hz: reliabilities ~0.1) beside
    # clean ones says so in its warnings (`fit --json`'s drive.warnings, under fit's table)
    clean = FreeDriveConfig(seed=3, runs_per_surface=2, run_s=60.0)
    noisy = FreeDriveConfig(
        seed=4,
        runs_per_surface=1,
        run_s=60.0,
        realism_overrides={"speed_noise_mps": 0.3, "speed_step_mps": 0.0},
    )
    runs = [as_run(r) for c in (clean, noisy) for r in simulate_free(c)]
    stats = [drive_stats(r) for r in runs]
    low = [min(run_windows(s).reliability) < MOSTLY_NOISE for s in stats]
    assert low == [False] * 4 + [True] * 2
    for direct in (False, True):
        warnings = fit_drive_stats(stats, direct=direct).summary()["warnings"]
        assert [w for w in warnings if "mostly noise" in w][0].startswith("2 of 6 run(s)")
    # the clean runs alone: no such warning
    assert not any("mostly noise" in w for w in fit_drive_stats(stats[:4]).warnings)


def test_lag_refined_from_whole_lags_exactly_for_a_quartic():
    # the sum of squares a bin either side of its minimum is not a parabola (here a quartic,
    # least at 4.3 bins), and between two whole lags it dips by the power's noise (the mix of
    # two shifted window means is less noisy than either: -5 t (1 - t) here); the quartic
    # through the five whole lags around the best is exact for it and never reads the dip.
    # The parabola through the best three, refined through the points half a bin either side
    # (the search before), found 4.277
    def sse_at(lag: float) -> float:
        d, t = lag - 4.3, lag - np.floor(lag)
        return 1000 + 50 * d**2 + 10 * d**3 + 5 * d**4 - 5.0 * t * (1 - t)

    found, whole = refine_lag(np.arange(21), sse_at)
    assert_allclose(found, 4.3, atol=1e-9)
    assert_allclose(whole[4], sse_at(4))
    # near the grid's ends (no two whole lags on one side): the parabola's vertex, in the bin
    found, _ = refine_lag(np.arange(21), lambda lag: sse_at(lag + 3.0))
    assert 1.0 < found < 1.6
