"""Line numbers of a log's data rows, and its lines split as pyarrow splits them.

Every line is split by one pattern, `LINE_END` (the line ends pyarrow knows: \\r\\n, \\r,
\\n); `scan_lines` is its vectorised twin for counting, checked against it. Line numbers for
messages are worked out only when a message needs one, by reading the file again
(`LineMap`). Split out of `transport.py` (issue 24: one job a module).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.errors import LogError

if TYPE_CHECKING:
    from wifibot_power.io.transport import Content

LINE_END = re.compile(rb"\r\n|\r|\n")


class LineMap:
    """File line numbers (1-based) of data rows, worked out only when a message needs one, by
    reading the content again up to `limit` bytes (where a cut last line starts)."""

    def __init__(self, content: Content, header_line: int, limit: int | None = None) -> None:
        self._content = content
        #: the file's size and modification time as read: a message written later (a gap's,
        #: `stamps.GapProblem`) never takes its line from a file changed since
        self._stamp = _file_stamp(content)
        self._header_line = header_line
        self._limit = limit
        self._rows: np.ndarray | None = None
        #: the number of data rows when they are the lines after the header one for one
        #: (`plain_lines`): row k is then on line header_line + 2 + k, no array needed
        self._plain: int | None = None
        self._line_ends = 0

    def _scan(self) -> None:
        if self._rows is not None or self._plain is not None:
            return
        if self._stamp is not None and _file_stamp(self._content) != self._stamp:
            raise LogError(
                "the file changed since it was read: its line numbers are not those read",
                file=str(self._content.path),
                fix="read it again when no program writes it",
            )
        plain = plain_lines(self._content.chunks(self._limit), self._header_line)
        if plain is not None:
            self._plain, self._line_ends = plain
        else:
            self._rows, self._line_ends = scan_lines(
                self._content.chunks(self._limit), self._header_line
            )

    def line_of(self, row: int) -> int:
        """Line of data row `row` (pyarrow skips empty lines, so they are skipped here too)."""
        self._scan()
        count = self._plain if self._rows is None else self._rows.size
        if not count:
            return self._header_line + 2
        row = min(max(row, 0), count - 1)
        return self._header_line + 2 + row if self._rows is None else int(self._rows[row])

    @property
    def rereadable(self) -> bool:
        """Whether another process can find the lines again from the file (no bytes held in
        memory: pickled, the map is its path and numbers)."""
        return self._content.data is None

    def line_count(self) -> int:
        """Line ends up to the limit (a \\r\\n counts once)."""
        self._scan()
        return self._line_ends

    def find(self, match: Callable[[bytes], bool]) -> tuple[int, bytes] | None:
        """First data line (1-based) for which `match(line bytes)` holds, and the line."""
        for index, line in enumerate(iter_lines(self._content.chunks(self._limit))):
            if index > self._header_line and line and match(line):
                return index + 1, line
        return None


def _file_stamp(content: Content) -> tuple[int, int] | None:
    """A file's size and modification time [ns] (None for bytes in memory or no file)."""
    path = getattr(content, "path", None)
    if getattr(content, "data", None) is not None or path is None:
        return None
    try:
        stat = os.stat(path)
    except OSError:
        return None
    return stat.st_size, stat.st_mtime_ns


def iter_lines(chunks: Iterator[bytes]) -> Iterator[bytes]:
    """The lines of the concatenated chunks, as `LINE_END.split` of the whole gives them."""
    carry = b""
    for chunk in chunks:
        buffer = carry + chunk
        # a \r at the end may be the first half of a \r\n: keep it for the next chunk
        held = b"\r" if buffer.endswith(b"\r") else b""
        parts = LINE_END.split(buffer[: len(buffer) - len(held)])
        carry = parts.pop() + held
        yield from parts
    yield from LINE_END.split(carry)


