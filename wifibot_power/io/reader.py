"""Read one log (canonical wbpower CSV or Keysight N6705 datalog) into a `Run`.

Parsing goes through pyarrow's CSV reader, reading the file itself in 1 MiB blocks parsed in
parallel (decompressed on the fly for .gz/.zst): the file's bytes are never held whole, only
the numeric columns used are kept, and they are copied to numpy a column at a time, so memory
follows the columns kept, not the file (docs/log-format.md, "Memory"). Per-sample work is
vectorised. The preamble (metadata lines, N6705 header, the first data lines) is parsed in
Python from the first 64 KiB: it is a handful of lines. Line numbers for messages are
worked out only when a message needs one, by reading the file again.

What is read where the spec is silent is described in docs/log-format.md.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from wifibot_power.errors import LogError
from wifibot_power.io.columns import (
    CANONICAL_COLUMNS,
    N6705_COLUMN,
    N6705_QUANTITY,
    PowerSource,
    channel_of,
    find_column,
    time_unit_of,
    unit_scale,
)
from wifibot_power.io.metadata import build_meta
from wifibot_power.io.options import (
    FORMAT_CANONICAL,
    FORMAT_N6705,
    LOG_SUFFIXES,
    TIME_UNITS,
    ReadOptions,
)
from wifibot_power.io.validate import check_samples, check_speed
from wifibot_power.run import Problem, Run

#: The canonical format versions this reader knows (`# wbpower-log: 1`).
KNOWN_VERSIONS = ("1",)
_HEAD_BYTES = 1 << 16
#: pyarrow parses blocks of this size in parallel and holds a few at once, whatever the file's
#: size. 1 MiB: fastest on the corpus's 41 MB logs and the smallest parse buffers (16 MiB
#: blocks hold ~70 MB of buffers; docs/log-format.md, "Memory").
_BLOCK_BYTES = 1 << 20
#: Bytes read at a time when a file is scanned again for line numbers.
_SCAN_BYTES = 1 << 20
_UTF8_BOM = b"\xef\xbb\xbf"
#: The scale of a time "column" that is a sample index (N6705 `Sample`): x the sample period.
_INDEX = 0.0
#: Canonical time columns (log-format.md): these win over other time-like columns.
CANONICAL_TIME_COLUMNS = ("time_s", "time_ms", "time_us")
#: Data lines of the head looked at to tell the decimal mark and the field count.
_SNIFF_LINES = 50
_LINE_END = re.compile(r"\r\n|\r|\n")
_LINE_END_BYTES = re.compile(rb"\r\n|\r|\n")
_COLUMN_IN_MESSAGE = re.compile(r"column #(\d+)")
_INVALID_VALUE = re.compile(r"invalid value '(.*)'")
_DECIMAL_COMMA_CELL = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*$")
_DECIMAL_POINT_CELL = re.compile(r"^\s*[+-]?\d*\.\d+(?:[eE][+-]?\d+)?\s*$")


@dataclass(frozen=True)
class _Preamble:
    format: str
    header_line: int  # 0-based index of the header row in the file
    header: list[str]
    metadata: dict[str, str]
    delimiter: str
    decimal_comma: bool
    #: metadata key -> where it was set ("line 3"), for messages
    metadata_where: dict[str, str] = field(default_factory=dict)


@contextmanager
def _read_errors(path: Path) -> Iterator[None]:
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


def _codec(path: Path) -> str | None:
    name = path.name.lower()
    return "gzip" if name.endswith(".gz") else "zstd" if name.endswith(".zst") else None


def read_bytes(path: Path) -> bytes:
    """The file's bytes, decompressed by extension (.gz, .zst)."""
    with _read_errors(path):
        codec = _codec(path)
        if codec is not None:
            with pa.input_stream(str(path), compression=codec) as stream:
                return stream.read()
        return path.read_bytes()


