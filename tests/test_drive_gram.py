"""The drive model's least squares from sufficient statistics (drive/gram.py, identify.py
`bounded_from_gram`): the same answers as least squares on the windows themselves. The
references are independent: scipy's `lsq_linear` (a trust-region bounded solver on X and y)
and the direct lag search over a fold's windows (identify.py `lag_search`)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import lsq_linear

from wifibot_power.drive import drive_stats
from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.heldout import heldout_accuracy
from wifibot_power.drive.identify import bounded_from_gram, lag_grid, lag_search
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
