"""`cruise_ripple`: wheel or gear eccentricity; cruise power oscillates at the wheel's
rotation frequency, which scales with speed.

Term: ``+ A·sin(2π·f(v)·t)``, ``f ∝ v`` (causes.md). Zero-mean: it adds no energy, so its
gain is measured on the cruise power trace (metric ``power_trace``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import (
    POWER_TRACE,
    Cause,
    Check,
    Evidence,
    PanelView,
    RunTable,
    RunView,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.design import column
from wifibot_power.changepoint import block_means
from wifibot_power.sinusoid import detrended
from wifibot_power.stats import binomial_at_least, ols, t_quantile
from wifibot_power.traces import ripple_peak, ripple_trace_rmse_W

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes

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
#: Block length for spectra and trace comparisons [s]; ripple is at most a few Hz.
BLOCK_S = 0.01
#: Shortest cruise phase whose spectrum is analysed [s].
MIN_CRUISE_S = 3.0
#: The per-run statistics (`run_stats`), kept in the diagnosis's table for the figure.
STATS = ("ripple_hz", "ripple_amplitude_W", "ripple_p_value", "ripple_cruise_s")


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
    table_columns = STATS
    columns = STATS

    def _spectrum(self, view: RunView) -> tuple[float, float, float, np.ndarray, float]:
        """`cruise_spectrum` of the run, made once for both hooks."""
        if self.name not in view.memo:
            view.memo[self.name] = cruise_spectrum(view)
        return view.memo[self.name]  # type: ignore[return-value]

    def run_stats(self, view: RunView) -> dict[str, float]:
        """The cruise spectrum's strongest line: frequency [Hz], amplitude [W], p-value
        against the local spectrum, and how long the analysed cruise is [s] (how many
        cycles of a line it can show)."""
        hz, amplitude_W, p_value, blocks, block_s = self._spectrum(view)
        return dict(
            zip(
                STATS,
                (
                    float(hz),
                    float(amplitude_W),
                    float(p_value),
                    blocks.size * block_s if blocks.size else np.nan,
                ),
                strict=True,
            )
        )

    def run_trace(self, view: RunView) -> tuple[np.ndarray, float] | None:
        """The detrended 10 ms block means of the longest cruise [W] and the block length
        [s]: what the held-out trace gain and the spectrum panel read."""
        _, _, _, blocks, block_s = self._spectrum(view)
        return (blocks, block_s) if blocks.size else None

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

    def heldout_trace_gain_pct(
        self, runs: pd.DataFrame, folds: np.ndarray, traces: Mapping[str, object]
    ) -> float:
        """Held-out gain on the cruise power trace [%]: amplitude and Hz per m/s from the
        training folds, only the phase fitted to each held-out cruise (its start time is
        arbitrary). `traces`: run_id -> `run_trace` (detrended 10 ms block means of its
        longest cruise, block length [s])."""
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

    def panels(self, view: PanelView) -> list[Callable[[Axes], None]]:
        """The cruise spectrum's peak frequency of each run against its speed, with the
        fitted ``f = k v`` line; and, when the runs' cruise blocks are given, the spectrum of
        the fastest run with 3 s or more of cruise."""
        drawn = [lambda ax: _scaling_panel(ax, view)]
        if any(r in set(view.runs["run_id"]) for r in view.traces):
            drawn.append(lambda ax: _spectrum_panel(ax, view))
        return drawn

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


def cruise_spectrum(view: RunView) -> tuple[float, float, float, np.ndarray, float]:
    """The strongest line of the longest cruise's spectrum (`traces.ripple_peak`: frequency
    [Hz], amplitude [W], p-value), the cruise's detrended block means [W] and the block
    length [s]; NaN and no blocks when the run has no cruise of MIN_CRUISE_S."""
    run, segmentation = view.run, view.segmentation
    dt = run.sample_period_s
    cruises = [p for p in segmentation.phases if p.phase == "cruise"]
    if not cruises:
        return np.nan, np.nan, np.nan, np.zeros(0), BLOCK_S
    longest = max(cruises, key=lambda p: p.i_end - p.i_start)
    per_block = max(1, round(BLOCK_S / dt))
    block_s = per_block * dt
    n_blocks = (longest.i_end - longest.i_start) // per_block
    if n_blocks * block_s < MIN_CRUISE_S:
        return np.nan, np.nan, np.nan, np.zeros(0), block_s
    x = block_means(
        run.power_W[longest.i_start : longest.i_start + n_blocks * per_block], per_block
    )
    x = detrended(x, block_s)  # drift within a cruise is not ripple
    hz, amplitude_W, p_value = ripple_peak(x, block_s)
    return hz, amplitude_W, p_value, x, block_s


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


def _scaling_panel(ax: Axes, view: PanelView) -> None:
    runs = view.runs
    speed = runs["speed_mps"].to_numpy(np.float64)
    hz = runs["ripple_hz"].to_numpy(np.float64)
    found = lines_found(runs)  # the lines the evidence counts
    ax.plot(
        speed[found],
        hz[found],
        "o",
        ms=4,
        color=view.colours["cruise"],
        mec="#333333",
        mew=0.5,
        label=f"peak of a run's cruise spectrum (n = {int(found.sum())})",
        gid="runs",
    )
    k = float(view.estimate.get(HZ_PER_MPS, np.nan))
    grid = np.linspace(0.0, max(1.0, float(np.nanmax(speed)) * 1.05), 50)
    ax.plot(grid, k * grid, color="black", lw=1.2, label=f"f = {k:.4g} Hz/(m/s) · v", gid="fit")
    ax.set_xlim(0.0, grid[-1])
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("speed [m/s]")
    ax.set_ylabel("ripple frequency [Hz]")
    ax.set_title(view.title, fontsize=8, loc="left")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")


def _spectrum_panel(ax: Axes, view: PanelView) -> None:
    # the fastest run with 3 s or more of cruise: its peak stands clear of 0 Hz
    runs = view.runs.set_index("run_id")
    cruise_blocks = view.traces
    candidates = [r for r in cruise_blocks if r in runs.index]
    long_enough = [r for r in candidates if cruise_blocks[r][0].size * cruise_blocks[r][1] >= 3]
    run_id = max(long_enough or candidates, key=lambda r: (runs.at[r, "speed_mps"], r))
    blocks, block_s = cruise_blocks[run_id]
    speed = float(runs.at[run_id, "speed_mps"])
    amplitude = np.abs(np.fft.rfft(blocks)) * 2 / max(blocks.size, 1)  # one-sided [W]
    freq = np.fft.rfftfreq(blocks.size, block_s)
    expected = float(view.estimate.get(HZ_PER_MPS, np.nan)) * speed
    top = min(20.0, 5 * expected) if np.isfinite(expected) and expected > 0 else 20.0
    band = (freq > 0) & (freq <= top)
    ax.plot(freq[band], amplitude[band], color=view.colours["cruise"], lw=1.0, gid="spectrum")
    ax.axvline(
        expected,
        color="black",
        ls="--",
        lw=1.0,
        label=f"k · v = {expected:.3g} Hz at {speed:g} m/s",
    )
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("amplitude [W]")
    ax.set_title(
        f"cruise power spectrum of {run_id} ({blocks.size * block_s:.1f} s of cruise)",
        fontsize=8,
        loc="left",
    )
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
