"""One very long line (issue 29: 50 MB took 1.7 s, 200 MB 16.5 s, 1 GB over 300 s: the read
carried the line over by concatenation, quadratic in its length). A line over
`transport.MAX_LINE_BYTES` is now an error naming it, found in time linear in its length."""

from __future__ import annotations

import gzip
import time
from pathlib import Path

import pytest

from wifibot_power.errors import LogError
from wifibot_power.io import read_log, transport

#: (1 MiB before the bound was named)
MAX_LINE_BYTES = getattr(transport, "MAX_LINE_BYTES", 1 << 20)

HEAD = "time_s,power_W\n" + "".join(f"{k * 0.01:.2f},23.3\n" for k in range(100))  # lines 1-101
TAIL = "".join(f"{1.01 + k * 0.01:.2f},23.3\n" for k in range(100))


def _write(path: Path, text: str) -> Path:
    if path.suffix == ".gz":
        with gzip.open(path, "wt", compresslevel=1) as handle:
            handle.write(text)
    else:
        path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("name", "body", "line"),
    [
        ("number.csv", "1.00," + "1" * (3 * MAX_LINE_BYTES) + "\n" + TAIL, 102),
        ("number.csv.gz", "1.00," + "1" * (3 * MAX_LINE_BYTES) + "\n" + TAIL, 102),
        ("no_line_end.csv", "1.00," + "1" * (3 * MAX_LINE_BYTES), 102),  # also a cut line
        ("blanks.csv", "1.00,23.3" + " " * (3 * MAX_LINE_BYTES) + "\n" + TAIL, 102),
    ],
)
def test_a_line_over_the_bound_is_an_error_naming_it(tmp_path, name, body, line):
    path = _write(tmp_path / name, HEAD + body)
    with pytest.raises(LogError) as error:
        read_log(path)
    assert error.value.where == f"line {line}"
    assert "line longer than 1 MiB" in error.value.problem


def test_a_line_just_under_the_bound_is_read_as_any_line(tmp_path):
    # a long but legal line: a number padded with blanks (pyarrow trims them)
    line = "1.00,23.3" + " " * (MAX_LINE_BYTES // 2)
    run = read_log(_write(tmp_path / "ok.csv.gz", HEAD + line + "\n" + TAIL))
    assert run.power_W.size == 201


def _refusal_s(path: Path) -> float:
    started = time.perf_counter()
    with pytest.raises(LogError):  # (before the fix: "the last line has no line end")
        read_log(path)
    return time.perf_counter() - started


def test_refusing_a_long_line_takes_time_linear_in_its_length(tmp_path):
    """16 MB and 64 MB lines with no line end (the stream path, which carried the line over):
    4x the length must not take 16x the time. Measured before the fix: 40 MB 3.3 s, 160 MB
    30 s; after it, both well under 1 s."""
    small = _write(tmp_path / "small.csv", HEAD + "1.00," + "1" * (16 << 20))
    large = _write(tmp_path / "large.csv", HEAD + "1.00," + "1" * (64 << 20))
    _refusal_s(small)  # warm: imports, page cache
    small_s = min(_refusal_s(small) for _ in range(2))
    large_s = min(_refusal_s(large) for _ in range(2))
    assert large_s < max(8 * small_s, 0.5), (small_s, large_s)
