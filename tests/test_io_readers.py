"""The three input kinds of log-format.md: canonical CSV (.csv/.gz/.zst), the N6705 datalog
(incl. the real file), the runs.csv manifest; metadata, units, sample period, formats told apart.

Expected numbers are computed in the tests from the text written (or, for the real file,
with Python's own csv module), never taken from the reader.
"""

from __future__ import annotations

import csv
import gzip
import json
import re
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from numpy.testing import assert_allclose
from rich.console import Console

from wifibot_power.cli import inspect_cmd
from wifibot_power.errors import LogError
from wifibot_power.io import FORMAT_CANONICAL, FORMAT_N6705, ReadOptions, read_log

CANONICAL = """# wbpower-log: 1
# run_id: v0.80_d10_s10_r1
# mode: motion
# speed_mps: 0.8
# distance_m: 10
# steps: 10
# payload_kg: 0.5
# started_at: 2015-06-01T10:00:00Z
time_s,voltage_V,current_A,power_W
0.0000000,12.8000,1.82031,23.3000
0.0001024,12.8001,1.82110,23.3102
0.0002048,12.7990,1.90000,24.3181
"""


def _write(path: Path, text: str) -> Path:
    data = text.encode()
    if path.name.endswith(".gz"):
        data = gzip.compress(data)
    elif path.name.endswith(".zst"):
        with pa.output_stream(str(path), compression="zstd") as out:
            out.write(data)
        return path
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("name", ["run.csv", "run.csv.gz", "run.csv.zst"])
def test_canonical_csv_every_compression(tmp_path, name):
    run = read_log(_write(tmp_path / name, CANONICAL))
    assert run.format == FORMAT_CANONICAL
    assert run.power_W.tolist() == [23.3, 23.3102, 24.3181]  # the power column wins over V x I
    assert run.time_s.tolist() == [0.0, 0.0001024, 0.0002048]
    assert run.sample_period_s == 0.1024e-3
    meta = run.meta
    assert (
        meta.run_id,
        meta.mode,
        meta.speed_mps,
        meta.distance_m,
        meta.steps,
        meta.payload_kg,
    ) == (
        "v0.80_d10_s10_r1",
        "motion",
        0.8,
        10.0,
        10,
        0.5,
    )
    assert meta.started_at == datetime(2015, 6, 1, 10, 0, tzinfo=UTC)
    # energy by the rectangle rule: (23.3 + 23.3102 + 24.3181) W x 0.1024 ms
    assert_allclose(run.energy_J, 70.9283 * 0.1024e-3, rtol=1e-12)


def test_power_from_voltage_times_current_and_milli_units(tmp_path):
    text = (
        "# mode: idle\ntime_s,voltage_V,current_mA,extra_note\n0,12.5,2000,a\n0.001,12.0,1500,b\n"
    )
    run = read_log(_write(tmp_path / "vi.csv", text))
    # 12.5 V x 2.000 A = 25 W; 12.0 V x 1.500 A = 18 W; the unknown column is not used
    assert_allclose(run.power_W, [25.0, 18.0], rtol=1e-15)
    assert run.sample_period_s == 0.001  # from the time column, not the 0.1024 ms default
    run = read_log(_write(tmp_path / "mw.csv", "power_mW\n23300\n24500\n"))
    assert_allclose(run.power_W, [23.3, 24.5], rtol=1e-15)


def test_no_time_column_uses_metadata_then_option_then_default(tmp_path):
    text = "# sample_period_s: 0.002\npower_W\n23.3\n23.4\n23.5\n"
    run = read_log(_write(tmp_path / "meta.csv", text))
    assert run.sample_period_s == 0.002 and run.time_s.tolist() == [0.0, 0.002, 0.004]
    plain = _write(tmp_path / "plain.csv", "power_W\n23.3\n23.4\n")
    assert read_log(plain).sample_period_s == 0.1024e-3  # the paper's analyser
    assert read_log(plain, ReadOptions(sample_period_s=0.01)).time_s.tolist() == [0.0, 0.01]


