"""Runs with a speed column (`Run.speed_mps`), segmented from kinematics: standing
(`idle`), speeding up (`accel`), holding a level (`cruise`), slowing (`decel`), several
levels per run allowed, each boundary that power marks refined on the power trace
(docs/segmentation.md, "With a speed column")."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from wifibot_power.changepoint import best_split, block_means, median, percentile, robust_sigma_W
from wifibot_power.errors import LogError
from wifibot_power.phases import Segmentation
from wifibot_power.run import Run
from wifibot_power.segment.common import (
    Piece,
    _centred_mean,
    _merge_stretches,
    _phases,
    speed_across_gaps,
)
from wifibot_power.segment.params import SpeedParams
from wifibot_power.segment.turning import standstill_doubts, track_m, turning_blocks, with_turns

#: power refinement of a kinematic boundary, by (phase before, phase after): polynomial
#: degrees of the pieces either side and the sign of the power jump the physics gives (the
#: drive switching on, the inertial term ending, the drive stopping or shorting). A motion
#: end (-> idle) is never moved by power: a coasting robot moves on after its power drops.
_REFINE = {
    ("idle", "accel"): (0, 1, 1),
    ("accel", "cruise"): (1, 1, -1),
    ("cruise", "accel"): (1, 1, 1),
    ("accel", "decel"): (1, 1, -1),
    ("cruise", "decel"): (1, 1, -1),
    ("decel", "cruise"): (1, 1, 1),
    ("decel", "accel"): (1, 1, 1),
}


@dataclass(frozen=True)
class _SpeedTrace:
    """A run's power and speed in blocks of `block` samples (`block_dt` [s]): power `y`
    [W], the signed speed `signed` and its magnitude `v` [m/s], the magnitude smoothed over
    `smooth_s` (`smoothed`, a centred mean over 2 `half` + 1 blocks), the noise sd of the
    signed speed `sigma_v`, the top speed (99th percentile of `smoothed`) and the
    threshold above which a block is `moving`; `speed_mps` is the full-rate speed with its
    unknown stretches `gaps` filled (`speed_across_gaps`)."""

    y: np.ndarray
    signed: np.ndarray
    v: np.ndarray
    smoothed: np.ndarray
    block: int
    block_dt: float
    half: int
    sigma_v: float
    top: float
    smooth_sd: float
    threshold: float
    moving: np.ndarray
    speed_mps: np.ndarray
    gaps: list[tuple[int, int]]

    def blocks(self, seconds: float) -> int:
        """The number of blocks (at least one) that last `seconds`."""
        return max(1, round(seconds / self.block_dt))


def _speed_trace(run: Run, params: SpeedParams) -> _SpeedTrace:
    """The blocks of `_SpeedTrace` of a run with a speed column."""
    dt = run.sample_period_s
    block = max(1, round(params.block_s / dt))
    y = block_means(run.power_W, block)
    # signed speed averaged first, |.| after: the noise of a standing speed estimate
    # averages to 0 (its absolute value would average to 0.8 sd above 0), and so does a
    # vibration of the wheels back and forth in place
    speed_mps, gaps = speed_across_gaps(run.speed_mps)
    signed = block_means(speed_mps, block)
    block_dt = block * dt
    half = max(1, round(params.smooth_s / block_dt)) // 2
    smoothed = np.abs(_centred_mean(signed, half))
    sigma_v = robust_sigma_W(signed)
    top = percentile(smoothed, 99) if y.size else 0.0
    smooth_sd = sigma_v / np.sqrt(2 * half + 1)
    threshold = max(params.moving_fraction * top, params.moving_z * smooth_sd)
    return _SpeedTrace(
        y, signed, np.abs(signed), smoothed, block, block_dt, half, sigma_v, top, smooth_sd,
        threshold, smoothed > threshold, speed_mps, gaps,
    )  # fmt: skip


def _segment_kinematic(run: Run, params: SpeedParams) -> Segmentation | None:
    """Phases from the speed column: standing (`idle`), speeding up (`accel`), holding a
    level (`cruise`), slowing (`decel`), each boundary refined on the power trace where
    power marks it, and, with a turning column, turning while standing (`turn`). None when
    neither the speed nor the turning column shows motion and the run is not a motion run
    (its levels are then segmented as any log's)."""
    trace = _speed_trace(run, params)
    n = trace.y.size
    turning = None
    if run.yaw_rate_radps is not None:
        turning = turning_blocks(
            run.yaw_rate_radps, trace.block, trace.half, ~trace.moving, params.moving_fraction,
            params.moving_z, trace.threshold, track_m(run),
        )  # fmt: skip
    moves = n >= 3 and trace.top > trace.threshold and bool(trace.moving.any())
    if not moves and (turning is None or not turning.any()):
        if run.meta.mode != "motion":
            return None
        low_W, high_W = (percentile(trace.y, q) for q in (5, 95)) if n else (0.0, 0.0)
        raise LogError(
            "no motion found: the speed column never rises clearly above standstill"
            + (" and the turning column shows no turn" if turning is not None else "")
            + f" (power {low_W:.3g}-{high_W:.3g} W, 5th-95th percentile)",
            file=run.file,
            fix="check the speed column (--speed-column) and its unit (m/s); a robot that "
            "only turns in place is seen turning through a turning column (--yaw-rate-column, "
            "or the two wheel speeds with --track-width)",
        )
    if not moves:  # turns only: standing throughout, but for the turns
        trace = replace(trace, moving=np.zeros(n, dtype=bool))
    motions, floor = _motions(trace, params)
    cuts = _phase_cuts(trace, motions, params)
    starts = _refined_starts(trace, cuts, params)
    if turning is not None:
        cuts, starts = with_turns(cuts, starts, turning, trace.blocks(params.min_stretch_s))
    pieces: list[Piece] = []
    # the magnitude of each phase's mean signed speed (a standing robot's speed noise
    # averages to ~0; the mean of |v| would give it a speed of ~0.8 sigma)
    speed_sum = np.concatenate(([0.0], np.cumsum(trace.speed_mps)))
    block = trace.block
    for k, (_, name, number) in enumerate(cuts):
        i_start = starts[k] * block
        i_end = run.samples if starts[k + 1] >= n else starts[k + 1] * block
        if i_end > i_start:
            mean_speed = abs(float((speed_sum[i_end] - speed_sum[i_start]) / (i_end - i_start)))
            pieces.append((number, name, i_start, i_end, mean_speed))
    phases = _phases(run, pieces)
    # the speed at the log's first and last instants: the signed speed averaged over the
    # edge window (`edge_s`, as a motion's ends are found; signed, so a standing estimate's
    # noise averages out). Over 50 ms, a robot that starts from standstill at its first
    # sample and speeds up at once (the REGBOT logs) read a quarter of its speed at 50 ms,
    # and 66 of 72 sound logs were doubted as starting moving
    ends = trace.blocks(params.edge_s)
    signed = trace.signed
    end_speeds = (abs(float(np.mean(signed[:ends]))), abs(float(np.mean(signed[-ends:]))))
    moving_floor = max(floor, params.moving_fraction * trace.top)
    edge_ms = 1000.0 * ends * trace.block_dt
    doubts = _kinematic_doubts(run, end_speeds, edge_ms, moving_floor, motions)
    doubts += _over_commanded(run, trace.top)
    doubts += _gap_doubts(run, trace.gaps, params.still_s)
    doubts += standstill_doubts(run, phases, turning is not None, trace.y, trace.block)
    return Segmentation(run.meta.run_id, tuple(phases), (), tuple(doubts))


def _motions(trace: _SpeedTrace, params: SpeedParams) -> tuple[list[tuple[int, int]], float]:
    """The motions [a, b) between standstills (blocks), and the standstill's speed floor
    [m/s]: its median reading plus `standing_z` noise sd (0 and 0 for an encoder that
    reads 0).

    Each motion runs from the last standstill reading before it to the first after it
    (the smoothed speed crosses its threshold late at a start and early at an end), on
    speed averaged over `edge_s` (one reading of 0 amid a slow coast is not a stop) and
    standing still for `still_s` (a coast can read 0 once before it reads its last
    count)."""
    n, block_dt, moving = trace.y.size, trace.block_dt, trace.moving
    stretches = _merge_stretches(moving, trace.blocks(params.min_stretch_s))
    standing = ~moving
    edge_half = round(params.edge_s / 2 / block_dt)
    v_edge = np.abs(_centred_mean(trace.signed, edge_half))
    standing_mps = float(median(v_edge[standing])) if standing.any() else 0.0
    edge_sd = robust_sigma_W(trace.signed[standing]) / np.sqrt(2 * edge_half + 1)
    floor = standing_mps + params.standing_z * edge_sd
    still = v_edge <= floor
    # a motion ends where the speed falls below the moving threshold's share of the top
    # speed, not where the reading reaches 0: a filtered speed reading decays for tens of
    # ms after the wheels stop (at the start nothing comes before the first count)
    stopped = v_edge <= max(floor, params.moving_fraction * trace.top)
    hold = max(1, round(params.still_s / block_dt))
    motions: list[tuple[int, int]] = []
    for a, b in stretches:
        lo = max(motions[-1][1] if motions else 0, 0)
        # from the first and last clearly moving reading of the stretch (the averaged
        # speed's window reaches half of it before and after the motion)
        inside = np.flatnonzero(~stopped[a:b])
        first, last = (a + int(inside[0]), a + int(inside[-1])) if inside.size else (a, b - 1)
        lo = min(lo, first)
        # the start: just after the last standstill reading before it (a noise blip above
        # the floor earlier on is not motion); the end: where the speed then stays low
        standstill = np.flatnonzero(still[lo:first])
        start = lo + int(standstill[-1]) + 1 if standstill.size else lo
        after = _held(stopped[last + 1 :], hold)
        end = last + 1 + after if after is not None else n
        if motions and first < motions[-1][1]:
            # the motion before had not come to a standstill when this stretch started (the
            # speed dipped below the moving threshold, not to a stop: a slow crawl between
            # two fast stretches): one motion, not two that overlap and count their phases
            # twice (an F1/10 car's log, docs/real-logs.md)
            motions[-1] = (motions[-1][0], max(motions[-1][1], end))
            continue
        motions.append((start, max(end, start + 1)))
    return motions, floor


def _phase_cuts(
    trace: _SpeedTrace, motions: list[tuple[int, int]], params: SpeedParams
) -> list[tuple[int, str, int]]:
    """The phases as (first block, phase, step): idle between motions, and in each motion
    accel, cruise or decel by the slope of the smoothed speed (per second) against its
    noise and `accel_fraction` of the top speed, runs shorter than `min_phase_s` merged."""
    n, h, block_dt, top = trace.y.size, max(1, trace.half), trace.block_dt, trace.top
    vs = trace.smoothed
    slope = np.zeros(n)
    if n > 2 * h:
        slope[h:-h] = (vs[2 * h :] - vs[: -2 * h]) / (2 * h * block_dt)
    slope_sd = trace.smooth_sd * np.sqrt(2.0) / (2 * h * block_dt)
    accel_threshold = max(params.accel_fraction * top, params.accel_z * slope_sd)
    kind = np.where(slope > accel_threshold, 1, np.where(slope < -accel_threshold, -1, 0))
    names = {1: "accel", 0: "cruise", -1: "decel"}
    cuts: list[tuple[int, str, int]] = []  # (first block, phase, step)
    cursor = 0
    for number, (a, b) in enumerate(motions, start=1):
        if a > cursor:
            cuts.append((cursor, "idle", number - 1))
        pieces = _merge_runs(kind[a:b], trace.blocks(params.min_phase_s))
        for start, label in _without_creep(trace.v[a:b], pieces, params.creep_fraction * top):
            cuts.append((a + start, names[label], number))
        cursor = b
    if cursor < n:
        cuts.append((cursor, "idle", len(motions)))
    return cuts


def _without_creep(
    v: np.ndarray, pieces: list[tuple[int, int]], creep_mps: float
) -> list[tuple[int, int]]:
    """The runs (start, label: 1 accel, 0 cruise, -1 decel) of one motion's speeds `v`,
    where a "level" below `creep_mps` next to a slowing (speeding up) phase is the tail
    (head) of that phase, e.g. the slow end of an exponential coast."""
    ends = [p[0] for p in pieces[1:]] + [v.size]
    kept: list[tuple[int, int]] = []
    for k, (start, label) in enumerate(pieces):
        level = float(np.mean(v[start : ends[k]]))
        creep = label == 0 and level < creep_mps
        if creep and kept and kept[-1][1] == -1:
            continue  # joins the slowing before it
        if creep and k + 1 < len(pieces) and pieces[k + 1][1] == 1:
            pieces[k + 1] = (start, 1)
            continue  # joins the speeding up after it
        kept.append((start, label))
    return kept


def _refined_starts(
    trace: _SpeedTrace, cuts: list[tuple[int, str, int]], params: SpeedParams
) -> list[int]:
    """Each phase's first block (and the end, n), each boundary that power marks
    (`_REFINE`) moved to the best split of the power trace within `refine_s`, inside its
    neighbours, where the power jump there exceeds `refine_z` noise sd."""
    y, n = trace.y, trace.y.size
    sigma_b = robust_sigma_W(y)
    refine = trace.blocks(params.refine_s)
    starts = [c[0] for c in cuts] + [n]
    for k in range(1, len(cuts)):
        rule = _REFINE.get((cuts[k - 1][1], cuts[k][1]))
        if rule is None:
            continue
        deg_left, deg_right, sign = rule
        min_len = max(3, trace.blocks(0.005))
        lo = max(starts[k - 1] + 1, starts[k] - refine)
        hi = min(starts[k + 1] - 1, starts[k] + refine)
        split = best_split(y, lo, hi, deg_left, deg_right, min_len, jump_sign=sign)
        if split is not None and abs(split.jump_W) > params.refine_z * sigma_b:
            starts[k] = split.index
    return starts


#: A speed column whose top (99th percentile of its smoothed |speed|) is over this many times
#: the commanded (maximum) `speed_mps` is not that speed in m/s (`_over_commanded`): a
#: controlled robot overshoots its set speed by tens of percent at most; the real logs' tops
#: are 0.46-1.01 of theirs (REGBOT, F1/10, BorealTC: docs/segmentation.md). km/h is 3.6x, mph 2.2x.
OVER_COMMANDED = 1.5


def _over_commanded(run: Run, top_mps: float) -> list[str]:
    """The doubt of a speed column far over the commanded speed (`OVER_COMMANDED`): a column
    in km/h or mph makes every phase's speed, and the fit's lines, that much off."""
    commanded = run.meta.speed_mps
    if commanded is None or not commanded > 0 or not top_mps > OVER_COMMANDED * commanded:
        return []
    return [
        f"the speed column's top, {top_mps:.3g} m/s, is {top_mps / commanded:.2g}x the "
        f"commanded (maximum) speed_mps {commanded:g}: is the column in km/h (3.6x) or mph "
        "(2.2x), or speed_mps wrong?"
    ]


def _kinematic_doubts(
    run: Run,
    end_speeds: tuple[float, float],
    edge_ms: float,
    floor: float,
    motions: list[tuple[int, int]],
) -> list[str]:
    """Why phases from the speed column may not describe the run as a fit needs it
    (`end_speeds`: |mean speed| over the first and last `edge_ms`; moving above `floor`)."""
    doubts = []
    first, last = end_speeds
    if first > floor:
        doubts.append(
            f"the run starts moving ({first:.3g} m/s over its first "
            f"{edge_ms:.3g} ms): its first acceleration is not in the log"
        )
    if last > floor:
        doubts.append(
            f"the run ends moving ({last:.3g} m/s over its last {edge_ms:.3g} ms): its "
            "last stop is not in the log"
        )
    # a motion log without a commanded speed (free driving: log-format.md, "Speed") has no
    # step count to hold the motions to, unless its metadata gives one over 1 (RunMeta does
    # not tell a given 1 from the default)
    stepped = run.meta.speed_mps is not None or run.meta.steps != 1
    if run.meta.mode == "motion" and stepped and len(motions) != run.meta.steps:
        doubts.append(
            f"the speed column shows {len(motions)} motion(s) between standstills, the "
            f"metadata says {run.meta.steps} step(s)"
        )
    return doubts


def _gap_doubts(run: Run, gaps: list[tuple[int, int]], still_s: float) -> list[str]:
    """A doubt when the speed is unknown (NaN) for `still_s` [s] or longer somewhere: the
    speed is filled across by a straight line (`speed_across_gaps`), so a stop (which needs
    `still_s` of standing) or a start inside such a stretch is not seen. Shorter stretches
    cannot hide a stop and are said by the reader that left them."""
    dt = run.sample_period_s
    long = [(i, j) for i, j in gaps if (j - i) * dt >= still_s]
    if not long:
        return []
    i, j = max(long, key=lambda g: g[1] - g[0])
    total_s = sum(b - a for a, b in long) * dt
    return [
        f"the speed is unknown for {len(long)} stretch(es) of {still_s:g} s or longer "
        f"({total_s:.3g} s in all; the longest {(j - i) * dt:.3g} s from t = "
        f"{float(run.time_s[i]):.6g} s): filled by a straight line across, so a stop or a "
        "start inside is not seen"
    ]


def _held(mask: np.ndarray, hold: int) -> int | None:
    """Index of the first True in `mask` that starts a run of `hold` Trues (or a shorter one
    reaching its end); None without one."""
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    ok = ((ends - starts) >= hold) | (ends == mask.size)
    return int(starts[ok][0]) if ok.any() else None


def _merge_runs(labels: np.ndarray, min_len: int) -> list[tuple[int, int]]:
    """Runs of equal labels as (start, label), runs shorter than `min_len` merged into a
    neighbour (the shortest first; into the neighbour it resembles, else the longer one)."""
    if labels.size == 0:
        return []
    change = np.flatnonzero(np.diff(labels)) + 1
    starts = [0, *change.tolist()]
    runs = [[s, int(labels[s])] for s in starts]
    ends = [*starts[1:], labels.size]
    lengths = [e - s for s, e in zip(starts, ends, strict=True)]
    while len(runs) > 1:
        k = int(np.argmin(lengths))
        if lengths[k] >= min_len:
            break
        left = k - 1 if k > 0 else None
        right = k + 1 if k + 1 < len(runs) else None
        if left is None or (right is not None and lengths[right] > lengths[left]):
            target = right
        else:
            target = left
        # a short cruise between two accelerations (or a blip) joins the longer side
        if target == right:
            runs[right][0] = runs[k][0]
        lengths[target] += lengths[k]
        del runs[k], lengths[k]
        # neighbours now equal in label are one run
        merged_runs: list[list[int]] = []
        merged_lengths: list[int] = []
        for r, length in zip(runs, lengths, strict=True):
            if merged_runs and merged_runs[-1][1] == r[1]:
                merged_lengths[-1] += length
            else:
                merged_runs.append(r)
                merged_lengths.append(length)
        runs, lengths = merged_runs, merged_lengths
    return [(int(s), int(label)) for s, label in runs]
