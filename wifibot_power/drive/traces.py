"""Held-out power traces of the drive model, for the report's figure (cli.md, "Figures": "held-out
runs' measured and predicted power over time"): a few runs, each predicted by a model
identified without it (its own lag, as heldout.py's folds), window by window.

Only a few runs are drawn (`MAX_RUNS`, one per surface first): each costs one identification.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from wifibot_power.drive.identify import identify, lag_search
from wifibot_power.drive.model import MIN_RUN_CLUSTERS
from wifibot_power.drive.stats import DriveStats
from wifibot_power.drive.windows import WINDOW_S, assemble, run_windows

#: Runs drawn at most.
MAX_RUNS = 3


@dataclass(frozen=True, eq=False)
class HeldOutTrace:
    """One run's windows: start time [s], measured and held-out predicted mean power [W]."""

    run_id: str
    surface: str
    time_s: np.ndarray
    measured_W: np.ndarray
    predicted_W: np.ndarray


def heldout_traces(
    stats_list: Sequence[DriveStats | None], *, max_runs: int = MAX_RUNS
) -> tuple[HeldOutTrace, ...]:
    """Up to `max_runs` runs (the first of each surface, then in order), each predicted by the
    drive model identified on the other runs; empty with fewer than two runs."""
    runs = [run_windows(s, WINDOW_S) for s in stats_list if s is not None]
    runs = [rw for rw in runs if rw.count]
    if len(runs) < 2:
        return ()
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    first_of = {}
    for i, rw in enumerate(runs):
        first_of.setdefault(rw.stats.surfaces[0] if rw.stats.surfaces else "", i)
    chosen = list(first_of.values())
    chosen += [i for i in range(len(runs)) if i not in chosen]
    out = []
    for i in chosen[:max_runs]:
        train = [np.full(rw.count, j != i) for j, rw in enumerate(runs)]
        lag_bins, _ = lag_search(runs, surfaces, train)
        fitted_on = assemble(runs, lag_bins, surfaces, only=train)
        by_run = len(runs) - 1 >= MIN_RUN_CLUSTERS
        model = identify(fitted_on, lag_bins, fitted_on.run if by_run else fitted_on.trip)
        rw = runs[i]
        held = assemble([rw], lag_bins, surfaces)
        _, power_ok = rw.power_at(lag_bins)
        kept = np.flatnonzero(rw.ok & power_ok)
        out.append(
            HeldOutTrace(
                run_id=rw.stats.run_id,
                surface=", ".join(rw.stats.surfaces),
                time_s=kept * held.window_s,
                measured_W=held.power_W,
                predicted_W=model.predict_W(held.design),
            )
        )
    return tuple(out)
