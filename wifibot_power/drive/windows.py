"""Windows: what the drive model is fitted on. Each run's bins (`stats.py`) are grouped into
windows of `WINDOW_S` seconds; a window's row of the design holds the window means of each
term's regressor (terms.py), its response the window's mean power `lag` later.

- Speed terms: the means over the window's bins of |v|, v^2 and |yaw rate| (bins already
  average a fast logger's samples).
- The inertial terms need a v, and a differentiated quantized speed is mostly noise. The
  window mean of a v is exactly the change of v^2/2 over the window divided by its duration
  (d(v^2/2)/dt = a v), so only the speed at the window's two edges is needed
  (`edge_speeds`: Richardson's extrapolation of box means, exact for a cubic speed), with the
  attenuation its noise brings corrected for (`calibrated`). Its sign splits speeding up
  (a v > 0) from braking (a v < 0), reversing included (v^2 does not care about the
  direction).
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

from wifibot_power.drive.stats import DriveStats
from wifibot_power.drive.terms import TERM_BY_NAME, TERMS

#: The window the model is fitted on [s]. The inertial terms are exact window means whatever
#: its length (d(v^2/2)/dt), so it need only be short enough that a window seldom holds both
#: speeding up and braking, and long enough that a 6.5 Hz logger puts 3 samples in it (their
#: noise averages before |v| and |yaw rate| are taken).
WINDOW_S = 0.5
#: The speed at a window's edge (`edge_speeds`): Richardson's combination of the means over
#: `EDGE_SAMPLES` samples (at least one bin) on each side and over twice as many,
#: (4 A(w) - A(2w)) / 3, which cancels the box mean's curvature error (A(w) = v + v'' w^2 / 24
#: + ...; the interface value of Colella & Woodward's piecewise parabolic method, J. Comput.
#: Phys. 54, 1984, Eq. 1.6, at 20 Hz: (7 (s_-1 + s_+1) - (s_-2 + s_+2)) / 12). A plain mean over
#: 2 bins a side (200 ms at 20 Hz) smeared the speed profile's corners into the neighbouring
#: windows, where the power has no inertial share: a regressor smoother than its response, the
#: effective mass 0.29 kg (1.6 standard errors) high on the simulator with exact speeds, 0.04
#: with this. The edges' noise is then corrected for (`calibrated`), not smoothed away.
EDGE_SAMPLES = 1.0
#: The speed noise estimate (`speed_noise_per_sample`) leaves out second differences beyond this
#: many of its own deviations (corners of the speed profile, reversing), iterated `CLIP_ROUNDS`
#: times: white noise loses 0.006% of its samples and 0.1% of its variance so.
CLIP_DEVIATIONS = 4.0
CLIP_ROUNDS = 4
#: Standing: slower than this [m/s] and turning slower than `STANDING_RADPS`.
STANDING_MPS = 0.02
STANDING_RADPS = 0.05
#: Below these a window's mean speed [m/s] and rate of turn [rad/s] are 0 whatever the noise
#: estimate (a resolution: 1 mm/s, 1 mrad/s).
NOISE_FLOOR_MPS = 1e-3
NOISE_FLOOR_RADPS = 1e-3
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
        power = self.stats.power_W
        bad = np.concatenate(([0], np.cumsum(~np.isfinite(power))))
        total = np.concatenate(([0.0], np.cumsum(np.nan_to_num(power))))
        return bad, total

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

    def power_at_lags(self, lags: np.ndarray, windows: np.ndarray | None = None) -> np.ndarray:
        """Each window's (of `windows`, indices; else every one) mean power at each whole lag
        of `lags` [bins], a column each [W]; NaN where not defined (past the run's end, or
        over a drop-out)."""
        lags = np.asarray(lags, dtype=np.intp)
        windows = np.arange(self.count) if windows is None else np.asarray(windows)
        if not windows.size or not lags.size:
            return np.full((windows.size, lags.size), np.nan)
        means = self._span_means
        # window i at lag l starts at bin i n + l; none starts past the run's last span
        start = (windows * self.n)[:, None] + lags[None, :]
        if not means.size:
            return np.full(start.shape, np.nan)
        out = means[np.minimum(start, means.size - 1)]
        out[start >= means.size] = np.nan
        return out

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
    samples = max(n * stats.samples_per_bin, 1.0)
    mean_speed = speed[:used].reshape(shape).mean(axis=1)
    mean_yaw = stats.yaw_rate_radps[:used].reshape(shape).mean(axis=1)
    # the speed's noise per sample: the smaller of the bins' mean square second difference
    # (`speed_noise_per_sample`), which real fast motion inflates, and stats.py's median
    # successive difference, which reads an encoder's quantized speed as a step of noise
    # (0.021 m/s for the simulator's 0.0115); a speed from phases has none. For the edges'
    # noise (`calibrated`), and |v|'s (`_denoised_abs`) and standing still; the share moving
    # keeps stats.py's (with this one, BorealTC flooring's held-out MAPE went 5.8 -> 7.6%)
    sample_noise_mps = (
        0.0
        if stats.speed_from_phases
        else min(speed_noise_per_sample(speed, stats.samples_per_bin), stats.speed_noise_mps)
    )
    speed_noise = sample_noise_mps / np.sqrt(samples)
    yaw_noise = stats.yaw_noise_radps / np.sqrt(samples)
    abs_speed = _window_abs(speed[:used].reshape(shape), mean_speed, speed_noise, samples)
    abs_yaw = _window_abs(stats.yaw_rate_radps[:used].reshape(shape), mean_yaw, yaw_noise, samples)
    speed2 = np.square(speed[:used]).reshape(shape).mean(axis=1)
    av_up, av_down = inertial_regressors(stats, n, count, mean_speed, sample_noise_mps)
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
    # the resolution floor): a ramp starting is moving from its first mm/s on an exact log,
    # from its first few encoder steps on a noisy one
    bin_samples = max(stats.samples_per_bin, 1.0)
    speed_floor = max(NOISE_FLOOR_MPS, 3.0 * stats.speed_noise_mps / np.sqrt(bin_samples))
    yaw_floor = max(NOISE_FLOOR_RADPS, 3.0 * stats.yaw_noise_radps / np.sqrt(bin_samples))
    moving_bins = (np.abs(speed[:used]) > speed_floor) | (
        np.abs(stats.yaw_rate_radps[:used]) > yaw_floor
    )
    moving = moving_bins.reshape(shape).mean(axis=1)
    if stats.current_proxy:
        translating = (np.abs(speed[:used]) > speed_floor).reshape(shape)
        turning_bins = (np.abs(stats.yaw_rate_radps[:used]) > yaw_floor).reshape(shape)
        radius_w = _radius_factor(
            speed[:used].reshape(shape), stats.yaw_rate_radps[:used].reshape(shape), stats.track_m
        )
        abs_speed, speed2, turning, abs_yaw, av_up, av_down = _force_form(
            translating, turning_bins, radius_w, abs_speed, abs_yaw, av_up, av_down
        )
        moving = np.zeros(count)  # a motor current holds no drivers' step (no drive_on_W)
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
        stats, n, abs_speed, speed2, av_up, av_down, abs_yaw, moving, ok, trip, standing, turning
    )


def inertial_regressors(
    stats: DriveStats, n: int, count: int, mean_speed: np.ndarray, sample_noise_mps: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each of a run's `count` windows of `n` bins: its mean of (a v)+ and (a v)- [m^2/s^3]
    (a current proxy: of (a sign v)+ and (a sign v)- [m/s^2]) from the speed at its edges
    (`edge_speeds`, `_speeding_and_braking`), corrected for the edges' noise (`calibrated`)."""
    speed = stats.speed_mps
    half = edge_half_bins(stats.samples_per_bin)
    edge_speed = edge_speeds(speed, np.arange(count + 1) * n, half)
    # power: d(v^2/2)/dt = a v; a current proxy's force form: d|v|/dt = a sign(v) (terms.py)
    kinetic = np.abs if stats.current_proxy else _half_square
    # whether a window speeds up or brakes, from its neighbours' mean speeds over the bins
    # its own edge speeds do not use: the same samples on both sides would correlate the
    # choice with the edges' noise (a cruise's window whose start edge reads high is called
    # braking and gets a negative change: braking 1.2 standard errors low on the simulator,
    # 0.8 with this; the effective mass 1.2 high, 1.0)
    trim = min(2 * half, n - 1)
    blocks = speed[: count * n].reshape(count, n)
    neighbours = (
        np.square(blocks[:, trim:].mean(axis=1)),  # a window without its first bins: "after"
        np.square(blocks[:, : n - trim].mean(axis=1)),  # without its last bins: "before"
    )
    window_s = n * stats.bin_s
    av_up, av_down = _speeding_and_braking(edge_speed, mean_speed, window_s, kinetic, neighbours)
    weights, centres = edge_kernel(half)
    edge_noise_mps = sample_noise_mps * np.sqrt(
        sample_gain(weights, centres, stats.samples_per_bin)
    )
    noise_up, noise_down = inertial_noise_var(
        edge_speed, edge_noise_mps, window_s, power_form=not stats.current_proxy
    )
    return calibrated(av_up, av_down, noise_up, noise_down)


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


