"""A compressed or cut log read in pieces of whole lines, for pyarrow to parse in turn.

`_Pieces` reads the stream into pyarrow buffers of `BLOCK_BYTES`, hands out whole lines,
and keeps a last line without a line end out of the parse (a cut file); a line longer than
`MAX_LINE_BYTES` stops the read (`LineTooLongError`), found in time linear in its length.
Split out of `transport.py` (issue 24: one job a module).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TYPE_CHECKING

import numpy as np
import pyarrow as pa

if TYPE_CHECKING:
    from wifibot_power.io.transport import Content

#: pyarrow parses blocks of this size one after the other and holds a few at once, whatever
#: the file's size. 1 MiB: fastest on the corpus's 41 MB logs and the smallest parse buffers (16 MiB
#: blocks hold ~70 MB of buffers; docs/log-format.md, "Memory").
BLOCK_BYTES = 1 << 20

#: The longest line read [bytes]: a log's line is a few dozen bytes (a few hundred with many
#: channels); pyarrow parses in blocks of `_BLOCK_BYTES` and cannot parse a line longer than
#: one. A longer line is an error naming it (`LineTooLongError`), found in time linear in its
#: length (issue 29: a 200 MB line took 16.5 s, 1 GB over 300 s).
MAX_LINE_BYTES = BLOCK_BYTES


class LineTooLongError(Exception):
    """A line longer than `MAX_LINE_BYTES` starts at byte `start` of the content."""

    def __init__(self, start: int) -> None:
        super().__init__(start)
        self.start = start


def _find_long_line(content: Content) -> int | None:
    """Where the first line longer than `MAX_LINE_BYTES` starts, by one pass over the
    content (vectorised per read), or None."""
    offset = 0  # of the chunk in the content
    line_start = 0
    for chunk in content.chunks():
        data = np.frombuffer(chunk, dtype=np.uint8)
        ends = np.flatnonzero((data == 10) | (data == 13)) + offset
        starts = np.concatenate(([line_start], ends + 1))
        lengths = np.append(ends, offset + len(chunk)) - starts
        if lengths.size and int(lengths.max()) > MAX_LINE_BYTES:
            return int(starts[int(np.argmax(lengths > MAX_LINE_BYTES))])
        line_start = int(starts[-1])
        offset += len(chunk)
    return None


#: Bytes read at a time when the stream is watched for a cut last line (`_Pieces`): the
#: parse's block size, so memory is as when pyarrow reads the file itself.
_PIECE_BYTES = BLOCK_BYTES

#: Bytes searched from a piece's end for its last line end before the whole is searched.
_LINE_END_SEARCH = 1 << 16


def _last_line_end(buffer: pa.Buffer) -> int:
    """Index of the last \\n or \\r in `buffer`, or -1: looked for in its last bytes (a
    line is short), then in the whole."""
    view = memoryview(buffer)
    for start in (max(len(view) - _LINE_END_SEARCH, 0), 0):
        part = bytes(view[start:])
        last = max(part.rfind(b"\n"), part.rfind(b"\r"))
        if last >= 0 or start == 0:
            return start + last if last >= 0 else -1
    return -1  # pragma: no cover - the loop always returns


def _first_line_end(buffer: pa.Buffer) -> int:
    """Index of the first \\n or \\r in `buffer`, or -1."""
    view = memoryview(buffer)
    for end in (min(len(view), _LINE_END_SEARCH), len(view)):
        part = bytes(view[:end])
        found = [k for k in (part.find(b"\n"), part.find(b"\r")) if k >= 0]
        if found or end == len(view):
            return min(found) if found else -1
    return -1  # pragma: no cover - the loop always returns


class _Pieces:
    """The content as pieces of whole lines, for pyarrow to parse one after the other, less a
    last line that has no line end.

    A last data line with no line end is what a full disk or a cut copy leaves: it may hold a
    shortened number (23.3102 -> 23.3), so it is never parsed, and the read stops with an
    error (`_cut_line`). What follows the last line end read so far waits for the next
    read; at the end, it is kept out if it is more than blanks and starts after
    `header_start` (a header with no line end stays: "header only" follows). `cut_at` is then
    where that line starts.

    The stream is read here, into pyarrow buffers (a line cut by a read's end is joined in
    a small piece of its own; nothing else is copied), and pyarrow parses each piece from a
    buffer: no pyarrow thread ever calls back into Python (its readahead threads reading a
    Python file object were the suspect when a test worker crashed twice in a .gz read).
    The next piece is read (decompressed, outside the GIL) by one thread while pyarrow
    parses the current one.
    """

    def __init__(self, stream: pa.NativeFile, header_start: int) -> None:
        self._stream = stream
        self._header_start = header_start
        self._consumed = 0  # bytes taken from `stream` and looked at
        self._carry = b""  # the bytes after the last line end seen (part of a line)
        #: more of that line, read since: joined once its end comes (`_carried`), so a long
        #: line costs time linear in its length, not quadratic
        self._more: list[bytes] = []
        self._more_bytes = 0
        self._coming: Future[pa.Buffer] | None = None  # the read under way
        self._ended = False
        self.cut_at: int | None = None
        #: the exception reading the stream raised
        self.error: BaseException | None = None

    def _read(self) -> pa.Buffer:
        try:
            return self._stream.read_buffer(_PIECE_BYTES)
        except (OSError, pa.ArrowException) as exc:
            self.error = exc
            raise

    def __iter__(self) -> Iterator[pa.Buffer]:
        header_done = False  # whether a piece with the header's line end was handed out
        ahead = ThreadPoolExecutor(max_workers=1)
        try:
            self._coming = ahead.submit(self._read)
            while True:
                chunk = self._coming.result()
                self._coming = None
                if not chunk.size:
                    break
                self._coming = ahead.submit(self._read)
                start = self._consumed - len(self._carry) - self._more_bytes
                self._consumed += chunk.size
                last = _last_line_end(chunk)
                # the first piece holds the whole header line (pyarrow skips up to it)
                header_in = self._consumed - chunk.size + last >= self._header_start
                if last < 0 or not (header_done or header_in):
                    self._read_on(chunk, start)  # a line longer than a read
                    continue
                carry = self._carried()
                self._carry = chunk.slice(last + 1).to_pybytes()
                if not header_done:  # lines up to the header may span reads: one piece, once
                    header_done = True
                    yield pa.py_buffer(carry + chunk.slice(0, last + 1).to_pybytes())
                elif carry:
                    first = _first_line_end(chunk)
                    yield pa.py_buffer(carry + chunk.slice(0, first + 1).to_pybytes())
                    if first < last:
                        yield chunk.slice(first + 1, last - first)
                else:
                    yield chunk.slice(0, last + 1)
        finally:
            ahead.shutdown(wait=True)  # no read left under way: the stream may be closed
        self._end()

    def _read_on(self, chunk: pa.Buffer, start: int) -> None:
        """`chunk` holds no line end: more of the line that starts at `start`, kept until
        its end comes; a line longer than `MAX_LINE_BYTES` stops the read (`LineTooLongError`)."""
        self._more.append(chunk.to_pybytes())
        self._more_bytes += chunk.size
        if len(self._carry) + self._more_bytes > MAX_LINE_BYTES and start >= self._header_start:
            raise LineTooLongError(start)

    def _carried(self) -> bytes:
        """The part-line carried over, whole (`_read_on`)."""
        if self._more:
            self._carry = b"".join([self._carry, *self._more])
            self._more, self._more_bytes = [], 0
        return self._carry

    def _end(self) -> None:
        self._carried()
        self._ended = True
        tail_start = self._consumed - len(self._carry)
        if self._carry.strip() and tail_start > self._header_start:
            self.cut_at = tail_start
            self._carry = b""

    def tail(self) -> bytes:
        """What follows the last line end when it is not a cut line: parsed last."""
        return self._carry

    def drain(self) -> None:
        """Read the rest of the stream (after a parse error, the iteration closed): an error
        reading it wins, as when the whole stream was read ahead; `cut_at` is then known."""
        if self._ended or self.error is not None:
            return
        with contextlib.suppress(OSError, pa.ArrowException):
            chunk = self._coming.result() if self._coming is not None else self._read()
            while chunk.size:
                start = self._consumed - len(self._carry) - self._more_bytes
                self._consumed += chunk.size
                last = _last_line_end(chunk)
                if last < 0:
                    self._read_on(chunk, start)
                else:
                    self._more, self._more_bytes = [], 0
                    self._carry = chunk.slice(last + 1).to_pybytes()
                chunk = self._read()
            self._end()


def _cut_start(tail: bytes, size: int, header_start: int) -> int | None:
    """Where a last data line without a line end starts (see `_HoldBackCutLine`), from the
    content's last bytes `tail` and its `size`; -1 when the tail holds no line end at all."""
    if not tail or tail.endswith((b"\n", b"\r")):
        return None
    last = max(tail.rfind(b"\n"), tail.rfind(b"\r"))
    if last < 0 and len(tail) < size:
        return -1  # a last line longer than the tail: let the stream find where it starts
    start = size - len(tail) + last + 1
    return start if tail[last + 1 :].strip() and start > header_start else None