@dataclass(frozen=True)
class _Content:
    """A log's (decompressed) bytes, opened afresh for each pass over them: from the file, or
    from `data` when the caller already holds them."""

    path: Path
    data: bytes | None = None

    def open(self) -> pa.NativeFile:
        """A stream of the bytes from the start (errors surface as they are read)."""
        if self.data is not None:
            return pa.BufferReader(self.data)
        return pa.input_stream(str(self.path), compression=_codec(self.path))

    def head(self) -> bytes:
        """The first bytes: `_HEAD_BYTES` after a byte-order mark, and one more to tell whether
        the content goes on."""
        with _read_errors(self.path), self.open() as stream:
            return stream.read(_HEAD_BYTES + len(_UTF8_BOM) + 1)

    def chunks(self, limit: int | None = None, size: int = _SCAN_BYTES) -> Iterator[bytes]:
        """The bytes in pieces of `size`, up to `limit` bytes if given."""
        left = limit
        with _read_errors(self.path), self.open() as stream:
            while left is None or left > 0:
                chunk = stream.read(size if left is None else min(size, left))
                if not chunk:
                    return
                if left is not None:
                    left -= len(chunk)
                yield chunk

    def tail(self) -> tuple[bytes, int] | None:
        """The last `_HEAD_BYTES` bytes and the size of the whole, when they can be had without
        reading the rest (bytes in memory, an uncompressed file); else None."""
        if self.data is not None:
            return self.data[-_HEAD_BYTES:], len(self.data)
        if _codec(self.path) is not None:
            return None
        with _read_errors(self.path), pa.OSFile(str(self.path)) as stream:
            size = stream.size()
            stream.seek(max(size - _HEAD_BYTES, 0))
            return stream.read(), size

    def is_blank(self) -> bool:
        """Nothing but blanks (or nothing) after a UTF-8 byte-order mark."""
        chunks = self.chunks()
        first = next(chunks, b"").removeprefix(_UTF8_BOM)
        return (not first or first.isspace()) and all(chunk.isspace() for chunk in chunks)


def read_log(
    path: str | Path,
    options: ReadOptions | None = None,
    overrides: dict[str, str] | None = None,
    *,
    data: bytes | None = None,
    origin: str | None = None,
) -> Run:
    """Read a log file into a `Run`; `overrides` (manifest values) win over the file's metadata.

    `data` gives the (decompressed) bytes instead of reading `path`; `origin` says where the
    overrides come from (e.g. "runs.csv line 4"), so a contradiction names that row.
    Raises `LogError` with a one-line message for anything it cannot read honestly.
    """
    options = options or ReadOptions()
    path = Path(path)
    named = tuple(
        c
        for c in (
            options.current_column,
            options.voltage_column,
            options.speed_column,
            options.time_column,
            *options.power_columns,
        )
        if c
    )
    content, head = _decode(path, _Content(path, data))
    pre = _parse_preamble(path, content, head, named)
    sources = _power_sources(path, pre, pre.header, options)
    time_spec, time_problems = _time_source(path, pre, options)
    speed_column = _speed_column(path, pre, options)
    # only the columns used are converted to numbers (about a third of the parse time saved
    # on the 4-column canonical log); every line's field count is still checked
    used = list(dict.fromkeys(name for source in sources for name in source.columns()))
    used += [name for name in (time_spec and time_spec[0], speed_column) if name]
    columns = _read_columns(path, content, pre, head, used)
    lines = columns.lines
    values = dict(pre.metadata)
    where = {k: f"metadata {w}" for k, w in pre.metadata_where.items()}
    for key, value in (overrides or {}).items():
        values[key] = value
        where[key] = origin or "manifest"
    has_time = time_spec is not None and time_spec[1] != _INDEX
    if options.sample_period_s is not None and not has_time:
        values["sample_period_s"] = repr(options.sample_period_s)
        where["sample_period_s"] = "--sample-period"
    if pre.format == FORMAT_N6705 and "sample_period_s" not in values:
        raise LogError(
            "N6705 export without a 'Sample interval' line",
            file=path,
            fix="give the sample spacing with --sample-period S, or re-export the datalog",
        )
    meta = build_meta(values, file=str(path), stem=_stem(path), where="metadata", origins=where)
    power_W, channels_W, measured = _power(path, columns, sources, options.flip_current)
    time_s = _time(path, pre, columns, time_spec, meta.sample_period_s)
    speed_mps = _column(path, columns, (speed_column, 1.0)) if speed_column else None
    columns.values.clear()  # the arrays live on in power_W, measured and time_s only
    period_s, problems = check_samples(
        str(path),
        time_s,
        power_W,
        line_of=lines.line_of,
        default_period_s=meta.sample_period_s,
        measured=measured,
    )
    del measured
    if speed_mps is not None:
        check_speed(str(path), speed_column, speed_mps, line_of=lines.line_of)
    if time_s is None:
        time_s = np.arange(power_W.size) * period_s
    elif period_s != meta.sample_period_s:
        values["sample_period_s"] = repr(period_s)
        meta = build_meta(values, file=str(path), stem=_stem(path), where="metadata", origins=where)
    return Run(
        file=str(path),
        format=pre.format,
        meta=meta,
        time_s=time_s,
        power_W=power_W,
        problems=(*time_problems, *problems),
        speed_mps=speed_mps,
        channels_W=channels_W,
    )


