"""Which of a run's bins move and turn, and what that makes of a window (windows.py
`run_windows`): motion by hysteresis (`motion_bins`), a current proxy's force-form shares
(`force_form_regressors`) with a turn's moment by its radius (`radius_factor`), and the
trips a run is cut into at its stops (`trip_numbers`)."""

from __future__ import annotations

import numpy as np

from wifibot_power.drive.regressors import row_means, row_shares

#: Wong's empirical lateral resistance of a skid-steer turn, mu_t = mu_max / (A + B_R R/B)
#: (`radius_factor`)
WONG_A, WONG_B = 0.925, 0.15


def radius_factor(speed_mps: np.ndarray, yaw_rate_radps: np.ndarray, track_m: float):
    """Each bin's scrubbing moment on a turn of radius R = |v| / |yaw rate| over its value
    turning in place, 0.925 / (0.925 + 0.15 R/B), B the track (1 where the track is unknown
    or the bin does not turn). The lateral resistance of a skid-steer vehicle falls with the
    turning radius: Wong, "Theory of Ground Vehicles", 4th ed., 2008, Sec. 7.2, the empirical
    mu_t = mu_max / (0.925 + 0.15 R/B) of Steeds; Morales et al. 2009 ([1] of terms.py) find
    the Auriga's moment larger on tight turns. On BorealTC's Husky (R from the wheel
    speeds), sandy loam's one arc (R/B ~1.2) turns with ~0.7 of its spins' moment by the
    sides' currents (the formula: 0.84); held out per surface with the factor, MAPE 17.0% ->
    16.1% (median 7.1%): asphalt 25.6 -> 19.5%, sandy loam 5.8 -> 5.0%, its arc +23% ->
    +10%. Used by the force form only (measured on current proxies; the simulator's robot
    has a constant moment)."""
    if not track_m > 0:
        return np.ones_like(speed_mps)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(speed_mps) / (np.abs(yaw_rate_radps) * track_m)
    factor = WONG_A / (WONG_A + WONG_B * ratio)
    return np.where(np.isfinite(factor), factor, 1.0)