def plain_lines(chunks: Iterator[bytes], header_line: int) -> tuple[int, int] | None:
    """`(data rows, line ends)` when every line ends in \\n alone and no line after line
    `header_line` (0-based) is empty: the data rows are then the lines after the header one
    for one, as `scan_lines` would number them; None otherwise (a \\r anywhere, an empty
    line after the header: `scan_lines` numbers those). One mask of the \\n bytes a chunk,
    ~10x faster than the scan's masks and offsets on a 2 MB log."""
    line_ends = 0  # \n seen before the chunk
    after_header = False  # whether the chunk starts after the header's line end
    last_lf = False  # whether the byte before the chunk is a \n
    for chunk in chunks:
        if b"\r" in chunk:
            return None
        is_lf = np.frombuffer(chunk, dtype=np.uint8) == 10
        start = 0  # where the data lines start in the chunk
        if not after_header:
            start = _after_line(chunk, header_line - line_ends)
            after_header = start >= 0
        if after_header:
            # an empty data line: its \n right after another (the header's included)
            tail = is_lf[max(start - 1, 0) :]
            if (start == 0 and last_lf and is_lf[0]) or np.any(tail[1:] & tail[:-1]):
                return None
        line_ends += int(np.count_nonzero(is_lf))
        last_lf = bool(is_lf[-1])
    rows = max(line_ends - header_line - 1, 0)
    if not last_lf and line_ends > header_line:
        rows += 1  # a last line without a line end (`scan_lines` counts it)
    return rows, line_ends


def _after_line(chunk: bytes, index: int) -> int:
    """Offset in `chunk` just after the line end of its line `index` (0-based, counted from
    the chunk's start), or -1 when that line end is not in the chunk."""
    at = -1
    for _ in range(index + 1):
        at = chunk.find(b"\n", at + 1)
        if at < 0:
            return -1
    return at + 1


def scan_lines(chunks: Iterator[bytes], header_line: int) -> tuple[np.ndarray, int]:
    """Line numbers (1-based) of the non-empty lines after line `header_line` (0-based), and
    the number of line ends (\\r\\n, \\r or \\n, as pyarrow and `LINE_END` know them).
    Vectorised over the bytes of each chunk; a line cut by a chunk's end is carried over."""
    found: list[np.ndarray] = []
    carry = b""
    lines_before = 0  # complete lines in the chunks already done

    def complete_lines(buffer: bytes) -> int:
        """Note the data rows among the complete lines of `buffer`; return where they end."""
        nonlocal lines_before
        data = np.frombuffer(buffer, dtype=np.uint8)
        is_cr, is_lf = data == 13, data == 10
        after_cr = np.concatenate(([False], is_cr[:-1]))
        starts = np.flatnonzero(is_cr | (is_lf & ~after_cr))  # first byte of each line end
        if not starts.size:
            return 0
        before_lf = np.concatenate((is_lf[1:], [False]))
        ends = starts + 1 + before_lf[starts]  # one past each line end
        lengths = starts - np.concatenate(([0], ends[:-1]))
        index = lines_before + np.arange(starts.size)
        keep = (lengths > 0) & (index > header_line)
        found.append(index[keep] + 1)
        lines_before += int(starts.size)
        return int(ends[-1])

    for chunk in chunks:
        buffer = carry + chunk
        held = 1 if buffer.endswith(b"\r") else 0  # may be the first half of a \r\n
        done = complete_lines(buffer[: len(buffer) - held])
        carry = buffer[done:]
    done = complete_lines(carry)
    if carry[done:] and lines_before > header_line:
        found.append(np.array([lines_before + 1]))  # a last line without a line end
    rows = np.concatenate(found) if found else np.zeros(0, dtype=np.int64)
    return rows, lines_before


def _line_start(head: bytes, index: int) -> int:
    """Byte offset of line `index` (0-based) in `head`."""
    if index == 0:
        return 0
    for count, match in enumerate(LINE_END.finditer(head), start=1):
        if count == index:
            return match.end()
    return len(head)
