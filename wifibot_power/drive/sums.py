"""A run's per-trip sums of the drive model's least squares (`RunSums`), made in the worker
beside its bins (`models.drive.DriveFamily.run_stats`), so that the parent fits, searches the
lag and checks every held-out fold from sums of a few hundred numbers a trip instead of
passes over every window (lagsums.py; docs/drive-model.md, "From sufficient statistics").

The design X (a window's regressors, lag 0's) and its rate R (`Windows.design_rate`) do not
move with the lag; only the response does (the mean power `lag` bins later) and which windows
have one (none across a drop-out or past the run's end). So, over the windows whose power is
defined at every whole lag the search tries ("common": all but a few a run), each trip keeps
W'W and W'Y (W = [X R], Y the power at each whole lag, a column each), Y's squares and its
products with the next lag's (a lag between two whole bins is linear between them:
windows.py `between_bins`), how many windows see each regressor (identify.py's screens) and
how many lie on each surface. The run keeps, per column, the power's sums over the windows
where the column is seen (the loose-term check), and the windows whose power changes sign
between two whole lags (|power| is not linear between them). The few windows defined at some
lags only ("edge") are kept as rows, added at the lag a fit uses.

Columns are the run's own (`design_columns(surfaces)`, its surfaces): lagsums.py places them
among the batch's. Sums of the same windows in another order: the same numbers up to the
order of summation (benchmarks/gram_equal.py, tests/test_drive_gram.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from wifibot_power.drive.gram import CANCELLATION
from wifibot_power.drive.identify import lag_grid
from wifibot_power.drive.moments import seen_columns
from wifibot_power.drive.stats import DriveStats
from wifibot_power.drive.windows import (
    WINDOW_S,
    RunWindows,
    design_columns,
    fill_design,
    run_windows,
    surface_of,
    window_bins,
)


@dataclass(frozen=True, eq=False)
class RunSums:
    """One run's sums (module docstring). p: the run's design columns, L: the whole lags
    tried, T: its trips; "common" windows are those with a power at every whole lag."""

    run_id: str
    surfaces: tuple[str, ...]
    bin_s: float
    window_s: float
    proxy: bool
    #: (T,) every window of each trip (defined or not), and its common windows
    trip_windows: np.ndarray
    count: np.ndarray
    #: per trip over its common windows: W'W (T, 2p, 2p), W'Y (T, 2p, L), Y_l'Y_l and
    #: Y_l'Y_l+1 (T, 2, L; the last of the second row 0), windows seeing each column (T, p)
    #: and on each surface (T, S)
    ww: np.ndarray
    wy: np.ndarray
    yy: np.ndarray
    seen: np.ndarray
    on_surface: np.ndarray
    #: per column over the run's common windows that see it: sum x^2 (p), sum Y (p, L), sum
    #: Y^2 and Y_l Y_l+1 (p, 2, L), sum |Y| (p, L)
    seen_xx: np.ndarray
    seen_y: np.ndarray
    seen_yy: np.ndarray
    seen_abs: np.ndarray
    #: common windows whose power changes sign between two whole lags: X (c, p), Y (c, L)
    cross_x: np.ndarray
    cross_y: np.ndarray
    #: windows with a power at some whole lags only: X, R (e, p), Y (e, L; NaN where not
    #: defined), trip (e), surface (e, an index into `surfaces`)
    edge_x: np.ndarray
    edge_r: np.ndarray
    edge_y: np.ndarray
    edge_trip: np.ndarray
    edge_surface: np.ndarray
    #: the speeding-up and braking columns' reliability (`RunWindows.reliability`)
    reliability: tuple[float, float] = (1.0, 1.0)

    @property
    def columns(self) -> tuple[str, ...]:
        """The run's design columns (its own surfaces')."""
        return design_columns(self.surfaces)

    @property
    def windows(self) -> int:
        """Every window of the run, defined or not."""
        return int(self.trip_windows.sum())

    @property
    def lags(self) -> int:
        """The whole lags the sums hold a column for (L)."""
        return int(self.wy.shape[2])


def sums_of(stats: DriveStats, window_s: float = WINDOW_S) -> RunSums:
    """`run_sums` of a run's bins."""
    return run_sums(run_windows(stats, window_s))


