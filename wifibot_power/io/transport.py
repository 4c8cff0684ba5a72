"""The bytes of a log, whatever its format: opening, decompression, text and lines.

What every format shares (issue 12: one transport, one module per format, as pvlib's
iotools): the file's bytes read as a stream (decompressed on the fly for .gz/.zst: the codec
comes from `options.codec_of`, the one place compression is told), a UTF-16 file converted,
the head decoded and split into lines for the format's preamble, the data lines parsed by
pyarrow's CSV reader into numpy columns, line numbers for messages, and a cut last line
found. Every line is split by one pattern, `LINE_END` (the line ends pyarrow knows: \\r\\n,
\\r, \\n); `scan_lines` is its vectorised twin for counting, checked against it.

Parsing goes through pyarrow's CSV reader, reading the file itself in 1 MiB blocks parsed one
after the other (its serial reader: the threaded one can silently drop a table's last
blocks, `_csv_options`): the file's bytes are never held whole, only the numeric columns
used are kept, and they are copied to numpy a column at a time, so memory follows the
columns kept, not the file (docs/log-format.md, "Memory"). Line numbers for messages are
worked out only when a message needs one, by reading the file again.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from wifibot_power.errors import LogError
from wifibot_power.io.csv_errors import (
    _cut_line,
    _header_only,
    _long_line_error,
    _parse_error,
)
from wifibot_power.io.csv_errors import cut_line_error as cut_line_error  # re-exported
from wifibot_power.io.lines import LineMap, _line_start
from wifibot_power.io.lines import iter_lines as iter_lines  # re-exported
from wifibot_power.io.lines import scan_lines as scan_lines  # re-exported
from wifibot_power.io.options import codec_of
from wifibot_power.io.pieces import (
    BLOCK_BYTES,
    LineTooLongError,
    _cut_start,
    _find_long_line,
    _Pieces,
)
from wifibot_power.io.pieces import MAX_LINE_BYTES as MAX_LINE_BYTES  # re-exported

HEAD_BYTES = 1 << 16

#: pyarrow's parse block (`pieces.BLOCK_BYTES`); a name of this module's, read by
#: `_csv_options` when it runs (tests make it small)
_BLOCK_BYTES = BLOCK_BYTES

#: Columns below this size are not given back to the OS after the parse: pyarrow's pool keeps
#: their blocks and the next parse reuses them. Giving them back cost 12-25% of parsing
#: the log again (page faults; measured on 0.5-9 MB power-only logs), and what the pool may
#: keep is bounded by this and a few parse blocks, whatever the number of files.
_RELEASE_BYTES = 16 << 20


def _arrow_pool() -> pa.MemoryPool:
    """The allocator the parse uses: jemalloc where pyarrow has it (its Linux and macOS wheels),
    unless ARROW_DEFAULT_MEMORY_POOL chooses. pyarrow's default, mimalloc, kept freed pages
    across logs even after `release_unused`: one `fit --jobs 1` process over the 89 logs of
    the bench's power corpus peaked at 204-212 MB with mimalloc and 151-162 MB with jemalloc
    (136-141 MB on 2 of them either way), with no more CPU (docs/log-format.md, "Memory")."""
    if os.environ.get("ARROW_DEFAULT_MEMORY_POOL"):
        return pa.default_memory_pool()
    try:
        return pa.jemalloc_memory_pool()
    except NotImplementedError:  # a pyarrow built without it (Windows wheels)
        return pa.default_memory_pool()


_POOL = _arrow_pool()

#: Bytes read at a time when a file is scanned again for line numbers.
_SCAN_BYTES = 1 << 20

UTF8_BOM = b"\xef\xbb\xbf"

#: `LINE_END` for decoded text.
_TEXT_LINE_END = re.compile(r"\r\n|\r|\n")


@contextmanager
def read_errors(path: Path) -> Iterator[None]:
    """Errors opening, reading or decompressing a file, as one-line `LogError`s."""
    try:
        yield
    except FileNotFoundError:
        raise LogError("no such file", file=path, fix="check the path") from None
    except IsADirectoryError:
        raise LogError("is a folder, not a log", file=path, fix="name a log file") from None
    except PermissionError:
        raise LogError("permission denied", file=path, fix="check the file's permissions") from None
    except (OSError, pa.ArrowException) as exc:
        first = (str(exc).splitlines() or [exc.__class__.__name__])[0][:80]
        raise LogError(
            f"cannot read or decompress ({first})",
            file=path,
            fix="check the file is complete and its extension matches its compression",
        ) from None


def require_regular(path: Path) -> None:
    """Refuse what is not a regular file before it is opened: a FIFO blocks `open()` forever
    (and Ctrl-C cannot end a wait inside pyarrow), a device never ends. A missing file is
    left to `open()` (its own error)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if not stat.S_ISREG(mode) and not stat.S_ISDIR(mode):
        raise LogError(
            "not a regular file (a FIFO, device or socket)",
            file=path,
            fix="give a file; copy a stream to a file first",
        )


