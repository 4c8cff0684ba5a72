"""The named causes of shared/spec/causes.md: a registry of model terms and evidence tests.

Each `Cause` holds its physics, the term it adds to the paper's model, the unit of its size,
the metric its gain is measured on, the smallest size worth naming, and its evidence test.
`fit_model` fits the paper's model extended by any set of causes, on any subset of runs
(the held-out machinery of `diagnose` calls it on training folds only).

All tests take a per-run table: `runtable.run_row` columns plus the trace statistics of
`traces.TraceStats.as_row` and `tau_mid_min` (motor-on minutes in the session at the
middle of the run), one row per usable motion run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy import stats

from wifibot_power.energy import trip_energy
from wifibot_power.fit import fit_line, fit_table
from wifibot_power.model import LinearFit, PowerModel
from wifibot_power.stats import ols, one_sample_p_greater

#: Significance level of every evidence test (strict: six causes are tested on every batch).
ALPHA = 1e-3
#: A periodogram peak counts for a run below this p-value (Fisher's g-test).
RIPPLE_RUN_ALPHA = 0.01


@dataclass(frozen=True)
class Evidence:
    """What one evidence test found on a batch of runs."""

    cause: str
    testable: bool
    p_value: float = float("nan")
    estimate: float = float("nan")
    ci95: tuple[float, float] = (float("nan"), float("nan"))
    parameters: dict[str, float] = field(default_factory=dict)
    summary: str = ""

    @property
    def significant(self) -> bool:
        return self.testable and np.isfinite(self.p_value) and self.p_value < ALPHA

    @property
    def passes(self) -> bool:
        """Significant and at least the smallest size worth naming."""
        return self.significant and self.estimate >= CAUSES[self.cause].min_size


@dataclass(frozen=True)
class Cause:
    name: str
    physics: str
    term: str
    unit: str
    parameter: str
    metric: str  # "run_energy" or "power_trace"
    min_size: float
    evidence: str
    test: Callable[..., Evidence]


# -- helpers ---------------------------------------------------------------------------
def _v(runs: pd.DataFrame) -> np.ndarray:
    return runs["speed_mps"].to_numpy(np.float64)


def stacked_design(
    runs: pd.DataFrame, extra: Iterable[str], idle_W: float, alpha_per_min: float = 0.0
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Acceleration and cruise phase means of every run stacked into one least-squares
    problem: the paper's two lines (paper Eq. 1-4) plus the extra columns of causes.

    accel rows: a0 + a1 v [+ k2 v²/3] [+ kI payload a v / 2] [+ E_start / t_acc]
    cruise rows: c0 + c1 v [+ k2 v²]
    With thermal drift, the means above idle are first divided by (1 + α τ_mid).
    """
    extra = list(extra)
    v = _v(runs)
    t_acc = runs["t_acc_s"].to_numpy(np.float64)
    payload = runs["payload_kg"].to_numpy(np.float64)
    factor = 1.0 + alpha_per_min * runs["tau_mid_min"].to_numpy(np.float64)
    y_acc = idle_W + (runs["accel_mean_power_W"].to_numpy(np.float64) - idle_W) / factor
    y_cr = idle_W + (runs["cruise_mean_power_W"].to_numpy(np.float64) - idle_W) / factor
    one, zero = np.ones_like(v), np.zeros_like(v)
    acc_cols = [one, v, zero, zero]
    cr_cols = [zero, zero, one, v]
    names = ["a0", "a1", "c0", "c1"]
    if "speed_quadratic" in extra:
        acc_cols.append(v**2 / 3)  # mean of v(t)² over a linear ramp
        cr_cols.append(v**2)
        names.append("k2")
    if "accel_inertial" in extra:
        acc_cols.append(payload * (v / t_acc) * v / 2)  # payload · a · mean v over the ramp
        cr_cols.append(zero)
        names.append("kI")
    if "start_transient" in extra:
        acc_cols.append(1.0 / t_acc)  # E_start spread over the acceleration phase
        cr_cols.append(zero)
        names.append("E_start")
    X = np.vstack([np.column_stack(acc_cols), np.column_stack(cr_cols)])
    return X, np.concatenate([y_acc, y_cr]), names


