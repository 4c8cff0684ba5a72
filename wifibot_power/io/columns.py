"""Columns whatever the format: how power is made from them (`PowerSource`), finding a
column by name, and what a name says of its unit (`_mA` -> 1e-3; `Time [ms]` is time in ms).

Each format's own column names live in its module (`formats/canonical.py`,
`formats/n6705.py`); the names here are what any CSV may use, and what column options name.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from wifibot_power.run import Problem

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
    #: a current and a voltage column logged beside a `power` column: not read as power, but
    #: their first lines judge the power column's unit (`validate.check_power_scale`) and,
    #: when both are there, the whole column must agree with them (`twice`)
    logged_current: tuple[str, float] | None = None
    logged_voltage: tuple[str, float] | None = None

    @property
    def twice(self) -> tuple[tuple[str, float], tuple[str, float]] | None:
        """(current, voltage) when both are logged beside a `power` column: the log says the
        power twice, and the two must agree (`validate.check_power_twice`)."""
        if self.power and self.logged_current and self.logged_voltage:
            return self.logged_current, self.logged_voltage
        return None

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


def time_unit_disagrees(name: str, named_s: float | None, time_unit: str | None) -> list[Problem]:
    """A warning when `--time-unit` and the unit a time column's name gives disagree
    (`--time-unit ms` on `time_s`): the option is obeyed (a misnamed column is the reason to
    give it), and said, since one of the two is wrong (log-format.md: every assumption said)."""
    if time_unit is None or named_s is None:
        return []
    from wifibot_power.io.options import TIME_UNITS

    if abs(TIME_UNITS[time_unit] - named_s) <= 1e-9 * named_s:
        return []
    return [
        Problem(
            "time_unit",
            f"--time-unit {time_unit} on column '{name}', whose name says another unit: read "
            f"in {time_unit} as asked (stamps x {TIME_UNITS[time_unit] / named_s:g} against "
            "its name); drop --time-unit if the name is right",
        )
    ]


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


#: What a column's name suggests it holds, for the hint of a column error: the name, lower
#: case, matched as a word (`Power`, `P [W]`, `Watts`, `I_A`, `U_V`).
_GUESSES = (
    ("power", re.compile(r"(^|[^a-z])(p|power|pwr|watts?|w)([^a-z]|$)|power|watt")),
    ("current", re.compile(r"(^|[^a-z])(i|current|curr|amps?|ma)([^a-z]|$)|current|ampere")),
    ("voltage", re.compile(r"(^|[^a-z])(u|v|volts?|voltage|mv)([^a-z]|$)|volt")),
)


def column_hint(header: list[str], *, with_time: bool = True) -> str:
    """The columns a log holds and the reading options that would map them (log-format.md:
    every column error lists the columns found and the option that maps them): e.g.
    "columns found: 'Time', 'Power'; try --power-column 'Power' --time-column 'Time'
    --time-unit s|ms|us"; `with_time=False` leaves time out, for a format that has its own
    (an N6705 export's sample index)."""
    names = [n for n in header if n.strip()]
    found = ", ".join(f"'{n}'" for n in names) or "none"
    guesses: dict[str, str] = {}
    time_column: tuple[str, float | None] | None = None
    for name in names:
        is_time, scale = time_unit_of(name)
        if is_time and time_column is None:
            time_column = (name, scale)
            continue
        lowered = name.strip().strip('"').lower()
        for quantity, pattern in _GUESSES:
            if quantity not in guesses and pattern.search(lowered):
                guesses[quantity] = name
                break
    options: list[str] = []
    if "power" in guesses:
        options.append(f"--power-column '{guesses['power']}'")
    elif "current" in guesses:
        options.append(f"--current-column '{guesses['current']}'")
        options.append(
            f"--voltage-column '{guesses['voltage']}'"
            if "voltage" in guesses
            else "--supply-voltage V"
        )
    else:
        options.append("--power-column NAME (or --current-column NAME with --voltage-column)")
    if not with_time:
        pass
    elif time_column is not None:
        named, scale_s = time_column
        unit = " --time-unit s|ms|us" if scale_s is None else ""
        options.append(f"--time-column '{named}'{unit}")
    else:
        options.append("--sample-period S (no time column found)")
    return f"columns found: {found}; try {' '.join(options)}"
