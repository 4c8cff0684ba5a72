"""The stop phase of a motion run's steps (stage 5 of the step search, after the motion end
t3 was found): its start t2, kept only when the data shows one (causes.md `decel_phase`;
the paper's Eq. 6 has none), and then the motion end refitted from it. Like the stages of
`wifibot_power.segment.steps`, each stage here runs over all steps at once, one batched
split per stage (`_splits`)."""

from __future__ import annotations

import numpy as np

from wifibot_power.changepoint import jump_sd_factor, jump_statistic_W, median
from wifibot_power.segment.common import _line, _mean, _wavy
from wifibot_power.segment.search import _Search, _SplitAsked, _splits, _Trace


def _find_stops(trace: _Trace, searches: list[_Search]) -> None:
    """Stage 5: the stop phase of each step, when the data shows one (t2 = t3 when not).

    A long stop, or a lower level, at the end of a steady cruise makes [t1, b) wavy too:
    the ripple's search is for a cruise that is wavy before its stop, so a wavy cruise is
    judged again before the best split into a flat cruise and a falling line. Once a stop
    is found, its end is refitted as a falling line then flat idle (the quadratic piece of
    the motion end straddled the drop at t2), and its start searched once more.
    """
    _recheck_wavy(trace, [s for s in searches if s.wavy])
    _find_stop_starts(trace, searches)
    stopping = [s for s in searches if s.t2 < s.t3]
    _refit_motion_ends(trace, stopping)
    _find_stop_starts(trace, stopping)


def _recheck_wavy(trace: _Trace, searches: list[_Search]) -> None:
    """Whether each wavy cruise is still wavy before the best split of its end into a
    flat cruise and a falling line (a stop, or a lower level, made it look wavy)."""
    group = trace.blocks(0.01)
    params, min_len = trace.params, trace.min_len
    asked: list[_SplitAsked | None] = []
    for s in searches:
        back = trace.blocks(params.max_decel_s) + trace.blocks(params.decel_cruise_s)
        asked.append((max(s.t1 + min_len, s.t3 - back), s.t3, 0, 1, min_len, -1))
    for s, split in zip(searches, _splits(trace.y, asked), strict=True):
        if split and split.index - s.t1 >= 20 * group:
            s.wavy = _wavy(trace.y, trace.sigma_b, s.t1, split.index, group)


def _refit_motion_ends(trace: _Trace, searches: list[_Search]) -> None:
    """A step's motion end once its stop phase is found: a falling line then flat idle,
    over the end of the stop only (a line through a whole decay, an exponential stop,
    would put the end where the decay flattens, seconds early)."""
    params, min_len = trace.params, trace.min_len
    asked: list[_SplitAsked | None] = []
    for s in searches:
        longest = params.max_decel_wavy_s if s.wavy else params.max_decel_s
        stop = min(max(s.t3, s.t2 + trace.blocks(longest)) + trace.refine, s.end_hi)
        start = max(s.t2 + min_len, s.t3 - trace.blocks(params.end_back_s))
        asked.append((start, stop, 1, 0, min_len, -1))
    for s, split in zip(searches, _splits(trace.y, asked), strict=True):
        s.t3 = split.index if split else s.t3


def _find_stop_starts(trace: _Trace, searches: list[_Search]) -> None:
    """The start t2 of each step's stop phase before its t3, or t3 when the data shows none.

    After a steady cruise a candidate (`_stop_candidates`) is kept unless its power is
    seen not to fall from its start (`_falls_from_start`): a stop's power falls towards
    idle through the phase, a second, lower speed level is flat first. Such a level may
    end with a stop of its own, so the search is repeated after the level's start (a few
    times at most). After a wavy cruise the ripple runs on through the stop and hides its
    shape: the candidate stands (and is looked for over `max_decel_wavy_s` only).
    """
    floors = dict.fromkeys(range(len(searches)), 0)  # the window's start, by search
    for _ in range(3):
        pending = list(floors)
        candidates = _stop_candidates(trace, [searches[i] for i in pending], list(floors.values()))
        for i, t2 in zip(pending, candidates, strict=True):
            s = searches[i]
            if t2 >= s.t3 or s.wavy or _falls_from_start(trace, t2, s.t3):
                s.t2 = t2
                del floors[i]
            else:
                floors[i] = t2 + 2  # clear of the drop into the level (it may straddle a block)
    for i in floors:
        searches[i].t2 = searches[i].t3


