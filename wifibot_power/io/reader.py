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

from pathlib import Path

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.columns import PowerSource, find_column, time_unit_of, unit_scale
from wifibot_power.io.formats import LogFormat, Preamble, TimeSource, format_of
from wifibot_power.io.formats.base import SNIFF_LINES
from wifibot_power.io.metadata import build_meta
from wifibot_power.io.options import TIME_UNITS, ReadOptions, log_stem
from wifibot_power.io.transport import (
    Columns,
    Content,
    cut_line_error,
    decode,
    head_ends_cut,
    head_lines,
    read_bytes,
    read_columns,
)
from wifibot_power.io.validate import (
    check_channels,
    check_power_twice,
    check_samples,
    check_speed,
)
from wifibot_power.run import Problem, Run

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
    named = tuple(
        c
        for c in (
            options.current_column,
            options.voltage_column,
            options.speed_column,
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
    # only the columns used are converted to numbers (about a third of the parse time saved
    # on the 4-column canonical log); every line's field count is still checked
    used = list(dict.fromkeys(name for source in sources for name in source.columns()))
    used += [name for name in (time_source and time_source.column, speed_column) if name]
    columns = read_columns(path, content, pre, head, used)
    values = dict(pre.metadata)
    where = {k: f"metadata {w}" for k, w in pre.metadata_where.items()}
    for key, value in (overrides or {}).items():
        values[key] = value
        where[key] = origin or "manifest"
    if options.sample_period_s is not None and (time_source is None or time_source.index):
        values["sample_period_s"] = repr(options.sample_period_s)
        where["sample_period_s"] = "--sample-period"
    log_format.check_metadata(path, values)
    meta = build_meta(values, file=str(path), stem=log_stem(path), where="metadata", origins=where)
    power_W, channels_W, measured = _power(path, columns, sources, options.flip_current)
    time_s = _time(path, columns, time_source, meta.sample_period_s)
    speed_mps = _column(path, columns, (speed_column, 1.0)) if speed_column else None
    columns.values.clear()  # the arrays live on in power_W, measured and time_s only
    period_s, problems = check_samples(
        str(path),
        time_s,
        power_W,
        line_of=columns.lines.line_of,
        default_period_s=meta.sample_period_s,
        measured=measured,
        voltages=frozenset(source.voltage[0] for source in sources if source.voltage),
    )
    del measured
    check_channels(str(path), channels_W)
    if speed_mps is not None:
        check_speed(str(path), speed_column, speed_mps, line_of=columns.lines.line_of)
    if time_s is not None and period_s != meta.sample_period_s:
        values["sample_period_s"] = repr(period_s)
        meta = build_meta(
            values, file=str(path), stem=log_stem(path), where="metadata", origins=where
        )
    return Run(
        file=str(path),
        format=pre.format,
        meta=meta,
        stamps_s=time_s,  # None without a time column: `Run.time_s` makes the axis if asked
        power_W=power_W,
        problems=(*time_problems, *problems),
        speed_mps=speed_mps,
        channels_W=channels_W,
    )


# -- the column options: the same for every format -------------------------------------------


def _lookup(path: Path, pre: Preamble, wanted: str, option: str) -> str:
    """The column an option names (case-insensitively), or an error naming the option."""
    found = find_column(pre.header, wanted)
    if found is None:
        raise LogError(
            f"no column '{wanted}' (columns: {', '.join(pre.header)})",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix=f"check {option}",
        )
    return found


def _power_sources(
    path: Path, log_format: LogFormat, pre: Preamble, options: ReadOptions
) -> list[PowerSource]:
    """The channels whose power, summed, is the robot's power: the columns the options name,
    else the format's own."""
    if options.power_columns:
        return [
            PowerSource(power=(name, unit_scale(name)), name=wanted)
            for wanted in dict.fromkeys(options.power_columns)
            for name in [_lookup(path, pre, wanted, "--power-column")]
        ]
    if not (options.current_column or options.voltage_column):
        return log_format.power_sources(path, pre, options)
    if not options.current_column:
        raise LogError(
            "--voltage-column needs --current-column too", file=path, fix="name both columns"
        )
    current = _lookup(path, pre, options.current_column, "--current-column")
    if options.voltage_column:
        voltage = _lookup(path, pre, options.voltage_column, "--voltage-column")
        return [
            PowerSource(
                current=(current, unit_scale(current)), voltage=(voltage, unit_scale(voltage))
            )
        ]
    if options.supply_voltage_V is None:
        raise LogError(
            "--current-column needs a voltage",
            file=path,
            fix="give --voltage-column or --supply-voltage",
        )
    return [
        PowerSource(
            current=(current, unit_scale(current)), supply_voltage_V=options.supply_voltage_V
        )
    ]


def _time_source(
    path: Path, log_format: LogFormat, pre: Preamble, options: ReadOptions
) -> tuple[TimeSource | None, list[Problem]]:
    """`--time-column` (in `--time-unit`, else the unit its name gives), else the format's."""
    if not options.time_column:
        return log_format.time_source(path, pre, options)
    found = _lookup(path, pre, options.time_column, "--time-column")
    scale_s = TIME_UNITS[options.time_unit] if options.time_unit else time_unit_of(found)[1]
    if scale_s is None:
        raise LogError(
            f"the unit of time column '{found}' is unknown",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix="give --time-unit s|ms|us",
        )
    return TimeSource(found, scale_s), []


def _speed_column(
    path: Path, log_format: LogFormat, pre: Preamble, options: ReadOptions
) -> str | None:
    """The speed column (log-format.md, "Speed"): `--speed-column`, which must exist, else
    the format's own (`speed_mps`) if the log has one."""
    if options.speed_column:
        return _lookup(path, pre, options.speed_column, "--speed-column")
    return log_format.speed_column(pre)


# -- samples from the columns read --------------------------------------------------------------


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


def _power(
    path: Path, columns: Columns, sources: list[PowerSource], flip: bool
) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Power [W] (the sum of the channels), each channel's power when there are several, and
    the measured columns power comes from (checked for clipping)."""
    measured: dict[str, np.ndarray] = {}
    channels: dict[str, np.ndarray] = {}
    for source in sources:
        if source.power:
            power_W = _column(path, columns, source.power)
            measured[source.power[0]] = power_W
            if source.twice:  # the log says the power twice: the two must agree
                current, voltage = source.twice
                check_power_twice(
                    str(path),
                    (source.power[0], power_W),
                    (current[0], _column(path, columns, current)),
                    (voltage[0], _column(path, columns, voltage)),
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
        return next(iter(channels.values())), {}, measured
    total_W = np.sum(list(channels.values()), axis=0)
    return total_W, channels, measured


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