def read_bytes(path: Path) -> bytes:
    """The file's bytes, decompressed by extension (.gz, .zst)."""
    require_regular(path)
    with read_errors(path):
        codec = codec_of(path)
        if codec is not None:
            with pa.input_stream(str(path), compression=codec) as stream:
                return stream.read()
        return path.read_bytes()


@dataclass(frozen=True)
class Content:
    """A log's (decompressed) bytes, opened afresh for each pass over them: from the file, or
    from `data` when the caller already holds them."""

    path: Path
    data: bytes | None = None

    def open(self) -> pa.NativeFile:
        """A stream of the bytes from the start (errors surface as they are read)."""
        if self.data is not None:
            return pa.BufferReader(self.data)
        require_regular(self.path)
        return pa.input_stream(str(self.path), compression=codec_of(self.path))

    def head(self) -> bytes:
        """The first bytes: `HEAD_BYTES` after a byte-order mark, and one more to tell whether
        the content goes on."""
        with read_errors(self.path), self.open() as stream:
            return stream.read(HEAD_BYTES + len(UTF8_BOM) + 1)

    def chunks(self, limit: int | None = None, size: int = _SCAN_BYTES) -> Iterator[bytes]:
        """The bytes in pieces of `size`, up to `limit` bytes if given."""
        left = limit
        with read_errors(self.path), self.open() as stream:
            while left is None or left > 0:
                chunk = stream.read(size if left is None else min(size, left))
                if not chunk:
                    return
                if left is not None:
                    left -= len(chunk)
                yield chunk

    def tail(self) -> tuple[bytes, int] | None:
        """The last `HEAD_BYTES` bytes and the size of the whole, when they can be had without
        reading the rest (bytes in memory, an uncompressed file); else None."""
        if self.data is not None:
            return self.data[-HEAD_BYTES:], len(self.data)
        if codec_of(self.path) is not None:
            return None
        with read_errors(self.path), pa.OSFile(str(self.path)) as stream:
            size = stream.size()
            stream.seek(max(size - HEAD_BYTES, 0))
            return stream.read(), size

    def is_blank(self) -> bool:
        """Nothing but blanks (or nothing) after a UTF-8 byte-order mark."""
        chunks = self.chunks()
        first = next(chunks, b"").removeprefix(UTF8_BOM)
        return (not first or first.isspace()) and all(chunk.isspace() for chunk in chunks)


def not_a_log(path: Path, why: str, where: str | None = None) -> LogError:
    return LogError(
        f"not a power log ({why})",
        file=path,
        where=where,
        fix="give a wbpower CSV (see 'wbpower docs log-format') or a Keysight N6705 datalog export",
    )


def decode(path: Path, content: Content) -> tuple[Content, bytes]:
    """A UTF-16 file (with its BOM, as spreadsheets save "Unicode text") is converted to UTF-8
    in memory (such exports are small); anything else is read as it is. A UTF-8 BOM is left
    in place: it sits in the first line, which the CSV parse skips, and the preamble drops it.
    Both BOMs are unambiguous."""
    head = content.head()
    if not head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return content, head
    raw = read_bytes(path) if content.data is None else content.data
    try:
        utf8 = Content(path, raw.decode("utf-16").lstrip("\ufeff").encode("utf-8"))
    except UnicodeDecodeError:
        raise not_a_log(path, "broken UTF-16 text") from None
    return utf8, utf8.head()


@dataclass(frozen=True)
class TextLayout:
    """Where a log's data lines are and how they are written: what the CSV parse needs."""

    header_line: int  # 0-based index of the header row in the file
    header: list[str]
    delimiter: str
    decimal_comma: bool


def head_ends_cut(head: bytes) -> bool:
    """Whether the head (`Content.head`, up to `HEAD_BYTES` + 1) is the whole content and its
    last line has no line end."""
    head = head.removeprefix(UTF8_BOM)
    return 0 < len(head) <= HEAD_BYTES and not head.endswith((b"\n", b"\r"))


