"""Windows: what the drive model is fitted on. Each run's bins (`stats.py`) are grouped into
windows of `WINDOW_S` seconds; a window's row of the design holds the window means of each
term's regressor (terms.py), its response the window's mean power `lag` later.

- Speed terms: the means over the window's bins of |v|, v^2 and |yaw rate| (bins already
  average a fast logger's samples).
- The inertial terms from the speed at the window's two edges (d(v^2/2)/dt = a v), and |v|
  and |yaw rate| with the noise around a true 0 taken out: regressors.py.
- A window is kept only when all its power bins and the bins its speeds are taken from hold
  samples: no window spans a drop-out.
- A current-proxy log (`DriveStats.current_proxy`: nominal voltage x motor current, ~ the
  wheels' force) gets the force form of the regressors (terms.py): the share of the window
  moving, |v|, the change of |v| (not of v^2/2), the share turning, and |yaw rate|, with an
  arc's (translating and turning) longitudinal and moment columns counted half: only its
  outer side drives (`_force_form`).
- Trips: a run is cut at its stops (the robot standing, not turning, for at least `STOP_S`),
  in the middle of each stop; a trip is the unit held out (heldout.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from wifibot_power.drive.regressors import (
    _window_abs,
    inertial_regressors,
    running_sums,
    speed_noise_per_sample,
    window_gain,
)
from wifibot_power.drive.stats import DriveStats
from wifibot_power.drive.terms import TERM_BY_NAME, TERMS

#: The window the model is fitted on [s]. The inertial terms are exact window means whatever
#: its length (d(v^2/2)/dt), so it need only be short enough that a window seldom holds both
#: speeding up and braking, and long enough that a 6.5 Hz logger puts 3 samples in it (their
#: noise averages before |v| and |yaw rate| are taken).
WINDOW_S = 0.5
#: Standing: slower than this [m/s] and turning slower than `STANDING_RADPS`.
STANDING_MPS = 0.02
STANDING_RADPS = 0.05
#: Below these a window's mean speed [m/s] and rate of turn [rad/s] are 0 whatever the noise
#: estimate (a resolution: 1 mm/s, 1 mrad/s).
NOISE_FLOOR_MPS = 1e-3
NOISE_FLOOR_RADPS = 1e-3
#: A stretch of motion (`_motion`) is followed on from its bins beyond 3 noise deviations to
#: where the speed (or rate of turn) comes within this many deviations of 0.
MOTION_LEAVE_DEVIATIONS = 1.0
#: A stop at least this long [s] cuts a run into trips.
STOP_S = 3.0


#: Each term's regressor (`RunWindows.regressors`; None: the constant 1).
REGRESSOR_OF = {
    "idle_W": None,
    "drive_on_W": "moving",
    "rolling_W_per_mps": "abs_speed",
    "quadratic_W_per_mps2": "speed2",
    "effective_mass_kg": "av_up",
    "braking_mass_kg": "av_down",
    "turning_Nm": "abs_yaw",
    "turning_coulomb_W": "turning",
}


@dataclass(frozen=True, eq=False)
class Windows:
    """The windows of one or more runs: a row per window."""

    #: the regressors, by column name (`columns`): what each term multiplies
    design: np.ndarray
    #: their rate of change from window to window [1/s]: how the fit moves with the lag
    design_rate: np.ndarray
    columns: tuple[str, ...]
    power_W: np.ndarray
    #: per window: its run's index (into `run_ids`), its trip's global number, its surface
    run: np.ndarray
    trip: np.ndarray
    surface: np.ndarray
    run_ids: tuple[str, ...]
    surfaces: tuple[str, ...]
    window_s: float
    #: every run is a current proxy: the columns are the terms' force form (`_force_form`)
    force_form: bool = False
    #: per window: its log is a current proxy (the force form's columns)
    proxy: np.ndarray | None = None

    @property
    def size(self) -> int:
        return int(self.power_W.size)

    def take(self, keep: np.ndarray) -> Windows:
        return Windows(
            self.design[keep],
            self.design_rate[keep],
            self.columns,
            self.power_W[keep],
            self.run[keep],
            self.trip[keep],
            self.surface[keep],
            self.run_ids,
            self.surfaces,
            self.window_s,
            self.force_form,
            None if self.proxy is None else self.proxy[keep],
        )


@dataclass(frozen=True, eq=False)
class RunWindows:
    """One run's windows before the response is chosen: the regressors and, for any lag, the
    power (`power_at`)."""

    stats: DriveStats
    n: int  # bins a window
    abs_speed_mps: np.ndarray
    speed2_mps2: np.ndarray
    av_up_m2ps3: np.ndarray  # window mean of (a v)+, speeding up [m^2/s^3]
    av_down_m2ps3: np.ndarray  # window mean of (a v)-, braking [m^2/s^3]
    abs_yaw_radps: np.ndarray
    moving: np.ndarray  # share of the window's bins spent moving or turning
    ok: np.ndarray  # the regressors are defined (no drop-out in their bins)
    trip: np.ndarray  # trip number within the run
    standing: np.ndarray
    #: share of the window's bins turning: the force form's Coulomb scrubbing moment (0 in a
    #: power log: `turning_coulomb_W` is the force form's only)
    turning: np.ndarray | None = None
    #: the speeding-up and braking columns' reliability (regressors.py `reliability`): the
    #: share of each column's sum of squares that is not the edge speeds' noise
    reliability: tuple[float, float] = (1.0, 1.0)

    @property
    def count(self) -> int:
        return int(self.ok.size)

    def regressors(self) -> dict[str, np.ndarray]:
        """Each window's regressors, by the names `REGRESSOR_OF` gives the terms."""
        return {
            "abs_speed": self.abs_speed_mps,
            "speed2": self.speed2_mps2,
            "av_up": self.av_up_m2ps3,
            "av_down": self.av_down_m2ps3,
            "abs_yaw": self.abs_yaw_radps,
            "moving": self.moving,
            "turning": self.turning if self.turning is not None else 0.0 * self.moving,
        }

    def power_at(self, lag_bins: float) -> tuple[np.ndarray, np.ndarray]:
        """Each window's mean power `lag_bins` bins later [W] (a fraction of a bin: linear
        between the two whole bins), and whether it is defined."""
        return between_bins(self._power_at, lag_bins)

    @cached_property
    def _power_sums(self) -> tuple[np.ndarray, np.ndarray]:
        """The running count of undefined power bins and the running sum of power (the same at
        every lag: made once, not at each of the lag search's tries)."""
        return running_sums(self.stats.power_W)

    @cached_property
    def rates(self) -> dict[str, np.ndarray]:
        """Each regressor's rate of change from window to window [1/s] (`Windows.design_rate`)."""
        return {
            name: np.gradient(values, self.n * self.stats.bin_s) if values.size > 1 else 0 * values
            for name, values in self.regressors().items()
        }

    @cached_property
    def _surface_local(self) -> np.ndarray:
        """Each window's surface, an index into `stats.surfaces` (its first bin's)."""
        return self.stats.surface_index[np.arange(self.count) * self.n]

    def _power_at(self, lag_bins: int) -> tuple[np.ndarray, np.ndarray]:
        """`power_at` at a whole lag."""
        mean = self.power_at_lags(np.array([lag_bins]))[:, 0]
        return mean, np.isfinite(mean)

    def power_at_lags(
        self, lags: np.ndarray, windows: np.ndarray | None = None, out: np.ndarray | None = None
    ) -> np.ndarray:
        """Each window's (of `windows`, indices; else every one) mean power at each whole lag
        of `lags` [bins], a column each [W]; NaN where not defined (past the run's end, or
        over a drop-out). `out`: where to write them (a window a row), returned."""
        lags = np.asarray(lags, dtype=np.intp)
        windows = np.arange(self.count) if windows is None else np.asarray(windows)
        means = self._span_means
        if not windows.size or not lags.size or not means.size:
            nothing = np.full((windows.size, lags.size), np.nan)
            return nothing if out is None else _into(out, nothing)
        # window i at lag l is the span mean from bin i n + l: NaN past the run's last span
        if lags[0] >= 0 and np.array_equal(lags, lags[0] + np.arange(lags.size)):
            # consecutive lags: each window's row is a stretch of the span means (a strided
            # view, rows gathered whole: no index per window and lag)
            padded = self._padded_means((self.count - 1) * self.n + int(lags[-1]) + 1)
            rows = np.lib.stride_tricks.as_strided(
                padded[lags[0] :],
                shape=(self.count, lags.size),
                strides=(self.n * padded.strides[0], padded.strides[0]),
                writeable=False,
            )
            if out is None:
                return rows[windows]
            # (indexing the strided rows, then a copy into `out`: np.take would first make the
            # rows contiguous, then write into a strided `out` through a buffer, ~10x slower)
            out[...] = rows[windows]
            return out
        start = (windows * self.n)[:, None] + lags[None, :]
        power = means[np.minimum(start, means.size - 1)]
        power[start >= means.size] = np.nan
        return power if out is None else _into(out, power)

    def _padded_means(self, size: int) -> np.ndarray:
        """`_span_means` followed by NaN up to at least `size` values, made once a run (the
        lag search's and the sums' strided rows read it: `power_at_lags`)."""
        padded = self.__dict__.get("_padded")
        if padded is None or padded.size < size:
            padded = _padded(self._span_means, size)
            self.__dict__["_padded"] = padded  # (a cache on a frozen dataclass, as cached_property)
        return padded

    @cached_property
    def _span_means(self) -> np.ndarray:
        """The mean power over the `n` bins from each bin on [W] (NaN over a drop-out; none
        past the run's end): a window's power at any lag is one of these."""
        bad, total = self._power_sums
        n = self.n
        if total.size <= n:
            return np.zeros(0)
        span = (total[n:] - total[:-n]) / n
        return np.where(bad[n:] - bad[:-n] == 0, span, np.nan)