def run_sums(rw: RunWindows) -> RunSums:
    """The run's sums (module docstring)."""
    surfaces = rw.stats.surfaces
    columns = design_columns(surfaces)
    lags = lag_grid([rw])
    defined = _defined_at_every_lag(rw, lags.size)
    trips = int(rw.trip[-1]) + 1 if rw.count else 0
    p = len(columns)
    surface = surface_of(rw, surfaces)
    common, edge = np.flatnonzero(rw.ok & defined), np.flatnonzero(rw.ok & ~defined)
    # Z = [X R Y] over the common windows: every window's row made once (`_window_rows`),
    # then the common ones taken whole (all of them: the rows as they are)
    every = _window_rows(rw, surface, lags)
    Z = every if common.size == rw.count else every[common]
    X, Yc = Z[:, :p], Z[:, 2 * p :]
    trip = rw.trip[common]
    seen = seen_columns(X, columns)
    # Y's squares and next-lag products, once for the trips' sums and the columns'
    square, next_product = np.square(Yc), Yc[:, :-1] * Yc[:, 1:]
    per_trip = _trip_sums(Z, 2 * p, trip, trips, square, next_product)
    S = len(surfaces)
    on_surface = np.bincount(trip * S + surface[common], minlength=trips * S)
    # per column over the windows that see it: sum Y, Y^2, Y_l Y_l+1 and |Y|
    L = lags.size
    seen_f = seen.astype(np.float64).T
    seen_yy = np.zeros((len(columns), 2, L))
    seen_yy[:, 0] = seen_f @ square
    seen_yy[:, 1, :-1] = seen_f @ next_product
    crossing = _any_per_row(next_product < 0)
    edge_rows = every[edge]
    return RunSums(
        run_id=rw.stats.run_id,
        surfaces=surfaces,
        bin_s=rw.stats.bin_s,
        window_s=rw.n * rw.stats.bin_s,
        proxy=bool(rw.stats.current_proxy),
        trip_windows=np.bincount(rw.trip, minlength=trips),
        count=np.bincount(trip, minlength=trips),
        ww=per_trip[0],
        wy=per_trip[1],
        yy=per_trip[2],
        seen=group_sum(seen.astype(np.int64), trip, trips),
        on_surface=on_surface.reshape(trips, S),
        seen_xx=np.sum(seen * np.square(X), axis=0),
        seen_y=seen_f @ Yc,
        seen_yy=seen_yy,
        seen_abs=seen_f @ np.abs(Yc),
        cross_x=X[crossing],
        cross_y=Yc[crossing],
        edge_x=np.ascontiguousarray(edge_rows[:, :p]),
        edge_r=np.ascontiguousarray(edge_rows[:, p : 2 * p]),
        edge_y=np.ascontiguousarray(edge_rows[:, 2 * p :]),
        edge_trip=rw.trip[edge],
        edge_surface=surface[edge],
        reliability=rw.reliability,
    )


def windows_of(stats: DriveStats, window_s: float = WINDOW_S) -> RunWindows:
    """`run_windows(stats, window_s)`: the windows the run's worker made and sent with its bins
    (`send_with`) when they are those, else made here (the same arrays: one function of the
    bins)."""
    sent = stats.__dict__.get("_sent_windows")
    if sent is not None and sent.stats is stats and sent.n == window_bins(stats, window_s):
        return sent
    return run_windows(stats, window_s)


def send_with(windows: RunWindows) -> None:
    """Keep `windows` on the bins they were made from (`windows.stats`), so that they travel
    with them to the process that fits (`windows_of` takes them): a run at risk, whose bins
    go there for the lag search over the windows (`AT_RISK_SHARE`). Their fields only, not
    what they made from them and keep (their running sums and span means over the bins,
    their regressors' rates: made again where needed)."""
    object.__setattr__(windows.stats, "_sent_windows", replace(windows))  # a cache, not a field


def own_share(sums: RunSums) -> float:
    """The smallest share of the power's sum of squares that the run's own least squares
    leaves, over the whole lags: sse / y'y from its sums, as gram.py's searches make it
    (`FoldGrams.search`, one fold of this run's trips). A batch's searches fall back to the
    windows (gram.py `CANCELLATION`) only where this is tiny: a run that leaves more of its
    power unexplained, by its own coefficients, cannot fit better pooled with others (at a
    whole lag, over all its trips); the bins it would need are kept below `AT_RISK_SHARE`
    (models/drive.py `WorkerStats.without_bins`). NaN without a common window."""
    p = len(sums.columns)
    xx = sums.ww[:, :p, :p].sum(axis=0)
    xy = sums.wy[:, :p, :].sum(axis=0)
    yy = sums.yy[:, 0].sum(axis=0)
    usable = np.diag(xx) != 0
    if not usable.any() or not (yy > 0).all():
        return float("nan")
    xx, xy = xx[np.ix_(usable, usable)], xy[usable]
    scale = np.sqrt(np.diag(xx))
    coef = (np.linalg.pinv(xx / np.outer(scale, scale)) @ (xy / scale[:, None])) / scale[:, None]
    sse = yy - 2.0 * np.sum(coef * xy, axis=0) + np.einsum("il,ij,jl->l", coef, xx, coef)
    return float(np.min(sse / yy))


