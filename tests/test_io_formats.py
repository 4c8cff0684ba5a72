"""One module per input format behind one interface, one registry (issue 12, part 5): a new
instrument is one `LogFormat` and one entry in `FORMATS`, and nothing else knows its columns.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import ClassVar

import pytest
from numpy.testing import assert_allclose

from wifibot_power.errors import LogError
from wifibot_power.io import ReadOptions, formats, read_log
from wifibot_power.io.columns import PowerSource, find_column
from wifibot_power.io.formats.base import (
    LogFormat,
    Preamble,
    TimeSource,
    delimiter_of,
    header_cells,
)

ROOT = Path(__file__).resolve().parents[1] / "wifibot_power"


class ToyLogger(LogFormat):
    """A made-up instrument: first line 'TOYLOG', then 'ms;mA;V' rows at a 5 V bus."""

    name: ClassVar[str] = "toylog"

    def sniff(self, first_line: str) -> bool:
        return first_line.startswith("TOYLOG")

    def preamble(self, path: Path, lines: list[str], named: tuple[str, ...]) -> Preamble:
        delimiter = delimiter_of(lines[1])
        return Preamble(1, header_cells(lines[1], delimiter), delimiter, False, self.name)

    def power_sources(self, path, pre, options: ReadOptions) -> list[PowerSource]:
        return [PowerSource(current=(find_column(pre.header, "mA"), 1e-3), supply_voltage_V=5.0)]

    def time_source(self, path, pre, options):
        return TimeSource(find_column(pre.header, "ms"), 1e-3), []


def test_a_new_format_is_one_class_and_one_registry_entry(tmp_path, monkeypatch):
    path = tmp_path / "toy.csv"
    path.write_text("TOYLOG v2\nms;mA\n0;200\n10;400\n20;300\n")
    with pytest.raises(LogError):
        read_log(path)  # not registered: the canonical format does not know these columns
    monkeypatch.setattr(formats, "FORMATS", (ToyLogger(), *formats.FORMATS))
    run = read_log(path)
    assert run.format == "toylog"
    assert_allclose(run.power_W, [1.0, 2.0, 1.5], rtol=1e-15)  # mA x 1e-3 x 5 V
    assert_allclose(run.time_s, [0.0, 0.01, 0.02], rtol=1e-15)
    assert run.sample_period_s == pytest.approx(0.01)


def test_the_registry_tries_the_canonical_format_last():
    names = [f.name for f in formats.FORMATS]
    assert names[-1] == "wbpower-csv" and "n6705" in names
    assert formats.format_of(["", "N6705C exported datalog"]).name == "n6705"
    assert formats.format_of(["time_s,power_W"]).name == "wbpower-csv"


def test_an_n6705_export_after_blank_lines_is_read_as_without_them(tmp_path):
    """format_of skips blank lines to sniff an N6705 export, so its preamble must too: the
    instrument's name is read off the first line that is not blank (a leading blank line
    was an IndexError, an internal error, before)."""
    body = (
        'N6705C exported datalog\n"Sample interval: 0.001"\n'
        'Sample,"Curr avg 1","Volt avg 1"\n0,0.1,12\n1,0.2,12\n'
    )
    plain, blank = tmp_path / "plain.csv", tmp_path / "blank.csv"
    plain.write_text(body)
    blank.write_text("\n  \n" + body)
    a, b = read_log(plain), read_log(blank)
    assert_allclose(b.power_W, a.power_W, rtol=0)
    assert a.meta == dataclasses.replace(b.meta, run_id=a.meta.run_id)
    assert b.meta.extra["instrument"] == "N6705C"


def test_an_instruments_column_names_live_in_its_module_only():
    """'Curr avg 3' is known to formats/n6705.py and nowhere else in the package."""
    pattern = re.compile(r"(Curr|Volt|Power) (avg|min|max)")
    knowing = sorted(
        str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py") if pattern.search(p.read_text())
    )
    assert knowing == ["io/formats/n6705.py"]


def _full_preamble(path: Path) -> tuple[object, object]:
    """Format and preamble from every line of the head, as before the short first try."""
    from wifibot_power.io.transport import Content, decode, head_lines

    content, head = decode(path, Content(path))
    lines = head_lines(path, content, head)
    log_format = formats.format_of(lines)
    return log_format, log_format.preamble(path, lines, ())


def _head_logs(tmp_path: Path) -> list[Path]:
    """Logs whose preamble, header and sniffed lines lie at various places of the head."""
    data = "".join(f"{0.0001 * k:.4f},{20 + (k % 7) * 0.1:.1f}\n" for k in range(400))
    logs = {
        "plain.csv": "# wbpower-log: 1\n# mode: idle\ntime_s,power_W\n" + data,
        # 240 comment lines: the header within the first 256 lines, < 50 data lines after it
        "long_preamble.csv": "# c\n" * 240 + "time_s,power_W\n" + data,
        # the header past line 256
        "longer_preamble.csv": "# c\n" * 300 + "time_s,power_W\n" + data,
        # blank lines among the data: sniffing skips them
        "blanks.csv": "time_s,power_W\n" + data.replace("\n", "\n\n", 120),
        "crlf.csv": ("# mode: idle\ntime_s;power_W\n" + data.replace(",", ";")).replace(
            "\n", "\r\n"
        ),
        "decimal_comma.csv": "time_s;power_W\n" + data.replace(",", ";").replace(".", ","),
        "short.csv": "time_s,power_W\n" + "".join(data.splitlines(True)[:10]),
        # blank lines among the data lines near the bound: 49 data lines within the first
        # 256 lines, the 50th after them (sniffing counts non-blank lines only)
        "blanks_at_bound.csv": "time_s,power_W\n"
        + "".join(data.splitlines(True)[:49])
        + "\n" * 210
        + "".join(data.splitlines(True)[49:]),
    }
    paths = []
    for name, text in logs.items():
        (tmp_path / name).write_text(text)
        paths.append(tmp_path / name)
    return paths


def test_the_preamble_from_the_first_lines_is_the_one_from_all(tmp_path) -> None:
    """`read_log` reads a format's preamble from the head's first `FIRST_LINES` lines when
    they hold the header and the sniffed data lines, else from all of them: the same result
    either way, on made-up layouts, the sample logs and the real N6705C export."""
    from wifibot_power.io import reader
    from wifibot_power.io.transport import Content, decode

    real = Path(__file__).parent.parent.parent / "shared" / "real_logs"
    samples = sorted((Path(__file__).parent.parent / "sample_logs").glob("*.csv.gz"))[:6]
    paths = _head_logs(tmp_path) + samples + sorted(real.glob("*.csv"))
    for path in paths:
        content, head = decode(path, Content(path))
        assert reader._preamble(path, content, head, ()) == _full_preamble(path), path.name


def test_a_usual_head_is_split_once_and_a_long_preamble_falls_back(tmp_path, monkeypatch):
    """The short first try is taken for a usual log (one split of 256 lines), and the whole
    head is split when the header or the sniffed lines lie beyond them."""
    from wifibot_power.io import reader

    limits: list[int | None] = []
    original = reader.head_lines

    def counting(path, content, head, limit=None):
        limits.append(limit)
        return original(path, content, head, limit)

    monkeypatch.setattr(reader, "head_lines", counting)
    by_name = {p.name: p for p in _head_logs(tmp_path)}
    expected = {
        "plain.csv": [reader.FIRST_LINES],
        "blanks.csv": [reader.FIRST_LINES],
        "crlf.csv": [reader.FIRST_LINES],
        "decimal_comma.csv": [reader.FIRST_LINES],
        "long_preamble.csv": [reader.FIRST_LINES, None],
        "longer_preamble.csv": [reader.FIRST_LINES, None],
        "short.csv": [reader.FIRST_LINES],  # fewer lines than the first try: all of them
        "blanks_at_bound.csv": [reader.FIRST_LINES, None],
    }
    for name, calls in expected.items():
        limits.clear()
        read_log(by_name[name], ReadOptions(sample_period_s=0.0001))
        assert limits == calls, name
