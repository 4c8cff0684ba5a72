"""Reading logs: every format, the manifest, units. Nothing else knows file formats.

`read_log` (and with it pyarrow and the parser) loads on first use: finding logs and the
reading options do not need them, and a warm `fit --cache` never parses (docs/benchmarks.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wifibot_power.io.discover import LogSource, Skipped, find_logs, single_source
from wifibot_power.io.options import FORMAT_CANONICAL, FORMAT_N6705, ReadOptions

if TYPE_CHECKING:  # pragma: no cover
    from wifibot_power.io.reader import read_log

__all__ = [
    "FORMAT_CANONICAL",
    "FORMAT_N6705",
    "LogSource",
    "ReadOptions",
    "Skipped",
    "find_logs",
    "read_log",
    "single_source",
]


def __getattr__(name: str) -> object:
    if name == "read_log":
        from wifibot_power.io.reader import read_log

        return read_log
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
