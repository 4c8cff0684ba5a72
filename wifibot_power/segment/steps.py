"""The power step search of a motion run without a speed column: the fine boundaries of
each step (acceleration start t0 and end t1, stop start t2, motion end t3) inside the
stretch the coarse search found (`wifibot_power.segment.motion`).

The search runs stage by stage over all steps at once (`_search_steps`): each stage asks
every step still searching for one least-squares split (`best_split`), and the splits of
one kind (polynomial degrees and jump sign) are found by one `best_splits` call
(`_splits`). A short split costs numpy's overhead per call more than its window, so ten
steps are split for little more than one step's time. The stages, in order, are those of
the module docstring of `wifibot_power.segment` (2a, 3a, 2b, 3b, 4, 5); the stop phase's
search is `wifibot_power.segment.stop`.
"""

from __future__ import annotations

import numpy as np

from wifibot_power.changepoint import jump_sd_factor, jump_statistic_W, peaks
from wifibot_power.segment.common import _line, _std, _wavy
from wifibot_power.segment.params import MotionParams
from wifibot_power.segment.search import _Search, _SplitAsked, _splits, _Step, _Trace
from wifibot_power.segment.stop import _find_stops


def _locate_steps(
    y: np.ndarray,
    block_dt: float,
    sigma_b: float,
    coarse: list[tuple[int, int]],
    params: MotionParams,
    assumed_ends: list[int] | None = None,
) -> list[_Step]:
    """Fine boundaries of every step (`_search_steps`), the steps searched side by side.

    A step's search needs the end of the step before it only where its idle window starts
    (`_idle_window_start`: 0.5 s before its coarse start, unless the step before ends
    later). Every step is first searched with an assumed end of the step before in its
    place (`assumed_ends`, of every step but the last; by default their coarse ends), all
    at once; then, in order, a step whose window start the step before's found end
    changes is searched again on its own. The steps are therefore those of a search step
    after step, whatever was assumed.
    """
    trace = _Trace(y, block_dt, sigma_b, params)
    next_starts = [a for a, _ in coarse[1:]] + [y.size]
    assumed = [0] + (assumed_ends or [b for _, b in coarse[:-1]])  # the first: none before
    windows = [
        (a, b, prev, nxt) for (a, b), prev, nxt in zip(coarse, assumed, next_starts, strict=True)
    ]
    steps = _search_steps(trace, windows)
    for i in range(1, len(steps)):
        a, b, _, nxt = windows[i]
        found = _idle_window_start(a, steps[i - 1].t3, block_dt, params)
        if found != _idle_window_start(a, assumed[i], block_dt, params):
            steps[i] = _search_steps(trace, [(a, b, steps[i - 1].t3, nxt)])[0]
    return steps


def _search_steps(trace: _Trace, windows: list[tuple[int, int, int, int]]) -> list[_Step]:
    """Fine boundaries of the steps whose motion was coarsely found in [a, b), for each
    window (a, b, end of the step before, start of the next), stage by stage."""
    searches = [_Search(a, b, prev_end, next_start) for a, b, prev_end, next_start in windows]
    _find_accel_starts(trace, searches)
    for s in searches:
        s.t1_coarse = _coarse_accel_end(trace, s)
    _refit_accel_starts(trace, searches)
    _find_accel_ends(trace, searches)
    _find_motion_ends(trace, searches)
    _find_stops(trace, searches)
    return [s.step() for s in searches]


def _idle_window_start(a: int, prev_end: int, block_dt: float, params: MotionParams) -> int:
    """First block of the idle stretch a step's acceleration start is fitted from: up to
    `idle_probe_s` before its coarse start `a`, after the step before ends."""
    return max(prev_end + 1, a - max(1, round(params.idle_probe_s / block_dt)))


def _find_accel_starts(trace: _Trace, searches: list[_Search]) -> None:
    """2a. Acceleration start t0: flat idle, then the drive-on step and the ramp (a line),
    power jumping up."""
    for s in searches:
        s.idle_from = _idle_window_start(s.a, s.prev_end, trace.block_dt, trace.params)
    asked = [
        (s.idle_from, min(s.a + trace.blocks(0.04), s.b), 0, 1, trace.min_len, 1) for s in searches
    ]
    for s, split in zip(searches, _splits(trace.y, asked), strict=True):
        s.t0 = split.index if split else s.a