def _speed_column(path: Path, pre: _Preamble, options: ReadOptions) -> str | None:
    """The speed column (log-format.md, "Speed"): `--speed-column`, which must exist, else a
    `speed_mps` column if the log has one."""
    if options.speed_column:
        found = find_column(pre.header, options.speed_column)
        if found is None:
            raise LogError(
                f"no column '{options.speed_column}' (columns: {', '.join(pre.header)})",
                file=path,
                where=f"line {pre.header_line + 1}",
                fix="check --speed-column",
            )
        return found
    return find_column(pre.header, "speed_mps")


def _time_source(
    path: Path, pre: _Preamble, options: ReadOptions
) -> tuple[tuple[str, float] | None, list[Problem]]:
    """The time column and its scale to seconds (log-format.md: a column whose name says it is
    time is never silently ignored in favour of an assumed sample period), and a problem to
    report when one is left out because `--sample-period` was given instead.

    An N6705 export's time is its `Sample` index (scale: the sample interval, applied later).
    """
    unit_scale_s = TIME_UNITS[options.time_unit] if options.time_unit else None
    if options.time_column:
        found = find_column(pre.header, options.time_column)
        if found is None:
            raise LogError(
                f"no column '{options.time_column}' (columns: {', '.join(pre.header)})",
                file=path,
                where=f"line {pre.header_line + 1}",
                fix="check --time-column",
            )
        scale = unit_scale_s if unit_scale_s is not None else time_unit_of(found)[1]
        if scale is None:
            raise LogError(
                f"the unit of time column '{found}' is unknown",
                file=path,
                where=f"line {pre.header_line + 1}",
                fix="give --time-unit s|ms|us",
            )
        return (found, scale), []
    if pre.format == FORMAT_N6705:
        sample = find_column(pre.header, "Sample")
        return ((sample, _INDEX) if sample else None), []
    timelike = [(name, time_unit_of(name)[1]) for name in pre.header if time_unit_of(name)[0]]
    if not timelike:
        return None, []
    canonical = [t for t in timelike if t[0].strip().lower() in CANONICAL_TIME_COLUMNS]
    if len(timelike) > 1 and len(canonical) == 1:
        timelike = canonical  # time_s beside, say, a clock-time column: time_s is the time
    if len(timelike) > 1:
        raise LogError(
            f"several time columns ({', '.join(repr(t[0]) for t in timelike)})",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix="name the one to use with --time-column (and --time-unit)",
        )
    ((name, scale),) = timelike
    if unit_scale_s is not None:
        return (name, unit_scale_s), []
    if scale is not None:
        return (name, scale), []
    if options.sample_period_s is not None:
        note = (
            f"column '{name}' looks like time but its unit is unknown: not used, samples "
            f"spaced at --sample-period {options.sample_period_s:g} s instead"
        )
        return None, [Problem("time_ignored", note)]
    raise LogError(
        f"column '{name}' looks like time, but its name gives no unit",
        file=path,
        where=f"line {pre.header_line + 1}",
        fix="give --time-unit s|ms|us, or --sample-period S to space samples evenly instead",
    )


def _stem(path: Path) -> str:
    name = path.name
    for suffix in LOG_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def _not_a_log(path: Path, why: str, where: str | None = None) -> LogError:
    return LogError(
        f"not a power log ({why})",
        file=path,
        where=where,
        fix="give a wbpower CSV (see docs/log-format.md) or a Keysight N6705 datalog export",
    )


def _decode(path: Path, content: _Content) -> tuple[_Content, bytes]:
    """A UTF-16 file (with its BOM, as spreadsheets save "Unicode text") is converted to UTF-8
    in memory (such exports are small); anything else is read as it is. A UTF-8 BOM is left
    in place: it sits in the first line, which the CSV parse skips, and the preamble drops it.
    Both BOMs are unambiguous."""
    head = content.head()
    if not head.startswith((b"\xff\xfe", b"\xfe\xff")):
        return content, head
    raw = read_bytes(path) if content.data is None else content.data
    try:
        utf8 = _Content(path, raw.decode("utf-16").lstrip("\ufeff").encode("utf-8"))
    except UnicodeDecodeError:
        raise _not_a_log(path, "broken UTF-16 text") from None
    return utf8, utf8.head()


