"""Column names and units: the one place that maps a log's columns to power in W.

Canonical logs name columns with their unit (`power_W`, `power_mW`, `voltage_V`,
`current_A`, `current_mA`, `time_s`, `speed_mps`); the N6705 export names them after the
analyser's outputs (`Curr avg 3`, `Volt avg 4`, `Power avg 1`). Both resolve here.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: canonical column name (lower case) -> (quantity, scale to SI)
CANONICAL_COLUMNS: dict[str, tuple[str, float]] = {
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
}

#: N6705 datalog columns: "Curr avg 3", "Volt max 4", "Power avg 1" -> quantity, statistic, output.
N6705_COLUMN = re.compile(r"^\s*(curr|volt|power)\s+(avg|min|max)\s+([1-4])\s*$", re.IGNORECASE)
N6705_QUANTITY = {"curr": "current", "volt": "voltage", "power": "power"}


#: Canonical channel columns (log-format.md, "Several channels"): `power_<name>_W`,
#: `voltage_<name>_V`, `current_<name>_A` (and their milli units).
CHANNEL_COLUMN = re.compile(
    r"^\s*(?P<quantity>power|voltage|current)_(?P<name>.+)_(?P<unit>w|mw|v|mv|a|ma)\s*$",
    re.IGNORECASE,
)
_CHANNEL_UNITS = {"power": ("w", "mw"), "voltage": ("v", "mv"), "current": ("a", "ma")}

#: Units a time column's name may carry, and their scale to seconds.
TIME_NAME_UNITS: dict[str, float] = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), 1.0),
    **dict.fromkeys(("ms", "msec", "millis", "milliseconds"), 1e-3),
    **dict.fromkeys(("us", "µs", "μs", "usec", "microseconds"), 1e-6),
    **dict.fromkeys(("ns", "nsec", "nanoseconds"), 1e-9),
}
#: A column whose name says it is time: `t`, `time`, `timestamp`, `elapsed`, ..., with or
#: without a unit (`Time [s]`, `time (ms)`, `t_us`, `timestamp_ms`).
TIME_COLUMN = re.compile(
    r"^\s*(?:t|time|times|timestamp|time[ _]?stamp|elapsed(?:[ _]?time)?|time[ _]?elapsed)"
    r"(?:\s*[\[(]\s*(?P<bracket>[^\])]*?)\s*[\])]|[ _](?P<suffix>[a-zµμ]+))?\s*$",
    re.IGNORECASE,
)


@dataclass(frozen=True)
class PowerSource:
    """How the power of one channel is computed from a table: `power`, or `current` x
    (`voltage` or a fixed supply). `name` names the channel when power is a sum of several."""

    power: tuple[str, float] | None = None
    current: tuple[str, float] | None = None
    voltage: tuple[str, float] | None = None
    supply_voltage_V: float | None = None
    name: str = ""

    def columns(self) -> list[str]:
        return [spec[0] for spec in (self.power, self.current, self.voltage) if spec]


def channel_of(name: str) -> tuple[str, str, float] | None:
    """(quantity, channel name, scale to SI) of a canonical channel column, else None."""
    match = CHANNEL_COLUMN.match(name)
    if match is None:
        return None
    quantity, unit = match["quantity"].lower(), match["unit"].lower()
    if unit not in _CHANNEL_UNITS[quantity]:
        return None  # `power_x_A`: not a channel column
    return quantity, match["name"], 1e-3 if unit.startswith("m") else 1.0


def time_unit_of(name: str) -> tuple[bool, float | None]:
    """Whether the name says the column is time, and its scale to seconds when the name says
    the unit (`Time [ms]` -> 1e-3); None when it does not (`Time`, `t`) or is not one of
    `TIME_NAME_UNITS`."""
    match = TIME_COLUMN.match(name.strip().strip('"'))
    if match is None:
        return False, None
    if match["suffix"] is not None:  # `time_s`, `t_ms`; `time_zone` is not time
        scale = TIME_NAME_UNITS.get(match["suffix"].lower().replace("μ", "µ"))
        return scale is not None, scale
    if match["bracket"] is None:
        return True, None
    return True, TIME_NAME_UNITS.get(match["bracket"].strip().lower().replace("μ", "µ"))


def find_column(names: list[str], wanted: str) -> str | None:
    """The column whose name matches `wanted` case-insensitively (quotes and blanks ignored)."""
    key = wanted.strip().strip('"').lower()
    for name in names:
        if name.strip().strip('"').lower() == key:
            return name
    return None


def unit_scale(name: str) -> float:
    """SI scale of a user-named column from its unit suffix (`_mA`, `_mV`, `_mW` -> 1e-3)."""
    lowered = name.strip().lower()
    return 1e-3 if lowered.endswith(("_ma", "_mv", "_mw")) else 1.0