def run_windows(stats: DriveStats, window_s: float = WINDOW_S) -> RunWindows:
    """A run's windows and their regressors (module docstring)."""
    n = max(int(round(window_s / stats.bin_s)), 1)
    count = stats.bins // n
    used = count * n
    speed = stats.speed_mps
    shape = (count, n)
    # |mean| rather than mean |.|: noise around a true 0 (a gyro's, an encoder's jitter)
    # averages out before the absolute value, and what is left of it is taken out of the
    # square (`_denoised_abs`) instead of adding its mean |noise| to the regressor
    mean_speed = speed[:used].reshape(shape).mean(axis=1)
    mean_yaw = stats.yaw_rate_radps[:used].reshape(shape).mean(axis=1)
    # the speed's noise per sample: the smaller of the bins' mean square second difference
    # (`speed_noise_per_sample`), which real fast motion inflates, and stats.py's median
    # successive difference, which reads an encoder's quantized speed as a step of noise
    # (0.021 m/s for the simulator's 0.0115); a speed from phases has none. For the edges'
    # noise (`calibrated`), |v|'s (`_denoised_abs`), standing still and where a stretch of
    # motion ends (`_motion`); the test that a bin moves keeps stats.py's (with this one,
    # BorealTC flooring's held-out MAPE went 5.8 -> 7.6%)
    sample_noise_mps = (
        0.0
        if stats.speed_from_phases
        else min(speed_noise_per_sample(speed, stats.samples_per_bin), stats.speed_noise_mps)
    )
    # the rate of turn's alike: stats.py's median reads motion at a slow logger (0.034 rad/s
    # at 6.5 Hz for the simulator's 0.03, 0.0058 at 20 Hz for 0.005), and `_denoised_abs`
    # reads a true 0 below 0 with too large a noise
    sample_noise_radps = min(
        speed_noise_per_sample(stats.yaw_rate_radps, stats.samples_per_bin),
        stats.yaw_noise_radps,
    )
    # a window mean's noise over a sample's: `window_gain`
    gain = np.sqrt(window_gain(n, stats.samples_per_bin))
    speed_noise = sample_noise_mps * gain
    yaw_noise = sample_noise_radps * gain
    # a bin's noise: a sample's over the samples it averages (a slow logger's bins interpolate
    # between samples: one sample's, an upper bound)
    bin_root = np.sqrt(max(stats.samples_per_bin, 1.0))
    abs_speed = _window_abs(
        speed[:used].reshape(shape), mean_speed, speed_noise, sample_noise_mps / bin_root
    )
    yaw_bins = stats.yaw_rate_radps[:used]
    abs_yaw = _window_abs(
        yaw_bins.reshape(shape), mean_yaw, yaw_noise, sample_noise_radps / bin_root
    )
    speed2 = np.square(speed[:used]).reshape(shape).mean(axis=1)
    av_up, av_down, reliable = inertial_regressors(stats, n, count, mean_speed, sample_noise_mps)
    ok = np.isfinite(abs_speed) & np.isfinite(abs_yaw) & np.isfinite(av_up + av_down)
    standing = (np.abs(mean_speed) < STANDING_MPS) & (np.abs(mean_yaw) < STANDING_RADPS)
    # a robot standing still is not moving a little: where speed and rate of turn are both
    # within 3 noise deviations of 0 (and slow), its speed terms are 0, not noise
    still = (
        standing
        & (np.abs(mean_speed) < 3.0 * max(speed_noise, NOISE_FLOOR_MPS))
        & (np.abs(mean_yaw) < 3.0 * max(yaw_noise, NOISE_FLOOR_RADPS))
    )
    # moving: a bin whose speed or rate of turn is beyond 3 deviations of its own noise (and
    # the resolution floor), and the bins next to it on to where the speed comes within one
    # deviation of 0 (`_motion`): a ramp starting is moving from its first mm/s on an exact
    # log, from its first encoder step or so on a noisy one
    speed_bins = speed[:used]
    speed_floor = max(NOISE_FLOOR_MPS, 3.0 * stats.speed_noise_mps / bin_root)
    yaw_floor = max(NOISE_FLOOR_RADPS, 3.0 * stats.yaw_noise_radps / bin_root)
    if stats.current_proxy:
        # a current proxy's shares (the force form's) keep the one threshold: with the ends
        # of motion counted, Vulpi's held-out MAPE went 7.2 -> 7.8% (ploughed 4.9 -> 6.9%),
        # BorealTC's within 0.1 point: no gain measured
        translating = (np.abs(speed_bins) > speed_floor).reshape(shape)
        turning_bins = (np.abs(yaw_bins) > yaw_floor).reshape(shape)
        moving = np.zeros(count)  # a motor current holds no drivers' step (no drive_on_W)
    else:
        translating = _motion(
            speed_bins,
            speed_floor,
            max(NOISE_FLOOR_MPS, MOTION_LEAVE_DEVIATIONS * sample_noise_mps / bin_root),
        )
        turning_bins = _motion(
            yaw_bins,
            yaw_floor,
            max(NOISE_FLOOR_RADPS, MOTION_LEAVE_DEVIATIONS * sample_noise_radps / bin_root),
        )
        moving = (translating | turning_bins).reshape(shape).mean(axis=1)
    if stats.current_proxy:
        radius_w = _radius_factor(
            speed[:used].reshape(shape), stats.yaw_rate_radps[:used].reshape(shape), stats.track_m
        )
        abs_speed, speed2, turning, abs_yaw, av_up, av_down = _force_form(
            translating, turning_bins, radius_w, abs_speed, abs_yaw, av_up, av_down
        )
    else:
        turning = np.zeros(count)  # a power log's scrubbing moment is all in |yaw rate|
    # (not the speeding-up and braking terms: a window standing still may end where a step
    # in speed begins, and its edge speeds say so; at a true standstill they are ~0 anyway)
    # (nor the shares moving and turning: counts of bins beyond their noise, not a noise
    # rectified by |.|; a window "still" by its mean may hold the last bins of motion,
    # whose drivers' step zeroed went to idle: idle 1.1 standard errors high on the
    # simulator, the step 1.3 low; 0.8 and 1.1 with the shares kept)
    for regressor in (abs_speed, speed2, abs_yaw):
        regressor[still] = 0.0
    trip = _trips(standing, max(int(round(STOP_S / (n * stats.bin_s))), 1))
    return RunWindows(
        stats,
        n,
        abs_speed,
        speed2,
        av_up,
        av_down,
        abs_yaw,
        moving,
        ok,
        trip,
        standing,
        turning,
        reliable,
    )