class _LineMap:
    """File line numbers (1-based) of data rows, worked out only when a message needs one, by
    reading the content again up to `limit` bytes (where a cut last line starts)."""

    def __init__(self, content: _Content, header_line: int, limit: int | None = None) -> None:
        self._content = content
        self._header_line = header_line
        self._limit = limit
        self._rows: np.ndarray | None = None
        self._line_ends = 0

    def _scan(self) -> np.ndarray:
        if self._rows is None:
            self._rows, self._line_ends = _scan_lines(
                self._content.chunks(self._limit), self._header_line
            )
        return self._rows

    def line_of(self, row: int) -> int:
        """Line of data row `row` (pyarrow skips empty lines, so they are skipped here too)."""
        rows = self._scan()
        if not rows.size:
            return self._header_line + 2
        return int(rows[min(max(row, 0), rows.size - 1)])

    def line_count(self) -> int:
        """Line ends up to the limit (a \\r\\n counts once)."""
        self._scan()
        return self._line_ends

    def find(self, match: Callable[[bytes], bool]) -> tuple[int, bytes] | None:
        """First data line (1-based) for which `match(line bytes)` holds, and the line."""
        for index, line in enumerate(_iter_lines(self._content.chunks(self._limit))):
            if index > self._header_line and line and match(line):
                return index + 1, line
        return None


def _iter_lines(chunks: Iterator[bytes]) -> Iterator[bytes]:
    """The lines of the concatenated chunks, as `_LINE_END_BYTES.split` of the whole gives them."""
    carry = b""
    for chunk in chunks:
        buffer = carry + chunk
        # a \r at the end may be the first half of a \r\n: keep it for the next chunk
        held = b"\r" if buffer.endswith(b"\r") else b""
        parts = _LINE_END_BYTES.split(buffer[: len(buffer) - len(held)])
        carry = parts.pop() + held
        yield from parts
    yield from _LINE_END_BYTES.split(carry)


def _scan_lines(chunks: Iterator[bytes], header_line: int) -> tuple[np.ndarray, int]:
    """Line numbers (1-based) of the non-empty lines after line `header_line` (0-based), and
    the number of line ends (\\r\\n, \\r or \\n, as pyarrow and `_LINE_END_BYTES` know them).
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


def _split_lines(text: str) -> list[str]:
    # the same line ends pyarrow knows (\r\n, \r, \n); str.splitlines knows more
    return _LINE_END.split(text)


def _parse_preamble(
    path: Path, content: _Content, head: bytes, extra_columns: tuple[str, ...] = ()
) -> _Preamble:
    """The preamble, from the content's first bytes (`_Content.head`)."""
    head = head.removeprefix(_UTF8_BOM)
    more = len(head) > _HEAD_BYTES
    head = head[:_HEAD_BYTES]
    if not head or (head.isspace() and (not more or content.is_blank())):
        raise LogError("the file is empty", file=path, fix="re-export the log")
    if b"\x00" in head:
        raise _not_a_log(path, "binary data")
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
    lines = _split_lines(text)
    if more:
        lines = lines[:-1]  # the last line of the head may be cut by the head limit
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    if re.match(r"^N6705[ABC]?\b", first, re.IGNORECASE):
        return _n6705_preamble(path, lines)
    return _canonical_preamble(path, lines, extra_columns)


def _header_cells(line: str, delimiter: str) -> list[str]:
    cells = next(csv.reader([line], delimiter=delimiter), [])
    return [c.strip() for c in cells]


def _canonical_preamble(path: Path, lines: list[str], extra_columns: tuple[str, ...]) -> _Preamble:
    metadata: dict[str, str] = {}
    where: dict[str, str] = {}
    wanted = set(CANONICAL_COLUMNS) | {c.strip().lower() for c in extra_columns}
    for index, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            body = stripped.lstrip("#").strip()
            if ":" in body:
                key, _, value = body.partition(":")
                metadata[key.strip().lower()] = value.strip()
                where[key.strip().lower()] = f"line {index + 1}"
            continue
        delimiter = _delimiter(stripped)
        header = _header_cells(stripped, delimiter)
        # with columns named by options, the first such line is the header whatever it holds
        # (a named column it lacks is then reported by name)
        if not extra_columns and not any(h.lower() in wanted or channel_of(h) for h in header):
            if any(ch.isdigit() for ch in stripped) and not any(ch.isalpha() for ch in stripped):
                raise _not_a_log(path, "data but no header row", where=f"line {index + 1}")
            raise _not_a_log(
                path,
                "no header row with power_W, voltage_V x current_A or current_A",
                where=f"line {index + 1}",
            )
        version = metadata.get("wbpower-log")
        if version is not None and version not in KNOWN_VERSIONS:
            raise LogError(
                f"wbpower-log version '{version}' is not one this wbpower reads",
                file=path,
                where=where["wbpower-log"],
                fix="update wbpower, or re-export as version 1",
            )
        _check_header(path, header, index)
        decimal_comma = _sniff_data(path, lines, index, header, delimiter)
        return _Preamble(FORMAT_CANONICAL, index, header, metadata, delimiter, decimal_comma, where)
    if metadata:
        raise LogError(
            "metadata only: no header row and no samples",
            file=path,
            fix="the log holds no data; re-export it",
        )
    raise _not_a_log(path, "no header row")


