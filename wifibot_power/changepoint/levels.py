"""Steady levels of any power trace and the jumps between them (`detect_levels`).

Part of `wifibot_power.changepoint`: jumps above a noise threshold, then short start-up
spikes (inrush, overshoot) merged into the level they start, then changes too small to
matter merged.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from wifibot_power.changepoint.jumps import jump_sd_factor, jump_statistic_W, peaks
from wifibot_power.changepoint.stats import block_means, median, percentile, robust_sigma_W


@dataclass(frozen=True)
class LevelSpike:
    """A short start-up excursion at the start of a level, in samples."""

    i_start: int
    i_end: int
    peak_W: float
    energy_above_level_J: float


@dataclass(frozen=True)
class Levels:
    """Steady levels of a trace: `bounds` are sample indices (0, ..., n), one more than levels."""

    bounds: tuple[int, ...]
    levels_W: tuple[float, ...]
    spikes: tuple[LevelSpike, ...]
    block: int
    noise_W: float
    min_step_W: float


@dataclass(frozen=True)
class LevelParams:
    """Parameters of `detect_levels` (docs/segmentation.md)."""

    #: block length [s] of the block means everything works on
    block_s: float = 0.005
    #: each line of the jump statistic is fitted over this long [s]
    half_width_s: float = 0.05
    #: a jump must exceed z times its noise sd
    z: float = 6.0
    #: smallest change between levels that counts [W]; None: 2% of the trace's 1-99% range
    min_step_W: float | None = None
    #: longest start-up spike [s]; a level must last longer than this
    spike_max_s: float = 0.3


def detect_levels(
    power_W: np.ndarray, sample_period_s: float, params: LevelParams | None = None
) -> Levels:
    """Steady levels of a power trace and the sample indices of the changes between them.

    1. block means over `block_s`; noise sd from `robust_sigma_W`;
    2. candidate changes: peaks of |J| (`jump_statistic_W`) above max(z sd(J), min_step_W);
       each is put on the sample where a two-mean split of the +-1 block around it is best;
    3. a level shorter than `spike_max_s` that overshoots the level after it (in the
       direction of the change that started it) is a start-up spike: merged into that level;
    4. neighbouring levels closer than `min_step_W` are merged.
    """
    params = params or LevelParams()
    power_W = np.asarray(power_W, dtype=np.float64)
    n = power_W.size
    block = max(1, round(params.block_s / sample_period_s))
    y = block_means(power_W, block)
    w = max(2, round(params.half_width_s / (block * sample_period_s)))
    sigma = robust_sigma_W(y)
    if params.min_step_W is not None:
        min_step = float(params.min_step_W)
    elif y.size:
        # numpy's percentiles, the same numbers, without its overhead (~3 ms on an idle run)
        lo_W, hi_W = percentile(y, 1), percentile(y, 99)
        min_step = 0.02 * float(hi_W - lo_W)
    else:
        min_step = 0.0
    bounds = [0]
    if y.size >= 2 * w + 1:
        jump = jump_statistic_W(y, w)
        threshold = max(params.z * jump_sd_factor(w) * sigma, min_step, 1e-12)
        for k in peaks(np.abs(jump), threshold, w):
            bounds.append(_refine_to_sample(power_W, int(k) * block, block))
    bounds.append(n)
    bounds = sorted(set(b for b in bounds if 0 <= b <= n))
    spike_max = max(1, round(params.spike_max_s / sample_period_s))
    bounds = _merge_spikes(power_W, bounds, spike_max)
    bounds = _merge_small(power_W, bounds, min_step)
    levels = tuple(_level(power_W, a, b) for a, b in pairwise(bounds))
    spikes = _find_spikes(
        power_W, sample_period_s, bounds, levels, block, spike_max, sigma, params.z
    )
    return Levels(tuple(bounds), levels, spikes, block, sigma, min_step)


def _refine_to_sample(power_W: np.ndarray, i_guess: int, block: int) -> int:
    """The sample where a two-mean split of [i_guess - block, i_guess + block) is best."""
    lo = max(0, i_guess - block)
    hi = min(power_W.size, i_guess + block)
    if hi - lo < 2:
        return i_guess
    seg = power_W[lo:hi] - power_W[lo:hi].mean()
    c = np.cumsum(seg)
    m = seg.size
    k = np.arange(1, m)
    # between-class sum of squares of a split at k (maximal where SSE is minimal)
    score = c[k - 1] ** 2 / k + c[k - 1] ** 2 / (m - k)
    return lo + int(k[np.argmax(score)])


def _level(power_W: np.ndarray, a: int, b: int) -> float:
    """The median of the samples [a, b): `numpy.median`'s number (`median`, narrowed first:
    a level of a whole idle run is some 10^5-10^6 samples)."""
    return median(power_W[a:b])


def _merge_spikes(power_W: np.ndarray, bounds: list[int], spike_max: int) -> list[int]:
    """Merge a short segment that overshoots the segment after it into that segment."""
    changed = True
    while changed and len(bounds) > 3:
        changed = False
        for s in range(1, len(bounds) - 2):  # segment s = [bounds[s], bounds[s+1]), not the first
            a, b, c = bounds[s], bounds[s + 1], bounds[s + 2]
            if b - a >= spike_max:
                continue
            before = _level(power_W, bounds[s - 1], a)
            here = float(np.mean(power_W[a:b]))
            after = _level(power_W, b, c)
            rise = after - before
            overshoot = here - after
            if rise != 0 and np.sign(overshoot) == np.sign(rise):
                # a spike that settles to a new level belongs to that level
                del bounds[s + 1]
                changed = True
                break
            if abs(after - before) < abs(here - before) * 0.25 and c - a < spike_max:
                # a short excursion that returns (a glitch): one level with its neighbours
                del bounds[s + 1]
                changed = True
                break
    return bounds


def _merge_small(power_W: np.ndarray, bounds: list[int], min_step: float) -> list[int]:
    """Merge neighbouring levels closer than `min_step`, the closest pair first."""
    while len(bounds) > 2:
        levels = [_level(power_W, a, b) for a, b in pairwise(bounds)]
        diffs = np.abs(np.diff(levels))
        k = int(np.argmin(diffs))
        if diffs[k] >= min_step:
            break
        del bounds[k + 1]
    return bounds


def _find_spikes(
    power_W: np.ndarray,
    sample_period_s: float,
    bounds: list[int],
    levels: tuple[float, ...],
    block: int,
    spike_max: int,
    sigma_W: float,
    z: float,
) -> tuple[LevelSpike, ...]:
    """The leading run of blocks of each level (after the first) that stands out from it."""
    spikes = []
    for s in range(1, len(levels)):
        a, b = bounds[s], bounds[s + 1]
        step_W = levels[s] - levels[s - 1]
        stop = min(b, a + spike_max)
        head = block_means(power_W[a:stop], block)
        if head.size == 0 or step_W == 0:
            continue
        # excursions beyond the level in the direction of the step (overshoot)
        excess = (head - levels[s]) * np.sign(step_W)
        threshold = max(z * sigma_W, 0.05 * abs(step_W))
        out = excess > threshold
        if not out[: min(2, out.size)].any():
            continue
        first_in = np.flatnonzero(~out[np.argmax(out) :])
        n_out = int(first_in[0]) + int(np.argmax(out)) if first_in.size else out.size
        i_end = min(b, a + n_out * block)
        seg = power_W[a:i_end]
        spikes.append(
            LevelSpike(
                i_start=a,
                i_end=i_end,
                peak_W=float(seg.max() if step_W > 0 else seg.min()),
                energy_above_level_J=float(np.sum(seg - levels[s]) * sample_period_s),
            )
        )
    return tuple(spikes)