def test_without_a_time_column_the_axis_is_made_only_when_asked(tmp_path):
    """A power-only log's run holds no time stamps (`stamps_s` None): `time_s` is i x period,
    the same floats as numpy's arange times the period, made once on first use; `time_at`
    gives one of them without making the axis. A log with a time column keeps its own."""
    n, period = 1000, 0.1024e-3
    text = "power_W\n" + "23.3\n" * n
    run = read_log(_write(tmp_path / "power.csv", text))
    assert run.stamps_s is None and "_even_time_s" not in run.__dict__
    for i in (0, 1, 7, 500, n - 1, -1, -n):
        assert run.time_at(i) == float(np.arange(n)[i] * period)
    assert "_even_time_s" not in run.__dict__  # time_at made nothing
    for bad in (n, -n - 1):
        with pytest.raises(IndexError):
            run.time_at(bad)
    made = run.time_s
    assert np.array_equal(made, np.arange(n) * period) and made.dtype == np.float64
    assert run.time_s is made  # made once
    stamped = read_log(_write(tmp_path / "stamped.csv", CANONICAL))
    assert stamped.stamps_s is not None and stamped.time_s is stamped.stamps_s
    assert stamped.time_at(-1) == 0.0002048 and stamped.time_at(1) == 0.0001024


def test_current_only_with_supply_voltage(tmp_path):
    path = _write(tmp_path / "i.csv", "time_s,current_A\n0,1.5\n0.0001024,2.0\n")
    with pytest.raises(LogError, match="current only"):
        read_log(path)
    assert_allclose(read_log(path, ReadOptions(supply_voltage_V=12.0)).power_W, [18.0, 24.0])


N6705 = """N6705B exported datalog

"Sample interval: 0.0005"
"Trigger sample: 0"
"Date: Tue Sep  1 16:19:49 2020"

Sample,"Curr avg 1","Volt avg 1","Curr max 1","Curr avg 2"
0,1.5,12.0,1.7,0.1
1,2.0,12.5,2.2,0.1
2,1.0,12.0,1.1,0.1
"""


def test_n6705_export_with_volt_and_curr_on_one_output(tmp_path):
    run = read_log(_write(tmp_path / "dlog.csv", N6705))
    assert run.format == FORMAT_N6705
    # output 1 has both: 1.5 x 12 = 18, 2 x 12.5 = 25, 1 x 12 = 12 W; min/max columns unused
    assert_allclose(run.power_W, [18.0, 25.0, 12.0], rtol=1e-15)
    assert run.sample_period_s == 0.0005
    assert_allclose(run.time_s, [0.0, 0.0005, 0.001], rtol=1e-15)  # Sample x interval
    assert run.meta.extra["instrument"] == "N6705B"
    assert run.meta.mode == "unknown" and run.meta.run_id == "dlog"


def test_n6705_power_column_and_named_columns(tmp_path):
    text = N6705.replace('"Curr avg 2"', '"Power avg 2"').replace(",0.1\n", ",30.5\n")
    assert_allclose(read_log(_write(tmp_path / "p.csv", text)).power_W, [30.5] * 3)
    both = _write(tmp_path / "two.csv", text.replace('"Curr max 1"', '"Power avg 1"'))
    with pytest.raises(LogError, match="several analyser outputs"):
        read_log(both)
    named = read_log(both, ReadOptions(current_column="curr avg 1", voltage_column="Volt avg 1"))
    assert_allclose(named.power_W, [18.0, 25.0, 12.0], rtol=1e-15)


def _advised_options(message: str) -> ReadOptions:
    """The reading options an error's fix names (`--opt 'value'` pairs), as ReadOptions: the
    first of each option, as a user following "e.g." would, every --power-column."""
    pairs = re.findall(r"--([a-z-]+) '([^']+)'", message)
    fields = {"current-column": "current_column", "voltage-column": "voltage_column"}
    named = {fields[k]: v for k, v in reversed(pairs) if k in fields}
    powers = tuple(dict.fromkeys(v for k, v in pairs if k == "power-column"))
    return ReadOptions(power_columns=powers, **named)