#: Wong's empirical lateral resistance of a skid-steer turn, mu_t = mu_max / (A + B_R R/B)
#: (`_radius_factor`)
WONG_A, WONG_B = 0.925, 0.15


def _radius_factor(speed_mps: np.ndarray, yaw_rate_radps: np.ndarray, track_m: float):
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


def _force_form(
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
    `_radius_factor`) and the window's |v|, |yaw rate| and d|v|/dt: (rolling, viscous,
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
    arc = arc_bins.mean(axis=1)
    # an arc's moment, each bin's by its radius (`_radius_factor`; 1: a spin's)
    arc_moment = (arc_bins * radius_w).mean(axis=1)
    half = 1.0 - arc / 2.0
    moving = (translating | turning).mean(axis=1)
    rolling = moving - arc / 2.0
    coulomb = turning.mean(axis=1) - arc + arc_moment / 2.0
    rate = abs_yaw * (1.0 - arc + arc_moment / 2.0)
    return rolling, abs_speed * half, coulomb, rate, av_up * half, av_down * half


def _motion(values: np.ndarray, enter: float, leave: float) -> np.ndarray:
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
    strong = np.logical_or.reduceat(np.abs(values) > enter, starts)
    moves = (side[starts] != 0) & strong
    return np.repeat(moves, np.diff(np.append(starts, values.size)))


