"""The column options of a text log, the same for every format: which columns give power
(`--power-column`, `--current-column`, `--voltage-column`, `--supply-voltage`), time
(`--time-column`, `--time-unit`), speed and turning (`--speed-column`, `--yaw-rate-column`,
the two wheels' speeds), each looked up by name with an error naming the option and the
columns found. Split out of `reader.py` (issue 24: one job a module).
"""

from __future__ import annotations

from pathlib import Path

from wifibot_power.errors import LogError
from wifibot_power.io.columns import (
    PowerSource,
    find_column,
    time_unit_disagrees,
    time_unit_of,
    unit_scale,
)
from wifibot_power.io.formats import LogFormat, Preamble, TimeSource
from wifibot_power.io.formats.base import TurningColumns
from wifibot_power.io.options import TIME_UNITS, ReadOptions
from wifibot_power.run import Problem


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
    named_s = time_unit_of(found)[1]
    scale_s = TIME_UNITS[options.time_unit] if options.time_unit else named_s
    if scale_s is None:
        raise LogError(
            f"the unit of time column '{found}' is unknown",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix="give --time-unit s|ms|us",
        )
    return TimeSource(found, scale_s), time_unit_disagrees(found, named_s, options.time_unit)


def _speed_column(
    path: Path, log_format: LogFormat, pre: Preamble, options: ReadOptions
) -> str | None:
    """The speed column (log-format.md, "Speed"): `--speed-column`, which must exist, else
    the format's own (`speed_mps`) if the log has one."""
    if options.speed_column:
        return _lookup(path, pre, options.speed_column, "--speed-column")
    return log_format.speed_column(pre)


def _turning_columns(
    path: Path, log_format: LogFormat, pre: Preamble, options: ReadOptions
) -> TurningColumns:
    """The turning columns (log-format.md, "Turning"): `--yaw-rate-column`, which must exist,
    else the format's own rate of turn, else its two wheel speeds; and its `surface` column."""
    own = log_format.turning_columns(pre)
    if options.yaw_rate_column:
        found = _lookup(path, pre, options.yaw_rate_column, "--yaw-rate-column")
        return TurningColumns(yaw_rate=found, surface=own.surface)
    if own.yaw_rate or not (own.speed_left and own.speed_right):
        return TurningColumns(yaw_rate=own.yaw_rate, surface=own.surface)
    return own