#: Below this `own_share` a run keeps its bins in a fit's records: 10x gram.py's
#: `CANCELLATION` (the simulator's free driving: 1.1e-4 to 3.6e-4 a run; noise-free step
#: runs: ~0)
AT_RISK_SHARE = 10 * CANCELLATION


def _window_rows(rw: RunWindows, surface: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Every window's row [X R Y] (a window a row; `surface`: each window's): its design and
    the design's rate (`windows.regressor_rows`' columns) and its power at each of `lags`
    (`RunWindows.power_at_lags`: NaN where not defined). One pass per column over the run,
    not one per column for each set of windows taken from it (the common and the edge)."""
    regressors, rates = rw.regressors(), rw.rates
    S = len(rw.stats.surfaces)
    p = len(design_columns(rw.stats.surfaces))
    rows = np.empty((rw.count, 2 * p + lags.size))
    # (copies: `fill_design` makes each column finite in place)
    fill_design(rows[:, :p], lambda name: regressors[name].copy(), surface, S)
    fill_design(rows[:, p : 2 * p], lambda name: rates[name].copy(), surface, S, rate=True)
    rw.power_at_lags(lags, out=rows[:, 2 * p :])
    return rows


def _any_per_row(flags: np.ndarray) -> np.ndarray:
    """`flags.any(axis=1)`, a column at a time (numpy's reduction per short row is ~3x
    slower)."""
    if not flags.shape[1]:
        return np.zeros(flags.shape[0], dtype=bool)
    out = flags[:, 0].copy()
    for k in range(1, flags.shape[1]):
        out |= flags[:, k]
    return out


def _defined_at_every_lag(rw: RunWindows, lags: int) -> np.ndarray:
    """Per window: its power is defined at every whole lag below `lags` (`RunWindows.power_at`):
    no drop-out in the bins from its start to `lags - 1` bins past its end, all in the run."""
    bad, _ = rw._power_sums
    start = np.arange(rw.count) * rw.n
    end = start + rw.n + lags - 1
    inside = end <= rw.stats.bins
    end = np.minimum(end, rw.stats.bins)
    return inside & (bad[end] - bad[start] == 0)


def _trip_sums(
    Z: np.ndarray,
    q: int,
    trip: np.ndarray,
    trips: int,
    square: np.ndarray,
    next_product: np.ndarray,
):
    """Per trip (rows sorted by trip) of Z = [W Y], W its first `q` columns: W'W, W'Y, and Y's
    squares and next-lag products (`square`, `next_product`: each row's). (W'Z, not Z'Z:
    numpy makes Z'Z a symmetric rank update that OpenBLAS spreads over threads, ~6x slower
    at these sizes.)"""
    L = Z.shape[1] - q
    wz = np.zeros((trips, q, q + L))
    yy = np.zeros((trips, 2, L))
    bounds = np.searchsorted(trip, np.arange(trips + 1))
    for g in np.flatnonzero(np.diff(bounds)):  # a loop over trips, each one matrix product
        rows = Z[bounds[g] : bounds[g + 1]]
        np.matmul(rows[:, :q].T, rows, out=wz[g])
    ww, wy = np.ascontiguousarray(wz[:, :, :q]), np.ascontiguousarray(wz[:, :, q:])
    yy[:, 0] = group_sum(square, trip, trips)
    yy[:, 1, :-1] = group_sum(next_product, trip, trips)
    return ww, wy, yy


def group_sum(values: np.ndarray, group: np.ndarray, groups: int) -> np.ndarray:
    """Sums of `values`' rows by `group` (sorted, in 0..groups-1), a row per group (0 for an
    empty one)."""
    out = np.zeros((groups, *values.shape[1:]), dtype=values.dtype)
    bounds = np.searchsorted(group, np.arange(groups + 1))
    filled = np.flatnonzero(np.diff(bounds))
    if filled.size:
        out[filled] = np.add.reduceat(values, bounds[filled], axis=0)
    return out
