"""The drive model's least squares from sufficient statistics (drive/gram.py, identify.py
`bounded_from_gram`): the same answers as least squares on the windows themselves. The
references are independent: scipy's `lsq_linear` (a trust-region bounded solver on X and y)
and the direct lag search over a fold's windows (identify.py `lag_search`)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import lsq_linear

import wifibot_power.drive.model as model_module
from wifibot_power.drive import drive_stats
from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.heldout import heldout_accuracy
from wifibot_power.drive.identify import WindowSearch, bounded_from_gram, lag_grid, lag_search
from wifibot_power.drive.model import fit_drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.windows import run_windows


def test_bounded_fit_from_group_sums_is_the_bounded_fit_of_the_rows() -> None:
    """A random bounded problem whose second term's free least squares is negative: held at
    its bound 0. The fit from the sums of 6 groups' X'X, X'y less one held-out group's equals
    scipy's bounded fit of the other groups' rows."""
    rng = np.random.default_rng(7)
    n, p = 600, 4
    X = np.column_stack((np.ones(n), rng.uniform(0, 1, (n, p - 1))))
    X[:, 2] += 0.6 * X[:, 1]  # correlated columns: the bound moves the others
    y = X @ np.array([5.0, -1.5, 2.0, 0.7]) + rng.normal(0, 0.3, n)
    group = rng.integers(0, 6, n)
    xx = np.stack([X[group == g].T @ X[group == g] for g in range(6)])
    xy = np.stack([X[group == g].T @ y[group == g] for g in range(6)])
    held = 3
    rows = group != held
    non_negative = np.array([True, True, True, False])
    free = np.linalg.lstsq(X[rows], y[rows], rcond=None)[0]
    assert free[1] < -0.5  # the problem is what it says: the bound is active

    coef = bounded_from_gram(xx.sum(axis=0) - xx[held], xy.sum(axis=0) - xy[held], non_negative)
    lower = np.where(non_negative, 0.0, -np.inf)
    reference = lsq_linear(X[rows], y[rows], bounds=(lower, np.inf), tol=1e-14, method="bvls").x

    assert coef[1] == 0.0
    assert_allclose(coef, reference, rtol=1e-9, atol=1e-12)


@pytest.fixture(scope="module")
def runs():
    config = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=5, lag_s=0.45)
    rws = [run_windows(drive_stats(as_run(r))) for r in simulate_free(config)]
    return [rw for rw in rws if rw.count]


def test_fold_lag_search_from_sums_is_the_direct_search(runs) -> None:
    """Each fold's lag (a fraction of a bin) and each whole lag's sum of squares from the
    folds' sums are those of least squares over the fold's windows."""
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    fold_of = [np.arange(rw.count) * 3 // rw.count for rw in runs]  # 3 folds a run
    grams = FoldGrams.from_windows(runs, surfaces, np.concatenate(fold_of), 3, lag_grid(runs))
    fractional = 0
    for fold in range(3):
        lag, sse = grams.search(fold)
        direct_lag, direct_sse = lag_search(
            runs, surfaces, [f != fold for f in fold_of], gram=False
        )
        assert_allclose(sse, direct_sse, rtol=1e-9)
        assert lag == pytest.approx(direct_lag, rel=1e-9, abs=1e-12)
        fractional += lag != round(lag)
    assert fractional  # the refinement between whole lags was exercised


def test_lag_search_from_sums_is_the_direct_search(runs) -> None:
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    lag, sse = lag_search(runs, surfaces)
    direct_lag, direct_sse = lag_search(runs, surfaces, gram=False)
    assert_allclose(sse, direct_sse, rtol=1e-9)
    assert lag == pytest.approx(direct_lag, rel=1e-9, abs=1e-12)
    assert lag != round(lag)


def test_heldout_from_sums_is_the_direct_heldout(runs) -> None:
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    fast = heldout_accuracy(runs, surfaces, True, gram=True)
    slow = heldout_accuracy(runs, surfaces, True, gram=False)
    assert fast is not None and slow is not None
    assert [r.run_id for r in fast.runs] == [r.run_id for r in slow.runs]
    assert_allclose(
        [r.predicted_J for r in fast.runs], [r.predicted_J for r in slow.runs], rtol=1e-9
    )
    assert_allclose(fast.mape_pct, slow.mape_pct, rtol=1e-9)


def test_search_over_the_windows_when_the_sums_cancel(runs, monkeypatch) -> None:
    """A sum of squares too small against y'y to be taken from sums: the direct search."""
    import wifibot_power.drive.gram as gram

    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    fold_of = [np.zeros(rw.count, dtype=int) for rw in runs]
    grams = FoldGrams.from_windows(runs, surfaces, np.concatenate(fold_of), 1, lag_grid(runs))
    assert grams.search(-1) is not None
    monkeypatch.setattr(gram, "CANCELLATION", 1.0)  # every fit "cancels"
    assert grams.search(-1) is None
    calls = []
    sums = gram.FoldGrams.search
    monkeypatch.setattr(gram.FoldGrams, "search", lambda self, f: calls.append(f) or sums(self, f))
    lag, sse = lag_search(runs, surfaces)
    assert calls and sse.size == lag_grid(runs).size
    assert lag == lag_search(runs, surfaces, gram=False)[0]  # the direct search's, exactly


