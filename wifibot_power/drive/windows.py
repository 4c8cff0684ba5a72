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
  outer side drives (`force_form_regressors`).
- Trips: a run is cut at its stops (the robot standing, not turning, for at least `STOP_S`),
  in the middle of each stop; a trip is the unit held out (heldout.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from wifibot_power.drive.moving import (
    force_form_regressors,
    motion_bins,
    radius_factor,
    trip_numbers,
)
from wifibot_power.drive.regressors import (
    _window_abs,
    gradient,
    inertial_regressors,
    row_means,
    row_shares,
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
#: A stretch of motion (`motion_bins`) is followed on from its bins beyond 3 noise deviations to
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
    #: every run is a current proxy: the columns are the terms' force form (`force_form_regressors`)
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
            name: gradient(values, self.n * self.stats.bin_s) if values.size > 1 else 0 * values
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
        every = windows is None
        windows = np.arange(self.count) if every else np.asarray(windows)
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
            # rows contiguous, then write into a strided `out` through a buffer, ~10x slower;
            # every window's: the rows copied as they are, no index)
            out[...] = rows if every else rows[windows]
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
    n = window_bins(stats, window_s)
    count = stats.bins // n
    used = count * n
    speed = stats.speed_mps
    shape = (count, n)
    # |mean| rather than mean |.|: noise around a true 0 (a gyro's, an encoder's jitter)
    # averages out before the absolute value, and what is left of it is taken out of the
    # square (`_denoised_abs`) instead of adding its mean |noise| to the regressor
    mean_speed = row_means(speed[:used].reshape(shape))
    # a run that never turns (the step runs: no turning column, 0 in every bin): its rate of
    # turn's mean, noise, |.| and turning bins are 0 without ~40 numpy calls on its zeros
    turns = stats.has_turning or bool(stats.yaw_rate_radps.any())
    mean_yaw = row_means(stats.yaw_rate_radps[:used].reshape(shape)) if turns else np.zeros(count)
    sample_noise_mps, sample_noise_radps = _noise_per_sample(stats, turns)
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
    abs_yaw = (
        _window_abs(yaw_bins.reshape(shape), mean_yaw, yaw_noise, sample_noise_radps / bin_root)
        if turns
        else np.zeros(count)  # (|0| with a noise <= 0: `_denoised_abs`' root alone)
    )
    speed2 = row_means(np.square(speed[:used]).reshape(shape))
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
    speed_bins = speed[:used]
    translating, turning_bins, moving = _moving(
        stats, speed_bins, yaw_bins, shape, (sample_noise_mps, sample_noise_radps), bin_root, turns
    )
    if stats.current_proxy:
        radius_w = radius_factor(
            speed[:used].reshape(shape), stats.yaw_rate_radps[:used].reshape(shape), stats.track_m
        )
        abs_speed, speed2, turning, abs_yaw, av_up, av_down = force_form_regressors(
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
    trip = trip_numbers(standing, max(int(round(STOP_S / (n * stats.bin_s))), 1))
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


def window_bins(stats: DriveStats, window_s: float) -> int:
    """The bins a window of `window_s` holds (a whole number, at least one)."""
    return max(int(round(window_s / stats.bin_s)), 1)


def _noise_per_sample(stats: DriveStats, turns: bool = True) -> tuple[float, float]:
    """The speed's and the rate of turn's noise per sample [m/s, rad/s] (`run_windows`;
    `turns` False: the rate of turn is 0 in every bin, its second differences too)."""
    # the speed's: the smaller of the bins' mean square second difference
    # (`speed_noise_per_sample`), which real fast motion inflates, and stats.py's median
    # successive difference, which reads an encoder's quantized speed as a step of noise
    # (0.021 m/s for the simulator's 0.0115); a speed from phases has none. For the edges'
    # noise (`calibrated`), |v|'s (`_denoised_abs`), standing still and where a stretch of
    # motion ends (`motion_bins`); the test that a bin moves keeps stats.py's (with this one,
    # BorealTC flooring's held-out MAPE went 5.8 -> 7.6%)
    sample_noise_mps = (
        0.0
        if stats.speed_from_phases
        else min(
            speed_noise_per_sample(stats.speed_mps, stats.samples_per_bin),
            stats.speed_noise_mps,
        )
    )
    # the rate of turn's alike: stats.py's median reads motion at a slow logger (0.034 rad/s
    # at 6.5 Hz for the simulator's 0.03, 0.0058 at 20 Hz for 0.005), and `_denoised_abs`
    # reads a true 0 below 0 with too large a noise
    sample_noise_radps = min(
        speed_noise_per_sample(stats.yaw_rate_radps, stats.samples_per_bin) if turns else 0.0,
        stats.yaw_noise_radps,
    )
    return sample_noise_mps, sample_noise_radps


def _moving(
    stats: DriveStats,
    speed_bins: np.ndarray,
    yaw_bins: np.ndarray,
    shape: tuple[int, int],
    sample_noise: tuple[float, float],
    bin_root: float,
    turns: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which of the window's bins translate and turn (a row of bins per window), and the share
    of each window moving (`run_windows`; `sample_noise`: `_noise_per_sample`'s; `turns`
    False: the rate of turn is 0 in every bin, none turns)."""
    sample_noise_mps, sample_noise_radps = sample_noise
    count = shape[0]
    # moving: a bin whose speed or rate of turn is beyond 3 deviations of its own noise (and
    # the resolution floor), and the bins next to it on to where the speed comes within one
    # deviation of 0 (`motion_bins`): a ramp starting is moving from its first mm/s on an exact
    # log, from its first encoder step or so on a noisy one
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
        translating = motion_bins(
            speed_bins,
            speed_floor,
            max(NOISE_FLOOR_MPS, MOTION_LEAVE_DEVIATIONS * sample_noise_mps / bin_root),
        )
        if not turns:  # (a 0 is within the floors, > 0: no bin turns)
            none_turn = np.zeros(yaw_bins.shape, bool)
            return translating, none_turn, row_shares(translating.reshape(shape))
        turning_bins = motion_bins(
            yaw_bins,
            yaw_floor,
            max(NOISE_FLOOR_RADPS, MOTION_LEAVE_DEVIATIONS * sample_noise_radps / bin_root),
        )
        moving = row_shares((translating | turning_bins).reshape(shape))
    return translating, turning_bins, moving


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
    cost where every value is finite, and elsewhere of the undefined values only (its passes
    over every value, one per kind of non-finite, cost more)."""
    finite = np.isfinite(values)
    if finite.all():
        return values
    undefined = np.logical_not(finite, out=finite)
    bad = values[undefined]
    # (np.nan_to_num of float64's: NaN 0, +-inf +-the largest float; its own call costs
    # more than these few values)
    largest = np.finfo(values.dtype).max  # (float32: its own largest, as numpy)
    values[undefined] = np.where(np.isnan(bad), 0.0, np.where(bad > 0, largest, -largest))
    return values


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
