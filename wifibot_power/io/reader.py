"""Read one log, in any format wbpower knows, into a `Run`.

The work is split as pvlib's iotools splits it: `transport.py` holds what every format
shares (bytes, decompression, lines, the CSV parse into numpy columns, line numbers, a cut
last line), `formats/` one module per format that owns its column names behind one
interface (`formats.base.LogFormat`), and `formats.FORMATS` the only list of formats. This
module puts them together: it picks the format, applies the column options (the same for
every format), makes power (the sum of the channels), time and speed, and checks the
samples (`validate.py`).

What is read where the spec is silent is described in docs/log-format.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.column_options import (
    _power_sources,
    _speed_column,
    _time_source,
    _turning_columns,
)
from wifibot_power.io.columns import (
    PowerSource,
)
from wifibot_power.io.formats import LogFormat, Preamble, TimeSource, file_format_of, format_of
from wifibot_power.io.formats.base import SNIFF_LINES, TurningColumns
from wifibot_power.io.formats.files import samples_to_run
from wifibot_power.io.holdgrid import HoldGrid
from wifibot_power.io.kinematics import lateral_problem, slow_speed_problem
from wifibot_power.io.metadata import build_meta
from wifibot_power.io.options import ReadOptions, log_stem
from wifibot_power.io.power_scale import power_scale
from wifibot_power.io.transport import (
    Columns,
    Content,
    cut_line_error,
    decode,
    head_ends_cut,
    head_lines,
    read_bytes,
    read_columns,
    require_regular,
)
from wifibot_power.io.validate import (
    PowerScale,
    check_channels,
    check_log_samples,
    check_power_twice,
    check_speed,
    check_yaw_rate,
)
from wifibot_power.run import PAPER_SAMPLE_PERIOD_S, Problem, Run, RunMeta

__all__ = ["read_bytes", "read_log"]

#: Lines of the head split off first (`_preamble`): enough for a preamble, its header and the
#: data lines the format sniffs after it (`SNIFF_LINES`) in every log seen so far.
FIRST_LINES = 256


def read_log(
    path: str | Path,
    options: ReadOptions | None = None,
    overrides: dict[str, str] | None = None,
    *,
    data: bytes | None = None,
    origin: str | None = None,
) -> Run:
    """Read a log file into a `Run`; `overrides` (manifest values) win over the file's metadata.

    `data` gives the (decompressed) bytes instead of reading `path`; `origin` says where the
    overrides come from (e.g. "runs.csv line 4"), so a contradiction names that row.
    Raises `LogError` with a one-line message for anything it cannot read honestly.
    """
    options = options or ReadOptions()
    path = Path(path)
    file_format = file_format_of(path)
    if file_format is not None:  # a bag or a recording: read whole by its own library
        require_regular(path)  # (a FIFO named *.jls would block its library's open forever)
        samples = file_format.read_samples(path, options)
        return samples_to_run(path, file_format, samples, options, overrides, origin)
    text = _parse(path, options, data)
    values, where, meta = _metadata(path, text, options, overrides, origin)
    scale = power_scale(
        path, text.content, text.head, text.pre, text.sources, options, values, where
    )
    samples = _samples(path, text, options, values, meta)
    period_s, problems, grid = _checked(path, text, samples, meta, scale)
    if samples.time_s is not None and period_s != meta.sample_period_s:
        values["sample_period_s"] = repr(period_s)
        meta = _meta(path, text, values, where)
    if grid is not None:  # a logger stamping rows as they arrive: read by sample and hold
        samples.on_grid(grid)
    return Run(
        file=str(path),
        format=text.pre.format,
        meta=meta,
        stamps_s=samples.time_s,  # None without a time column: `Run.time_s` makes the axis
        power_W=samples.power_W,
        problems=(
            *_assumptions(text.sources, text.time_source, options, values, samples.size),
            *text.time_problems,
            *samples.turn_problems,
            *problems,
        ),
        speed_mps=samples.speed_mps,
        yaw_rate_radps=samples.yaw_rate_radps,
        channels_W=samples.channels_W,
        surface_index=samples.surface_index,
        surface_names=samples.surface_names,
    )


@dataclass
class _TextLog:
    """A text log parsed (`_parse`): its content, layout, the columns that give each
    quantity, and those columns read."""

    content: Content
    head: bytes
    log_format: LogFormat
    pre: Preamble
    sources: list[PowerSource]
    time_source: TimeSource | None
    time_problems: list[Problem]
    speed_column: str | None
    turning: TurningColumns
    columns: Columns


def _parse(path: Path, options: ReadOptions, data: bytes | None) -> _TextLog:
    """The text log's layout (its format's preamble), the columns the options and the format
    name for each quantity, and those columns read as numbers."""
    named = tuple(
        c
        for c in (
            options.current_column,
            options.voltage_column,
            options.speed_column,
            options.yaw_rate_column,
            options.time_column,
            *options.power_columns,
        )
        if c
    )
    content, head = decode(path, Content(path, data))
    log_format, pre = _preamble(path, content, head, named)
    sources = _power_sources(path, log_format, pre, options)
    time_source, time_problems = _time_source(path, log_format, pre, options)
    speed_column = _speed_column(path, log_format, pre, options)
    turning = _turning_columns(path, log_format, pre, options)
    # only the columns used are converted to numbers (about a third of the parse time saved
    # on the 4-column canonical log); every line's field count is still checked
    used = list(dict.fromkeys(name for source in sources for name in source.columns()))
    used += [name for name in (time_source and time_source.column, speed_column) if name]
    used += [c for c in (turning.yaw_rate, turning.speed_left, turning.speed_right) if c]
    labels = (turning.surface,) if turning.surface else ()
    columns = read_columns(path, content, pre, head, list(dict.fromkeys(used)), labels)
    return _TextLog(
        content, head, log_format, pre, sources, time_source, time_problems, speed_column,
        turning, columns,
    )  # fmt: skip


def _metadata(
    path: Path,
    text: _TextLog,
    options: ReadOptions,
    overrides: dict[str, str] | None,
    origin: str | None,
) -> tuple[dict[str, str], dict[str, str], RunMeta]:
    """The run's metadata values (the manifest's win, then `--sample-period` where time is
    not a column in a unit), where each was set, and the `RunMeta` built from them."""
    values = dict(text.pre.metadata)
    where = {k: f"metadata {w}" for k, w in text.pre.metadata_where.items()}
    for key, value in (overrides or {}).items():
        values[key] = value
        where[key] = origin or "manifest"
    time_source = text.time_source
    if options.sample_period_s is not None and (time_source is None or time_source.index):
        values["sample_period_s"] = repr(options.sample_period_s)
        where["sample_period_s"] = "--sample-period"
    text.log_format.check_metadata(path, values)
    return values, where, _meta(path, text, values, where)


def _meta(path: Path, text: _TextLog, values: dict[str, str], where: dict[str, str]) -> RunMeta:
    """The checked `RunMeta` of a text log's metadata `values` (`build_meta`); a motion log
    with a speed (a speed column, or two wheel speeds: their mean) needs no commanded one."""
    turning = text.turning
    has_speed = bool(text.speed_column or (turning.speed_left and turning.speed_right))
    return build_meta(
        values,
        file=str(path),
        stem=log_stem(path),
        where="metadata",
        origins=where,
        speed_column=has_speed,
    )


@dataclass
class _Samples:
    """The per-sample arrays of a text log (`_samples`), and what their checks need."""

    power_W: np.ndarray
    channels_W: dict[str, np.ndarray]
    measured: dict[str, np.ndarray] | None
    twice: list
    time_s: np.ndarray | None
    speed_mps: np.ndarray | None
    yaw_rate_radps: np.ndarray | None
    turn_problems: list[Problem]
    surface_index: np.ndarray | None
    surface_names: tuple[str, ...]

    @property
    def size(self) -> int:
        return int(self.power_W.size)

    def on_grid(self, grid: HoldGrid) -> None:
        """Every per-sample array taken at the grid's points (`holdgrid`), time its stamps."""
        self.time_s = grid.stamps_s
        self.power_W, self.speed_mps, self.yaw_rate_radps = map(
            grid.take, (self.power_W, self.speed_mps, self.yaw_rate_radps)
        )
        self.channels_W = {name: grid.take(v) for name, v in self.channels_W.items()}
        self.surface_index = grid.take(self.surface_index)


