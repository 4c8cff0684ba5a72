"""Checks on the samples of a log: the numbers must be ones we can trust.

Vectorised over samples. Errors name the file and the line. What is harmless and
reported (a short gap) is returned as a `Problem`; what would make a number quietly
wrong is an error. The thresholds are documented in
docs/log-format.md ("What wbpower checks"). The time stamps' checks (period, gaps, a
logger's own pattern) are in `stamps.py`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.holdgrid import HoldGrid, hold_energies_J, hold_grid
from wifibot_power.io.options import MAX_SUPPLY_VOLTAGE_V
from wifibot_power.io.stamps import GAP_FACTOR as GAP_FACTOR  # re-exported
from wifibot_power.io.stamps import MAX_GAP_PCT as MAX_GAP_PCT  # re-exported
from wifibot_power.io.stamps import MAX_GAP_S as MAX_GAP_S  # re-exported
from wifibot_power.io.stamps import _check_period, _check_time, _grid_is_nearer, _on_the_grid
from wifibot_power.io.stamps import _median_10_digits as _median_10_digits  # re-exported
from wifibot_power.run import PAPER_SAMPLE_PERIOD_S, Problem

#: A median current above this is not in amperes (mA read as A) [A]: a battery vehicle's
#: continuous draw stays in the hundreds (a 3 kW unicycle at 84 V: 36 A; a car's starter
#: motor peaks at 200-400 A). Judged on the median, so a 1-3 kW vehicle's peaks never count.
MAX_MEDIAN_CURRENT_A = 500.0
#: A power column whose median stands further than this factor from the median of the voltage
#: x current logged beside it is in another unit: a slip of 1000 (mW read as W) is nearer, on
#: a log scale, to 1000 than to 1 beyond sqrt(1000) ~ 32; real losses between two measuring
#: points (a battery and a motor) stay within a few times.
UNIT_MISTAKE_FACTOR = 30.0
#: A power-only log (no voltage, current or `max_power_W` to judge it by) whose peak is above
#: this is read, with a warning that it could not be judged (a column in mW would read 1000x
#: too high) [W]: the size of the small robots wbpower was built for, not a ceiling.
UNJUDGED_POWER_W = 1000.0
#: Medians for these judgements are taken on at most about this many samples (a strided
#: subsample): a unit mistake holds through a whole column.
_MEDIAN_SAMPLES = 4096
#: A mostly negative channel whose mean power is under this share of another channel's mean
#: absolute power reads almost nothing: a dead sensor with an offset, not a reversed one.
DEAD_CHANNEL_SHARE = 0.05
#: Above this a speed column is not in m/s (a small robot; mm/s or rpm by mistake) [m/s].
ABSURD_SPEED_MPS = 50.0
#: Above this a rate of turn is not in rad/s (deg/s by mistake: 60 deg/s, a slow spin, would
#: read 60 rad/s, ten turns a second) [rad/s].
ABSURD_YAW_RATE_RADPS = 30.0
#: Below this a reading is negative, not an offset around zero: such samples are data
#: (regenerative braking, current lagging a voltage reversal by a sample), read and reported.
NEGATIVE_POWER_W = -1.0
#: Negative samples holding more than this share of the log's absolute energy mean the power
#: is negative most of the time: the current sign is reversed (an error). At 2/3 the negative
#: energy is twice the positive: a zero-mean noise trace (a motor log idling at 0 W) sits
#: near 1/2, a log with brief regeneration far below.
REVERSED_ENERGY_SHARE = 2.0 / 3.0
#: ... and so do samples below `NEGATIVE_POWER_W` in more than this share of the log when
#: the mean power is negative too: the spec's "negative most of the time". Below -1 W, not
#: below 0 W, so that the zero-mean noise of a motor log idling at 0 W (half its samples
#: below 0) is not judged; with a negative mean, so that a motor log idling at -1.3 W (a
#: current sensor's offset) and driving at 40 W is not called reversed (flipping it would
#: make it wrong).
REVERSED_TIME_SHARE = 0.5
#: Consecutive identical readings at a column's maximum that mean the range clipped.
SATURATION_SAMPLES = 10
#: A trace with more repeated consecutive values than this share is quantised or noise-free:
#: a flat top there is a level, not clipping, and is not reported.
QUANTISED_SHARE = 0.5
#: A voltage column's flat top is clipping only when it stands this far above the column's
#: median: a regulated supply sits flat at its set point while the robot idles (a 2-decimal
#: logger reads 12.80 V for seconds) and sags under load, so its top is a level as a rule.
#: Power and current have no such level at their top (the robot's load is noisy there).
SATURATION_ABOVE_MEDIAN = 1.05


def check_samples(
    file: str, time_s: np.ndarray | None, power_W: np.ndarray, **options: object
) -> tuple[float, list[Problem]]:
    """Validate samples; return the sample period [s] and the problems that did not stop
    reading: `check_log_samples` (its keyword options) without the grid, which a reader
    needs and a check alone does not."""
    period_s, problems, _ = check_log_samples(file, time_s, power_W, **options)
    return period_s, problems


def check_log_samples(
    file: str,
    time_s: np.ndarray | None,
    power_W: np.ndarray,
    *,
    line_of: Callable[[int], int] | None = None,
    first_data_line: int = 2,
    default_period_s: float = PAPER_SAMPLE_PERIOD_S,
    measured: dict[str, np.ndarray] | None = None,
    voltages: frozenset[str] = frozenset(),
    scale: PowerScale | None = None,
) -> tuple[float, list[Problem], HoldGrid | None]:
    """Validate samples: the sample period [s], the problems that did not stop reading, and
    the even grid (`holdgrid.hold_grid`) the samples are to be read on when a logger stamps
    rows as they arrive (bursty or uneven stamps), else None.

    `line_of(i)` is the file line of sample i (for messages); `measured` holds the columns the
    power was computed from (clipping shows in a current column, not always in the product),
    `voltages` the names of those that are voltages (`SATURATION_ABOVE_MEDIAN`); `scale` what
    the log says of its robot, to judge absurd power by (`check_power_scale`).
    """
    if line_of is None:
        line_of = lambda index: first_data_line + index  # noqa: E731
    low_W, high_W = _check_power(file, power_W, line_of)
    scale = scale or PowerScale(voltages=voltages)
    unjudged = check_power_scale(
        file, power_W, high_W, measured or {"power": power_W}, scale, line_of
    )
    grid = None
    if time_s is None:
        period_s = default_period_s
        problems: list[Problem] = []
    else:
        period_s, problems, stamped_gaps = _check_time(file, time_s, line_of, default_period_s)
        _check_period(file, period_s)
        if stamped_gaps is not None:  # the note on the stamps comes first: it says the grid
            grid = hold_grid(time_s, stamped_gaps, period_s)
            energies_J = hold_energies_J(time_s, power_W, stamped_gaps, period_s, grid)
            problems[0] = _on_the_grid(problems[0], energies_J)
            if not _grid_is_nearer(energies_J):
                grid = None
    negative = _negative_samples(power_W, time_s, period_s, low_W)
    if negative is not None:
        problems.insert(0, negative)
    if unjudged is not None:
        problems.insert(0, unjudged)
    for name, values in (measured or {"power": power_W}).items():
        # the power's maximum is known already: one pass over the samples fewer
        peak = high_W if values is power_W else None
        voltage = name in scale.voltages
        _check_saturation(file, name, values, time_s, period_s, line_of, peak, voltage)
    return period_s, problems, grid


def check_speed(
    file: str, name: str, speed_mps: np.ndarray, *, line_of: Callable[[int], int]
) -> None:
    """A speed column must hold a finite number in every sample (a gap in it would be a
    quietly wrong phase); any sign is kept (a robot may reverse)."""
    _check_motion(
        file, name, speed_mps, line_of, ("speed", "m/s", ABSURD_SPEED_MPS),
        "the speed column must be in m/s (mm/s or rpm need converting)",
    )  # fmt: skip


def check_yaw_rate(
    file: str, name: str, yaw_rate_radps: np.ndarray, *, line_of: Callable[[int], int]
) -> None:
    """A rate-of-turn column must hold a finite number in every sample, in rad/s."""
    _check_motion(
        file, name, yaw_rate_radps, line_of, ("yaw rate", "rad/s", ABSURD_YAW_RATE_RADPS),
        "the rate of turn must be in rad/s (deg/s needs converting; a wheel-speed pair "
        "needs the track width in m)",
    )  # fmt: skip


def _check_motion(
    file: str,
    name: str,
    values: np.ndarray,
    line_of: Callable[[int], int],
    quantity: tuple[str, str, float],
    fix: str,
) -> None:
    """Every value finite, and none over the quantity's absurd limit (a unit mistake)."""
    if not values.size:
        return
    what, unit, limit = quantity
    _require_finite(values, what, file, line_of, f", column '{name}'")
    high = float(np.max(np.abs(values)))
    if high > limit:
        index = int(np.argmax(np.abs(values) > limit))
        raise LogError(
            f"absurd {what} ({values[index]:.4g} {unit}, over {limit:g} {unit})",
            file=file,
            where=f"line {line_of(index)}, column '{name}'",
            fix=fix,
        )


