"""`accel_inertial`: accelerating mass costs ``m·a·v/η``; heavier payloads or steeper ramps
raise acceleration power beyond ``P_acc(v)``.

Term: ``+ kI·(m + payload)·a·v`` in acceleration (causes.md). The robot's own mass is inside
the fitted ``P_acc(v)``, so only the payload's part is added.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import (
    CHECK_ALPHA,
    Cause,
    Check,
    Evidence,
    RunTable,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.common import coefficient_evidence, distinct
from wifibot_power.causes.design import column, mixed_rows, stacked_design
from wifibot_power.causes.design import power_factor as factor_of
from wifibot_power.causes.spread import spread_check
from wifibot_power.stats import ols

if TYPE_CHECKING:
    import pandas as pd

KI = "kI"


class AccelInertial(Cause):
    """Plausible kI = 1/η: 1 to 10. A drivetrain cannot return more mechanical work than the
    electrical energy it takes (η <= 1, kI >= 1); small geared DC drives reach 20-70%, and
    below 10% efficiency (kI > 10) the motors would overheat at the paper's accelerations."""

    name = "accel_inertial"
    physics = "accelerating mass costs m a v / eta"
    term = "+ kI (m + payload) a v in acceleration"
    unit = "1/eta"
    parameter = KI
    parameters = (KI,)
    min_size = 0.5
    plausible = (1.0, 10.0)
    signature = "residual against payload"
    default_size = 4.6
    realistic_range = (2.5, 6.0)
    grid_payloads_kg = (0.0, 2.0, 4.0)
    own_patterns = ("payload_kg",)
    fit_stage = "column"
    energy_stage = "lump"

    def power_terms(self, runs: pd.DataFrame, value: float) -> dict[str, np.ndarray]:
        # payload · a · v(t) with v(t) = v u over the ramp: ramp1 in u
        v = column(runs, "speed_mps")
        accel_mps2 = v / column(runs, "t_acc_s")
        return {"ramp1": value * column(runs, "payload_kg") * accel_mps2 * v}

    def evidence(self, table: RunTable) -> Evidence:
        """Residual against payload: acceleration power rises with payload · a · v."""
        if distinct(column(table.runs, "payload_kg")) < 2:
            return Evidence(self.name, False, summary="needs runs with different payloads")
        return coefficient_evidence(
            self,
            table,
            "acceleration power rises with payload x acceleration x speed",
            "acceleration power falls with payload x acceleration x speed (not inertia)",
            "no change of acceleration power with payload x acceleration x speed "
            "distinguishable from zero",
        )

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [
            self._cruise_independent_of_payload(table),
            spread_check(self, table),
            self.plausible_check(evidence),
        ]

    def _cruise_independent_of_payload(self, table: RunTable) -> Check:
        """A cruise-only payload column added to the stacked fit (with kI in it): only
        acceleration may depend on payload."""
        runs = table.runs
        given = [c for c in table.given if c != self.name]
        X, y, _ = stacked_design(
            runs, [*given, self.name], table.model.idle_W, factor_of(runs, table.model.extensions)
        )
        n = len(runs)
        cruise_payload = np.zeros(2 * n)
        cruise_payload[n:] = column(runs, "payload_kg")
        # a row of acceleration and cruise together (`mixed_rows`) holds its cruise's share
        mixed, w_acc = mixed_rows(runs, [*given, self.name])
        cruise_payload[:n] = np.where(mixed, (1.0 - w_acc) * column(runs, "payload_kg"), 0.0)
        fit = ols(np.column_stack([X, cruise_payload]), y)
        p_value = fit.p_two_sided(X.shape[1])
        ok = not p_value < CHECK_ALPHA
        return Check(
            "only acceleration is affected; cruise does not depend on payload",
            bool(ok),
            f"cruise power {fit.coef[-1]:+.3g} W per kg of payload (p = {p_value:.2g})",
        )

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """Integrated over the ramp, ``∫ m a v dt = m v_peak² / 2`` (the kinetic energy):
        ``kI payload v_peak² / 2`` per step [J per trip]."""
        per_step = params[KI] * trip.payload_kg * trip.step.peak_speed_mps**2 / 2.0
        return 0.0, trip.steps * per_step

    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        """The payload's inertial power at 1/η = `size` instead of the robot's own."""
        extra = (size - trace.robot.inertial_k) * trace.payload_kg
        trace.motion_W += (trace.kind == 1) * extra * trace.accel_mps2 * trace.speed_mps
        return {}
