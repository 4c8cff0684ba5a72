"""Least squares with t-tests: hand-checked values, and no false significance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.stats import ols, one_sample_p_greater, t_quantile


def test_ols_on_a_line_with_known_residuals():
    # y = 1 + 2 x + e with e = (+1, -1, -1, +1): SSE = 4, s² = 4 / 2 = 2, S_xx = 5
    x = np.array([0.0, 1.0, 2.0, 3.0])
    y = 1 + 2 * x + np.array([1.0, -1.0, -1.0, 1.0])
    fit = ols(np.column_stack([np.ones_like(x), x]), y)
    assert fit.coef == pytest.approx([1.0, 2.0])
    assert fit.se[1] == pytest.approx(math.sqrt(2 / 5))  # s / sqrt(S_xx)
    assert fit.dof == 2


def test_a_collinear_design_is_never_significant():
    x = np.linspace(0, 1, 10)
    design = np.column_stack([np.ones_like(x), x, 2 * x])  # third column = 2 x second
    fit = ols(design, 3 + x)
    assert math.isnan(fit.p_greater(2))
    assert math.isnan(fit.ci95(2)[0])


def test_one_sample_mean_test():
    mean, se, p = one_sample_p_greater(np.array([1.0, 2.0, 3.0]))
    assert mean == 2.0 and se == pytest.approx(1 / math.sqrt(3))
    # t = 2 sqrt(3) with 2 dof, where P(T > t) = (1 - t / sqrt(t² + 2)) / 2 in closed form
    t = 2 * math.sqrt(3)
    assert p == pytest.approx((1 - t / math.sqrt(t**2 + 2)) / 2, rel=1e-9)


def test_t_quantile_known_values() -> None:

    # closed forms: 1 dof is Cauchy, t = tan(pi (p - 1/2)); 2 dof, t = (2p - 1) / sqrt(2p(1 - p))
    for p in (0.6, 0.975, 0.999):
        assert t_quantile(p, 1.0) == pytest.approx(math.tan(math.pi * (p - 0.5)), rel=1e-13)
        assert t_quantile(p, 2.0) == pytest.approx(
            (2 * p - 1) / math.sqrt(2 * p * (1 - p)), rel=1e-13
        )
    # printed tables (e.g. Montgomery & Runger, Table V): t_{0.975, 10} = 2.228, 30 -> 2.042
    assert t_quantile(0.975, 10.0) == pytest.approx(2.228, abs=5e-4)
    assert t_quantile(0.975, 30.0) == pytest.approx(2.042, abs=5e-4)
    # symmetric, and 0 at the median
    assert t_quantile(0.025, 7.5) == -t_quantile(0.975, 7.5)
    assert t_quantile(0.5, 3.0) == 0.0
    # just above the median t = delta / f(0): f(0) = Gamma(5/2) / (sqrt(4 pi) Gamma(2)) = 3/8
    # for 4 dof; the next term is O(delta^3), so 1e-12 relative holds for delta = 1e-7
    delta = 0.5000001 - 0.5
    assert t_quantile(0.5000001, 4.0) == pytest.approx(delta / 0.375, rel=1e-12)
    assert math.isnan(t_quantile(0.975, 0.0)) and math.isnan(t_quantile(1.0, 5.0))


@settings(max_examples=200, deadline=None)
@given(
    p=st.floats(0.6, 1 - 1e-9),
    dof=st.one_of(st.floats(0.5, 1000.0), st.integers(1, 1000).map(float)),
)
def test_t_quantile_is_scipys(p: float, dof: float) -> None:
    """Against scipy.special.stdtrit (what scipy.stats.t.ppf calls). rtol 1e-11: the
    incomplete beta's front factor takes lgamma(dof / 2), whose absolute error (~eps x
    lgamma) is ~1e-13 relative at 1000 dof; the Newton solve adds a few ulps. (Near p = 1/2
    scipy itself is less accurate than this: see test_t_quantile_known_values.)"""
    from scipy.special import stdtrit

    assert t_quantile(p, dof) == pytest.approx(float(stdtrit(dof, p)), rel=1e-11)


def test_lack_of_fit_and_nested_f_test_by_hand():
    # replicates at x = 1, 2, 3 with group means 2, 3, 7: pure error SS = 6 on 3 dof. The line
    # through all six points is the line through the means: slope 5/2, intercept -1, fitted
    # 1.5, 4, 6.5, so SS_lack_of_fit = 2 (0.5² + 1² + 0.5²) = 3 on 3 - 2 = 1 dof: F = 3 / 2.
    from scipy import stats

    x = np.array([1.0, 1.0, 2.0, 2.0, 3.0, 3.0])
    y = np.array([1.0, 3.0, 2.0, 4.0, 6.0, 8.0])
    line = ols(np.column_stack([np.ones_like(x), x]), y)
    assert line.coef == pytest.approx([-1.0, 2.5])
    p_value, df_lof, df_pe = line.lack_of_fit(x)
    assert (df_lof, df_pe) == (1, 3)
    assert p_value == pytest.approx(stats.f.sf(1.5, 1, 3), rel=1e-12)
    # against the mean alone: SST = 34, SSE = 9 on 4 dof: F = 25 / (9 / 4)
    mean = ols(np.ones((6, 1)), y)
    assert line.f_test(mean) == pytest.approx(stats.f.sf(25 / (9 / 4), 1, 4), rel=1e-12)
    assert line.r2 == pytest.approx(1 - 9 / 34)
    # and the two-sided t test of the slope is the same F test (t² = F)
    assert line.p_two_sided(1) == pytest.approx(line.f_test(mean), rel=1e-10)


def test_an_ill_conditioned_design_is_not_estimable():
    x = np.linspace(0.2, 0.9, 12)
    good = ols(np.column_stack([np.ones_like(x), x]), 1 + x)
    assert good.estimable and good.rank == 2
    nearly = np.column_stack([np.ones_like(x), x, x + 1e-12 * np.arange(x.size)])
    bad = ols(nearly, 1 + x)
    assert not bad.estimable
    assert math.isnan(bad.p_greater(2)) or bad.condition > 1e8


def test_binomial_at_least_is_scipys_binomial_tail():
    """The ripple's count test (causes/cruise_ripple.py): P(K >= k) against
    scipy.stats.binom.sf(k - 1) for every n <= 60 and k <= n, at the levels it is used at."""
    from scipy.stats import binom

    from wifibot_power.stats import binomial_at_least

    for p in (0.01, 0.05, 0.5):
        for n in range(1, 61):
            ours = np.array([binomial_at_least(k, n, p) for k in range(n + 1)])
            np.testing.assert_allclose(ours, binom.sf(np.arange(n + 1) - 1, n, p), rtol=1e-12)


def test_t_sf_and_f_sf_are_scipys_without_importing_it():
    """P(T > t) and P(F > f) by our `betainc` (importing scipy.special cost ~0.27 s of every
    diagnose). Against closed forms (dof 1: 1/2 - atan(t)/π; dof 2: 1/2 - t / (2 sqrt(2 +
    t²)); measured within 6e-15 and 1e-13 relative, pinned at 1e-12) and against
    scipy.special.stdtr / fdtrc over a grid (measured within 2.5e-11 relative, at dof 1e4;
    pinned at 1e-10). Where they differ most, near t = 0 at dof 1, scipy is the one off:
    stdtr(1, -1e-8) is 3e-9 from the Cauchy's closed form, ours 0."""
    from scipy import special

    from wifibot_power.stats import f_sf, t_sf

    for t in np.linspace(-30, 30, 601):
        assert t_sf(t, 1) == pytest.approx(0.5 - math.atan(t) / math.pi, rel=1e-12)
        assert t_sf(t, 2) == pytest.approx(0.5 - t / (2 * math.sqrt(2 + t * t)), rel=1e-12)
    assert t_sf(1e-8, 1) == pytest.approx(0.5 - math.atan(1e-8) / math.pi, rel=1e-15)
    for dof in (1, 3, 5, 10, 29, 100, 1000, 1e4):
        for t in np.concatenate([np.linspace(-50, 50, 200), [100.0, 300.0]]):
            ref = special.stdtr(dof, -t)
            if ref > 1e-200:
                assert t_sf(float(t), float(dof)) == pytest.approx(ref, rel=1e-10), (dof, t)
    for d1 in (1, 2, 3, 5, 14, 29, 60):
        for d2 in (1, 2, 5, 15, 30, 100, 1000, 5000):
            for f in np.logspace(-4, 5, 46):
                ref = special.fdtrc(d1, d2, f)
                if ref > 1e-200:
                    assert f_sf(float(f), d1, d2) == pytest.approx(ref, rel=1e-10), (d1, d2, f)
    assert t_sf(0.0, 7) == 0.5 and f_sf(0.0, 2, 9) == 1.0 and f_sf(-1.0, 2, 9) == 1.0
    assert t_sf(math.inf, 3) == 0.0 and t_sf(-math.inf, 3) == 1.0 and f_sf(math.inf, 1, 2) == 0
    assert math.isnan(t_sf(math.nan, 3)) and math.isnan(f_sf(1.0, 0, 2))


def test_diagnose_loads_no_scipy():
    """A diagnosis (a cause named, its p-values, the replication tests) in a fresh
    interpreter imports nothing of scipy: its p-values are `stats`' own."""
    import subprocess
    import sys
    from pathlib import Path

    code = (
        "import sys; sys.path.insert(0, 'tests')\n"
        "from test_diagnose import GRID\n"
        "from wifibot_power.simulate import SimConfig, simulate_runs\n"
        "from wifibot_power.diagnose import diagnose_runs\n"
        "config = SimConfig(**GRID, seed=3, effects={'cruise_ripple': 1.0})\n"
        "result = diagnose_runs([s.run for s in simulate_runs(config)])\n"
        "assert [f.cause for f in result.findings] == ['cruise_ripple'], result.findings\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))\n"
    )
    root = Path(__file__).resolve().parents[1]
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "[]", done.stdout
