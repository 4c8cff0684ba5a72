"""Small statistics shared by the diagnosis: multiple least squares with t-tests.

Ordinary least squares `y = X b + e` (e.g. Montgomery & Runger, Applied Statistics,
§12-1/12-2): `b = (XᵀX)⁻¹ Xᵀ y`, `s² = SSE / (n - p)`, `se(b_j) = s sqrt((XᵀX)⁻¹_jj)`,
t statistic `b_j / se(b_j)` with n - p degrees of freedom.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class OLS:
    coef: np.ndarray
    se: np.ndarray
    dof: int
    residual: np.ndarray

    def ci95(self, j: int) -> tuple[float, float]:
        if self.dof < 1 or not np.isfinite(self.se[j]):
            return (float("nan"), float("nan"))
        t = float(stats.t.ppf(0.975, self.dof))
        return (float(self.coef[j] - t * self.se[j]), float(self.coef[j] + t * self.se[j]))

    def p_greater(self, j: int) -> float:
        """One-sided p-value of H0: b_j <= 0 against b_j > 0; NaN when the design cannot
        tell b_j apart (rank-deficient or no degrees of freedom), never a false 0."""
        if self.dof < 1 or not np.isfinite(self.se[j]):
            return float("nan")
        if self.se[j] == 0:
            return 0.0 if self.coef[j] > 0 else 1.0
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
    return mean, se, float(stats.t.sf(mean / se, x.size - 1))