@pytest.mark.parametrize("logs", ["current and voltage", "power"])
def test_n6705_several_outputs_error_advises_options_that_read_the_file(tmp_path, logs):
    # the advice once named 'Power avg 1' and 'Power avg 2' whatever the file held: followed
    # on an export with V and I on two outputs, it failed again
    header = 'Sample,"Curr avg 1","Volt avg 1","Curr avg 3","Volt avg 3"\n'
    rows = "0,1.8,12.8,0.5,5.0\n1,1.9,12.8,0.5,5.0\n"
    if logs == "power":
        header = 'Sample,"Power avg 2","Power avg 4"\n'
        rows = "0,23.0,2.5\n1,24.0,2.5\n"
    text = 'N6705B exported datalog\n\n"Sample interval: 0.001"\n\n' + header + rows
    path = _write(tmp_path / "two.csv", text)
    with pytest.raises(LogError, match="several analyser outputs") as error:
        read_log(path)
    advice = error.value.one_line()
    for first in _advised_options(advice), _advised_options(advice.split(", or ")[0]):
        run = read_log(path, first)
        expected = [23.04, 24.32] if logs != "power" else [23.0, 24.0]
        if first.power_columns and len(first.power_columns) > 1:
            expected = [25.5, 26.5]  # both outputs summed
        assert_allclose(run.power_W, expected, rtol=1e-12)


def _real_columns(path: Path) -> tuple[list[float], list[float]]:
    """Current and voltage of the real export, parsed independently with the csv module."""
    lines = path.read_text().splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("Sample,"))
    rows = list(csv.reader(lines[start + 1 :]))
    return [float(r[1]) for r in rows if r], [float(r[2]) for r in rows if r]


def test_real_n6705c_export(real_n6705, wbpower):
    result = wbpower("inspect", "--json", "--supply-voltage", "12.6", real_n6705)
    assert result.exit_code == 0, result.stderr
    (row,) = json.loads(result.stdout)["logs"]
    assert row["format"] == "n6705" and row["samples"] == 9965
    assert row["sample_period_s"] == 1.00352e-3
    assert_allclose(row["duration_s"], 9965 * 1.00352e-3, rtol=1e-12)
    current_A, voltage_V = _real_columns(real_n6705)
    assert len(current_A) == 9965
    assert_allclose(row["mean_power_W"], 12.6 * np.mean(current_A), rtol=1e-12)
    assert row["meta"]["instrument"] == "N6705C" and row["problems"] == []
    # or power = current x voltage of the two named outputs, sample by sample
    run = read_log(
        real_n6705, ReadOptions(current_column="Curr avg 3", voltage_column="Volt avg 4")
    )
    assert_allclose(run.power_W, np.multiply(current_A, voltage_V), rtol=1e-15)


def test_real_n6705c_without_supply_voltage_is_a_clear_error(real_n6705, wbpower):
    result = wbpower("inspect", real_n6705)
    assert result.exit_code == 2 and result.stdout == ""
    message = result.stderr.strip()
    assert "\n" not in message and str(real_n6705) in message
    assert "no analyser output has both current and voltage" in message
    assert "--supply-voltage" in message