def _n6705_preamble(path: Path, lines: list[str]) -> _Preamble:
    metadata: dict[str, str] = {"instrument": lines[0].split()[0] if lines else "N6705"}
    where: dict[str, str] = {}
    for index, line in enumerate(lines):
        stripped = line.strip().strip('"')
        lowered = stripped.lower()
        for prefix, key in (
            ("sample interval:", "sample_period_s"),
            ("trigger sample:", "trigger_sample"),
            ("date:", "date"),
        ):
            if lowered.startswith(prefix):
                metadata[key] = stripped.split(":", 1)[1].strip()
                where[key] = f"line {index + 1}"
        if lowered.startswith("sample") and any(d in stripped for d in ",;\t"):
            delimiter = _delimiter(line.strip())
            header = _header_cells(line.strip(), delimiter)
            _check_header(path, header, index)
            decimal_comma = _sniff_data(path, lines, index, header, delimiter)
            return _Preamble(FORMAT_N6705, index, header, metadata, delimiter, decimal_comma, where)
    raise LogError(
        "N6705 export without a 'Sample,...' header row",
        file=path,
        fix="re-export the datalog as CSV from the analyser",
    )


def _check_header(path: Path, header: list[str], index: int) -> None:
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


def _delimiter(header: str) -> str:
    counts = {d: header.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] else ","


def _sniff_data(
    path: Path, lines: list[str], header_index: int, header: list[str], delimiter: str
) -> bool:
    """Whether numbers use a decimal comma; a first data line whose field count does not match
    the header (e.g. decimal commas in a ','-separated file) is an error here, with a hint."""
    data = [(k, ln) for k, ln in enumerate(lines[header_index + 1 :], start=header_index + 2) if ln]
    data = data[:_SNIFF_LINES]
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


def _line_start(head: bytes, index: int) -> int:
    """Byte offset of line `index` (0-based) in `head`."""
    if index == 0:
        return 0
    for count, match in enumerate(_LINE_END_BYTES.finditer(head), start=1):
        if count == index:
            return match.end()
    return len(head)


class _HoldBackCutLine(io.RawIOBase):
    """The content as a stream for pyarrow, less a last line that has no line end.

    A last data line with no line end is what a full disk or a cut copy leaves: it may hold a
    shortened number (23.3102 -> 23.3), so it is never parsed, and the read stops with an
    error (`_cut_line`). What follows the last line end seen so far is held back until more
    comes; at the end, what is held is kept out if it is more than blanks and starts after
    `header_start` (a header with no line end stays: "header only" follows). `cut_at` is then
    where that line starts.
    """

    def __init__(self, stream: pa.NativeFile, header_start: int) -> None:
        super().__init__()
        self._stream = stream
        self._header_start = header_start
        self._ready = b""  # bytes that can be handed out
        self._held = b""  # the bytes after the last line end seen
        self._consumed = 0  # bytes taken from `stream`
        self._ended = False
        self.cut_at: int | None = None
        #: the exception reading the file raised (pyarrow may wrap it in its own)
        self.error: BaseException | None = None

    def readable(self) -> bool:
        return True

    def read(self, size: int | None = -1) -> bytes:
        if size == 0:
            return b""
        want = _BLOCK_BYTES if size is None or size < 0 else size
        while not self._ready and not self._ended:
            # what is held and what is read fit in `want`: handed out whole, not re-cut
            self._pull(max(want - len(self._held), 1))
        out, self._ready = self._ready[:want], self._ready[want:]
        return out

    def readinto(self, buffer: memoryview) -> int:  # pragma: no cover - pyarrow calls read()
        data = self.read(len(buffer))
        buffer[: len(data)] = data
        return len(data)

    def _pull(self, size: int) -> None:
        try:
            chunk = self._stream.read(size)
        except (OSError, pa.ArrowException) as exc:
            self.error = exc
            raise
        if not chunk:
            self._ended = True
            tail_start = self._consumed - len(self._held)
            if self._held.strip() and tail_start > self._header_start:
                self.cut_at = tail_start
            else:
                self._ready += self._held
            self._held = b""
            return
        self._consumed += len(chunk)
        buffer = self._held + chunk
        last = max(buffer.rfind(b"\n"), buffer.rfind(b"\r"))
        if last < 0:
            self._held = buffer  # a line longer than `size`: read on until it ends
        else:
            self._ready += buffer[: last + 1]
            self._held = buffer[last + 1 :]


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


