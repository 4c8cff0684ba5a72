"""Parameters of segmentation: of motion runs cut from power (`MotionParams`) and of runs
cut from their speed column (`SpeedParams`); docs/segmentation.md explains each."""

from __future__ import annotations

from dataclasses import dataclass


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
