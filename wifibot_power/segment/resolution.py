"""Durations read from phases a few samples long are known to one sample period, not better
(issue 26, "exact-looking numbers"; docs/segmentation.md, "Resolution").

Phase boundaries fall on sample edges: the true start of a phase lies within a sample of
its boundary, and so does its end, so a phase of k samples lasted between (k - 1) and
(k + 1) sample periods. Where phases are one or two samples long (a 6.5 Hz log's
accelerations: every one 0.154 s), every run's duration is the same count of samples and a
least-squares interval over runs shrinks to nothing (t_acc = 0.154 s, CI [0.154, 0.154]):
the scatter the interval is built from is not there to see. `quantized_durations` says
when that is so; its `Quantized` widens an interval to the resolution at least and words
the warning. The fit of t_acc (`fit._fitted_columns`, the pipeline's) calls it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: phases this many samples long or shorter carry their sample period as their resolution
#: (one or two samples, with room for a mean over a run's steps and for uneven stamps)
MAX_SAMPLES = 2.5


@dataclass(frozen=True)
class Quantized:
    """Durations quantized to the sample period: `period_s` the largest sample period among
    the runs whose phases are `MAX_SAMPLES` long or shorter (`runs` of them), each such
    duration known to ± `period_s` at best."""

    period_s: float
    runs: int
    shortest_samples: float

    def floor_ci95(self, value: float, ci95: tuple[float, float]) -> tuple[float, float]:
        """`ci95` widened to value ± `period_s` at least (a NaN interval stays NaN: no
        interval was to be had)."""
        low, high = ci95
        if not (math.isfinite(low) and math.isfinite(high)):
            return ci95
        return min(low, value - self.period_s), max(high, value + self.period_s)

    def floor_slope_ci95(
        self, slope: float, ci95: tuple[float, float], speed_mps: np.ndarray
    ) -> tuple[float, float]:
        """A line's slope interval widened to slope ± 2 `period_s` / (speed range) at least:
        each point known to ± `period_s`, the steepest and flattest lines through those
        bands differ from the fitted one by that much (NaN stays NaN; a single speed leaves
        no slope to bound)."""
        speeds = np.asarray(speed_mps, dtype=np.float64)
        speeds = speeds[np.isfinite(speeds)]
        span = float(speeds.max() - speeds.min()) if speeds.size else 0.0
        low, high = ci95
        if not (math.isfinite(low) and math.isfinite(high)) or span <= 0:
            return ci95
        half = 2.0 * self.period_s / span
        return min(low, slope - half), max(high, slope + half)

    def warning(self, quantity: str) -> str:
        """The warning that says so, for `quantity` (e.g. "t_acc")."""
        return (
            f"{quantity} is quantized to the sample period: {self.runs} run(s) hold phases of "
            f"{self.shortest_samples:.3g} sample(s) of {self.period_s:.3g} s, each known to "
            f"± {self.period_s:.3g} s; its interval is at least that wide"
        )


def quantized_durations(
    durations_s: np.ndarray, sample_period_s: np.ndarray | float
) -> Quantized | None:
    """Whether per-run phase durations [s] (one a run: e.g. `t_acc_s`, the mean of a run's
    accel phases) are quantized to their runs' sample periods [s]: some of them
    `MAX_SAMPLES` samples long or shorter. None when none is (their scatter over runs
    then shows their error), or without a finite duration."""
    durations = np.asarray(durations_s, dtype=np.float64)
    periods = np.broadcast_to(np.asarray(sample_period_s, dtype=np.float64), durations.shape)
    ok = np.isfinite(durations) & np.isfinite(periods) & (periods > 0)
    samples = durations[ok] / periods[ok]
    short = samples <= MAX_SAMPLES
    if not short.any():
        return None
    return Quantized(
        period_s=float(periods[ok][short].max()),
        runs=int(short.sum()),
        shortest_samples=float(samples[short].min()),
    )