# --- the whole fit from the workers' per-trip sums (sums.py, lagsums.py) ----------------------


def _numbers_equal(fast, direct, where="drive") -> None:
    """Every number of two `summary()`s within rtol 1e-9 (or 1e-12 absolute), every string and
    key exactly (as benchmarks/gram_equal.py)."""
    if isinstance(direct, dict):
        assert list(fast) == list(direct), where
        for key in direct:
            _numbers_equal(fast[key], direct[key], f"{where}.{key}")
    elif isinstance(direct, list | tuple):
        assert len(fast) == len(direct), where
        for i, (a, b) in enumerate(zip(fast, direct, strict=True)):
            _numbers_equal(a, b, f"{where}[{i}]")
    elif isinstance(direct, float) and not isinstance(direct, bool):
        assert fast == pytest.approx(direct, rel=1e-9, abs=1e-12, nan_ok=True), where
    else:
        assert fast == direct, where


@pytest.fixture(scope="module")
def field_stats():
    """12 runs at field realism (drop-outs: windows defined at some lags only), a lag between
    two bins; the power shifted by -40 W so that it changes sign between lags (|y| sums)."""
    from dataclasses import replace

    config = FreeDriveConfig(runs_per_surface=6, run_s=60.0, seed=11, lag_s=0.43)
    stats = [drive_stats(as_run(r)) for r in simulate_free(config)]
    return stats, [replace(s, power_W=s.power_W - 40.0) for s in stats]


@pytest.mark.parametrize("shifted", [False, True])
@pytest.mark.parametrize("n_runs", [12, 5])
def test_fit_from_sums_is_the_direct_fit(field_stats, shifted, n_runs) -> None:
    """`fit_drive_stats` from per-trip sums equals the fit from the windows (every lag by least
    squares over them, each fold's identification row by row): clusters by run (12 runs)
    and by trip (5), on a power that stays positive and one that changes sign."""
    stats = field_stats[shifted][:n_runs]
    fast = fit_drive_stats(stats)
    direct = fit_drive_stats(stats, direct=True)
    assert fast.heldout is not None and len(fast.heldout.runs) >= 10
    _numbers_equal(fast.summary(), direct.summary())
    assert fast.coef == pytest.approx(direct.coef, rel=1e-9, nan_ok=True)