def _window_abs(bins: np.ndarray, mean: np.ndarray, noise: float, samples: float) -> np.ndarray:
    """A window's mean |x| from its bins (a row each): |mean| denoised (`_denoised_abs`), except
    in a window where x changes sign (reversing, a spin turned the other way: its bins reach
    beyond 3 bin-noise deviations on both sides of 0), where |mean| would cancel the two
    directions: there the mean of the bins' own denoised |x|."""
    bin_noise = noise * np.sqrt(samples / bins.shape[1]) if bins.size else noise
    reach = 3.0 * max(bin_noise, 1e-12)
    flips = (bins.max(axis=1) > reach) & (bins.min(axis=1) < -reach)
    out = _denoised_abs(mean, noise)
    if flips.any():
        out[flips] = _denoised_abs(bins[flips], bin_noise).mean(axis=1)
    return out


def _denoised_abs(mean: np.ndarray, noise: float) -> np.ndarray:
    """|x| of a window mean x whose noise has standard deviation `noise` s: sqrt(max(x^2 - s^2,
    0)) - sqrt(2) `ZERO_READING` s exp(-x^2 / 2 s^2). The square root is a moment correction
    (E[x^2] = |true|^2 + s^2), which leaves a true |x| >> s as it is but reads a true 0 as
    0.342 s on average (`max` keeps only the noise's large draws). The second part takes that
    out where x is within a few s of 0 (E[exp(-z^2/2)] = 1/sqrt(2) for a standard normal z,
    so a true 0 reads 0 on average) and vanishes beyond (3 s: 0.04 s): a window that does not
    turn (most of a robot's: driving straight) has |yaw rate| 0 on average, a window driving
    has its |v|. Read as 0.342 s, the straight windows' |yaw rate| (0.0006 rad/s on the
    simulator at field realism) times 25-60 N m was turning power in every straight window,
    which the drivers' step paid: drive_on_W 0.16 W low, inside its 95% interval in 172 of
    200 seeds (180 with this; a constant shift, 0.342 s everywhere, took 0.342 s off every
    moving window's |v| too and pushed the 6.5 Hz row's drive_on_W as far the other way). A
    window whose true |x| is 0 may read below 0: an estimate unbiased at 0 of a quantity
    >= 0 is."""
    root = np.sqrt(np.maximum(np.square(mean) - noise * noise, 0.0))
    if noise <= 0:
        return root
    return root - np.sqrt(2.0) * ZERO_READING * noise * np.exp(-np.square(mean / noise) / 2.0)