def _trips(standing: np.ndarray, stop_windows: int) -> np.ndarray:
    """Each window's trip number: a new trip starts in the middle of every stretch of at least
    `stop_windows` standing windows that has motion on both sides."""
    if not standing.size:
        return np.zeros(0, dtype=np.intp)
    change = np.flatnonzero(np.diff(standing.astype(np.int8))) + 1
    bounds = np.concatenate(([0], change, [standing.size]))
    cuts = np.zeros(standing.size, dtype=np.intp)
    for start, end in zip(bounds[:-1], bounds[1:], strict=True):  # a loop over stops, not samples
        if standing[start] and end - start >= stop_windows and start > 0 and end < standing.size:
            cuts[(start + end) // 2] = 1
    return np.cumsum(cuts)


def design_columns(surfaces: tuple[str, ...]) -> tuple[str, ...]:
    """The design's column names: each term, per-surface ones as `NAME[surface]`."""
    return tuple(
        f"{term.name}[{surface}]" if term.per_surface else term.name
        for term in TERMS
        for surface in (surfaces if term.per_surface else (None,))
    )


class StackedPower:
    """Several runs' windows side by side (`assemble`'s row order), for the lag search: each
    window's power at any lag in one pass over all runs, the same numbers as each run's
    `RunWindows.power_at` (their running sums laid end to end, each window's first bin and its
    run's end as indices into them)."""

    def __init__(self, runs: list[RunWindows]) -> None:
        sums = [rw._power_sums for rw in runs]
        offsets = np.cumsum([0] + [total.size for _, total in sums])[:-1]
        self.bad = np.concatenate([bad for bad, _ in sums]) if sums else np.zeros(1, np.intp)
        self.total = np.concatenate([total for _, total in sums]) if sums else np.zeros(1)
        self.first = _joined(
            [base + np.arange(rw.count) * rw.n for base, rw in zip(offsets, runs, strict=True)]
        )
        self.end = _joined(
            [
                np.full(rw.count, base + rw.stats.bins)
                for base, rw in zip(offsets, runs, strict=True)
            ]
        )
        self.n = _joined([np.full(rw.count, rw.n) for rw in runs])
        #: per window: its regressors are defined (`RunWindows.ok`)
        self.ok = _joined([rw.ok for rw in runs]).astype(bool)
        self.counts = [rw.count for rw in runs]

    def split(self, mask: np.ndarray) -> list[np.ndarray]:
        """A mask over the stacked windows as one mask per run."""
        return np.split(mask, np.cumsum(self.counts)[:-1])

    def power_at(self, lag_bins: float) -> tuple[np.ndarray, np.ndarray]:
        """`RunWindows.power_at` of every run, stacked."""
        return between_bins(self._power_at, lag_bins)

    def _power_at(self, lag_bins: int) -> tuple[np.ndarray, np.ndarray]:
        start = self.first + lag_bins
        inside = start + self.n <= self.end
        end = np.minimum(start + self.n, self.end)
        start = np.minimum(start, self.end)
        ok = inside & (self.bad[end] - self.bad[start] == 0)
        mean = (self.total[end] - self.total[start]) / self.n
        return np.where(ok, mean, np.nan), ok


def _into(out: np.ndarray, values: np.ndarray) -> np.ndarray:
    out[...] = values
    return out


def _padded(values: np.ndarray, size: int) -> np.ndarray:
    """`values` followed by NaN up to `size` values (itself when it is as long)."""
    if values.size >= size:
        return values
    return np.concatenate((values, np.full(size - values.size, np.nan)))


def between_bins(power_at_whole, lag_bins: float) -> tuple[np.ndarray, np.ndarray]:
    """The power at a lag of `lag_bins` from `power_at_whole(whole lag)`: a fraction of a bin is
    linear between the two whole bins, defined where both are."""
    whole = int(np.floor(lag_bins))
    part = lag_bins - whole
    if part <= 1e-9:
        return power_at_whole(whole)
    low, low_ok = power_at_whole(whole)
    high, high_ok = power_at_whole(whole + 1)
    return (1 - part) * low + part * high, low_ok & high_ok


def _finite(values: np.ndarray) -> np.ndarray:
    """`np.nan_to_num(values)` in place (NaN 0, an infinity the largest float), without its
    cost where every value is finite."""
    return values if np.isfinite(values).all() else np.nan_to_num(values, copy=False)


def _joined(parts: list[np.ndarray]) -> np.ndarray:
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp)


