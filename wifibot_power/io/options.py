"""What a read is asked for, and which files are logs.

Kept apart from the parser so that finding logs and looking a file up in the parse cache
need neither pyarrow nor the parser: a warm `fit --cache` imports neither (docs/benchmarks.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

FORMAT_CANONICAL = "wbpower-csv"
FORMAT_N6705 = "n6705"
LOG_SUFFIXES = (".csv", ".csv.gz", ".csv.zst")


@dataclass(frozen=True)
class ReadOptions:
    """Options every log-reading command shares (cli.md: reading options)."""

    supply_voltage_V: float | None = None
    current_column: str | None = None
    voltage_column: str | None = None
    sample_period_s: float | None = None
    #: the column holding the robot's speed [m/s] (default: `speed_mps`, log-format.md "Speed")
    speed_column: str | None = None


def is_log_name(path: Path) -> bool:
    return path.name.lower().endswith(LOG_SUFFIXES)