def _coef(runs: pd.DataFrame, causes: Iterable[str], model: PowerModel) -> tuple[dict, object]:
    """The stacked fit with the given causes' columns; thermal drift from the model."""
    causes = list(causes)
    alpha = model.extensions.get("thermal_drift", {}).get("alpha_per_min", 0.0)
    X, y, names = stacked_design(runs, causes, model.idle_W, alpha)
    fit = ols(X, y)
    return dict(zip(names, map(float, fit.coef), strict=True)), (fit, names)


def _coefficient_evidence(
    cause: str,
    runs: pd.DataFrame,
    model: PowerModel,
    given: tuple[str, ...],
    name: str,
    what: str,
) -> Evidence:
    _, (fit, names) = _coef(runs, [*given, cause], model)
    j = names.index(name)
    estimate = float(fit.coef[j])
    parameter = CAUSES[cause].parameter
    return Evidence(
        cause,
        True,
        fit.p_greater(j),
        estimate,
        fit.ci95(j),
        {parameter: estimate},
        f"{what}: {parameter} = {estimate:.3g} {CAUSES[cause].unit}",
    )


def phase_power_terms(runs: pd.DataFrame, coef: dict[str, float]) -> dict[str, np.ndarray]:
    """Per-run modelled mean powers [W] from stacked-fit coefficients: the acceleration
    ramp's start level and slope in u = t / t_acc (constant acceleration, paper Eq. 5),
    and the cruise level, with the causes' terms the coefficients hold."""
    v = _v(runs)
    payload = runs["payload_kg"].to_numpy(np.float64)
    accel_mps2 = v / runs["t_acc_s"].to_numpy(np.float64)
    k2 = coef.get("k2", 0.0)
    return {
        "ramp0": np.full_like(v, coef["a0"]),
        # P(u) = a0 + (2 a1 v + kI payload a v) u + k2 v² u²: means a0 + a1 v + ... over u in [0, 1]
        "ramp1": 2 * coef["a1"] * v + coef.get("kI", 0.0) * payload * accel_mps2 * v,
        "ramp2": k2 * v**2,
        "cruise": coef["c0"] + coef["c1"] * v + k2 * v**2,
    }


