"""The log formats wbpower reads: one module each, behind one interface (`base.LogFormat`).

`FORMATS` is the only list of formats: a log is in the first whose `sniff` accepts its first
non-blank line; the canonical wbpower CSV, tried last, accepts any. A new instrument is one
module here and one entry in `FORMATS` (as pvlib's iotools: a reader per source).
"""

from __future__ import annotations

from wifibot_power.io.formats.base import LogFormat, Preamble, TimeSource
from wifibot_power.io.formats.canonical import Canonical
from wifibot_power.io.formats.n6705 import N6705

#: Tried in order; the canonical format, which accepts anything, last.
FORMATS: tuple[LogFormat, ...] = (N6705(), Canonical())

__all__ = ["FORMATS", "LogFormat", "Preamble", "TimeSource", "format_of"]


def format_of(lines: list[str]) -> LogFormat:
    """The format of a log whose first lines are `lines`."""
    first = next((line.strip() for line in lines if line.strip()), "")
    return next(f for f in FORMATS if f.sniff(first))
