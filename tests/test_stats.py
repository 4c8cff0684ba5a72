"""Least squares with t-tests: hand-checked values, and no false significance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wifibot_power.stats import ols, one_sample_p_greater


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
