"""The held-out check's lag searches from sufficient statistics (heldout.py). A fold's lag search
(identify.py, `lag_search`) fits the same design (the windows defined at every lag, lag 0's
regressors) to the power at each lag, on the windows of the other folds' trips. Least squares
needs only X'X, X'y and y'y: each fold's sums are made once, in one pass over the windows, for
every whole lag (Y the power at each whole lag, a column each: X'Y and Y'Y); a fold's fit at a
lag is then a p x p problem on the sum of the other folds' sums, whatever the number of
windows. A lag between two whole bins is linear between them (windows.py, `between_bins`:
y = (1 - t) y_w + t y_w+1), so its X'y and y'y are the same combination of the whole lags'
(the cross-products Y'Y included). The solve is `moments._normal_equations`' (unit-norm
columns, the pseudo-inverse of the scaled Gram), the sum of squares y'y - 2 b'X'y + b'X'X b
(Lawson & Hanson 1974, "Solving Least Squares Problems", Ch. 1: the normal equations): the
same numbers as the direct search up to the order of summation (benchmarks/gram_equal.py)
unless the fit is so close that the subtraction loses the digits (`CANCELLATION`): then the
direct search.

The criterion is the sum of squares of the *corrected* least squares: X'X less the noise the
speeding-up and braking columns carry (their edge speeds', regressors.py `calibrated`), so
that the lag is judged as with the true regressors (`noise_share`, `corrected_gram`).
"""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.windows import RunWindows, StackedPower, assemble, design_columns

#: The sum of squares from sums, y'y - 2b'X'y + b'X'Xb, loses the digits of y'y over it: below
#: this share of y'y (under ~10 digits left) the search is made over the windows instead. The
#: logs seen are at 2e-4 (the simulator's free driving, sample_logs) to 0.2 (F1/10).
CANCELLATION = 1e-6


#: The columns whose sum of squares holds a known share of noise (regressors.py `reliability`,
#: the two of `RunWindows.reliability` in this order).
NOISY_COLUMNS = ("effective_mass_kg", "braking_mass_kg")


def noise_share(columns: tuple[str, ...], reliability: tuple[float, float]) -> np.ndarray:
    """Per design column, the share of its sum of squares over a run's windows that is noise:
    1 - reliability for the speeding-up and braking columns, 0 for the others (whose noise is
    a window mean's: ~1e-4 of their spread on the simulator)."""
    out = np.zeros(len(columns))
    for name, kept in zip(NOISY_COLUMNS, reliability, strict=True):
        if name in columns:
            out[columns.index(name)] = 1.0 - kept
    return out