#: E[sqrt(max(z^2 - 1, 0))] for a standard normal z (`_denoised_abs`): 0.3422 by 4 million
#: draws (tests/test_drive_edges.py checks it to 3 digits)
ZERO_READING = 0.342


def _half_square(speed_mps: np.ndarray) -> np.ndarray:
    """v^2 / 2 [m^2/s^2]: its rate of change is a v."""
    return np.square(speed_mps) / 2.0


def _speeding_and_braking(
    edge_speed: np.ndarray,
    mean_speed: np.ndarray,
    window_s: float,
    kinetic=_half_square,
    neighbours: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, ...]:
    """Each window's mean of (a v)+ and (a v)- [m^2/s^3]. Its size is the change of v^2/2
    between the speeds at its edges over its duration (d(v^2/2)/dt = a v, exact whatever
    happens inside), all speeding up or all braking when the speed keeps its sign; a window
    where the speed changes sign (reversing through 0) brakes from v_start^2/2 to 0 and
    speeds up from 0 to v_end^2/2. Whether a window speeds up or brakes is read from its
    neighbours' mean speeds (v^2 after against before), not from the sign of its own noisy
    change: split by its own sign, the edges' noise in a cruise would be rectified into both
    columns, biasing both coefficients (seen on the simulator at 6.5 Hz: braking 10% low).
    `neighbours`: the squared mean speeds of each window without its first and without its
    last edge bins, so that the call shares no sample with the edges (run_windows).
    `kinetic` is the quantity differentiated: v^2/2 (power, a v), or |v| (a current proxy's
    force form, a sign(v) [m/s^2]: windows.run_windows)."""
    start, end = edge_speed[:-1], edge_speed[1:]
    half_change = kinetic(end) - kinetic(start)
    crosses = start * end < 0
    square = np.square(mean_speed)
    after_sq, before_sq = neighbours if neighbours is not None else (square, square)
    after = np.concatenate((after_sq[1:], square[-1:]))
    before = np.concatenate((square[:1], before_sq[:-1]))
    rising = np.where(np.isfinite(after - before), after - before, half_change) > 0
    up = np.where(crosses, kinetic(end), np.where(rising, half_change, 0.0))
    down = np.where(crosses, -kinetic(start), np.where(rising, 0.0, half_change))
    return up / window_s, down / window_s