def head_lines(path: Path, content: Content, head: bytes, limit: int | None = None) -> list[str]:
    """The lines of the content's first bytes (`Content.head`), as text: what a format's
    preamble is read from. An empty, binary or non-UTF-8 head is an error here.

    With `limit`, at most the first `limit` lines (only those are split off the text: a
    64 KiB head of a power-only log holds ~8,000 lines, and splitting them all is most of
    reading the head); fewer means these are all the head's lines."""
    head = head.removeprefix(UTF8_BOM)
    more = len(head) > HEAD_BYTES
    head = head[:HEAD_BYTES]
    if not head or (head.isspace() and (not more or content.is_blank())):
        raise LogError("the file is empty", file=path, fix="re-export the log")
    if b"\x00" in head:
        raise not_a_log(path, "binary data")
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte char cut by the head limit
            line = head[: exc.start].count(b"\n") + 1
            raise LogError(
                f"not UTF-8 text (byte {exc.start})",
                file=path,
                where=f"line {line}",
                fix="save the file as UTF-8 (or plain ASCII) text",
            ) from None
        text = head[: exc.start].decode("utf-8")
    # line ends are ASCII bytes, never inside a multi-byte character: decode once, then split
    # at the same line ends (a plain split at \n when there is no \r: ~10x faster than the
    # pattern on the 64 KiB head, which is most of reading the head)
    if limit is None:
        lines = text.split("\n") if "\r" not in text else _TEXT_LINE_END.split(text)
    else:  # at most `limit` splits: the item after the first `limit` lines is the rest
        lines = text.split("\n", limit) if "\r" not in text else _TEXT_LINE_END.split(text, limit)
    if limit is not None and len(lines) > limit:
        return lines[:limit]  # the item after them is the unsplit rest
    if more:
        lines = lines[:-1]  # the last line of the head may be cut by the head limit
    return lines


@dataclass
class Columns:
    """The columns read from a log, as numpy arrays (a column of text is named, not held)."""

    names: list[str]
    values: dict[str, np.ndarray]
    text: set[str]
    lines: LineMap
    #: the label columns asked for (`read_columns(labels=...)`): per sample an index into the
    #: column's distinct labels (-1 where empty), and those labels
    labels: dict[str, tuple[np.ndarray, tuple[str, ...]]] = field(default_factory=dict)


def _csv_options(
    pre: TextLayout, include_columns: list[str], skip: bool = True, labels: tuple[str, ...] = ()
) -> dict:
    """pyarrow's options for the data lines: the header's names, the included columns as
    float64 (no type inference, nothing else converted); `skip` the lines up to the header
    (the first piece of a stream, or the whole file); the parse's allocator (`_POOL`).

    Never pyarrow's threaded reader (`use_threads=False`): it can return a table that lacks
    its last block(s), with no error. Its task group (C++ `ThreadedTaskGroup`) can mark
    itself finished on a count of tasks left read before another thread added the last
    block's parse task, and the table is then assembled from the blocks reserved so far. A
    2-block log then ends where its first 1 MiB block ends, mid-run: that was the
    intermittent "ends moving" skip of `fit` (docs/benchmarks.md, "An intermittent
    truncated run?"). A run cut during its final idle would not even be doubted. The serial
    reader still reads the next block on pyarrow's I/O thread while this one is parsed, and
    a `fit` worker had one pyarrow CPU thread anyway (`parallel.py`)."""
    return {
        "memory_pool": _POOL,
        "read_options": pacsv.ReadOptions(
            skip_rows=pre.header_line + 1 if skip else 0,
            column_names=pre.header,
            block_size=_BLOCK_BYTES,
            use_threads=False,
        ),
        "parse_options": pacsv.ParseOptions(delimiter=pre.delimiter),
        "convert_options": pacsv.ConvertOptions(
            column_types={
                **dict.fromkeys(include_columns, pa.float64()),
                **dict.fromkeys(labels, pa.string()),
            },
            decimal_point="," if pre.decimal_comma else ".",
            include_columns=[*include_columns, *labels],
            strings_can_be_null=False,
            quoted_strings_can_be_null=False,
        ),
    }


