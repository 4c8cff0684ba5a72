"""The batch's per-trip sums (sums.py) laid side by side (`SumsTable`), and what a fit at one
lag reads of them (`LagSums`, `SumMoments`): the parent's whole drive fit in p x p work a trip
or a fold, never a pass over the windows (docs/drive-model.md, "From sufficient statistics").

- The lag searches (gram.py `FoldGrams`): each fold's X'X, X'Y and Y's band over the common
  windows of its trips (sums of the trips' sums).
- A fit at a lag l = w + t (t a fraction of a bin; windows.py `between_bins`): the response is
  (1 - t) Y_w + t Y_w+1, so each trip's W'y is the same combination of its W'Y's columns; its
  squares and next-lag products give sum y^2 over the windows where a column is seen. The
  edge windows defined at w (and w + 1) are added as rows.
- `SumMoments` is `moments.WindowMoments` from these sums: X'X and X'y of the training trips,
  each cluster's (run's or trip's) [X R]'[X R] and [X R]'y for the jackknife (its X_g'u_g is
  X_g'y_g - X_g'X_g b), each column's centred sum of squares from X'X (the idle column is the
  constant 1: its row holds each column's sum), in how many clusters each column is seen, and
  the power's spread where it is seen (sum |y| is sum y plus, where the power changes sign
  between the two whole lags, the difference: `RunSums.cross_y`).
"""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.gram import FoldGrams, noise_share
from wifibot_power.drive.moments import _gram_solve, seen_columns
from wifibot_power.drive.sums import RunSums, group_sum
from wifibot_power.drive.windows import design_columns


class SumsTable:
    """Every run's sums in the batch's columns (`design_columns(surfaces)`), a row per trip
    (trips numbered across the runs, in order, as `windows.assemble` numbers them)."""

    def __init__(self, sums: list[RunSums], surfaces: tuple[str, ...]) -> None:
        self.columns = design_columns(surfaces)
        assert self.columns[0] == "idle_W"  # the constant 1 (lagsums' module docstring)
        P, S, L = len(self.columns), len(surfaces), sums[0].lags
        self.surfaces, self.lags = surfaces, L
        self.run_ids = tuple(s.run_id for s in sums)
        self.window_s = sums[0].window_s
        trips = [s.trip_windows.size for s in sums]
        self.trip_base = np.concatenate(([0], np.cumsum(trips))).astype(np.intp)
        T = int(self.trip_base[-1])
        self.run_of_trip = np.repeat(np.arange(len(sums)), trips)
        self.proxy_run = np.array([s.proxy for s in sums])
        #: per run and column, the share of its sum of squares that is noise (gram.py)
        self.noise_share = np.array([noise_share(self.columns, s.reliability) for s in sums])
        self.force_form = bool(self.proxy_run.all())
        self.trip_windows = np.concatenate([s.trip_windows for s in sums])
        self.count = np.concatenate([s.count for s in sums])
        #: per trip [X R]'[X R] (T, 2P, 2P); [X R]'Y a lag at a time (L, T, 2P)
        self.ww, self.wy = np.zeros((T, 2 * P, 2 * P)), np.zeros((L, T, 2 * P))
        self.yy = np.concatenate([s.yy for s in sums])
        self.seen, self.on_surface = np.zeros((T, P), np.int64), np.zeros((T, S), np.int64)
        self.seen_xx, self.seen_y = np.zeros(P), np.zeros((P, L))
        self.seen_yy, self.seen_abs = np.zeros((P, 2, L)), np.zeros((P, L))
        cross, edges = [], []
        for r, s in enumerate(sums):
            col = np.array([self.columns.index(c) for c in s.columns], dtype=np.intp)
            both = np.concatenate((col, P + col))
            place = np.array([surfaces.index(name) for name in s.surfaces], dtype=np.intp)
            rows = slice(self.trip_base[r], self.trip_base[r + 1])
            self.ww[rows, both[:, None], both[None, :]] = s.ww
            self.wy[:, rows, both] = s.wy.transpose(2, 0, 1)
            self.seen[rows, col] = s.seen
            self.on_surface[rows, place] = s.on_surface
            self.seen_xx[col] += s.seen_xx
            self.seen_y[col] += s.seen_y
            self.seen_yy[col] += s.seen_yy
            self.seen_abs[col] += s.seen_abs
            cross.append((_widen(s.cross_x, col, P), s.cross_y))
            edges.append(
                (
                    _widen(s.edge_x, col, P),
                    _widen(s.edge_r, col, P),
                    s.edge_y,
                    s.edge_trip + self.trip_base[r],
                    place[s.edge_surface],
                )
            )
        self.cross_x = np.concatenate([x for x, _ in cross])
        self.cross_y = np.concatenate([y for _, y in cross])
        self.edge = tuple(np.concatenate(parts) for parts in zip(*edges, strict=True))
        #: per trip X'X (contiguous: the folds' sums), and every trip's
        self.xx = np.ascontiguousarray(self.ww[:, :P, :P])
        self.xx_all = self.xx.sum(axis=0)

    @property
    def trips(self) -> int:
        """Every run's trips (T)."""
        return int(self.trip_base[-1])

    def fold_grams(self, fold_of_trip: np.ndarray, folds: int, lags: np.ndarray) -> FoldGrams:
        """The lag search's sums per fold (gram.py) over the common windows of its trips."""
        P = len(self.columns)
        count = np.zeros(folds, dtype=np.int64)
        xx, xy = np.zeros((folds, P, P)), np.zeros((folds, P, self.lags))
        yy = np.zeros((folds, 2, self.lags))
        # each trip's noise sum of squares per column: its run's noise share of its X'X's
        # diagonal (gram.py `corrected_gram`)
        noise_of_trip = self.noise_share[self.run_of_trip] * np.diagonal(self.xx, axis1=1, axis2=2)
        noise = np.zeros((folds, P))
        for f in range(folds):
            rows = fold_of_trip == f
            # a fold of every trip (the whole batch's search) reads the arrays in place: the
            # same sums in the same order as over a masked copy (a copy of (L, T, P) of wy is
            # ~30 MB of fresh pages: tests/test_drive_parent_side.py)
            rows = slice(None) if rows.all() else rows
            count[f] = int(self.count[rows].sum())
            xx[f] = self.xx[rows].sum(axis=0)
            xy[f] = self.wy[:, rows, :P].sum(axis=1).T
            yy[f] = self.yy[rows].sum(axis=0)
            noise[f] = noise_of_trip[rows].sum(axis=0)
        return FoldGrams(count, xx, xy, yy, lags, noise)

    def at_lag(self, lag_bins: float) -> LagSums:
        """Each trip's sums with the power `lag_bins` later (`LagSums`)."""
        return LagSums(self, lag_bins)