def _edge_means(speed: np.ndarray, edges: np.ndarray, half: int) -> np.ndarray:
    """The mean of the `half` bins on either side of each edge (fewer at a run's ends); NaN
    when one of them is a drop-out."""
    total = np.concatenate(([0.0], np.cumsum(np.nan_to_num(speed))))
    bad = np.concatenate(([0], np.cumsum(~np.isfinite(speed))))
    low = np.clip(edges - half, 0, speed.size)
    high = np.clip(edges + half, 0, speed.size)
    mean = (total[high] - total[low]) / np.maximum(high - low, 1)
    return np.where(bad[high] - bad[low] == 0, mean, np.nan)


def edge_half_bins(samples_per_bin: float) -> int:
    """The bins on each side of an edge in the inner mean of `edge_speeds`: `EDGE_SAMPLES`
    samples, at least one bin (20 Hz: 1, 6.5 Hz: 4)."""
    return max(1, int(np.ceil(EDGE_SAMPLES / samples_per_bin - 1e-9)))


def edge_speeds(speed_mps: np.ndarray, edges: np.ndarray, half: int) -> np.ndarray:
    """The speed at each edge [m/s] from the bins' means: (4 A(2 half) - A(4 half)) / 3, A(w)
    the mean of the w bins centred on the edge (`EDGE_SAMPLES`: Richardson's extrapolation of
    the box mean to zero width, exact for a cubic speed; Colella & Woodward 1984, Eq. 1.6).
    Its weights: 7 / (12 half) on the inner 2 half bins, -1 / (12 half) on the outer ones
    (`edge_kernel`). NaN where a drop-out is among them."""
    inner = _edge_means(speed_mps, edges, half)
    outer = _edge_means(speed_mps, edges, 2 * half)
    return (4.0 * inner - outer) / 3.0


