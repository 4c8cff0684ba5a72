"""Motion runs without a speed column, segmented from power: the coarse motion stretches,
then each step's fine boundaries (`wifibot_power.segment.steps`), start-up spikes
(`.spikes`) and the doubts (`.doubts`). The stages are those of the docstring of
`wifibot_power.segment`."""

from __future__ import annotations

import numpy as np

from wifibot_power.changepoint import block_means, median, robust_sigma_W
from wifibot_power.errors import LogError
from wifibot_power.phases import Segmentation
from wifibot_power.run import Run
from wifibot_power.segment.common import Piece, _phases
from wifibot_power.segment.doubts import _motion_doubts
from wifibot_power.segment.params import MotionParams
from wifibot_power.segment.spikes import _start_spikes
from wifibot_power.segment.steps import _locate_steps


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
    pieces: list[Piece] = []
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
