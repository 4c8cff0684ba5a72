"""`decel_phase`: the robot needs time and power to stop; the paper's Eq. 6 has no stopping
phase.

Term: a stop phase of ``t_dec`` at ``P_dec(v)`` after each cruise (causes.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import Cause, Check, Evidence, RunTable, RunView, TripTerms
from wifibot_power.causes.design import column
from wifibot_power.causes.design import power_factor as factor_of
from wifibot_power.segment.resolution import quantized_durations
from wifibot_power.stats import ols, one_sample_p_greater, t_quantile
from wifibot_power.traces import windows_after

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel

T_DEC = "t_dec_s"
P_DEC0 = "P_dec_intercept_W"
P_DEC1 = "P_dec_slope_W_per_mps"
#: Length of the window after each cruise end where a stopping phase sits [s].
END_WINDOW_S = 1.0
#: fewest runs whose traces must show a stopping phase [fraction]
VISIBLE_FRACTION = 0.9
#: the after-cruise energy must be the stop phase's within this fraction (measured: within
#: 3% on simulated runs at the analyser's noise; see docs/diagnose.md)
LENGTH_TOLERANCE = 0.25


class DecelPhase(Cause):
    """Plausible t_dec: 0 to 5 s. From at most 1 m/s, stopping takes v / a; a deceleration
    below 0.2 m/s² (coasting against rolling friction alone) would take over 5 s, and any
    stop is at most what the wheels' grip allows (~8 m/s²), so t_dec stays under 5 s."""

    name = "decel_phase"
    physics = "the robot needs time and power to stop (no stop phase in Eq. 6)"
    term = "a stop phase of t_dec at P_dec(v) after each cruise"
    unit = "s"
    parameter = T_DEC
    parameters = (T_DEC, P_DEC0, P_DEC1)
    min_size = 0.1
    plausible = (0.0, 5.0)
    signature = "residual per step count, located after the cruise ends"
    default_size = 0.4
    realistic_range = (0.2, 1.0)
    fit_stage = "after"
    energy_stage = "power"
    energy_phase = "decel"
    columns = ("end_measured_J", "end_s")

    def energy_windows(self, view: RunView) -> tuple[list[int], list[int]]:
        """Each step's stop window: END_WINDOW_S after its cruise ends, or up to where the
        next step starts moving."""
        steps = view.steps
        period_s = view.run.sample_period_s
        return windows_after(steps.cruise_end, END_WINDOW_S, steps.next_start, period_s)

    def run_stats(self, view: RunView) -> dict[str, float]:
        """The stop windows' measured energy [J] and time [s], summed over steps."""
        dt = view.run.sample_period_s
        end_s = 0.0
        starts, ends = view.windows_of(self)
        for ic1, j_stop in zip(starts, ends, strict=True):
            end_s += (j_stop - ic1) * dt
        return {
            "end_measured_J": float(view.window_energies_J(self).sum()) if starts else 0.0,
            "end_s": end_s,
        }

    def evidence(self, table: RunTable) -> Evidence:
        """Energy above idle in the second after each cruise ends, where the paper's robot
        has already stopped (paper Eq. 6 has no stopping phase)."""
        excess_J = end_window_excess_J(table.runs, table.model)
        mean_J, _, p_value = one_sample_p_greater(excess_J)
        params = decel_parameters(table.runs, table.model)
        t_dec = params[T_DEC]
        ci = params.pop("t_dec_ci95")
        return Evidence(
            self.name,
            True,
            p_value,
            t_dec,
            ci,
            params,
            f"{mean_J:.3g} J above idle per step after cruise ends; stopping phase of "
            f"{t_dec:.3g} s at P_dec(v) = {params[P_DEC0]:.3g} + {params[P_DEC1]:.3g} v W",
        )

    def estimate(
        self, runs: pd.DataFrame, coef: dict[str, float], model: PowerModel
    ) -> dict[str, float]:
        params = decel_parameters(runs, model, factor_of(runs, model.extensions))
        params.pop("t_dec_ci95")
        return params

    def identifiable(self, runs: pd.DataFrame) -> str | None:
        found = column(runs, "decel_duration_s") > 0
        if found.sum() >= 2:
            return None
        return f"a stopping phase was found in {int(found.sum())} of the {len(runs)} runs (needs 2)"

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        runs = table.runs
        durations = column(runs, "decel_duration_s")
        found = durations > 0
        fraction = float(found.mean()) if len(runs) else 0.0
        visible = Check(
            "a stopping phase visible after each cruise",
            fraction >= VISIBLE_FRACTION,
            f"the traces show one in {int(found.sum())} of {len(runs)} runs "
            f"(at least {VISIBLE_FRACTION:.0%} needed)",
        )
        length = self._of_the_estimated_length(table, found)
        return [visible, length, self.plausible_check(evidence)]

    def _of_the_estimated_length(self, table: RunTable, found: np.ndarray) -> Check:
        """The energy above idle in the window after each cruise is the stop phase's: power is
        back at idle once the stop of the estimated length is over.

        A stop longer than the window (the segmentation looks for stops up to 5 s) is cut by
        it: the window then holds no less than the stop's flat share (mean power above idle x
        the window; a stop's power falls, so its first second holds at least that) and no
        more than the whole stop. For stops within the window both bounds are the stop's
        energy, the test as it was."""
        runs = table.runs
        if found.sum() < 2:
            return Check("of the estimated length", False, "no stopping phase to compare")
        idle_W = table.model.idle_W
        durations = column(runs, "decel_duration_s")
        above_W = column(runs, "decel_mean_power_W") - idle_W
        low_J = float(np.mean((above_W * np.minimum(durations, END_WINDOW_S))[found]))
        high_J = float(np.mean((above_W * durations)[found]))
        observed = float(np.mean(end_window_excess_J(runs, table.model)[found]))
        ratio = observed / low_J if low_J > 0 else float("nan")
        ok = bool(
            np.isfinite(ratio)
            and (1.0 - LENGTH_TOLERANCE) * low_J <= observed <= (1.0 + LENGTH_TOLERANCE) * high_J
        )
        if high_J <= low_J:
            expected = f"{low_J:.3g} J in the stop phases (ratio {ratio:.3g}"
        else:  # stops longer than the window: between its flat share and the whole stop
            expected = (
                f"{low_J:.3g}-{high_J:.3g} J in the stop phases, longer than the window "
                f"(their flat share of it to the whole stop; ratio to the share {ratio:.3g}"
            )
        return Check(
            "of the estimated length",
            ok,
            f"{observed:.3g} J above idle per step in the {END_WINDOW_S:g} s after cruise, "
            f"{expected}, within {LENGTH_TOLERANCE:.0%} needed)",
        )

    def stop_time_s(self, params: dict[str, float]) -> float:
        return float(params[T_DEC])

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """A stop phase after each cruise [s, J per trip]: ``P_dec(v) = P_dec_intercept_W +
        P_dec_slope_W_per_mps v`` over the stop time (``t_dec``, or less in a triangular step,
        at the peak speed). The distance covered while stopping, ``v t_dec / 2``, is taken off
        the cruise in `energy.step_kinematics`."""
        step = trip.step
        power_W = params[P_DEC0] + params[P_DEC1] * step.peak_speed_mps
        return trip.steps * step.decel_s, trip.steps * power_W * step.decel_s

    def sim_parameters(self, size: float) -> dict[str, float]:
        return {T_DEC: float(size)}