def read_columns(
    path: Path,
    content: Content,
    pre: TextLayout,
    head: bytes,
    include_columns: list[str],
    labels: tuple[str, ...] = (),
) -> Columns:
    """Parse the data lines into numpy arrays of the included columns.

    pyarrow reads the file itself, in blocks of `_BLOCK_BYTES` parsed in turn, so neither
    the file's bytes nor more than a few blocks' parse buffers are held at once; its table
    (the included columns only) is turned into numpy arrays a column at a time, each column
    dropped from the table once copied, so at most one column is held twice. `labels` are
    text columns (a `surface` per sample), read as an index into their distinct labels.
    """
    header_start = _line_start(head, pre.header_line)
    tail = content.tail()
    cut_at = -1 if tail is None else _cut_start(*tail, header_start)
    with read_errors(path):
        stream = content.open()
    source, pieces = _source(stream, content, cut_at, header_start)
    parts = iter(pieces) if pieces is not None else None
    try:
        table = _parse(source, pieces, parts, pre, include_columns, labels)
    except LineTooLongError as long:
        raise _long_line_error(path, content, pre, long.start) from None
    except (OSError, pa.ArrowException) as exc:
        _parse_failed(path, content, pre, exc, pieces, parts, cut_at)
    finally:
        if parts is not None:
            parts.close()  # no read-ahead left inside the stream when it closes, whatever
            # ended the read (a bug, MemoryError, KeyboardInterrupt as much as a bad line)
        stream.close()
    if pieces is not None:
        cut_at = pieces.cut_at
    if cut_at is not None:
        raise _cut_line(path, content, pre, cut_at)
    if table.num_rows == 0:
        raise _header_only(path, pre)
    held = [table]  # `_columns` holds the only reference: each column freed once copied
    del table
    return _columns(held, content, pre, labels)


def _source(
    stream: pa.NativeFile, content: Content, cut_at: int | None, header_start: int
) -> tuple[pa.NativeFile | None, _Pieces | None]:
    """What pyarrow parses: the stream itself, the content less a cut last line, or (None)
    the stream's pieces (`_Pieces`, returned). A last line without a line end is never
    parsed; the lines before it are, so that an error earlier in the file is the one
    reported, whatever the source (file, .gz, bytes)."""
    if cut_at is None:
        return stream, None  # pyarrow reads the file itself: no Python in the loop
    if cut_at >= 0 and content.data is not None:
        return pa.BufferReader(pa.py_buffer(content.data).slice(0, cut_at)), None
    # compressed, or cut: the stream is watched for a last line without a line end
    return None, _Pieces(stream, header_start)


def _parse(
    source: pa.NativeFile | None,
    pieces: _Pieces | None,
    parts: Iterator[pa.Buffer] | None,
    pre: TextLayout,
    include_columns: list[str],
    labels: tuple[str, ...],
) -> pa.Table:
    """pyarrow's table of `source`, or of the `pieces` (`parts`, their iterator) parsed in
    turn and joined."""
    if pieces is None:
        return pacsv.read_csv(source, **_csv_options(pre, include_columns, True, labels))
    tables = [
        pacsv.read_csv(pa.BufferReader(piece), **_csv_options(pre, include_columns, k == 0, labels))
        for k, piece in enumerate(parts)
    ]
    if pieces.tail():  # blanks after the last line end (a cut line is never parsed)
        options = _csv_options(pre, include_columns, not tables, labels)
        tables.append(pacsv.read_csv(pa.BufferReader(pieces.tail()), **options))
    table = (
        pa.concat_tables(tables, memory_pool=_POOL)
        if tables
        else pacsv.read_csv(
            pa.BufferReader(b""), **_csv_options(pre, include_columns, True, labels)
        )
    )
    del tables
    return table


def _parse_failed(
    path: Path,
    content: Content,
    pre: TextLayout,
    exc: OSError | pa.ArrowException,
    pieces: _Pieces | None,
    parts: Iterator[pa.Buffer] | None,
    cut_at: int | None,
) -> NoReturn:
    """Raise the one-line error for a parse that failed with `exc`: a line longer than a
    block, a read error of the file or stream, a header with no line end, text where a
    number belongs, or the CSV as pyarrow could not read it."""
    if "straddling object" in str(exc):  # pyarrow met a line longer than a block
        start = _find_long_line(content)
        if start is not None:
            raise _long_line_error(path, content, pre, start) from None
    if pieces is not None:
        parts.close()  # the read under way is done: what it read is looked at next
        pieces.drain()
        cut_at = pieces.cut_at
    read_error = pieces.error if pieces is not None else None
    if read_error is None and pieces is None and not isinstance(exc, pa.ArrowInvalid):
        read_error = exc  # the file itself (a disk error), not its text
    if read_error is not None:
        with read_errors(path):
            raise read_error from None
    if "Could not skip initial" in str(exc):  # the header is the last line, unended
        raise _header_only(path, pre) from None
    if isinstance(exc, pa.ArrowInvalid):
        lines = LineMap(content, pre.header_line, cut_at)
        raise _parse_error(path, pre, str(exc), lines) from None
    raise LogError(
        f"cannot parse the CSV ({str(exc)[:100]})",
        file=path,
        fix="check the delimiter and quoting",
    ) from None


