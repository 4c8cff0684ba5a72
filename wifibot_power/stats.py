"""Small statistics shared by fit and diagnose: Student's t quantile, multiple least squares
with t-tests. Importing this module loads no scipy (fit must start quickly); the p-value
functions load scipy.stats when called.

Ordinary least squares `y = X b + e` (e.g. Montgomery & Runger, Applied Statistics,
§12-1/12-2): `b = (XᵀX)⁻¹ Xᵀ y`, `s² = SSE / (n - p)`, `se(b_j) = s sqrt((XᵀX)⁻¹_jj)`,
t statistic `b_j / se(b_j)` with n - p degrees of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OLS:
    coef: np.ndarray
    se: np.ndarray
    dof: int
    residual: np.ndarray

    def ci95(self, j: int) -> tuple[float, float]:
        if self.dof < 1 or not np.isfinite(self.se[j]):
            return (float("nan"), float("nan"))
        t = t_quantile(0.975, self.dof)
        return (float(self.coef[j] - t * self.se[j]), float(self.coef[j] + t * self.se[j]))

    def p_greater(self, j: int) -> float:
        """One-sided p-value of H0: b_j <= 0 against b_j > 0; NaN when the design cannot
        tell b_j apart (rank-deficient or no degrees of freedom), never a false 0."""
        if self.dof < 1 or not np.isfinite(self.se[j]):
            return float("nan")
        if self.se[j] == 0:
            return 0.0 if self.coef[j] > 0 else 1.0
        from scipy import stats  # loaded by the tests that need p-values, not by fit

        return float(stats.t.sf(self.coef[j] / self.se[j], self.dof))


def ols(X: np.ndarray, y: np.ndarray) -> OLS:
    """Least squares with standard errors; rank-deficient designs give NaN errors."""
    X = np.asarray(X, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    coef, _, rank, _ = np.linalg.lstsq(X, y, rcond=None)
    residual = y - X @ coef
    n, p = X.shape
    dof = n - p
    if rank < p or dof < 1:
        return OLS(coef, np.full(p, np.nan), max(dof, 0), residual)
    s2 = float(residual @ residual) / dof
    cov = s2 * np.linalg.inv(X.T @ X)
    return OLS(coef, np.sqrt(np.clip(np.diag(cov), 0, None)), dof, residual)


def one_sample_p_greater(values: np.ndarray) -> tuple[float, float, float]:
    """Mean, its standard error and the one-sided p-value of mean > 0 (Student's t)."""
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return (float(x.mean()) if x.size else float("nan"), float("nan"), float("nan"))
    mean = float(x.mean())
    se = float(x.std(ddof=1) / np.sqrt(x.size))
    if se == 0:
        return mean, se, 0.0 if mean > 0 else 1.0
    from scipy import stats

    return mean, se, float(stats.t.sf(mean / se, x.size - 1))


def t_quantile(p: float, dof: float) -> float:
    """Student's t quantile `t_{p, dof}` (what `scipy.stats.t.ppf(p, dof)` gives, to ~1e-13
    relative), in plain Python: importing scipy.special costs ~0.25 s, most of a warm
    `fit --cache`.

    For t >= 0, `P(T > t) = I_x(ν/2, 1/2) / 2` and `P(0 < T <= t) = I_y(1/2, ν/2) / 2` with
    `x = ν / (ν + t²)`, `y = t² / (ν + t²) = 1 - x` (Abramowitz & Stegun 26.7.1 with 26.5.27;
    `I` the regularized incomplete beta function, `betainc`). The equation for t is set on
    the smaller of the two probabilities, `1 - p` or `p - 1/2` (each exact in floating point
    there), and solved by Newton's method with the t density
    `f(t) = Γ((ν+1)/2) / (sqrt(νπ) Γ(ν/2)) (1 + t²/ν)^(-(ν+1)/2)` (A&S 26.7.1) as derivative,
    kept inside a bracket that bisection falls back to.
    """
    if not (0.0 < p < 1.0 and dof > 0.0):
        return math.nan
    if p < 0.5:
        return -t_quantile(1.0 - p, dof)
    if p == 0.5:
        return 0.0
    half = 0.5 * (dof + 1.0)
    log_norm = math.lgamma(half) - math.lgamma(0.5 * dof) - 0.5 * math.log(dof * math.pi)
    use_tail = p > 0.75
    target = 1.0 - p if use_tail else p - 0.5

    def excess(t: float) -> float:
        """How far t's probability is from the target, signed: > 0 when t is below the root."""
        x, y = dof / (dof + t * t), t * t / (dof + t * t)
        if use_tail:
            return 0.5 * betainc(0.5 * dof, 0.5, x, y) - target
        return target - 0.5 * betainc(0.5, 0.5 * dof, y, x)

    def density(t: float) -> float:
        return math.exp(log_norm - half * math.log1p(t * t / dof))

    low, high = 0.0, 1.0
    while excess(high) > 0.0:  # double until the root is bracketed
        low, high = high, 2.0 * high
    t = 0.5 * (low + high)
    for _ in range(200):
        gap = excess(t)
        if gap > 0.0:
            low = t
        else:
            high = t
        following = t + gap / density(t)
        if not low < following < high:  # Newton left the bracket: bisect
            following = 0.5 * (low + high)
        if abs(following - t) <= 2.0 * _EPS * abs(following) or following in (low, high):
            return following
        t = following
    return t


_EPS = 2.220446049250313e-16  # float64 machine epsilon


def betainc(a: float, b: float, x: float, y: float) -> float:
    """Regularized incomplete beta function `I_x(a, b)`, given `x` and `y = 1 - x` (each as
    accurate as the caller can make it: `log x` and `log y` come from the smaller one).

    Continued fraction evaluated by the modified Lentz method (Numerical Recipes, 3rd ed.,
    Eq. 6.4.5 and §5.2), with `I_x(a, b) = 1 - I_y(b, a)` where it converges slowly
    (x > (a + 1) / (a + b + 2)).
    """
    if x <= 0.0:
        return 0.0
    if y <= 0.0:
        return 1.0
    if x > (a + 1.0) / (a + b + 2.0):
        return 1.0 - betainc(b, a, y, x)
    log_x = math.log(x) if x < 0.5 else math.log1p(-y)
    log_y = math.log(y) if y < 0.5 else math.log1p(-x)
    front = math.exp(math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * log_x + b * log_y)
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
    d = 1.0 / (d if abs(d) > tiny else tiny)
    fraction = d
    for m in range(1, 100_000):
        two_m = 2 * m
        for numerator in (
            m * (b - m) * x / ((a + two_m - 1.0) * (a + two_m)),
            -(a + m) * (a + b + m) * x / ((a + two_m) * (a + two_m + 1.0)),
        ):
            d = 1.0 + numerator * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + numerator / c
            c = c if abs(c) > tiny else tiny
            fraction *= c * d
        if abs(c * d - 1.0) <= _EPS:
            break
    return front * fraction / a