def _check_power(
    file: str, power_W: np.ndarray, line_of: Callable[[int], int]
) -> tuple[float | None, float | None]:
    """The power's smallest and largest sample (None without samples), once checked."""
    if not power_W.size:
        return None, None
    low_W, high_W = _require_finite(power_W, "power", file, line_of)
    if low_W < 0:
        _check_sign(
            file,
            power_W,
            "power",
            "the current sign looks reversed: give --flip-current (or drop it if given), or "
            "check the columns used",
        )
    return low_W, high_W


@dataclass(frozen=True)
class PowerScale:
    """What a log says of its robot, to judge its power by (log-format.md, "Bad input": never a
    fixed ceiling). `max_power_W` and where it was set (`--max-power`, "metadata line 3");
    the names of the measured columns that are voltages and currents; and, from the head of
    the file, a power column's median beside the median voltage x current (or voltage alone)
    logged next to it (`head`: power column name, median power [W], median V x I [W] or None,
    median V [V] or None)."""

    max_power_W: float | None = None
    max_power_where: str = ""
    voltages: frozenset[str] = frozenset()
    currents: frozenset[str] = frozenset()
    head: tuple[str, float, float | None, float | None] | None = None


def check_power_scale(
    file: str,
    power_W: np.ndarray,
    high_W: float | None,
    measured: dict[str, np.ndarray],
    scale: PowerScale,
    line_of: Callable[[int], int],
) -> Problem | None:
    """Absurd power, judged against the log's own robot: over its `max_power_W` (or
    `--max-power`); a voltage or current column whose median is not in V or A; a power column
    orders of magnitude off the voltage x current (or the voltage) logged beside it. A
    power-only log with none of these to judge it by is read; above `UNJUDGED_POWER_W` with a
    warning (returned) that says so. Errors otherwise; None when nothing is to be said."""
    if high_W is None:
        return None
    if scale.max_power_W is not None:
        if high_W > scale.max_power_W:
            index = int(np.argmax(power_W > scale.max_power_W))
            raise LogError(
                f"power {power_W[index]:.4g} W is over the robot's max_power_W "
                f"{scale.max_power_W:g} W ({scale.max_power_where})",
                file=file,
                where=f"line {line_of(index)}",
                fix="a unit mistake (mW read as W, mA as A) or the wrong columns; if this robot "
                "draws more, raise max_power_W (metadata or runs.csv) or --max-power",
            )
    for name, values in measured.items():
        for names, limit, quantity, unit, units in (
            (scale.voltages, MAX_SUPPLY_VOLTAGE_V, "voltage", "V", "volts"),
            (scale.currents, MAX_MEDIAN_CURRENT_A, "current", "A", "amperes"),
        ):
            if name in names and (median := _median_abs(values)) > limit:
                raise LogError(
                    f"{quantity} column '{name}' reads a median {median:.4g} {unit}, over "
                    f"{limit:g} {unit}: not {units}",
                    file=file,
                    where=f"column '{name}'",
                    fix=f"a unit mistake: m{unit} in a column named {unit}? name it *_m{unit}, "
                    "or convert it",
                )
    if scale.head is not None:
        name, power_median_W, vi_median_W, volts_median_V = scale.head
        if vi_median_W is not None and vi_median_W > 0 and power_median_W > 0:
            ratio = power_median_W / vi_median_W
            if not 1 / UNIT_MISTAKE_FACTOR <= ratio <= UNIT_MISTAKE_FACTOR:
                raise LogError(
                    f"power column '{name}' is {ratio:.3g} times the voltage x current logged "
                    f"beside it (medians {power_median_W:.4g} W and {vi_median_W:.4g} W over "
                    "the first lines)",
                    file=file,
                    where=f"column '{name}'",
                    fix="a unit mistake: mW in a column named W (or mA, mV as A, V)? fix the "
                    "column's name, or read the power from --current-column and "
                    "--voltage-column",
                )
        elif vi_median_W is None and volts_median_V:
            amps = power_median_W / volts_median_V
            if amps > MAX_MEDIAN_CURRENT_A:
                raise LogError(
                    f"power column '{name}' (median {power_median_W:.4g} W over the first "
                    f"lines) would be {amps:.4g} A at the {volts_median_V:.4g} V logged beside "
                    f"it, over {MAX_MEDIAN_CURRENT_A:g} A",
                    file=file,
                    where=f"column '{name}'",
                    fix="a unit mistake: mW in a column named W? name it *_mW, or convert it",
                )
        return None
    judged = scale.max_power_W is not None or any(
        name in scale.voltages or name in scale.currents for name in measured
    )
    if judged or high_W <= UNJUDGED_POWER_W:
        return None
    return Problem(
        "unjudged_power",
        f"peak power {high_W:.4g} W with no max_power_W, voltage or current to judge it by: "
        "read as W (a column holding mW would read 1000 times too high); give max_power_W "
        "(metadata or runs.csv) or --max-power to have it checked",
    )