def edge_kernel(half: int) -> tuple[np.ndarray, np.ndarray]:
    """`edge_speeds`' weights and the centres of the bins they fall on [bins from the edge]."""
    centres = np.arange(-2 * half, 2 * half) + 0.5
    weights = np.where(np.abs(centres) < half, 7.0, -1.0) / (12.0 * half)
    return weights, centres


def sample_gain(weights: np.ndarray, centres: np.ndarray, samples_per_bin: float) -> float:
    """The variance of sum_k w_k bin_k over that of one sample's white noise: the sum of the
    squared weights the combination puts on the samples. A bin of a fast logger is the mean of
    its `samples_per_bin` samples: sum w^2 / samples_per_bin. A slow logger's bins interpolate
    linearly between samples (stats.py `_held`): each weight spreads over the two samples
    around its bin by the hat function, averaged over 16 phases of the samples against the
    bins."""
    if samples_per_bin >= 1.0:
        return float(np.sum(np.square(weights)) / samples_per_bin)
    period = 1.0 / samples_per_bin  # [bins]
    phases = np.arange(16)[:, None, None] * period / 16.0
    first = np.floor((centres.min() - period) / period)
    middles = (first + np.arange(int(np.ptp(centres) / period) + 4))[None, :, None] * period
    hat = np.clip(1.0 - np.abs(centres[None, None, :] - middles - phases) / period, 0.0, None)
    on_samples = hat @ weights  # (phase, sample)
    return float(np.mean(np.sum(np.square(on_samples), axis=1)))


def speed_noise_per_sample(speed_mps: np.ndarray, samples_per_bin: float) -> float:
    """The white noise of one speed sample [m/s] from the bins: the mean square of their
    second differences (over one sample period at least: a straight ramp cancels) over its
    `sample_gain`, leaving out those beyond `CLIP_DEVIATIONS` of the estimate (a corner of the
    speed profile, a reversal), `CLIP_ROUNDS` times. A mean of squares, not a median: an
    encoder's quantized speed (2 cm/s steps over 1 cm/s noise) has successive differences of
    0 or one step, whose median is a step whatever the noise (stats.py's estimate, 0.021 m/s
    for the simulator's 0.0115); quantization adds its step^2 / 12 to the variance, which a
    mean of squares keeps (Widrow & Kollar, "Quantization Noise", 2008, Ch. 4)."""
    lag = 1 if samples_per_bin >= 1.0 else max(1, int(round(1.0 / samples_per_bin)))
    if speed_mps.size <= 2 * lag:
        return 0.0
    second = speed_mps[2 * lag :] - 2.0 * speed_mps[lag:-lag] + speed_mps[: -2 * lag]
    square = np.square(second[np.isfinite(second)])
    if not square.size:
        return 0.0
    gain = sample_gain(np.array([1.0, -2.0, 1.0]), np.array([0.0, lag, 2.0 * lag]), samples_per_bin)
    mean_square = float(np.mean(square))
    for _ in range(CLIP_ROUNDS):
        inside = square <= CLIP_DEVIATIONS**2 * mean_square
        mean_square = float(np.mean(square[inside])) if inside.any() else 0.0
    return float(np.sqrt(mean_square / gain))


