"""Checks on the samples of a log: the numbers must be ones we can trust.

Vectorised over samples. Errors name the file and the line. What is harmless and
reported (a short gap) is returned as a `Problem`; what would make a number quietly
wrong is an error. The thresholds are documented in
docs/log-format.md ("What wbpower checks").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.run import PAPER_SAMPLE_PERIOD_S, Problem

#: Above this the robot cannot be drawing power: a unit or column mistake.
ABSURD_POWER_W = 1000.0
#: A mostly negative channel whose mean power is under this share of another channel's mean
#: absolute power reads almost nothing: a dead sensor with an offset, not a reversed one.
DEAD_CHANNEL_SHARE = 0.05
#: Above this a speed column is not in m/s (a small robot; mm/s or rpm by mistake) [m/s].
ABSURD_SPEED_MPS = 50.0
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
#: A single dropped-sample gap longer than this stops the analysis [s] ...
MAX_GAP_S = 0.05
#: ... unless it is at most this many sample periods of the log's own spacing: a slow logger
#: (~18 Hz: 55 ms a sample) that drops a sample, or three in a row, is not refused.
MAX_GAP_PERIODS = 3
#: Dropped samples adding up to more than this share of the log stop the analysis [%], when
#: they also add up to more than `MAX_GAP_PERIODS` sample periods: else a short log from a
#: slow logger (30 samples at 1 Hz) that drops one sample would be refused, which the spec
#: says it is not.
MAX_GAP_PCT = 1.0
#: A step between time stamps above this many sample periods is a gap (jitter stays below).
GAP_FACTOR = 1.5
#: Time stamps whose mean step (between gaps) is further than this from their median [%]
#: are uneven (a logger stamping on arrival, e.g. ROS): the period is then their mean, so
#: that durations and energies follow the stamps (the bar is MAX_GAP_PCT's: as much time
#: miscounted as gaps that make energies wrong).
UNEVEN_PCT = 1.0
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
    file: str,
    time_s: np.ndarray | None,
    power_W: np.ndarray,
    *,
    line_of: Callable[[int], int] | None = None,
    first_data_line: int = 2,
    default_period_s: float = PAPER_SAMPLE_PERIOD_S,
    measured: dict[str, np.ndarray] | None = None,
    voltages: frozenset[str] = frozenset(),
) -> tuple[float, list[Problem]]:
    """Validate samples; return the sample period [s] and the problems that did not stop reading.

    `line_of(i)` is the file line of sample i (for messages); `measured` holds the columns the
    power was computed from (clipping shows in a current column, not always in the product),
    `voltages` the names of those that are voltages (`SATURATION_ABOVE_MEDIAN`).
    """
    if line_of is None:
        line_of = lambda index: first_data_line + index  # noqa: E731
    low_W, high_W = _check_power(file, power_W, line_of)
    if time_s is None:
        period_s = default_period_s
        problems: list[Problem] = []
    else:
        period_s, problems = _check_time(file, time_s, line_of, default_period_s)
    negative = _negative_samples(power_W, time_s, period_s, low_W)
    if negative is not None:
        problems.insert(0, negative)
    for name, values in (measured or {"power": power_W}).items():
        # the power's maximum is known already: one pass over the samples fewer
        peak = high_W if values is power_W else None
        _check_saturation(file, name, values, time_s, period_s, line_of, peak, name in voltages)
    return period_s, problems


def check_speed(
    file: str, name: str, speed_mps: np.ndarray, *, line_of: Callable[[int], int]
) -> None:
    """A speed column must hold a finite number in every sample (a gap in it would be a
    quietly wrong phase); any sign is kept (a robot may reverse)."""
    if not speed_mps.size:
        return
    _require_finite(speed_mps, "speed", file, line_of, f", column '{name}'")
    high = float(np.max(np.abs(speed_mps)))
    if high > ABSURD_SPEED_MPS:
        index = int(np.argmax(np.abs(speed_mps) > ABSURD_SPEED_MPS))
        raise LogError(
            f"absurd speed ({speed_mps[index]:.4g} m/s, over {ABSURD_SPEED_MPS:g} m/s)",
            file=file,
            where=f"line {line_of(index)}, column '{name}'",
            fix="the speed column must be in m/s (mm/s or rpm need converting)",
        )


def _check_time(
    file: str, time_s: np.ndarray, line_of: Callable[[int], int], default_period_s: float
) -> tuple[float, list[Problem]]:
    if not time_s.size:
        return default_period_s, []
    if time_s.size < 2:
        _time_error(file, time_s, np.diff(time_s), line_of)
        return default_period_s, []
    # one diff serves every check on a clean log (the usual case): steps all finite and > 0
    # with finite ends mean every stamp is finite and time goes forwards; anything else is
    # found again, exactly as before, by the slow path
    step_s = np.diff(time_s)
    low_s, high_s = step_s.min(), step_s.max()
    if not (np.isfinite(low_s) and np.isfinite(high_s) and np.isfinite(time_s[0]) and low_s > 0):
        _time_error(file, time_s, step_s, line_of)
    # time stamps carry far fewer than 10 significant digits: drop the float noise of the diff
    period_s, reordered = _median_10_digits(step_s)
    if abs(period_s - default_period_s) <= 1e-6 * default_period_s:
        period_s = default_period_s  # the stated period, not its float-rounded echo
    spacing_s = period_s  # the median step: gaps are judged against it
    gaps = np.empty(0, dtype=np.intp)
    if high_s > GAP_FACTOR * spacing_s:
        if reordered:  # the median sorted the steps in place: a fresh diff (one held at a time)
            step_s = None
            step_s = np.diff(time_s)
            reordered = False
        gaps = np.flatnonzero(step_s > GAP_FACTOR * spacing_s)
    uneven: list[Problem] = []
    # the steps between gaps: their mean is within high - low of their median, so a log
    # spaced evenly to 1% (every analyser's) is not looked at again; their sum is the span
    # less the gaps' steps (no pass over the steps)
    regular = step_s.size - gaps.size
    if regular and high_s - low_s > UNEVEN_PCT / 100.0 * spacing_s:
        gap_steps_s = float(np.sum(time_s[gaps + 1] - time_s[gaps]))
        mean_s = float(f"{(float(time_s[-1] - time_s[0]) - gap_steps_s) / regular:.10g}")
        if abs(mean_s - spacing_s) > UNEVEN_PCT / 100.0 * spacing_s:
            period_s = mean_s
            if reordered:
                step_s = None
                step_s = np.diff(time_s)
            longest_s = float(np.max(step_s[step_s <= GAP_FACTOR * spacing_s]))
            uneven.append(
                Problem(
                    "uneven",
                    f"uneven time stamps (steps of {1e3 * float(low_s):.3g}-"
                    f"{1e3 * longest_s:.3g} ms between gaps): the sample period is their "
                    f"mean, {1e3 * mean_s:.4g} ms, so that durations and energies follow the "
                    f"stamps (their median, {1e3 * spacing_s:.4g} ms, would count "
                    f"{100 * (spacing_s / mean_s - 1):+.2g}% of both)",
                )
            )
    del step_s
    if not gaps.size:
        return period_s, uneven
    missing_s = (time_s[gaps + 1] - time_s[gaps]) - period_s
    longest = int(np.argmax(missing_s))
    span_s = float(time_s[-1] - time_s[0]) + period_s
    missing_pct = 100.0 * float(missing_s.sum()) / (span_s if span_s > 0 else 1.0)
    summary = (
        f"{gaps.size} gap(s) of dropped samples, {missing_s.sum():.4g} s in all "
        f"({missing_pct:.2g}% of the log), longest {missing_s[longest]:.4g} s after "
        f"t = {time_s[gaps[longest]]:.6g} s"
    )
    limit_s = max(MAX_GAP_S, MAX_GAP_PERIODS * period_s)
    too_much = missing_pct > MAX_GAP_PCT and float(missing_s.sum()) > MAX_GAP_PERIODS * period_s
    if missing_s[longest] > limit_s or too_much:
        raise LogError(
            summary,
            file=file,
            where=f"line {line_of(int(gaps[longest]) + 1)}",
            fix=f"a gap over {limit_s:.4g} s (the longer of {MAX_GAP_S:g} s and "
            f"{MAX_GAP_PERIODS} sample periods), or gaps adding up to over {MAX_GAP_PCT:g}% of "
            f"the log and over {MAX_GAP_PERIODS} sample periods, make energies wrong; "
            "re-record, or cut the log at the gap",
        )
    problems = [
        Problem(
            "gap",
            f"line {line_of(int(index) + 1)}: {missing * 1e3:.4g} ms of samples dropped after "
            f"t = {time_s[index]:.6g} s",
            float(time_s[index]) + period_s,
            float(missing),
        )
        for index, missing in zip(gaps, missing_s, strict=True)
    ]
    return period_s, uneven + problems


def _time_error(
    file: str, time_s: np.ndarray, step_s: np.ndarray, line_of: Callable[[int], int]
) -> None:
    """Raise the error for time stamps that are not all finite or do not go forwards: the
    first non-finite stamp, else the first step that is not forwards; else return."""
    if not np.isfinite(time_s).all():
        index = int(np.argmax(~np.isfinite(time_s)))
        raise LogError(
            "time is missing, NaN or inf",
            file=file,
            where=f"line {line_of(index)}",
            fix="fix or delete that line",
        )
    if not (step_s <= 0).any():
        return  # finite stamps whose steps overflow (1e308 apart): nothing wrong here
    index = int(np.argmax(step_s <= 0))
    what = "is duplicated" if step_s[index] == 0 else "goes backwards"
    raise LogError(
        f"time {what} (t = {time_s[index + 1]:.7g} s after {time_s[index]:.7g} s)",
        file=file,
        where=f"line {line_of(index + 1)}",
        fix="the log is out of order or two logs were joined; sort or split it",
    )


#: Every this-many-th step is looked at to guess the median (`_median_10_digits`).
_MEDIAN_STRIDE = 64


def _median_10_digits(step_s: np.ndarray) -> tuple[float, bool]:
    """`float(f"{np.median(step_s):.10g}")`, without sorting the steps when it can be had by
    counting: the median of a strided subsample gives a guess `c` (10 significant digits);
    if fewer than half the steps lie below the band of values that round to `c` and fewer
    than half above it, both middle steps lie in that band, so their mean rounds to `c` too
    (correctly rounded printing is monotonic). Two counting passes instead of a partial
    sort (about 25 ns a step, as much as parsing a short line); when the guess misses (an
    irregular log) the steps are sorted in place as before: the second value says whether
    `step_s` was reordered so."""
    n = step_s.size
    guess = float(np.median(step_s[::_MEDIAN_STRIDE]))
    rounded = f"{guess:.10g}"
    center = float(rounded)
    if np.isfinite(center) and center > 0:
        unit = 10.0 ** (np.floor(np.log10(center)) - 9)  # one unit in the 10th digit
        for share in (0.49, 0.049):  # narrower if the digit's unit changes below `center`
            low, high = center - share * unit, center + share * unit
            if f"{low:.10g}" == rounded and f"{high:.10g}" == rounded:
                below = int(np.count_nonzero(step_s < low))
                above = int(np.count_nonzero(step_s > high))
                # the middle steps have ranks (n - 1) // 2 and n // 2 (0-based)
                if below <= (n - 1) // 2 and above <= n - 1 - n // 2:
                    return center, False
                break
    return float(f"{float(np.median(step_s, overwrite_input=True)):.10g}"), True


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
    if high_W > ABSURD_POWER_W:
        index = int(np.argmax(power_W > ABSURD_POWER_W))
        raise LogError(
            f"absurd power ({power_W[index]:.4g} W, over {ABSURD_POWER_W:g} W)",
            file=file,
            where=f"line {line_of(index)}",
            fix="check the units (mA vs A, mW vs W) and the columns used",
        )
    return low_W, high_W


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
    product_W = current_A * voltage_V
    both = np.isfinite(power_W) & np.isfinite(product_W)
    column_J = float(np.sum(power_W, where=both))  # per sample: energy / sample period
    product_J = float(np.sum(product_W, where=both))
    scale_J = max(
        float(np.sum(np.abs(power_W), where=both)), float(np.sum(np.abs(product_W), where=both))
    )
    # the numbers as written are rounded: V x I is off by up to half a step of each
    step_V, step_A, step_W = (_written_step(x) for x in (voltage_V, current_A, power_W))
    rounding_W = 0.5 * (np.abs(voltage_V) * step_A + np.abs(current_A) * step_V + step_W)
    rounding_J = float(np.sum(rounding_W, where=both)) + 0.5 * step_V * step_A * both.sum()
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
