"""What every part of segmentation shares: phases built from sample ranges, and the small
least-squares helpers the searches and doubts run many times per step."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wifibot_power.changepoint import block_means
from wifibot_power.phases import Phase
from wifibot_power.run import Run

#: a phase to build (`_phases`): (step, name, i_start, i_end, speed_mps)
Piece = tuple[int, str, int, int, float | None]


def _time_at(run: Run, index: int) -> float:
    """Start time of sample `index`; the end of the run for index == samples."""
    if index < run.samples:
        return run.time_at(index)
    return run.time_at(-1) + run.sample_period_s


def _phases(run: Run, pieces: list[Piece]) -> list[Phase]:
    """The phase of each piece (step, name, i_start, i_end, speed_mps) of the run: its
    times (`_time_at`), mean power and energy from one pairwise sum of its samples (the
    mean is the same sum over the count, as `numpy.mean`'s; `np.add.reduce`: `np.sum`'s
    reduction without its wrapper). The run's period, samples and time stamps are looked
    up once for all phases (~4 us a phase less than per phase: the same numbers)."""
    power = run.power_W
    period = run.sample_period_s
    samples = power.size
    stamps = run.stamps_s
    # `_time_at` (`Run.time_at`, and the end of the run for index == samples)
    if stamps is not None:
        end_s = float(stamps[-1]) + period
    else:
        end_s = float((samples - 1) * period) + period
    yaw_sum, yaw_count = _yaw_prefix(run)
    phases = []
    for step, name, i_start, i_end, speed_mps in pieces:
        total_W = np.add.reduce(power[i_start:i_end], dtype=np.float64)
        if stamps is not None:
            t_start_s = float(stamps[i_start]) if i_start < samples else end_s
            t_end_s = float(stamps[i_end]) if i_end < samples else end_s
        else:
            t_start_s = float(i_start * period) if i_start < samples else end_s
            t_end_s = float(i_end * period) if i_end < samples else end_s
        phases.append(
            Phase(
                step=step,
                phase=name,
                i_start=i_start,
                i_end=i_end,
                t_start_s=t_start_s,
                t_end_s=t_end_s,
                mean_power_W=float(total_W / (i_end - i_start)),
                energy_J=float(total_W * period),
                speed_mps=speed_mps,
                yaw_rate_radps=_mean_of(yaw_sum, yaw_count, i_start, i_end),
            )
        )
    return phases


def speed_across_gaps(speed_mps: np.ndarray) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """The speed column [m/s] with each stretch of unknown (NaN) samples filled by a straight
    line between the known samples either side (held at the log's ends), and those stretches
    as [i, j) sample ranges. A reader leaves the speed NaN where it has none (an odometry
    topic's drop-out in a bag, log-format.md "ROS bags"); read as 0 it would cut a motion in
    two with a stop that never happened. The filling is an assumption: `segment` says so
    where a stop could hide in a stretch (`kinematic._gap_doubts`)."""
    speed = np.asarray(speed_mps, dtype=np.float64)
    known = np.isfinite(speed)
    if known.all() or not known.any():
        return (speed if known.all() else np.zeros_like(speed)), (
            [] if known.all() else [(0, speed.size)]
        )
    index = np.arange(speed.size)
    filled = np.interp(index, index[known], speed[known])
    edges = np.diff(np.concatenate(([0], (~known).astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()
    gaps = list(zip(starts, ends, strict=True))
    return filled, gaps


def _yaw_prefix(run: Run) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Prefix sums of |yaw rate| over the finite samples and of their count (None, None
    without a turning column): each phase's mean |yaw rate| from two differences."""
    if run.yaw_rate_radps is None:
        return None, None
    magnitude = np.abs(np.asarray(run.yaw_rate_radps, dtype=np.float64))
    finite = np.isfinite(magnitude)
    total = np.concatenate(([0.0], np.cumsum(np.where(finite, magnitude, 0.0))))
    return total, np.concatenate(([0], np.cumsum(finite)))


def _mean_of(total: np.ndarray | None, count: np.ndarray | None, i: int, j: int) -> float | None:
    """The mean over samples [i, j) from prefix sums (`_yaw_prefix`); None where none."""
    if total is None or count is None or count[j] == count[i]:
        return None
    return float((total[j] - total[i]) / (count[j] - count[i]))


def _wavy(y: np.ndarray, sigma_b: float, t1: int, t3: int, group: int) -> bool:
    """Whether power between t1 and t3 wanders around its trend line more than noise (10 ms
    means off a straight line by more than max(3 sd of noise, 0.1 W) rms)."""
    means = block_means(y[t1 + 2 : t3 - 2], group)
    if means.size < 10:
        return False
    slope, intercept = _line(means)
    residual = means - (intercept + slope * np.arange(means.size, dtype=np.float64))
    return _std(residual) > max(3.0 * sigma_b / np.sqrt(group), 0.1)


def _wavy_means(values: np.ndarray, sigma10: float) -> bool:
    """Whether 10 ms means wander around their trend line more than noise (rms off it
    above max(3 sd, 0.1 W)): `_wavy`'s test."""
    slope, intercept = _line(values)
    residual = values - (intercept + slope * np.arange(values.size, dtype=np.float64))
    return _std(residual) > max(3.0 * sigma10, 0.1)


def _mean(values: np.ndarray) -> float:
    """`numpy.mean` of a 1-d float array, the same number (its pairwise sum over the count)
    without its Python-level argument handling: this runs some 20 times per step."""
    return float(np.add.reduce(values) / values.size)


def _std(values: np.ndarray) -> float:
    """`numpy.std` of a 1-d float array (population sd), the same number, as `_mean`."""
    centred = values - np.add.reduce(values) / values.size
    return float(np.sqrt(np.add.reduce(centred * centred) / values.size))


def _beats_line(values: np.ndarray, sse: float) -> bool:
    """Whether a fit of SSE `sse` beats one least-squares line through `values`."""
    slope, intercept = _line(values)
    line_resid = values - (intercept + slope * np.arange(values.size))
    return sse < float(np.einsum("i,i->", line_resid, line_resid))


def _line(y: np.ndarray) -> tuple[float, float]:
    """Least-squares slope (per block) and intercept (at the first block), closed form:
    slope = sum (x - x̄)(y - ȳ) / S_xx with x = 0..n-1, x̄ = (n-1)/2, S_xx = n (n² - 1) / 12
    (what `numpy.polyfit(x, y, 1)` returns, without its general least-squares solve)."""
    n = y.size
    mean_W = _mean(y) if n else float(np.mean(y))
    if n < 2:
        return 0.0, mean_W
    x_centred = np.arange(n, dtype=np.float64) - (n - 1) / 2.0
    # einsum, not @: no BLAS threads (see changepoint.block_means)
    slope = float(np.einsum("i,i->", x_centred, y - mean_W)) / (n * (n * n - 1) / 12.0)
    return slope, mean_W - slope * (n - 1) / 2.0


@dataclass(frozen=True)
class _Means10:
    """The 10 ms means a motion run's doubts are judged on (`values_W`), their noise sd
    (`sigma_W`, `robust_sigma_W`), the time of the first [s] and their step [s]."""

    values_W: np.ndarray
    sigma_W: float
    start_s: float
    step_s: float

    def when(self, index: int) -> float:
        """Start time [s] of mean `index`."""
        return self.start_s + index * self.step_s


def _phase_name(name: str, step: int) -> str:
    """A phase as the doubts name it: "the cruise of step 2", "the idle phase before step 1"."""
    return f"the {name} phase before step 1" if step == 0 else f"the {name} of step {step}"


#: a phase of a motion run's doubts: (first 10 ms mean, end, phase name, step)
Span = tuple[int, int, str, int]


def _centred_mean(values: np.ndarray, half: int) -> np.ndarray:
    """Mean over the centred window of 2 half + 1 values at every index (shorter, still
    centred where the window meets an end), by prefix sums."""
    n = values.size
    if half <= 0 or n == 0:
        return values.astype(np.float64, copy=True)
    prefix = np.concatenate(([0.0], np.cumsum(values, dtype=np.float64)))
    idx = np.arange(n)
    reach = np.minimum(np.minimum(idx, n - 1 - idx), half)
    return (prefix[idx + reach + 1] - prefix[idx - reach]) / (2 * reach + 1)


def _merge_stretches(mask: np.ndarray, min_len: int) -> list[tuple[int, int]]:
    """Stretches [a, b) where `mask` holds, after closing gaps shorter than `min_len` and
    dropping stretches shorter than `min_len`."""
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    stretches = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
    merged: list[tuple[int, int]] = []
    for a, b in stretches:
        if merged and a - merged[-1][1] < min_len:
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    return [(a, b) for a, b in merged if b - a >= min_len]