def _coarse_accel_end(trace: _Trace, s: _Search) -> int | None:
    """3a. Acceleration end, coarse: the first clear drop of the jump statistic (its lines
    start after t0, clear of the step at the start); None without one."""
    y, params = trace.y, trace.params
    w = trace.blocks(params.jump_half_width_s)
    first = s.t0 + max(trace.blocks(params.min_accel_s), w + 2)
    last = min(s.t0 + trace.blocks(params.max_accel_s), s.b - trace.min_len)
    if last <= first:
        return None
    lo_j = max(0, first - w)
    hi_j = min(y.size, last + w)
    jump = jump_statistic_W(y[lo_j:hi_j], w)[first - lo_j : last - lo_j + 1]
    if not np.isfinite(jump).any():
        return None
    threshold = params.jump_z * jump_sd_factor(w) * trace.sigma_b
    found = _first_strong_drop(y, s.t0, first, jump, threshold, w, trace.blocks(0.1))
    return None if found is None else first + found


def _refit_accel_starts(trace: _Trace, searches: list[_Search]) -> None:
    """2b. Acceleration start again, the line fitted on more of the ramp (up to
    `accel_probe_s`, clear of the end of acceleration)."""
    min_len = trace.min_len
    asked: list[_SplitAsked | None] = []
    for s in searches:
        hi = min(
            s.t0 + trace.blocks(trace.params.accel_probe_s),
            (s.t1_coarse if s.t1_coarse else s.b) - min_len,
            s.b,
        )
        asked.append((s.idle_from, hi, 0, 1, min_len, 1) if hi > s.t0 + 4 * min_len else None)
    for s, ask, split in zip(searches, asked, _splits(trace.y, asked), strict=True):
        if ask is not None:
            s.t0 = split.index if split else s.t0


def _find_accel_ends(trace: _Trace, searches: list[_Search]) -> None:
    """3b. Acceleration end t1, fine: a quadratic ramp (with any transient) then a quadratic
    cruise (with any ripple) around the clear drop; without one (a ripple can cancel it at
    low speed) the split of a ramp line from a smooth cruise over the first
    `kink_probe_s`."""
    min_len, refine, params = trace.min_len, trace.refine, trace.params
    asked: list[_SplitAsked | None] = []
    for s in searches:
        if s.t1_coarse is not None:
            lo = max(s.t0 + min_len, s.t1_coarse - refine)
            asked.append((lo, min(s.t1_coarse + refine, s.b), 2, 2, min_len, -1))
        else:
            hi = min(s.t0 + trace.blocks(params.kink_probe_s), s.b)
            asked.append((s.t0 + 1, hi, 1, 2, min_len, 0))
    for s, split in zip(searches, _splits(trace.y, asked), strict=True):
        if s.t1_coarse is not None:
            t1 = split.index if split else s.t1_coarse
        else:
            t1 = split.index if split else min(s.t0 + trace.blocks(params.min_accel_s), s.b - 1)
        s.t1 = max(t1, s.t0 + 1)


def _find_motion_ends(trace: _Trace, searches: list[_Search]) -> None:
    """4. Motion end t3: a quadratic piece (cruise or stop), then flat idle; power drops to
    idle there, unless a wavy cruise (a ripple, a cubic piece) happens to be low there."""
    blocks, params = trace.blocks, trace.params
    asked: list[_SplitAsked | None] = []
    for s in searches:
        lo = max(s.t1 + blocks(0.05), s.b - blocks(params.end_back_s))
        s.end_hi = min(s.next_start - blocks(0.05), s.b + blocks(params.end_forward_s))
        s.end_hi = min(s.end_hi, trace.y.size)
        s.wavy = s.wavy_at_first = _wavy(trace.y, trace.sigma_b, s.t1, s.b, blocks(0.01))
        wavy = s.wavy
        asked.append((lo, s.end_hi, 3 if wavy else 2, 0, trace.min_len, 0 if wavy else -1))
    for s, split in zip(searches, _splits(trace.y, asked), strict=True):
        s.t3 = max(split.index if split else s.b, s.t1 + 1)


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
