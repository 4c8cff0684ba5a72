"""The reader streams the file: it never holds the file's bytes, finds line numbers by reading
the file again, and stops at a cut last line the same way whatever the source.

Expected values are worked out by hand from the text written (line numbers counted from the
lines built here); the line scanner is checked against the plain `re.split` of the whole text.
"""

from __future__ import annotations

import gzip
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.errors import LogError
from wifibot_power.io import read_log
from wifibot_power.io.lines import LineMap, plain_lines
from wifibot_power.io.transport import iter_lines as _iter_lines
from wifibot_power.io.transport import scan_lines as _scan_lines

PERIOD_S = 0.1024e-3
HEAD = "# wbpower-log: 1\n# run_id: s\n# mode: idle\ntime_s,power_W\n"  # header: line 4


def _rows(power_W: np.ndarray, start: int = 0, end: str = "\n") -> str:
    times_s = (start + np.arange(power_W.size)) * PERIOD_S
    return "".join(f"{t:.7f},{p:.4f}{end}" for t, p in zip(times_s, power_W, strict=True))


def _write(path: Path, text: str) -> Path:
    """`text` as the file `path` names it: plain, gzip or zstd."""
    data = text.encode()
    if path.name.endswith(".gz"):
        path.write_bytes(gzip.compress(data))
    elif path.name.endswith(".zst"):
        with pa.output_stream(str(path), compression="zstd") as out:
            out.write(data)
    else:
        path.write_bytes(data)
    return path


def _chunked(data: bytes, size: int) -> list[bytes]:
    return [data[k : k + size] for k in range(0, len(data), size)]


# -- line numbers: a streaming scan equals the split of the whole text ----------------------


@settings(max_examples=300, deadline=None)
@given(
    text=st.lists(st.sampled_from([b"a", b",", b"\n", b"\r", b"\r\n", b""]), max_size=60).map(
        b"".join
    ),
    chunk=st.integers(1, 9),
    header_line=st.integers(0, 4),
)
def test_line_scan_in_chunks_matches_the_split_of_the_whole(text, chunk, header_line):
    # the definition the reader had when it held the whole file: split at \r\n, \r or \n;
    # data rows are the non-empty lines after the header (pyarrow skips empty lines)
    lines = re.split(rb"\r\n|\r|\n", text)
    rows = [k + 1 for k in range(header_line + 1, len(lines)) if lines[k]]
    found, line_ends = _scan_lines(iter(_chunked(text, chunk)), header_line)
    assert found.tolist() == rows
    assert line_ends == len(lines) - 1
    assert list(_iter_lines(iter(_chunked(text, chunk)))) == lines


@settings(max_examples=400, deadline=None)
@given(
    text=st.lists(
        st.sampled_from([b"a", b",", b"\n", b"\n", b"a,a\n", b"\r", b""]), max_size=60
    ).map(b"".join),
    chunk=st.integers(1, 9),
    header_line=st.integers(0, 4),
)
def test_plain_line_count_agrees_with_the_scan(text, chunk, header_line):
    # the shortcut for logs whose lines end in \n and have no empty data line: the same
    # numbers as the scan, and taken exactly when the text is so
    lines = re.split(rb"\r\n|\r|\n", text)
    rows = [k + 1 for k in range(header_line + 1, len(lines)) if lines[k]]
    plain = plain_lines(iter(_chunked(text, chunk)), header_line)
    empty_after_header = any(not line for line in lines[header_line + 1 : -1])
    if b"\r" in text or empty_after_header:
        assert plain is None
        return
    assert plain is not None
    count, line_ends = plain
    assert line_ends == len(lines) - 1
    assert rows == list(range(header_line + 2, header_line + 2 + count))


class _Text:
    """A content of `text` in chunks of `size` (what `LineMap` reads)."""

    def __init__(self, text: bytes, size: int) -> None:
        self.text, self.size = text, size

    def chunks(self, limit=None):
        return iter(_chunked(self.text[:limit], self.size))


@pytest.mark.parametrize(
    "text",
    [b"h\n1\n2\n3\n", b"h\n1\n\n2\n3", b"h\r\n1\r\n2\r\n3\r\n", b"h\n", b"h\n1\n2\n3"],
)
def test_line_map_numbers_rows_either_way(text):
    # rows 0, 1, 2 (and beyond the last: the last; before the first: the first)
    lines = LineMap(_Text(text, 3), header_line=0)
    special = {b"h\n": [2, 2, 2, 2, 2], b"h\n1\n\n2\n3": [2, 2, 4, 5, 5]}
    expected = special.get(text, [2, 2, 3, 4, 4])
    assert [lines.line_of(row) for row in (-1, 0, 1, 2, 3)] == expected


