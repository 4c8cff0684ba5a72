"""`-o/--out DIR` on `inspect` and `segment` (cli.md: "`-o/--out DIR` writes the command's
tables as Parquet files (plus JSON where noted) into DIR", said of every command): the same
values as `--json`, written as one set, an unwritable DIR refused before any work."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from realistic import Scenario, realistic_run

from wifibot_power.io.writer import format_log, write_log

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
LOGS = [SAMPLE_LOGS / "idle_r1.csv.gz", SAMPLE_LOGS / "v0.50_d10_s10_r1.csv.gz"]


def test_inspect_out_writes_a_row_per_log_with_the_json_keys(wbpower, tmp_path):
    out = tmp_path / "out"
    result = wbpower("inspect", *LOGS, "-o", out, "--json")
    assert result.exit_code == 0, result.stderr
    rows = json.loads(result.stdout)["logs"]
    table = pd.read_parquet(out / "logs.parquet")
    assert sorted(p.name for p in out.iterdir()) == ["logs.parquet"]
    assert list(table.columns)[:8] == [
        "file",
        "format",
        "run_id",
        "samples",
        "sample_period_s",
        "duration_s",
        "mean_power_W",
        "energy_J",
    ]
    assert set(rows[0]) <= set(table.columns)
    assert len(table) == len(rows) == 2
    for row, record in zip(rows, table.to_dict("records"), strict=True):
        for key, value in row.items():
            if key in ("meta", "channels", "problems", "problem_details"):
                assert _as_json(key, record[key]) == value  # nested: structs and lists
            elif isinstance(value, float):
                np.testing.assert_allclose(record[key], value, rtol=1e-15)  # the same float
            else:
                assert record[key] == value, key
    assert table["samples"].dtype == np.int64
    assert f"wrote {out / 'logs.parquet'}" in result.stderr


def _as_json(key: str, value: object) -> object:
    """A nested cell of logs.parquet read by pandas, in the `--json` form: a struct is a
    dict, a list an array, the map of `meta.extra` a list of (key, value) pairs."""
    if key == "meta":
        meta = dict(value)
        return {**{k: v for k, v in meta.items() if k != "extra"}, **dict(meta["extra"])}
    return [dict(item) if isinstance(item, dict) else item for item in value]


def test_inspect_out_nests_meta_channels_and_problems_as_parquet_types(wbpower, tmp_path):
    """Not JSON text in a string column (issue 28): `meta` a struct (its free keys in a
    map), `channels` and `problem_details` lists of structs, `problems` a list of text, so
    that pandas, DuckDB or Polars query them without parsing."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.concatenate([np.arange(0, 2, 0.01), np.arange(2.03, 40, 0.01)])  # a 30 ms gap
    lines = ["# wbpower-log: 1", "# run_id: gap_r1", "# mode: idle", "# surface: grass"]
    lines += ["time_s,left_W,right_W"] + [f"{x:.2f},{10 + np.sin(x):.3f},12" for x in t]
    log = tmp_path / "gap.csv"
    log.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    args = ["--power-column", "left_W", "--power-column", "right_W", "-o", out, "--json"]
    result = wbpower("inspect", log, *args)
    assert result.exit_code == 0, result.stderr
    rows = json.loads(result.stdout)["logs"]
    schema = pq.read_schema(out / "logs.parquet")
    assert pa.types.is_struct(schema.field("meta").type)
    assert pa.types.is_map(schema.field("meta").type.field("extra").type)
    assert schema.field("problems").type == pa.list_(pa.string())
    for key in ("channels", "problem_details", "topics"):
        assert pa.types.is_struct(schema.field(key).type.value_type), key
    table = pd.read_parquet(out / "logs.parquet").to_dict("records")
    gap = next(r for r in table if r["run_id"] == "gap_r1")
    assert gap["meta"]["mode"] == "idle" and dict(gap["meta"]["extra"])["surface"] == "grass"
    assert [c["name"] for c in gap["channels"]] == ["left_W", "right_W"]
    assert list(gap["problems"]) == ["line 206: 30 ms of samples dropped after t = 1.99 s"]
    assert gap["problem_details"][0]["kind"] == "gap"
    for row, record in zip(rows, table, strict=True):
        for key in ("meta", "channels", "problems", "problem_details"):
            assert _as_json(key, record[key]) == row[key], key


def _doubted_log(tmp_path: Path) -> Path:
    run, _ = realistic_run(Scenario(brake="none", idle_W=5.0))
    path = tmp_path / "ends.csv"
    write_log(path, format_log(run.meta, replace(run, speed_mps=None).power_W))
    return path


def test_segment_out_writes_phases_with_run_id_and_doubts(wbpower, tmp_path):
    out = tmp_path / "out"
    result = wbpower("segment", _doubted_log(tmp_path), "-o", out, "--json")
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    phases = pd.read_parquet(out / "phases.parquet")
    assert sorted(p.name for p in out.iterdir()) == ["phases.parquet", "spikes.parquet"]
    # fit's phases.parquet columns (the segment columns after run_id and file), then the doubts
    assert list(phases.columns) == [
        "run_id",
        "file",
        "step",
        "phase",
        "t_start_s",
        "t_end_s",
        "duration_s",
        "mean_power_W",
        "energy_J",
        "speed_mps",
        "yaw_rate_radps",
        "doubts",
    ]
    assert len(phases) == len(doc["phases"]) > 0
    assert set(phases["file"]) == {str(tmp_path / "ends.csv")}
    assert set(phases["run_id"]) == {doc["run_id"]}
    for phase, record in zip(doc["phases"], phases.to_dict("records"), strict=True):
        assert record["phase"] == phase["phase"] and record["step"] == phase["step"]
        np.testing.assert_allclose(record["energy_J"], phase["energy_J"], rtol=1e-15)
    assert set(phases["doubts"]) == {"; ".join(doc["doubts"])}
    assert "ends moving" in phases["doubts"].iloc[0]
    spikes = pd.read_parquet(out / "spikes.parquet")
    assert list(spikes.columns)[0] == "run_id" and len(spikes) == len(doc["spikes"])


def test_segment_out_of_a_sound_run_has_empty_doubts(wbpower, tmp_path):
    out = tmp_path / "out"
    result = wbpower("segment", SAMPLE_LOGS / "v0.50_d10_s10_r1.csv.gz", "-o", out)
    assert result.exit_code == 0, result.stderr
    phases = pd.read_parquet(out / "phases.parquet")
    assert set(phases["doubts"]) == {""} and len(phases) > 20
    assert set(phases["phase"]) == {"idle", "accel", "cruise", "decel"}


@pytest.mark.parametrize("command", ["inspect", "segment"])
def test_out_is_checked_before_any_log_is_read(wbpower, tmp_path, monkeypatch, command):
    import wifibot_power.cli.inspect_cmd
    import wifibot_power.io

    def no_work(*args, **kwargs):
        raise AssertionError("a log was read before -o was checked")

    monkeypatch.setattr(wifibot_power.cli.inspect_cmd, "inspect_logs", no_work)
    monkeypatch.setattr(wifibot_power.io, "read_log", no_work)
    target = tmp_path / "a_file"
    target.write_text("keep me")
    result = wbpower(command, LOGS[1], "-o", target)
    assert result.exit_code == 2
    (line,) = result.stderr.splitlines()
    assert line.startswith("wbpower: error: -o ") and "is a file, not a folder" in line
    assert target.read_text() == "keep me"
