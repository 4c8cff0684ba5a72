"""Reading logs: every format, the manifest, units. Nothing else knows file formats."""

from wifibot_power.io.discover import LogSource, Skipped, find_logs
from wifibot_power.io.reader import (
    FORMAT_CANONICAL,
    FORMAT_N6705,
    ReadOptions,
    read_log,
)

__all__ = [
    "FORMAT_CANONICAL",
    "FORMAT_N6705",
    "LogSource",
    "ReadOptions",
    "Skipped",
    "find_logs",
    "read_log",
]
