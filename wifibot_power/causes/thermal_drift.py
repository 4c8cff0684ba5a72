"""`thermal_drift`: winding resistance rises as the motors warm, so motion power creeps up
with the motor-on time accumulated in a session.

Term: ``× (1 + α·τ_on)`` on motion power above idle (causes.md), ``τ_on`` in minutes.
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
    RunView,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.design import column, measured_duration_prediction_J, stacked_fit
from wifibot_power.changepoint import block_means
from wifibot_power.sinusoid import detrended, refined_hz
from wifibot_power.stats import ols, t_quantile, t_sf

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel

ALPHA_PER_MIN = "alpha_per_min"
#: each cruise loses this much at either end before its trend is taken (the ends hold the
#: tails of acceleration and the start of the stop, not drift) [fraction of its length]
CRUISE_TRIM = 0.05
#: block length the within-cruise trend is fitted on [s]
BLOCK_S = 0.01
#: probability with which the within-run creep check must be able to see the creep the
#: between-run α implies before its absence counts against the name
CREEP_POWER = 0.9
#: A gap longer than this between one run's end and the next's start ends a session: the
#: motors have cooled [s].
SESSION_GAP_S = 30 * 60.0


class ThermalDrift(Cause):
    """Plausible α: 0 to 0.05 per minute. Copper's resistance rises 0.39% per kelvin, and the
    windings of small DC motors warm by at most ~10 K per minute of driving at the paper's
    loads, so motion power above idle cannot creep faster than ~4% per minute."""

    name = "thermal_drift"
    physics = "winding resistance rises as motors warm"
    term = "x (1 + alpha tau_on) on motion power above idle"
    unit = "1/min"
    parameter = ALPHA_PER_MIN
    parameters = (ALPHA_PER_MIN,)
    min_size = 0.001
    plausible = (0.0, 0.05)
    signature = "residual trend in session order"
    default_size = 0.005
    realistic_range = (0.003, 0.02)
    fit_stage = "scale"
    energy_stage = "scale"
    inject_order = 1
    columns = ("creep_s_tp", "creep_s_tt", "creep_power_W", "tau_before_min", "tau_mid_min")
    #: the session clock's minutes before each run, beside its held-out error
    table_columns = ("tau_before_min",)

    def run_stats(self, view: RunView) -> dict[str, float]:
        """Trend of power within the run's cruises (their middle 90%), pooled over them.

        Each cruise, in 10 ms block means, is fitted by least squares with a level, a line
        in time and the sinusoid at its strongest spectral peak (0.1-20 Hz): a wheel
        ripple of 1 W tilts a line through a 10 s cruise by ~0.01 W/s, twenty times the
        creep of a warming motor, so it is fitted out. Per cruise, its slope b and the
        information I = 1 / (XᵀX)⁻¹_tt (S_tt without a sinusoid) are kept; the run's are
        ``creep_s_tp = Σ I b`` and ``creep_s_tt = Σ I``, with the cruises' mean power."""
        run, segmentation = view.run, view.segmentation
        s_tp = s_tt = energy = seconds = 0.0
        dt = run.sample_period_s
        per_block = max(1, round(BLOCK_S / dt))
        for phase in segmentation.phases:
            if phase.phase != "cruise":
                continue
            n = phase.i_end - phase.i_start
            cut = int(n * CRUISE_TRIM)
            x = run.power_W[phase.i_start + cut : phase.i_end - cut]
            blocks = x.size // per_block
            if blocks < 20:
                continue
            y = block_means(x, per_block)
            block_s = per_block * dt
            t = (np.arange(blocks) - (blocks - 1) / 2.0) * block_s
            X = np.column_stack([np.ones(blocks), t, *_strongest_sinusoid(y, t, block_s)])
            # least squares by the normal equations (4 columns, well conditioned: a level,
            # a centred line and a sine and cosine over many periods); their inverse gives
            # the slope's information too, so no SVD is needed (two took 0.2 ms a cruise)
            gram_inverse = np.linalg.inv(X.T @ X)
            slope = float(gram_inverse[1] @ (X.T @ y))
            information = 1.0 / float(gram_inverse[1, 1])
            s_tp += information * slope
            s_tt += information
            energy += float(x.sum()) * dt
            seconds += x.size * dt
        return {
            "creep_s_tp": s_tp,
            "creep_s_tt": s_tt,
            "creep_power_W": energy / seconds if seconds > 0 else float("nan"),
        }

    def session_columns(self, runs: pd.DataFrame) -> dict[str, np.ndarray]:
        """The session clock: motor-on minutes accumulated in the session before each run
        (``tau_before_min``) and at its middle (``tau_mid_min``).

        Runs are taken in `session_order` (by `started_at`); a gap of over 30 min ends a
        session (motors cool). Runs without `started_at` get NaN (thermal drift is then not
        testable)."""
        import pandas as pd

        motion_s = pd.Series(
            np.where(
                runs["mode"] == "motion",
                runs["t_acc_s"].fillna(0) * runs["steps_found"]
                + runs["cruise_duration_s"].fillna(0)
                + runs["decel_duration_s"].fillna(0) * runs["steps_found"],
                0.0,
            )
        )
        tau_before = np.full(len(runs), np.nan)
        tau_mid = np.full(len(runs), np.nan)
        rank = runs["session_order"].to_numpy()
        timed = np.flatnonzero(rank >= 0)
        if timed.size:
            order = timed[np.argsort(rank[timed])]  # positions, in time order
            start = runs["started_at"].iloc[order].reset_index(drop=True)
            end = start + pd.to_timedelta(runs["duration_s"].iloc[order].to_numpy(), unit="s")
            new_session = (start - end.shift()).dt.total_seconds().fillna(np.inf) > SESSION_GAP_S
            session = new_session.cumsum()
            motion = motion_s.iloc[order].reset_index(drop=True)
            before = motion.groupby(session).cumsum() - motion
            tau_before[order] = before.to_numpy() / 60.0
            tau_mid[order] = (before + motion / 2).to_numpy() / 60.0
        return {"tau_before_min": tau_before, "tau_mid_min": tau_mid}

    def trip_inputs(self, runs: pd.DataFrame) -> dict[str, np.ndarray]:
        """The minutes of motor-on time before each run in its session (0: from cold, and
        where the logs do not say)."""
        tau = column(runs, "tau_before_min")
        return {"motor_on_before_min": np.where(np.isfinite(tau), tau, 0.0)}

    def power_factor(self, runs: pd.DataFrame, params: dict[str, float]) -> np.ndarray:
        return 1.0 + params[ALPHA_PER_MIN] * column(runs, "tau_mid_min")

    def estimate(
        self, runs: pd.DataFrame, coef: dict[str, float], model: PowerModel
    ) -> dict[str, float]:
        return {ALPHA_PER_MIN: thermal_alpha(runs, coef, model.idle_W)[0]}

    def identifiable(self, runs: pd.DataFrame) -> str | None:
        tau = column(runs, "tau_mid_min")
        if not np.isfinite(tau).all() or np.ptp(tau) <= 0:
            return "needs started_at on every run and motor-on time that grows"
        return None

    def evidence(self, table: RunTable) -> Evidence:
        """Residual trend in session order: motion power above idle, relative to the model,
        grows with the motor-on minutes accumulated before it."""
        runs, model = table.runs, table.model
        tau = column(runs, "tau_mid_min")
        if not np.isfinite(tau).all() or np.ptp(tau) < 1.0:
            return Evidence(
                self.name,
                False,
                summary="needs started_at on every run and a session over a minute of motion",
            )
        cold = model.with_extensions({}, model.source)
        coef, _, _ = stacked_fit(runs, [c for c in table.given if c != self.name], cold)
        alpha, ci, p_value = thermal_alpha(runs, coef, model.idle_W)
        return Evidence(
            self.name,
            True,
            p_value,
            alpha,
            ci,
            {ALPHA_PER_MIN: alpha},
            f"motion power above idle grows {100 * alpha:.3g}% per minute of motor-on time",
        )

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [
            self._smooth_not_a_jump(table),
            self._creep_within_runs(table, evidence),
            self.plausible_check(evidence),
        ]

    def _ratios(self, table: RunTable) -> tuple[np.ndarray, np.ndarray]:
        runs, model = table.runs, table.model
        cold = model.with_extensions({}, model.source)
        coef, _, _ = stacked_fit(runs, [c for c in table.given if c != self.name], cold)
        return above_idle_ratio(runs, coef, model.idle_W), column(runs, "tau_mid_min")

    def _smooth_not_a_jump(self, table: RunTable) -> Check:
        """Measured over modelled power above idle, per run, in motor-on order: a step added
        to a line in motor-on time must not explain what the line leaves. This asks for a
        jump to be *absent*, so it fails only when the data show one (p < CHECK_ALPHA): the
        best split's t-test of the step beside the line, Bonferroni over the splits tried
        (at least `MIN_SEGMENT_RUNS` runs on either side). A warming winding gives a smooth
        curve; a change of conditions between two runs, a step."""
        name = "smooth in motor-on time, not a jump between runs"
        ratio, tau = self._ratios(table)
        jump = step_beside_line(ratio, tau)
        if jump is None:
            return Check(
                name,
                True,
                f"not testable here: {ratio.size} runs are too few to look for a jump",
            )
        p_value, after, size, se, splits = jump
        return Check(
            name,
            bool(p_value >= CHECK_ALPHA),
            f"the best step beside a line in motor-on time (after run {after} of "
            f"{ratio.size} in motor-on order) is {100 * size:+.2g}% ± {100 * se:.2g}% of power "
            f"above idle (p = {p_value:.2g} over {splits} splits; a jump fails at "
            f"p < {CHECK_ALPHA:g})",
        )

    def _creep_within_runs(self, table: RunTable, evidence: Evidence) -> Check:
        """The trend of power within each run's cruises, against the run's cruise power above
        idle (before warming): the slope is α/60 per second of driving. Fitted over runs by
        least squares weighted by each run's S_tt, so the scatter of the runs' slopes (not
        a noise model) gives the error.

        causes.md asks that *long runs* show the same creep within themselves. Whether the
        batch's runs are long enough is read from that error: the creep of the α found
        between runs would be seen within them (one-sided, p < CHECK_ALPHA) with at least
        `CREEP_POWER` probability when α / se >= the sum of the two t quantiles. The check
        passes only when the creep is seen and agrees with α (two-sided, at CHECK_ALPHA).
        When it is not seen, the detail says which of three it is: the runs contradict α
        (a creep far from it), they could have shown it and do not, or they are too short to
        show it (the detail starts "not testable here" and says how much longer, or how many
        more, cruises would test it). The last fails too: causes.md asks that the consequence
        be *seen*, and a session effect that is not warming (a change of conditions, a trend
        in the session that stays flat inside each run) shows the same trend between runs, so
        a name resting on that alone would be a guess (docs/diagnose.md, "What the checks cost")."""
        name = "the same creep within runs"
        runs, idle_W = table.runs, table.model.idle_W
        s_tt = column(runs, "creep_s_tt")
        keep = s_tt > 0
        if keep.sum() < 3:
            return Check(name, False, "too few cruises to see a trend")
        slope_W_per_s = column(runs, "creep_s_tp")[keep] / s_tt[keep]
        # above each run's own idle, as the ratio between runs (`above_idle_ratio`)
        above_W = column(runs, "creep_power_W")[keep] - own_idle_W(runs, idle_W)[keep]
        tau = column(runs, "tau_mid_min")[keep]
        cold_W = above_W / (1.0 + evidence.estimate * tau)
        # weighted by S_tt: a slope's variance under white noise is sigma² / S_tt
        weight = np.sqrt(s_tt[keep])
        fit = ols((weight * cold_W / 60.0)[:, None], weight * slope_W_per_s)
        within, se = float(fit.coef[0]), float(fit.se[0])
        p_there = fit.p_greater(0)
        low_b, high_b = evidence.ci95
        se_between = (high_b - low_b) / (2 * t_quantile(0.975, max(len(runs) - 2, 1)))
        spread = np.hypot(se, se_between)
        z = abs(within - evidence.estimate) / spread if spread > 0 else float("inf")
        dof = max(fit.dof, 1)
        limit = t_quantile(1 - CHECK_ALPHA / 2, dof)
        agrees = z <= limit
        found = (
            f"within runs {100 * within:.3g}%/min ± {100 * se:.2g} (p = {p_there:.2g}), "
            f"between runs {100 * evidence.estimate:.3g}%/min ({z:.2g} standard errors "
            f"apart, at most {limit:.2g})"
        )
        needed = t_quantile(1 - CHECK_ALPHA, dof) + t_quantile(CREEP_POWER, dof)
        seen_at = evidence.estimate / se if se > 0 else float("inf")
        if not agrees:
            return Check(name, False, f"the creep within runs contradicts α: {found}")
        if p_there < CHECK_ALPHA:
            return Check(name, True, found)
        if seen_at >= needed:
            return Check(name, False, f"not seen where the runs could show it: {found}")
        # the slope error of a cruise falls as its length^1.5, and as sqrt of their number
        factor = needed / max(seen_at, 1e-9)
        return Check(
            name,
            False,
            detail=f"not testable here: the runs are too short to show this creep within them "
            f"({seen_at:.2g} standard errors, {needed:.2g} needed: cruises "
            f"{factor ** (2 / 3):.2g}x as long, or {factor**2:.2g}x as many), and a session "
            f"trend that is not warming would look the same between runs; {found}",
        )

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """``× (1 + α τ_on)`` on the trip's power above idle [J per trip]. The trip starts
        `motor_on_before_min` into the session (0: from cold) and its power above idle is
        spread evenly over its motor-on time T, so the factor averages
        ``1 + α (τ_0 + T / 2)``. The energy above idle covers the phase powers (acceleration,
        cruise, deceleration and the "power" terms), not the per-step lumps."""
        mean_tau_min = trip.motor_on_before_min + trip.motion_time_s / 60.0 / 2.0
        return 0.0, params[ALPHA_PER_MIN] * mean_tau_min * trip.motion_above_idle_J

    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        on_min = trace.motor_on_before_min + np.cumsum(trace.moving) * trace.dt_s / 60.0
        trace.motion_W *= 1.0 + size * on_min
        return {}