def test_line_numbers_past_the_first_block(tmp_path):
    # 150 000 rows (~2.7 MB, several 1 MiB parse blocks) with \r\n line ends and two empty
    # lines after line 10. Row k (0-based) is on line 5 + k, plus 2 from row 6 on (lines 11
    # and 12 are the empty ones, after row 5 on line 10).
    n = 150_000
    power_W = np.full(n, 23.3)
    power_W[::2] = 23.4  # not flat, so no clipping is suspected
    times_s = np.arange(n) * PERIOD_S
    times_s[120_000:] += 3 * PERIOD_S  # 3 samples dropped before row 120 000
    body = "".join(f"{t:.7f},{p:.4f}\r\n" for t, p in zip(times_s, power_W, strict=True))
    lines = body.split("\r\n")
    text = HEAD.replace("\n", "\r\n") + "\r\n".join(lines[:6] + ["", ""] + lines[6:])
    path = _write(tmp_path / "gap.csv", text)
    run = read_log(path)
    assert run.samples == n
    (gap,) = run.problems
    # row 120 000: line 5 + 120 000 + 2
    assert gap.message.startswith("line 120007: 0.3072 ms of samples dropped"), gap.message

    # the same log with a word where a number belongs in row 140 000 (line 140 007)
    lines[140_000] = "14.3360000,abc"
    text = HEAD + "\n".join(lines[:6] + ["", ""] + lines[6:])
    with pytest.raises(LogError, match=r"line 140007, column 'power_W'.*'abc' where a number"):
        read_log(_write(tmp_path / "word.csv", text))


# -- a cut last line: the same error, with its line, from every kind of source --------------


@pytest.mark.parametrize("name", ["cut.csv", "cut.csv.gz", "cut.csv.zst", "in memory"])
@pytest.mark.parametrize("end", ["\n", "\r\n"])
def test_cut_last_line_is_an_error_whatever_the_source(tmp_path, name, end):
    # lines 5-7 complete, line 8 cut mid-number ("23.5102" -> "23.5")
    text = HEAD.replace("\n", end) + _rows(np.array([23.3, 23.4, 23.5]), end=end) + "0.0003072,23.5"
    with pytest.raises(LogError, match="line 8: the last line has no line end"):
        if name == "in memory":
            read_log("cut.csv", data=text.encode())
        else:
            read_log(_write(tmp_path / name, text))
    # the same text with its line end is a good log of 4 samples
    assert read_log("whole.csv", data=(text + end).encode()).samples == 4


@pytest.mark.parametrize("name", ["bad.csv", "bad.csv.gz", "bad.csv.zst", "in memory"])
def test_an_earlier_bad_line_is_reported_before_the_cut_one(tmp_path, name):
    # line 6 has three fields, line 8 no line end: the first in the file is the one reported,
    # whatever the source (the cut line is found before parsing for some, after for others)
    text = HEAD + "0.0000000,23.3\n0.0001024,23.4,7\n0.0002048,23.5\n0.0003072,23.5"
    with pytest.raises(LogError, match="line 6: 3 field"):
        if name == "in memory":
            read_log("bad.csv", data=text.encode())
        else:
            read_log(_write(tmp_path / name, text))


@pytest.mark.parametrize("name", ["long.csv", "long.csv.gz", "in memory"])
def test_cut_line_longer_than_the_tail_read(tmp_path, name):
    # a cut last line of 70 000 characters: longer than the 64 KiB the reader looks at first
    # at the end of a file, so it is found while streaming instead
    text = HEAD + _rows(np.array([23.3, 23.4])) + "0.0002048," + "2" * 70_000
    with pytest.raises(LogError, match="line 7: the last line has no line end"):
        if name == "in memory":
            read_log("long.csv", data=text.encode())
        else:
            read_log(_write(tmp_path / name, text))


def test_header_without_line_end_is_header_only(tmp_path):
    path = _write(tmp_path / "h.csv", HEAD.rstrip("\n"))
    with pytest.raises(LogError, match="line 4: header only"):
        read_log(path)


# -- memory: the file's bytes are never held ------------------------------------------------


@pytest.mark.parametrize("name", ["big.csv", "big.csv.gz"])
def test_peak_python_memory_stays_under_twice_the_columns(tmp_path, name):
    # 300 000 rows, ~6 MB of text; the Run keeps time_s and power_W: 2 x 300 000 x 8 B = 4.8 MB.
    # tracemalloc sees numpy's arrays and Python's bytes (not pyarrow's own pool, which holds
    # a few 1 MiB blocks). The columns plus one column being joined plus one diff in the checks
    # is ~1.5x the columns (7.7 MB measured); the reader that held the file's bytes (6 MB) for
    # line numbers peaked at 11 MB here. Bound: 2x the columns (9.6 MB), the issue-7 target.
    n = 300_000
    power_W = 23.3 + 0.1 * np.sin(np.arange(n) / 50.0)
    path = _write(tmp_path / name, HEAD + _rows(power_W))
    columns_bytes = 2 * n * 8
    assert path.stat().st_size > 0
    # measured in a fresh interpreter: the peak is of this read alone, not of whatever the
    # tests before it left in this worker (and a worker that had run ~300 other tests died
    # once in 3 full runs with a native crash in a background thread during this test; a
    # fresh process has not shown it in 120 reads, with or without tracemalloc)
    script = (
        "import sys, tracemalloc\n"
        "from wifibot_power.io import read_log\n"
        "read_log(sys.argv[1])  # imports, pyarrow's first use\n"
        "tracemalloc.start()\n"
        "run = read_log(sys.argv[1])\n"
        "print(run.samples, tracemalloc.get_traced_memory()[1])\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, str(path)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    samples, peak_bytes = map(int, done.stdout.split())
    assert samples == n
    assert peak_bytes < 2 * columns_bytes, (peak_bytes / 1e6, columns_bytes / 1e6)
