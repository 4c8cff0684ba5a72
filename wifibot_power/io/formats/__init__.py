"""The log formats wbpower reads: one module each, behind one interface (`base.LogFormat`).

`FORMATS` is the only list of formats: a log is in the first whose `sniff` accepts its first
non-blank line; the canonical wbpower CSV, tried last, accepts any. A new instrument is one
module here and one entry in `FORMATS` (as pvlib's iotools: a reader per source).

`FILE_FORMATS` lists the logs that are not text (ROS bags, Joulescope recordings): each is
told by its name and read whole by its own library (`files.FileFormat`), before any text is
decoded.
"""

from __future__ import annotations

from pathlib import Path

from wifibot_power.io.formats.base import LogFormat, Preamble, TimeSource
from wifibot_power.io.formats.canonical import Canonical
from wifibot_power.io.formats.files import FileFormat
from wifibot_power.io.formats.jls import Joulescope
from wifibot_power.io.formats.n6705 import N6705
from wifibot_power.io.formats.rosbag import RosBag

#: Tried in order; the canonical format, which accepts anything, last.
FORMATS: tuple[LogFormat, ...] = (N6705(), Canonical())
#: Logs read whole by their own library, told by their names.
FILE_FORMATS: tuple[FileFormat, ...] = (RosBag(), Joulescope())

__all__ = [
    "FILE_FORMATS",
    "FORMATS",
    "FileFormat",
    "LogFormat",
    "Preamble",
    "TimeSource",
    "file_format_of",
    "format_of",
]


def file_format_of(path: Path) -> FileFormat | None:
    """The file format that claims `path` (a bag, a recording), or None: a text log."""
    return next((f for f in FILE_FORMATS if f.claims(path)), None)


def format_of(lines: list[str]) -> LogFormat:
    """The format of a log whose first lines are `lines`."""
    first = next((line.strip() for line in lines if line.strip()), "")
    return next(f for f in FORMATS if f.sniff(first))