def corrected_gram(xx: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """X'X less the regressors' noise, diag(`noise`) (each column's noise sum of squares over
    the windows): the corrected least squares of errors in variables, whose expected X'X is
    the true regressors' (Fuller, "Measurement Error Models", 1987, Sec. 2.2: (M_XX - S_uu)^-1
    M_XY; Carroll et al. 2006, Ch. 3). Why the lag needs it: with noisy columns the sum of
    squares at a lag d from the true one, y'y - (X'y_d)'(X'X + noise)^-1 (X'y_d), is no longer
    symmetric about d = 0. v^2's change over a lag is 2 (a v) times it (d v^2 / dt = 2 a v):
    with (a v) attenuated by its noise, the fit at a shorter lag explains more with v^2 than it
    loses (the simulator at field realism, 40 seeds: the lag 0.1983 s for 0.2, 0.1994 with
    this, exact speeds 0.1999; refined by the parabola, before `_quartic_minimum`: 0.1979,
    0.1990, 0.1995). Plain X'X where the corrected one is not positive definite."""
    if not noise.any():
        return xx
    fixed = xx - np.diag(noise)
    scale = np.sqrt(np.clip(np.diag(xx), 0, None))
    scale[scale == 0] = 1.0
    try:
        np.linalg.cholesky(fixed / np.outer(scale, scale) + 1e-12 * np.eye(xx.shape[0]))
    except np.linalg.LinAlgError:
        return xx
    return fixed


def refine_lag(lags: np.ndarray, sse_at) -> tuple[float, np.ndarray]:
    """The lag search's choice from `sse_at(lag)`, the sum of squares at a lag [bins]: the
    best whole lag of `lags`, then to a fraction of a bin; and each whole lag's sum of squares
    (identify.lag_search over the windows; `FoldGrams.search` from sufficient statistics)."""
    sse = np.array([sse_at(int(lag)) for lag in lags])
    if not np.isfinite(sse).any():
        return 0.0, sse
    best = int(np.argmin(sse))
    if not (0 < best < lags.size - 1 and np.isfinite(sse[best - 1 : best + 2]).all()):
        return float(lags[best]), sse
    # to a fraction of a bin (the inertial terms move by ~10% a bin of lag): the minimum of
    # the quartic through the five whole lags around the best (`_quartic_minimum`), else (the
    # best within two of the grid's ends) the vertex of the parabola through the best and its
    # neighbours, refined through the points half a bin either side
    if 1 < best < lags.size - 2 and np.isfinite(sse[best - 2 : best + 3]).all():
        return _quartic_minimum(best, sse[best - 2 : best + 3]), sse
    step = 1.0
    centre, values = float(best), tuple(sse[best - 1 : best + 2])
    for _ in range(2):
        below, at, above = values
        curvature = below - 2 * at + above
        if not curvature > 0:
            break
        centre += step * float(np.clip(0.5 * (below - above) / curvature, -0.5, 0.5))
        step /= 2
        values = (sse_at(centre - step), sse_at(centre), sse_at(centre + step))
    return centre, sse


def _quartic_minimum(best: int, values: np.ndarray) -> float:
    """The lag [bins] within a bin of the whole lag `best` where the quartic through the sums
    of squares at `best` - 2 ... `best` + 2 (`values`) is least. Whole lags only: between two
    whole bins the power is their mix, whose noise is smaller than either's, so the sum of
    squares dips between whole lags by the power's noise, not by the fit (the exact minimum
    within the bins, a quadratic in the lag in each, was 0.1985 s for 0.2, sd 0.0021, on the
    simulator at field realism, 40 seeds; without any noise 0.2002). The parabola through the
    best three is not the sum of squares' shape a bin away: 0.1991 s without any noise (10
    seeds; refined through the points half a bin either side, 0.1996; this quartic 0.2000),
    and at field realism 0.1985, refined 0.1990 (sd 0.0009), this quartic 0.1994 (sd 0.0010)."""
    poly = np.polynomial.Polynomial.fit(np.arange(-2.0, 3.0), values, 4, domain=[-2, 2])
    poly = poly.convert()
    candidates = [-1.0, 1.0] + [
        float(r.real) for r in poly.deriv().roots() if abs(r.imag) < 1e-9 and -1 <= r.real <= 1
    ]
    return best + min(candidates, key=lambda x: float(poly(x)))


class FoldGrams:
    """Per-fold sums of the lag search's least squares (module docstring): per fold its
    windows (`count`), X'X (`xx`), X'Y (`xy`, a column per whole lag of `lags`), Y's band
    (`yy`: Y_l'Y_l and Y_l'Y_l+1, the two rows; a lag between two whole bins needs no more) and
    each column's noise sum of squares (`noise`, folds x p: `corrected_gram`)."""

    def __init__(
        self,
        count: np.ndarray,
        xx: np.ndarray,
        xy: np.ndarray,
        yy: np.ndarray,
        lags: np.ndarray,
        noise: np.ndarray | None = None,
    ) -> None:
        self.count, self.xx, self.xy, self.yy = count, xx, xy, yy
        self.lags = lags
        self.folds = count.size
        self.noise = np.zeros(xx.shape[:2]) if noise is None else noise

    @classmethod
    def from_windows(
        cls,
        runs: list[RunWindows],
        surfaces: tuple[str, ...],
        fold_of_window: np.ndarray,
        folds: int,
        lags: np.ndarray,
        stacked: StackedPower | None = None,
    ) -> FoldGrams:
        """From the windows: `runs`, `surfaces` as `lag_search`'s; `fold_of_window` per
        stacked window (StackedPower's order) its fold, -1 for none (lagsums.py: from the
        workers' per-trip sums)."""
        stacked = stacked or StackedPower(runs)
        common = stacked.ok.copy()
        powers = [stacked.power_at(int(lag)) for lag in lags]
        for _, defined in powers:
            common &= defined
        X = assemble(runs, 0, surfaces, only=stacked.split(common), stacked=stacked).design
        Y = np.column_stack([power[common] for power, _ in powers])
        fold = fold_of_window[common]
        p, L = X.shape[1], lags.size
        share = window_noise_share(runs, stacked.split(common), X.shape[1], surfaces)
        count = np.zeros(folds, dtype=np.int64)
        xx, xy, yy = np.zeros((folds, p, p)), np.zeros((folds, p, L)), np.zeros((folds, 2, L))
        noise = np.zeros((folds, p))
        for f in range(folds):
            rows = fold == f
            Xf, Yf = X[rows], Y[rows]
            count[f] = int(rows.sum())
            xx[f] = Xf.T @ Xf
            xy[f] = Xf.T @ Yf
            yy[f, 0] = np.sum(np.square(Yf), axis=0)
            yy[f, 1, :-1] = np.sum(Yf[:, :-1] * Yf[:, 1:], axis=0)
            noise[f] = np.sum(share[rows] * np.square(Xf), axis=0)
        return cls(count, xx, xy, yy, lags, noise)

    def search(self, fold: int) -> tuple[float, np.ndarray] | None:
        """`lag_search` on the windows of every fold but `fold`; None when a sum of squares is
        under `CANCELLATION` of y'y (the caller then searches over the windows)."""
        train = np.arange(self.folds) != fold
        xx = self.xx[train].sum(axis=0)
        xy = self.xy[train].sum(axis=0)
        yy = self.yy[train].sum(axis=0)
        n = int(self.count[train].sum())
        usable = np.diag(xx) != 0
        xx = corrected_gram(xx[np.ix_(usable, usable)], self.noise[train].sum(axis=0)[usable])
        xy = xy[usable]
        p = int(usable.sum())
        scale = np.sqrt(np.diag(xx)).copy()
        scale[scale == 0] = 1.0
        inverse = np.linalg.pinv(xx / np.outer(scale, scale))
        last = self.lags.size - 1
        share = [np.inf]  # the smallest sum of squares over y'y seen

        def sse_at(lag: float) -> float:
            if n <= p:
                return np.inf
            whole = int(np.floor(lag))
            part = lag - whole
            weights = np.zeros(self.lags.size)
            if part <= 1e-9:
                weights[whole] = 1.0
                b_yy = float(yy[0, whole])
            else:
                if whole + 1 > last:
                    return np.inf  # never asked: the search stays within its grid
                weights[whole], weights[whole + 1] = 1 - part, part
                b_yy = float(
                    (1 - part) ** 2 * yy[0, whole]
                    + 2 * part * (1 - part) * yy[1, whole]
                    + part**2 * yy[0, whole + 1]
                )
            b_xy = xy @ weights
            coef = (inverse @ (b_xy / scale)) / scale
            sse = float(b_yy - 2.0 * coef @ b_xy + coef @ xx @ coef)
            if b_yy > 0:
                share[0] = min(share[0], sse / b_yy)
            return sse

        found = refine_lag(self.lags, sse_at)
        return found if share[0] >= CANCELLATION else None


def window_noise_share(
    runs: list[RunWindows], only: list[np.ndarray], p: int, surfaces: tuple[str, ...]
) -> np.ndarray:
    """Per window `only` keeps (stacked, `assemble`'s order) and design column: the share of
    its square that is noise (`noise_share` of its run's reliabilities)."""
    columns = design_columns(surfaces)
    rows = [
        np.broadcast_to(noise_share(columns, rw.reliability), (int(np.sum(keep)), p))
        for rw, keep in zip(runs, only, strict=True)
    ]
    return np.concatenate(rows) if rows else np.zeros((0, p))