@dataclass
class _Columns:
    """The columns read from a log, as numpy arrays (a column of text is named, not held)."""

    names: list[str]
    values: dict[str, np.ndarray]
    text: set[str]
    lines: _LineMap


def _read_columns(
    path: Path, content: _Content, pre: _Preamble, head: bytes, include_columns: list[str]
) -> _Columns:
    """Parse the data lines into numpy arrays of the included columns.

    pyarrow reads the file itself, in blocks of `_BLOCK_BYTES` parsed in parallel, so neither
    the file's bytes nor more than a few blocks' parse buffers are held at once; its table
    (the included columns only) is turned into numpy arrays a column at a time, each column
    dropped from the table once copied, so at most one column is held twice.
    """
    header_start = _line_start(head, pre.header_line)
    tail = content.tail()
    cut_at = -1 if tail is None else _cut_start(*tail, header_start)
    with _read_errors(path):
        stream = content.open()
    held_back: _HoldBackCutLine | None = None
    # a last line without a line end is never parsed; the lines before it are, so that an
    # error earlier in the file is the one reported, whatever the source (file, .gz, bytes)
    if cut_at is None:
        source = stream  # pyarrow reads the file itself: no Python in the loop
    elif cut_at >= 0 and content.data is not None:
        source = pa.BufferReader(pa.py_buffer(content.data).slice(0, cut_at))
    else:  # compressed, or cut: the stream is watched for a last line without a line end
        held_back = _HoldBackCutLine(stream, header_start)
        source = pa.PythonFile(held_back, mode="r")
    try:
        table = pacsv.read_csv(
            source,
            read_options=pacsv.ReadOptions(
                skip_rows=pre.header_line + 1, column_names=pre.header, block_size=_BLOCK_BYTES
            ),
            parse_options=pacsv.ParseOptions(delimiter=pre.delimiter),
            convert_options=pacsv.ConvertOptions(
                column_types=dict.fromkeys(include_columns, pa.float64()),
                decimal_point="," if pre.decimal_comma else ".",
                include_columns=include_columns,
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except (OSError, pa.ArrowException) as exc:
        if held_back is not None:
            cut_at = held_back.cut_at
        read_error = held_back.error if held_back is not None else None
        if read_error is None and held_back is None and not isinstance(exc, pa.ArrowInvalid):
            read_error = exc  # the file itself (a disk error), not its text
        if read_error is not None:
            with _read_errors(path):
                raise read_error from None
        if "Could not skip initial" in str(exc):  # the header is the last line, unended
            raise _header_only(path, pre) from None
        if isinstance(exc, pa.ArrowInvalid):
            lines = _LineMap(content, pre.header_line, cut_at)
            raise _parse_error(path, pre, str(exc), lines) from None
        raise LogError(
            f"cannot parse the CSV ({str(exc)[:100]})",
            file=path,
            fix="check the delimiter and quoting",
        ) from None
    finally:
        stream.close()
    if held_back is not None:
        cut_at = held_back.cut_at
    if cut_at is not None:
        raise _cut_line(path, content, pre, cut_at)
    if table.num_rows == 0:
        raise _header_only(path, pre)
    names = table.column_names
    numeric = (pa.types.is_floating, pa.types.is_integer)
    text = {f.name for f in table.schema if not any(is_type(f.type) for is_type in numeric)}
    values = {}
    pool = pa.default_memory_pool()
    for name in names:
        if name not in text:
            pieces = [chunk.to_numpy(zero_copy_only=False) for chunk in table[name].chunks]
            joined = np.concatenate(pieces) if len(pieces) > 1 else pieces[0].copy()
            values[name] = joined.astype(np.float64, copy=False)
            del pieces
        table = table.drop_columns([name])
        # pyarrow's allocator keeps freed blocks for its own reuse; the copies (and what
        # follows: checks, segmentation) allocate through numpy, so give each column back
        # before the next is copied: at most one column is held twice
        pool.release_unused()
    del table
    return _Columns(names, values, text, _LineMap(content, pre.header_line))


def _cut_line(path: Path, content: _Content, pre: _Preamble, cut_at: int) -> LogError:
    """The last line has no line end (log-format.md: a truncated last line is bad input)."""
    line = _LineMap(content, pre.header_line, cut_at).line_count() + 1
    return LogError(
        "the last line has no line end: the file may be cut short, and a cut line can hold a "
        "shortened number (23.3102 -> 23.3)",
        file=path,
        where=f"line {line}",
        fix="re-copy the file; if the line is complete, end it with a line break, or delete "
        "it to read the rest",
    )


def _header_only(path: Path, pre: _Preamble) -> LogError:
    return LogError(
        "header only: no samples",
        file=path,
        where=f"line {pre.header_line + 1}",
        fix="the log holds no data; re-export it",
    )


def _parse_error(path: Path, pre: _Preamble, message: str, lines: _LineMap) -> LogError:
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


def _power_sources(
    path: Path, pre: _Preamble, names: list[str], options: ReadOptions
) -> list[PowerSource]:
    """The channels whose power, summed, is the robot's power (one, unless the log has several
    channels or several `--power-column`s)."""
    if options.power_columns:
        return [
            PowerSource(power=_lookup(path, names, wanted, "--power-column"), name=wanted)
            for wanted in dict.fromkeys(options.power_columns)
        ]
    if options.current_column or options.voltage_column:
        return [_named_source(path, names, options)]
    if pre.format == FORMAT_CANONICAL:
        return _canonical_sources(path, pre, names, options)
    return [_n6705_source(path, pre, names, options)]


def _canonical_sources(
    path: Path, pre: _Preamble, names: list[str], options: ReadOptions
) -> list[PowerSource]:
    lowered = {n.strip().lower(): n for n in names}

    def first(*keys: str) -> tuple[str, float] | None:
        key = next((k for k in keys if k in lowered), None)
        return (lowered[key], CANONICAL_COLUMNS[key][1]) if key else None

    power = first("power_w", "power_mw")
    if power:
        return [PowerSource(power=power)]
    current, voltage = first("current_a", "current_ma"), first("voltage_v", "voltage_mv")
    if current and voltage:
        return [PowerSource(current=current, voltage=voltage)]
    channels = _channels(path, pre, names, voltage, options)
    if channels:
        return channels
    if current and options.supply_voltage_V:
        return [PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)]
    if current:
        raise LogError(
            "current only, no power or voltage column",
            file=path,
            fix="give --supply-voltage V, or name the voltage column with --voltage-column",
        )
    raise LogError(
        "no power_W, power_mW, or voltage_V x current_A columns",
        file=path,
        where=f"line {pre.header_line + 1}",
        fix="name the columns as in docs/log-format.md, or use --power-column, or "
        "--current-column and --voltage-column",
    )


def _channels(
    path: Path,
    pre: _Preamble,
    names: list[str],
    shared_voltage: tuple[str, float] | None,
    options: ReadOptions,
) -> list[PowerSource]:
    """Canonical channels (log-format.md, "Several channels"): `power_<name>_W`, else
    `current_<name>_A` x `voltage_<name>_V`, else x the shared `voltage_V` (motors on one
    bus), else x `--supply-voltage`. A lone `voltage_<name>_V` is not power and is not read."""
    found: dict[str, dict[str, tuple[str, float]]] = {}
    for name in names:
        parsed = channel_of(name)
        if parsed is not None:
            quantity, channel, scale = parsed
            if quantity in found.setdefault(channel, {}):
                raise LogError(
                    f"channel '{channel}' has two {quantity} columns "
                    f"('{found[channel][quantity][0]}', '{name}')",
                    file=path,
                    where=f"line {pre.header_line + 1}",
                    fix="keep one of them",
                )
            found[channel][quantity] = (name, scale)
    sources = []
    for channel, quantities in found.items():
        if "power" in quantities:
            sources.append(PowerSource(power=quantities["power"], name=channel))
        elif "current" in quantities:
            voltage = quantities.get("voltage", shared_voltage)
            if voltage is None and options.supply_voltage_V is None:
                raise LogError(
                    f"channel '{channel}' has a current column "
                    f"('{quantities['current'][0]}') but no voltage",
                    file=path,
                    where=f"line {pre.header_line + 1}",
                    fix=f"add voltage_{channel}_V or voltage_V, or give --supply-voltage V",
                )
            sources.append(
                PowerSource(
                    current=quantities["current"],
                    voltage=voltage,
                    supply_voltage_V=None if voltage else options.supply_voltage_V,
                    name=channel,
                )
            )
    return sources


def _n6705_source(
    path: Path, pre: _Preamble, names: list[str], options: ReadOptions
) -> PowerSource:
    outputs: dict[str, dict[str, str]] = {}
    for name in names:
        match = N6705_COLUMN.match(name)
        if match and match.group(2).lower() == "avg":
            outputs.setdefault(match.group(3), {})[N6705_QUANTITY[match.group(1).lower()]] = name
    with_power = [k for k, q in outputs.items() if "power" in q]
    with_both = [k for k, q in outputs.items() if "current" in q and "voltage" in q]
    currents = [k for k, q in outputs.items() if "current" in q]
    if options.supply_voltage_V is not None:
        if len(currents) == 1:
            return PowerSource(
                current=(outputs[currents[0]]["current"], 1.0),
                supply_voltage_V=options.supply_voltage_V,
            )
        if len(currents) > 1:
            raise LogError(
                f"several current columns ({', '.join(outputs[k]['current'] for k in currents)})",
                file=path,
                fix="name the one to use with --current-column",
            )
    for candidates, build in (
        (with_power, lambda k: PowerSource(power=(outputs[k]["power"], 1.0))),
        (
            with_both,
            lambda k: PowerSource(
                current=(outputs[k]["current"], 1.0), voltage=(outputs[k]["voltage"], 1.0)
            ),
        ),
    ):
        if len(candidates) == 1:
            return build(candidates[0])
        if len(candidates) > 1:
            raise LogError(
                f"several analyser outputs log power (outputs {', '.join(sorted(candidates))})",
                file=path,
                fix="name the columns to use with --current-column and --voltage-column, or "
                "sum outputs with --power-column 'Power avg 1' --power-column 'Power avg 2'",
            )
    if currents:
        have = ", ".join(f"'{n}'" for q in outputs.values() for n in q.values())
        raise LogError(
            f"no analyser output has both current and voltage (columns {have})",
            file=path,
            fix="give --supply-voltage V (power = current x V), or name the columns with "
            "--current-column and --voltage-column",
        )
    raise LogError(
        "no 'Curr avg K' or 'Power avg K' column",
        file=path,
        where=f"line {pre.header_line + 1}",
        fix="export the datalog with current logged",
    )


def _lookup(path: Path, names: list[str], wanted: str, option: str) -> tuple[str, float]:
    """A column named with an option, and its scale from its unit suffix."""
    found = find_column(names, wanted)
    if found is None:
        raise LogError(
            f"no column '{wanted}' (columns: {', '.join(names)})",
            file=path,
            fix=f"check {option}",
        )
    return found, unit_scale(found)


def _named_source(path: Path, names: list[str], options: ReadOptions) -> PowerSource:
    if not options.current_column:
        raise LogError(
            "--voltage-column needs --current-column too", file=path, fix="name both columns"
        )
    current = _lookup(path, names, options.current_column, "--current-column")
    if options.voltage_column:
        return PowerSource(
            current=current,
            voltage=_lookup(path, names, options.voltage_column, "--voltage-column"),
        )
    if options.supply_voltage_V is None:
        raise LogError(
            "--current-column needs a voltage",
            file=path,
            fix="give --voltage-column or --supply-voltage",
        )
    return PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)


