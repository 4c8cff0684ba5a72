"""Held-out accuracy of the drive model: K-fold by trip (a run, or a long log cut at its stops:
windows.py, `STOP_S`). Each fold's model is identified afresh (its own lag) from the other
folds' runs, and predicts the energy of each held-out trip: the sum over the trip's windows of
the predicted mean power times the window's duration, beside the measured sum over the same
windows (a window across a drop-out is in neither: the energy of a drop-out is unknown).

The 90% prediction interval of a held-out trip's energy comes from the run-to-run spread of
held-out errors: the root mean square of the relative held-out errors of the *other* trips
(its own error never sets its interval), times Student's t (0.95, n - 2 degrees of freedom)
and sqrt(1 + 1/(n - 1)) for the spread being estimated from n - 1 trips. The relative error is
used because what varies from run to run (battery voltage, temperature, a surface's
unevenness, a lag mis-set) scales with the energy. `coverage_pi90_pct` is how often these
intervals hold the measured energy: the check that they mean what they say.
"""

from __future__ import annotations

import math
from collections.abc import Container
from dataclasses import dataclass, replace

import numpy as np

from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.identify import identify, identify_moments, lag_grid, lag_search
from wifibot_power.drive.lagsums import SumsTable
from wifibot_power.drive.windows import (
    RunWindows,
    StackedPower,
    Windows,
    assemble,
    regressor_rows,
)
from wifibot_power.stats import t_quantile

#: Folds of the K-fold (fewer when there are fewer trips).
FOLDS = 10
#: Fewest trips for held-out accuracy (two folds of at least two trips).
MIN_TRIPS = 4


@dataclass(frozen=True)
class HeldOutRun:
    """One held-out trip: measured and predicted energy [J] and the 90% interval."""

    run_id: str
    surface: str
    measured_J: float
    predicted_J: float
    pi90_J: tuple[float, float]

    def as_dict(self) -> dict[str, object]:
        return {
            "run_id": self.run_id,
            "surface": self.surface,
            "measured_J": self.measured_J,
            "predicted_J": self.predicted_J,
            "pi90_J": list(self.pi90_J),
        }


@dataclass(frozen=True)
class HeldOut:
    runs: tuple[HeldOutRun, ...]
    mape_pct: float
    median_ape_pct: float
    coverage_pi90_pct: float
    #: root mean square of the relative held-out errors, and its degrees of freedom: the
    #: spread a new route's interval is made from (profile.py)
    relative_rms: float
    dof: int

    def as_dict(self) -> dict[str, object]:
        return {
            "runs": [run.as_dict() for run in self.runs],
            "mape_pct": None if math.isnan(self.mape_pct) else self.mape_pct,
            "median_ape_pct": None if math.isnan(self.median_ape_pct) else self.median_ape_pct,
            "coverage_pi90_pct": (
                None if math.isnan(self.coverage_pi90_pct) else self.coverage_pi90_pct
            ),
        }


