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

The package, one job a module: `params` (the parameters), `kinematic` (runs with a speed
column), `motion` (motion runs from power: the coarse search), `steps` and `stop` (the
step search, stages 2-5 above, on the search state of `search`), `spikes` (start-up
transients), `doubts` and `hidden_stop` (where the phase model does not fit), `common`
(phases from sample ranges, small least-squares helpers).
"""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

from wifibot_power.changepoint import LevelParams, detect_levels
from wifibot_power.errors import LogError
from wifibot_power.io import ReadOptions, read_log
from wifibot_power.phases import Segmentation, Spike
from wifibot_power.run import Run

# (`x as x`: the parts' names that tests and benchmarks reach, importable from here as
# before the package was split)
from wifibot_power.segment.common import (
    _beats_line as _beats_line,
)
from wifibot_power.segment.common import (
    _line as _line,
)
from wifibot_power.segment.common import (
    _mean as _mean,
)
from wifibot_power.segment.common import (
    _phases,
    _time_at,
)
from wifibot_power.segment.common import (
    _std as _std,
)
from wifibot_power.segment.common import (
    _wavy as _wavy,
)
from wifibot_power.segment.common import (
    _wavy_means as _wavy_means,
)
from wifibot_power.segment.doubts import (
    _above_off_edges as _above_off_edges,
)
from wifibot_power.segment.doubts import (
    _longest_runs as _longest_runs,
)
from wifibot_power.segment.doubts import (
    _may_hold_two_levels as _may_hold_two_levels,
)
from wifibot_power.segment.doubts import (
    _most_within as _most_within,
)
from wifibot_power.segment.doubts import (
    _motion_doubts as _motion_doubts,
)
from wifibot_power.segment.hidden_stop import (
    _hidden_stop_doubts as _hidden_stop_doubts,
)
from wifibot_power.segment.hidden_stop import (
    _ripple_continuation as _ripple_continuation,
)
from wifibot_power.segment.hidden_stop import (
    _ripple_continuations as _ripple_continuations,
)
from wifibot_power.segment.hidden_stop import (
    _stands_above as _stands_above,
)
from wifibot_power.segment.kinematic import (
    _segment_kinematic,
)
from wifibot_power.segment.motion import (
    _coarse_motion as _coarse_motion,
)
from wifibot_power.segment.motion import (
    _segment_motion,
)
from wifibot_power.segment.params import (
    MotionParams,
    SpeedParams,
)
from wifibot_power.segment.search import (
    _Step as _Step,
)
from wifibot_power.segment.search import (
    _Trace as _Trace,
)
from wifibot_power.segment.spikes import (
    SPIKE_MIN_FRACTION as SPIKE_MIN_FRACTION,
)
from wifibot_power.segment.spikes import (
    _start_spikes as _start_spikes,
)
from wifibot_power.segment.steps import (
    _locate_steps as _locate_steps,
)
from wifibot_power.segment.steps import (
    _search_steps as _search_steps,
)
from wifibot_power.segment.stop import (
    _falls_from_start as _falls_from_start,
)


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


__all__ = ["MotionParams", "SpeedParams", "segment_file", "segment_run"]
