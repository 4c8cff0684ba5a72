"""What the drive model's identification (identify.py) reads of its windows: `Moments`, the
sums least squares and its checks need, made either from the windows themselves
(`WindowMoments`: the direct computation) or from per-trip sums made in the workers
(lagsums.py, `SumMoments`: the same numbers up to the order of summation).

Least squares needs X'X and X'y only; the cluster jackknife (identify.py `jackknife`) the same
sums per cluster and each cluster's X_g'u_g; the screens (identify.py `_determined`) each
column's centred sum of squares and in how many clusters its regressor is seen; the loose-term
check (`_honest`) each column's count, sum of squares and the power's spread over the windows
where it is seen. `WindowMoments` computes each of them as the code before the sums did (row
by row), so that it stays the reference the sums are tested against (tests/test_drive_gram.py).
"""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.windows import Windows

#: Mean |yaw rate| [rad/s] a window must have to count as turning, |v| [m/s] as moving, and
#: |a v| [m^2/s^3] as speeding up or braking.
TURNING_RADPS = 0.1
MOVING_MPS = 0.05
ACCELERATING_M2PS3 = 0.02
#: A window's regressor is "seen" (clearly non-zero) above these (identify.py; the constant,
#: the step and the shares: over half).
SEEN_ABOVE = {
    "idle_W": 0.5,
    "drive_on_W": 0.5,
    "rolling_W_per_mps": MOVING_MPS,
    "quadratic_W_per_mps2": MOVING_MPS**2,
    "effective_mass_kg": ACCELERATING_M2PS3,
    "braking_mass_kg": ACCELERATING_M2PS3,
    "turning_Nm": TURNING_RADPS,
    "turning_coulomb_W": 0.5,
}


def term_of(column: str) -> str:
    """A design column's term name (`rolling_W_per_mps[grass]` -> `rolling_W_per_mps`)."""
    return column.split("[", 1)[0]


def seen_columns(design: np.ndarray, columns: tuple[str, ...]) -> np.ndarray:
    """bool (windows x columns): where each column's regressor is clearly non-zero."""
    threshold = np.array([SEEN_ABOVE[term_of(c)] for c in columns])
    return np.abs(design) > threshold


def cluster_jackknife(
    gram: np.ndarray, grams: np.ndarray, scores: np.ndarray
) -> tuple[np.ndarray, int, int]:
    """The cluster jackknife covariance (CR3; Cameron & Miller 2015, Sec. VI.B; MacKinnon,
    Nielsen & Webb 2023, "Cluster-robust inference: a guide to empirical practice", J.
    Econometrics 232(2), Eq. 19) from X'X (`gram`), each cluster's X_g'X_g (`grams`) and
    X_g'u_g (`scores`): (G-1)/G sum_g (d_g - mean d)(d_g - mean d)' with d_g the change of
    the coefficients when cluster g is left out, d_g = (X'X - X_g'X_g)^-1 X_g'u_g (exact for
    least squares; p x p solves only). A cluster without which the design is singular (the
    only run turning on a surface): the pseudo-inverse, which leaves that direction out of
    its change. Returns the covariance, G - 1 and G."""
    G = grams.shape[0]
    left_out = gram[None, :, :] - grams
    changes = np.einsum("gij,gj->gi", np.linalg.pinv(left_out), scores)
    centred = changes - changes.mean(axis=0)
    return (G - 1) / G * centred.T @ centred, G - 1, G


