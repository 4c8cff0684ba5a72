"""One module per input format behind one interface, one registry (issue 12, part 5): a new
instrument is one `LogFormat` and one entry in `FORMATS`, and nothing else knows its columns.
"""

from __future__ import annotations

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


def test_an_instruments_column_names_live_in_its_module_only():
    """'Curr avg 3' is known to formats/n6705.py and nowhere else in the package."""
    pattern = re.compile(r"(Curr|Volt|Power) (avg|min|max)")
    knowing = sorted(
        str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py") if pattern.search(p.read_text())
    )
    assert knowing == ["io/formats/n6705.py"]