def _samples(
    path: Path, text: _TextLog, options: ReadOptions, values: dict[str, str], meta: RunMeta
) -> _Samples:
    """Power (and its channels), time, speed, rate of turn and surface from the columns read;
    the columns' own arrays are let go (they live on in these only)."""
    columns, turning = text.columns, text.turning
    power_W, channels_W, measured, twice = _power(path, columns, text.sources, options.flip_current)
    time_source = text.time_source
    if time_source is not None and time_source.index:
        _check_index(path, columns, time_source.column)
    time_s = _time(path, columns, time_source, meta.sample_period_s)
    speed_column = text.speed_column
    speed_mps = _column(path, columns, (speed_column, 1.0)) if speed_column else None
    speed_mps, yaw_rate_radps, turn_problems = _turning(
        path, columns, turning, speed_mps, values, options
    )
    surface_index, surface_names = columns.labels.get(turning.surface or "", (None, ()))
    columns.values.clear()  # the arrays live on in power_W, measured and time_s only
    return _Samples(
        power_W, channels_W, measured, twice, time_s, speed_mps, yaw_rate_radps,
        turn_problems, surface_index, surface_names,
    )  # fmt: skip


def _checked(
    path: Path, text: _TextLog, samples: _Samples, meta: RunMeta, scale: PowerScale
) -> tuple[float, list[Problem], HoldGrid | None]:
    """The sample checks every log gets (`check_log_samples`), then those of the power said
    twice, the channels, the speed and the rate of turn: the period, the problems that did
    not stop reading, and the grid of a logger stamping rows as they arrive."""
    line_of = text.columns.lines.line_of
    turning = text.turning
    period_s, problems, grid = check_log_samples(
        str(path),
        samples.time_s,
        samples.power_W,
        line_of=line_of,
        default_period_s=meta.sample_period_s,
        measured=samples.measured,
        scale=scale,
    )
    samples.measured = None
    for said in samples.twice:  # after `check_samples`: a unit mistake is named as such first
        check_power_twice(str(path), *said)
    samples.twice = []
    check_channels(str(path), samples.channels_W)
    if samples.speed_mps is not None:
        named_speed = text.speed_column or f"{turning.speed_left}, {turning.speed_right}"
        check_speed(str(path), named_speed, samples.speed_mps, line_of=line_of)
    if samples.yaw_rate_radps is not None:
        named_turn = turning.yaw_rate or f"{turning.speed_left}, {turning.speed_right}"
        check_yaw_rate(str(path), named_turn, samples.yaw_rate_radps, line_of=line_of)
    if samples.speed_mps is not None and samples.yaw_rate_radps is not None and turning.yaw_rate:
        # a rate-of-turn column in deg/s under 30 (the check above): said (io/kinematics.py)
        names = (text.speed_column or "speed", turning.yaw_rate)
        said = lateral_problem(samples.speed_mps, samples.yaw_rate_radps, period_s, line_of, names)
        problems += [said] if said else []
    if samples.speed_mps is not None:  # a time column in ms read as s: said (io/kinematics.py)
        slow = slow_speed_problem(period_s, text.time_source)
        problems += [slow] if slow else []
    return period_s, problems, grid