def test_manifest_overrides_and_unlisted_files(tmp_path, wbpower):
    _write(
        tmp_path / "a.csv",
        "# run_id: own_a\n# mode: idle\ntime_s,power_W\n0,23.3\n0.0001024,23.3\n",
    )
    _write(tmp_path / "dlog.csv", N6705)
    _write(tmp_path / "b.csv", "# run_id: own_b\ntime_s,power_W\n0,30\n0.0001024,30\n")
    (tmp_path / "runs.csv").write_text(
        "file,run_id,mode,speed_mps,distance_m,steps,payload_kg,started_at\n"
        "a.csv,v0.8_d10_s2,motion,0.8,10,2,1.5,2015-06-01T10:00:00Z\n"
        "dlog.csv,wifi_1,network,,,,,\n"
    )
    result = wbpower("inspect", "--json", tmp_path)
    assert result.exit_code == 0, result.stderr
    by_file = {Path(r["file"]).name: r for r in json.loads(result.stdout)["logs"]}
    assert set(by_file) == {"a.csv", "b.csv", "dlog.csv"}
    a = by_file["a.csv"]["meta"]
    assert (
        a["run_id"],
        a["mode"],
        a["speed_mps"],
        a["distance_m"],
        a["steps"],
        a["payload_kg"],
    ) == (
        "v0.8_d10_s2",
        "motion",
        0.8,
        10.0,
        2,
        1.5,
    )  # the manifest wins over the file's own run_id and mode
    assert a["started_at"] == "2015-06-01T10:00:00+00:00"
    assert by_file["dlog.csv"]["run_id"] == "wifi_1" and by_file["dlog.csv"]["format"] == "n6705"
    assert by_file["dlog.csv"]["meta"]["mode"] == "network"
    assert by_file["b.csv"]["run_id"] == "own_b"  # not in the manifest: its own metadata
    # a single file reads the manifest beside it; the manifest itself lists its files
    single = json.loads(wbpower("inspect", "--json", tmp_path / "a.csv").stdout)["logs"]
    assert [r["run_id"] for r in single] == ["v0.8_d10_s2"]
    listed = json.loads(wbpower("inspect", "--json", tmp_path / "runs.csv").stdout)["logs"]
    assert sorted(r["run_id"] for r in listed) == ["v0.8_d10_s2", "wifi_1"]


def test_inspect_table_tells_formats_apart(tmp_path, wbpower, monkeypatch):
    # a wide console, whatever the terminal of the test run (the table's content is tested)
    monkeypatch.setattr(inspect_cmd, "stdout", Console(width=200, soft_wrap=False))
    _write(tmp_path / "canon.csv", CANONICAL)
    _write(tmp_path / "dlog.csv", N6705)
    result = wbpower("inspect", tmp_path)
    assert result.exit_code == 0, result.stderr
    line_of = {
        name: next(ln for ln in result.stdout.splitlines() if name in ln)
        for name in ("canon.csv", "dlog.csv")
    }
    assert "wbpower-csv" in line_of["canon.csv"] and "n6705" in line_of["dlog.csv"]
    assert "0.1024" in line_of["canon.csv"] and "0.5" in line_of["dlog.csv"]  # period in ms


def test_custom_column_names_with_options(tmp_path, wbpower):
    # a home-made log: no column wbpower knows by name, so the options must name them;
    # I_mA is in mA (1500 mA = 1.5 A), supply 12 V: 18 W and 24 W; `t` is time, in s
    path = _write(tmp_path / "home.csv", "t,I_mA\n0,1500\n1,2000\n")
    options = ("--current-column", "I_mA", "--supply-voltage", "12", "--time-unit", "s")
    result = wbpower("inspect", "--json", *options, path)
    assert result.exit_code == 0, result.stderr
    (row,) = json.loads(result.stdout)["logs"]
    assert_allclose(row["mean_power_W"], 21.0, rtol=1e-15)
    assert row["sample_period_s"] == 1.0 and row["duration_s"] == 2.0
    # without --time-unit, `t` is not silently replaced by an assumed period
    result = wbpower("inspect", *options[:4], path)
    assert result.exit_code == 2 and "column 't' looks like time" in result.stderr
    assert "not a power log" in wbpower("inspect", path).stderr  # without the options


# -- the speed column (log-format.md, "Speed") -------------------------------------------------


