"""Per-run statistics of the drive model: a run's samples reduced to short bins of a fixed
duration (`BIN_S`), whatever its logger's rate, so that the fit (`identify.py`) works alike on
a 10 kHz analyser log and a 6 Hz robot log, and a worker sends back kilobytes, not the samples.

`drive_stats(run, segmentation)` is what the pipeline calls in its workers (the model family's
`run_stats`); `DriveStats` is small, frozen and picklable.

How a run becomes bins (docs/drive-model.md, "Identification"):
- a logger faster than a quarter of a bin (an analyser): each bin holds the mean of its
  samples (power, speed, rate of turn); a bin without a sample is a drop-out;
- a slower logger (a robot's 6 Hz log): power is held over each sample's period (a sample is
  the mean power over its period: the rectangle rule, run.py), speed and rate of turn are
  interpolated linearly between the middles of their samples' periods (taken as means over
  the period too, as an encoder's count over it is); bins inside a gap (a step over
  `GAP_FACTOR` sample periods) are drop-outs;
- a run without a speed column but with motion phases (the paper's step runs) gets the
  speed of its phases (`speed_from_phases`): a trapezoid per step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.io.metadata import robot_mass_kg

if TYPE_CHECKING:
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

#: The bin the samples are reduced to [s]: 20 per second, finer than any lag or acceleration
#: the drive model resolves (windows are `identify.WINDOW_S`), coarse enough that an hour of
#: a 10 kHz log is 72,000 numbers a channel.
BIN_S = 0.05
#: A step between time stamps over this many median sample periods is a drop-out: no bin
#: inside it is filled (and so no window crosses it).
GAP_FACTOR = 2.5
#: The surface of a run (or a stretch of it) whose log names none.
UNKNOWN_SURFACE = "unknown"


@dataclass(frozen=True, eq=False)
class DriveStats:
    """A run reduced to bins of `bin_s` seconds: each bin's mean power [W], speed [m/s] and
    rate of turn [rad/s] (NaN in a drop-out), and its surface (an index into `surfaces`)."""

    run_id: str
    file: str
    bin_s: float
    power_W: np.ndarray
    speed_mps: np.ndarray
    #: zeros when the log has no turning column (`has_turning` False: turning not observed)
    yaw_rate_radps: np.ndarray
    surface_index: np.ndarray
    surfaces: tuple[str, ...]
    has_turning: bool
    #: the run's measured energy, all samples [J], and its duration [s]
    energy_J: float
    duration_s: float
    #: the noise of one window's mean speed [m/s] and rate of turn [rad/s] per sample (from
    #: successive differences: `_sample_noise`), and the samples a bin holds (< 1: slow logger)
    speed_noise_mps: float = 0.0
    yaw_noise_radps: float = 0.0
    samples_per_bin: float = 1.0
    #: the speed is the phases' trapezoid, not a measured column (`speed_from_phases`)
    speed_from_phases: bool = False
    notes: tuple[str, ...] = field(default=())
    #: the power column is a current proxy, a nominal voltage times motor currents (the log's
    #: `voltage_assumed_V` metadata, `current_proxy`): it grows with the motors' torque, not
    #: with the power they draw, and the drive model takes its force form (windows.py)
    current_proxy: bool = False
    #: the wheels' track [m] (the log's `track_m` metadata; NaN: unknown): the turning radius
    #: over it sets a current proxy's scrubbing moment on an arc (moving.py `force_form_regressors`)
    track_m: float = float("nan")
    #: the mass the drive accelerates [kg]: the log's `mass_kg` plus its `payload_kg` (NaN: no
    #: mass_kg), what effective_mass_kg cannot be under (drive/plausible.py)
    mass_kg: float = float("nan")

    @property
    def bins(self) -> int:
        return int(self.power_W.size)

    def to_json(self) -> dict[str, object]:
        """JSON values (the parse cache keeps a run's statistics): arrays as lists, NaN (a
        drop-out's bin) as null; `from_json` gives back the same floats."""

        def values(array: np.ndarray) -> list[float | None]:
            return [None if v != v else v for v in array.tolist()]  # v != v: NaN

        return {
            **{k: getattr(self, k) for k in _SCALARS},
            "power_W": values(self.power_W),
            "speed_mps": values(self.speed_mps),
            "yaw_rate_radps": values(self.yaw_rate_radps),
            "surface_index": self.surface_index.tolist(),
            "surfaces": list(self.surfaces),
            "notes": list(self.notes),
            "current_proxy": self.current_proxy,
            "track_m": None if self.track_m != self.track_m else self.track_m,
            "mass_kg": None if self.mass_kg != self.mass_kg else self.mass_kg,
        }

    @classmethod
    def from_json(cls, data: dict) -> DriveStats:
        def array(values: list) -> np.ndarray:
            return np.array([np.nan if v is None else v for v in values], dtype=np.float64)

        return cls(
            **{k: data[k] for k in _SCALARS},
            power_W=array(data["power_W"]),
            speed_mps=array(data["speed_mps"]),
            yaw_rate_radps=array(data["yaw_rate_radps"]),
            surface_index=np.array(data["surface_index"], dtype=np.int16),
            surfaces=tuple(data["surfaces"]),
            notes=tuple(data["notes"]),
            current_proxy=bool(data.get("current_proxy", False)),
            track_m=float("nan") if data.get("track_m") is None else float(data["track_m"]),
            mass_kg=float("nan") if data.get("mass_kg") is None else float(data["mass_kg"]),
        )


#: `DriveStats` fields that are plain values (JSON as they are)
_SCALARS = (
    "run_id",
    "file",
    "bin_s",
    "has_turning",
    "energy_J",
    "duration_s",
    "speed_noise_mps",
    "yaw_noise_radps",
    "samples_per_bin",
    "speed_from_phases",
)


def drive_stats(run: Run, segmentation: Segmentation | None = None) -> DriveStats | None:
    """The drive model's statistics of one run, or None when it has no speed (neither a speed
    column nor motion phases to reconstruct one from)."""
    speed_mps = run.speed_mps
    from_phases = False
    if speed_mps is None:
        if segmentation is None or not any(p.phase == "cruise" for p in segmentation.phases):
            return None
        speed_mps = speed_from_phases(run, segmentation)
        from_phases = True
    yaw_radps = run.yaw_rate_radps
    surface_index, surfaces = sample_surfaces(run)
    period_s = run.sample_period_s
    span_s = run.time_at(-1) + period_s - run.time_at(0)
    n_bins = max(int(np.floor(span_s / BIN_S + 1e-9)), 1)
    if period_s <= BIN_S / 4:
        present, starts = _bin_starts(run, n_bins)  # per bin, not per sample
        count = np.diff(np.r_[starts, run.samples]).astype(np.float64)
        binned = _bin_means(present, starts, count, n_bins, run.power_W, speed_mps, yaw_radps)
        bin_surface = np.zeros(n_bins, dtype=np.int16)  # a bin without a sample: the first
        if surface_index is not None:
            bin_surface[present] = surface_index[starts]  # each bin's first sample's
    else:
        time_s = run.time_s
        offset_s = time_s - time_s[0]
        centre_s = _centres(n_bins)
        at = _sample_at_centres(offset_s, n_bins, centre_s)  # once for the bins and surface
        binned = _held(offset_s, at, period_s, run.power_W, speed_mps, yaw_radps, centre_s)
        bin_surface = np.zeros(n_bins, np.int16) if surface_index is None else surface_index[at]
    power_W, bin_speed_mps, bin_yaw_radps = binned
    energy_J, _ = run.energy_and_mean()
    return DriveStats(
        run_id=run.meta.run_id,
        file=run.file,
        bin_s=BIN_S,
        power_W=power_W,
        speed_mps=bin_speed_mps,
        yaw_rate_radps=bin_yaw_radps if yaw_radps is not None else np.zeros(n_bins),
        surface_index=bin_surface.astype(np.int16),
        surfaces=surfaces,
        has_turning=yaw_radps is not None,
        energy_J=energy_J,
        duration_s=run.duration_s,
        speed_noise_mps=0.0 if from_phases else _sample_noise(speed_mps),
        yaw_noise_radps=_sample_noise(yaw_radps) if yaw_radps is not None else 0.0,
        samples_per_bin=BIN_S / period_s,
        speed_from_phases=from_phases,
        current_proxy=current_proxy(run),
        track_m=_track_m(run),
        mass_kg=_mass_kg(run),
    )


#: The metadata key a converter writes when the log holds motor currents only and the power
#: is that current times a voltage it assumed (benchmarks/real_logs/convert_borealtc.py).
VOLTAGE_ASSUMED_KEY = "voltage_assumed_V"


def current_proxy(run: Run) -> bool:
    """Whether the run's power is a current proxy: the log says, by its `voltage_assumed_V`
    metadata, that its voltage is assumed (a nominal battery voltage) and only the motor
    currents are measured. Such a "power" is V_nom I, and a DC motor's current is its torque
    over its torque constant (I = tau / k_t), so the proxy is proportional to the force at the
    wheels, F: V_nom I = u_0 F with u_0 = V_nom r / k_t the motor's no-load speed at the
    ground [m/s] (k_e = k_t). It does not grow with the speed as the electrical power F v /
    eta does (docs/drive-model.md, "Current-only logs")."""
    return VOLTAGE_ASSUMED_KEY.lower() in run.meta.extra  # (its keys in lower case: RunMeta)


def _track_m(run: Run) -> float:
    """The run's `track_m` metadata [m] when it is a positive number, else NaN (the reader
    refuses a bad one where it needs it: io/reader.py)."""
    try:
        track_m = float(run.meta.extra.get("track_m", "nan"))
    except ValueError:
        return float("nan")
    return track_m if track_m > 0 else float("nan")


def _mass_kg(run: Run) -> float:
    """The mass the run's drive accelerates [kg] (`io.metadata.robot_mass_kg`), NaN: unknown."""
    mass_kg = robot_mass_kg(run.meta)
    return float("nan") if mass_kg is None else mass_kg


def _sample_noise(values: np.ndarray) -> float:
    """The noise of one sample: the median absolute successive difference over 0.6745 and
    sqrt(2) (robust to the minority of differences that are real motion: a MAD estimate of
    white noise's standard deviation), over the differences of known samples (a bag's speed
    is NaN where its odometry has no recent message: rosbag.py)."""
    steps = np.subtract(values[1:], values[:-1])  # np.diff, made absolute in place
    np.abs(steps, out=steps)
    if not np.isfinite(np.sum(steps)):  # (a finite sum: every step is finite)
        steps = steps[np.isfinite(steps)]
    if steps.size < 2:
        return 0.0
    return float(_median(steps) / 0.6745 / np.sqrt(2.0))


#: Every this-many-th value is looked at to guess a median (`_median`).
_MEDIAN_STRIDE = 64


def _median(values: np.ndarray) -> float:
    """`np.median(values)` of finite values (reordered in place), by counting when it can:
    if fewer than half the values lie below a guess `g` (the median of every
    `_MEDIAN_STRIDE`-th) and fewer than half above it, both middle values of the sorted
    values are `g`, and so is their mean. A quantized speed's steps (a few distinct values)
    are so two counting passes instead of a partial sort; else `_median_between`."""
    n = values.size
    sample = values[::_MEDIAN_STRIDE]
    guess = float(np.median(sample))
    below = int(np.count_nonzero(values < guess))
    above = int(np.count_nonzero(values > guess))
    # the middle values have ranks (n - 1) // 2 and n // 2 (0-based)
    if below <= (n - 1) // 2 and above <= n - 1 - n // 2:
        return guess
    return _median_between(values, sample)


def _median_between(values: np.ndarray, sample: np.ndarray) -> float:
    """`np.median(values)` (finite values) from the few values between two bounds that hold
    both middle ranks: the bounds are the sample's values a few of its own ranks either side
    of its median (`_MEDIAN_MARGIN`), checked by counting; the middle ranks' values are then
    those ranks less the count below the lower bound among the values between, partitioned
    as np.median partitions the whole (~4x faster on 72,000 steps of a continuous speed).
    When the bounds miss a middle rank (a sample that is not like the whole), the whole is
    partitioned, as before."""
    n = values.size
    low_rank, high_rank = (n - 1) // 2, n // 2
    if sample.size >= 2 * _MEDIAN_MARGIN + 1:
        bounds = (sample.size // 2 - _MEDIAN_MARGIN, sample.size // 2 + _MEDIAN_MARGIN)
        low, high = np.partition(sample, bounds)[list(bounds)]
        inside = (values >= low) & (values <= high)
        below = int(np.count_nonzero(values < low))
        between = values[inside]
        if below <= low_rank and below + between.size > high_rank:
            ranks = (low_rank - below, high_rank - below)
            return float(np.mean(np.partition(between, ranks)[list(ranks)]))
    return float(np.median(values, overwrite_input=True))


#: The sample's ranks either side of its median that bound the whole's middle values
#: (`_median_between`): the whole's median falls among a sample of m values at a rank whose
#: standard deviation is sqrt(m) / 2 (17 for the 1,125 of 72,000 steps of an hour at 20 Hz),
#: so +-50 ranks miss it about once in 300; a miss costs a count, then the whole's partition.
_MEDIAN_MARGIN = 50


def sample_surfaces(run: Run) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """Each sample's surface as an index into the returned names: the log's `surface` column
    where it names one, else the `surface` metadata, else `UNKNOWN_SURFACE`. None when every
    sample's is the one name (no per-sample array made for it)."""
    default = (run.meta.extra.get("surface") or "").strip() or UNKNOWN_SURFACE
    if run.surface_index is None:
        return None, (default,)
    names = (*run.surface_names, default)
    index = np.where(run.surface_index >= 0, run.surface_index, len(names) - 1)
    return index.astype(np.int16), names


def _bin_means(
    present: np.ndarray,
    starts: np.ndarray,
    count: np.ndarray,
    n_bins: int,
    power_W: np.ndarray,
    speed_mps: np.ndarray,
    yaw_radps: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean of the samples in each bin (`present`: the bins that hold a sample; `starts`:
    where each one's stretch of samples starts, the samples being in time order; `count`: how
    many it holds; NaN in a bin without one: a drop-out). Each stretch summed by
    `np.add.reduceat` (4-9x faster than a weighted `np.bincount` on a 10 kHz log; the same
    sums up to the order of summation, pairwise within a stretch: 2e-15 relative)."""
    out = []
    for values in (power_W, speed_mps, yaw_radps):
        if values is None:
            out.append(np.zeros(n_bins))
            continue
        means = np.full(n_bins, np.nan)
        means[present] = np.add.reduceat(values, starts) / count
        out.append(means)
    return out[0], out[1], out[2]


def _centres(n_bins: int) -> np.ndarray:
    """Each bin's centre [s from the first stamp]: (k + 0.5) x `BIN_S`, in place."""
    centre_s = np.arange(n_bins, dtype=np.float64)
    centre_s += 0.5
    centre_s *= BIN_S
    return centre_s


def _sample_at_centres(
    offset_s: np.ndarray, n_bins: int, centre_s: np.ndarray | None = None
) -> np.ndarray:
    """The sample at each bin's centre: the last stamped at or before it (the first sample
    for a centre before every stamp): `np.searchsorted(offset_s, centres, "right") - 1`
    clipped to the samples, from np.interp of the samples' indices (its search goes on from
    the last one found: ~2x faster than a binary search per centre). Between stamps j and
    j + 1 the interpolated index is j plus a fraction in [0, 1), which its rounding may make
    j + 1: taken back where that stamp is after the centre. (The stamps increase: reader.)
    `centre_s`: `_centres(n_bins)` when the caller has them."""
    centre_s = _centres(n_bins) if centre_s is None else centre_s
    position = np.interp(centre_s, offset_s, np.arange(offset_s.size, dtype=np.float64))
    at = position.astype(np.intp)  # (>= 0: the floor)
    at -= (offset_s[at] > centre_s) & (at > 0)  # (a centre before every stamp: the first)
    return at


def _held(
    offset_s: np.ndarray,
    at: np.ndarray,
    period_s: float,
    power_W: np.ndarray,
    speed_mps: np.ndarray,
    yaw_radps: np.ndarray | None,
    centre_s: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A slow logger's samples on the bins (`at`: the sample at each bin's centre,
    `_sample_at_centres`; `centre_s`: `_centres`): power held over each sample's period (the
    rectangle rule), speed and rate of turn interpolated; NaN inside a gap (`_gap_bins`)."""
    n_bins = at.size
    centre_s = _centres(n_bins) if centre_s is None else centre_s
    gap = _gap_bins(offset_s, at, period_s, centre_s)
    # a sample is the mean over its period (as power's, run.py): placed at the period's middle;
    # power is interpolated as speed is, so that both are seen through the same filter
    middle_s = offset_s + period_s / 2
    power = np.interp(centre_s, middle_s, power_W)
    power[gap] = np.nan
    speed = np.interp(centre_s, middle_s, speed_mps)
    speed[gap] = np.nan
    yaw = np.interp(centre_s, middle_s, yaw_radps) if yaw_radps is not None else np.zeros(n_bins)
    yaw[gap] = np.nan
    return power, speed, yaw


def _gap_bins(
    offset_s: np.ndarray, at: np.ndarray, period_s: float, centre_s: np.ndarray
) -> np.ndarray:
    """The bins inside a gap (indices): their sample (`at`) is followed by a step over
    `GAP_FACTOR` periods, and their centre lies over a period after it. Looked for among
    the bins of those few samples only (`at` does not decrease: each sample's bins are one
    stretch, found by a binary search), not by testing every bin."""
    step_s = np.diff(offset_s, append=offset_s[-1] + period_s)
    before_gap = np.flatnonzero(step_s > GAP_FACTOR * period_s)
    first = np.searchsorted(at, before_gap, "left")
    count = np.searchsorted(at, before_gap, "right") - first
    # the bins of each stretch, one after the other: its first plus 0, 1, ... count - 1
    starts = np.repeat(first - np.cumsum(count) + count, count)
    bins = starts + np.arange(int(count.sum()))
    return bins[centre_s[bins] - offset_s[at[bins]] > period_s]


def speed_from_phases(run: Run, segmentation: Segmentation) -> np.ndarray:
    """The speed [m/s] of a step run without a speed column, from its phases: in each step a
    trapezoid, rising linearly from 0 over its `accel` phase to its cruise speed, holding it
    over `cruise`, falling linearly to 0 over `decel`; 0 elsewhere (idle). The cruise speed is
    the cruise phase's `speed_mps` (the measured or commanded speed, segment.py). The paper's
    experiment: constant acceleration to a set speed, then a stop (Sec. 3)."""
    speed_mps = np.zeros(run.samples)
    by_step: dict[int, dict[str, tuple[int, int, float | None]]] = {}
    for phase in segmentation.phases:
        by_step.setdefault(phase.step, {})[phase.phase] = (
            phase.i_start,
            phase.i_end,
            phase.speed_mps,
        )
    for phases in by_step.values():
        if "cruise" not in phases or phases["cruise"][2] is None:
            continue
        c_start, c_end, cruise_mps = phases["cruise"]
        speed_mps[c_start:c_end] = abs(float(cruise_mps))
        if "accel" in phases:
            a_start, a_end, _ = phases["accel"]
            speed_mps[a_start:a_end] = np.linspace(0.0, cruise_mps, a_end - a_start + 1)[1:]
        if "decel" in phases:
            d_start, d_end, _ = phases["decel"]
            speed_mps[d_start:d_end] = np.linspace(cruise_mps, 0.0, d_end - d_start + 1)[1:]
    return speed_mps


def _bin_starts(run: Run, n_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """The bins that hold a sample and where each one's stretch of samples starts, exactly as
    `_bin_of` over the run's offsets `time_s - time_s[0]` places them (the same floats):
    found per bin (`_starts_per_bin`), or from every sample's bin should that fail a check."""
    found = _starts_per_bin(run, n_bins)
    if found is not None:
        return found
    which = _bin_of(run.time_s - run.time_s[0], n_bins)
    starts = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    return which[starts], starts


def _starts_per_bin(run: Run, n_bins: int) -> tuple[np.ndarray, np.ndarray] | None:
    """`_bin_starts` found per bin, not per sample. The samples are in time order (the reader
    refuses stamps that do not go forwards: io/stamps.py), so a sample's bin never decreases
    with its index and bin k starts at the smallest i whose bin is k or later: within two
    samples of a guess (k x BIN_S / period for a log without a time column, a binary search
    of the stamps for one with), which `_bin_of` of the four samples around it settles and of
    the start and the sample before it checks (None if a check fails)."""
    samples, bin_k = run.samples, np.arange(n_bins)
    if run.stamps_s is None:  # the axis is arange(samples) x period (`Run.time_s`)
        guess = np.ceil(bin_k * (BIN_S / run.sample_period_s)).astype(np.intp)
    else:
        guess = np.searchsorted(run.stamps_s, run.stamps_s[0] + bin_k * BIN_S)
    start = guess - 2
    for shift in (-2, -1, 0, 1):  # how many of the four lie in an earlier bin
        start += _bin_at(run, guess + shift, n_bins) < bin_k
    settled = (_bin_at(run, start, n_bins) >= bin_k) & (_bin_at(run, start - 1, n_bins) < bin_k)
    if not settled.all():
        return None
    start = np.minimum(start, samples)
    present = np.flatnonzero(np.r_[start[1:], samples] > start)
    return present, start[present]


def _bin_at(run: Run, index: np.ndarray, n_bins: int) -> np.ndarray:
    """`_bin_of` of the samples `index` of the run (the same float offsets as the whole axis'
    `time_s - time_s[0]`): -1 for an index before the first sample; an index after the last
    is the last sample's, whose bin is the last (the span ends a period after it)."""
    inside = np.clip(index, 0, run.samples - 1)
    if run.stamps_s is None:
        offset_s = inside.astype(np.float64)
        offset_s *= run.sample_period_s  # (as `Run.time_s`: one rounding of i x period)
    else:
        offset_s = run.stamps_s[inside] - run.stamps_s[0]
    which = _bin_of(offset_s, n_bins)
    which[index < 0] = -1
    return which


def _bin_of(offset_s: np.ndarray, n_bins: int) -> np.ndarray:
    """Each sample's bin. A sample stamped on a bin's start belongs to it: the quotient is
    nudged by 1e-7 of a bin, or 0.15 s / 0.05 s = 2.9999999999999996 would put every such
    sample in the bin before (a jitter of samples between bins that biased the inertial terms
    by ~1% on 100 Hz logs)."""
    quotient = offset_s / BIN_S
    quotient += 1e-7
    np.floor(quotient, out=quotient)  # (in place: one temporary, not four)
    which = quotient.astype(np.intp)
    return np.minimum(which, n_bins - 1, out=which)