# -- samples from the columns read (the columns each comes from: `column_options.py`) ----------


def _turning(
    path: Path,
    columns: Columns,
    turning: TurningColumns,
    speed_mps: np.ndarray | None,
    values: dict[str, str],
    options: ReadOptions,
) -> tuple[np.ndarray | None, np.ndarray | None, list[Problem]]:
    """The speed [m/s], rate of turn [rad/s] and what to say: the yaw-rate column, or from the
    two wheel speeds v_l, v_r of a differential or skid-steer drive: v = (v_l + v_r)/2 (when
    the log has no speed column) and yaw rate = (v_r - v_l)/track width (kinematics of a
    differential drive, counter-clockwise positive; for skid steer the track width is the
    effective one). Without a track width the rate of turn is not read: said as a problem when
    the wheel speeds are the log's only speed (a log with its own speed column, as REGBOT's,
    reads as before, and the drive model says its turning is unknown)."""
    if turning.yaw_rate:
        return speed_mps, _column(path, columns, (turning.yaw_rate, 1.0)), []
    if not (turning.speed_left and turning.speed_right):
        return speed_mps, None, []
    track_m = _track_width_m(path, values, options)
    problems = []
    if track_m is None and speed_mps is None:
        problems.append(
            Problem(
                "turning_unread",
                f"wheel speeds {turning.speed_left}, {turning.speed_right} without a track "
                "width: speed is their mean, the rate of turn is not read (give --track-width "
                "M or a '# track_m: M' metadata line)",
            )
        )
    left_mps = _column(path, columns, (turning.speed_left, 1.0))
    right_mps = _column(path, columns, (turning.speed_right, 1.0))
    if speed_mps is None:
        speed_mps = 0.5 * (left_mps + right_mps)
    if track_m is None:
        return speed_mps, None, problems
    return speed_mps, (right_mps - left_mps) / track_m, problems