def _widen(rows: np.ndarray, col: np.ndarray, P: int) -> np.ndarray:
    """A run's rows of its own columns as rows of the batch's (0 elsewhere)."""
    out = np.zeros((rows.shape[0], P))
    out[:, col] = rows
    return out


def lag_weights(lag_bins: float, lags: int) -> tuple[int, float, np.ndarray]:
    """The whole lag w below `lag_bins`, the fraction t above it, and the weights of the whole
    lags' columns in the power at `lag_bins` (windows.py `between_bins`)."""
    whole = int(np.floor(lag_bins))
    part = lag_bins - whole
    weights = np.zeros(lags)
    if part <= 1e-9:
        part = 0.0
        weights[whole] = 1.0
    else:
        weights[whole], weights[whole + 1] = 1 - part, part
    return whole, part, weights


class LagSums:
    """Each trip's sums at one lag (module docstring): its windows (`count`), the sums of its
    regressors (`sum_x`, trips x columns) and power (`sum_y`), the windows seeing each column
    and on each surface; `moments(train)` for a fit."""

    def __init__(self, table: SumsTable, lag_bins: float) -> None:
        self.table = table
        self.whole, self.part, self.weights = lag_weights(lag_bins, table.lags)
        P, T = len(table.columns), table.trips
        # (T, 2P): W'y of the common windows
        if self.part:
            w, t = self.whole, self.part
            self.wy = (1 - t) * table.wy[w] + t * table.wy[w + 1]
        else:
            self.wy = table.wy[self.whole]
        edge_x, edge_r, edge_y, edge_trip, edge_surface = table.edge
        low = edge_y[:, self.whole]
        if self.part:
            high = edge_y[:, self.whole + 1]
            y = (1 - self.part) * low + self.part * high
            defined = np.isfinite(low) & np.isfinite(high)
        else:
            y, defined = low, np.isfinite(low)
        self.edge_x, self.edge_r, self.edge_y = edge_x[defined], edge_r[defined], y[defined]
        self.edge_trip = edge_trip[defined]
        edge_seen = seen_columns(self.edge_x, table.columns)
        self.edge_seen = edge_seen
        self.count = table.count + np.bincount(self.edge_trip, minlength=T)
        # (the edge windows are in trip order: the runs' in turn, each run's in order)
        # the idle row of W'W: each column's sum
        self.sum_x = table.ww[:, 0, :P] + group_sum(self.edge_x, self.edge_trip, T)
        self.sum_y = self.wy[:, 0] + np.bincount(self.edge_trip, self.edge_y, minlength=T)
        self.seen = table.seen + group_sum(edge_seen.astype(np.int64), self.edge_trip, T)
        S = len(table.surfaces)
        self.on_surface = table.on_surface + np.bincount(
            self.edge_trip * S + edge_surface[defined], minlength=T * S
        ).reshape(T, S)

    def moments(self, train: np.ndarray, by_run: bool) -> SumMoments:
        """`SumMoments` of the windows of the `train` trips (bool per trip), clusters the
        runs (`by_run`) or the trips."""
        return SumMoments(self, train, by_run)