def _stop_candidates(trace: _Trace, searches: list[_Search], floors: list[int]) -> list[int]:
    """A stop phase's start before each search's t3 (its window from its floor on), or t3.

    A steady cruise: the least-squares split of [.., t3) into a flat cruise and a falling
    line (the onset is a drop: the drive stops pushing), its drop tested against its own
    sd, sigma sqrt(1/n_cruise + 4/n_stop). A wavy cruise (a ripple): the strongest drop of
    the jump statistic at the fine scales (`_strongest_drop`), then a split of a quadratic
    cruise from a falling line around it. Either way the stop phase is kept only where
    `_kept_stop` says so.
    """
    params, min_len, refine = trace.params, trace.min_len, trace.refine
    asked: list[_SplitAsked | None] = []
    drops: list[int | None] = []  # a wavy cruise's strongest drop
    for s, floor in zip(searches, floors, strict=True):
        if not s.wavy:
            back = trace.blocks(params.max_decel_s) + trace.blocks(params.decel_cruise_s)
            asked.append((max(s.t1 + min_len, floor, s.t3 - back), s.t3, 0, 1, min_len, -1))
            drops.append(None)
            continue
        k = _strongest_drop(trace, s)
        drops.append(k)
        lo = max(s.t1 + min_len, k - refine) if k is not None else 0
        asked.append(None if k is None else (lo, min(k + refine, s.t3), 2, 1, min_len, 0))
    found = []
    for s, ask, k, split in zip(searches, asked, drops, _splits(trace.y, asked), strict=True):
        if ask is None:
            found.append(s.t3)
        elif k is not None:
            found.append(_kept_stop(trace, s, split.index if split else k))
        elif split is None:
            found.append(s.t3)
        else:
            t2 = split.index
            drop_sd = trace.sigma_b * np.sqrt(1.0 / (t2 - ask[0]) + 4.0 / (s.t3 - t2))
            unclear = -split.jump_W < params.decel_split_z * drop_sd
            found.append(s.t3 if unclear else _kept_stop(trace, s, t2))
    return found


def _strongest_drop(trace: _Trace, s: _Search) -> int | None:
    """A wavy cruise's stop onset: the block of the strongest drop of the jump statistic
    over the scales `decel_half_widths_s` (local lines, which a slow ripple does not bend)
    in its last `max_decel_wavy_s`, in sd of that statistic; None when none reaches
    `decel_z` sd."""
    y, params = trace.y, trace.params
    best: tuple[float, int] | None = None  # (drop in sd, block) over the scales
    for half_width_s in params.decel_half_widths_s:
        w = trace.blocks(half_width_s)
        first = max(s.t1 + w + 2 + trace.blocks(0.02), s.t3 - trace.blocks(params.max_decel_wavy_s))
        last = s.t3 - max(trace.blocks(params.min_decel_s), w)
        if last <= first:
            continue
        jump = jump_statistic_W(y[first - w : last + w], w)[w : last - first + w + 1]
        if not np.isfinite(jump).any():
            continue
        i = int(np.nanargmin(jump))
        score = -float(jump[i]) / (jump_sd_factor(w) * trace.sigma_b + 1e-12)
        if best is None or score > best[0]:
            best = (score, first + i)
    if best is None or best[0] < params.decel_z:
        return None
    return best[1]


def _kept_stop(trace: _Trace, s: _Search, t2: int) -> int:
    """`t2` when [t2, t3) holds a stop phase: a line that falls and ends closer to idle
    than `decel_end_fraction` of the cruise power above idle, lasting `min_decel_s`;
    else t3 (no stop)."""
    y, params, t1, t3 = trace.y, trace.params, s.t1, s.t3
    if t3 - t2 < trace.blocks(params.min_decel_s):
        return t3
    idle_W = float(median(y[t3 : min(y.size, t3 + trace.blocks(0.3))]))
    slope, intercept = _line(y[t2:t3])
    end_W = intercept + slope * (t3 - t2 - 0.5)
    # the mean over the whole cruise: a ripple averages out of it
    cruise_W = _mean(y[t1 + 2 : t2 - 1]) if t2 - t1 > 4 else float(y[t2 - 1])
    # after a wavy cruise the line over a short stop phase has the ripple's slope (a 1 W
    # ripple at 0.25 Hz rises 0.5 W over 0.3 s, the stop at 0.1 m/s falls 0.3 W): there
    # the clear drop that starts it and its end near idle must do
    falls = slope < 0 or s.wavy
    if falls and (end_W - idle_W) < params.decel_end_fraction * (cruise_W - idle_W):
        return t2
    return t3


def _falls_from_start(trace: _Trace, t2: int, t3: int) -> bool:
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
    y, sigma_b, params = trace.y, trace.sigma_b, trace.params
    n = t3 - t2
    k = n // 3
    if k < max(3, trace.blocks(0.01)):
        return True  # too short to tell: the drop into it and its end near idle decide
    idle_W = float(median(y[t3 : min(y.size, t3 + trace.blocks(0.3))]))
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
