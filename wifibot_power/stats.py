"""Small statistics shared by fit and diagnose: Student's t quantile, one least-squares path
with t, F and lack-of-fit tests. Nothing here loads scipy: the p-values come from one
regularised incomplete beta function (`betainc`; importing scipy.special cost ~0.27 s of
every diagnose, and fit must start quickly).

Ordinary least squares `y = X b + e` (e.g. Montgomery & Runger, Applied Statistics,
§12-1/12-2): `b = (XᵀX)⁻¹ Xᵀ y`, `s² = SSE / (n - p)`, `se(b_j) = s sqrt((XᵀX)⁻¹_jj)`,
t statistic `b_j / se(b_j)` with n - p degrees of freedom.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class OLS:
    """The one least-squares result every fit in wbpower uses (fit's lines, every cause's
    design, the residual tests of diagnose): coefficients with standard errors, 95% t
    intervals (one t quantile, `t_quantile`), R², F tests (overall and nested) and the
    lack-of-fit test against pure error from replicates."""

    coef: np.ndarray
    se: np.ndarray
    dof: int
    residual: np.ndarray
    #: numerical rank of the design, and its condition number after scaling each column to
    #: unit length (Belsley, Kuh & Welsch, Regression Diagnostics, 1980, §3.3)
    rank: int = 0
    condition: float = float("nan")
    #: total sum of squares about the mean of y [y²]
    sst: float = float("nan")

    @property
    def sse(self) -> float:
        return float(self.residual @ self.residual)

    @property
    def n(self) -> int:
        return int(self.residual.size)

    @property
    def p(self) -> int:
        return int(self.coef.size)

    @property
    def estimable(self) -> bool:
        """Every coefficient identifiable: full rank, a condition number below 1e8 (beyond
        it, 1e-8 relative noise in the data moves some coefficient by 100%), and at least
        one degree of freedom left."""
        return (
            self.rank == self.p and np.isfinite(self.condition) and self.condition < 1e8
        ) and self.dof >= 1

    @property
    def r2(self) -> float:
        """1 - SSE / SST (NaN when y is constant or no degrees of freedom are left)."""
        if self.dof < 1 or not self.sst > 0:
            return float("nan")
        return 1.0 - self.sse / self.sst

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
        return t_sf(float(self.coef[j] / self.se[j]), self.dof)

    def p_two_sided(self, j: int) -> float:
        """p-value of H0: b_j = 0 against b_j != 0 (NaN when not identifiable)."""
        if self.dof < 1 or not np.isfinite(self.se[j]):
            return float("nan")
        if self.se[j] == 0:
            return 0.0 if self.coef[j] != 0 else 1.0
        return min(1.0, 2.0 * t_sf(abs(float(self.coef[j] / self.se[j])), self.dof))

    def f_test(self, restricted: OLS) -> float:
        """p-value of the F test of this fit against a `restricted` one nested in it (its
        columns a subset of these, on the same y): does the extra part explain anything?"""
        df1 = restricted.dof - self.dof
        if df1 < 1 or self.dof < 1 or not self.sse > 0:
            return float("nan")
        f = ((restricted.sse - self.sse) / df1) / (self.sse / self.dof)
        return f_sf(max(f, 0.0), df1, self.dof)

    def lack_of_fit(self, groups: np.ndarray) -> tuple[float, int, int]:
        """Lack-of-fit F test against pure error (Montgomery & Runger §11-7.1, Draper &
        Smith §2.1): rows with the same `groups` label are replicates of one configuration;
        SSE = SS_pure_error (spread within configurations, n - m dof) + SS_lack_of_fit
        (m - rank dof). Returns (p-value, lack-of-fit dof, pure-error dof); NaN p when
        there are no replicates or no dof for lack of fit."""
        labels = np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
        m = int(labels.max()) + 1 if labels.size else 0
        df_pe = self.n - m
        df_lof = m - self.rank
        if df_pe < 1 or df_lof < 1:
            return float("nan"), max(df_lof, 0), max(df_pe, 0)
        y_hat_free = np.bincount(labels, weights=self.residual) / np.bincount(labels)
        ss_pe = float(np.sum((self.residual - y_hat_free[labels]) ** 2))
        ss_lof = max(self.sse - ss_pe, 0.0)
        if ss_pe <= 0:
            return (0.0 if ss_lof > 0 else 1.0), df_lof, df_pe
        return f_sf((ss_lof / df_lof) / (ss_pe / df_pe), df_lof, df_pe), df_lof, df_pe


def ols(X: np.ndarray, y: np.ndarray) -> OLS:
    """Least squares `y = X b + e` with standard errors; rank-deficient designs, or no
    degrees of freedom, give NaN errors (so never a false significance)."""
    X = np.asarray(X, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n, p = X.shape
    norms = np.sqrt(np.sum(X * X, axis=0))
    scaled = X / np.where(norms > 0, norms, 1.0)
    coef, _, rank, singular = np.linalg.lstsq(X, y, rcond=None)
    scaled_singular = np.linalg.svd(scaled, compute_uv=False) if n and p else np.zeros(0)
    condition = (
        float(scaled_singular[0] / scaled_singular[-1])
        if scaled_singular.size and scaled_singular[-1] > 0
        else float("inf")
    )
    del singular
    residual = y - X @ coef
    dof = n - p
    sst = float(np.sum((y - y.mean()) ** 2)) if n else float("nan")
    if rank < p or dof < 1:
        return OLS(coef, np.full(p, np.nan), max(dof, 0), residual, int(rank), condition, sst)
    s2 = float(residual @ residual) / dof
    cov = s2 * np.linalg.pinv(X.T @ X)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    return OLS(coef, se, dof, residual, int(rank), condition, sst)


def one_sample_p_greater(values: np.ndarray) -> tuple[float, float, float]:
    """Mean, its standard error and the one-sided p-value of mean > 0 (Student's t): the
    least squares of the finite values on a constant."""
    x = np.asarray(values, dtype=np.float64)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return (float(x.mean()) if x.size else float("nan"), float("nan"), float("nan"))
    fit = ols(np.ones((x.size, 1)), x)
    return float(fit.coef[0]), float(fit.se[0]), fit.p_greater(0)


def t_sf(t: float, dof: float) -> float:
    """P(T > t) for Student's t with `dof` degrees of freedom: 1/2 I_{dof/(dof+t²)}(dof/2,
    1/2) for t > 0 (A&S 26.7.1), by symmetry for t < 0."""
    if not (dof > 0) or math.isnan(t):
        return float("nan")
    if math.isinf(t):
        return 0.0 if t > 0 else 1.0
    t2 = t * t
    # importing scipy.special for stdtr cost ~0.27 s of every diagnose: `betainc` is ours
    half_tail = 0.5 * betainc(0.5 * dof, 0.5, dof / (dof + t2), t2 / (dof + t2))
    return half_tail if t > 0 else 1.0 - half_tail


def f_sf(f: float, df1: float, df2: float) -> float:
    """P(F > f) for Fisher's F with (df1, df2) degrees of freedom: I_{df2/(df2+df1 f)}(df2/2,
    df1/2) (A&S 26.6.2)."""
    if not (df1 > 0 and df2 > 0) or math.isnan(f):
        return float("nan")
    if f <= 0:
        return 1.0
    if math.isinf(f):
        return 0.0
    return betainc(0.5 * df2, 0.5 * df1, df2 / (df2 + df1 * f), df1 * f / (df2 + df1 * f))


@functools.lru_cache(maxsize=4096)  # diagnose asks for the same few hundreds of times
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


def average_ranks(x: np.ndarray) -> np.ndarray:
    """Ranks 1..n of `x`, ties given the mean of the ranks they span (what
    `scipy.stats.rankdata(x, "average")` gives, exactly: the ranks are halves)."""
    x = np.asarray(x)
    order = np.argsort(x, kind="mergesort")
    sorted_x = x[order]
    new = np.concatenate(([True], sorted_x[1:] != sorted_x[:-1]))
    dense = np.cumsum(new)[np.argsort(order, kind="mergesort")]
    ends = np.concatenate((np.flatnonzero(new), [new.size]))  # where each tie group starts
    return 0.5 * (ends[dense] + ends[dense - 1] + 1)


def spearman(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Spearman's rank correlation and its two-sided p-value (Student's t with n - 2 degrees
    of freedom on `t = rho sqrt((n - 2) / (1 - rho^2))`), as `scipy.stats.spearmanr`
    computes them, without importing scipy.stats (a second of every `diagnose`). NaN for
    fewer than 2 points, a NaN or a constant input."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if x.size <= 1 or np.isnan(x).any() or np.isnan(y).any():
        return math.nan, math.nan
    if (x == x[0]).all() or (y == y[0]).all():
        return math.nan, math.nan
    rho = np.corrcoef(np.vstack([average_ranks(x), average_ranks(y)]))[1, 0]
    dof = x.size - 2
    with np.errstate(divide="ignore"):  # rho = ±1: t infinite, p 0
        t = rho * np.sqrt(np.clip(dof / ((rho + 1.0) * (1.0 - rho)), 0, None))
    return float(rho), 2 * t_sf(abs(float(t)), dof)


def binomial_at_least(k: int, n: int, p: float) -> float:
    """P(K >= k) for K ~ Binomial(n, p): the regularised incomplete beta I_p(k, n - k + 1)
    (Abramowitz & Stegun 26.5.24); 1 for k <= 0, 0 for k > n."""
    if k <= 0:
        return 1.0
    if k > n:
        return 0.0
    return betainc(k, n - k + 1, p, 1.0 - p)