def test_speed_column_is_read_per_sample(tmp_path, wbpower):
    text = "time_s,power_W,SPEED_MPS\n0,23.3,0\n0.001,30.1,0.25\n0.002,35.2,0.5\n"
    run = read_log(_write(tmp_path / "v.csv.gz", text))
    assert run.speed_mps.dtype == np.float64
    assert run.speed_mps.tolist() == [0.0, 0.25, 0.5]  # case-insensitive name
    assert read_log(_write(tmp_path / "none.csv", "power_W\n23\n")).speed_mps is None
    # another name, given with --speed-column (also case-insensitive); negative speed is kept
    text = "time_s,power_W,wheel_v\n0,23.3,0\n0.001,30.1,-0.25\n"
    path = _write(tmp_path / "w.csv", text)
    assert read_log(path).speed_mps is None  # not a name wbpower knows: not guessed
    assert read_log(path, ReadOptions(speed_column="Wheel_V")).speed_mps.tolist() == [0, -0.25]
    result = wbpower("inspect", "--json", "--speed-column", "wheel_v", path)
    assert result.exit_code == 0, result.stderr
    result = wbpower("inspect", "--speed-column", "odometry", path)
    assert result.exit_code == 2
    assert "no column 'odometry'" in result.stderr and "--speed-column" in result.stderr


@pytest.mark.parametrize(
    "cell, found",
    [("nan", "NaN"), ("inf", "inf"), ("", "missing"), ("fast", "where a number belongs")],
)
def test_speed_column_bad_values_are_errors_naming_the_line(tmp_path, cell, found):
    text = f"time_s,power_W,speed_mps\n0,23.3,0\n0.001,30.1,{cell}\n0.002,35.2,0.5\n"
    path = _write(tmp_path / "bad.csv", text)
    with pytest.raises(LogError, match=found) as error:
        read_log(path)
    message = error.value.one_line()
    assert "bad.csv" in message and "line 3" in message and "speed_mps" in message


def test_speed_in_mm_per_s_is_an_error(tmp_path):
    path = _write(tmp_path / "mm.csv", "time_s,power_W,speed_mps\n0,23.3,0\n0.001,30.1,250\n")
    with pytest.raises(LogError, match="absurd speed.*m/s") as error:
        read_log(path)
    assert "line 3" in error.value.one_line()


def test_a_cut_first_data_line_is_reported_as_cut_not_as_its_field_count():
    """Hypothesis found it: a file cut inside its first data line ('0' of '0,0') was
    reported as '1 fields where the header has 2'; it is a cut file, like any other."""
    head = b"# wbpower-log: 1\n# run_id: 0\n# mode: idle\ntime_s,power_W\n"
    with pytest.raises(LogError, match=r"line 5: the last line has no line end"):
        read_log("cut.csv", data=head + b"0")
    # the same line, ended, is what it says: a line with too few fields
    with pytest.raises(LogError, match=r"line 5: 1 fields where the header has 2"):
        read_log("short.csv", data=head + b"0\n")


def test_fit_and_diagnosis_of_a_power_only_log_make_no_time_axis(tmp_path):
    """Segmentation, the run's row and its trace statistics read times through
    `Run.time_at`: the axis of a power-only log is never made (review, sixth session: it was
    made by segmentation for every run, so the reader's saving moved there)."""
    from wifibot_power.diagnose import summarize_run
    from wifibot_power.simulate import SimConfig, simulate_runs

    config = SimConfig(speeds_mps=(0.5,), trips=((2.0, 1),), repeats=1, seed=1)
    (sim,) = [s for s in simulate_runs(config) if s.run.meta.mode == "motion"]
    path = tmp_path / "motion.csv"
    period = sim.run.sample_period_s
    path.write_text(
        f"# mode: motion\n# speed_mps: 0.5\n# distance_m: 2\n# sample_period_s: {period!r}\n"
        "power_W\n" + "\n".join(f"{w:.6f}" for w in sim.run.power_W) + "\n"
    )
    run = read_log(path)
    summary = summarize_run(run)
    assert summary.row["usable"], summary.row["skip_reason"]
    assert run.stamps_s is None and "_even_time_s" not in run.__dict__