def _median_abs(values: np.ndarray) -> float:
    """The median magnitude of a column, from a strided subsample of ~`_MEDIAN_SAMPLES`."""
    if not values.size:
        return 0.0
    stride = max(1, values.size // _MEDIAN_SAMPLES)
    return float(np.median(np.abs(values[::stride])))


def _check_sign(file: str, power_W: np.ndarray, what: str, fix: str) -> None:
    """Power negative most of the time (`REVERSED_ENERGY_SHARE` of the energy, or
    `REVERSED_TIME_SHARE` of the samples below `NEGATIVE_POWER_W`): a reversed current sign."""
    negative_J = -float(np.sum(power_W, where=power_W < 0))
    positive_J = float(np.sum(power_W, where=power_W > 0))
    total_J = negative_J + positive_J
    if negative_J > REVERSED_ENERGY_SHARE * total_J:
        why = f"negative samples hold {100 * negative_J / total_J:.0f}% of its energy"
    else:
        below_share = np.count_nonzero(power_W < NEGATIVE_POWER_W) / power_W.size
        if below_share <= REVERSED_TIME_SHARE or positive_J >= negative_J:
            return  # mostly above -1 W, or a mean power >= 0: not reversed
        why = f"{100 * below_share:.0f}% of its samples below {NEGATIVE_POWER_W:g} W"
    raise LogError(
        f"{what} is negative most of the time (mean {power_W.mean():.4g} W; {why})",
        file=file,
        fix=fix,
    )


def check_channels(file: str, channels_W: dict[str, np.ndarray]) -> None:
    """Each channel of a summed log is checked for a reversed sign on its own: one motor's
    sensor wired the other way would otherwise cancel the other's power in the sum, quietly.
    A channel that is mostly negative but reads almost nothing (under `DEAD_CHANNEL_SHARE`
    of the others' mean absolute power) is named as a dead sensor instead: a current offset
    of a few mA, not a reversal."""
    for name, channel_W in channels_W.items():
        if not (channel_W.size and channel_W.min() < 0):
            continue
        others_W = [float(np.mean(np.abs(c))) for n, c in channels_W.items() if n != name]
        level_W = abs(float(channel_W.mean()))
        if others_W and level_W < DEAD_CHANNEL_SHARE * max(others_W):
            fix = (
                f"its sensor looks dead: it reads {level_W:.3g} W against {max(others_W):.3g} W "
                "on another channel; check its current sensor (to read one channel alone, "
                "name its columns with --current-column and --voltage-column)"
            )
        else:
            fix = (
                "that channel's current sign looks reversed: negate its column in the log "
                "(--flip-current negates every channel), or check the columns used"
            )
        _check_sign(file, channel_W, f"the power of channel '{name}'", fix)


def _negative_samples(
    power_W: np.ndarray, time_s: np.ndarray | None, period_s: float, low_W: float | None = None
) -> Problem | None:
    """Samples below `NEGATIVE_POWER_W` in a log whose power is positive on the whole: data,
    read and counted in the energy, reported as one problem (log-format.md, negative power)."""
    if not power_W.size:
        return None
    if (power_W.min() if low_W is None else low_W) >= NEGATIVE_POWER_W:
        return None
    below = power_W < NEGATIVE_POWER_W
    count = int(np.count_nonzero(below))
    lowest = int(np.argmin(power_W))
    first = int(np.argmax(below))
    t_first_s = float(time_s[first]) if time_s is not None else first * period_s
    t_lowest_s = float(time_s[lowest]) if time_s is not None else lowest * period_s
    energy_J = float(np.sum(power_W, where=below)) * period_s
    return Problem(
        "negative",
        f"{count} sample(s) of negative power below {NEGATIVE_POWER_W:g} W, the lowest "
        f"{power_W[lowest]:.4g} W at t = {t_lowest_s:.6g} s, {energy_J:.3g} J in all: read as "
        "data (regenerative braking, or current lagging a voltage reversal) and counted in "
        "the energy",
        t_first_s,
        count * period_s,
    )


def _check_saturation(
    file: str,
    name: str,
    values: np.ndarray,
    time_s: np.ndarray | None,
    period_s: float,
    line_of: Callable[[int], int],
    peak: float | None = None,
    supply: bool = False,
) -> None:
    """Flat stretches at the column's maximum: the analyser range clipped there, so the energy
    there is unknown. log-format.md lists clipped readings as bad input: an error, however
    short. `supply`: a voltage column, whose flat top is its set point unless it stands
    `SATURATION_ABOVE_MEDIAN` above the median."""
    if values.size < SATURATION_SAMPLES:
        return
    peak = values.max() if peak is None else peak
    at_peak = values == peak
    if np.count_nonzero(at_peak) < SATURATION_SAMPLES:
        return
    if not peak > 0:
        return  # a column negative throughout (a reversed sensor, checked elsewhere)
    if supply and not peak > SATURATION_ABOVE_MEDIAN * np.median(values):
        return  # the supply's set point (at idle), not a clip
    stop = np.zeros(1, dtype=np.int8)  # int8 throughout: a list [0] would make it int64
    edges = np.diff(np.concatenate((stop, at_peak.view(np.int8), stop)))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    lengths = ends - starts
    keep = lengths >= SATURATION_SAMPLES
    if not keep.any():
        return
    # Clipping or a level is told by the rest of the trace, not by where the median lies:
    # a range that clips through most of a run (a cruise above it) puts the median at the
    # clip, so "well above the median" missed exactly the worst clips. Consecutive samples
    # both off the top: where most repeat, the trace is noise-free or coarsely quantised and
    # a flat top is a level; too few to see their noise: a steady load. (Masks only: no
    # full-size copy of the column.)
    off = ~at_peak
    pairs = off[1:] & off[:-1]
    pair_count = np.count_nonzero(pairs)
    if np.count_nonzero(off) < SATURATION_SAMPLES or not pair_count:
        return
    repeats = np.count_nonzero((values[1:] == values[:-1]) & pairs)
    if repeats > QUANTISED_SHARE * pair_count:
        return
    starts, lengths = starts[keep], lengths[keep]
    longest = int(np.argmax(lengths))
    start = int(starts[longest])
    t_start_s = float(time_s[start]) if time_s is not None else start * period_s
    raise LogError(
        f"'{name}' clipped: {lengths.sum()} samples ({lengths.sum() * period_s:.4g} s) flat at "
        f"its maximum {peak:.6g} in {lengths.size} stretch(es), longest {lengths[longest]} "
        f"samples from t = {t_start_s:.6g} s",
        file=file,
        where=f"line {line_of(start)}",
        fix="the analyser range clipped, so energy there is unknown; re-record with a higher range",
    )


def _require_finite(
    values: np.ndarray,
    quantity: str,
    file: str,
    line_of: Callable[[int], int],
    column: str = "",
) -> tuple[float, float]:
    """The smallest and largest value, once every value is checked to be a finite number:
    else a one-line error naming the line (and `column`) of the first that is not. min/max
    first: on a clean log (the usual case) no full-size mask is made."""
    low, high = values.min(), values.max()
    if not (np.isfinite(low) and np.isfinite(high)):
        index = int(np.argmax(~np.isfinite(values)))
        raise LogError(
            f"{quantity} is missing, NaN or inf ({values[index]})",
            file=file,
            where=f"line {line_of(index)}{column}",
            fix="fix or delete that line",
        )
    return float(low), float(high)


#: How far a power column and the product of the voltage and current columns beside it
#: may disagree, as a share of their energy, before the log is refused
#: (`check_power_twice`). Each of voltage and current is good to about 1% on the loggers
#: seen (INA219/INA226-class sensors 0.5-1%, a Keysight N6705 0.1%), so their product to
#: about 2%; an instrument's power averaged over a sample interval (mean of V x I) differs
#: from the product of the averaged V and I by the covariance within the interval, a few
#: percent at most for a PWM motor load. 5% leaves room for both; a mW column in a W
#: column (1000x) or a wrong scale of 1.5x is far outside.
POWER_TWICE_TOLERANCE = 0.05


def _written_step(values: np.ndarray, sample: int = 10_000) -> float:
    """The step of the decimals a column is written with (0.01 for "12.61"), read off its
    first `sample` finite values: the largest 10^-d of which they are all multiples (to
    1e-6 of a step); 0 where they carry more than 9 decimals."""
    head = values[:sample]
    head = head[np.isfinite(head)]
    for decimals in range(10):
        scaled = head * 10.0**decimals
        if np.all(np.abs(scaled - np.rint(scaled)) <= 1e-6 + 1e-12 * np.abs(scaled)):
            return 10.0**-decimals
    return 0.0


def _twice_sums(
    power_W: np.ndarray, current_A: np.ndarray, voltage_V: np.ndarray, *, masked: bool = False
) -> tuple[float, float, float, float, float, int]:
    """Over the samples where the power, current and voltage are all finite numbers: the sums
    of P, V x I, the larger of |P|'s and |V x I|'s, of |V| and of |I|, and how many samples.
    When every sample is finite (the sums of P and V x I are: a NaN or an inf makes them so),
    plain sums through one temporary (V x I, then each |.| in turn in its place: a fresh
    array's first writes, the kernel's page faults, were half the check's time on 10 kHz
    logs); else `masked` sums (as `masked=True` forces)."""
    product_W = current_A * voltage_V
    column_J, product_J = float(np.sum(power_W)), float(np.sum(product_W))
    if not masked and np.isfinite(column_J) and np.isfinite(product_J):
        size = np.abs(product_W, out=product_W)  # (V x I is not needed once summed)
        scale_J = float(np.sum(size))
        scale_J = max(float(np.sum(np.abs(power_W, out=size))), scale_J)
        size_V = float(np.sum(np.abs(voltage_V, out=size)))
        size_A = float(np.sum(np.abs(current_A, out=size)))
        return column_J, product_J, scale_J, size_V, size_A, int(power_W.size)
    both = np.isfinite(power_W)
    both &= np.isfinite(product_W)
    column_J = float(np.sum(power_W, where=both))  # per sample: energy / sample period
    product_J = float(np.sum(product_W, where=both))
    size = np.abs(power_W)
    scale_J = float(np.sum(size, where=both))
    scale_J = max(scale_J, float(np.sum(np.abs(product_W, out=product_W), where=both)))
    size_V = float(np.sum(np.abs(voltage_V, out=size), where=both))
    size_A = float(np.sum(np.abs(current_A, out=size), where=both))
    return column_J, product_J, scale_J, size_V, size_A, int(np.count_nonzero(both))


def check_power_twice(
    file: str,
    power: tuple[str, np.ndarray],
    current: tuple[str, np.ndarray],
    voltage: tuple[str, np.ndarray],
) -> None:
    """A log that says its power twice (a power column, and voltage and current columns
    of the same channel) must agree with itself: the energy of the power column and that of
    voltage x current, sample by sample, within `POWER_TWICE_TOLERANCE` of the larger plus
    what rounding the numbers as written can make (half a step of the decimals of each
    column, `_written_step`), over the samples where all three are finite numbers. Else a
    one-line error naming the columns: the power column would otherwise be trusted
    whatever it holds (issue 29).

    P = V x I (Joule's law for the electrical power a DC load draws)."""
    (power_name, power_W), (current_name, current_A), (voltage_name, voltage_V) = (
        power,
        current,
        voltage,
    )
    column_J, product_J, scale_J, size_V, size_A, count = _twice_sums(power_W, current_A, voltage_V)
    # the numbers as written are rounded: V x I is off by up to half a step of each,
    # 0.5 (|V| step_A + |I| step_V + step_W + step_V step_A) a sample, summed
    step_V, step_A, step_W = (_written_step(x) for x in (voltage_V, current_A, power_W))
    rounding_J = 0.5 * (step_A * size_V + step_V * size_A + (step_W + step_V * step_A) * count)
    if abs(column_J - product_J) <= POWER_TWICE_TOLERANCE * scale_J + rounding_J:
        return
    ratio = f"{column_J / product_J:.4g}x" if product_J else "not 0 where they give 0"
    raise LogError(
        f"column '{power_name}' disagrees with '{voltage_name}' x '{current_name}' (its energy "
        f"is {ratio} theirs, over {POWER_TWICE_TOLERANCE:.0%} apart)",
        file=file,
        fix="check the units of the columns (a power in mW in a W column?), or name the ones "
        "to use with --power-column, or --current-column and --voltage-column",
    )
