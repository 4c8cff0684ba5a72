"""`speed_quadratic`: copper (I²R) losses and viscous friction grow with the square of speed.

Term: ``+ k2·v²`` in cruise and acceleration power (causes.md). Over a linear ramp the
mean of ``v(t)²`` is ``v²/3``.
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

K2 = "k2_W_per_mps2"
#: k2 in acceleration and in cruise differ when they differ by more than this fraction
SAME_FRACTION = 0.2


class SpeedQuadratic(Cause):
    """Plausible k2: 0 to 100 W/(m/s)². The v² loss is drawn by the drive, so at 1 m/s it
    cannot exceed what the drive can take in: four motors at 12 V and ~2 A rated, ~100 W.
    (The paper's robot draws ~12 W above idle at 1 m/s in all.)"""

    name = "speed_quadratic"
    physics = "copper (I²R) losses and viscous friction grow with speed²"
    term = "+ k2 v² in cruise and acceleration power"
    unit = "W/(m/s)^2"
    parameter = K2
    parameters = (K2,)
    min_size = 1.0
    plausible = (0.0, 100.0)
    signature = "residual curvature against speed"
    default_size = 5.0
    realistic_range = (3.0, 10.0)
    fit_stage = "column"
    energy_stage = "power"

    def power_terms(self, runs: pd.DataFrame, value: float) -> dict[str, np.ndarray]:
        v2 = column(runs, "speed_mps") ** 2
        return {"ramp2": value * v2, "cruise": value * v2}

    def evidence(self, table: RunTable) -> Evidence:
        """Residual curvature against speed: the k2 v² column of the stacked fit, one-sided."""
        if distinct(column(table.runs, "speed_mps")) < 3:
            return Evidence(self.name, False, summary="needs runs at 3 or more speeds")
        return coefficient_evidence(
            self,
            table,
            "phase power curves upward with speed",
            "phase power curves downward with speed (not a drag that grows with speed)",
            "no curvature of phase power with speed distinguishable from zero",
        )

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [
            self._same_in_both_phases(table),
            self._no_lack_of_fit(table),
            spread_check(self, table),
            self.plausible_check(evidence),
        ]

    def _design(self, table: RunTable):
        given = [c for c in table.given if c != self.name]
        factor = factor_of(table.runs, table.model.extensions)
        return stacked_design(table.runs, [*given, self.name], table.model.idle_W, factor)

    def _same_in_both_phases(self, table: RunTable) -> Check:
        """k2 fitted separately in acceleration and in cruise rows: k2 > 0 in cruise, and
        acceleration's not different: an acceleration-only extra k2 that is significant
        (two-sided t) and material (over a fifth of k2), or an acceleration k2 shown below
        zero (one-sided t at `CHECK_ALPHA`). Its sign alone is not a test: acceleration
        means hold a k2 to a few W/(m/s)², so a true k2 of 6 reads negative in a few % of
        batches (measured: -0.15 beside 5.76 in cruise, difference p = 0.07). Phase means
        known to mW make a 1.5% difference significant (measured on simulated runs:
        segmentation moves acceleration means)."""
        X, y, names = self._design(table)
        j = names.index(K2)
        n = len(table.runs)
        accel_only = np.zeros(2 * n)
        # acceleration rows only: a row of acceleration and cruise together is mostly cruise
        mixed, _ = mixed_rows(table.runs, [*table.given, self.name])
        accel_only[:n] = np.where(mixed, 0.0, X[:n, j])
        # the split with acceleration's k2 as a coefficient of its own: its sign's test
        own = X.copy()
        own[:n, j] = np.where(mixed, X[:n, j], 0.0)
        p_negative = 1.0 - ols(np.column_stack([own, accel_only]), y).p_greater(X.shape[1])
        # and with the acceleration-only extra k2 beside the common one: the difference
        split = ols(np.column_stack([X, accel_only]), y)
        k2_cruise = float(split.coef[j])
        k2_accel = k2_cruise + float(split.coef[-1])
        p_diff = split.p_two_sided(X.shape[1])
        differ = p_diff < CHECK_ALPHA and abs(k2_accel - k2_cruise) > SAME_FRACTION * abs(k2_cruise)
        ok = k2_cruise > 0 and not differ and not p_negative < CHECK_ALPHA
        return Check(
            "same k2 > 0 in acceleration and cruise",
            bool(ok),
            f"k2 {k2_accel:.3g} in acceleration, {k2_cruise:.3g} in cruise W/(m/s)² "
            f"(difference p = {p_diff:.2g}; acceleration's below zero p = {p_negative:.2g})",
        )

    def _no_lack_of_fit(self, table: RunTable) -> Check:
        """With k2 v² added, each phase's means sit on the model across speed levels within
        the spread of repeated runs: per phase, the lack-of-fit F test against pure error
        (rows of one speed and payload are replicates). Structure left fails the check when
        it is significant and material: at least a tenth (RMS) of the curvature the v² term
        explains, so mW-level segmentation effects on very precise means do not count, and
        a v² fitted to something that is not a parabola does."""
        X, y, names = self._design(table)
        j = names.index(K2)
        runs = table.runs
        n = len(runs)
        config = np.array(
            [
                f"{v:.6g}|{p:.6g}"
                for v, p in zip(column(runs, "speed_mps"), column(runs, "payload_kg"), strict=True)
            ]
        )
        # each phase's own rows: a row of acceleration and cruise together (`mixed_rows`) is
        # left out of the acceleration's, where its cruise columns would add a parameter
        # only those runs load on and take up their level's misfit
        mixed, _ = mixed_rows(runs, [*table.given, self.name])
        accel = np.flatnonzero(~mixed)
        details, ok = [], True
        for phase, rows in (("acceleration", accel), ("cruise", np.arange(n, 2 * n))):
            Xp, yp = X[rows], y[rows]
            used = np.flatnonzero(np.any(Xp != 0, axis=0))
            k = int(np.searchsorted(used, j))
            with_k2 = ols(Xp[:, used], yp)
            without = ols(np.delete(Xp[:, used], k, axis=1), yp)
            p_value, df_lof, df_pe = with_k2.lack_of_fit(config[rows % n])
            if not np.isfinite(p_value):
                return Check(
                    "no structure left across speed levels",
                    False,
                    f"not testable in {phase}: needs repeated runs at more speeds "
                    f"({df_lof} lack-of-fit, {df_pe} pure-error dof)",
                )
            labels = np.unique(config[rows % n], return_inverse=True)[1]
            level_means = np.bincount(labels, with_k2.residual) / np.bincount(labels)
            left_W = float(np.sqrt(np.mean(level_means[labels] ** 2)))
            explained_W = float(np.sqrt(np.mean((without.residual - with_k2.residual) ** 2)))
            material = left_W >= MATERIAL_FRACTION * explained_W
            ok = ok and not (p_value < CHECK_ALPHA and material)
            details.append(
                f"{phase}: lack of fit p = {p_value:.2g}, {1000 * left_W:.3g} mW left by speed "
                f"level vs {1000 * explained_W:.3g} mW the v² term explains"
            )
        return Check("no structure left across speed levels", bool(ok), "; ".join(details))

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """``+ k2 v²`` [J per trip]: cruise ``k2 v² t_cruise``; acceleration: the ramp is
        linear in time, so the mean of ``v(t)²`` over it is ``v_peak² / 3``."""
        step, k2 = trip.step, params[K2]
        cruise_J = k2 * step.speed_mps**2 * step.cruise_s
        accel_J = k2 * step.peak_speed_mps**2 / 3.0 * step.accel_s
        return 0.0, trip.steps * (cruise_J + accel_J)

    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        trace.motion_W += size * trace.speed_mps**2 * trace.moving
        return {}