def _strongest_sinusoid(y: np.ndarray, t: np.ndarray, block_s: float) -> list[np.ndarray]:
    """sin and cos columns (over centred `t`) at the strongest periodogram peak of `y`
    (linear trend removed) between 0.1 and 20 Hz, refined (`sinusoid.refined_hz`), or
    none when the band holds fewer than 3 frequencies."""
    residual = detrended(y, block_s)  # only the peak's frequency is taken from it
    freqs = np.fft.rfftfreq(y.size, block_s)
    band = (freqs >= 0.1) & (freqs <= min(20.0, 0.5 / block_s))
    if band.sum() < 3:
        return []
    power = np.abs(np.fft.rfft(residual)) ** 2
    peak = float(freqs[band][np.argmax(power[band])])
    # the periodogram's grid is 1/T: refined within one bin either side (a sinusoid off
    # by half a bin would leave most of its tilt in the line)
    hz = refined_hz(residual, block_s, peak)
    return [np.sin(2 * np.pi * hz * t), np.cos(2 * np.pi * hz * t)]


def above_idle_ratio(runs: pd.DataFrame, coef: dict[str, float], idle_W: float) -> np.ndarray:
    """Measured over modelled acceleration + cruise energy above idle, minus 1, per run.

    The measured energy is taken above the run's own idle level (its idle phases' mean
    power): an offset of a run's whole trace (the electronics' or the analyser's zero moving
    by 0.1 W between runs) is not motion power, and against the 3 W a robot draws above
    idle at 0.2 m/s it would read as a 3% change of it. The modelled energy is taken above
    the mean of those levels, the idle the lines fitted on these runs carry in their
    intercepts (the idle logs' `idle_W` may sit 0.1 W away, which would tilt the ratio
    against speed). Runs without idle phases fall back on `idle_W`."""
    predicted_J, seconds = measured_duration_prediction_J(runs, coef)
    measured_J = column(runs, "accel_energy_J") + column(runs, "cruise_energy_J")
    runs_idle_W = own_idle_W(runs, idle_W)
    lines_idle_W = float(runs_idle_W.mean()) if runs_idle_W.size else idle_W
    return (measured_J - runs_idle_W * seconds) / (predicted_J - lines_idle_W * seconds) - 1.0