def least_squares(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least squares by the normal equations of unit-norm columns (a few columns, thousands of
    rows: ~50x faster than an SVD here, and as exact at these condition numbers); the
    pseudo-inverse where a column is a combination of others."""
    return _normal_equations(X)(y)


def _normal_equations(X: np.ndarray):
    """`least_squares(X, .)` with X factorised once: a function of y."""
    scale = np.sqrt(np.sum(np.square(X), axis=0))
    scale[scale == 0] = 1.0
    A = X / scale
    inverse = np.linalg.pinv(A.T @ A)
    return lambda y: (inverse @ (A.T @ y)) / scale


def _gram_solve(xx: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """`least_squares` from X'X and X'y: the same unit-norm scaling and pseudo-inverse
    (the same numbers up to the order of summation of the sums)."""
    scale = np.sqrt(np.diag(xx)).copy()
    scale[scale == 0] = 1.0
    return (np.linalg.pinv(xx / np.outer(scale, scale)) @ (xy / scale)) / scale


class WindowMoments:
    """`Moments` of `windows` (rows) with `clusters` (per window), computed from the rows."""

    def __init__(self, windows: Windows, clusters: np.ndarray) -> None:
        self.windows = windows
        self.clusters = clusters
        self.columns = windows.columns
        self.force_form = windows.force_form
        proxy = windows.proxy if windows.proxy is not None else np.zeros(windows.size, bool)
        self.proxy_any = bool(proxy.any())
        self.proxy_all = bool(proxy.size and proxy.all())
        self.n = windows.size
        self.gram = windows.design.T @ windows.design
        self.residual_W: np.ndarray | None = None
        self._seen = seen_columns(windows.design, windows.columns)

    def seen_clusters(self) -> np.ndarray:
        """Per column: the clusters with a window where its regressor is seen."""
        return np.array(
            [np.unique(self.clusters[seen]).size if seen.any() else 0 for seen in self._seen.T]
        )

    def centred_ss(self, j: int) -> float:
        """Column j's sum of squares about its mean."""
        x = self.windows.design[:, j]
        return float(np.sum(np.square(x - x.mean())))

    def gram_xy(self, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """X'X and X'y of the `kept` columns."""
        X = self.windows.design[:, kept]
        return X.T @ X, X.T @ self.windows.power_W

    def unbounded(self, kept: np.ndarray) -> np.ndarray:
        """Least squares without bounds on the `kept` columns (`least_squares`)."""
        return least_squares(self.windows.design[:, kept], self.windows.power_W)

    def jackknife_sums(self, kept: np.ndarray, coef_k: np.ndarray):
        """(X'X, X_g'X_g, X_g'u_g) of the jackknife's design: the kept columns and, when the
        fitted power moves with the lag, the lag's column (identify.py `_fit_kept`); None
        when the covariance cannot be made (G < 2, n <= p). Sets `residual_W`."""
        windows = self.windows
        Xk = windows.design[:, kept]
        residual = windows.power_W - Xk @ coef_k
        self.residual_W = residual
        lag_column = windows.design_rate[:, kept] @ coef_k
        X = np.column_stack((Xk, lag_column)) if np.any(lag_column) else Xk
        n, p = X.shape
        groups, inverse = np.unique(self.clusters, return_inverse=True)
        G = groups.size
        if p == 0 or G < 2 or n <= p:
            return None, p, G
        # per-cluster sums X_g'X_g and X_g'u_g, a cluster's rows at a time (a loop over
        # clusters, not rows: one matrix product each, without an n x p x p temporary)
        order = np.argsort(inverse, kind="stable")
        ends = np.cumsum(np.bincount(inverse, minlength=G))
        scores = np.zeros((G, p))
        grams = np.zeros((G, p, p))
        for g, rows in enumerate(np.split(order, ends[:-1])):
            Xg = X[rows]
            grams[g] = Xg.T @ Xg
            scores[g] = Xg.T @ residual[rows]
        return (X.T @ X, grams, scores), p, G

    def seen_spread(self, j: int, idle: bool) -> tuple[int, float, float]:
        """Over the windows where column j is seen: their count, the regressor's root mean
        square, and the power's mean |.| (`idle`) or standard deviation [W]."""
        seen = self._seen[:, j]
        count = int(seen.sum())
        if count == 0:
            return 0, np.nan, np.nan
        typical = float(np.sqrt(np.mean(np.square(self.windows.design[seen, j]))))
        power = self.windows.power_W[seen]
        spread = float(np.mean(np.abs(power))) if idle else float(np.std(power))
        return count, typical, spread
