"""What every log format shares: the interface a format implements, and the CSV-text
helpers its preamble uses (header cells, delimiter, decimal mark).

A format (`canonical.py`, `n6705.py`, ...) is one subclass of `LogFormat`, registered in
`formats/__init__.py`, the only list of formats. It owns its column names: nothing outside
its module knows them. A new instrument is one module and one line in the registry.
"""

from __future__ import annotations

import csv
import re
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path
from typing import ClassVar

from wifibot_power.errors import LogError
from wifibot_power.io.columns import PowerSource
from wifibot_power.io.options import ReadOptions
from wifibot_power.io.transport import TextLayout
from wifibot_power.run import Problem

#: Data lines of the head looked at to tell the decimal mark and the field count.
SNIFF_LINES = 50
_DECIMAL_COMMA_CELL = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*$")
_DECIMAL_POINT_CELL = re.compile(r"^\s*[+-]?\d*\.\d+(?:[eE][+-]?\d+)?\s*$")


@dataclass(frozen=True)
class Preamble(TextLayout):
    """What a format reads before the data lines: its name, where the header is, the
    metadata (key -> value), and where each metadata value was set ("line 3", for messages)."""

    format: str = ""
    metadata: dict[str, str] = field(default_factory=dict)
    metadata_where: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class TimeSource:
    """Where a log's time comes from: `column` x `scale_s` (its unit in s), or, when
    `index` is set, `column` is a sample index: x the sample period."""

    column: str
    scale_s: float = 1.0
    index: bool = False


class LogFormat(ABC):
    """One input format: how it is told from the others, its preamble, and what its columns
    mean (power, time, speed). Column options (`--power-column`, `--current-column`,
    `--time-column`, `--speed-column`) are applied by the reader, whatever the format."""

    #: the name in `Run.format` and `inspect` (FORMAT_* in options.py)
    name: ClassVar[str]

    @abstractmethod
    def sniff(self, first_line: str) -> bool:
        """Whether a log whose first non-blank line is `first_line` is in this format."""

    @abstractmethod
    def preamble(self, path: Path, lines: list[str], named: tuple[str, ...]) -> Preamble:
        """The preamble, from the first lines of the file (`named`: columns named by options,
        which a header may hold instead of the format's own names)."""

    @abstractmethod
    def power_sources(self, path: Path, pre: Preamble, options: ReadOptions) -> list[PowerSource]:
        """The channels whose power, summed, is the robot's power (one, mostly)."""

    @abstractmethod
    def time_source(
        self, path: Path, pre: Preamble, options: ReadOptions
    ) -> tuple[TimeSource | None, list[Problem]]:
        """The time column (None: samples evenly spaced), and what to report about it."""

    def speed_column(self, pre: Preamble) -> str | None:
        """The format's own speed column, if it has one."""
        return None

    def turning_columns(self, pre: Preamble) -> TurningColumns:
        """The format's own turning columns (log-format.md, "Turning"), if it has any."""
        return TurningColumns()

    def check_metadata(self, path: Path, values: dict[str, str]) -> None:
        """Raise when the metadata (the file's, the manifest's and options') lacks what this
        format needs to be read."""
        return None


@dataclass(frozen=True)
class TurningColumns:
    """Where a log says how the robot turns (log-format.md, "Turning"): a rate-of-turn column,
    or the two sides' wheel-speed columns; and a per-sample `surface` column. None: absent."""

    yaw_rate: str | None = None
    speed_left: str | None = None
    speed_right: str | None = None
    surface: str | None = None


def header_cells(line: str, delimiter: str) -> list[str]:
    cells = next(csv.reader([line], delimiter=delimiter), [])
    return [c.strip() for c in cells]


def check_header(path: Path, header: list[str], index: int) -> None:
    seen: dict[str, int] = {}
    for position, name in enumerate(header):
        key = name.lower()
        if key in seen and key:
            raise LogError(
                f"column '{name}' appears twice in the header (columns {seen[key] + 1} and "
                f"{position + 1})",
                file=path,
                where=f"line {index + 1}",
                fix="rename or delete one of them",
            )
        seen[key] = position


def delimiter_of(header: str) -> str:
    counts = {d: header.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] else ","


def sniff_data(
    path: Path, lines: list[str], header_index: int, header: list[str], delimiter: str
) -> bool:
    """Whether numbers use a decimal comma; a first data line whose field count does not match
    the header (e.g. decimal commas in a ','-separated file) is an error here, with a hint."""
    rows = enumerate(lines[header_index + 1 :], start=header_index + 2)
    data = list(islice(((k, ln) for k, ln in rows if ln), SNIFF_LINES))
    if not data:
        return False
    line_no, first = data[0]
    cells = next(csv.reader([first], delimiter=delimiter), [])
    if len(cells) != len(header):
        hint = ""
        if delimiter == "," and any(
            _DECIMAL_COMMA_CELL.match(f"{a},{b}") for a, b in zip(cells, cells[1:], strict=False)
        ):
            hint = "; decimal commas in a ','-separated file are ambiguous"
        raise LogError(
            f"{len(cells)} fields where the header has {len(header)}{hint}",
            file=path,
            where=f"line {line_no}",
            fix="export with ';' as the separator (or '.' as the decimal mark) so fields and "
            "header match",
        )
    commas = points = None
    for line_no, line in data:
        for cell in next(csv.reader([line], delimiter=delimiter), []):
            if _DECIMAL_COMMA_CELL.match(cell) and commas is None:
                commas = line_no
            elif _DECIMAL_POINT_CELL.match(cell) and points is None:
                points = line_no
    if commas is not None and points is not None:
        raise LogError(
            "both ',' and '.' are used as the decimal mark",
            file=path,
            where=f"line {commas}"
            if commas == points
            else f"lines {min(commas, points)} and {max(commas, points)}",
            fix="export with one decimal mark",
        )
    return commas is not None