def own_idle_W(runs: pd.DataFrame, idle_W: float) -> np.ndarray:
    """Each run's own idle level (its idle phases' mean power), `idle_W` where it has none."""
    level_W = column(runs, "idle_mean_power_W")
    return np.where(np.isfinite(level_W), level_W, idle_W)


def thermal_alpha(
    runs: pd.DataFrame, coef: dict[str, float], idle_W: float
) -> tuple[float, tuple[float, float], float]:
    """Slope of (measured/modelled power above idle - 1) against tau_mid [1/min]."""
    ratio = above_idle_ratio(runs, coef, idle_W)
    tau = column(runs, "tau_mid_min")
    fit = ols(np.column_stack([np.ones_like(tau), tau]), ratio)
    # the fitted lines absorb the mean drift: ratio ~ α (τ - τ̄) / (1 + α τ̄), so the
    # slope b gives α = b / (1 - b τ̄)
    scale = 1.0 / max(1.0 - float(fit.coef[1]) * float(tau.mean()), 1e-6)
    alpha = float(fit.coef[1]) * scale
    lo, hi = fit.ci95(1)
    return alpha, (lo * scale, hi * scale), fit.p_greater(1)


def step_beside_line(y: np.ndarray, x: np.ndarray) -> tuple[float, int, float, float, int] | None:
    """The best single step in `y`, ordered by `x`, added beside a line in `x` (at least
    `MIN_SEGMENT_RUNS` points either side): its p-value (two-sided t of the step, times the
    number of splits tried: Bonferroni, so at most `alpha` of straight lines with white
    errors show one at `alpha`), the points before it, its size and standard error, and the
    splits tried; None when there are too few points (under 5, or no split).

    Every split at once: with the line projected out, the step's extra sum of squares is
    ``(r~ . s~)² / (s~ . s~)``, r~ and s~ the residuals of `y` and of the step."""
    from wifibot_power.residuals import MIN_SEGMENT_RUNS  # loads pandas: not at import

    order = np.argsort(x, kind="stable")
    r, t = np.asarray(y, np.float64)[order], np.asarray(x, np.float64)[order]
    n = r.size
    splits = np.arange(MIN_SEGMENT_RUNS, n - MIN_SEGMENT_RUNS + 1)
    if splits.size == 0 or n < 5:
        return None
    line = np.column_stack([np.ones(n), t])
    project = np.eye(n) - line @ np.linalg.pinv(line)
    steps = (np.arange(n)[:, None] >= splits[None, :]).astype(np.float64)
    steps_res = project @ steps
    r_res = project @ r
    extra = (r_res @ steps_res) ** 2 / np.einsum("ij,ij->j", steps_res, steps_res)
    dof = n - 3
    t_stat = np.sqrt(extra / np.maximum((float(r_res @ r_res) - extra) / dof, 1e-300))
    best = int(np.argmax(t_stat))
    p_value = min(1.0, splits.size * 2.0 * t_sf(float(t_stat[best]), dof))
    fit = ols(np.column_stack([line, steps[:, best]]), r)
    return p_value, int(splits[best]), float(fit.coef[2]), float(fit.se[2]), int(splits.size)
