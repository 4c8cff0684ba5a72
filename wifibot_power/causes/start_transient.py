"""`start_transient`: inrush current / static-friction breakaway at every start.

Term: ``+ E_start`` per step, spent in the first ~0.2 s of acceleration (causes.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import (
    CHECK_ALPHA,
    MATERIAL_FRACTION,
    Cause,
    Check,
    Evidence,
    RunTable,
    RunView,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.design import (
    column,
    measured_duration_prediction_J,
    phase_power_terms,
    stacked_fit,
)
from wifibot_power.causes.design import power_factor as factor_of
from wifibot_power.causes.spread import spread_check
from wifibot_power.stats import ols, one_sample_p_greater
from wifibot_power.traces import windows_after

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel

E_START = "E_start_J"
#: Length of the window after each acceleration start where a start transient sits [s].
START_WINDOW_S = 0.25


class StartTransient(Cause):
    """Plausible E_start: 0 to 30 J per step. Inrush is bounded by the stall current: four
    motors at ~10 A and 12 V for at most ~0.05 s (their electrical time constant) is ~25 J."""

    name = "start_transient"
    physics = "inrush current / static-friction breakaway at every start"
    term = "+ E_start per step, in the first ~0.2 s of acceleration"
    unit = "J"
    parameter = E_START
    parameters = (E_START,)
    min_size = 0.5
    plausible = (0.0, 30.0)
    signature = "residual per step count, located at the start of acceleration"
    default_size = 3.0
    realistic_range = (1.5, 8.0)
    fit_stage = "column"
    energy_stage = "lump"
    columns = (
        "start_measured_J",
        "start_accel_s",
        "start_ramp_s",
        "start_ramp2_s",
        "start_cruise_s",
    )
    #: Half the evidence's start window (0.25 s): a decaying transient of causes.md's "~0.2 s"
    #: has spent most of its energy by then (the simulator's inrush, τ = 50 ms cut at 0.2 s:
    #: 96%; uncut, 92%). A run that accelerates for less (0.1 m/s: 0.1 s, 8.8% of the
    #: simulated inrush in its cruise, 13.5% of an uncut one) is fitted on
    #: acceleration and cruise together; one that accelerates longer (0.2 m/s: 0.2 s, all of
    #: it) keeps its acceleration row, whose 1/t_acc is the lump's most telling column. At
    #: the whole window (0.25 s), the 0.2 m/s runs lost it and the lump, left to the faster
    #: runs, took up an unmodelled k2 v²: speed_quadratic beside it was missed on the tests'
    #: grid (docs/diagnose.md, "The same at field realism on the study's own grid")
    lump_within_s = START_WINDOW_S / 2

    def energy_windows(self, view: RunView) -> tuple[list[int], list[int]]:
        """Each step's start window: its first START_WINDOW_S of acceleration, and of the
        cruise after it when the acceleration is shorter (ending at the cruise's end)."""
        steps = view.steps
        period_s = view.run.sample_period_s
        return windows_after(steps.accel_start, START_WINDOW_S, steps.cruise_end, period_s)

    def run_stats(self, view: RunView) -> dict[str, float]:
        """The start windows' measured energy [J] and, summed over steps, their time in
        acceleration and in cruise [s] and the sums over their acceleration samples of
        u = (t - t_a0) / t_acc and u² times dt [s]: sufficient statistics, linear in the
        model's coefficients, of the modelled energy in the windows
        (`start_window_excess_J`)."""
        dt = view.run.sample_period_s
        accel_s = ramp_s = ramp2_s = cruise_s = 0.0
        starts, stops = view.windows_of(self)
        for ia0, ia1, i_stop in zip(starts, view.steps.accel_end, stops, strict=True):
            n_acc = min(i_stop, ia1) - ia0
            # u at the middle of each accel sample in the window (an arithmetic series)
            n_ramp = ia1 - ia0
            sum_u = (n_acc * n_acc / 2.0) / n_ramp
            # sum of ((j + 0.5) / n)² for j < m: (m³/3 - m/12) / n²
            sum_u2 = (n_acc**3 / 3.0 - n_acc / 12.0) / n_ramp**2
            accel_s += n_acc * dt
            ramp_s += sum_u * dt
            ramp2_s += sum_u2 * dt
            cruise_s += max(i_stop - ia1, 0) * dt
        return {
            "start_measured_J": float(view.window_energies_J(self).sum()) if starts else 0.0,
            "start_accel_s": accel_s,
            "start_ramp_s": ramp_s,
            "start_ramp2_s": ramp2_s,
            "start_cruise_s": cruise_s,
        }

    def lump_J_per_step(self, runs: pd.DataFrame, value: float) -> np.ndarray:
        return np.full(len(runs), float(value))

    def evidence(self, table: RunTable) -> Evidence:
        """A fixed energy per step, located in the first 0.25 s of each acceleration.

        Two tests must both hold: the per-step energy column of the stacked fit (residual per
        step count), and the excess over the modelled ramp in the start window (where it
        sits). The ramp is that of the lines fitted together with the per-step term, so it
        is not inflated by the transient it is meant to reveal.
        """
        coef, fit, names = stacked_fit(table.runs, [*table.given, self.name], table.model)
        j = names.index(E_START)
        excess_J = start_window_excess_J(table.runs, coef, table.model)
        mean_J, _, p_window = one_sample_p_greater(excess_J)
        estimate = float(fit.coef[j])
        return Evidence(
            self.name,
            True,
            max(fit.p_greater(j), p_window),
            estimate,
            fit.ci95(j),
            {E_START: estimate, "start_window_J": mean_J},
            f"extra {estimate:.3g} J per step, {mean_J:.3g} J of it in the first 0.25 s of "
            "acceleration",
        )

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [
            self._per_step_not_per_distance(table),
            self._at_the_start(evidence),
            spread_check(self, table),
            self.plausible_check(evidence),
        ]

    def _per_step_not_per_distance(self, table: RunTable) -> Check:
        """Each run's energy left by the lines alone (fitted with the per-step term, which
        is then left out) against steps, steps x speed and distance: it must not grow with
        the distance or the speed."""
        runs = table.runs
        coef, _, _ = stacked_fit(runs, [*table.given, self.name], table.model)
        without = {k: v for k, v in coef.items() if k != E_START}
        predicted_J, _ = measured_duration_prediction_J(
            runs, without, factor_of(runs, table.model.extensions), table.model.idle_W
        )
        measured_J = column(runs, "accel_energy_J") + column(runs, "cruise_energy_J")
        steps = column(runs, "steps_found")
        X = np.column_stack([steps, steps * column(runs, "speed_mps"), column(runs, "distance_m")])
        fit = ols(X, measured_J - predicted_J)
        p_steps, p_speed, p_dist = fit.p_greater(0), fit.p_two_sided(1), fit.p_two_sided(2)
        # that it is there per step is the signature's test (the stacked fit and the start
        # window); here, on the noisier run energies, only that it is not per metre or per
        # unit of speed (another cause not yet modelled makes the per-step part noisy here):
        # either fails when significant and material, its largest share of a step's extra
        # (at the fastest speed, the longest distance per step) a tenth of it or more
        per_step_J = abs(float(fit.coef[0]))
        speed_J = abs(float(fit.coef[1])) * float(np.max(column(runs, "speed_mps")))
        metres = column(runs, "distance_m") / np.maximum(steps, 1.0)
        dist_J = abs(float(fit.coef[2])) * float(np.max(metres))
        by_speed = p_speed < CHECK_ALPHA and speed_J >= MATERIAL_FRACTION * per_step_J
        by_dist = p_dist < CHECK_ALPHA and dist_J >= MATERIAL_FRACTION * per_step_J
        ok = not by_speed and not by_dist
        return Check(
            "grows with steps, not with distance or speed",
            bool(ok),
            f"{fit.coef[0]:.3g} J per step (p = {p_steps:.2g}); per step and m/s "
            f"{fit.coef[1]:.3g} J (p = {p_speed:.2g}, up to {speed_J:.2g} J a step); per m "
            f"{fit.coef[2]:.3g} J (p = {p_dist:.2g}, up to {dist_J:.2g} J a step)",
        )

    def _at_the_start(self, evidence: Evidence) -> Check:
        window_J = evidence.parameters.get("start_window_J", float("nan"))
        ok = bool(np.isfinite(window_J) and window_J >= 0.5 * evidence.estimate)
        return Check(
            "sits at the start of acceleration",
            ok,
            f"{window_J:.3g} J of the {evidence.estimate:.3g} J per step is in the first "
            "0.25 s of acceleration (at least half must be)",
        )

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """``+ E_start`` per step [J per trip]."""
        return 0.0, trip.steps * params[E_START]

    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        """A decaying pulse (time constant `start_transient_tau_s`) that reaches zero at the
        end of its window, holding `size` J, at the start of every acceleration."""
        robot, dt = trace.robot, trace.dt_s
        tau = robot.start_transient_tau_s
        window = round(robot.start_transient_window_s / dt)
        t_local = (np.arange(window) + 0.5) * dt
        pulse = np.clip(np.exp(-t_local / tau) - np.exp(-window * dt / tau), 0.0, None)
        pulse *= size / (pulse.sum() * dt)
        n = trace.motion_W.size
        for (name, _, _, _, _), start in zip(trace.plan, trace.bounds[:-1], strict=True):
            if name == "accel":
                stop = min(start + window, n)
                trace.motion_W[start:stop] += pulse[: stop - start]
        return {}


def start_window_excess_J(runs: pd.DataFrame, coef: dict[str, float], model: PowerModel):
    """Measured minus modelled energy in the start window, per step [J] (E_start not in the
    model: it is what the window should reveal)."""
    terms = phase_power_terms(runs, coef)
    predicted = (
        terms["ramp0"] * column(runs, "start_accel_s")
        + terms["ramp1"] * column(runs, "start_ramp_s")
        + terms["ramp2"] * column(runs, "start_ramp2_s")
        + terms["cruise"] * column(runs, "start_cruise_s")
    )
    factor = factor_of(runs, model.extensions)
    window_s = column(runs, "start_accel_s") + column(runs, "start_cruise_s")
    predicted = model.idle_W * window_s + (predicted - model.idle_W * window_s) * factor
    steps = np.clip(column(runs, "steps_found"), 1, None)
    return (column(runs, "start_measured_J") - predicted) / steps
