"""The one-line errors of a CSV log's data lines: a cut last line, header only, text where a
number belongs, a line with the wrong number of fields, a line too long. Split out of
`transport.py` (issue 24: one job a module).
"""

from __future__ import annotations

import csv
import re
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.errors import LogError
from wifibot_power.io.lines import LineMap
from wifibot_power.io.pieces import MAX_LINE_BYTES

if TYPE_CHECKING:
    from wifibot_power.io.transport import Content, TextLayout

_COLUMN_IN_MESSAGE = re.compile(r"column #(\d+)")

_INVALID_VALUE = re.compile(r"invalid value '(.*)'")


def _long_line_error(path: Path, content: Content, pre: TextLayout, start: int) -> LogError:
    line = LineMap(content, pre.header_line, start).line_count() + 1
    return LogError(
        f"line longer than {MAX_LINE_BYTES >> 20} MiB (a log's line is a few dozen bytes)",
        file=path,
        where=f"line {line}",
        fix="the file is not a log, or its line ends are missing or not \\n, \\r\\n or \\r; "
        "fix or delete that line",
    )


def _cut_line(path: Path, content: Content, pre: TextLayout, cut_at: int) -> LogError:
    """The last line has no line end (log-format.md: a truncated last line is bad input)."""
    return cut_line_error(path, LineMap(content, pre.header_line, cut_at).line_count() + 1)


def cut_line_error(path: Path, line: int) -> LogError:
    """`line`, the file's last, has no line end: a cut file, whose last number may be cut."""
    return LogError(
        "the last line has no line end: the file may be cut short, and a cut line can hold a "
        "shortened number (23.3102 -> 23.3)",
        file=path,
        where=f"line {line}",
        fix="re-copy the file; if the line is complete, end it with a line break, or delete "
        "it to read the rest",
    )


def _header_only(path: Path, pre: TextLayout) -> LogError:
    return LogError(
        "header only: no samples",
        file=path,
        where=f"line {pre.header_line + 1}",
        fix="the log holds no data; re-export it",
    )


def _parse_error(path: Path, pre: TextLayout, message: str, lines: LineMap) -> LogError:
    first = (message.splitlines() or [""])[0]
    col = _COLUMN_IN_MESSAGE.search(first)
    value = _INVALID_VALUE.search(first)
    if col and value and int(col.group(1)) < len(pre.header):
        index, text = int(col.group(1)), value.group(1)
        name = pre.header[index]

        def holds(line: bytes) -> bool:
            cells = _cells(line, pre.delimiter)
            return index < len(cells) and cells[index].strip() == text.strip()

        found = lines.find(holds)
        where = f"line {found[0]}, column '{name}'" if found else f"column '{name}'"
        return LogError(
            f"'{text[:40]}' where a number belongs",
            file=path,
            where=where,
            fix="fix or delete that line",
        )
    if "Expected" in first and "columns" in first:
        expected = len(pre.header)
        found = lines.find(lambda line: len(_cells(line, pre.delimiter)) != expected)
        what = (
            f"{len(_cells(found[1], pre.delimiter))} field(s) where the header has {expected}"
            if found
            else "a line with the wrong number of fields"
        )
        return LogError(
            what,
            file=path,
            where=f"line {found[0]}" if found else None,
            fix="the line is truncated or malformed; delete it or re-export the log",
        )
    return LogError(
        f"cannot parse the CSV ({first[:100]})", file=path, fix="check the delimiter and quoting"
    )


def _cells(line: bytes, delimiter: str) -> list[str]:
    text = line.decode("utf-8", "replace")
    return next(csv.reader([text], delimiter=delimiter), [""])
