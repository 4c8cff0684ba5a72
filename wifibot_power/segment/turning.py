"""Standing by the speed column, but not idle: turning in place, and a standstill at motion
power (docs/segmentation.md, "Turning and standstills").

A robot whose linear speed reads ~0 may still move: a skid-steer robot spinning in place
turns its wheels in opposite directions and draws more than it does driving straight
(log-format.md, "Turning"). With a turning column (`Run.yaw_rate_radps`) the stretches of a
standstill where the robot turns are `turn` phases, never `idle`. Without one, or where it
shows no turn, an idle phase drawing motion power is a doubt that says what was seen.
"""

from __future__ import annotations

import math

import numpy as np

from wifibot_power.changepoint import block_means, median, percentile, robust_sigma_W
from wifibot_power.phases import Phase
from wifibot_power.run import Run
from wifibot_power.segment.common import _centred_mean, _merge_stretches, _phase_name


def track_m(run: Run) -> float | None:
    """The run's track width [m] (`track_m` metadata, log-format.md), None where it is not
    given or not a positive number."""
    raw = run.meta.extra.get("track_m")
    try:
        value = float(raw) if raw is not None else math.nan
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None


def turning_blocks(
    yaw_rate_radps: np.ndarray,
    block: int,
    half: int,
    standing: np.ndarray,
    moving_fraction: float,
    moving_z: float,
    wheel_threshold_mps: float,
    track: float | None,
) -> np.ndarray:
    """Whether the robot turns in each block of `block` samples: its |yaw rate|, averaged
    signed over the block and then over 2 `half` + 1 blocks as the speed is (a gyro's
    noise, and a wobble back and forth in place, average out), above

        max(moving_fraction * top, moving_z * sigma_smoothed, 2 * wheel_threshold_mps / track)

    the speed column's own moving test read for the rate of turn: `moving_fraction` of the
    run's top rate (99th percentile), `moving_z` sd of its noise at standstill (`sigma`
    from the first differences over the `standing` blocks, `robust_sigma_W`, divided by
    sqrt(2 half + 1) for the smoothing), and, where the track width is known, the rate
    at which each wheel of a robot spinning in place, at omega * track / 2, moves as fast
    as the speed column's moving threshold `wheel_threshold_mps`. All False when the top
    rate does not clear that bar (a run that never turns). Drop-outs (NaN samples) are
    bridged by linear interpolation between the readings around them (read as 0, a spin
    with every other reading missing was cut into one-sample turns); without any reading,
    no turn.
    """
    values = np.asarray(yaw_rate_radps, dtype=np.float64)
    finite = np.isfinite(values)
    if not finite.all():
        if not finite.any():
            return np.zeros(values.size // block, dtype=bool)
        at = np.flatnonzero(finite)
        values = np.interp(np.arange(values.size), at, values[at])
    yaw = block_means(values, block)
    n = yaw.size
    if n < 3:
        return np.zeros(n, dtype=bool)
    smoothed = np.abs(_centred_mean(yaw, half))
    noise = robust_sigma_W(yaw[standing]) if int(standing.sum()) >= 3 else robust_sigma_W(yaw)
    top = percentile(smoothed, 99)
    threshold = max(moving_fraction * top, moving_z * noise / np.sqrt(2 * half + 1))
    if track is not None:
        threshold = max(threshold, 2.0 * wheel_threshold_mps / track)
    if not top > threshold:
        return np.zeros(n, dtype=bool)
    return smoothed > threshold


def with_turns(
    cuts: list[tuple[int, str, int]],
    starts: list[int],
    turning: np.ndarray,
    min_blocks: int,
) -> tuple[list[tuple[int, str, int]], list[int]]:
    """The phases (`cuts`: first block, phase, step; `starts`: each phase's first block and
    the end) with each idle's turning stretches (`turning`, gaps and stretches shorter than
    `min_blocks` merged and dropped as the speed's are) cut out as `turn` phases numbered
    as the idle they interrupt."""
    out_cuts: list[tuple[int, str, int]] = []
    out_starts: list[int] = []
    for k, (_, name, step) in enumerate(cuts):
        a, b = starts[k], starts[k + 1]
        pieces = [(a, name)]
        if name == "idle":
            pieces = []
            cursor = a
            for s, e in _merge_stretches(turning[a:b], min_blocks):
                if a + s > cursor:
                    pieces.append((cursor, "idle"))
                pieces.append((a + s, "turn"))
                cursor = a + e
            if cursor < b or not pieces:
                pieces.append((cursor, "idle"))
        for first, piece in pieces:
            out_cuts.append((first, piece, step))
            out_starts.append(first)
    return out_cuts, [*out_starts, starts[-1]]


def standstill_doubts(
    run: Run, phases: list[Phase], has_turning: bool, y: np.ndarray, block: int
) -> list[str]:
    """Idle phases drawing motion power: a standstill by the speed column at which the robot
    pushes (against an obstacle, at its current limit), or turns unseen (no turning column).
    On the run's power in blocks of `block` samples (`y`, 1 ms block means, or samples
    where a sample is longer, as all of the kinematic segmentation).

    Judged against the log's own powers: standstill power P_s, the lowest median power of
    its idle phases of two samples or more (an idle holding motion is higher), and motion
    power P_m, the mean power over its accel, cruise and decel phases (their energy over
    their time). "At motion power" is at P_m or above: standing, the robot draws what it
    draws moving, on average. Not halfway to it: electronics switched on after a motion (an
    idle 5 -> 7 W, moving at 7-9 W) are another flat level, not motion. An idle is doubted
    (`_at_motion_power`) when

    - its median power is at motion power (the whole idle: the car pushing at its current
      limit while its speed reads 0.04 m/s), or
    - it holds a stretch at motion power of its own, rising from and falling back to below
      it inside the idle (10 ms means), longer than the 50 ms a boundary may be off and two
      samples or more (a robot that stopped, spun in place, and stood again). A stretch
      that runs on from either end of the idle is not enough: the tail of a stop, or the
      head of a start, read as standing by a speed that lags the power.

    and, either way, its power stands clear of P_s by more than 5 sd of its median (the
    blocks' noise, `robust_sigma_W`, over sqrt(blocks)). Nothing is judged without motion
    above standstill (P_m > P_s) or without a second idle to read P_s from.
    """
    idles = [p for p in phases if p.phase == "idle" and p.i_end - p.i_start >= 2]
    moving = [p for p in phases if p.phase in ("accel", "cruise", "decel")]
    if len(idles) < 2 or not moving:
        return []
    # each idle's blocks (the last phase's partial block is not one: `block_means`)
    spans = [(p.i_start // block, min(-(-p.i_end // block), y.size)) for p in idles]
    medians_W = [float(median(y[a:b])) if b > a else math.nan for a, b in spans]
    standing_W = min(medians_W)
    motion_W = sum(p.energy_J for p in moving) / sum(p.duration_s for p in moving)
    if not motion_W > standing_W:
        return []
    noise_W = None  # only where some idle stands at motion power (a full pass: rare)
    doubts = []
    for phase, (a, b), median_W in zip(idles, spans, medians_W, strict=True):
        if phase.duration_s <= 0.05 or b <= a:
            continue
        found = _at_motion_power(run, y[a:b], a * block, block, median_W, motion_W)
        if found is None:
            continue
        seen_W, start_s, duration_s, blocks = found
        noise_W = robust_sigma_W(y) if noise_W is None else noise_W
        if seen_W - standing_W <= 5.0 * noise_W / np.sqrt(blocks):
            continue
        turning = "the log has no turning column"
        if has_turning and phase.yaw_rate_radps is not None:
            turning = f"its turning column shows no turn ({phase.yaw_rate_radps:.2g} rad/s)"
        where = "" if duration_s is None else f" for {duration_s:.2f} s from {start_s:.3f} s"
        doubts.append(
            f"{_phase_name('idle', phase.step)} ({phase.t_start_s:.3f}-{phase.t_end_s:.3f} s) "
            f"stands still ({phase.speed_mps or 0.0:.2g} m/s) at motion power{where}: "
            f"{seen_W:.3g} W (median) against {standing_W:.3g} W standing and "
            f"{motion_W:.3g} W moving on average; {turning}: pushing (against an obstacle, "
            "at a current limit) or turning in place?"
        )
    return doubts


def _at_motion_power(
    run: Run, values: np.ndarray, first: int, block: int, median_W: float, motion_W: float
) -> tuple[float, float | None, float | None, int] | None:
    """What of an idle phase, its blocks `values` of `block` samples from sample `first`,
    stands at motion power (`standstill_doubts`): (its median power [W], None, None, its
    blocks) for the whole idle, or (the stretch's median power, its start [s], its
    duration [s], its blocks) for the longest stretch inside it; None."""
    if median_W >= motion_W:
        return median_W, None, None, values.size
    if not values.max() >= motion_W:  # as a rule: nothing to look for
        return None
    dt = run.sample_period_s
    group = max(1, round(0.01 / (block * dt)))
    means = block_means(values, group)
    padded = np.concatenate(([False], means >= motion_W, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    inside = (starts > 0) & (ends < means.size)  # its own rise and fall
    if not inside.any():
        return None
    lengths = np.where(inside, ends - starts, 0)
    k = int(np.argmax(lengths))
    count = int(lengths[k]) * group  # blocks
    if count * block < 2 or count * block * dt <= 0.05:
        return None
    at = int(starts[k]) * group
    seen_W = float(median(values[at : at + count]))
    return seen_W, run.time_at(first + at * block), count * block * dt, count