def assemble(
    runs: list[RunWindows],
    lag_bins: float,
    surfaces: tuple[str, ...] | None = None,
    only: list[np.ndarray] | None = None,
    stacked: StackedPower | None = None,
) -> Windows:
    """The windows of `runs` with the power `lag_bins` later: rows of every window whose
    regressors and power are defined (and, with `only`, that its run's mask keeps), columns
    `design_columns(surfaces)`. `stacked`: `StackedPower(runs)` when the caller has it."""
    if surfaces is None:
        surfaces = tuple(sorted({s for r in runs for s in r.stats.surfaces}))
    # every run's windows side by side, kept or not in one pass (no loop over runs per column)
    power, power_ok = (stacked or StackedPower(runs)).power_at(lag_bins)
    keep = _joined([rw.ok for rw in runs]).astype(bool) & power_ok
    if only is not None:
        keep &= _joined(list(only)).astype(bool)
    return _assemble_rows(runs, surfaces, keep, power)


def regressor_rows(
    runs: list[RunWindows], surfaces: tuple[str, ...], ok: np.ndarray | None = None
) -> Windows:
    """Every window of `runs` whose regressors are defined (`ok`: the stacked `RunWindows.ok`
    when the caller has it), with a power of 0: the design, whatever the lag."""
    ok = _joined([rw.ok for rw in runs]).astype(bool) if ok is None else ok
    return _assemble_rows(runs, surfaces, ok, np.zeros(ok.size))