def _track_width_m(path: Path, values: dict[str, str], options: ReadOptions) -> float | None:
    """`--track-width`, else the `track_m` metadata: what turns wheel speeds into a rate of
    turn (None: neither given); a one-line error naming the option when `track_m` is not a
    width > 0 m."""
    if options.track_width_m is not None:
        return options.track_width_m
    text = values.get("track_m")
    if not text:
        return None
    try:
        track_m = float(text)
    except ValueError:
        track_m = math.nan
    if not (math.isfinite(track_m) and track_m > 0):
        raise LogError(
            f"wheel speeds need a track width: track_m '{text}' is not a width > 0 m",
            file=path,
            fix="give --track-width M or a '# track_m: M' metadata line",
        )
    return track_m


def _column(path: Path, columns: Columns, spec: tuple[str, float]) -> np.ndarray:
    name, scale = spec
    if name in columns.text:
        raise LogError(
            f"column '{name}' holds text, not numbers",
            file=path,
            where=f"column '{name}'",
            fix="fix the column or re-export",
        )
    return _scaled(columns.values[name], scale)


def _scaled(values: np.ndarray, scale: float) -> np.ndarray:
    """`values * scale`, in place when the array is ours to change (no second full-size copy)."""
    if scale == 1.0:
        return values
    if values.flags.writeable and values.flags.owndata:
        values *= scale
        return values
    return values * scale


#: A power column said twice: (its name, power [W]), (current name, [A]), (voltage name, [V])
PowerTwice = tuple[tuple[str, np.ndarray], tuple[str, np.ndarray], tuple[str, np.ndarray]]


def _power(
    path: Path, columns: Columns, sources: list[PowerSource], flip: bool
) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray], list[PowerTwice]]:
    """Power [W] (the sum of the channels), each channel's power when there are several, the
    measured columns power comes from (checked for clipping), and the power columns the log
    says twice with the current and voltage beside them (`validate.check_power_twice`)."""
    measured: dict[str, np.ndarray] = {}
    channels: dict[str, np.ndarray] = {}
    twice: list[PowerTwice] = []
    for source in sources:
        if source.power:
            power_W = _column(path, columns, source.power)
            measured[source.power[0]] = power_W
            if source.twice:  # the log says the power twice: the two must agree
                current, voltage = source.twice
                twice.append(
                    (
                        (source.power[0], power_W),
                        (current[0], _column(path, columns, current)),
                        (voltage[0], _column(path, columns, voltage)),
                    )
                )
        else:
            current_A = _column(path, columns, source.current)
            measured[source.current[0]] = current_A
            if source.voltage:
                voltage_V = _column(path, columns, source.voltage)
                measured[source.voltage[0]] = voltage_V
                power_W = current_A * voltage_V
            else:
                power_W = current_A * float(source.supply_voltage_V)
        if flip:
            power_W = -power_W  # a new array: the measured columns stay as measured
        channels[source.name] = power_W
    if len(channels) == 1:
        return next(iter(channels.values())), {}, measured, twice
    total_W = np.sum(list(channels.values()), axis=0)
    return total_W, channels, measured, twice


def _time(
    path: Path, columns: Columns, source: TimeSource | None, period_s: float
) -> np.ndarray | None:
    """Time stamps [s] from the time column (a sample index x the sample period)."""
    if source is None:
        return None
    values = _column(path, columns, (source.column, 1.0))
    return _scaled(values, period_s if source.index else source.scale_s)


