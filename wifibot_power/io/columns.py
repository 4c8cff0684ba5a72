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
    "speed_mps": ("speed", 1.0),
}

#: N6705 datalog columns: "Curr avg 3", "Volt max 4", "Power avg 1" -> quantity, statistic, output.
N6705_COLUMN = re.compile(r"^\s*(curr|volt|power)\s+(avg|min|max)\s+([1-4])\s*$", re.IGNORECASE)
N6705_QUANTITY = {"curr": "current", "volt": "voltage", "power": "power"}


@dataclass(frozen=True)
class PowerSource:
    """How power is computed from a table: `power`, or `current` x (`voltage` or a fixed supply)."""

    power: tuple[str, float] | None = None
    current: tuple[str, float] | None = None
    voltage: tuple[str, float] | None = None
    supply_voltage_V: float | None = None


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