def _assemble_rows(
    runs: list[RunWindows], surfaces: tuple[str, ...], keep: np.ndarray, power: np.ndarray
) -> Windows:
    """`assemble`'s windows: the stacked windows `keep` holds, `power` their response."""
    columns = design_columns(surfaces)
    bases = np.cumsum([0] + [int(rw.trip[-1]) + 1 if rw.count else 0 for rw in runs])[:-1]
    names = tuple(runs[0].regressors()) if runs else ()
    joined = {
        **{name: _joined([rw.regressors()[name] for rw in runs])[keep] for name in names},
        **{f"rate:{name}": _joined([rw.rates[name] for rw in runs])[keep] for name in names},
        "surface": _joined([surface_of(rw, surfaces) for rw in runs])[keep],
        "power": power[keep],
        "run": np.repeat(np.arange(len(runs)), [rw.count for rw in runs])[keep],
        "proxy": np.repeat(
            [rw.stats.current_proxy for rw in runs], [rw.count for rw in runs]
        ).astype(bool)[keep],
        "trip": _joined([rw.trip + base for rw, base in zip(runs, bases, strict=True)])[keep],
    }
    power = joined.get("power", np.zeros(0))
    surface = joined.get("surface", np.zeros(0)).astype(np.intp)
    design = np.empty((power.size, len(columns)))
    design_rate = np.empty((power.size, len(columns)))
    fill_design(design, joined.__getitem__, surface, len(surfaces))
    fill_design(design_rate, lambda name: joined["rate:" + name], surface, len(surfaces), True)
    return Windows(
        design=design,
        design_rate=design_rate,
        columns=columns,
        power_W=power,
        run=joined.get("run", np.zeros(0)).astype(np.intp),
        trip=joined.get("trip", np.zeros(0)).astype(np.intp),
        surface=surface,
        run_ids=tuple(rw.stats.run_id for rw in runs),
        surfaces=surfaces,
        window_s=runs[0].n * runs[0].stats.bin_s if runs else WINDOW_S,
        force_form=bool(runs) and all(rw.stats.current_proxy for rw in runs),
        proxy=joined.get("proxy", np.zeros(0, dtype=bool)).astype(bool),
    )