def force_form_regressors(
    translating: np.ndarray,
    turning: np.ndarray,
    radius_w: np.ndarray,
    abs_speed: np.ndarray,
    abs_yaw: np.ndarray,
    av_up: np.ndarray,
    av_down: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """A current proxy's regressors (docs/drive-model.md, "Current-only logs"), from each
    bin's `translating`, `turning` and moment factor `radius_w` (a row of bins per window;
    `radius_factor`) and the window's |v|, |yaw rate| and d|v|/dt: (rolling, viscous,
    Coulomb moment, rate moment, speeding up, braking), in the slots of (|v|, v^2,
    `turning_coulomb_W`'s share, |yaw rate|, (a v)+, (a v)-).

    The proxy is V_nom (|I_left| + |I_right|), each side's current its motor's torque while
    it drives (the Husky's controller reads ~0 A on a side that brakes: below). A skid-steer
    robot's two sides share the longitudinal force F (rolling F_r, viscous c|v|, inertial
    m a) and make the scrubbing moment M between them: F_out = F/2 + M/B, F_in = F/2 - M/B
    (Wong, "Theory of Ground Vehicles", 4th ed., Wiley 2008, Sec. 7.2, the kinetics of skid
    steering; Morales et al. 2009, [1] of terms.py, Eq. 20-22 for M). So the proxy is u_0 F
    driving straight; u_0 (F_r + 2 M/B) turning in place (each side drives its own way,
    rolling included); and u_0 (F/2 + M/B) on an arc where M/B > F/2: the inner side
    brakes, its current is not in the log, and every longitudinal force and the moment
    count half. On BorealTC's Husky logs the inner side reads <= 0.6 A (the standstill
    current) in 51-98% of the arc samples per surface (turning at > 0.15 rad/s, both sides
    forward; Vulpi's few arcs: 27-45%), against 0-9% of the slower side driving straight or
    spinning; its median is 0.0-0.6 A while the outer side's is about one side of a spin's
    on the same surface (3.6-12.7 A against 3.5-11.8 A: benchmarks/validate_drive_real.py,
    "The sides of an arc"). An arc's moment is its spin's times the radius factor. The
    moment's part growing with the rate of turn is |yaw rate|'s column, halved on an arc
    alike (within a trip the Husky's currents grow with the rate:
    83 W window RMS on BorealTC against 96 W with the Coulomb part alone; from trip to trip
    its spins' currents are flat in the rate, which the Coulomb part carries). Held out (one
    fit per surface, BorealTC): MAPE 19.8% -> 17.5%, median 10.1% -> 7.1%, against an arc
    counted as a spin plus a straight run."""
    arc_bins = translating & turning
    arc = row_shares(arc_bins)
    # an arc's moment, each bin's by its radius (`radius_factor`; 1: a spin's)
    arc_moment = row_means(arc_bins * radius_w)
    half = 1.0 - arc / 2.0
    moving = row_shares(translating | turning)
    rolling = moving - arc / 2.0
    coulomb = row_shares(turning) - arc + arc_moment / 2.0
    rate = abs_yaw * (1.0 - arc + arc_moment / 2.0)
    return rolling, abs_speed * half, coulomb, rate, av_up * half, av_down * half


def motion_bins(values: np.ndarray, enter: float, leave: float) -> np.ndarray:
    """Which bins move by `values` (a speed [m/s] or a rate of turn [rad/s], a bin each):
    those beyond `leave` on one side of 0 in an unbroken stretch on that side that goes
    beyond `enter` somewhere (hysteresis, the two thresholds of Canny's edge linking: J.
    Canny, IEEE Trans. PAMI 8(6), 1986, Sec. VI). A speed is continuous: motion confirmed by
    a bin beyond 3 noise deviations (`enter`) began where the speed left 0 and ends where it
    comes back, so the stretch is followed down to one deviation of the noise (`leave`),
    not cut at 3: a start's and a stop's first bins of motion are moving, and their drivers'
    step is not left to idle. At one deviation a standing bin next to motion joins it with
    the normal's tail, 16%, whether the speed is quantized or not (followed to 0: half the
    bins of a continuous noise, few of an encoder's), while a ramp's bins below one deviation
    are missed. Idle's bias on the simulator (60 seeds, 20 Hz and 6.5 Hz; docs/drive-model.md,
    "Validation"), in standard errors: +0.76 and +1.39 cut at 3 deviations (before), -0.08
    and -0.58 followed to 0, +0.03 and -0.14 to half a deviation, +0.14 and +0.22 to one,
    +0.55 and +0.85 to two. A drop-out (NaN) ends a stretch.

    Both sides at once, per stretch rather than per bin: each bin's side (+1 beyond `leave`,
    -1 beyond -`leave`, else 0), the stretches where it stays the same, whether each holds
    a bin beyond `enter` (a stretch is on one side: |value| is its side's), and the
    stretches that move repeated over their bins (the same bins as labelling each side's
    stretches by a running count and looking each bin's label up, in a third of the
    passes: tests/test_drive_fast_paths.py)."""
    if not values.size:
        return np.zeros(values.shape, dtype=bool)
    side = (values > leave).view(np.int8) - (values < -leave).view(np.int8)
    starts = np.concatenate(([0], np.flatnonzero(side[1:] != side[:-1]) + 1))
    ends = np.append(starts[1:], values.size)
    # a stretch holds a bin beyond `enter` where the running count of such bins grows over
    # it (a count, not np.logical_or.reduceat: that copies each stretch's first value on
    # its own, slow for the thousands of short stretches a noisy standstill makes)
    beyond = np.empty(values.size + 1, dtype=np.intp)
    beyond[0] = 0
    np.cumsum(np.abs(values) > enter, out=beyond[1:])
    moves = (side[starts] != 0) & (beyond[ends] > beyond[starts])
    return np.repeat(moves, ends - starts)


def trip_numbers(standing: np.ndarray, stop_windows: int) -> np.ndarray:
    """Each window's trip number: a new trip starts in the middle of every stretch of at least
    `stop_windows` standing windows that has motion on both sides."""
    if not standing.size:
        return np.zeros(0, dtype=np.intp)
    change = np.flatnonzero(np.diff(standing.astype(np.int8))) + 1
    start = np.concatenate(([0], change))  # each stretch of standing or moving windows
    end = np.append(change, standing.size)
    stop = standing[start] & (end - start >= stop_windows) & (start > 0) & (end < standing.size)
    cuts = np.zeros(standing.size, dtype=np.intp)
    cuts[(start[stop] + end[stop]) // 2] = 1
    return np.cumsum(cuts)
