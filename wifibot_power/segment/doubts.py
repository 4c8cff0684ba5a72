"""Doubts of a motion run segmented from power alone: where the phase model does not fit
the trace, a plain sentence saying what was seen and what it may mean
(docs/segmentation.md, "Doubts"). The stops a ripple may hide are
`wifibot_power.segment.hidden_stop`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wifibot_power.changepoint import (
    Split,
    best_splits,
    jump_sd_factor,
    jump_statistic_W,
    median,
    peaks,
    percentile,
)
from wifibot_power.run import Run
from wifibot_power.segment.common import (
    Span,
    _beats_line,
    _line,
    _mean,
    _Means10,
    _phase_name,
)
from wifibot_power.segment.hidden_stop import _hidden_stop_doubts
from wifibot_power.segment.params import MotionParams


@dataclass(frozen=True)
class _Levels:
    """The power levels a run's doubts are judged against [W]: idle (the lowest of the idle
    phases' medians: an "idle" holding motion is higher), the motion's swing above it (the
    median cruise's), "well above idle" (clear of noise and a fifth of the swing) and the
    band "at idle" (within noise and a tenth of the swing)."""

    idle_W: float
    swing_W: float
    on_W: float
    near_W: float


def _motion_doubts(
    run: Run,
    y10: np.ndarray,
    group: int,
    sigma10: float,
    block_dt: float,
    bounds: list[tuple[int, int, str, int]],
    steps_found: int,
    params: MotionParams,
    wavy_steps: set[int] | None = None,
) -> list[str]:
    """Why the phases found from power alone may not describe the run (plain sentences);
    empty when the phase model fits the trace.

    On 10 ms means (`y10`: of `group` blocks of `block_dt` [s]), against the trace's own
    noise (σ₁₀, `robust_sigma_W`) and its motion swing (median cruise power above idle),
    each test looks for structure the phase model cannot hold (docs/segmentation.md,
    "Doubts"):

    1. the run starts or ends with power well above idle (it starts / ends moving);
    2. an idle phase holds power well above idle (motion labelled idle);
    3. an accel or cruise phase holds a stretch at idle power (the drive off, labelled motion);
    4. power steps where the model has no boundary (a second speed level, a stop);
    5. a decel phase whose power neither falls nor sits clearly below the cruise before it;
    6. idle at ~0 W (a motors-only log) and power dropping straight to it: the robot may
       coast on, unseen (shorted motors, free wheel);
    7. the step count against the metadata;
    8. a stop the ripple hid (`_hidden_stop_doubts`): a wavy cruise whose end strays off
       its own carried-on ripple, or an idle after a step that starts above its level.
    """
    m = y10.size
    if m < 10:
        return []
    means = _Means10(y10, sigma10, run.time_at(0), group * block_dt)
    # each phase in 10 ms means (its whole 10 ms means only)
    spans = [(-(-a // group), min(b // group, m), name, k) for a, b, name, k in bounds]
    idle_median_W = {
        k: float(median(y10[a:b]))
        for k, (a, b, name, _) in enumerate(spans)
        if name == "idle" and b > a
    }
    levels = _levels(y10, spans, list(idle_median_W.values()), sigma10, params)
    doubts, starts_moving, ends_moving = _moving_ends_doubts(y10, levels)
    doubts += _phase_doubts(means, spans, levels, params, starts_moving, ends_moving)
    doubts += _hidden_stop_doubts(means, spans, idle_median_W, params, wavy_steps, ends_moving)
    edges10 = [b / group for _, b, _, _ in bounds[:-1]]
    doubts += _unexplained_step_doubts(means, spans, edges10, levels)
    doubts += _coasting_doubts(y10, bounds, levels.idle_W)
    if run.meta.mode == "motion" and steps_found != run.meta.steps:
        doubts.append(
            f"found {steps_found} step(s) separated by idle, the metadata says {run.meta.steps}"
        )
    return doubts


def _levels(
    y10: np.ndarray,
    spans: list[Span],
    idle_levels: list[float],
    sigma10: float,
    params: MotionParams,
) -> _Levels:
    """The levels of `_Levels` from the idle phases' medians and the cruises' means."""
    idle_W = min(idle_levels) if idle_levels else float(y10.min())
    cruise_W = [_mean(y10[a:b]) for a, b, name, _ in spans if name == "cruise" and b > a]
    swing_W = float(median(cruise_W)) - idle_W if cruise_W else float(y10.max()) - idle_W
    swing_W = max(swing_W, params.min_excess_W)
    on_W = idle_W + max(params.motion_z * sigma10, 0.2 * swing_W, params.min_excess_W)
    near_W = max(3.0 * sigma10, 0.1 * swing_W)
    return _Levels(idle_W, swing_W, on_W, near_W)


def _moving_ends_doubts(y10: np.ndarray, levels: _Levels) -> tuple[list[str], bool, bool]:
    """The doubts of a run that starts or ends with power well above idle (its median over
    the first or last 5 means), and whether it starts and ends moving."""
    edge = min(5, y10.size)
    first_W, last_W = float(median(y10[:edge])), float(median(y10[-edge:]))
    starts_moving, ends_moving = first_W > levels.on_W, last_W > levels.on_W
    doubts = []
    if starts_moving:
        doubts.append(
            f"the run starts moving (power {first_W - levels.idle_W:.3g} W above "
            "idle from its first sample): its first acceleration is not in the log"
        )
    if ends_moving:
        doubts.append(
            f"the run ends moving (power {last_W - levels.idle_W:.3g} W above "
            "idle at its last sample): its last stop is not in the log"
        )
    return doubts, starts_moving, ends_moving


def _phase_doubts(
    means: _Means10,
    spans: list[Span],
    levels: _Levels,
    params: MotionParams,
    starts_moving: bool,
    ends_moving: bool,
) -> list[str]:
    """Each phase's own doubts, in phase order: motion in an idle (not the first or last
    when the run starts or ends moving: doubted as such already), two levels in a cruise,
    the drive off in an accel or cruise, a decel that does not fall."""
    two_levels = _two_level_splits(means, spans, levels, params)
    at_idle = _longest_at_idle(means, spans, levels)
    doubts: list[str] = []
    for k, (a, b, name, _) in enumerate(spans):
        if b - a < 1:
            continue
        if name == "idle":
            if (k == 0 and starts_moving) or (k == len(spans) - 1 and ends_moving):
                continue
            doubts += _motion_in_idle_doubts(means, spans[k], levels)
        elif name in ("accel", "cruise"):
            doubts += _two_levels_doubts(means, spans[k], two_levels.get(k), levels, params)
            doubts += _drive_off_doubts(means, spans[k], at_idle[k])
        elif name == "decel" and b - a >= 5:
            doubts += _flat_decel_doubts(means, spans, k, levels)
    return doubts


def _two_level_splits(
    means: _Means10, spans: list[Span], levels: _Levels, params: MotionParams
) -> dict[int, Split | None]:
    """Every cruise's two-level split at once (`best_splits`: the splits of `best_split`
    into flat pieces of a quarter or more, on each cruise's own means), by span; only where
    a split could pass the test (`_may_hold_two_levels`: none, as a rule)."""
    y10 = means.values_W
    cruises = [k for k, (a, b, name, _) in enumerate(spans) if name == "cruise" and b - a >= 20]
    may = _may_hold_two_levels(
        y10, [spans[k][:2] for k in cruises], means.sigma_W, params.level_fraction * levels.swing_W
    )
    cruises = [k for k, kept in zip(cruises, may, strict=True) if kept]
    windows = [(spans[k][0], spans[k][1], (spans[k][1] - spans[k][0]) // 4) for k in cruises]
    return dict(zip(cruises, best_splits(y10, windows, 0, 0), strict=True))


def _longest_at_idle(
    means: _Means10, spans: list[Span], levels: _Levels
) -> dict[int, tuple[int, int]]:
    """Every accel's and cruise's longest stretch of means at idle power (length, start),
    by span; only where it could be longer than the test's 50 ms (`_longest_runs`'s
    `longer_than`)."""
    driven = [(k, a, b) for k, (a, b, name, _) in enumerate(spans) if name in ("accel", "cruise")]
    at_idle = _longest_runs(
        np.abs(means.values_W - levels.idle_W) < levels.near_W,
        [(a, b) for _, a, b in driven],
        longer_than=_most_within(0.05, means.step_s),
    )
    return dict(zip((k for k, _, _ in driven), at_idle, strict=True))


def _motion_in_idle_doubts(means: _Means10, span: Span, levels: _Levels) -> list[str]:
    """An idle phase holding power well above idle for more than the 50 ms a boundary may
    be off and still right."""
    a, b, name, step = span
    values = means.values_W[a:b]
    above = values > levels.on_W
    dt10 = means.step_s
    if not above.sum() * dt10 > 0.05:
        return []
    return [
        f"{_phase_name(name, step)} ({means.when(a):.3f}-{means.when(b):.3f} s) holds "
        f"{above.sum() * dt10:.2f} s of power well above idle (up to "
        f"{float(values.max()) - levels.idle_W:.3g} W over it): motion labelled idle?"
    ]


def _two_levels_doubts(
    means: _Means10, span: Span, split: Split | None, levels: _Levels, params: MotionParams
) -> list[str]:
    """Two levels in one cruise: the best split into two flat pieces of at least a quarter
    each, their means further apart than noise, than twice the scatter left within the
    pieces (a ripple's: it does not split into levels) and `level_fraction` of the swing,
    and fitting better than one line (a slow drift is one line, not two levels)."""
    if split is None:
        return []
    a, b, name, step = span
    index = split.index - a  # into the cruise's means
    step_W = split.jump_W
    sd = means.sigma_W * np.sqrt(1.0 / index + 1.0 / (b - a - index))
    scatter_W = np.sqrt(split.sse / (b - a))
    bar_W = max(6.0 * sd, 2.0 * scatter_W, params.level_fraction * levels.swing_W)
    if abs(step_W) > bar_W and _beats_line(means.values_W[a:b], split.sse):
        return [
            f"{_phase_name(name, step)} holds two levels ({step_W:+.3g} W at "
            f"{means.when(a + index):.3f} s): a second speed level inside one cruise?"
        ]
    return []


def _drive_off_doubts(means: _Means10, span: Span, at_idle: tuple[int, int]) -> list[str]:
    """An accel or cruise holding more than 50 ms at idle power (`_longest_at_idle`)."""
    a, _, name, step = span
    longest, at = at_idle
    if not longest * means.step_s > 0.05:
        return []
    return [
        f"{_phase_name(name, step)} holds {longest * means.step_s:.2f} s at idle power from "
        f"{means.when(a + at):.3f} s: the drive off, labelled {name}?"
    ]


def _flat_decel_doubts(means: _Means10, spans: list[Span], k: int, levels: _Levels) -> list[str]:
    """A decel phase (span `k`) whose least-squares line neither falls (against the fall's
    own sd sigma sqrt(12 / n) and a tenth of its start's height above idle) nor sits clearly
    below the cruise before it (a ripple can tilt its line)."""
    a, b, name, step = spans[k]
    y10, idle_W = means.values_W, levels.idle_W
    values = y10[a:b]
    slope, start_W = _line(values)
    n10 = b - a
    end_W = start_W + slope * (n10 - 1)
    fall_sd = means.sigma_W * np.sqrt(12.0 / n10)
    falls = start_W - end_W > max(3.0 * fall_sd, 0.1 * (start_W - idle_W))
    before = spans[k - 1] if k > 0 else None
    lower = False
    if before is not None and before[2] == "cruise" and before[1] > before[0]:
        level_W = float(np.mean(y10[before[0] : before[1]]))
        lower = level_W - float(np.mean(values)) > 0.25 * (level_W - idle_W)
    if falls or lower:
        return []
    return [
        f"{_phase_name(name, step)} ({means.when(a):.3f}-{means.when(b):.3f} s) does not fall "
        f"({start_W:.3g} W at its start, {end_W:.3g} W at its end): a steady "
        "stretch labelled decel?"
    ]


def _unexplained_step_doubts(
    means: _Means10, spans: list[Span], edges10: list[float], levels: _Levels
) -> list[str]:
    """Power steps where the phase model has no boundary (the first three): peaks of the
    jump statistic over 5 means a side, above 6 of its sd and a quarter of the swing, more
    than 60 ms (1.5 means) from every phase edge (`edges10`, in means)."""
    y10, w = means.values_W, 5
    if not y10.size > 2 * w + 2:
        return []
    jump = jump_statistic_W(y10, w)
    threshold = max(6.0 * jump_sd_factor(w) * means.sigma_W, 0.25 * levels.swing_W)
    edges = np.array(edges10, dtype=np.float64)
    tolerance = max(0.06 / means.step_s, 1.5)
    score = np.abs(jump)
    found = (
        peaks(score, threshold, w)
        if _above_off_edges(score, threshold, edges.tolist(), tolerance)
        else np.empty(0, dtype=np.int64)
    )
    if edges.size and found.size:
        nearest = np.min(np.abs(edges[None, :] - found[:, None]), axis=1)
        found = found[nearest > tolerance]
    doubts = []
    for k in [int(k) for k in found][:3]:
        inside = next((sp for sp in spans if sp[0] <= k < sp[1]), spans[-1])
        doubts.append(
            f"power steps by {float(jump[k]):+.3g} W at {means.when(k):.3f} s inside "
            f"{_phase_name(inside[2], inside[3])}, where the phase model has no boundary "
            "(a second speed level, or a stop?)"
        )
    return doubts


def _coasting_doubts(
    y10: np.ndarray, bounds: list[tuple[int, int, str, int]], idle_W: float
) -> list[str]:
    """A motors-only log: idle ~0 W, and the drive stops straight into it (no decel)."""
    with_decel = {k for _, _, name, k in bounds if name == "decel"}
    abrupt = [k for _, _, name, k in bounds if name == "cruise" and k not in with_decel]
    # the 99th percentile is at most the maximum: where even the maximum leaves idle above
    # 5% of it (a robot's idle of ~23 W, as a rule), the percentile is not needed
    if (
        abrupt
        and abs(idle_W) < 0.05 * max(float(y10.max()), 1e-9)
        and abs(idle_W) < 0.05 * max(percentile(y10, 99), 1e-9)
    ):
        return [
            f"idle is {idle_W:.2g} W (the log sees the motors only) and power drops straight "
            f"to it at the end of {len(abrupt)} step(s): a robot that coasts or brakes by "
            "shorting its motors moves on unseen, so the motion ends may be early (a speed "
            "column would tell)"
        ]
    return []


def _may_hold_two_levels(
    y10: np.ndarray, spans: list[tuple[int, int]], sigma10: float, fraction_W: float
) -> list[bool]:
    """For each cruise [a, b) of the 10 ms means `y10` (in order, apart): whether the
    two-levels test of `_motion_doubts` could pass, False only where it cannot (its split
    is then not made).

    The test's split is the best split of the cruise into two flat pieces of n // 4 means
    or more (`best_split`, degrees 0 and 0), and it passes when the pieces' means differ by
    more than max(6 sd, twice the scatter left, `fraction_W`), sd = sigma10 sqrt(1/i +
    1/(n - i)) at the split i. sd is at least sigma10 sqrt(4 / n) (1/i + 1/(n - i) is
    least at i = n/2), and the pieces' means differ by at most the cruise's range (max -
    min): a cruise whose range stays below max(6 sigma10 sqrt(4 / n), `fraction_W`)
    cannot pass (every cruise of `power10k`). For the others, over every allowed split s,
    with d(s) the difference of the two pieces' means: the split's difference is at most
    max |d(s)|, and the scatter's square is its SSE over n, SSE = SST - s (n - s) / n
    d(s)² at the best split, so at least SST - max s (n - s) / n d(s)² (SST: the squares
    about the cruise's mean); when max |d(s)| stays below max(6 sigma10 sqrt(4 / n), 2
    sqrt(that / n), `fraction_W`) the test cannot pass. Margins of 1e-9 (relative, and in
    W plus 64 ulps of the cruise's largest power) cover the rounding of these sums against
    `best_split`'s own (~1e-13 W at a robot's powers). All
    cruises at once: the ranges by one `reduceat` over the cruises' edges, the splits by
    one prefix sum over their means (each centred on its own mean)."""
    if not spans:
        return []
    n = np.array([hi - lo for lo, hi in spans], dtype=np.int64)
    noise_W = 6.0 * sigma10 * np.sqrt(4.0 / n)
    # each cruise's range: its max and min at the even places of a reduceat over the
    # cruises' edges (the odd places reduce the gaps between them)
    edges = np.array([edge for span in spans for edge in span], dtype=np.int64)
    edges = edges[:-1] if edges[-1] >= y10.size else edges
    top, bottom = np.maximum.reduceat(y10, edges)[::2], np.minimum.reduceat(y10, edges)[::2]
    spread = top - bottom
    # the margin in W: 1e-9, and 64 ulps of the cruise's largest value (`best_split` adds
    # the window's mean back to its pieces: ulps of the power, ~1e-7 W at 1e9 W)
    slack_W = 1e-9 + 64.0 * np.spacing(np.maximum(np.abs(top), np.abs(bottom)))
    may = spread * (1.0 + 1e-9) + slack_W >= np.maximum(noise_W, fraction_W) * (1.0 - 1e-9)
    if not may.any():
        return may.tolist()
    keep = np.flatnonzero(may)
    n, noise_W, slack_W = n[keep], noise_W[keep], slack_W[keep]
    least = np.maximum(n // 4, 2)
    starts = np.concatenate(([0], np.cumsum(n)[:-1]))
    values = np.concatenate([y10[spans[k][0] : spans[k][1]] for k in keep.tolist()])
    centred = values - np.repeat(np.add.reduceat(values, starts) / n, n)
    prefix = np.concatenate(([0.0], np.cumsum(centred)))
    # about the exact mean: the rounded one leaves a sum c of the centred values, and the
    # squares about it exceed SST by c² / n (far above the margins at powers of 1e6 W+)
    residue = prefix[starts + n] - prefix[starts]
    sst = np.add.reduceat(centred * centred, starts) - residue * residue / n
    # every allowed split s = least .. n - least of every cruise
    counts = n - 2 * least + 1
    first = np.concatenate(([0], np.cumsum(counts)[:-1]))
    s = np.arange(int(counts.sum())) - np.repeat(first - least, counts)
    at = np.repeat(starts, counts)
    size = np.repeat(n, counts)
    left = prefix[at + s] - prefix[at]
    total = np.repeat(prefix[starts + n] - prefix[starts], counts)
    d = (total - left) / (size - s) - left / s
    largest = np.maximum.reduceat(np.abs(d), first)
    between = np.maximum.reduceat(s * (size - s) / size * d * d, first)
    sse_least = np.maximum(sst - between - 1e-9 * sst, 0.0)
    bar_least = np.maximum(np.maximum(noise_W, 2.0 * np.sqrt(sse_least / n)), fraction_W)
    may[keep] = largest * (1.0 + 1e-9) + slack_W >= bar_least * (1.0 - 1e-9)
    return may.tolist()


def _above_off_edges(
    score: np.ndarray, threshold: float, edges: list[float], tolerance: float
) -> bool:
    """Whether `score` stands above `threshold` anywhere more than `tolerance` from every
    edge, or may (False only where it cannot): the doubts' peaks of the jump statistic
    are kept only there, so without such a place there are none to find. Each edge's
    reach is shrunk by one index either side (its rounding against |edge - k| <=
    tolerance in doubles); NaN is never above."""
    far = np.ones(score.size, dtype=bool)
    for edge in edges:
        lo = max(math.ceil(edge - tolerance) + 1, 0)
        hi = math.floor(edge + tolerance)
        if hi > lo:
            far[lo:hi] = False
    return bool((score[far] > threshold).any())


def _most_within(seconds: float, step_s: float) -> int:
    """The most steps of `step_s` that last `seconds` or less, as the doubts test it:
    the largest k with k * step_s <= seconds in doubles (0 when one step is longer)."""
    k = int(seconds / step_s) + 1
    while k > 0 and k * step_s > seconds:
        k -= 1
    return k


def _longest_runs(
    mask: np.ndarray, spans: list[tuple[int, int]], longer_than: int = 0
) -> list[tuple[int, int]]:
    """Length and start (from the span's start) of the longest run of True in each span
    [a, b) of `mask`, the first of equal ones ((0, 0) without one): the runs of the whole
    mask found once, each cut to each span. With `longer_than`, only where the run could
    be longer than that: a span holding no more Trues in all gives (0, 0) (counted by one
    prefix sum; the runs are not found when no span holds more)."""
    if longer_than > 0 and spans:
        held = np.concatenate(([0], mask.cumsum()))
        counts = [int(held[b] - held[a]) if b > a else 0 for a, b in spans]
        wanted = [k for k, count in enumerate(counts) if count > longer_than]
        found = _longest_runs(mask, [spans[k] for k in wanted])
        out = [(0, 0)] * len(spans)
        for k, run in zip(wanted, found, strict=True):
            out[k] = run
        return out
    if not spans:
        return []
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    if edges.size == 0:
        return [(0, 0)] * len(spans)
    starts, ends = edges[::2], edges[1::2]
    a, b = np.array(spans).T
    first = np.maximum(starts[None, :], a[:, None])
    lengths = np.minimum(ends[None, :], b[:, None]) - first
    k = np.argmax(lengths, axis=1)
    rows = np.arange(len(spans))
    longest = np.maximum(lengths[rows, k], 0)
    at = np.where(longest > 0, first[rows, k] - a, 0)
    return list(zip(longest.tolist(), at.tolist(), strict=True))