def test_sum_moments_are_the_window_moments(field_stats) -> None:
    """At a lag between two bins, every number identification reads (X'X, X'y, the screens'
    counts and centred sums, the jackknife's per-cluster sums, each column's spread where it
    is seen) from the sums equals the same from the windows; on some trips too."""
    from wifibot_power.drive.lagsums import SumsTable
    from wifibot_power.drive.moments import WindowMoments
    from wifibot_power.drive.sums import sums_of
    from wifibot_power.drive.windows import assemble

    stats = field_stats[1]
    runs = [run_windows(s) for s in stats]
    surfaces = tuple(sorted({name for s in stats for name in s.surfaces}))
    table = SumsTable([sums_of(s) for s in stats], surfaces)
    lag = 8.4
    assert table.edge[0].shape[0] and table.cross_x.shape[0]  # edge and sign-changing windows
    for train, by_run in (
        (np.ones(table.trips, bool), True),
        (np.arange(table.trips) % 3 > 0, False),
    ):
        fast = table.at_lag(lag).moments(train, by_run)
        only = [train[rw.trip + base] for rw, base in zip(runs, table.trip_base, strict=False)]
        windows = assemble(runs, lag, surfaces, only=only)
        direct = WindowMoments(windows, windows.run if by_run else windows.trip)
        kept = np.ones(len(direct.columns), bool)
        kept[-2:] = False  # the force form's columns: 0 in a power log
        assert fast.n == direct.n
        assert_allclose(fast.gram, direct.gram, rtol=1e-11, atol=1e-9)
        for a, b in zip(fast.gram_xy(kept), direct.gram_xy(kept), strict=True):
            assert_allclose(a, b, rtol=1e-11, atol=1e-9)
        assert_allclose(fast.seen_clusters(), direct.seen_clusters())
        for j in range(len(direct.columns)):
            assert fast.centred_ss(j) == pytest.approx(direct.centred_ss(j), rel=1e-9, abs=1e-9)
            if train.all():
                for idle in (True, False):
                    assert_allclose(
                        fast.seen_spread(j, idle), direct.seen_spread(j, idle), rtol=1e-9
                    )
        coef = np.linspace(1.0, 3.0, int(kept.sum()))
        (gram_f, grams_f, scores_f), p_f, g_f = fast.jackknife_sums(kept, coef)
        (gram_d, grams_d, scores_d), p_d, g_d = direct.jackknife_sums(kept, coef)
        assert (p_f, g_f) == (p_d, g_d)
        assert_allclose(gram_f, gram_d, rtol=1e-10)
        assert_allclose(grams_f, grams_d, rtol=1e-10, atol=1e-6)
        assert_allclose(scores_f, scores_d, rtol=1e-9)


def test_fold_sums_from_trips_are_the_fold_sums_of_the_windows(field_stats) -> None:
    """Each fold's lag search from the trips' sums (lagsums.py) finds the lag and every whole
    lag's sum of squares that the same folds' sums made from the windows do (gram.py)."""
    from wifibot_power.drive.lagsums import SumsTable
    from wifibot_power.drive.sums import sums_of

    stats = field_stats[0]
    runs = [run_windows(s) for s in stats]
    surfaces = tuple(sorted({name for s in stats for name in s.surfaces}))
    table = SumsTable([sums_of(s) for s in stats], surfaces)
    fold_of_trip = np.arange(table.trips) % 4
    fold_of_window = np.concatenate(
        [fold_of_trip[rw.trip + base] for rw, base in zip(runs, table.trip_base, strict=False)]
    )
    lags = lag_grid(runs)
    from_trips = table.fold_grams(fold_of_trip, 4, lags)
    from_windows = FoldGrams.from_windows(runs, surfaces, fold_of_window, 4, lags)
    for fold in range(4):
        lag, sse = from_trips.search(fold)
        direct_lag, direct_sse = from_windows.search(fold)
        assert_allclose(sse, direct_sse, rtol=1e-9)
        assert lag == pytest.approx(direct_lag, rel=1e-9)


def test_fit_from_sums_searches_the_windows_where_the_sums_cancel(field_stats, monkeypatch) -> None:
    """Where every lag search's sum of squares "cancels" (gram.CANCELLATION), the fit from
    sums searches those lags over the windows (as the direct fit does) and still equals it."""
    import wifibot_power.drive.gram as gram

    stats = field_stats[0][:6]
    monkeypatch.setattr(gram, "CANCELLATION", 1.0)
    calls = []
    search = model_module.WindowSearch.search
    monkeypatch.setattr(
        model_module.WindowSearch,
        "search",
        lambda self, only: calls.append(only) or search(self, only),
    )
    fast = fit_drive_stats(stats)
    assert len(calls) >= 5  # the whole fit's and the folds' searches, over the windows
    _numbers_equal(fast.summary(), fit_drive_stats(stats, direct=True).summary())


def test_window_search_of_a_subset_is_the_search_of_its_windows_alone(runs) -> None:
    """`WindowSearch` assembles every window once and searches a subset by its rows (the
    held-out folds of step runs, model.py `_window_search`): a subset that is whole runs
    gives exactly (bit for bit) the search made from those runs' windows alone."""
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    shared = WindowSearch(runs, surfaces)
    first = len(runs) // 2
    only = np.concatenate([np.full(rw.count, k < first) for k, rw in enumerate(runs)])
    lag, sse = shared.search(only)
    alone_lag, alone_sse = WindowSearch(runs[:first], surfaces).search(None)
    assert lag == alone_lag
    assert np.array_equal(sse, alone_sse)
    everything = shared.search(None)
    assert not np.array_equal(everything[1], sse)  # the subset is searched, not every window