def _columns(
    held: list[pa.Table], content: Content, pre: TextLayout, labels: tuple[str, ...]
) -> Columns:
    """The columns of the table `held` (taken out of it: the caller keeps no reference) as
    numpy arrays, one at a time, each dropped from the table once copied; its text columns
    named; its `labels` as indices (`_label_index`)."""
    table = held.pop()
    names = table.column_names
    numeric = (pa.types.is_floating, pa.types.is_integer)
    text = {f.name for f in table.schema if not any(is_type(f.type) for is_type in numeric)}
    values = {}
    pool = _POOL
    release = table.nbytes >= _RELEASE_BYTES
    labelled = {name: _label_index(table[name]) for name in labels}
    for name in names:
        if name not in text and name not in labelled:
            chunks = [_numeric_values(chunk) for chunk in table[name].chunks]
            joined = np.concatenate(chunks) if len(chunks) > 1 else chunks[0].copy()
            values[name] = joined.astype(np.float64, copy=False)
            del chunks
        table = table.drop_columns([name])
        # pyarrow's allocator keeps freed blocks for its own reuse; the copies (and what
        # follows: checks, segmentation) allocate through numpy, so give each column of a
        # large table back before the next is copied: at most one column is held twice.
        # A small table's blocks are kept for the next parse (`_RELEASE_BYTES`).
        if release:
            pool.release_unused()
    del table
    return Columns(names, values, text - set(labels), LineMap(content, pre.header_line), labelled)


def _label_index(column: pa.ChunkedArray) -> tuple[np.ndarray, tuple[str, ...]]:
    """A text column as a per-sample index into its distinct non-empty labels (-1: empty)."""
    import pyarrow.compute as pc

    encoded = pc.dictionary_encode(pc.utf8_trim_whitespace(column.combine_chunks()))
    found = encoded.dictionary.to_pylist()
    kept = tuple(sorted(label for label in found if label))
    lookup = np.array([kept.index(label) if label else -1 for label in found] or [-1])
    codes = encoded.indices.to_numpy(zero_copy_only=False)
    return lookup[codes].astype(np.int16), kept


def _numeric_values(chunk: pa.Array) -> np.ndarray:
    """A numeric column chunk as numpy, nulls as NaN: what `chunk.to_numpy(zero_copy_only=
    False)` gives (a view of the values when there is no null), read from the chunk's
    buffers. `to_numpy` goes through pyarrow's pandas conversion, which imports pandas
    (~0.45 s of CPU, in every forked worker of a `fit` that needs no pandas otherwise)."""
    dtype = _NUMPY_OF[chunk.type.id]
    validity, data = chunk.buffers()[:2]
    values = np.frombuffer(
        data, dtype=dtype, count=len(chunk), offset=chunk.offset * dtype.itemsize
    )
    if chunk.null_count == 0:
        return values
    bits = np.unpackbits(np.frombuffer(validity, dtype=np.uint8), bitorder="little")
    missing = bits[chunk.offset : chunk.offset + len(chunk)] == 0
    # a copy (integers as float64, as to_numpy gives them): NaN where a value is missing
    values = values.astype(np.float64 if dtype.kind in "iu" else dtype)
    values[missing] = np.nan
    return values


#: numpy's type of each numeric arrow type (`pa.types.is_floating` / `is_integer`), by id
_NUMPY_OF = {
    arrow.id: np.dtype(numpy)
    for arrow, numpy in (
        (pa.float16(), np.float16),
        (pa.float32(), np.float32),
        (pa.float64(), np.float64),
        (pa.int8(), np.int8),
        (pa.int16(), np.int16),
        (pa.int32(), np.int32),
        (pa.int64(), np.int64),
        (pa.uint8(), np.uint8),
        (pa.uint16(), np.uint16),
        (pa.uint32(), np.uint32),
        (pa.uint64(), np.uint64),
    )
}