def measured_duration_prediction_J(
    runs: pd.DataFrame,
    coef: dict[str, float],
    alpha_per_min: float = 0.0,
    idle_W: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration + cruise energy the coefficients give for each run's measured phase
    times [J], and those times [s]."""
    terms = phase_power_terms(runs, coef)
    steps = runs["steps_found"].to_numpy(np.float64)
    accel_s = runs["t_acc_s"].to_numpy(np.float64) * steps
    cruise_s = runs["cruise_duration_s"].to_numpy(np.float64)
    energy_J = (
        (terms["ramp0"] + terms["ramp1"] / 2 + terms["ramp2"] / 3) * accel_s
        + terms["cruise"] * cruise_s
        + coef.get("E_start", 0.0) * steps
    )
    if alpha_per_min:
        factor = 1.0 + alpha_per_min * runs["tau_mid_min"].to_numpy(np.float64)
        energy_J = (
            idle_W * (accel_s + cruise_s) + (energy_J - idle_W * (accel_s + cruise_s)) * factor
        )
    return energy_J, accel_s + cruise_s


# -- evidence tests, one per cause -----------------------------------------------------
# Each test takes the runs, the model fitted with the causes already found (`given`), and
# tests its own cause on top of them.
def speed_quadratic_evidence(runs: pd.DataFrame, model: PowerModel, given=()) -> Evidence:
    """Residual curvature against speed: the k2 v² column of the stacked fit, one-sided t-test."""
    if np.unique(_v(runs)).size < 3:
        return Evidence("speed_quadratic", False, summary="needs runs at 3 or more speeds")
    return _coefficient_evidence(
        "speed_quadratic", runs, model, tuple(given), "k2", "phase power curves upward with speed"
    )


def accel_inertial_evidence(runs: pd.DataFrame, model: PowerModel, given=()) -> Evidence:
    """Residual against payload: acceleration power rises with payload · a · v."""
    if np.unique(runs["payload_kg"].to_numpy(np.float64)).size < 2:
        return Evidence("accel_inertial", False, summary="needs runs with different payloads")
    return _coefficient_evidence(
        "accel_inertial",
        runs,
        model,
        tuple(given),
        "kI",
        "acceleration power rises with payload x acceleration x speed",
    )


def start_transient_evidence(runs: pd.DataFrame, model: PowerModel, given=()) -> Evidence:
    """A fixed energy per step, located in the first 0.25 s of each acceleration.

    Two tests must both hold: the per-step energy column of the stacked fit (residual per
    step count), and the excess over the modelled ramp in the start window (where it sits).
    The ramp is that of the lines fitted together with the per-step term, so it is not
    inflated by the transient it is meant to reveal.
    """
    coef, (fit, names) = _coef(runs, [*given, "start_transient"], model)
    j = names.index("E_start")
    excess_J = start_window_excess_J(runs, coef, model)
    mean_J, _, p_window = one_sample_p_greater(excess_J)
    estimate = float(fit.coef[j])
    return Evidence(
        "start_transient",
        True,
        max(fit.p_greater(j), p_window),
        estimate,
        fit.ci95(j),
        {"E_start_J": estimate},
        f"extra {estimate:.3g} J per step, {mean_J:.3g} J of it in the first 0.25 s of "
        "acceleration",
    )


def start_window_excess_J(
    runs: pd.DataFrame, coef: dict[str, float], model: PowerModel
) -> np.ndarray:
    """Measured minus modelled energy in the start window, per step [J] (E_start not in the
    model: it is what the window should reveal)."""
    terms = phase_power_terms(runs, coef)
    predicted = (
        terms["ramp0"] * runs["start_accel_s"].to_numpy(np.float64)
        + terms["ramp1"] * runs["start_ramp_s"].to_numpy(np.float64)
        + terms["ramp2"] * runs["start_ramp2_s"].to_numpy(np.float64)
        + terms["cruise"] * runs["start_cruise_s"].to_numpy(np.float64)
    )
    alpha = model.extensions.get("thermal_drift", {}).get("alpha_per_min", 0.0)
    if alpha:
        window_s = (runs["start_accel_s"] + runs["start_cruise_s"]).to_numpy(np.float64)
        factor = 1.0 + alpha * runs["tau_mid_min"].to_numpy(np.float64)
        predicted = model.idle_W * window_s + (predicted - model.idle_W * window_s) * factor
    steps = runs["steps_found"].clip(lower=1).to_numpy(np.float64)
    return (runs["start_measured_J"].to_numpy(np.float64) - predicted) / steps


def decel_phase_evidence(runs: pd.DataFrame, model: PowerModel, given=()) -> Evidence:
    """Energy above idle in the second after each cruise ends, where the paper's robot
    has already stopped (paper Eq. 6 has no stopping phase)."""
    del given
    excess_J = end_window_excess_J(runs, model)
    mean_J, _, p_value = one_sample_p_greater(excess_J)
    params = decel_parameters(runs, model)
    t_dec = params["t_dec_s"]
    return Evidence(
        "decel_phase",
        True,
        p_value,
        t_dec,
        params.pop("t_dec_ci95"),
        params,
        f"{mean_J:.3g} J above idle per step after cruise ends; stopping phase of "
        f"{t_dec:.3g} s at P_dec(v) = {params['P_dec_intercept_W']:.3g} + "
        f"{params['P_dec_slope_W_per_mps']:.3g} v W",
    )


def end_window_excess_J(runs: pd.DataFrame, model: PowerModel) -> np.ndarray:
    steps = runs["steps_found"].clip(lower=1)
    return ((runs["end_measured_J"] - model.idle_W * runs["end_s"]) / steps).to_numpy(np.float64)


def decel_parameters(
    runs: pd.DataFrame, base: PowerModel, factor: np.ndarray | None = None
) -> dict:
    """t_dec [s] and P_dec(v) [W] from the decel phases the segmentation found; when it
    found none, from the end-window excess assuming power falls linearly to idle."""
    durations = runs["decel_duration_s"].to_numpy(np.float64)
    found = durations > 0
    v = _v(runs)
    if found.sum() >= 2:
        t_dec = float(durations[found].mean())
        se = float(durations[found].std(ddof=1) / np.sqrt(found.sum()))
        means = runs["decel_mean_power_W"].to_numpy(np.float64)
        if factor is not None:
            means = base.idle_W + (means - base.idle_W) / factor
        line = fit_line(v[found], means[found])
        if not np.isfinite(line.slope):
            line = LinearFit(float(np.nanmean(means[found])), 0.0)
    else:
        excess = end_window_excess_J(runs, base)
        above_W = np.maximum(base.cruise.at(v) - base.idle_W, 1e-9)
        t_each = 2 * excess / above_W
        t_dec = float(max(np.nanmean(t_each), 0.0))
        se = float(np.nanstd(t_each, ddof=1) / np.sqrt(len(t_each))) if len(t_each) > 1 else np.nan
        extra_W = float(np.nanmean(excess)) / t_dec if t_dec > 1e-3 else 0.0
        line = LinearFit(base.idle_W + extra_W, 0.0)
    return {
        "t_dec_s": t_dec,
        "P_dec_intercept_W": float(line.intercept),
        "P_dec_slope_W_per_mps": float(line.slope),
        "t_dec_ci95": (t_dec - 1.96 * se, t_dec + 1.96 * se),
    }


def thermal_drift_evidence(runs: pd.DataFrame, model: PowerModel, given=()) -> Evidence:
    """Residual trend in session order: motion power above idle, relative to the model,
    grows with the motor-on minutes accumulated before it."""
    tau = runs["tau_mid_min"].to_numpy(np.float64)
    if not np.isfinite(tau).all() or np.ptp(tau) < 1.0:
        return Evidence(
            "thermal_drift",
            False,
            summary="needs started_at on every run and a session over a minute of motion",
        )
    coef, _ = _coef(
        runs, [c for c in given if c != "thermal_drift"], model.with_extensions({}, model.source)
    )
    alpha, ci, p_value = thermal_alpha(runs, coef, model.idle_W)
    return Evidence(
        "thermal_drift",
        True,
        p_value,
        alpha,
        ci,
        {"alpha_per_min": alpha},
        f"motion power above idle grows {100 * alpha:.3g}% per minute of motor-on time",
    )


def thermal_alpha(
    runs: pd.DataFrame, coef: dict[str, float], idle_W: float
) -> tuple[float, tuple[float, float], float]:
    """Slope of (measured/modelled power above idle - 1) against tau_mid [1/min]."""
    predicted_J, seconds = measured_duration_prediction_J(runs, coef)
    measured_J = runs["accel_energy_J"].to_numpy(np.float64) + runs["cruise_energy_J"].to_numpy(
        np.float64
    )
    ratio = (measured_J - idle_W * seconds) / (predicted_J - idle_W * seconds) - 1.0
    tau = runs["tau_mid_min"].to_numpy(np.float64)
    fit = ols(np.column_stack([np.ones_like(tau), tau]), ratio)
    # the fitted lines absorb the mean drift: ratio ~ α (τ - τ̄) / (1 + α τ̄), so the
    # slope b gives α = b / (1 - b τ̄)
    scale = 1.0 / max(1.0 - float(fit.coef[1]) * float(tau.mean()), 1e-6)
    alpha = float(fit.coef[1]) * scale
    lo, hi = fit.ci95(1)
    return alpha, (lo * scale, hi * scale), fit.p_greater(1)


def cruise_ripple_evidence(
    runs: pd.DataFrame, model: PowerModel | None = None, given=()
) -> Evidence:
    """A spectral peak in the cruise power whose frequency scales with speed."""
    del model, given
    analysed = runs[np.isfinite(runs["ripple_p_value"].to_numpy(np.float64))]
    if len(analysed) < 3:
        return Evidence("cruise_ripple", False, summary="needs 3 or more cruises of 3 s or more")
    found = analysed[analysed["ripple_p_value"] < RIPPLE_RUN_ALPHA]
    n, k = len(analysed), len(found)
    p_value = float(stats.binom.sf(k - 1, n, RIPPLE_RUN_ALPHA))
    if k < max(3, n / 2):
        return Evidence(
            "cruise_ripple",
            True,
            p_value,
            0.0,
            summary=f"a spectral peak in only {k} of {n} cruises",
        )
    scaling = ripple_scaling(found)
    amplitudes = found["ripple_amplitude_W"].to_numpy(np.float64)
    amplitude = float(np.mean(amplitudes))
    half = stats.t.ppf(0.975, k - 1) * amplitudes.std(ddof=1) / np.sqrt(k)
    params = {
        "amplitude_W": amplitude,
        "hz_per_mps": scaling["hz_per_mps"],
        "hz_per_mps_ci95_low": scaling["ci95"][0],
        "hz_per_mps_ci95_high": scaling["ci95"][1],
        "r2": scaling["r2"],
    }
    if not scaling["scales"]:
        return Evidence(
            "cruise_ripple",
            True,
            p_value,
            0.0,
            parameters=params,
            summary=f"periodic cruise power in {k} of {n} runs, but its frequency "
            f"does not scale with speed (R² {scaling['r2']:.2f})",
        )
    return Evidence(
        "cruise_ripple",
        True,
        p_value,
        amplitude,
        (amplitude - half, amplitude + half),
        params,
        f"{amplitude:.3g} W oscillation in {k} of {n} cruises at {scaling['hz_per_mps']:.3g} Hz "
        f"per m/s (f ∝ v, R² {scaling['r2']:.3f}): wheel rotation, diameter "
        f"{1 / (np.pi * scaling['hz_per_mps']):.3g} m",
    )


def ripple_scaling(found: pd.DataFrame) -> dict:
    """Peak frequency against speed, a line through the origin (f = k v)."""
    v = _v(found)
    hz = found["ripple_hz"].to_numpy(np.float64)
    if np.unique(v).size < 2:
        return {
            "hz_per_mps": float(np.mean(hz / v)),
            "ci95": (np.nan, np.nan),
            "r2": np.nan,
            "scales": False,
        }
    fit = ols(v[:, None], hz)
    k = float(fit.coef[0])
    sst = float(np.sum((hz - hz.mean()) ** 2))
    r2 = 1 - float(fit.residual @ fit.residual) / sst if sst > 0 else np.nan
    # f = k v must explain the spread of frequencies, and a free intercept must not be needed
    free = ols(np.column_stack([np.ones_like(v), v]), hz)
    intercept_small = abs(free.coef[0]) < 0.1 * float(hz.mean())
    return {
        "hz_per_mps": k,
        "ci95": fit.ci95(0),
        "r2": r2,
        "scales": bool(np.isfinite(r2) and r2 >= 0.9 and intercept_small),
    }


# -- the registry ----------------------------------------------------------------------
CAUSES: dict[str, Cause] = {
    c.name: c
    for c in (
        Cause(
            "speed_quadratic",
            "copper (I²R) losses and viscous friction grow with speed²",
            "+ k2 v² in cruise and acceleration power",
            "W/(m/s)^2",
            "k2_W_per_mps2",
            "run_energy",
            1.0,
            "residual curvature against speed",
            speed_quadratic_evidence,
        ),
        Cause(
            "start_transient",
            "inrush current / static-friction breakaway at every start",
            "+ E_start per step, in the first ~0.2 s of acceleration",
            "J",
            "E_start_J",
            "run_energy",
            0.5,
            "residual per step count, located at the start of acceleration",
            start_transient_evidence,
        ),
        Cause(
            "decel_phase",
            "the robot needs time and power to stop (no stop phase in Eq. 6)",
            "a stop phase of t_dec at P_dec(v) after each cruise",
            "s",
            "t_dec_s",
            "run_energy",
            0.1,
            "residual per step count, located after the cruise ends",
            decel_phase_evidence,
        ),
        Cause(
            "accel_inertial",
            "accelerating mass costs m a v / eta",
            "+ kI (m + payload) a v in acceleration",
            "1/eta",
            "kI",
            "run_energy",
            0.5,
            "residual against payload",
            accel_inertial_evidence,
        ),
        Cause(
            "thermal_drift",
            "winding resistance rises as motors warm",
            "x (1 + alpha tau_on) on motion power above idle",
            "1/min",
            "alpha_per_min",
            "run_energy",
            0.001,
            "residual trend in session order",
            thermal_drift_evidence,
        ),
        Cause(
            "cruise_ripple",
            "wheel or gear eccentricity at the wheel rotation frequency",
            "+ A sin(2 pi f(v) t), f ∝ v",
            "W",
            "amplitude_W",
            "power_trace",
            0.2,
            "a spectral peak whose frequency scales with speed",
            cruise_ripple_evidence,
        ),
    )
}


# -- the extended model ----------------------------------------------------------------
def fit_model(runs: pd.DataFrame, causes: Iterable[str] = ()) -> PowerModel:
    """The paper's model fitted on `runs` (fit.fit_table: paper Eq. 1-4 by least squares
    over runs), extended jointly by `causes`: their columns enter one stacked least-squares
    fit of the phase means; thermal drift is estimated against the other terms and then
    divides the means above idle by (1 + α τ); the decel and ripple terms come from their
    own phases and spectra."""
    base = fit_table(runs).model
    causes = [c for c in CAUSES if c in set(causes)]
    if not causes:
        return base
    motion = runs[(runs["mode"] == "motion") & runs["usable"]]
    extensions: dict[str, dict[str, float]] = {}
    columns = [c for c in causes if c in ("speed_quadratic", "accel_inertial", "start_transient")]
    alpha = 0.0
    if "thermal_drift" in causes:
        coef, _ = _coef(motion, columns, base)
        alpha = thermal_alpha(motion, coef, base.idle_W)[0]
        extensions["thermal_drift"] = {"alpha_per_min": alpha}
    coef, _ = _coef(motion, columns, base.with_extensions(extensions, "diagnose"))
    accel = replace(base.accel, intercept=coef["a0"], slope=coef["a1"])
    cruise = replace(base.cruise, intercept=coef["c0"], slope=coef["c1"])
    if "k2" in coef:
        extensions["speed_quadratic"] = {"k2_W_per_mps2": coef["k2"]}
    if "kI" in coef:
        extensions["accel_inertial"] = {"kI": coef["kI"]}
    if "E_start" in coef:
        extensions["start_transient"] = {"E_start_J": coef["E_start"]}
    model = replace(base, accel=accel, cruise=cruise)
    if "decel_phase" in causes:
        factor = 1.0 + alpha * motion["tau_mid_min"].to_numpy(np.float64)
        params = decel_parameters(motion, model, factor)
        params.pop("t_dec_ci95")
        extensions["decel_phase"] = params
    if "cruise_ripple" in causes:
        evidence = cruise_ripple_evidence(motion)
        if evidence.estimate > 0:
            extensions["cruise_ripple"] = {
                "amplitude_W": evidence.parameters["amplitude_W"],
                "hz_per_mps": evidence.parameters["hz_per_mps"],
            }
    return model.with_extensions(extensions, source="diagnose")


def predict_motion_energy_J(model: PowerModel, runs: pd.DataFrame) -> np.ndarray:
    """Motion energy of each run as the model simulates it from (v, D, N, payload) alone:
    paper Eq. 5/6 per step with the model's extensions (energy.trip_energy); thermal drift
    from the motor-on minutes accumulated in the session before the run (tau_before_min)."""
    thermal = model.extensions.get("thermal_drift")
    cold = model.with_extensions(
        {k: v for k, v in model.extensions.items() if k != "thermal_drift"}, model.source
    )
    out = np.empty(len(runs))
    for i, row in enumerate(runs.itertuples(index=False)):  # a row per run, not per sample
        trip = trip_energy(
            cold, row.speed_mps, row.distance_m, int(row.steps), payload_kg=row.payload_kg
        )
        energy_J = trip.energy_J
        if thermal:
            above_J = energy_J - model.idle_W * trip.time_s
            tau_mid = row.tau_before_min + trip.time_s / 120.0
            energy_J += thermal["alpha_per_min"] * tau_mid * above_J
        out[i] = energy_J
    return out
