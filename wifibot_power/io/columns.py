"""Columns whatever the format: how power is made from them (`PowerSource`), finding a
column by name, and what a name says of its unit (`_mA` -> 1e-3; `Time [ms]` is time in ms).

Each format's own column names live in its module (`formats/canonical.py`,
`formats/n6705.py`); the names here are what any CSV may use, and what column options name.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

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
    #: (current, voltage) columns the log also holds for this channel when its power comes
    #: from `power`: the log says the power twice, and the two must agree
    #: (`validate.check_power_twice`)
    twice: tuple[tuple[str, float], tuple[str, float]] | None = None

    def columns(self) -> list[str]:
        twice = self.twice or ()
        return [spec[0] for spec in (self.power, self.current, self.voltage, *twice) if spec]


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
