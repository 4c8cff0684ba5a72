"""A logger that stamps rows as they arrive, read on an even grid by sample and hold.

A phone app or a ROS bridge writes a row when a reading arrives: its steps spread (pairs
20 ms apart then 0.6 s of nothing; 60-170 ms with a Bluetooth connection interval that
changes along a ride). Everything after reading treats a run's samples as evenly spaced at
its period (energy = sum P_i x T, additive over phases; log-format.md). Each row held for
the mean step T instead of its own step dt_i misses the hold integral sum_i P_i dt_i by
n x cov(P_i, dt_i): where the logger writes faster in some stretches than in others and the
power differs between them (the unicycle rides: up to 13%, euc_core/v9/4).

So such a log is put on an even grid at T over the time it covers (the gaps' excess left
out, `stamps._gap_problems`): grid point k, at covered time k x T, takes the last row at
or before it, the zero-order hold the hold integral assumes (no value is made up: every
point is a copy of a logged row). The grid has as many points as the log has rows, so the
period and the covered time are those of the mean step; its energy is the hold integral's
to within one transition's rounding per row, measured and said in the log's note.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class HoldGrid:
    """Row `index[k]` at grid point k, whose time is `stamps_s[k]` [s] (the row's stamp plus
    how far into its hold the point falls)."""

    index: np.ndarray
    stamps_s: np.ndarray

    def take(self, values: np.ndarray | None) -> np.ndarray | None:
        """The per-row `values` at the grid points (None stays None)."""
        return None if values is None else values[self.index]


def hold_grid(time_s: np.ndarray, gaps: np.ndarray, period_s: float) -> HoldGrid:
    """The even grid at `period_s` over the covered time of stamps `time_s` whose steps after
    the samples `gaps` are gaps (each held for one period, the rest missing)."""
    held_s = np.diff(time_s)
    held_s[gaps] = period_s
    covered_s = np.empty(time_s.size)
    covered_s[0] = 0.0
    np.cumsum(held_s, out=covered_s[1:])
    grid_s = np.arange(time_s.size) * period_s
    index = np.searchsorted(covered_s, grid_s, side="right") - 1
    return HoldGrid(index, time_s[index] + (grid_s - covered_s[index]))


def hold_energies_J(
    time_s: np.ndarray, power_W: np.ndarray, gaps: np.ndarray, period_s: float, grid: HoldGrid
) -> tuple[float, float, float]:
    """(hold integral, each row held for the mean step, the grid's) energies [J]: the hold
    integral sum_i P_i dt_i (a gap's row and the last one held for one period)."""
    held_s = np.diff(time_s)
    held_s[gaps] = period_s
    hold_J = float(np.dot(power_W[:-1], held_s)) + float(power_W[-1]) * period_s
    mean_J = float(np.sum(power_W, dtype=np.float64)) * period_s
    grid_J = float(np.sum(power_W[grid.index], dtype=np.float64)) * period_s
    return hold_J, mean_J, grid_J