def calibrated(
    av_up: np.ndarray,
    av_down: np.ndarray,
    noise_var_up: np.ndarray,
    noise_var_down: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The speeding-up and braking regressors of one run times their reliability ratio,
    lambda = 1 - sum(noise variance) / sum(regressor^2) over the windows where each acts,
    clipped to [0, 1]: regression calibration, E[x | x_observed] ~ lambda x_observed, whose
    least squares is consistent where the noisy regressor's is biased towards 0 (errors in
    variables: Carroll, Ruppert, Stefanski & Crainiceanu, "Measurement Error in Nonlinear
    Models", 2nd ed., 2006, Sec. 2.2 and Ch. 4; Fuller, "Measurement Error Models", 1987,
    Sec. 1.1). The noise is the edges' (`inertial_noise_var`); without it the effective mass
    came out 0.31 kg (1.6 standard errors) low on the simulator at field realism, braking
    0.26 kg (1.7; 100 seeds)."""
    out = []
    for values, noise_var in ((av_up, noise_var_up), (av_down, noise_var_down)):
        acting = np.isfinite(values) & (values != 0)
        total = float(np.sum(np.square(values[acting])))
        noise = float(np.sum(noise_var[acting]))
        reliability = min(max(1.0 - noise / total, 0.0), 1.0) if total > 0 else 1.0
        out.append(values * reliability)
    return out[0], out[1]


def inertial_noise_var(
    edge_speed: np.ndarray, edge_noise_mps: float, window_s: float, power_form: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """The noise variance each window's speeding-up and braking regressor takes from the
    noise (standard deviation `edge_noise_mps`, s) of its edge speeds (`_speeding_and_
    braking`): v^2/2 at an edge read as (v + e)^2/2 is off by v e + e^2/2, so a window's change
    over `window_s` T has variance (s^2 (v_start^2 + v_end^2) + s^4) / T^2, with v^2 = the
    read v^2 - s^2; a current proxy's |v| (`power_form` False) is off by about e: 2 s^2 / T^2.
    A window through 0 (reversing) has one edge in each column. Returns the variances where
    the window is (up, down) as if it were all in each column: `calibrated` takes those of
    the windows where each column acts."""
    s2 = edge_noise_mps**2
    if power_form:
        edge_var = np.maximum(s2 * np.square(edge_speed) - s2 * s2 / 2.0, 0.0)
    else:
        edge_var = np.full(edge_speed.shape, s2)
    start, end = edge_var[:-1], edge_var[1:]
    crosses = edge_speed[:-1] * edge_speed[1:] < 0
    both = start + end
    t2 = window_s**2
    return np.where(crosses, end, both) / t2, np.where(crosses, start, both) / t2


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
    position = {name: k for k, name in enumerate(surfaces)}
    bases = np.cumsum([0] + [int(rw.trip[-1]) + 1 if rw.count else 0 for rw in runs])[:-1]
    names = tuple(runs[0].regressors()) if runs else ()
    joined = {
        **{name: _joined([rw.regressors()[name] for rw in runs])[keep] for name in names},
        **{f"rate:{name}": _joined([rw.rates[name] for rw in runs])[keep] for name in names},
        "surface": _joined(
            [
                np.array([position[s] for s in rw.stats.surfaces], dtype=np.intp)[rw._surface_local]
                for rw in runs
            ]
        )[keep],
        "power": power[keep],
        "run": np.repeat(np.arange(len(runs)), [rw.count for rw in runs])[keep],
        "proxy": np.repeat(
            [rw.stats.current_proxy for rw in runs], [rw.count for rw in runs]
        ).astype(bool)[keep],
        "trip": _joined([rw.trip + base for rw, base in zip(runs, bases, strict=True)])[keep],
    }
    power = joined.get("power", np.zeros(0))
    surface = joined.get("surface", np.zeros(0)).astype(np.intp)
    one_hot = surface[:, None] == np.arange(len(surfaces))[None, :]

    def block(term_name: str, prefix: str) -> np.ndarray:
        regressor = REGRESSOR_OF[term_name]
        if regressor is None:
            return np.ones((power.size, 1)) if not prefix else np.zeros((power.size, 1))
        values = _finite(joined[prefix + regressor])[:, None]
        return one_hot * values if TERM_BY_NAME[term_name].per_surface else values

    design = np.hstack([block(term.name, "") for term in TERMS])
    return Windows(
        design=design,
        design_rate=np.hstack([block(term.name, "rate:") for term in TERMS]),
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
