"""The wbpower CSV (log-format.md, section 1): `#` metadata lines, then a header naming
columns with their unit, and the data. Also the fallback for any CSV whose columns the
options name (`--power-column`, `--current-column`, ...).

Its column names live here and nowhere else: `power_W`, `power_mW`, `voltage_V`,
`voltage_mV`, `current_A`, `current_mA`, `time_s`, `time_ms`, `time_us`, `speed_mps`, the
turning columns `yaw_rate_radps` or `speed_left_mps` + `speed_right_mps`, `surface`, and the
channels `power_<name>_W`, `voltage_<name>_V` + `current_<name>_A` (summed). A column whose
name says it is time (`t`, `Time [s]`, `timestamp`; `columns.time_unit_of`) is never
silently ignored.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import ClassVar

from wifibot_power.errors import LogError
from wifibot_power.io.columns import (
    PowerSource,
    column_hint,
    find_column,
    time_unit_disagrees,
    time_unit_of,
)
from wifibot_power.io.formats.base import (
    LogFormat,
    Preamble,
    TimeSource,
    TurningColumns,
    check_header,
    delimiter_of,
    header_cells,
    sniff_data,
)
from wifibot_power.io.options import FORMAT_CANONICAL, TIME_UNITS, ReadOptions
from wifibot_power.io.transport import not_a_log
from wifibot_power.run import Problem

#: The canonical format versions this reader knows (`# wbpower-log: 1`).
KNOWN_VERSIONS = ("1",)

#: canonical column name (lower case) -> (quantity, scale to SI)
COLUMNS: dict[str, tuple[str, float]] = {
    "power_w": ("power", 1.0),
    "power_mw": ("power", 1e-3),
    "voltage_v": ("voltage", 1.0),
    "voltage_mv": ("voltage", 1e-3),
    "current_a": ("current", 1.0),
    "current_ma": ("current", 1e-3),
    "time_s": ("time", 1.0),
    "time_ms": ("time", 1e-3),
    "time_us": ("time", 1e-6),
    "speed_mps": ("speed", 1.0),
    "yaw_rate_radps": ("yaw_rate", 1.0),
    "speed_left_mps": ("speed_left", 1.0),
    "speed_right_mps": ("speed_right", 1.0),
}
#: Canonical time columns: these win over other time-like columns.
TIME_COLUMNS = tuple(name for name, (quantity, _) in COLUMNS.items() if quantity == "time")
SPEED_COLUMN = "speed_mps"
#: log-format.md, "Turning": the rate of turn, or the two sides' wheel speeds; and the
#: per-sample surface (text)
YAW_RATE_COLUMN = "yaw_rate_radps"
WHEEL_SPEED_COLUMNS = ("speed_left_mps", "speed_right_mps")
SURFACE_COLUMN = "surface"

#: Channel columns (log-format.md, "Several channels"): `power_<name>_W`,
#: `voltage_<name>_V`, `current_<name>_A` (and their milli units).
CHANNEL_COLUMN = re.compile(
    r"^\s*(?P<quantity>power|voltage|current)_(?P<name>.+)_(?P<unit>w|mw|v|mv|a|ma)\s*$",
    re.IGNORECASE,
)
_CHANNEL_UNITS = {"power": ("w", "mw"), "voltage": ("v", "mv"), "current": ("a", "ma")}


def channel_of(name: str) -> tuple[str, str, float] | None:
    """(quantity, channel name, scale to SI) of a channel column, else None."""
    match = CHANNEL_COLUMN.match(name)
    if match is None:
        return None
    quantity, unit = match["quantity"].lower(), match["unit"].lower()
    if unit not in _CHANNEL_UNITS[quantity]:
        return None  # `power_x_A`: not a channel column
    return quantity, match["name"], 1e-3 if unit.startswith("m") else 1.0


class Canonical(LogFormat):
    """The wbpower CSV: the fallback format, tried last."""

    name: ClassVar[str] = FORMAT_CANONICAL

    def sniff(self, first_line: str) -> bool:
        return True

    def preamble(self, path: Path, lines: list[str], named: tuple[str, ...]) -> Preamble:
        metadata: dict[str, str] = {}
        where: dict[str, str] = {}
        for index, line in enumerate(lines):
            stripped = line.strip()
            if not stripped:
                continue
            if stripped.startswith("#"):
                body = stripped.lstrip("#").strip()
                if ":" in body:
                    key, _, value = body.partition(":")
                    metadata[key.strip().lower()] = value.strip()
                    where[key.strip().lower()] = f"line {index + 1}"
                continue
            delimiter = delimiter_of(stripped)
            header = header_cells(stripped, delimiter)
            # with columns named by options, the first such line is the header whatever it
            # holds (a named column it lacks is then reported by name)
            if not named and not any(h.lower() in COLUMNS or channel_of(h) for h in header):
                if any(ch.isdigit() for ch in stripped) and not any(
                    ch.isalpha() for ch in stripped
                ):
                    raise not_a_log(path, "data but no header row", where=f"line {index + 1}")
                raise LogError(
                    "not a power log (no header row with power_W, voltage_V x current_A or "
                    "current_A)",
                    file=path,
                    where=f"line {index + 1}",
                    fix=f"{column_hint(header)}; or give a wbpower CSV "
                    "(see 'wbpower docs log-format')",
                )
            version = metadata.get("wbpower-log")
            if version is not None and version not in KNOWN_VERSIONS:
                raise LogError(
                    f"wbpower-log version '{version}' is not one this wbpower reads",
                    file=path,
                    where=where["wbpower-log"],
                    fix="update wbpower, or re-export as version 1",
                )
            check_header(path, header, index)
            decimal_comma = sniff_data(path, lines, index, header, delimiter)
            return Preamble(index, header, delimiter, decimal_comma, self.name, metadata, where)
        if metadata:
            raise LogError(
                "metadata only: no header row and no samples",
                file=path,
                fix="the log holds no data; re-export it",
            )
        raise not_a_log(path, "no header row")

    def power_sources(self, path: Path, pre: Preamble, options: ReadOptions) -> list[PowerSource]:
        lowered = {n.strip().lower(): n for n in pre.header}

        def first(*keys: str) -> tuple[str, float] | None:
            key = next((k for k in keys if k in lowered), None)
            return (lowered[key], COLUMNS[key][1]) if key else None

        power = first("power_w", "power_mw")
        current, voltage = first("current_a", "current_ma"), first("voltage_v", "voltage_mv")
        if power:
            # current and voltage logged beside it judge its unit (validate.check_power_scale)
            # and, both there, must agree with it (validate.check_power_twice)
            return [PowerSource(power=power, logged_current=current, logged_voltage=voltage)]
        if current and voltage:
            return [PowerSource(current=current, voltage=voltage)]
        channels = _channels(path, pre, voltage, options)
        if channels:
            return channels
        if current and options.supply_voltage_V:
            return [PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)]
        if current:
            raise LogError(
                "current only, no power or voltage column",
                file=path,
                fix="give --supply-voltage V, or name the voltage column with --voltage-column "
                f"({column_hint(pre.header)})",
            )
        raise LogError(
            "no power_W, power_mW, or voltage_V x current_A columns",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix=f"{column_hint(pre.header)}; or name the columns as in 'wbpower docs log-format'",
        )

    def time_source(
        self, path: Path, pre: Preamble, options: ReadOptions
    ) -> tuple[TimeSource | None, list[Problem]]:
        """A column whose name says it is time is never silently ignored in favour of an
        assumed sample period (log-format.md): read in the unit its name gives, or in
        `--time-unit`; else an error, or, with `--sample-period`, left out and reported."""
        timelike = [(n, time_unit_of(n)[1]) for n in pre.header if time_unit_of(n)[0]]
        if not timelike:
            return None, []
        canonical = [t for t in timelike if t[0].strip().lower() in TIME_COLUMNS]
        if len(timelike) > 1 and len(canonical) == 1:
            timelike = canonical  # time_s beside, say, a clock-time column: time_s is the time
        if len(timelike) > 1:
            raise LogError(
                f"several time columns ({', '.join(repr(t[0]) for t in timelike)})",
                file=path,
                where=f"line {pre.header_line + 1}",
                fix="name the one to use with --time-column (and --time-unit)",
            )
        ((name, scale_s),) = timelike
        if options.time_unit:
            said = time_unit_disagrees(name, scale_s, options.time_unit)
            return TimeSource(name, TIME_UNITS[options.time_unit]), said
        if scale_s is not None:
            return TimeSource(name, scale_s), []
        if options.sample_period_s is not None:
            note = (
                f"column '{name}' looks like time but its unit is unknown: not used, samples "
                f"spaced at --sample-period {options.sample_period_s:g} s instead"
            )
            return None, [Problem("time_ignored", note)]
        raise LogError(
            f"column '{name}' looks like time, but its name gives no unit",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix="give --time-unit s|ms|us, or --sample-period S to space samples evenly instead",
        )

    def speed_column(self, pre: Preamble) -> str | None:
        return find_column(pre.header, SPEED_COLUMN)

    def turning_columns(self, pre: Preamble) -> TurningColumns:
        left, right = (find_column(pre.header, name) for name in WHEEL_SPEED_COLUMNS)
        return TurningColumns(
            yaw_rate=find_column(pre.header, YAW_RATE_COLUMN),
            speed_left=left,
            speed_right=right,
            surface=find_column(pre.header, SURFACE_COLUMN),
        )


def _channels(
    path: Path,
    pre: Preamble,
    shared_voltage: tuple[str, float] | None,
    options: ReadOptions,
) -> list[PowerSource]:
    """Channels (log-format.md, "Several channels"): `power_<name>_W`, else
    `current_<name>_A` x `voltage_<name>_V`, else x the shared `voltage_V` (motors on one
    bus), else x `--supply-voltage`. A lone `voltage_<name>_V` is not power and is not read."""
    found: dict[str, dict[str, tuple[str, float]]] = {}
    for name in pre.header:
        parsed = channel_of(name)
        if parsed is not None:
            quantity, channel, scale = parsed
            if quantity in found.setdefault(channel, {}):
                raise LogError(
                    f"channel '{channel}' has two {quantity} columns "
                    f"('{found[channel][quantity][0]}', '{name}')",
                    file=path,
                    where=f"line {pre.header_line + 1}",
                    fix="keep one of them",
                )
            found[channel][quantity] = (name, scale)
    sources = []
    for channel, quantities in found.items():
        if "power" in quantities:
            # its current and voltage, both logged, say its power twice (`PowerSource.twice`)
            current, voltage = quantities.get("current"), quantities.get("voltage")
            both = current is not None and voltage is not None
            sources.append(
                PowerSource(
                    power=quantities["power"],
                    name=channel,
                    logged_current=current if both else None,
                    logged_voltage=voltage if both else None,
                )
            )
        elif "current" in quantities:
            voltage = quantities.get("voltage", shared_voltage)
            if voltage is None and options.supply_voltage_V is None:
                raise LogError(
                    f"channel '{channel}' has a current column "
                    f"('{quantities['current'][0]}') but no voltage",
                    file=path,
                    where=f"line {pre.header_line + 1}",
                    fix=f"add voltage_{channel}_V or voltage_V, or give --supply-voltage V",
                )
            sources.append(
                PowerSource(
                    current=quantities["current"],
                    voltage=voltage,
                    supply_voltage_V=None if voltage else options.supply_voltage_V,
                    name=channel,
                )
            )
    return sources