class SumMoments:
    """`moments.WindowMoments` from a `LagSums` (module docstring)."""

    residual_W = None  # no window is at hand

    def __init__(self, at: LagSums, train: np.ndarray, by_run: bool) -> None:
        table = at.table
        P = len(table.columns)
        self.at, self.train, self.by_run = at, train, by_run
        self.columns, self.force_form = table.columns, table.force_form
        self.P = P
        edge = train[at.edge_trip]
        self.edge = edge
        self.n = int(at.count[train].sum())
        ex = at.edge_x[edge]
        # every trip's X'X less those of the trips left out (a fold's: a tenth)
        left_out = table.xx[~train].sum(axis=0)
        self.gram = (table.xx_all - left_out if (~train).any() else table.xx_all) + ex.T @ ex
        self.xy = at.wy[train, :P].sum(axis=0) + ex.T @ at.edge_y[edge]
        runs_with_rows = np.bincount(table.run_of_trip[train], at.count[train], len(table.run_ids))
        proxy = table.proxy_run[runs_with_rows > 0]
        self.proxy_any = bool(proxy.any())
        self.proxy_all = bool(proxy.size and proxy.all())

    def _cluster_of_trip(self) -> np.ndarray:
        """Each trip's cluster: its run's index (`by_run`) or its own."""
        table = self.at.table
        return table.run_of_trip if self.by_run else np.arange(table.trips)

    def seen_clusters(self) -> np.ndarray:
        """Per column: the clusters with a window where its regressor is seen."""
        cluster = self._cluster_of_trip()[self.train]  # in order
        groups = int(cluster.max()) + 1 if cluster.size else 0
        return (group_sum(self.at.seen[self.train], cluster, groups) > 0).sum(axis=0)

    def centred_ss(self, j: int) -> float:
        """Column j's sum of squares about its mean: x'x - (sum x)^2 / n."""
        return float(self.gram[j, j] - self.gram[0, j] ** 2 / self.n)

    def gram_xy(self, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """X'X and X'y of the `kept` columns."""
        return self.gram[np.ix_(kept, kept)], self.xy[kept]

    def unbounded(self, kept: np.ndarray) -> np.ndarray:
        """Least squares without bounds on the `kept` columns (from X'X, X'y)."""
        return _gram_solve(*self.gram_xy(kept))

    def jackknife_sums(self, kept: np.ndarray, coef_k: np.ndarray):
        """`WindowMoments.jackknife_sums` from each cluster's [X R]'[X R] and [X R]'y: the
        lag's column is R_k c (c the coefficients), its score c'R_g'y_g - c'R_g'X_g b."""
        P = self.P
        ww, wy = self._cluster_sums()
        k = np.flatnonzero(kept)
        r = P + k
        A = ww[:, k[:, None], k[None, :]]
        xr = ww[:, k[:, None], r[None, :]] @ coef_k  # X_g'R_g c
        rr = np.einsum("i,gij,j->g", coef_k, ww[:, r[:, None], r[None, :]], coef_k)
        xy_g, ry_g = wy[:, k], wy[:, r] @ coef_k
        scores = xy_g - A @ coef_k
        if rr.sum() > 0:  # the fitted power moves with the lag (identify.py `_fit_kept`)
            p = k.size + 1
            grams = np.zeros((A.shape[0], p, p))
            grams[:, :-1, :-1], grams[:, :-1, -1], grams[:, -1, :-1] = A, xr, xr
            grams[:, -1, -1] = rr
            scores = np.column_stack((scores, ry_g - xr @ coef_k))
        else:
            grams, p = A, k.size
        G = grams.shape[0]
        if p == 0 or G < 2 or self.n <= p:
            return None, p, G
        return (grams.sum(axis=0), grams, scores), p, G

    def _cluster_sums(self) -> tuple[np.ndarray, np.ndarray]:
        """Each cluster's (with a window) [X R]'[X R] and [X R]'y: its trips' common sums and
        its edge windows' rows."""
        at, table = self.at, self.at.table
        cluster_of_trip = self._cluster_of_trip()
        has_rows = self.train & (at.count > 0)
        # trips in order, clusters (runs, or trips) in order: each cluster's trips a stretch
        cluster = cluster_of_trip[has_rows]
        clusters, starts = np.unique(cluster, return_index=True)
        if not clusters.size:
            Q = 2 * self.P
            return np.zeros((0, Q, Q)), np.zeros((0, Q))
        if has_rows.all():  # the whole fit's: summed in place (not a copy of every trip's)
            ww = np.add.reduceat(table.ww, starts, axis=0)
            wy = np.add.reduceat(at.wy, starts, axis=0)
        else:
            ww = np.add.reduceat(table.ww[has_rows], starts, axis=0)
            wy = np.add.reduceat(at.wy[has_rows], starts, axis=0)
        edge_cluster = np.searchsorted(clusters, cluster_of_trip[at.edge_trip[self.edge]])
        W = np.hstack((at.edge_x[self.edge], at.edge_r[self.edge]))
        y = at.edge_y[self.edge]
        # the edge windows are in trip order, so each cluster's are a stretch: a loop over
        # the clusters with edge windows, each its own rows (not a mask over all of them)
        groups, first = np.unique(edge_cluster, return_index=True)
        assert np.all(np.diff(edge_cluster) >= 0), "edge windows in trip order"
        stops = np.append(first[1:], edge_cluster.size) if groups.size else first
        for g, start, stop in zip(groups, first, stops, strict=True):
            rows = W[start:stop]
            ww[g] += rows.T @ rows.copy()  # two buffers: gemm, as the masked rows were (not syrk)
            wy[g] += rows.T @ y[start:stop]
        return ww, wy

    def seen_spread(self, j: int, idle: bool) -> tuple[int, float, float]:
        """`WindowMoments.seen_spread` over every trip's windows (the whole fit's)."""
        at, table = self.at, self.at.table
        assert self.train.all(), "the loose-term check is the whole fit's"
        w, t = at.whole, at.part
        count = int(at.seen[:, j].sum())
        if count == 0:
            return 0, np.nan, np.nan
        edge = at.edge_seen[:, j]
        ey = at.edge_y[edge]
        sum_xx = table.seen_xx[j] + float(np.sum(np.square(at.edge_x[edge, j])))
        sum_y = float(table.seen_y[j] @ at.weights) + float(ey.sum())
        band = table.seen_yy[j]
        sum_yy = band[0, w] + float(np.sum(np.square(ey)))
        sum_abs = table.seen_abs[j, w] + float(np.abs(ey).sum())
        if t:
            sum_yy = (1 - t) ** 2 * band[0, w] + 2 * t * (1 - t) * band[1, w]
            sum_yy += t**2 * band[0, w + 1] + float(np.sum(np.square(ey)))
            sum_abs = (1 - t) * table.seen_abs[j, w] + t * table.seen_abs[j, w + 1]
            sum_abs += float(np.abs(ey).sum())
            # where the power changes sign between the two whole lags, |y| is not their mix
            seen = seen_columns(table.cross_x, table.columns)[:, j]
            low, high = table.cross_y[seen, w], table.cross_y[seen, w + 1]
            mixed = (1 - t) * np.abs(low) + t * np.abs(high)
            sum_abs -= float(np.sum(mixed - np.abs((1 - t) * low + t * high)))
        typical = float(np.sqrt(sum_xx / count))
        if idle:
            return count, typical, sum_abs / count
        mean = sum_y / count
        return count, typical, float(np.sqrt(max(sum_yy / count - mean * mean, 0.0)))