def end_window_excess_J(runs: pd.DataFrame, model: PowerModel) -> np.ndarray:
    """Energy above idle in the window after each cruise ends, per step [J]."""
    steps = np.clip(column(runs, "steps_found"), 1, None)
    return (column(runs, "end_measured_J") - model.idle_W * column(runs, "end_s")) / steps


def decel_parameters(runs: pd.DataFrame, base: PowerModel, factor: np.ndarray | None = None):
    """t_dec [s] and P_dec(v) [W] from the decel phases the segmentation found; when it
    found none, from the end-window excess assuming power falls linearly to idle."""
    durations = column(runs, "decel_duration_s")
    found = durations > 0
    v = column(runs, "speed_mps")
    if found.sum() >= 2:
        t_dec = float(durations[found].mean())
        dof = int(found.sum()) - 1
        se = float(durations[found].std(ddof=1) / np.sqrt(found.sum()))
        means = column(runs, "decel_mean_power_W")
        if factor is not None:
            means = base.idle_W + (means - base.idle_W) / factor
        if np.unique(v[found]).size >= 2:
            line = ols(np.column_stack([np.ones(int(found.sum())), v[found]]), means[found])
            intercept, slope = float(line.coef[0]), float(line.coef[1])
        else:
            intercept, slope = float(np.nanmean(means[found])), 0.0
    else:
        excess = end_window_excess_J(runs, base)
        above_W = np.maximum(base.cruise.at(v) - base.idle_W, 1e-9)
        t_each = 2 * excess / above_W
        t_dec = float(max(np.nanmean(t_each), 0.0))
        dof = len(t_each) - 1
        se = float(np.nanstd(t_each, ddof=1) / np.sqrt(len(t_each))) if dof > 0 else np.nan
        extra_W = float(np.nanmean(excess)) / t_dec if t_dec > 1e-3 else 0.0
        intercept, slope = base.idle_W + extra_W, 0.0
    half = t_quantile(0.975, dof) * se if dof > 0 else float("nan")
    ci95 = (t_dec - half, t_dec + half)
    if found.sum() >= 2 and "sample_period_s" in runs:
        # decel phases a sample or two long are known to a sample period, however alike
        # (issue 26: a 6.5 Hz log's every phase is one sample; segment/resolution.py)
        coarse = quantized_durations(durations[found], column(runs, "sample_period_s")[found])
        if coarse is not None:
            ci95 = coarse.floor_ci95(t_dec, ci95)
    return {
        T_DEC: t_dec,
        P_DEC0: intercept,
        P_DEC1: slope,
        "t_dec_ci95": ci95,
    }