def _column(path: Path, columns: _Columns, spec: tuple[str, float]) -> np.ndarray:
    name, scale = spec
    if name in columns.text:
        raise LogError(
            f"column '{name}' holds text, not numbers",
            file=path,
            where=f"column '{name}'",
            fix="fix the column or re-export",
        )
    return _scaled(columns.values[name], scale)


def _scaled(values: np.ndarray, scale: float) -> np.ndarray:
    """`values * scale`, in place when the array is ours to change (no second full-size copy)."""
    if scale == 1.0:
        return values
    if values.flags.writeable and values.flags.owndata:
        values *= scale
        return values
    return values * scale


def _power(
    path: Path, columns: _Columns, sources: list[PowerSource], flip: bool
) -> tuple[np.ndarray, dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Power [W] (the sum of the channels), each channel's power when there are several, and
    the measured columns power comes from (checked for clipping)."""
    measured: dict[str, np.ndarray] = {}
    channels: dict[str, np.ndarray] = {}
    for source in sources:
        if source.power:
            power_W = _column(path, columns, source.power)
            measured[source.power[0]] = power_W
        else:
            current_A = _column(path, columns, source.current)
            measured[source.current[0]] = current_A
            if source.voltage:
                voltage_V = _column(path, columns, source.voltage)
                measured[source.voltage[0]] = voltage_V
                power_W = current_A * voltage_V
            else:
                power_W = current_A * float(source.supply_voltage_V)
        if flip:
            power_W = -power_W  # a new array: the measured columns stay as measured
        channels[source.name] = power_W
    if len(channels) == 1:
        return next(iter(channels.values())), {}, measured
    total_W = np.sum(list(channels.values()), axis=0)
    return total_W, channels, measured


def _time(
    path: Path,
    pre: _Preamble,
    columns: _Columns,
    spec: tuple[str, float] | None,
    period_s: float,
) -> np.ndarray | None:
    """Time stamps [s] from the time column (an index x the sample period for N6705)."""
    if spec is None:
        return None
    name, scale = spec
    return _scaled(_column(path, columns, (name, 1.0)), period_s if scale == _INDEX else scale)
