"""The inputs real users have (issue 12): several channels, --power-column, time columns in
their unit, a time-like column never silently ignored, --time-column/--time-unit.

Expected numbers are computed here from the values written, never taken from the reader.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.errors import LogError, UsageError
from wifibot_power.io import ReadOptions, read_log


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# -- several channels (log-format.md, "Several channels") -----------------------------------


def test_power_channels_are_summed_and_each_kept(tmp_path):
    text = "time_s,power_left_W,power_right_mW,note\n0,1.5,2000,a\n0.01,1.25,2500,b\n"
    run = read_log(_write(tmp_path / "two.csv", text))
    # left 1.5 + right 2.0 = 3.5 W; 1.25 + 2.5 = 3.75 W (mW read in its unit)
    assert_allclose(run.power_W, [3.5, 3.75], rtol=1e-15)
    assert list(run.channels_W) == ["left", "right"]
    assert_allclose(run.channels_W["left"], [1.5, 1.25], rtol=1e-15)
    assert_allclose(run.channels_W["right"], [2.0, 2.5], rtol=1e-15)


def test_voltage_current_channel_pairs_and_a_shared_bus(tmp_path):
    # motor a: its own voltage; motor b: the shared voltage_V (two motors on one bus)
    text = (
        "time_s,voltage_V,voltage_a_V,current_a_A,current_b_mA\n"
        "0,12.0,11.0,1.0,500\n"
        "0.01,12.5,10.0,2.0,1000\n"
    )
    run = read_log(_write(tmp_path / "bus.csv", text))
    # a: 11 x 1 = 11, 10 x 2 = 20; b: 12 x 0.5 = 6, 12.5 x 1 = 12.5
    assert_allclose(run.channels_W["a"], [11.0, 20.0], rtol=1e-15)
    assert_allclose(run.channels_W["b"], [6.0, 12.5], rtol=1e-15)
    assert_allclose(run.power_W, [17.0, 32.5], rtol=1e-15)


def test_a_total_power_column_wins_over_channels(tmp_path):
    text = "time_s,power_W,power_left_W,power_right_W\n0,4,1,2\n0.01,5,2,2\n"
    run = read_log(_write(tmp_path / "total.csv", text))
    assert run.power_W.tolist() == [4.0, 5.0] and run.channels_W == {}


def test_a_current_channel_without_voltage_is_an_error(tmp_path):
    path = _write(tmp_path / "i.csv", "time_s,current_m1_A,current_m2_A\n0,1,2\n0.01,1,2\n")
    with pytest.raises(LogError, match="channel 'm1' has a current column") as error:
        read_log(path)
    assert "--supply-voltage" in error.value.one_line()
    run = read_log(path, ReadOptions(supply_voltage_V=12.0))  # both on a 12 V supply
    assert_allclose(run.power_W, [36.0, 36.0], rtol=1e-15)


def test_power_column_option_repeatable_summed(tmp_path, wbpower):
    text = "secs_since_boot,P1 [W],P2_mW,other\n0,1.5,2000,9\n1,1.0,500,9\n"
    path = _write(tmp_path / "home.csv", text)
    options = ReadOptions(power_columns=("p1 [w]", "P2_mW"), sample_period_s=1.0)
    run = read_log(path, options)
    assert_allclose(run.power_W, [3.5, 1.5], rtol=1e-15)  # 1.5 + 2.0, 1.0 + 0.5
    assert list(run.channels_W) == ["p1 [w]", "P2_mW"]
    result = wbpower(
        "inspect", "--json", "--power-column", "P1 [W]", "--power-column", "P2_mW",
        "--sample-period", "1", path,
    )  # fmt: skip
    assert result.exit_code == 0, result.stderr
    (row,) = json.loads(result.stdout)["logs"]
    assert_allclose(row["energy_J"], 5.0, rtol=1e-15)  # (3.5 + 1.5) W x 1 s
    assert [c["name"] for c in row["channels"]] == ["P1 [W]", "P2_mW"]
    result = wbpower("inspect", "--power-column", "P3", path)
    assert result.exit_code == 2 and "no column 'P3'" in result.stderr
    result = wbpower("inspect", "--power-column", "P1 [W]", "--current-column", "x", path)
    assert result.exit_code == 2 and "--power-column with --current-column" in result.stderr
    assert "Traceback" not in result.stderr


# -- time in its unit; a time-like column is never silently ignored ---------------------------


@pytest.mark.parametrize(("column", "scale"), [("time_ms", 1e-3), ("time_us", 1e-6)])
def test_time_ms_and_us_are_read_in_their_unit(tmp_path, column, scale):
    text = f"{column},power_W\n0,23\n250,24\n500,25\n"
    run = read_log(_write(tmp_path / "t.csv", text))
    assert_allclose(run.time_s, np.array([0, 250, 500]) * scale, rtol=1e-15)
    assert run.sample_period_s == pytest.approx(250 * scale, rel=1e-12)


def _time_volts_amps_watts(path: Path) -> tuple[float, float]:
    """The issue's reproduction: a `Time,Volts,Amps,Watts` log at 1.024 ms for 6.67 s, about
    28 W; returns the true duration [s] and energy [J] of what is written."""
    n = 6514  # 6514 x 1.024 ms = 6.670 s
    k = np.arange(n)
    volts = 12.0 + 0.01 * (k % 7)
    amps = 2.23 + 0.05 * (k % 5)
    lines = [
        f"{j * 1.024e-3:.6f},{v:.2f},{a:.2f},{v * a:.4f}"
        for j, v, a in zip(k, volts, amps, strict=True)
    ]
    path.write_text("Time,Volts,Amps,Watts\n" + "\n".join(lines) + "\n")
    written_V = np.round(volts, 2)
    written_A = np.round(amps, 2)
    return n * 1.024e-3, float(np.sum(written_V * written_A) * 1.024e-3)


def test_reproduction_time_column_not_ignored(tmp_path, wbpower):
    path = tmp_path / "logger.csv"
    duration_s, energy_J = _time_volts_amps_watts(path)
    assert duration_s == pytest.approx(6.67, abs=0.001) and energy_J == pytest.approx(187, rel=0.01)
    named = ("--current-column", "Amps", "--voltage-column", "Volts")
    # before: 0.667 s and 18.7 J (the 'Time' column ignored, 0.1024 ms assumed); now an error
    result = wbpower("inspect", "--json", *named, path)
    assert result.exit_code == 2
    assert "column 'Time' looks like time" in result.stderr and "--time-unit" in result.stderr
    for unit in (("--time-unit", "s"), ("--time-column", "time", "--time-unit", "s")):
        result = wbpower("inspect", "--json", *named, *unit, path)
        assert result.exit_code == 0, result.stderr
        (row,) = json.loads(result.stdout)["logs"]
        assert row["sample_period_s"] == pytest.approx(1.024e-3, rel=1e-9)
        assert row["duration_s"] == pytest.approx(duration_s, rel=1e-9)
        assert row["energy_J"] == pytest.approx(energy_J, rel=1e-9)


@pytest.mark.parametrize(
    ("name", "scale"), [("Time [s]", 1.0), ("time (ms)", 1e-3), ("Timestamp_us", 1e-6)]
)
def test_a_time_column_whose_name_gives_its_unit_is_used(tmp_path, name, scale):
    run = read_log(_write(tmp_path / "t.csv", f"{name},power_W\n0,23\n2,24\n4,25\n"))
    assert_allclose(run.time_s, np.array([0.0, 2.0, 4.0]) * scale, rtol=1e-15)


def test_time_column_options(tmp_path):
    path = _write(tmp_path / "t.csv", "clock,power_W\n0,23\n5,24\n10,25\n")
    assert read_log(path).sample_period_s == 0.1024e-3  # 'clock' does not say it is time
    run = read_log(path, ReadOptions(time_column="CLOCK", time_unit="ms"))
    assert_allclose(run.time_s, [0.0, 0.005, 0.010], rtol=1e-15)
    with pytest.raises(LogError, match="unit of time column 'clock' is unknown"):
        read_log(path, ReadOptions(time_column="clock"))
    with pytest.raises(LogError, match="no column 'tick'"):
        read_log(path, ReadOptions(time_column="tick", time_unit="s"))
    with pytest.raises(UsageError, match="time unit 'min'"):
        ReadOptions(time_unit="min")


def test_several_time_columns(tmp_path):
    both = _write(tmp_path / "two.csv", "t,Time [ms],power_W\n0,0,23\n1,1,24\n")
    with pytest.raises(LogError, match="several time columns"):
        read_log(both)
    run = read_log(both, ReadOptions(time_column="Time [ms]"))
    assert_allclose(run.time_s, [0.0, 0.001], rtol=1e-15)
    # the canonical time_s beside a clock-time text column: time_s is the time
    text = "time_s,timestamp,power_W\n0,2020-01-01T10:00:00,23\n0.5,2020-01-01T10:00:00.5,24\n"
    assert read_log(_write(tmp_path / "clock.csv", text)).time_s.tolist() == [0.0, 0.5]


def test_sample_period_instead_of_an_unreadable_time_column_is_reported(tmp_path):
    path = _write(tmp_path / "t.csv", "timestamp,power_W\n10:00:00,23\n10:00:01,24\n")
    with pytest.raises(LogError, match="column 'timestamp' looks like time"):
        read_log(path)
    run = read_log(path, ReadOptions(sample_period_s=1.0))
    assert run.time_s.tolist() == [0.0, 1.0]
    (problem,) = run.problems
    assert problem.kind == "time_ignored" and "'timestamp'" in problem.message


@pytest.mark.parametrize(
    "arrow_type",
    ["float16", "float32", "float64", "int8", "int16", "int32", "int64", "uint8", "uint64"],
)
@pytest.mark.parametrize("nulls", [False, True])
def test_numeric_chunks_read_as_to_numpy_reads_them(arrow_type: str, nulls: bool) -> None:
    """The reader takes a numeric column's values from its buffers (pyarrow's `to_numpy`
    imports pandas: ~0.45 s in every `fit` worker): the same values as `to_numpy`, nulls
    NaN, chunks that start inside their buffers (slices) included."""
    import pyarrow as pa

    from wifibot_power.io.transport import _numeric_values

    values = [float(k % 7) for k in range(40)]
    data = [None if nulls and k % 9 == 4 else v for k, v in enumerate(values)]
    array = pa.array(data, type=pa.float64()).cast(getattr(pa, arrow_type)())
    for chunk in (array, array.slice(3), array.slice(5, 20), array.slice(13, 1)):
        expected = chunk.to_numpy(zero_copy_only=False)
        got = _numeric_values(chunk)
        assert got.dtype == expected.dtype
        np.testing.assert_array_equal(got, expected)  # NaN where the other has NaN
        assert np.isnan(got).any() == (chunk.null_count > 0)
