"""Segmentation of a run into phases: what `wbpower segment` computes (and `fit` uses).

A run with a speed column (`Run.speed_mps`) whose speed shows motion is cut from
kinematics: standing (`idle`), speeding up (`accel`), holding a level (`cruise`), slowing
(`decel`), several levels per run allowed, the power trace refining the boundaries it marks
(`_segment_kinematic`, `SpeedParams`). Otherwise a motion run (`meta.mode == "motion"`,
`meta.steps = N`) is cut from power into: idle, then for each step `accel`, `cruise`,
`decel` (only when the data shows one), idle between steps, and the phase model is then
tested against the trace (`_motion_doubts`): where it does not fit, `Segmentation.doubts`
says why. Any other log is cut into steady `level` segments by the generic layer
(`wifibot_power.changepoint.detect_levels`).

Motion runs, on 1 ms block means (docs/segmentation.md has the details and figures):

1. Idle level: the lower of the medians of the first and last `idle_probe_s` (runs start
   and end idle). Motion is where 10 ms means stand `motion_z` noise sd (and at least
   `min_excess_W`) above idle; of the stretches found, gaps where power does not settle at
   idle are closed (the shortest first) until N remain, so a cruise ripple dipping towards
   idle does not cut a step in two (settled gaps are idle between steps: a wrong step count
   then shows as steps found != metadata).
2. Acceleration start t0: a least-squares split [Bai & Perron 1998] of the window around
   the coarse start into a flat idle piece and a line (the drive-on step, then the linear
   power ramp of constant acceleration), power jumping up: the true start, not a crossing.
3. Acceleration end t1: power falls from the ramp's peak P_idle + P_drive +
   (c_roll + kI m a) v (the mean of that ramp is the paper's Eq. 2 line) to the cruise level
   (Eq. 4) when the acceleration stops: the first clear drop of the jump statistic after
   rising power, then a split of a quadratic ramp piece from a quadratic cruise piece.
4. Motion end t3: a split into a quadratic piece (cruise or stop) and a flat idle piece.
5. Stop phase (decel) start t2, kept only when the data shows one (causes.md
   `decel_phase`; the paper's Eq. 6 has none): a significant drop into a falling line
   that ends closer to idle than to the cruise level and lasts `min_decel_s`; after a
   steady cruise, up to 5 s long, and dropped when its power is seen not to fall from its
   start (a second, lower speed level is flat first).

Phases cover every sample exactly once; boundaries fall on block edges (1 ms).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np

from wifibot_power.changepoint import (
    LevelParams,
    Split,
    best_split,
    best_splits,
    block_means,
    detect_levels,
    jump_sd_factor,
    jump_statistic_W,
    median,
    peaks,
    percentile,
    robust_sigma_W,
)
from wifibot_power.errors import LogError
from wifibot_power.io import ReadOptions, read_log
from wifibot_power.phases import Phase, Segmentation, Spike
from wifibot_power.run import Run


@dataclass(frozen=True)
class MotionParams:
    """Parameters of motion segmentation (docs/segmentation.md)."""

    #: block length [s] every fit works on
    block_s: float = 0.001
    #: leading and trailing stretch assumed idle [s]
    idle_probe_s: float = 0.5
    #: motion is where 10 ms means exceed idle by this many noise sd, and at least `min_excess_W`
    motion_z: float = 5.0
    min_excess_W: float = 0.25
    #: motion stretches shorter than this are noise [s]
    min_motion_s: float = 0.05
    #: while more stretches than steps are found, gaps between them where power does not
    #: settle at idle (10 ms means off idle by more than max(idle_rms_z sd, idle_rms_min_W)
    #: rms: a cruise ripple dipping) are closed, the shortest first; settled gaps never are
    idle_rms_z: float = 1.5
    idle_rms_min_W: float = 0.05
    #: the longest acceleration looked for [s] and the shortest
    max_accel_s: float = 2.5
    min_accel_s: float = 0.03
    #: half width of the lines of the jump statistic that finds the end of acceleration [s]
    jump_half_width_s: float = 0.025
    #: a drop at the end of acceleration must exceed this many sd of the jump statistic
    jump_z: float = 5.0
    #: the acceleration start is fitted on at most this much of the ramp [s]
    accel_probe_s: float = 0.3
    #: without a clear drop, the end of acceleration is looked for this far from its start [s]
    kink_probe_s: float = 0.5
    #: half width of the window of each fine split [s]
    refine_s: float = 0.06
    #: how far before / after the coarse motion end the end is looked for [s]
    end_back_s: float = 0.4
    end_forward_s: float = 1.6
    #: the longest stop phase looked for [s] and the shortest kept: decel_phase's plausible
    #: 5 s after a steady cruise, where a candidate must fall from its start (a lower speed
    #: level is flat first: `decel_shape_z`); after a wavy cruise (a ripple hides that
    #: shape) 1.5 s, and a lower level within that is taken for a stop (docs/segmentation.md)
    max_decel_s: float = 5.0
    max_decel_wavy_s: float = 1.5
    min_decel_s: float = 0.1
    #: a stop phase after a steady cruise must start with a drop of this many sd; the flat
    #: cruise before it is fitted over up to this long [s]
    decel_split_z: float = 6.0
    decel_cruise_s: float = 1.0
    #: after a wavy cruise (a ripple): a drop of this many sd of the jump statistic, whose
    #: lines are this long [s] (short: a slow ripple hardly bends them)
    decel_z: float = 4.0
    decel_half_widths_s: tuple[float, ...] = (0.025, 0.08, 0.2)
    #: a stop phase ends closer to idle than this fraction of the cruise power above idle
    decel_end_fraction: float = 0.45
    #: after a steady cruise a stop's power falls from its start (`_falls_from_start`): a
    #: candidate is dropped when, by more than this many noise sd, its first third's mean
    #: falls less than `decel_fall_fraction` of its height above idle to its last third's,
    #: or its first third falls less than half as much as its last third. 2 sd, not 3: a
    #: stop dropped by chance (one-sided 2.3% per test where its shape shows nothing) is
    #: a doubted run (its drop stands unexplained in the cruise), a level kept as a stop
    #: a silent one. Of 238 stops at field realism (fieldgen's exponential ones of 1-4 s,
    #: the simulator's linear ones of 0.2-4 s) none was dropped, the closest 3.3 sd clear
    decel_shape_z: float = 2.0
    decel_fall_fraction: float = 0.1
    #: a doubt: a cruise whose two parts (the best split into flat pieces of a quarter or
    #: more) differ by this fraction of the motion's swing above idle (and by more than
    #: noise and twice the scatter within them, and fit better than one line) holds two
    #: levels
    level_fraction: float = 0.25
    #: doubts of a stop the ripple hid (`_hidden_stop_doubts`): a wavy cruise's last
    #: `max_decel_wavy_s` off its carried-on ripple by more than this times the rms of the
    #: ripple's fit before it (twice: the two-levels test's "twice the scatter"); an idle
    #: whose start stands above its level by more than this many sd of the stretch's mean
    hidden_stop_ratio: float = 2.0
    hidden_stop_z: float = 6.0
    #: the ripple is fitted over up to this long before the tail [s] (2 cycles at 0.1 m/s
    #: of the paper's robot: 8.2 s)
    hidden_stop_fit_s: float = 10.0


@dataclass(frozen=True)
class SpeedParams:
    """Parameters of segmentation from a speed column (docs/segmentation.md, "With a speed
    column")."""

    #: block length [s] everything works on (at least one sample)
    block_s: float = 0.001
    #: the speed is smoothed over this long [s] (a centred moving average) before the
    #: moving test and the slope
    smooth_s: float = 0.04
    #: moving where the smoothed speed exceeds this fraction of the run's top speed (99th
    #: percentile) and `moving_z` sd of its noise
    moving_fraction: float = 0.02
    moving_z: float = 5.0
    #: a motion's ends are where the raw speed last / first reads standstill: its standing
    #: median plus this many noise sd
    standing_z: float = 3.0
    #: ... on the speed averaged over this long [s] (the raw speed where a sample is longer)
    edge_s: float = 0.009
    #: ... where it then stays at standstill this long [s] (at least one sample)
    still_s: float = 0.1
    #: moving or standing stretches shorter than this are merged into their neighbours [s]
    min_stretch_s: float = 0.1
    #: accelerating (braking) where the slope of the smoothed speed exceeds this fraction of
    #: the top speed per second [1/s] (a change of 2% of the top speed in 0.1 s) and
    #: `accel_z` sd of its noise; cruising otherwise
    accel_fraction: float = 0.2
    accel_z: float = 5.0
    #: a steady stretch below this fraction of the top speed beside a slowing (speeding
    #: up) phase is that phase's tail (head), not a speed level
    creep_fraction: float = 0.1
    #: phases shorter than this are merged into a neighbour [s]
    min_phase_s: float = 0.06
    #: each boundary with a power signature is refined on the power trace within this far [s]
    refine_s: float = 0.06
    #: and moved only when the power jump there exceeds this many noise sd (of a block)
    refine_z: float = 5.0


@dataclass(frozen=True)
class _Step:
    t0: int  # accel start (block index)
    t1: int  # accel end = cruise start
    t2: int  # cruise end (= t3 without a stop phase)
    t3: int  # motion end
    wavy: bool = False  # [t1, motion end) wavy (a ripple), before any stop was split off


def segment_run(
    run: Run,
    motion: MotionParams | None = None,
    levels: LevelParams | None = None,
    speed: SpeedParams | None = None,
) -> Segmentation:
    """Phases of one run: from its speed column when it has one (a motion run, or a run of
    unknown mode whose speed shows motion), else motion phases from power for a motion run,
    steady levels otherwise. `Segmentation.doubts` says why the phases may be wrong.

    Raises `LogError` (naming the file) when a motion run shows no motion.
    """
    if run.samples == 0:
        raise LogError("the log holds no samples", file=run.file, fix="check the file")
    if run.speed_mps is not None and run.meta.mode in ("motion", "unknown"):
        found = _segment_kinematic(run, speed or SpeedParams())
        if found is not None:
            return found
    if run.meta.mode == "motion":
        return _segment_motion(run, motion or MotionParams())
    return _segment_levels(run, levels or LevelParams())


def segment_file(path: str | Path, options: ReadOptions | None = None) -> tuple[Run, Segmentation]:
    """Read one log and segment it (what `wbpower segment FILE` does)."""
    run = read_log(path, options or ReadOptions())
    try:
        return run, segment_run(run)
    except LogError as exc:
        raise exc.with_file(path) from None


# -- level logs ----------------------------------------------------------------------------


def _segment_levels(run: Run, params: LevelParams) -> Segmentation:
    found = detect_levels(run.power_W, run.sample_period_s, params)
    bounds = list(found.bounds)
    phases = _phases(
        run,
        [(level, "level", a, b, None) for level, (a, b) in enumerate(pairwise(bounds), start=1)],
    )
    spikes = tuple(
        Spike(
            t_start_s=_time_at(run, s.i_start),
            duration_s=_time_at(run, s.i_end) - _time_at(run, s.i_start),
            peak_W=s.peak_W,
            energy_above_level_J=s.energy_above_level_J,
        )
        for s in found.spikes
    )
    return Segmentation(run.meta.run_id, tuple(phases), spikes)


# -- runs with a speed column --------------------------------------------------------------

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


def _segment_kinematic(run: Run, params: SpeedParams) -> Segmentation | None:
    """Phases from the speed column: standing (`idle`), speeding up (`accel`), holding a
    level (`cruise`), slowing (`decel`), each boundary refined on the power trace where
    power marks it. None when the speed never shows motion and the run is not a motion run
    (its levels are then segmented as any log's)."""
    dt = run.sample_period_s
    block = max(1, round(params.block_s / dt))
    y = block_means(run.power_W, block)
    # signed speed averaged first, |.| after: the noise of a standing speed estimate
    # averages to 0 (its absolute value would average to 0.8 sd above 0), and so does a
    # vibration of the wheels back and forth in place
    signed = block_means(np.nan_to_num(run.speed_mps, nan=0.0), block)
    v = np.abs(signed)
    n = y.size
    block_dt = block * dt

    def blocks(seconds: float) -> int:
        return max(1, round(seconds / block_dt))

    half = blocks(params.smooth_s) // 2
    vs = np.abs(_centred_mean(signed, half))
    sigma_v = robust_sigma_W(signed)
    top = percentile(vs, 99) if n else 0.0
    smooth_sd = sigma_v / np.sqrt(2 * half + 1)
    threshold = max(params.moving_fraction * top, params.moving_z * smooth_sd)
    moving = vs > threshold
    if n < 3 or top <= threshold or not moving.any():
        if run.meta.mode != "motion":
            return None
        raise LogError(
            "no motion found: the speed column never rises clearly above standstill",
            file=run.file,
            fix="check the speed column (--speed-column) and its unit (m/s)",
        )
    stretches = _merge_stretches(moving, blocks(params.min_stretch_s))
    standing = ~moving
    # standstill: its median reading and noise (0 and 0 for an encoder that reads 0)
    edge_half = round(params.edge_s / 2 / block_dt)
    v_edge = np.abs(_centred_mean(signed, edge_half))
    standing_mps = float(median(v_edge[standing])) if standing.any() else 0.0
    edge_sd = robust_sigma_W(signed[standing]) / np.sqrt(2 * edge_half + 1)
    floor = standing_mps + params.standing_z * edge_sd
    # each motion runs from the last standstill reading before it to the first after it
    # (the smoothed speed crosses its threshold late at a start and early at an end), on
    # speed averaged over `edge_s` (one reading of 0 amid a slow coast is not a stop)
    # and standing still for `still_s` (a coast can read 0 once before it reads its last
    # count)
    still = v_edge <= floor
    # a motion ends where the speed falls below the moving threshold's share of the top
    # speed, not where the reading reaches 0: a filtered speed reading decays for tens of
    # ms after the wheels stop (at the start nothing comes before the first count)
    stopped = v_edge <= max(floor, params.moving_fraction * top)
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
    # slope of the smoothed speed (per second), its noise, and the class of each block
    h = max(1, half)
    slope = np.zeros(n)
    if n > 2 * h:
        slope[h:-h] = (vs[2 * h :] - vs[: -2 * h]) / (2 * h * block_dt)
    slope_sd = smooth_sd * np.sqrt(2.0) / (2 * h * block_dt)
    accel_threshold = max(params.accel_fraction * top, params.accel_z * slope_sd)
    kind = np.where(slope > accel_threshold, 1, np.where(slope < -accel_threshold, -1, 0))
    names = {1: "accel", 0: "cruise", -1: "decel"}
    sigma_b = robust_sigma_W(y)
    refine = blocks(params.refine_s)
    cuts: list[tuple[int, str, int]] = []  # (first block, phase, step)
    cursor = 0
    for number, (a, b) in enumerate(motions, start=1):
        if a > cursor:
            cuts.append((cursor, "idle", number - 1))
        pieces = _merge_runs(kind[a:b], blocks(params.min_phase_s))
        # a "level" far below the top speed next to a slowing (speeding up) phase is the
        # tail (head) of that phase, e.g. the slow end of an exponential coast
        ends = [p[0] for p in pieces[1:]] + [b - a]
        kept: list[tuple[int, int]] = []
        for k, (start, label) in enumerate(pieces):
            level = float(np.mean(v[a + start : a + ends[k]]))
            creep = label == 0 and level < params.creep_fraction * top
            if creep and kept and kept[-1][1] == -1:
                continue  # joins the slowing before it
            if creep and k + 1 < len(pieces) and pieces[k + 1][1] == 1:
                pieces[k + 1] = (start, 1)
                continue  # joins the speeding up after it
            kept.append((start, label))
        for start, label in kept:
            cuts.append((a + start, names[label], number))
        cursor = b
    if cursor < n:
        cuts.append((cursor, "idle", len(motions)))
    # refine the boundaries that power marks, each inside its neighbours
    starts = [c[0] for c in cuts] + [n]
    for k in range(1, len(cuts)):
        rule = _REFINE.get((cuts[k - 1][1], cuts[k][1]))
        if rule is None:
            continue
        deg_left, deg_right, sign = rule
        min_len = max(3, blocks(0.005))
        lo = max(starts[k - 1] + 1, starts[k] - refine)
        hi = min(starts[k + 1] - 1, starts[k] + refine)
        split = best_split(y, lo, hi, deg_left, deg_right, min_len, jump_sign=sign)
        if split is not None and abs(split.jump_W) > params.refine_z * sigma_b:
            starts[k] = split.index
    pieces: list[tuple[int, str, int, int, float | None]] = []
    # the magnitude of each phase's mean signed speed (a standing robot's speed noise
    # averages to ~0; the mean of |v| would give it a speed of ~0.8 sigma)
    speed_sum = np.concatenate(([0.0], np.cumsum(np.nan_to_num(run.speed_mps))))
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
    ends = blocks(params.edge_s)
    end_speeds = (abs(float(np.mean(signed[:ends]))), abs(float(np.mean(signed[-ends:]))))
    moving_floor = max(floor, params.moving_fraction * top)
    edge_ms = 1000.0 * ends * block_dt
    doubts = _kinematic_doubts(run, end_speeds, edge_ms, moving_floor, motions)
    return Segmentation(run.meta.run_id, tuple(phases), (), tuple(doubts))


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
    if run.meta.mode == "motion" and len(motions) != run.meta.steps:
        doubts.append(
            f"the speed column shows {len(motions)} motion(s) between standstills, the "
            f"metadata says {run.meta.steps} step(s)"
        )
    return doubts


def _held(mask: np.ndarray, hold: int) -> int | None:
    """Index of the first True in `mask` that starts a run of `hold` Trues (or a shorter one
    reaching its end); None without one."""
    padded = np.concatenate(([False], mask, [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    ok = ((ends - starts) >= hold) | (ends == mask.size)
    return int(starts[ok][0]) if ok.any() else None


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


# -- motion runs ---------------------------------------------------------------------------


def _segment_motion(run: Run, params: MotionParams) -> Segmentation:
    dt = run.sample_period_s
    block = max(1, round(params.block_s / dt))
    y = block_means(run.power_W, block)
    block_dt = block * dt
    n_blocks = y.size
    if n_blocks < 50:
        raise LogError(
            f"too short to segment ({run.samples} samples)",
            file=run.file,
            fix="a motion run needs idle before and after the motion",
        )
    # 10 ms means and their noise, shared by the coarse search and the doubts
    group = max(1, round(0.01 / block_dt))
    y10 = block_means(y, group)
    sigma10 = robust_sigma_W(y10)
    coarse = _coarse_motion(y, y10, group, sigma10, block_dt, max(1, run.meta.steps), params)
    if not coarse:
        raise LogError(
            "no motion found: power never rises clearly above the idle level (read from "
            "the first and last 0.5 s: a run moving at both ends shows none)",
            file=run.file,
            fix="check the run's mode, or the reading options (--supply-voltage); a run "
            "without idle at either end needs a speed column",
        )
    sigma_b = robust_sigma_W(y)
    steps = _locate_steps(y, block_dt, sigma_b, coarse, params)

    bounds: list[tuple[int, int, str, int]] = []  # (start block, end block, phase, step)
    cursor = 0
    for number, st in enumerate(steps, start=1):
        bounds.append((cursor, st.t0, "idle", number - 1))
        bounds.append((st.t0, st.t1, "accel", number))
        bounds.append((st.t1, st.t2, "cruise", number))
        if st.t3 > st.t2:
            bounds.append((st.t2, st.t3, "decel", number))
        cursor = st.t3
    bounds.append((cursor, n_blocks, "idle", len(steps)))
    pieces: list[tuple[int, str, int, int, float | None]] = []
    for a, b, name, number in bounds:
        i_start = a * block
        i_end = run.samples if b >= n_blocks else b * block
        if i_end > i_start:
            # without a speed column, a cruise is at the run's commanded speed (cli.md)
            speed = run.meta.speed_mps if name == "cruise" else None
            pieces.append((number, name, i_start, i_end, speed))
    phases = _phases(run, pieces)
    spikes = tuple(_start_spikes(run, y, block, sigma_b, steps))
    wavy = {number for number, st in enumerate(steps, start=1) if st.wavy}
    doubts = _motion_doubts(
        run, y10, group, sigma10, block_dt, bounds, len(steps), params, wavy_steps=wavy
    )
    return Segmentation(run.meta.run_id, tuple(phases), spikes, tuple(doubts))


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

    On 10 ms means, against the trace's own noise (σ₁₀, `robust_sigma_W`) and its motion
    swing (median cruise power above idle), each test looks for structure the phase model
    cannot hold (docs/segmentation.md, "Doubts"):

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
    dt10 = group * block_dt
    m = y10.size
    if m < 10:
        return []
    # each phase in 10 ms means (its whole 10 ms means only)
    spans = [(-(-a // group), min(b // group, m), name, k) for a, b, name, k in bounds]
    # idle: the lowest of the idle phases' medians (an "idle" holding motion is higher)
    idle_median_W = {
        k: float(median(y10[a:b]))
        for k, (a, b, name, _) in enumerate(spans)
        if name == "idle" and b > a
    }
    idle_levels = list(idle_median_W.values())
    idle_W = min(idle_levels) if idle_levels else float(y10.min())
    cruise_W = [_mean(y10[a:b]) for a, b, name, _ in spans if name == "cruise" and b > a]
    swing_W = float(median(cruise_W)) - idle_W if cruise_W else float(y10.max()) - idle_W
    swing_W = max(swing_W, params.min_excess_W)
    # "well above idle": clear of noise and a fifth of the motion's swing
    on_W = idle_W + max(params.motion_z * sigma10, 0.2 * swing_W, params.min_excess_W)
    # "at idle": within noise and a tenth of the swing
    near_W = max(3.0 * sigma10, 0.1 * swing_W)

    def when(index10: int) -> float:
        return run.time_at(0) + index10 * dt10

    def name_of(name: str, step: int) -> str:
        return f"the {name} phase before step 1" if step == 0 else f"the {name} of step {step}"

    doubts: list[str] = []
    # every cruise's two-level split at once (`best_splits`: the splits of `best_split` on
    # each cruise's own means), and every accel's and cruise's longest stretch at idle
    cruises = [k for k, (a, b, name, _) in enumerate(spans) if name == "cruise" and b - a >= 20]
    # only where a split could pass the test (`_may_hold_two_levels`: none, as a rule)
    may = _may_hold_two_levels(
        y10, [spans[k][:2] for k in cruises], sigma10, params.level_fraction * swing_W
    )
    cruises = [k for k, kept in zip(cruises, may, strict=True) if kept]
    windows = [(spans[k][0], spans[k][1], (spans[k][1] - spans[k][0]) // 4) for k in cruises]
    two_levels = dict(zip(cruises, best_splits(y10, windows, 0, 0), strict=True))
    # (only where it could pass the test's 50 ms: `_longest_runs`'s `longer_than`)
    driven = [(k, a, b) for k, (a, b, name, _) in enumerate(spans) if name in ("accel", "cruise")]
    at_idle = _longest_runs(
        np.abs(y10 - idle_W) < near_W,
        [(a, b) for _, a, b in driven],
        longer_than=_most_within(0.05, dt10),
    )
    longest_at_idle = dict(zip((k for k, _, _ in driven), at_idle, strict=True))
    edge = min(5, m)
    starts_moving = float(median(y10[:edge])) > on_W
    ends_moving = float(median(y10[-edge:])) > on_W
    if starts_moving:
        doubts.append(
            f"the run starts moving (power {float(median(y10[:edge])) - idle_W:.3g} W above "
            "idle from its first sample): its first acceleration is not in the log"
        )
    if ends_moving:
        doubts.append(
            f"the run ends moving (power {float(median(y10[-edge:])) - idle_W:.3g} W above "
            "idle at its last sample): its last stop is not in the log"
        )
    for k, (a, b, name, step) in enumerate(spans):
        if b - a < 1:
            continue
        values = y10[a:b]
        if name == "idle":
            if (k == 0 and starts_moving) or (k == len(spans) - 1 and ends_moving):
                continue
            # more than the 50 ms a boundary may be off and still right
            above = values > on_W
            if above.sum() * dt10 > 0.05:
                doubts.append(
                    f"{name_of(name, step)} ({when(a):.3f}-{when(b):.3f} s) holds "
                    f"{above.sum() * dt10:.2f} s of power well above idle (up to "
                    f"{float(values.max()) - idle_W:.3g} W over it): motion labelled idle?"
                )
        elif name in ("accel", "cruise"):
            longest, at = longest_at_idle[k]
            split = two_levels.get(k)
            if split is not None:
                # two levels in one cruise: the best split into two flat pieces of at
                # least a quarter each, their means further apart than noise, than twice
                # the scatter left within the pieces (a ripple's: it does not split into
                # levels) and `level_fraction` of the swing, and fitting better than one
                # line (a slow drift is one line, not two levels)
                index = split.index - a  # into the cruise's means
                step_W = split.jump_W
                sd = sigma10 * np.sqrt(1.0 / index + 1.0 / (b - a - index))
                scatter_W = np.sqrt(split.sse / (b - a))
                bar_W = max(6.0 * sd, 2.0 * scatter_W, params.level_fraction * swing_W)
                if abs(step_W) > bar_W and _beats_line(values, split.sse):
                    doubts.append(
                        f"{name_of(name, step)} holds two levels ({step_W:+.3g} W at "
                        f"{when(a + index):.3f} s): a second speed level inside "
                        "one cruise?"
                    )
            if longest * dt10 > 0.05:
                doubts.append(
                    f"{name_of(name, step)} holds {longest * dt10:.2f} s at idle power from "
                    f"{when(a + at):.3f} s: the drive off, labelled {name}?"
                )
        elif name == "decel" and b - a >= 5:
            # the least-squares line over the phase: its fall, against the fall's own sd
            # sigma sqrt(12 / n) and a tenth of its start's height above idle
            slope, start_W = _line(values)
            n10 = b - a
            end_W = start_W + slope * (n10 - 1)
            fall_sd = sigma10 * np.sqrt(12.0 / n10)
            falls = start_W - end_W > max(3.0 * fall_sd, 0.1 * (start_W - idle_W))
            # or it sits clearly below the cruise before it (a ripple can tilt its line)
            before = spans[k - 1] if k > 0 else None
            lower = False
            if before is not None and before[2] == "cruise" and before[1] > before[0]:
                level_W = float(np.mean(y10[before[0] : before[1]]))
                lower = level_W - float(np.mean(values)) > 0.25 * (level_W - idle_W)
            if not (falls or lower):
                doubts.append(
                    f"{name_of(name, step)} ({when(a):.3f}-{when(b):.3f} s) does not fall "
                    f"({start_W:.3g} W at its start, {end_W:.3g} W at its end): a steady "
                    "stretch labelled decel?"
                )
    doubts += _hidden_stop_doubts(
        y10, sigma10, spans, idle_median_W, when, name_of, params, wavy_steps, ends_moving
    )
    # power steps where the phase model has no boundary
    w = 5
    if m > 2 * w + 2:
        jump = jump_statistic_W(y10, w)
        threshold = max(6.0 * jump_sd_factor(w) * sigma10, 0.25 * swing_W)
        edges10 = np.array([b / group for _, b, _, _ in bounds[:-1]], dtype=np.float64)
        tolerance = max(0.06 / dt10, 1.5)
        score = np.abs(jump)
        found = (
            peaks(score, threshold, w)
            if _above_off_edges(score, threshold, edges10.tolist(), tolerance)
            else np.empty(0, dtype=np.int64)
        )
        if edges10.size and found.size:
            nearest = np.min(np.abs(edges10[None, :] - found[:, None]), axis=1)
            found = found[nearest > tolerance]
        unexplained = [int(k) for k in found]
        for k in unexplained[:3]:
            inside = next((sp for sp in spans if sp[0] <= k < sp[1]), spans[-1])
            doubts.append(
                f"power steps by {float(jump[k]):+.3g} W at {when(k):.3f} s inside "
                f"{name_of(inside[2], inside[3])}, where the phase model has no boundary "
                "(a second speed level, or a stop?)"
            )
    # a motors-only log: idle ~0 W, and the drive stops straight into it
    abrupt = [k for _, _, name, k in bounds if name == "cruise"]
    with_decel = {k for _, _, name, k in bounds if name == "decel"}
    abrupt = [k for k in abrupt if k not in with_decel]
    # the 99th percentile is at most the maximum: where even the maximum leaves idle above
    # 5% of it (a robot's idle of ~23 W, as a rule), the percentile is not needed
    if (
        abrupt
        and abs(idle_W) < 0.05 * max(float(y10.max()), 1e-9)
        and abs(idle_W) < 0.05 * max(percentile(y10, 99), 1e-9)
    ):
        doubts.append(
            f"idle is {idle_W:.2g} W (the log sees the motors only) and power drops straight "
            f"to it at the end of {len(abrupt)} step(s): a robot that coasts or brakes by "
            "shorting its motors moves on unseen, so the motion ends may be early (a speed "
            "column would tell)"
        )
    if run.meta.mode == "motion" and steps_found != run.meta.steps:
        doubts.append(
            f"found {steps_found} step(s) separated by idle, the metadata says {run.meta.steps}"
        )
    return doubts


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


def _hidden_stop_doubts(
    y10: np.ndarray,
    sigma10: float,
    spans: list[tuple[int, int, str, int]],
    idle_median_W: dict[int, float],
    when: Callable[[int], float],
    name_of: Callable[[str, int], str],
    params: MotionParams,
    wavy_steps: set[int] | None = None,
    ends_moving: bool = False,
) -> list[str]:
    """Stops a ripple may have hidden (docs/segmentation.md, "A stop hidden by the
    ripple"), on the 10 ms means `y10` (noise sd `sigma10`) of the phases `spans` (the
    idles' medians `idle_median_W`, by span). When the run `ends_moving` (doubted as such
    already), its last idle is not looked at: the motion in it is not a stop.

    - A wavy cruise (`wavy_steps`: the steps whose search found the motion after the
      acceleration wavy, any stop in it included; by default the cruise's 10 ms means
      tested as `_wavy` does) that runs straight into idle (no stop
      found): its ripple (a line and the sinusoid that fits it best,
      `_ripple_continuation`) is fitted on the cruise but its last `max_decel_wavy_s` (or
      third), and carried on over that tail. Where the
      cruise really held on to the end, the tail scatters about the carried-on ripple as
      the fitted part does about its fit; a stop inside it (power drops, then falls
      towards idle, while the ripple fades with the speed) does not. Doubted when the
      tail's rms off the ripple exceeds `hidden_stop_ratio` times the fitted part's
      (and noise's).
    - An idle after a step: power that stands above the idle's own median from its start
      (the drive still on: a stop labelled idle) by more than `hidden_stop_z` noise sd of
      the stretch's mean from 50 ms past its start to 50 ms before its end (the tolerance
      of a boundary at either end, as for a cruise), and by `min_excess_W` at least.
    """
    doubts: dict[int, str] = {}  # by span, in span order at the end
    dt_ms = 1000.0 * (when(1) - when(0))
    # a boundary within 50 ms is right (issue 12): the ends of each phase are left out
    guard = max(1, round(50.0 / dt_ms))
    # the wavy cruises that run straight into idle: their means (of `group` 10 ms means,
    # at most `_RIPPLE_POINTS`: the cost), fitted part and tail, fitted all at once
    cruises: list[tuple[int, np.ndarray, int, float, float]] = []
    for k, (a, b, name, step) in enumerate(spans):
        following = spans[k + 1][2] if k + 1 < len(spans) else None
        if name != "cruise" or following != "idle" or b - a - 2 * guard < 30:
            continue
        values = y10[a + guard : b - guard]
        # wavy as the step's search first found it (the cruise with any stop it hides),
        # else by the same test here
        wavy = step in wavy_steps if wavy_steps is not None else _wavy_means(values, sigma10)
        if not wavy:
            continue
        n = values.size
        tail = min(max(1, round(params.max_decel_wavy_s * 1000.0 / dt_ms)), n // 3)
        # fitted over up to `hidden_stop_fit_s` before the tail
        fit = min(n - tail, max(1, round(params.hidden_stop_fit_s * 1000.0 / dt_ms)))
        group = -(-(fit + tail) // _RIPPLE_POINTS)
        fit_g, tail_g = fit // group, tail // group  # (fit + tail) // group <= 256
        if fit_g < 8 or tail_g < 1:
            continue
        means = block_means(values[n - (fit_g + tail_g) * group :], group)
        cruises.append((k, means, fit_g, sigma10 / np.sqrt(group), tail * dt_ms / 1000.0))
    fits = _ripple_continuations([(means, fit_g, noise) for _, means, fit_g, noise, _ in cruises])
    for (k, means, fit_g, noise_W, tail_s), fitted in zip(cruises, fits, strict=True):
        if fitted is None:
            continue  # no ripple to carry on, or under two cycles of it: no telling
        carried, fit_rms_W = fitted
        off = means[fit_g:] - carried
        tail_rms_W = float(np.sqrt(np.einsum("i,i->", off, off) / off.size))
        if tail_rms_W > params.hidden_stop_ratio * max(fit_rms_W, noise_W):
            doubts[k] = (
                f"{name_of('cruise', spans[k][3])} ends off its own ripple: over its last "
                f"{tail_s:.2f} s power is {tail_rms_W:.3g} W rms off the ripple fitted "
                f"before ({fit_rms_W:.3g} W there): a stop the ripple hid?"
            )
    # the idles after a step, past the 50 ms a boundary may be off: the running mean above
    # the idle's median from there on, in sd of that mean, all idles in one pass
    idles = [
        (k, a, b)
        for k, (a, b, name, step) in enumerate(spans)
        if name == "idle"
        and step >= 1
        and b - a >= 4 * guard
        and not (ends_moving and k == len(spans) - 1)
    ]
    # a running mean stands `min_excess_W` above the level only where some mean does:
    # where none does (noise of a few sd under 0.25 W, as a rule), nothing to test
    windows = [(a + guard, b - guard) for _, a, b in idles]
    levels_W = [idle_median_W[k] for k, _, _ in idles]
    # (a bound only for a bar of 0 sd or more: under it, an idle at its level is doubted)
    if (
        idles
        and params.hidden_stop_z >= 0
        and not _stands_above(y10, windows, levels_W, params.min_excess_W)
    ):
        idles = []
    if idles:
        # its last 50 ms left out too: the next step's start may be labelled that late
        lengths = np.array([b - a - 2 * guard for _, a, b in idles])
        starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
        levels = np.array([idle_median_W[k] for k, _, _ in idles])
        excess = np.concatenate([y10[a + guard : b - guard] for _, a, b in idles])
        excess -= np.repeat(levels, lengths)
        running = np.cumsum(excess)
        before = np.concatenate(([0.0], running[starts[1:] - 1]))
        running -= np.repeat(before, lengths)
        count = np.arange(1, running.size + 1, dtype=np.float64)
        count -= np.repeat(starts.astype(np.float64), lengths)
        z = running / (sigma10 * np.sqrt(count) + 1e-12)
        # and by at least `min_excess_W` (what the segmenter calls the drive on, "motion"):
        # the sd of a long mean is sigma10 / sqrt(n) under white noise only, and fieldgen's
        # 1/f noise of 0.05 W stood idles 0.075-0.13 W above their median at z > 6 (5 of 24
        # null batches unexplained through the runs it left out; found by validation)
        z = np.where(running >= params.min_excess_W * count, z, 0.0)
        for j in np.flatnonzero(np.maximum.reduceat(z, starts) > params.hidden_stop_z):
            k, a, _ = idles[j]
            i = int(starts[j]) + int(np.argmax(z[starts[j] : starts[j] + lengths[j]]))
            doubts[k] = (
                f"{name_of('idle', spans[k][3])} stands {running[i] / count[i]:.3g} W above "
                f"its own level from {when(a):.3f} s for "
                f"{(count[i] + guard) * dt_ms / 1000.0:.2f} s: the drive still on, a stop "
                "labelled idle?"
            )
    return [doubts[k] for k in sorted(doubts)]


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


def _stands_above(
    y10: np.ndarray, windows: list[tuple[int, int]], levels_W: list[float], excess_W: float
) -> bool:
    """Whether any value of `y10` in the windows [a, b) (in order, apart, not empty)
    stands `excess_W` or more above its window's level, less 1e-6 W (a margin far above
    the rounding of the running sums this stands in for): each window's maximum by one
    `reduceat` over the windows' edges."""
    edges = [edge for window in windows for edge in window]
    if edges[-1] >= y10.size:
        edges.pop()
    tops = np.maximum.reduceat(y10, edges)[::2].tolist()
    return max(top - level for top, level in zip(tops, levels_W, strict=True)) >= excess_W - 1e-6


def _wavy_means(values: np.ndarray, sigma10: float) -> bool:
    """Whether 10 ms means wander around their trend line more than noise (rms off it
    above max(3 sd, 0.1 W)): `_wavy`'s test."""
    slope, intercept = _line(values)
    residual = values - (intercept + slope * np.arange(values.size, dtype=np.float64))
    return _std(residual) > max(3.0 * sigma10, 0.1)


def _ripple_continuation(
    values: np.ndarray, fit_n: int, noise_W: float
) -> tuple[np.ndarray, float] | None:
    """`_ripple_continuations` of one window."""
    return _ripple_continuations([(values, fit_n, noise_W)])[0]


def _ripple_continuations(
    windows: list[tuple[np.ndarray, int, float]],
) -> list[tuple[np.ndarray, float] | None]:
    """For each window (values, fit_n, noise_W): a line plus the ripple's sinusoid fitted
    (least squares) to `values[:fit_n]`, carried on over `values[fit_n:]` (returned), and
    the rms of the fit's residual. None when the
    fitted part holds under `_RIPPLE_CYCLES` cycles of it (a fraction of a cycle fits, but
    does not carry on: on the default grid's 1 m steps at 0.7 m/s, 0.75 of a cycle carried
    on 0.3 s was 4 times its fit's rms off with no stop), over a quarter of a cycle per
    value (a sinusoid near the values' Nyquist frequency is noise's), or when the
    sinusoid's rms is not above max(3 `noise_W`, 0.1 W), `_wavy`'s bar: no ripple to carry
    on (a noisy cruise at 0.9 m/s, 1.5 W, had an alternating "ripple" fitted to its noise
    whose continuation stood 2.4 noise sd off).

    The frequency w0: the strongest peak of the periodogram of the detrended values
    (zero-padded to 4x or more, a power of two: `_fft_length`; the peak interpolated by
    a parabola). The fit is linear in the
    columns 1, u, sin w0 u, cos w0 u, u sin w0 u, u cos w0 u (u: the time centred and
    scaled to [-1/2, 1/2) over the fitted part): the last two are the first-order terms
    of a frequency a little off w0, a sin((w0 + d) u) + b cos((w0 + d) u) ~ ... +
    d u (a cos w0 u - b sin w0 u), so d is read off their coefficients c = -b d, e = a d
    (least squares) and the line and the sinusoid at w0 + d are carried on, its amplitude
    held (the first-order terms themselves grow with u). One 6 x 6 solve per window;
    normal equations by `einsum`: no BLAS threads (see changepoint.block_means).

    The windows are the rows of padded arrays (each padded past its window with zeros,
    which the periodogram and the normal equations ignore; the periodogram zero-padded to
    a power of two, 4x the longest window or more). A step's cost is numpy's per call, not
    its few hundred means: ten windows of 256 means cost 0.2-0.4 ms at once against
    0.5-0.8 ms one by one; one window costs 125-150 us as a row (a one-window copy of this
    function, 50-70 us, was dropped in review: the same fit written twice, kept equal by a
    test; it runs only for a wavy cruise with no stop found).
    """
    if not windows:
        return []
    rows = len(windows)
    fit_n = np.array([w[1] for w in windows])
    tail_n = np.array([w[0].size - w[1] for w in windows])
    width, tail_width = int(fit_n.max()), max(1, int(tail_n.max()))
    fit = np.zeros((rows, width))
    for i, (values, n, _) in enumerate(windows):
        fit[i, :n] = values[:n]
    columns = np.arange(width, dtype=np.float64)
    inside = columns[None, :] < fit_n[:, None]
    centre = (fit_n[:, None] - 1) / 2.0
    x = np.where(inside, columns[None, :] - centre, 0.0)  # centred, 0 past each window
    mean_W = fit.sum(axis=1) / fit_n
    s_xx = fit_n * (fit_n * fit_n - 1) / 12.0
    slope = np.einsum("ij,ij->i", x, fit) / s_xx
    detrended = np.where(inside, fit - mean_W[:, None] - slope[:, None] * x, 0.0)
    noise_W = np.array([w[2] for w in windows])
    bar_W = np.maximum(3.0 * noise_W, 0.1)
    scattered = np.einsum("ij,ij->i", detrended, detrended) / fit_n > bar_W * bar_W
    if not scattered.any():  # no ripple in any (as `_ripple_continuation`)
        return [None] * rows
    pad = _fft_length(4 * width)
    spectrum = np.abs(np.fft.rfft(detrended, pad, axis=1))
    spectrum[:, 0] = 0.0
    peak = spectrum.argmax(axis=1)
    at = np.arange(rows)
    inner = (peak >= 1) & (peak < spectrum.shape[1] - 1)
    left = spectrum[at, np.maximum(peak - 1, 0)]
    mid = spectrum[at, peak]
    right = spectrum[at, np.minimum(peak + 1, spectrum.shape[1] - 1)]
    curve = left - 2.0 * mid + right
    shift = np.where(
        inner & (curve < 0), 0.5 * (left - right) / np.where(curve < 0, curve, -1.0), 0.0
    )
    cycles = (peak + shift) * fit_n / pad  # in each fitted part
    valid = scattered & (cycles >= _RIPPLE_CYCLES) & (cycles <= fit_n / 4.0)
    u = x / fit_n[:, None]
    omega = 2.0 * np.pi * cycles
    design = np.empty((rows, 6, width))
    design[:, 0] = inside
    design[:, 1] = u
    angle = omega[:, None] * u
    np.sin(angle, out=design[:, 2])
    np.cos(angle, out=design[:, 3])
    design[:, 2:4] *= inside[:, None, :]
    np.multiply(u[:, None, :], design[:, 2:4], out=design[:, 4:6])
    gram = np.einsum("sij,skj->sik", design, design)
    gram[~valid] = np.eye(6)  # not solved for: no ripple there
    rhs = np.einsum("sij,sj->si", design, fit)
    try:
        coef = np.linalg.solve(gram, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:  # a degenerate window: each solved alone, it left out
        coef = np.full((rows, 6), np.nan)
        for i in range(rows):
            try:
                coef[i] = np.linalg.solve(gram[i], rhs[i])
            except np.linalg.LinAlgError:
                valid[i] = False
    resid = fit - np.einsum("si,sij->sj", coef, design)
    rms_W = np.sqrt(np.einsum("ij,ij->i", resid, resid) / fit_n)
    a_W, b_W, c_W, e_W = coef[:, 2], coef[:, 3], coef[:, 4], coef[:, 5]
    amplitude2 = a_W * a_W + b_W * b_W
    valid &= np.sqrt(amplitude2 / 2.0) > bar_W
    omega += (a_W * e_W - b_W * c_W) / np.where(valid, amplitude2, 1.0)
    u_tail = (np.arange(tail_width, dtype=np.float64)[None, :] + fit_n[:, None] - centre) / fit_n[
        :, None
    ]
    angle = omega[:, None] * u_tail
    carried = (
        coef[:, 0:1]
        + coef[:, 1:2] * u_tail
        + a_W[:, None] * np.sin(angle)
        + b_W[:, None] * np.cos(angle)
    )
    return [(carried[i, : tail_n[i]], float(rms_W[i])) if valid[i] else None for i in range(rows)]


def _fft_length(n: int) -> int:
    """The power of two at or above `n`: the periodogram's zero-padded length. A few
    lengths, each planned once by numpy's FFT (its plans are cached; a new length per
    cruise was planned per call, which cost more than the transform)."""
    return 1 << max(0, n - 1).bit_length()


#: the fewest cycles of the ripple the fitted part must hold (`_ripple_continuation`), and
#: the most means it is fitted on (`_hidden_stop_doubts` averages longer cruises to these)
_RIPPLE_CYCLES = 2.0
_RIPPLE_POINTS = 256


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


def _coarse_motion(
    y: np.ndarray,
    y10: np.ndarray,
    group: int,
    sigma10: float,
    block_dt: float,
    steps: int,
    params: MotionParams,
) -> list[tuple[int, int]]:
    """Motion stretches [a, b) in block indices: 10 ms means above idle, N of them (`y10`:
    means of `group` blocks, noise sd `sigma10`)."""
    probe = max(3, round(params.idle_probe_s / (group * block_dt)))
    probe = min(probe, max(3, y10.size // 10))
    idle_W = min(float(median(y10[:probe])), float(median(y10[-probe:])))
    threshold = idle_W + max(params.motion_z * sigma10, params.min_excess_W)
    above = np.concatenate(([False], y10 > threshold, [False]))
    edges = np.flatnonzero(np.diff(above.astype(np.int8)))
    stretches = [(int(s), int(e)) for s, e in zip(edges[::2], edges[1::2], strict=True)]
    min_len = max(1, round(params.min_motion_s / (group * block_dt)))
    stretches = [(s, e) for s, e in stretches if e - s >= min_len]
    # a gap where power sits at idle (rms off idle within noise) is idle between steps; a
    # gap where it wanders below the threshold without settling is a dip of the cruise
    idle_rms = max(params.idle_rms_z * sigma10, params.idle_rms_min_W)

    def settles(gap: tuple[int, int]) -> bool:
        values = y10[gap[0] : gap[1]]
        return bool(np.sqrt(np.mean((values - idle_W) ** 2)) < idle_rms)

    while len(stretches) > steps:
        gaps = [(stretches[k][1], stretches[k + 1][0]) for k in range(len(stretches) - 1)]
        dips = [k for k, gap in enumerate(gaps) if not settles(gap)]
        if not dips:  # every gap is idle: the metadata's step count is off
            break
        k = min(dips, key=lambda j: gaps[j][1] - gaps[j][0])
        stretches[k : k + 2] = [(stretches[k][0], stretches[k + 1][1])]
    return [(s * group, min(e * group, y.size)) for s, e in stretches]


#: a split a step's search asks for: (lo, hi, deg_left, deg_right, min_len, jump_sign), the
#: arguments of `best_split`
_SplitAsked = tuple[int, int, int, int, int, int]
#: a step's search (`_locate_step`): yields the splits it needs, one at a time, is sent each
#: one's `best_split`, and returns the step
_StepSearch = Generator[_SplitAsked, Split | None, _Step]


def _locate_steps(
    y: np.ndarray,
    block_dt: float,
    sigma_b: float,
    coarse: list[tuple[int, int]],
    params: MotionParams,
    assumed_ends: list[int] | None = None,
) -> list[_Step]:
    """Fine boundaries of every step (`_locate_step`), the steps searched side by side.

    A step's search needs the end of the step before it only where its idle window starts
    (`_idle_window_start`: 0.5 s before its coarse start, unless the step before ends
    later). Every step is first searched with an assumed end of the step before in its
    place (`assumed_ends`, of every step but the last; by default their coarse ends), all
    at once (`_drive`); then, in order, a step whose window start the step before's found
    end changes is searched again on its own. The steps are therefore those of a search
    step after step, whatever was assumed, and the short windows of ten steps are split
    for little more than one step's (numpy's overhead per call, not the window, is most of
    a short split's time).
    """
    n_blocks = y.size
    next_starts = [a for a, _ in coarse[1:]] + [n_blocks]
    assumed = [0] + (assumed_ends or [b for _, b in coarse[:-1]])  # the first: none before

    def search(i: int, prev_end: int) -> _StepSearch:
        a, b = coarse[i]
        return _locate_step(y, block_dt, sigma_b, a, b, prev_end, next_starts[i], params)

    steps = _drive(y, [search(i, prev_end) for i, prev_end in enumerate(assumed)])
    for i in range(1, len(steps)):
        a = coarse[i][0]
        found = _idle_window_start(a, steps[i - 1].t3, block_dt, params)
        if found != _idle_window_start(a, assumed[i], block_dt, params):
            steps[i] = _drive(y, [search(i, steps[i - 1].t3)])[0]
    return steps


def _drive(y: np.ndarray, searches: list[_StepSearch]) -> list[_Step]:
    """Run step searches side by side: at each round, the splits they ask for of one kind
    (degrees and jump sign) are found by one `best_splits` call."""
    found: list[_Step | None] = [None] * len(searches)
    asked: dict[int, _SplitAsked] = {}

    def advance(i: int, split: Split | None, first: bool = False) -> None:
        try:
            asked[i] = next(searches[i]) if first else searches[i].send(split)
        except StopIteration as done:
            found[i] = done.value

    for i in range(len(searches)):
        advance(i, None, first=True)
    while asked:
        kinds: dict[tuple[int, int, int], list[int]] = {}
        for i, (_, _, deg_left, deg_right, _, sign) in asked.items():
            kinds.setdefault((deg_left, deg_right, sign), []).append(i)
        answers: dict[int, Split | None] = {}
        for (deg_left, deg_right, sign), who in kinds.items():
            windows = [(asked[i][0], asked[i][1], asked[i][4]) for i in who]
            splits = best_splits(y, windows, deg_left, deg_right, 5, sign)
            answers.update(zip(who, splits, strict=True))
        asked.clear()
        for i, split in answers.items():
            advance(i, split)
    return [step for step in found if step is not None]


def _idle_window_start(a: int, prev_end: int, block_dt: float, params: MotionParams) -> int:
    """First block of the idle stretch a step's acceleration start is fitted from: up to
    `idle_probe_s` before its coarse start `a`, after the step before ends."""
    return max(prev_end + 1, a - max(1, round(params.idle_probe_s / block_dt)))


def _locate_step(
    y: np.ndarray,
    block_dt: float,
    sigma_b: float,
    a: int,
    b: int,
    prev_end: int,
    next_start: int,
    params: MotionParams,
) -> _StepSearch:
    """Fine boundaries of one step whose motion was coarsely found in [a, b): a search that
    yields each split it needs (`_locate_steps` runs it)."""

    def blocks(seconds: float) -> int:
        return max(1, round(seconds / block_dt))

    refine = blocks(params.refine_s)
    min_len = max(5, blocks(0.005))
    # 2a. acceleration start: flat idle, then the drive-on step and the ramp (a line)
    lo = _idle_window_start(a, prev_end, block_dt, params)
    split = yield (lo, min(a + blocks(0.04), b), 0, 1, min_len, 1)
    t0 = split.index if split else a
    # 3a. acceleration end, coarse: the first clear drop of the jump statistic (its lines
    # start after t0, clear of the step at the start)
    w = blocks(params.jump_half_width_s)
    first = t0 + max(blocks(params.min_accel_s), w + 2)
    last = min(t0 + blocks(params.max_accel_s), b - min_len)
    t1c = None
    if last > first:
        lo_j = max(0, first - w)
        hi_j = min(y.size, last + w)
        jump = jump_statistic_W(y[lo_j:hi_j], w)[first - lo_j : last - lo_j + 1]
        if np.isfinite(jump).any():
            threshold = params.jump_z * jump_sd_factor(w) * sigma_b
            found = _first_strong_drop(y, t0, first, jump, threshold, w, blocks(0.1))
            t1c = None if found is None else first + found
    # 2b. acceleration start again, the line fitted on more of the ramp (up to
    # `accel_probe_s`, clear of the end of acceleration)
    hi = min(t0 + blocks(params.accel_probe_s), (t1c if t1c else b) - min_len, b)
    if hi > t0 + 4 * min_len:
        split = yield (lo, hi, 0, 1, min_len, 1)
        t0 = split.index if split else t0
    # 3b. acceleration end, fine: a quadratic ramp (with any transient) then a quadratic
    # cruise (with any ripple); without a clear drop (a ripple can cancel it at low speed)
    # the split of a ramp line from a smooth cruise over the first `kink_probe_s`
    if t1c is not None:
        split = yield (max(t0 + min_len, t1c - refine), min(t1c + refine, b), 2, 2, min_len, -1)
        t1 = split.index if split else t1c
    else:
        split = yield (t0 + 1, min(t0 + blocks(params.kink_probe_s), b), 1, 2, min_len, 0)
        t1 = split.index if split else min(t0 + blocks(params.min_accel_s), b - 1)
    t1 = max(t1, t0 + 1)
    # 4. motion end: a quadratic piece (cruise or stop), then flat idle
    lo = max(t1 + blocks(0.05), b - blocks(params.end_back_s))
    hi = min(next_start - blocks(0.05), b + blocks(params.end_forward_s), y.size)
    # power drops to idle at the end, unless a wavy cruise (ripple) happens to be low there
    wavy = wavy_at_first = _wavy(y, sigma_b, t1, b, blocks(0.01))
    split = yield (lo, hi, 3 if wavy else 2, 0, min_len, 0 if wavy else -1)
    t3 = split.index if split else b
    t3 = max(t3, t1 + 1)
    # 5. a stop phase, when the data shows one. A long stop, or a lower level, at the end
    # of a steady cruise makes [t1, b) wavy too: the ripple's search is for a cruise that
    # is wavy before its stop
    if wavy:
        lo = max(t1 + min_len, t3 - blocks(params.max_decel_s) - blocks(params.decel_cruise_s))
        split = yield (lo, t3, 0, 1, min_len, -1)
        group = blocks(0.01)
        if split and split.index - t1 >= 20 * group:
            wavy = _wavy(y, sigma_b, t1, split.index, group)
    t2 = yield from _decel_start(y, sigma_b, t1, t3, wavy, blocks, params, min_len)
    if t2 < t3:
        # the stop phase found, its end is re-fitted as a falling line then flat idle (the
        # quadratic of step 4 straddled the drop at t2), then its start once more
        longest = params.max_decel_wavy_s if wavy else params.max_decel_s
        stop = min(max(t3, t2 + blocks(longest)) + refine, hi)
        # over the end of the stop only: a line through a whole decay (an exponential
        # stop) would put the end where the decay flattens, seconds early
        start = max(t2 + min_len, t3 - blocks(params.end_back_s))
        split = yield (start, stop, 1, 0, min_len, -1)
        t3 = split.index if split else t3
        t2 = yield from _decel_start(y, sigma_b, t1, t3, wavy, blocks, params, min_len)
    return _Step(t0=t0, t1=t1, t2=t2, t3=t3, wavy=wavy_at_first)


def _first_strong_drop(
    y: np.ndarray,
    t0: int,
    first: int,
    jump_W: np.ndarray,
    threshold_W: float,
    separation: int,
    rise_window: int,
) -> int | None:
    """Index (into `jump_W`) of the drop that ends the acceleration, None without a clear one.

    Among the clear drops at least half the strongest, the first one after clearly rising
    power (the ramp: slope above 2 sd over up to 0.1 s), else the first: the end of cruise,
    or the end of a start transient, can drop further than the end of a short acceleration
    at low speed.
    """
    drops = peaks(-jump_W, threshold_W, separation)
    if drops.size == 0:
        return None
    sizes = -jump_W[drops]
    strong = drops[sizes >= 0.5 * sizes.max()]
    for k in strong:
        # over up to `rise_window` blocks after t0; the blocks just before the drop may
        # straddle it, so they are left out
        before = y[max(t0 + 2, first + k - rise_window) : first + k - 2]
        if before.size >= 5:
            slope, intercept = _line(before)
            x = np.arange(before.size, dtype=np.float64)
            resid = before - (intercept + slope * x)
            s_xx = before.size * (before.size**2 - 1) / 12.0
            slope_sd = _std(resid) / np.sqrt(s_xx)
            if slope > 2.0 * slope_sd:
                return int(k)
    return int(strong[0])


def _decel_start(
    y: np.ndarray,
    sigma_b: float,
    t1: int,
    t3: int,
    wavy: bool,
    blocks: Callable[[float], int],
    params: MotionParams,
    min_len: int,
) -> Generator[_SplitAsked, Split | None, int]:
    """Start of the stop phase before `t3`, or `t3` when the data shows none (a search, as
    `_locate_step`, which yields from it).

    After a steady cruise a candidate (`_decel_candidate`) is kept unless its power is
    seen not to fall from its start (`_falls_from_start`): a stop's power falls towards
    idle through the phase, a second, lower speed level is flat first. Such a level may
    end with a stop of its own, so the search is repeated after the level's start (a few
    times at most). After a wavy cruise the ripple runs on through the stop and hides its
    shape: the candidate stands (and is looked for over `max_decel_wavy_s` only).
    """
    floor = 0
    for _ in range(3):
        t2 = yield from _decel_candidate(y, sigma_b, t1, t3, floor, wavy, blocks, params, min_len)
        if t2 >= t3 or wavy or _falls_from_start(y, sigma_b, t2, t3, blocks, params):
            return t2
        floor = t2 + 2  # clear of the drop into the level (it may straddle a block)
    return t3


def _falls_from_start(
    y: np.ndarray,
    sigma_b: float,
    t2: int,
    t3: int,
    blocks: Callable[[float], int],
    params: MotionParams,
) -> bool:
    """Whether the power of [t2, t3) may be a stop's, falling from its start, rather than
    a second, lower speed level's, flat first (docs/segmentation.md, "Stop or level").

    The means m1, m2, m3 of the phase's first, middle and last thirds (1 ms blocks): a
    stop's power is monotone non-increasing towards idle with a non-increasing steepness
    (linear, causes.md's form: m1 - m2 = m2 - m3; a decay such as an exponential:
    m1 - m2 > m2 - m3). A level is flat (m1 = m2 = m3), or flat and then its own stop
    (m1 - m2 = 0 < m2 - m3). The candidate is not a stop when, by more than
    `decel_shape_z` sd of the difference,

    - m1 - m3 is below `decel_fall_fraction` of m1's height above idle (a stop of the
      paper's robot falls by 0.18-0.35 of it between its thirds down to 0.05 m/s, the drive's
      0.6 W being the part that does not fall), or
    - m1 - m2 is below half of m2 - m3 (half: the midpoint between a line, 1, and a flat
      first third, 0; it leaves room for a stop whose fall starts gently).

    The sd is that of the white noise of the blocks (`sigma_b` / sqrt(length) per mean):
    where noise hides the shape (a short stop, a noisy trace) nothing is dropped, and the
    drop into the phase and its end near idle decide as before.
    """
    n = t3 - t2
    k = n // 3
    if k < max(3, blocks(0.01)):
        return True  # too short to tell: the drop into it and its end near idle decide
    idle_W = float(median(y[t3 : min(y.size, t3 + blocks(0.3))]))
    m1 = _mean(y[t2 : t2 + k])
    m2 = _mean(y[t2 + k : t3 - k])
    m3 = _mean(y[t3 - k : t3])
    z = params.decel_shape_z
    k2 = n - 2 * k
    fall_sd_W = sigma_b * np.sqrt(2.0 / k)
    early_sd_W = sigma_b * np.sqrt(1.25 / k + 2.25 / k2)  # of m1 - 1.5 m2 + 0.5 m3
    falls = (m1 - m3) - params.decel_fall_fraction * (m1 - idle_W) > -z * fall_sd_W
    early = (m1 - m2) - 0.5 * (m2 - m3) > -z * early_sd_W
    return bool(falls and early)


def _decel_candidate(
    y: np.ndarray,
    sigma_b: float,
    t1: int,
    t3: int,
    floor: int,
    wavy: bool,
    blocks: Callable[[float], int],
    params: MotionParams,
    min_len: int,
) -> Generator[_SplitAsked, Split | None, int]:
    """A stop phase's start before `t3` (its window from `floor` on), or `t3` (a search, as
    `_decel_start`, which yields from it).

    A steady cruise: the least-squares split of [.., t3) into a flat cruise and a falling
    line (the onset is a drop: the drive stops pushing), its drop tested against its own
    sd, sigma sqrt(1/n_cruise + 4/n_stop). A wavy cruise (a ripple): the strongest drop of
    the jump statistic at the fine scales (local lines, which a slow ripple does not bend),
    then a split of a quadratic cruise from a falling line around it. Either way the stop
    phase is kept only when the line falls and ends closer to idle than
    `decel_end_fraction` of the cruise power above idle, and lasts `min_decel_s`.
    """
    refine = blocks(params.refine_s)
    if not wavy:
        lo = max(
            t1 + min_len, floor, t3 - blocks(params.max_decel_s) - blocks(params.decel_cruise_s)
        )
        split = yield (lo, t3, 0, 1, min_len, -1)
        if split is None:
            return t3
        t2 = split.index
        drop_sd = sigma_b * np.sqrt(1.0 / (t2 - lo) + 4.0 / (t3 - t2))
        if -split.jump_W < params.decel_split_z * drop_sd:
            return t3
    else:
        best: tuple[float, int] | None = None  # (drop in sd, block) over the scales
        for half_width_s in params.decel_half_widths_s:
            w = blocks(half_width_s)
            first = max(t1 + w + 2 + blocks(0.02), t3 - blocks(params.max_decel_wavy_s))
            last = t3 - max(blocks(params.min_decel_s), w)
            if last <= first:
                continue
            jump = jump_statistic_W(y[first - w : last + w], w)[w : last - first + w + 1]
            if not np.isfinite(jump).any():
                continue
            i = int(np.nanargmin(jump))
            score = -float(jump[i]) / (jump_sd_factor(w) * sigma_b + 1e-12)
            if best is None or score > best[0]:
                best = (score, first + i)
        if best is None or best[0] < params.decel_z:
            return t3
        k = best[1]
        split = yield (max(t1 + min_len, k - refine), min(k + refine, t3), 2, 1, min_len, 0)
        t2 = split.index if split else k
    if t3 - t2 < blocks(params.min_decel_s):
        return t3
    idle_W = float(median(y[t3 : min(y.size, t3 + blocks(0.3))]))
    slope, intercept = _line(y[t2:t3])
    end_W = intercept + slope * (t3 - t2 - 0.5)
    # the mean over the whole cruise: a ripple averages out of it
    cruise_W = _mean(y[t1 + 2 : t2 - 1]) if t2 - t1 > 4 else float(y[t2 - 1])
    # after a wavy cruise the line over a short stop phase has the ripple's slope (a 1 W
    # ripple at 0.25 Hz rises 0.5 W over 0.3 s, the stop at 0.1 m/s falls 0.3 W): there
    # the clear drop that starts it and its end near idle must do
    falls = slope < 0 or wavy
    if falls and (end_W - idle_W) < params.decel_end_fraction * (cruise_W - idle_W):
        return t2
    return t3


def _wavy(y: np.ndarray, sigma_b: float, t1: int, t3: int, group: int) -> bool:
    """Whether power between t1 and t3 wanders around its trend line more than noise (10 ms
    means off a straight line by more than max(3 sd of noise, 0.1 W) rms)."""
    means = block_means(y[t1 + 2 : t3 - 2], group)
    if means.size < 10:
        return False
    slope, intercept = _line(means)
    residual = means - (intercept + slope * np.arange(means.size, dtype=np.float64))
    return _std(residual) > max(3.0 * sigma_b / np.sqrt(group), 0.1)


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


#: A start-up spike holds at least this fraction of its acceleration's energy: an inrush
#: or breakaway worth reporting changes the phase's energy by more than the 1% that the
#: per-run energies are compared at (the simulator's start_transient: 20-40%).
SPIKE_MIN_FRACTION = 0.01


def _start_spikes(
    run: Run, y: np.ndarray, block: int, sigma_b: float, steps: list[_Step]
) -> list[Spike]:
    """Start-up transients: the first blocks of an acceleration that stand out above the
    line fitted to the rest of that acceleration."""
    spikes = []
    dt = run.sample_period_s
    for st in steps:
        seg = y[st.t0 : st.t1]
        if seg.size < 20:
            continue
        tail = seg[seg.size // 2 :]
        x = np.arange(seg.size, dtype=np.float64)
        slope, tail_intercept = _line(tail)
        intercept = tail_intercept - slope * (seg.size // 2)  # the line at x = 0
        excess = seg - (intercept + slope * x)
        # a spike starts at the first block: where that block stands within 6 sd of noise
        # (+ 0.5 W) of the line, it stands within the bar below whatever the tail's scatter
        # (the bar is at least that), so the tail's median is not taken (most steps)
        if not excess[0] > 6.0 * sigma_b + 0.5:
            continue
        # above the tail's own scatter, not only the analyser's: a ripple during the ramp
        # (sample_logs: 1 W) bends it, and a hump of the ripple at its start was taken for
        # a spike of 0.27 s (drawn in red on the README's trace figure)
        tail_scatter_W = 1.4826 * float(median(np.abs(excess[seg.size // 2 :])))
        out = excess > 6.0 * max(sigma_b, tail_scatter_W) + 0.5
        if not out[0]:
            continue
        n_out = int(np.argmin(out)) if not out.all() else out.size
        i0, i1 = st.t0 * block, (st.t0 + n_out) * block
        above_J = float(np.sum(excess[:n_out]) * block * dt)
        if above_J < SPIKE_MIN_FRACTION * float(np.sum(seg)) * block * dt:
            # a step of a fraction of a watt where the ramp starts (sample_logs: 0.01 J of a
            # 15 J acceleration) is no inrush: reported, it was drawn as a start-up spike
            continue
        spikes.append(
            Spike(
                t_start_s=_time_at(run, i0),
                duration_s=(i1 - i0) * dt,
                peak_W=float(run.power_W[i0:i1].max()),
                energy_above_level_J=above_J,
            )
        )
    return spikes


# -- shared --------------------------------------------------------------------------------


def _time_at(run: Run, index: int) -> float:
    """Start time of sample `index`; the end of the run for index == samples."""
    if index < run.samples:
        return run.time_at(index)
    return run.time_at(-1) + run.sample_period_s


def _phases(run: Run, pieces: list[tuple[int, str, int, int, float | None]]) -> list[Phase]:
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
            )
        )
    return phases


__all__ = ["MotionParams", "SpeedParams", "segment_file", "segment_run"]
