"""The small things of issue 28 that add up: what the human output says, in words a reader
takes in at once (`simulate`'s summary, `energy`'s digits, `diagnose` with no finding,
`--markdown`, what `-o` wrote)."""

from __future__ import annotations

import json
import re
from pathlib import Path

from wifibot_power.cli.simulate_cmd import size_text

SMALL_GRID = ["--speeds", "0.5", "--trips", "2x1", "--repeats", "2", "--modes", ""]


def test_simulate_says_what_it_wrote_in_words(wbpower, tmp_path):
    out = tmp_path / "sim"
    result = wbpower("simulate", "-o", out, *SMALL_GRID, "--effect", "decel_phase=0.3")
    assert result.exit_code == 0, result.stderr
    text = result.stdout
    logs = sorted(out.glob("v*.csv"))
    assert len(logs) == 2
    size = sum(p.stat().st_size for p in logs)
    assert re.search(rf"logs\s+│ 2 files, {re.escape(size_text(size))}", text), text
    assert size_text(size).endswith(" MB") and 1 <= float(size_text(size).split()[0]) < 1000
    assert re.search(r"effects\s+│ decel_phase=0\.3\b", text), text
    assert "csv_bytes" not in text and "{}" not in text and str(size) not in text
    # the JSON keeps the raw numbers (cli.md: `--json` for scripts)
    again = tmp_path / "again"
    doc = json.loads(wbpower("simulate", "-o", again, *SMALL_GRID, "--json").stdout)
    assert doc["csv_bytes"] == sum(p.stat().st_size for p in again.glob("v*.csv"))
    assert doc["effects"] == {}


def test_simulate_without_effects_says_none(wbpower, tmp_path):
    result = wbpower("simulate", "-o", tmp_path / "sim", *SMALL_GRID)
    assert re.search(r"effects\s+│ none\b", result.stdout), result.stdout


def test_sizes_read_as_people_read_them():
    assert size_text(91891604) == "91.9 MB"
    assert size_text(512) == "512 B"
    assert size_text(1500) == "1.5 kB"
    assert size_text(2.5e9) == "2.5 GB"
    assert size_text(Path(__file__).stat().st_size).split()[1] in ("B", "kB")