def surface_of(rw: RunWindows, surfaces: tuple[str, ...]) -> np.ndarray:
    """Each of the run's windows' surface as an index into `surfaces`."""
    position = {name: k for k, name in enumerate(surfaces)}
    return np.array([position[s] for s in rw.stats.surfaces], dtype=np.intp)[rw._surface_local]


def fill_design(
    out: np.ndarray, values_of, surface: np.ndarray, surfaces: int, rate: bool = False
) -> None:
    """Write the design's columns (`design_columns` order) into `out` (a row per window): each
    term's regressor (`values_of(name)`, its values on the rows, a fresh array: made finite in
    place, NaN 0), a per-surface term's on its surface's column (0 elsewhere), the constant 1
    for idle. `rate`: the design's rate (`Windows.design_rate`; idle's 0)."""
    one_hot = surface[:, None] == np.arange(surfaces)[None, :]
    j = 0
    for term in TERMS:
        regressor = REGRESSOR_OF[term.name]
        if regressor is None:
            out[:, j] = 0.0 if rate else 1.0
            j += 1
            continue
        values = _finite(values_of(regressor))[:, None]
        if TERM_BY_NAME[term.name].per_surface:
            np.multiply(one_hot, values, out=out[:, j : j + surfaces])
            j += surfaces
        else:
            out[:, j : j + 1] = values
            j += 1
