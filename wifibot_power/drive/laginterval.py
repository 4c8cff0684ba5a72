"""The lag's 95% interval (identify.py's lag search, cli.md "The drive model": a term the logs
cannot determine is reported so, never given a number that only looks exact).

Method: a cluster bootstrap of the lag search itself (Efron & Tibshirani 1993, "An
Introduction to the Bootstrap", Ch. 13, the percentile interval; clusters resampled whole:
Cameron, Gelbach & Miller 2008, "Bootstrap-based improvements for inference with clustered
errors", Rev. Econ. Stat. 90(3), the pairs cluster bootstrap). Each replicate draws G clusters
(runs, or trips when the fit's intervals are by trip: model.py `MIN_RUN_CLUSTERS`) with
replacement out of the G, sums their lag-search sums (gram.py `FoldGrams`, a "fold" a cluster:
X'X, X'Y at each whole lag, Y's band, the noise of the inertial columns) with the draw's counts
as weights, and searches the lag as the fit does (the corrected least squares' sum of squares
at each whole lag, refined to a fraction of a bin: gram.py `refine_lag`, here for every
replicate at once). The interval is the 2.5% and 97.5% quantiles of the replicates' lags,
widened about the lag found by t(0.975, G - 1) / z(0.975) x sqrt(G / (G - 1)): with few
clusters the bootstrap's spread is the (G - 1)/G-biased one (CR0's, not CR1's) and its
quantiles are normal-like where the intervals of G clusters need Student's t with G - 1
degrees of freedom (Cameron & Miller 2015, Sec. VI.A and VI.C: the corrections the terms'
intervals get, identify.py). 1.17 for 12 clusters, 1.58 for 5.

Why not the joint sandwich's own lag variance (identify.py `lag_var_s2`, lag +- t(G - 1) SE):
measured against this bootstrap (docs/drive-model.md, "The lag's interval"), it held the
simulator's true lag in 99.5% of seeds at 20 Hz (too wide) and 77% at lab (too narrow),
against 97% and 86%; and where the criterion is flat, a linearisation at the minimum gives a
symmetric interval past both ends of the lags tried (BorealTC sandy loam: 0.61 +- 1.36 s)
where the replicates show the criterion's two minima.

Not determined (`LagInterval.determined`): (1) the interval is wider than half the lags tried
(`UNDETERMINED_SHARE`): the logs cannot tell in which half of the search range the lag lies
(one reaching both ends is a case of it); (2) it reaches the longest lag tried: the search's
upper end (identify.py `MAX_LAG_S`) is a choice, not physics, so an interval cut there has
no upper end of its own (the lag may be longer). Its lower end reaching 0 is not a reason:
0 is the physical bound (the power does not answer a speed before it), as 0 bounds the
non-negative terms' intervals. (3) Fewer than 2 clusters: no interval. The lag the model
applies is still the search's minimum (predictions use it; the held-out energies are the
same), and the not-determined entry says so.

Cost: all replicates' solves at once (B x p x p: numpy's stacked inverse, its pseudo-inverse
where a replicate's Gram is singular), never a pass over the windows: the sums are the
fit's, a few arrays of clusters x p x lags (1.1-1.7% of `fit` of a 202-run corpus).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.lagsums import SumsTable
from wifibot_power.drive.windows import RunWindows
from wifibot_power.stats import t_quantile

#: Bootstrap replicates: the 2.5% quantile of 1000 draws is off by ~0.5 percentile points
#: (the count of draws below it is binomial, sd sqrt(1000 x 0.025 x 0.975) = 4.9; Efron &
#: Tibshirani 1993 ask about 1000 for percentile intervals).
REPLICATES = 1000
#: The lag is not determined when its 95% interval spans more than this share of the lags
#: tried (0 to `identify.MAX_LAG_S`): the logs cannot tell which half of the range holds it.
UNDETERMINED_SHARE = 0.5


@dataclass(frozen=True)
class LagInterval:
    """The lag's 95% interval [s] from `replicates` cluster-bootstrap replicates of the lag
    search over the lags `grid_s` (the first and last tried)."""

    lag_s: float
    ci95_s: tuple[float, float]
    grid_s: tuple[float, float]
    replicates: int
    clusters: int

    @property
    def determined(self) -> bool:
        """False when there is no interval (fewer than 2 clusters), when it spans more than
        `UNDETERMINED_SHARE` of the lags tried, or when it reaches the longest lag tried (module
        docstring)."""
        return self._why() is None

    def _why(self) -> str | None:
        """Why the lag is not determined (every rule that applies), None when it is."""
        low, high = self.ci95_s
        first, last = self.grid_s
        if self.clusters == 0:  # the search's own sums are empty: it returned its first lag
            return (
                f"not searched: no window has a power at every lag tried ({first:.2f}-"
                f"{last:.2f} s; runs too short, or cut by drop-outs)"
            )
        if not (np.isfinite(low) and np.isfinite(high)):
            if self.clusters < 2:
                return f"no interval ({self.clusters} cluster: at least 2 are needed)"
            # clusters enough, but fewer than 2 resampled searches could be solved
            return (
                f"no interval (only {self.replicates} bootstrap replicate(s) of "
                f"{self.clusters} clusters could be searched: too few windows for the columns)"
            )
        span = last - first
        why = []
        if high - low > UNDETERMINED_SHARE * span:
            why.append(
                f"spans {100 * (high - low) / span:.0f}% of the lags tried "
                f"({first:.2f}-{last:.2f} s; over {100 * UNDETERMINED_SHARE:.0f}%: these logs "
                "hold little that times a change of speed against the power, e.g. no start "
                "from rest)"
            )
        if high >= last - 1e-9 * span:
            why.append(
                f"reaches the longest lag tried ({last:.2f} s: these logs do not bound it from "
                "above; the search stops there)"
            )
        if not why:
            return None
        return f"its 95% interval [{low:.2f}, {high:.2f}] s " + " and ".join(why)

    def reason(self) -> str | None:
        """The `not_determined` entry (None when determined)."""
        why = self._why()
        if why is None:
            return None
        how = f" (cluster bootstrap of the search over {self.clusters} clusters)"
        used = "" if self.clusters == 0 else "the lag search's minimum, "
        return f"lag_s: not determined, {why}; the predictions use {used}{self.lag_s:.2f} s" + (
            how if self.replicates else ""
        )


def lag_interval(
    grams: FoldGrams,
    lag_bins: float,
    bin_s: float,
    seed: int = 0,
    replicates: int = REPLICATES,
) -> LagInterval:
    """`LagInterval` from the lag search's sums per cluster (`grams`, a fold a cluster) and the
    lag the fit found (`lag_bins`, for the entry's wording): module docstring."""
    G = grams.folds
    grid = (float(grams.lags[0]) * bin_s, float(grams.lags[-1]) * bin_s)
    if G < 2:
        return LagInterval(lag_bins * bin_s, (np.nan, np.nan), grid, 0, G)
    rng = np.random.default_rng(seed)
    weights = rng.multinomial(G, np.full(G, 1.0 / G), size=replicates).astype(float)
    lags = searches(grams, weights)
    found = lags[np.isfinite(lags)]
    if found.size < 2:
        return LagInterval(lag_bins * bin_s, (np.nan, np.nan), grid, found.size, G)
    low, high = np.quantile(found, [0.025, 0.975])
    # the few-clusters correction (module docstring), about the lag found (held within the
    # quantiles: a replicate distribution of two modes may leave it out), within the grid
    # a replicate at the grid's first lag is not refined (gram.py `refine_lag`): known to half
    # a bin, so an interval of such replicates alone ([0, 0]) reaches half a bin
    high = max(high, float(grams.lags[0]) + 0.5)
    centre = min(max(lag_bins, low), high)
    widen = few_clusters_factor(G)
    low = max(centre - widen * (centre - low), float(grams.lags[0]))
    high = min(centre + widen * (high - centre), float(grams.lags[-1]))
    return LagInterval(lag_bins * bin_s, (low * bin_s, high * bin_s), grid, found.size, G)


def few_clusters_factor(clusters: int) -> float:
    """How much wider than the bootstrap's percentiles the interval is with G clusters:
    t(0.975, G - 1) / z(0.975) x sqrt(G / (G - 1)) (module docstring; 1.17 for 12)."""
    G = clusters
    return t_quantile(0.975, G - 1) / t_quantile(0.975, 10**9) * math.sqrt(G / (G - 1))


def cluster_grams_of_table(table: SumsTable, by_run: bool, lags: np.ndarray) -> FoldGrams:
    """The lag search's sums per cluster (runs, or trips) from the batch's per-trip sums: the
    clusters with a window in the search (common windows), a fold each."""
    cluster = table.run_of_trip if by_run else np.arange(table.trips)
    return _clusters_of(cluster, table.count > 0, lambda fold, k: table.fold_grams(fold, k, lags))


def cluster_grams_of_windows(
    runs: list[RunWindows], surfaces: tuple[str, ...], by_run: bool, lags: np.ndarray
) -> FoldGrams:
    """`cluster_grams_of_table` from the windows (the fit over windows: model.py `direct`)."""
    base = np.concatenate(([0], np.cumsum([int(rw.trip[-1]) + 1 for rw in runs])))
    cluster = np.concatenate(
        [np.full(rw.count, r) if by_run else rw.trip + base[r] for r, rw in enumerate(runs)]
    )
    grams = FoldGrams.from_windows(runs, surfaces, cluster, int(cluster.max()) + 1, lags)
    keep = grams.count > 0
    return FoldGrams(
        grams.count[keep], grams.xx[keep], grams.xy[keep], grams.yy[keep], lags, grams.noise[keep]
    )


def _clusters_of(cluster: np.ndarray, has_windows: np.ndarray, grams_of) -> FoldGrams:
    """`grams_of(fold_of_trip, folds)` with a fold per cluster that has windows (-1: none)."""
    numbers, fold = np.unique(cluster[has_windows], return_inverse=True)
    fold_of_trip = np.full(cluster.size, -1)
    fold_of_trip[has_windows] = fold
    return grams_of(fold_of_trip, numbers.size)


def searches(grams: FoldGrams, weights: np.ndarray) -> np.ndarray:
    """The lag search (gram.py `FoldGrams.search`, `refine_lag`) [bins] of each row of
    `weights` (replicates x folds: each fold's sums counted that many times), all at once; NaN
    where no lag has a sum of squares."""
    return _Replicates(grams, weights).refined()


class _Replicates:
    """Every replicate's lag-search sums and least-squares inverse (`FoldGrams.search`'s, a
    stack of them)."""

    def __init__(self, grams: FoldGrams, weights: np.ndarray) -> None:
        self.lags = grams.lags
        B, (G, p, L) = weights.shape[0], grams.xy.shape
        xx = (weights @ grams.xx.reshape(G, p * p)).reshape(B, p, p)
        self.xy = (weights @ grams.xy.reshape(G, p * L)).reshape(B, p, L)
        self.yy = (weights @ grams.yy.reshape(G, 2 * L)).reshape(B, 2, L)
        noise = weights @ grams.noise
        n = weights @ grams.count
        diagonal = np.diagonal(xx, axis1=1, axis2=2)
        usable = diagonal != 0
        # corrected_gram (gram.py): X'X less the noise where that stays positive definite
        scale = np.sqrt(np.clip(diagonal, 0, None))
        scale[scale == 0] = 1.0
        fixed = xx - noise[:, :, None] * np.eye(p)
        scaled = fixed / (scale[:, :, None] * scale[:, None, :])
        both = usable[:, :, None] & usable[:, None, :]
        probe = np.where(both, scaled, 0.0) + np.where(usable, 0.0, 1.0)[:, :, None] * np.eye(p)
        positive = _positive_definite(probe + 1e-12 * np.eye(p))
        corrected = np.where(positive[:, None, None] & noise.any(axis=1)[:, None, None], fixed, xx)
        corrected = np.where(both, corrected, 0.0)
        self.xx = corrected
        scale = np.sqrt(np.clip(np.diagonal(corrected, axis1=1, axis2=2), 0, None))
        scale[scale == 0] = 1.0
        self.scale = scale
        # a column no window of the replicate holds (a surface none of its clusters drove on):
        # 1 on the diagonal, so its coefficient is 0 (its X'y is) and the rest are pinv's
        filled = corrected / (scale[:, :, None] * scale[:, None, :])
        filled += np.where(usable, 0.0, 1.0)[:, :, None] * np.eye(p)
        self.inverse = _inverse(filled)
        #: a replicate whose windows are no more than its usable columns has no sum of squares
        self.fits = n > usable.sum(axis=1)
        self.B = B

    def _sse(self, b_yy: np.ndarray, b_xy: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The corrected sums of squares of replicates `rows` with y'y `b_yy` and X'y `b_xy`."""
        scale = self.scale[rows]
        coef = np.einsum("bij,bj->bi", self.inverse[rows], b_xy / scale) / scale
        sse = b_yy - 2.0 * np.sum(coef * b_xy, axis=1)
        sse += np.einsum("bi,bij,bj->b", coef, self.xx[rows], coef)
        return np.where(self.fits[rows], sse, np.inf)

    def whole(self) -> np.ndarray:
        """Each replicate's sum of squares at each whole lag (B x L): `_sse`, every lag at
        once."""
        scale = self.scale[:, :, None]
        coef = (self.inverse @ (self.xy / scale)) / scale
        sse = self.yy[:, 0] - 2.0 * np.sum(coef * self.xy, axis=1)
        sse += np.sum(coef * (self.xx @ coef), axis=1)
        return np.where(self.fits[:, None], sse, np.inf)

    def at(self, lag: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """The sums of squares of replicates `rows` at lags `lag` [bins] (between whole lags:
        FoldGrams.search's `sse_at`)."""
        whole = np.floor(lag).astype(int)
        part = lag - whole
        part = np.where(part <= 1e-9, 0.0, part)
        upper = np.minimum(whole + 1, self.lags.size - 1)
        yy, xy = self.yy[rows], self.xy[rows]
        pick = np.arange(rows.size)
        b_yy = (
            (1 - part) ** 2 * yy[pick, 0, whole]
            + 2 * part * (1 - part) * yy[pick, 1, whole]
            + part**2 * yy[pick, 0, upper]
        )
        b_xy = (1 - part)[:, None] * xy[pick, :, whole] + part[:, None] * xy[pick, :, upper]
        return self._sse(b_yy, b_xy, rows)

    def refined(self) -> np.ndarray:
        """`refine_lag` for every replicate (gram.py): the best whole lag, then the quartic's
        minimum through the five around it, or near the grid's ends the parabola refined
        twice through the points half a bin either side."""
        sse = self.whole()
        L = self.lags.size
        out = np.full(self.B, np.nan)
        finite = np.isfinite(sse)
        some = finite.any(axis=1)
        best = np.argmin(np.where(finite, sse, np.inf), axis=1)
        out[some] = self.lags[best[some]]
        pad = np.pad(finite, ((0, 0), (2, 2)))
        window = np.stack([pad[np.arange(self.B), best + 2 + k] for k in range(-2, 3)], axis=1)
        quartic = some & (best > 1) & (best < L - 2) & window.all(axis=1)
        parabola = some & ~quartic & (best > 0) & (best < L - 1) & window[:, 1:4].all(axis=1)
        if quartic.any():
            rows = np.flatnonzero(quartic)
            values = sse[rows[:, None], best[rows, None] + np.arange(-2, 3)]
            out[rows] = best[rows] + _quartic_minima(values)
        if parabola.any():
            rows = np.flatnonzero(parabola)
            out[rows] = self._parabola(rows, best[rows], sse)
        return out

    def _parabola(self, rows: np.ndarray, best: np.ndarray, sse: np.ndarray) -> np.ndarray:
        """`refine_lag`'s parabola through the best whole lag and its neighbours, refined
        through the points half a bin either side (twice), for replicates `rows`."""
        centre = best.astype(float)
        values = sse[rows[:, None], best[:, None] + np.arange(-1, 2)]
        step = 1.0
        going = np.ones(rows.size, dtype=bool)
        for _ in range(2):
            below, at, above = values.T
            curvature = below - 2 * at + above
            going &= curvature > 0
            shift = np.clip(0.5 * (below - above) / np.where(going, curvature, 1.0), -0.5, 0.5)
            centre = np.where(going, centre + step * shift, centre)
            step /= 2
            points = centre[:, None] + step * np.array([-1.0, 0.0, 1.0])
            values = np.column_stack([self.at(points[:, k], rows) for k in range(3)])
        return centre


def _positive_definite(a: np.ndarray) -> np.ndarray:
    """bool per matrix of the stack `a`: its Cholesky factor exists (gram.py
    `corrected_gram`'s test), the whole stack at once unless one fails."""
    try:
        np.linalg.cholesky(a)
        return np.ones(a.shape[0], dtype=bool)
    except np.linalg.LinAlgError:
        return np.linalg.eigvalsh(a)[:, 0] > 0


def _inverse(a: np.ndarray) -> np.ndarray:
    """`np.linalg.pinv` of a stack of symmetric matrices (`FoldGrams.search`'s): the plain
    inverse when every one is positive definite (the same up to rounding, ~20x faster),
    else from their eigenvalues (`_symmetric_pinv`)."""
    try:
        np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        return _symmetric_pinv(a)
    return np.linalg.inv(a)


def _symmetric_pinv(a: np.ndarray) -> np.ndarray:
    """`np.linalg.pinv` of a stack of symmetric matrices from their eigenvalues (|eigenvalue|
    the singular value; the same cut-off, 1e-15 of the largest): ~3x faster than the SVD."""
    values, vectors = np.linalg.eigh(a)
    size = np.abs(values)
    keep = size > 1e-15 * size.max(axis=1, keepdims=True)
    inverse = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    return np.einsum("bij,bj,bkj->bik", vectors, inverse, vectors)


def _quartic_minima(values: np.ndarray) -> np.ndarray:
    """gram.py `_quartic_minimum` for many rows of five sums of squares (at -2..2 bins from
    the best whole lag): the offset in [-1, 1] where the quartic through them is least, each
    row's candidates the ends and the real roots of its cubic derivative inside (the
    eigenvalues of its companion matrix, every row's at once)."""
    x = np.arange(-2.0, 3.0)
    c = np.linalg.solve(np.vander(x, 5, increasing=True), values.T).T  # c0..c4 per row
    d = c[:, 1:] * np.arange(1.0, 5.0)  # the derivative's d0..d3
    candidates = np.full((c.shape[0], 5), np.nan)
    candidates[:, 0], candidates[:, 1] = -1.0, 1.0
    cubic = np.abs(d[:, 3]) > 1e-300
    if cubic.any():
        lead = d[cubic, 3]
        companion = np.zeros((int(cubic.sum()), 3, 3))
        companion[:, 1, 0] = companion[:, 2, 1] = 1.0
        companion[:, :, 2] = -d[cubic, :3] / lead[:, None]
        roots = np.linalg.eigvals(companion)
        real = (np.abs(roots.imag) < 1e-9) & (np.abs(roots.real) <= 1)
        candidates[cubic, 2:] = np.where(real, roots.real, np.nan)
    for i in np.flatnonzero(~cubic):  # a derivative of lower degree (never seen): one by one
        roots = np.polynomial.Polynomial(d[i]).roots()
        inside = [r.real for r in roots if abs(r.imag) < 1e-9 and abs(r.real) <= 1][:3]
        candidates[i, 2 : 2 + len(inside)] = inside
    powers = candidates[:, :, None] ** np.arange(5.0)
    at = np.einsum("bkj,bj->bk", powers, c)
    best = np.nanargmin(np.where(np.isnan(candidates), np.inf, at), axis=1)
    return candidates[np.arange(c.shape[0]), best]
