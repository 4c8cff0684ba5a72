"""`cruise_ripple`: wheel or gear eccentricity; cruise power oscillates at the wheel's
rotation frequency, which scales with speed.

Term: ``+ A·sin(2π·f(v)·t)``, ``f ∝ v`` (causes.md). Zero-mean: it adds no energy, so its
gain is measured on the cruise power trace (metric ``power_trace``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import (
    POWER_TRACE,
    Cause,
    Check,
    Evidence,
    RunTable,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.design import column
from wifibot_power.stats import binomial_at_least, ols, t_quantile

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel

AMPLITUDE = "amplitude_W"
HZ_PER_MPS = "hz_per_mps"
#: A spectral line counts for a run below this p-value (`traces.ripple_peak`).
RUN_ALPHA = 0.01
#: A cruise can show a line only if it holds this many of its cycles: the line test finds a
#: 0.5 W line over 1/f noise in 93.5% of 10 s cruises at 3.6 cycles and 97-100% from 4.2,
#: and cannot test one under ~3.5 (benchmarks/line_test_noise.py). A wheel turns 1/(π d)
#: times a metre: 2.4 turns in a 1 m step of the paper's 0.13 m wheels.
SHOWABLE_CYCLES = 4.0
#: wheels or gear stages the frequency may come from: diameters [m]
DIAMETER_RANGE_M = (0.02, 1.0)


class CruiseRipple(Cause):
    """Plausible A: 0 to 10 W. An eccentric wheel modulates the rolling load by a fraction of
    itself; the paper's robot draws ~10 W above idle at its top speed, so a swing of more
    than 10 W would be more than the whole drive load. The frequency per unit speed must
    also be that of something that rolls: f / v = 1 / (π d) for a diameter d of 2 cm to 1 m.
    """

    name = "cruise_ripple"
    physics = "wheel or gear eccentricity at the wheel rotation frequency"
    term = "+ A sin(2 pi f(v) t), f ∝ v"
    unit = "W"
    parameter = AMPLITUDE
    parameters = (AMPLITUDE, HZ_PER_MPS)
    metric = POWER_TRACE
    min_size = 0.2
    plausible = (0.0, 10.0)
    signature = "a spectral peak whose frequency scales with speed"
    default_size = 1.0
    realistic_range = (0.5, 2.0)
    fit_stage = "after"
    energy_stage = "lump"

    def evidence(self, table: RunTable) -> Evidence:
        """A spectral line in the cruise power: in how many of the cruises that can show it
        the line test finds one (a binomial test of that count), its mean amplitude, and f
        against v. A cruise can show it when it holds SHOWABLE_CYCLES of it: at the found
        frequency where a line is found, else at the frequency the found lines give its
        speed; the others are not counted (a 1 m step holds 2.4 turns of the paper's
        wheels). That most of them show it is a check."""
        runs = table.runs
        analysed = runs[np.isfinite(column(runs, "ripple_p_value"))]
        if len(analysed) < 3:
            return Evidence(self.name, False, summary="needs 3 or more cruises of 3 s or more")
        is_found = lines_found(analysed)
        found = analysed[is_found]
        k = len(found)
        scaling = ripple_scaling(found) if k >= 3 else None
        hz_per_mps = scaling["hz_per_mps"] if scaling is not None else float("nan")
        predicted_hz = hz_per_mps * column(analysed, "speed_mps")
        showable = is_found | (
            (column(analysed, "ripple_p_value") >= RUN_ALPHA) & _long_enough(analysed, predicted_hz)
        )
        n = int(showable.sum())
        p_value = binomial_at_least(k, n, RUN_ALPHA)
        short = len(analysed) - n
        not_counted = f" ({short} too short to show it, not counted)" if short else ""
        if scaling is None:
            return Evidence(
                self.name,
                True,
                p_value,
                0.0,
                summary=f"a spectral peak in only {k} of {n} cruises{not_counted}",
            )
        amplitudes = column(found, "ripple_amplitude_W")
        amplitude = float(np.mean(amplitudes))
        half = t_quantile(0.975, k - 1) * amplitudes.std(ddof=1) / np.sqrt(k)
        params = {
            AMPLITUDE: amplitude,
            HZ_PER_MPS: scaling["hz_per_mps"],
            "hz_per_mps_ci95_low": scaling["ci95"][0],
            "hz_per_mps_ci95_high": scaling["ci95"][1],
            "r2": scaling["r2"],
            "free_intercept_hz": scaling["intercept_hz"],
            "mean_hz": float(np.mean(column(found, "ripple_hz"))),
            "cruises_found": float(k),
            "cruises_showable": float(n),
        }
        where = (
            f"at {scaling['hz_per_mps']:.3g} Hz per m/s (f ∝ v, R² {scaling['r2']:.3f}): "
            f"wheel rotation, diameter {1 / (np.pi * scaling['hz_per_mps']):.3g} m"
            if scales(params)
            else f"whose frequency does not scale with speed (R² {scaling['r2']:.2f})"
        )
        return Evidence(
            self.name,
            True,
            p_value,
            amplitude,
            (amplitude - half, amplitude + half),
            params,
            f"{amplitude:.3g} W oscillation in {k} of {n} cruises{not_counted} {where}",
        )

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        params = evidence.parameters
        k = params.get(HZ_PER_MPS, float("nan"))
        scaling = Check(
            "frequency scales with speed (f ∝ v) across runs",
            scales(params),
            f"f = {k:.3g} Hz per m/s · v explains R² {params.get('r2', float('nan')):.3f} of the "
            f"peak frequencies (0.9 needed); a free intercept would be "
            f"{params.get('free_intercept_hz', float('nan')):.3g} Hz (under 10% of the mean "
            "frequency needed)",
        )
        diameter_m = 1.0 / (np.pi * k) if np.isfinite(k) and k > 0 else float("nan")
        low, high = DIAMETER_RANGE_M
        rolls = Check(
            "frequency is that of something that rolls",
            bool(np.isfinite(diameter_m) and low <= diameter_m <= high),
            f"f / v = 1 / (π d) gives d = {diameter_m:.3g} m ({low:g} to {high:g} m plausible)",
        )
        k_found = params.get("cruises_found", float("nan"))
        n_showable = params.get("cruises_showable", float("nan"))
        most = Check(
            "a line in most cruises long enough to show it",
            shown_in_most(params),
            f"{k_found:.0f} of {n_showable:.0f} cruises of {SHOWABLE_CYCLES:g} cycles or more "
            "(half needed: a wheel turns in every cruise)",
        )
        return [scaling, rolls, most, self.plausible_check(evidence)]

    def estimate(
        self, runs: pd.DataFrame, coef: dict[str, float], model: PowerModel
    ) -> dict[str, float] | None:
        evidence = self.evidence(RunTable(runs, model))
        if (
            evidence.estimate > 0
            and scales(evidence.parameters)
            and shown_in_most(evidence.parameters)
        ):
            return {key: evidence.parameters[key] for key in (AMPLITUDE, HZ_PER_MPS)}
        return None

    def heldout_trace_gain_pct(self, runs: pd.DataFrame, folds: np.ndarray, traces) -> float:
        """Held-out gain on the cruise power trace [%]: amplitude and Hz per m/s from the
        training folds, only the phase fitted to each held-out cruise (its start time is
        arbitrary). `traces`: run_id -> (detrended 10 ms block means of its longest cruise,
        block length [s])."""
        from wifibot_power.traces import ripple_trace_rmse_W

        base_sq, ext_sq, count = 0.0, 0.0, 0
        for k in np.unique(folds):
            train, test = runs[folds != k], runs[folds == k]
            params = self.estimate(train, {}, None)  # model unused by the ripple's test
            for run_id, speed_mps in zip(  # a run per iteration
                test["run_id"].tolist(), test["speed_mps"].tolist(), strict=True
            ):
                x, block_s = traces.get(run_id, (np.zeros(0), 0.0))
                if x.size == 0:
                    continue
                rms_W = float(np.sqrt(np.mean(x**2)))
                rmse = (
                    ripple_trace_rmse_W(
                        x, block_s, params[HZ_PER_MPS] * speed_mps, params[AMPLITUDE]
                    )
                    if params
                    else rms_W  # not found on the training folds: the baseline's error
                )
                base_sq += rms_W**2 * x.size
                ext_sq += rmse**2 * x.size
                count += x.size
        if count == 0 or base_sq <= 0:
            return 0.0
        return 100.0 * (1.0 - np.sqrt(ext_sq / count) / np.sqrt(base_sq / count))

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float]:
        """Zero-mean: no energy [J]."""
        return 0.0, 0.0

    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        """The load oscillates with the wheel angle 2 x(t) / d, so at a steady speed
        f = v / (π d); its amplitude follows the speed, so the ripple fades in and out with
        the motion instead of switching at the cruise boundaries."""
        robot = trace.robot
        wheel_angle = 2.0 * np.cumsum(trace.speed_mps) * trace.dt_s / robot.wheel_diameter_m
        phase0 = trace.rng.uniform(0, 2 * np.pi)
        amplitude_W = size * trace.speed_mps / trace.target_speed_mps
        trace.motion_W += amplitude_W * np.sin(wheel_angle + phase0) * trace.moving
        return {"ripple_hz": robot.ripple_hz_per_mps * trace.target_speed_mps}

    def sim_parameters(self, size: float) -> dict[str, float]:
        return {AMPLITUDE: float(size)}


def scales(params: dict[str, float]) -> bool:
    """f = k v explains the spread of frequencies (R² >= 0.9), and a free intercept is not
    needed (under 10% of the mean frequency)."""
    r2 = params.get("r2", float("nan"))
    intercept = params.get("free_intercept_hz", float("nan"))
    mean_hz = params.get("mean_hz", float("nan"))
    return bool(np.isfinite(r2) and r2 >= 0.9 and abs(intercept) < 0.1 * mean_hz)


def shown_in_most(params: dict[str, float]) -> bool:
    """The line was found in at least half the cruises that can show it."""
    k = params.get("cruises_found", float("nan"))
    n = params.get("cruises_showable", float("nan"))
    return bool(np.isfinite(k) and k >= max(3.0, n / 2))


def lines_found(runs: pd.DataFrame) -> np.ndarray:
    """Which runs' cruises show the line and count for it: found at RUN_ALPHA in a cruise
    that holds SHOWABLE_CYCLES of it. A line found in fewer cycles is there, but its
    frequency is not known to better than a few % (2-3% in the 2.4 turns of a 1 m step):
    not counted either way."""
    found = column(runs, "ripple_p_value") < RUN_ALPHA
    return found & _long_enough(runs, column(runs, "ripple_hz"))


def _long_enough(analysed: pd.DataFrame, hz: np.ndarray) -> np.ndarray:
    """Which analysed cruises hold SHOWABLE_CYCLES of a line at `hz` (all where the
    frequency or the cruise's length is not known)."""
    if "ripple_cruise_s" not in analysed:
        return np.ones(len(analysed), dtype=bool)
    return ~(hz * column(analysed, "ripple_cruise_s") < SHOWABLE_CYCLES)  # NaN counts


def ripple_scaling(found: pd.DataFrame) -> dict:
    """Peak frequency against speed, a line through the origin (f = k v), and with a free
    intercept."""
    v = column(found, "speed_mps")
    hz = column(found, "ripple_hz")
    if np.unique(v).size < 2:
        return {
            "hz_per_mps": float(np.mean(hz / v)),
            "ci95": (np.nan, np.nan),
            "r2": np.nan,
            "intercept_hz": np.nan,
        }
    fit = ols(v[:, None], hz)
    free = ols(np.column_stack([np.ones_like(v), v]), hz)
    sst = float(np.sum((hz - hz.mean()) ** 2))
    r2 = 1 - fit.sse / sst if sst > 0 else np.nan
    return {
        "hz_per_mps": float(fit.coef[0]),
        "ci95": fit.ci95(0),
        "r2": r2,
        "intercept_hz": float(free.coef[0]),
    }
