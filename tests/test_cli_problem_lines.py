"""A log with many short drop-outs: a few warning lines a file, never one per drop-out
(docs/cli-output.md), while `inspect --json` keeps every one in `problems`."""

from __future__ import annotations

import json

import numpy as np

from wifibot_power.cli.common import PROBLEMS_SAID


def _log_with_drop_outs(path, drops: int) -> None:
    """100 Hz for 200 s (20,000 samples), `drops` single samples missing far apart (0.01 s
    each: under the 1% of the log the reader accepts)."""
    t = np.arange(20_000) * 0.01
    missing = np.arange(drops) * (20_000 // (drops + 1)) + 500
    keep = np.ones(t.size, dtype=bool)
    keep[missing] = False
    rows = "\n".join(f"{x:.2f},{23.3 + 0.1 * np.sin(x):.4f}" for x in t[keep])
    path.write_text(f"time_s,power_W\n{rows}\n", encoding="utf-8")


def test_many_drop_outs_are_said_in_a_few_lines(tmp_path, wbpower):
    log = tmp_path / "dropping.csv"
    _log_with_drop_outs(log, 40)
    result = wbpower("inspect", log)
    assert result.exit_code == 0, result.stderr
    lines = [line for line in result.stderr.splitlines() if "dropping.csv" in line]
    assert len(lines) == PROBLEMS_SAID + 1, result.stderr
    assert all("ms of samples dropped" in line for line in lines[:PROBLEMS_SAID])
    rest = 40 - PROBLEMS_SAID
    assert f"and {rest} more of kind 'gap' like these, {rest * 0.01:.4g} s in all" in lines[-1]
    doc = json.loads(wbpower("inspect", log, "--json").stdout)
    (entry,) = doc["logs"]
    assert len(entry["problems"]) == 40
    assert len([w for w in doc["warnings"] if "dropping.csv" in w]) == PROBLEMS_SAID + 1


def test_a_few_drop_outs_are_each_said(tmp_path, wbpower):
    log = tmp_path / "few.csv"
    _log_with_drop_outs(log, PROBLEMS_SAID)
    lines = [line for line in wbpower("inspect", log).stderr.splitlines() if "few.csv" in line]
    assert len(lines) == PROBLEMS_SAID and not any("more of kind" in line for line in lines)