def heldout_accuracy(
    runs: list[RunWindows],
    surfaces: tuple[str, ...],
    clusters_by_run: bool,
    folds: int = FOLDS,
    seed: int = 0,
    gram: bool = True,
) -> HeldOut | None:
    """K-fold by trip (module docstring); None with fewer than `MIN_TRIPS` trips. `gram`: each
    fold's lag search from the folds' sufficient statistics (gram.py), else by least squares
    over the fold's windows (the same numbers up to the order of summation)."""
    whole = assemble(runs, 0, surfaces)
    trips = np.unique(whole.trip)
    if trips.size < MIN_TRIPS:
        return None
    k = min(folds, trips.size)
    trip_base = np.concatenate(([0], np.cumsum([int(rw.trip[-1]) + 1 for rw in runs])))
    fold_of_trip = np.full(int(trip_base[-1]), -1)
    fold_of_trip[np.random.default_rng(seed).permutation(trips)] = np.arange(trips.size) % k
    measured, predicted, trip_ids, trip_surface = [], [], [], []
    bases = trip_base[:-1]
    fold_of = [fold_of_trip[rw.trip + base] for rw, base in zip(runs, bases, strict=True)]
    stacked = StackedPower(runs)
    grams = (
        FoldGrams.from_windows(runs, surfaces, np.concatenate(fold_of), k, lag_grid(runs), stacked)
        if gram
        else None
    )
    windows_at = at_any_lag(runs, surfaces, stacked)
    for fold in range(k):
        train = [f != fold for f in fold_of]
        test = [~mask for mask in train]
        if not any(mask.any() for mask in train) or not any(mask.any() for mask in test):
            continue
        found = grams.search(fold) if grams else None
        lag_bins, _ = found or lag_search(runs, surfaces, train, gram=False)
        # the fold's windows and the held-out ones at its lag: one assembly, split by trip
        # (the rows `assemble(..., only=train)` and `only=test` give, in the same order)
        at_lag = windows_at(lag_bins)
        held_out = fold_of_trip[at_lag.trip] == fold
        fitted_on = at_lag.take(~held_out)
        clusters = fitted_on.run if clusters_by_run else fitted_on.trip
        model = identify(fitted_on, lag_bins, clusters)
        held = at_lag.take(held_out)
        power_W = model.predict_W(held.design)
        for trip in np.unique(held.trip):
            rows = held.trip == trip
            measured.append(float(held.power_W[rows].sum()) * held.window_s)
            predicted.append(float(power_W[rows].sum()) * held.window_s)
            trip_ids.append(int(trip))
            values, counts = np.unique(held.surface[rows], return_counts=True)
            trip_surface.append(surfaces[int(values[np.argmax(counts)])])
    if len(measured) < MIN_TRIPS:
        return None
    run_ids = tuple(rw.stats.run_id for rw in runs)
    return _accuracy(run_ids, trip_base, measured, predicted, trip_ids, trip_surface)


def heldout_from_sums(
    table: SumsTable,
    clusters_by_run: bool,
    folds: int = FOLDS,
    seed: int = 0,
    search_windows=None,
) -> HeldOut | None:
    """`heldout_accuracy` from the batch's per-trip sums (lagsums.py): the same folds, lags,
    fits and held-out energies up to the order of summation. A fold whose lag search cannot
    be made from sums (gram.py `CANCELLATION`) is searched over its windows:
    `search_windows(train)`, `train` a bool per trip (`model.py`)."""
    trips = np.flatnonzero(table.at_lag(0).count > 0)  # the trips with a window at lag 0
    if trips.size < MIN_TRIPS:
        return None
    k = min(folds, trips.size)
    fold_of_trip = np.full(table.trips, -1)
    fold_of_trip[np.random.default_rng(seed).permutation(trips)] = np.arange(trips.size) % k
    grams = table.fold_grams(fold_of_trip, k, lag_grid_of(table))
    measured, predicted, trip_ids, trip_surface = [], [], [], []
    for fold in range(k):
        train = fold_of_trip != fold
        if not (table.trip_windows[train].any() and table.trip_windows[~train].any()):
            continue
        found = grams.search(fold) or search_windows(train)
        at = table.at_lag(found[0])
        model = identify_moments(at.moments(train, clusters_by_run), found[0], True)
        held = np.flatnonzero(~train & (at.count > 0))
        kept = model.kept
        power_J = at.sum_x[np.ix_(held, kept)] @ model.coef[kept] * table.window_s
        measured += [float(v) * table.window_s for v in at.sum_y[held]]
        predicted += [float(v) for v in power_J]
        trip_ids += [int(t) for t in held]
        trip_surface += [table.surfaces[int(i)] for i in np.argmax(at.on_surface[held], axis=1)]
    if len(measured) < MIN_TRIPS:
        return None
    return _accuracy(table.run_ids, table.trip_base, measured, predicted, trip_ids, trip_surface)


def lag_grid_of(table: SumsTable) -> np.ndarray:
    """The whole lags [bins] the searches try (identify.lag_grid): a column of the sums each."""
    return np.arange(table.lags)


