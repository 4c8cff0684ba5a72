"""A log with many short drop-outs: a few warning lines a file, never one per drop-out
(docs/cli-output.md), while `inspect --json` keeps every one in `problems`."""

from __future__ import annotations

import json

import numpy as np

from wifibot_power.cli.common import PROBLEMS_SAID


def _log_with_drop_outs(path, drops: int, offset_W: float = 0.0) -> None:
    """100 Hz for 200 s (20,000 samples), `drops` single samples missing far apart (0.01 s
    each: under the 1% of the log the reader accepts); `offset_W` makes logs that differ."""
    t = np.arange(20_000) * 0.01
    missing = np.arange(drops) * (20_000 // (drops + 1)) + 500
    keep = np.ones(t.size, dtype=bool)
    keep[missing] = False
    rows = "\n".join(f"{x:.2f},{23.3 + offset_W + 0.1 * np.sin(x):.4f}" for x in t[keep])
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


def test_a_batch_says_the_problems_of_its_first_files_and_counts_the_rest(tmp_path, wbpower):
    """Five logs with drop-outs: the first `PROBLEM_FILES_SAID` files' are said as one file's
    are, the other files' in one line with their count and time, on stderr and in --json."""
    from wifibot_power.cli.common import PROBLEM_FILES_SAID

    drops = PROBLEMS_SAID + 2
    n_files = PROBLEM_FILES_SAID + 2
    for i in range(n_files):
        _log_with_drop_outs(tmp_path / f"log{i}.csv", drops, offset_W=i)
    result = wbpower("inspect", tmp_path)
    assert result.exit_code == 0, result.stderr
    per_file = [line for line in result.stderr.splitlines() if ".csv: " in line]
    said = sorted({line.split(".csv")[0].rsplit("/", 1)[-1] for line in per_file})
    assert said == [f"log{i}" for i in range(PROBLEM_FILES_SAID)], result.stderr
    assert len(per_file) == PROBLEM_FILES_SAID * (PROBLEMS_SAID + 1)
    left = n_files - PROBLEM_FILES_SAID
    summary = (
        f"and {left * drops} more problem(s) of kind 'gap' in {left} more file(s), "
        f"{left * drops * 0.01:.4g} s in all"
    )
    assert summary in result.stderr
    doc = json.loads(wbpower("inspect", tmp_path, "--json").stdout)
    assert sum(len(entry["problems"]) for entry in doc["logs"]) == n_files * drops
    assert any(summary in w for w in doc["warnings"]), doc["warnings"]


def test_duplicates_are_said_for_every_file(tmp_path, wbpower):
    """A duplicate names the file it repeats: said for each file, however many."""
    from wifibot_power.cli.common import PROBLEM_FILES_SAID

    n_files = PROBLEM_FILES_SAID + 2
    for i in range(n_files):
        _log_with_drop_outs(tmp_path / f"log{i}.csv", 1)
    result = wbpower("inspect", tmp_path)
    duplicates = [line for line in result.stderr.splitlines() if "the same samples as" in line]
    assert len(duplicates) == n_files - 1, result.stderr
    assert "more problem(s) of kind 'duplicate'" not in result.stderr


def test_one_file_past_the_first_few_is_said_as_any_file(tmp_path, wbpower):
    """One more file with problems of a kind than `PROBLEM_FILES_SAID`: its own lines (a
    count of one file's problems would say less in as many lines)."""
    from wifibot_power.cli.common import PROBLEM_FILES_SAID

    for i in range(PROBLEM_FILES_SAID + 1):
        _log_with_drop_outs(tmp_path / f"log{i}.csv", 1, offset_W=i)
    result = wbpower("inspect", tmp_path)
    assert "more problem(s)" not in result.stderr
    for i in range(PROBLEM_FILES_SAID + 1):
        assert f"log{i}.csv: line " in result.stderr, result.stderr