def _preamble(
    path: Path, content: Content, head: bytes, named: tuple[str, ...]
) -> tuple[LogFormat, Preamble]:
    """The log's format and preamble, read from the head's first `FIRST_LINES` lines when
    they hold the header and the `SNIFF_LINES` data lines sniffed after it (a format reads
    its preamble down to the header and sniffs that many non-empty lines after it, nothing
    further: the same result as from all of the head's lines, which are split otherwise, as
    they are when anything about the first lines is wrong). Splitting a 64 KiB head of a
    power-only log into its ~8,000 lines was most of reading the head (~0.3 ms a log)."""
    lines = head_lines(path, content, head, limit=FIRST_LINES)
    if len(lines) == FIRST_LINES:  # (fewer: they are all the head's lines)
        log_format = format_of(lines)
        try:
            pre = log_format.preamble(path, lines, named)
        except LogError:
            pass  # looked at again with every line of the head: its error, if any
        else:
            if sum(1 for line in lines[pre.header_line + 1 :] if line) >= SNIFF_LINES:
                return log_format, pre
        lines = head_lines(path, content, head)
    log_format = format_of(lines)
    try:
        return log_format, log_format.preamble(path, lines, named)
    except LogError as exc:
        # the first data line may also be the file's last, cut short: that, not what it holds
        # (too few fields, a cut number), is the error, as for any later cut line
        if head_ends_cut(head) and exc.where == f"line {len(lines)}":
            raise cut_line_error(path, len(lines)) from None
        raise


# -- what the log says of its robot, and what was assumed ---------------------------------------

#: The largest sample index a float64 holds exactly: beyond it `Sample` x interval cannot be
#: a time stamp (neighbouring indices round to one value).
MAX_SAMPLE_INDEX = 2**53


def _check_index(path: Path, columns: Columns, name: str) -> None:
    """A sample index (N6705 `Sample`) must be a count a float holds exactly."""
    values = columns.values.get(name)
    if values is None or not values.size or name in columns.text:
        return
    high = float(np.max(np.abs(values)))
    if high > MAX_SAMPLE_INDEX:
        at = int(np.argmax(np.abs(values) > MAX_SAMPLE_INDEX))
        raise LogError(
            f"sample index {values[at]:.4g} in column '{name}' is beyond 2^53: no logger "
            "counts so many samples, and neighbouring indices would be one time stamp",
            file=path,
            where=f"line {columns.lines.line_of(at)}",
            fix="the column is not a sample count (or the line is damaged); fix or cut that line",
        )


def _assumptions(
    sources: list[PowerSource],
    time_source: TimeSource | None,
    options: ReadOptions,
    values: dict[str, str],
    samples: int,
) -> list[Problem]:
    """What the reading assumed, and options that had no effect on this log: each said
    (log-format.md: every assumption is said; cli.md: warnings on stderr and in --json).
    A time column with a single stamp gives no spacing either."""
    said: list[Problem] = []
    unspaced = time_source is None or (samples == 1 and not time_source.index)
    if unspaced and "sample_period_s" not in values:
        said.append(
            Problem(
                "assumed_period",
                f"no time column (or a single stamp) and no sample_period_s: samples assumed "
                f"{PAPER_SAMPLE_PERIOD_S * 1e3:g} ms apart (the reference analyser's "
                f"{1 / PAPER_SAMPLE_PERIOD_S:g} Hz); give --sample-period S or sample_period_s "
                "metadata (a 1 kHz logger read so gives energies ten times too small)",
            )
        )
    if options.supply_voltage_V is not None and not any(
        source.supply_voltage_V is not None for source in sources
    ):
        used = ", ".join(f"'{c}'" for source in sources for c in source.columns())
        said.append(
            Problem(
                "ignored_option",
                f"--supply-voltage {options.supply_voltage_V:g} has no effect: power comes from "
                f"{used}",
            )
        )
    if options.sample_period_s is not None and time_source is not None and not time_source.index:
        said.append(
            Problem(
                "ignored_option",
                f"--sample-period {options.sample_period_s:g} has no effect: time comes from "
                f"column '{time_source.column}'",
            )
        )
    if options.time_unit is not None and (time_source is None or time_source.index):
        said.append(
            Problem(
                "ignored_option",
                f"--time-unit {options.time_unit} has no effect: the log has no time column "
                "in a unit (none, or a sample index)",
            )
        )
    return said