def at_any_lag(runs: list[RunWindows], surfaces: tuple[str, ...], stacked: StackedPower):
    """`assemble(runs, lag, surfaces)` as a function of the lag, the regressors assembled once
    (they do not move with the lag: only which windows have a power, and the power, do)."""
    ok = stacked.ok
    every = regressor_rows(runs, surfaces, ok)

    def at(lag_bins: float) -> Windows:
        power, power_ok = stacked.power_at(lag_bins)
        rows = power_ok[ok]
        return replace(every.take(rows), power_W=power[ok][rows])

    return at


def trip_name(run_id: str, k: int) -> str:
    """The held-out name of trip `k` (from 1) of a log cut into several at its stops:
    `run_id#k`; a log not cut is held out under its own run_id (`trip_log` reads it back)."""
    return f"{run_id}#{k}"


def trip_log(name: str, run_ids: Container[str]) -> str | None:
    """The run_id of the log whose trip the held-out `name` is (`trip_name`), or None for a
    run held out whole. `run_ids`: the batch's; a name that is one of them is that run (a
    run_id may hold '#' itself: `a#2`), and a trip is `RUN#k` of one of them."""
    if name in run_ids:
        return None
    base, mark, k = name.rpartition("#")
    return base if mark and k.isdigit() and base in run_ids else None


def _accuracy(
    run_ids: tuple[str, ...],
    trip_base: np.ndarray,
    measured: list[float],
    predicted: list[float],
    trip_ids: list[int],
    trip_surface: list[str],
) -> HeldOut:
    measured_J = np.array(measured)
    predicted_J = np.array(predicted)
    # a trip predicted at 0 J (its windows standing, every column 0: a unicycle's stop whose
    # motion windows all hold drop-outs) has no relative error: it sets no interval and is
    # not counted in the coverage. (Its 0/0 made every other trip's interval NaN, and
    # `coverage_pi90_pct` 0%: EUC_core's apex folder through `fit`)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = (measured_J - predicted_J) / predicted_J
    scaled = np.isfinite(relative)
    n = int(np.count_nonzero(scaled))
    squares = np.where(scaled, np.square(relative), 0.0)
    # each trip's interval from the other trips' errors (leave its own out)
    others = np.maximum(n - scaled, 1)
    others_rms = np.sqrt((squares.sum() - squares) / others)
    t95 = t_quantile(0.95, n - 2) if n > 2 else float("inf")
    with np.errstate(invalid="ignore"):  # (inf x 0 with too few trips: a point at 0, below)
        half = t95 * others_rms * np.sqrt(1.0 + 1.0 / others) * np.abs(predicted_J)
    half[predicted_J == 0] = 0.0
    low, high = predicted_J - half, predicted_J + half
    inside = ((measured_J >= low) & (measured_J <= high))[scaled]
    # a trip of zero net energy has no relative error: left out of the percentages
    with np.errstate(divide="ignore", invalid="ignore"):
        ape = np.abs(measured_J - predicted_J) / np.abs(measured_J) * 100.0
    ape = ape[np.isfinite(ape)]
    rows = []
    run_of = np.searchsorted(trip_base, trip_ids, side="right") - 1
    for j, trip in enumerate(trip_ids):
        r = int(run_of[j])
        local = trip - int(trip_base[r])
        run_id = run_ids[r]
        several = int(trip_base[r + 1] - trip_base[r]) > 1
        rows.append(
            HeldOutRun(
                run_id=trip_name(run_id, local + 1) if several else run_id,
                surface=trip_surface[j],
                measured_J=float(measured_J[j]),
                predicted_J=float(predicted_J[j]),
                pi90_J=(float(low[j]), float(high[j])),
            )
        )
    rows.sort(key=lambda row: row.run_id)
    return HeldOut(
        runs=tuple(rows),
        mape_pct=float(np.mean(ape)) if ape.size else float("nan"),
        median_ape_pct=float(np.median(ape)) if ape.size else float("nan"),
        coverage_pi90_pct=float(np.mean(inside) * 100.0) if n else float("nan"),
        relative_rms=float(np.sqrt(np.sum(squares) / max(n, 1))),
        dof=n - 1,
    )
