"""Field logs read right (issue 26, the reader's part): no fixed power ceiling, bursty loggers
judged by their own pattern, every assumption said, column errors that list what was found,
absurd sample periods refused.

Each file is made here to the shape the issue describes (seeded); expected values are worked
out by hand from what the test wrote, never taken from the reader's output.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.errors import LogError, UsageError
from wifibot_power.io import ReadOptions, read_log

# -- 1. plausible power: the log's own robot, never a fixed ceiling ---------------------------


def vehicle_log(path: Path, *, power_scale: float = 1.0, meta: str = "", seed: int = 1) -> Path:
    """An electric unicycle's ride as a phone app logs it at 10 Hz: 84 V pack, 1-3 kW.
    `power_scale=1000` writes the power in mW under the name `power_W` (the unit mistake)."""
    rng = np.random.default_rng(seed)
    n = 600
    power_W = 1000.0 + 2000.0 * rng.random(n)  # 1-3 kW
    voltage_V = 84.0 - 0.002 * power_W  # sag under load
    current_A = power_W / voltage_V
    lines = [
        f"{0.1 * k:.1f},{v:.3f},{c:.4f},{p * power_scale:.3f}"
        for k, (v, c, p) in enumerate(zip(voltage_V, current_A, power_W, strict=True))
    ]
    path.write_text(f"{meta}time_s,voltage_V,current_A,power_W\n" + "\n".join(lines) + "\n")
    return path


def test_a_1_to_3_kW_vehicle_is_read(tmp_path):
    run = read_log(vehicle_log(tmp_path / "unicycle.csv"))
    assert 1000.0 <= run.power_W.min() and run.power_W.max() <= 3000.0
    assert 1900.0 < run.mean_power_W < 2100.0  # uniform 1-3 kW: mean 2 kW
    assert not [p for p in run.problems if p.kind == "unjudged_power"]  # V and I judged it


def test_a_unit_mistake_is_still_refused(tmp_path):
    """The same ride with the power in mW under `power_W`: 1000 x the V x I beside it."""
    with pytest.raises(LogError, match=r"1e\+03 times the voltage x current") as error:
        read_log(vehicle_log(tmp_path / "unicycle_mW.csv", power_scale=1000.0))
    assert "mW in a column named W" in str(error.value)


def test_max_power_metadata_and_option_are_the_robots_ceiling(tmp_path):
    small = vehicle_log(tmp_path / "small.csv", meta="# max_power_W: 2500\n")
    with pytest.raises(LogError, match="over the robot's max_power_W 2500 W") as error:
        read_log(small)
    assert "metadata line 1" in str(error.value)
    # --max-power wins over the metadata, either way
    assert read_log(small, ReadOptions(max_power_W=3500.0)).samples == 600
    plain = vehicle_log(tmp_path / "plain.csv")
    with pytest.raises(LogError, match=r"max_power_W 1500 W \(--max-power\)"):
        read_log(plain, ReadOptions(max_power_W=1500.0))
    with pytest.raises(UsageError, match="--max-power"):
        ReadOptions(max_power_W=0.0)


def test_a_power_only_kW_log_is_read_with_a_warning_that_it_was_not_judged(tmp_path):
    path = tmp_path / "kw_only.csv"
    path.write_text("time_s,power_W\n0,1500\n0.1,2500\n0.2,1800\n")
    run = read_log(path)
    (said,) = [p for p in run.problems if p.kind == "unjudged_power"]
    assert "2500 W" in said.message and "--max-power" in said.message
    # with a ceiling that holds it, nothing to say
    assert not read_log(path, ReadOptions(max_power_W=3000.0)).problems


def test_supply_voltage_in_mV_is_a_usage_error():
    with pytest.raises(UsageError, match="--supply-voltage 12600"):
        ReadOptions(supply_voltage_V=12600.0)


# -- 2. a bursty logger judged by its own pattern ---------------------------------------------

BURST_STEP_S = 0.020
STALL_S = 9.0


def bursty_times(seed: int = 26, pairs: int = 600, stall_after: int | None = 300) -> np.ndarray:
    """A phone app's stamps: rows in pairs 20 ms apart, then nothing for 0.5-3.6 s; with one
    stall of `STALL_S` after pair `stall_after` (the app paused by the phone). Rounded to the
    0.1 ms the file holds."""
    rng = np.random.default_rng(seed)
    steps_s = np.empty(2 * pairs - 1)
    steps_s[0::2] = BURST_STEP_S
    steps_s[1::2] = rng.uniform(0.5, 3.6, pairs - 1)
    if stall_after is not None:
        steps_s[2 * stall_after + 1] = STALL_S
    return np.round(np.concatenate(([0.0], np.cumsum(steps_s))), 4)


def write_bursty(path: Path, time_s: np.ndarray, seed: int = 27) -> np.ndarray:
    """A 1.5 kW ride (84 V) at those stamps; returns the power written [W]."""
    rng = np.random.default_rng(seed)
    power_W = np.round(1500.0 + rng.normal(0.0, 20.0, time_s.size), 2)
    current_A = power_W / 84.0
    lines = [
        f"{t:.4f},84.000,{c:.5f},{p:.2f}"
        for t, c, p in zip(time_s, current_A, power_W, strict=True)
    ]
    path.write_text("time_s,voltage_V,current_A,power_W\n" + "\n".join(lines) + "\n")
    return power_W


def test_a_bursty_log_is_read_with_its_energy_over_the_time_it_covers(tmp_path):
    time_s = bursty_times()
    power_W = write_bursty(tmp_path / "phone.csv", time_s)
    run = read_log(tmp_path / "phone.csv")
    assert run.samples == time_s.size
    # by hand: every step is covered except the stall's excess over one sample's hold; each
    # sample holds its own step, the stall's sample and the last one the mean of the others
    steps_s = np.diff(time_s)
    stall = int(np.argmax(steps_s))
    assert steps_s[stall] == pytest.approx(STALL_S)
    regular_s = np.delete(steps_s, stall)
    hold_s = regular_s.mean()
    own_s = np.append(steps_s, hold_s)
    own_s[stall] = hold_s
    covered_s = own_s.sum()
    missing_s = STALL_S - hold_s
    assert_allclose(covered_s, time_s[-1] - time_s[0] - missing_s + hold_s, rtol=1e-12)
    assert_allclose(run.duration_s, covered_s, rtol=1e-9)
    # the energy each sample holds over its own duration (a hold integral); the reader gives
    # each the mean step, the same to within the noise (20 W) x the spread of the steps
    # (~0.9 s) x sqrt(n) ~ 0.8 kJ of ~1.85 MJ: 5e-4; the stall counted as covered would add
    # 1.5 kW x 8 s = 0.64%
    hold_J = float(np.sum(power_W * own_s))
    assert_allclose(run.energy_J, hold_J, rtol=2e-3)
    counted_J = run.energy_J * (1.0 + missing_s / covered_s)  # the stall held, not missing
    assert counted_J - hold_J > 2 * 2e-3 * hold_J
    # what is missing is reported: the stall, where and how long
    (gap,) = [p for p in run.problems if p.kind == "gap"]
    assert_allclose(gap.duration_s, missing_s, rtol=1e-6)
    assert_allclose(gap.t_start_s, time_s[stall] + hold_s, rtol=1e-9)
    assert "bursty logger" in gap.message
    (pattern,) = [p for p in run.problems if p.kind == "bursty"]
    assert "20 ms" in pattern.message and "not the median step" in pattern.message


def test_a_bursty_log_without_a_stall_misses_nothing(tmp_path):
    time_s = bursty_times(stall_after=None)
    power_W = write_bursty(tmp_path / "phone.csv", time_s)
    run = read_log(tmp_path / "phone.csv")
    assert not [p for p in run.problems if p.kind == "gap"]
    assert "0 s missing" in next(p.message for p in run.problems if p.kind == "bursty")
    span_s = time_s[-1] - time_s[0]
    assert_allclose(run.duration_s, span_s * time_s.size / (time_s.size - 1), rtol=1e-9)
    assert_allclose(run.mean_power_W, power_W.mean(), rtol=1e-12)


def test_a_bursty_log_with_a_long_stall_is_read_with_the_stall_missing(tmp_path):
    """A minute without rows in a log that waits at most 3.6 s (a phone that lost the wheel):
    read, the minute missing (reported with its line), the energy over the time covered."""
    time_s = bursty_times(stall_after=None)
    time_s[601:] += 60.0
    power_W = write_bursty(tmp_path / "phone.csv", time_s)
    run = read_log(tmp_path / "phone.csv")
    (gap,) = [p for p in run.problems if p.kind == "gap"]
    assert gap.duration_s > 55.0 and "line 603" in gap.message  # the header is line 1
    # energy over the covered time: the span less the missing minute, at the mean power
    assert_allclose(run.duration_s + gap.duration_s, time_s[-1] - time_s[0] + run.sample_period_s)
    assert_allclose(run.energy_J, power_W.mean() * run.duration_s, rtol=1e-9)


def test_a_log_missing_more_time_than_it_covers_is_refused(tmp_path):
    """Two sessions hours apart in one file (euc_core/mten4/2: 8.4 h between two rides of
    43 min): more time missing than its samples cover; refused, saying to cut it there."""
    time_s = bursty_times(stall_after=None)
    covered_s = time_s[-1] - time_s[0]
    time_s[601:] += 1.2 * covered_s
    write_bursty(tmp_path / "phone.csv", time_s)
    with pytest.raises(LogError, match="more time missing than the") as error:
        read_log(tmp_path / "phone.csv")
    assert "line 603" in str(error.value) and "cut it at its longest gap" in str(error.value)
    # a stall a little shorter than the covered time is read
    time_s[601:] -= 0.4 * covered_s
    write_bursty(tmp_path / "phone.csv", time_s)
    assert read_log(tmp_path / "phone.csv").samples == time_s.size


def test_a_logger_dropping_samples_now_and_then_is_not_bursty(tmp_path):
    """10 kHz with 15% of the steps two periods long: 26% of its time in them, not its habit
    (the bursty rule needs most of the time): refused as dropped samples, as before."""
    rng = np.random.default_rng(5)
    steps = np.where(rng.random(3000) < 0.15, 2, 1)
    time_s = np.concatenate(([0], np.cumsum(steps))) * 1e-4
    body = "".join(f"{t:.4f},23.3\n" for t in time_s)
    (tmp_path / "drops.csv").write_text("time_s,power_W\n" + body)
    with pytest.raises(LogError, match="gap\\(s\\) of dropped samples, .* % of the log|dropped"):
        read_log(tmp_path / "drops.csv")


# -- 3. every assumption said ------------------------------------------------------------------


def test_an_assumed_sample_period_is_said_everywhere(tmp_path, wbpower):
    path = tmp_path / "power_only.csv"
    path.write_text("power_W\n23.3\n23.4\n23.5\n")
    (said,) = read_log(path).problems
    assert said.kind == "assumed_period"
    assert "0.1024 ms" in said.message and "--sample-period" in said.message
    result = wbpower("inspect", "--json", path)
    assert result.exit_code == 0, result.stderr
    assert "0.1024 ms" in result.stderr
    document = json.loads(result.stdout)
    assert any("0.1024 ms" in w for w in document["warnings"])
    assert any("0.1024 ms" in p for p in document["logs"][0]["problems"])
    # said where the period comes from somewhere: nothing assumed
    assert not read_log(path, ReadOptions(sample_period_s=1e-3)).problems
    path.write_text("# sample_period_s: 0.001\npower_W\n23.3\n23.4\n")
    assert not read_log(path).problems


def test_an_option_without_effect_is_said(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("time_s,power_W\n0,23.3\n0.001,23.4\n")
    (said,) = read_log(path, ReadOptions(supply_voltage_V=12.0)).problems
    assert said.kind == "ignored_option"
    assert "--supply-voltage 12 has no effect" in said.message and "'power_W'" in said.message
    (said,) = read_log(path, ReadOptions(sample_period_s=0.01)).problems
    assert "--sample-period 0.01 has no effect" in said.message
    # where it has an effect, nothing is said
    current = tmp_path / "i.csv"
    current.write_text("time_s,current_A\n0,1.5\n0.001,1.6\n")
    assert not read_log(current, ReadOptions(supply_voltage_V=12.0)).problems


def test_a_time_unit_that_disagrees_with_the_column_name_is_obeyed_and_said(tmp_path, wbpower):
    path = tmp_path / "t.csv"
    path.write_text("time_s,power_W\n0,23.3\n1,23.4\n2,23.5\n")
    run = read_log(path, ReadOptions(time_unit="ms"))
    assert run.sample_period_s == pytest.approx(1e-3)  # as asked
    (said,) = run.problems
    assert said.kind == "time_unit" and "'time_s'" in said.message and "ms" in said.message
    named = read_log(path, ReadOptions(time_column="time_s", time_unit="ms"))
    assert [p.kind for p in named.problems] == ["time_unit"]
    assert not read_log(path, ReadOptions(time_unit="s")).problems  # they agree
    result = wbpower("inspect", "--json", "--time-unit", "ms", path)
    assert any(
        "--time-unit ms on column 'time_s'" in w for w in json.loads(result.stdout)["warnings"]
    )


@pytest.mark.parametrize(
    ("header", "body", "needles"),
    [
        (
            "Time,Power",
            "0,23.3\n",
            (
                "columns found: 'Time', 'Power'",
                "--power-column 'Power'",
                "--time-column 'Time' --time-unit",
            ),
        ),
        (
            "time_s,Watts",
            "0,23.3\n",
            ("columns found: 'time_s', 'Watts'", "--power-column 'Watts'"),
        ),
        (
            "t_ms,I_A,U_V",
            "0,1.8,12\n",
            (
                "columns found: 't_ms', 'I_A', 'U_V'",
                "--current-column 'I_A' --voltage-column 'U_V'",
            ),
        ),
        ("time_s,speed", "0,1.0\n", ("columns found: 'time_s', 'speed'", "--power-column NAME")),
    ],
)
def test_a_column_error_lists_the_columns_found_and_the_options(tmp_path, header, body, needles):
    path = tmp_path / "log.csv"
    path.write_text(f"{header}\n{body}")
    with pytest.raises(LogError) as error:
        read_log(path)
    for needle in needles:
        assert needle in str(error.value), (needle, str(error.value))


def test_the_hinted_options_read_the_log(tmp_path):
    path = tmp_path / "log.csv"
    path.write_text("t_ms,I_A,U_V\n0,1.8,12\n1,1.9,12\n")
    run = read_log(path, ReadOptions(current_column="I_A", voltage_column="U_V"))
    assert_allclose(run.power_W, [21.6, 22.8])
    assert run.sample_period_s == pytest.approx(1e-3)


# -- 4. absurd sample periods ------------------------------------------------------------------

N6705 = (
    'N6705C exported datalog\n\n"Sample interval: {interval}"\n\nSample,"Curr avg 1","Volt avg 1"\n'
)


def test_an_absurd_n6705_interval_is_an_error(tmp_path):
    path = tmp_path / "dlog.csv"
    path.write_text(N6705.format(interval="1e300") + "0,1.0,12\n1,1.1,12\n")
    with pytest.raises(LogError, match="sample_period_s is 1e\\+300 s, outside") as error:
        read_log(path)
    assert "line 3" in str(error.value)
    # the option mends it
    assert read_log(path, ReadOptions(sample_period_s=1e-3)).sample_period_s == pytest.approx(1e-3)


def test_an_absurd_sample_period_option_is_a_usage_error(wbpower, tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("power_W\n23.3\n")
    result = wbpower("inspect", "--sample-period", "1e300", path)
    assert result.exit_code == 2
    assert "--sample-period 1e+300: outside" in result.stderr


def test_a_sample_index_beyond_2_to_the_53_is_an_error(tmp_path):
    path = tmp_path / "dlog.csv"
    path.write_text(N6705.format(interval="0.001") + "0,1.0,12\n1,1.1,12\n1e23,1.0,12\n")
    with pytest.raises(LogError, match="sample index 1e\\+23 .* beyond 2\\^53") as error:
        read_log(path)
    assert "line 8" in str(error.value)


def test_time_stamps_in_another_unit_than_named_are_an_error(tmp_path):
    """`time_us` holding seconds at 1 kHz: a 1 ns period."""
    path = tmp_path / "t.csv"
    path.write_text("time_us,power_W\n0,23\n0.001,23\n0.002,23\n")
    with pytest.raises(LogError, match="sample period of 1e-09 s, outside"):
        read_log(path)


# -- 5. inspect shows what fit would refuse -----------------------------------------------------


def test_inspect_lists_every_file_fit_would_refuse_with_its_own_reason(tmp_path, wbpower):
    """Five files refused at read time for five reasons: `inspect --json` lists each in
    `skipped` with its reason (the document of cli.md), beside the good log it read."""
    (tmp_path / "good.csv").write_text("time_s,power_W\n0,23.3\n0.001,23.4\n0.002,23.5\n")
    bad = {
        "unit.csv": ("# max_power_W: 100\ntime_s,power_W\n0,23\n0.001,2300\n", "max_power_W 100"),
        "columns.csv": ("Time,Power\n0,23\n", "columns found: 'Time', 'Power'"),
        "period.csv": ("# sample_period_s: 1e300\npower_W\n23\n", "outside the plausible"),
        "nan.csv": ("time_s,power_W\n0,23\n0.001,nan\n", "NaN"),
        "reversed.csv": ("time_s,power_W\n0,-23\n0.001,-24\n0.002,-23\n", "--flip-current"),
    }
    for name, (text, _) in bad.items():
        (tmp_path / name).write_text(text)
    result = wbpower("inspect", "--json", tmp_path)
    assert result.exit_code == 1
    document = json.loads(result.stdout)
    assert set(document) == {"logs", "skipped", "warnings", "error"}
    assert document["error"] is None
    assert [Path(row["file"]).name for row in document["logs"]] == ["good.csv"]
    reasons = {Path(item["file"]).name: item["reason"] for item in document["skipped"]}
    assert set(reasons) == set(bad)
    for name, (_, needle) in bad.items():
        assert needle in reasons[name], (name, reasons[name])
        assert reasons[name] in result.stderr  # and on stderr, as every command says it


def test_max_power_from_the_manifest_names_its_row(tmp_path, wbpower):
    (tmp_path / "a.csv").write_text("time_s,power_W\n0,23\n0.001,2300\n0.002,24\n")
    (tmp_path / "runs.csv").write_text("file,max_power_W\na.csv,100\n")
    result = wbpower("inspect", tmp_path / "a.csv")
    assert result.exit_code == 2
    assert "over the robot's max_power_W 100 W (" in result.stderr
    assert "runs.csv line 2)" in result.stderr
    # --max-power wins over the manifest too
    assert wbpower("inspect", "--max-power", "5000", tmp_path / "a.csv").exit_code == 0


def test_a_short_log_with_one_long_pause_is_a_gap_not_a_pattern(tmp_path):
    """Six samples 1 s apart with one 10 s pause: most of its time in one long step, but one
    wait is no pattern (bursty needs 10 waits): refused as a gap, as before."""
    (tmp_path / "pause.csv").write_text("time_s,power_W\n0,23\n1,23\n2,23\n12,23\n13,23\n14,23\n")
    with pytest.raises(LogError, match="1 gap\\(s\\) of dropped samples, 9 s in all"):
        read_log(tmp_path / "pause.csv")


def test_bursts_of_five_rows_are_a_pattern_too(tmp_path):
    """Rows in fives 20 ms apart, then 0.5-3.6 s: a fifth of the steps long, 97% of the
    time in them."""
    rng = np.random.default_rng(8)
    steps_s = np.tile([0.02, 0.02, 0.02, 0.02, 0.0], 300)[:-1]
    steps_s[4::5] = rng.uniform(0.5, 3.6, steps_s[4::5].size)
    time_s = np.round(np.concatenate(([0.0], np.cumsum(steps_s))), 4)
    write_bursty(tmp_path / "fives.csv", time_s)
    run = read_log(tmp_path / "fives.csv")
    assert [p.kind for p in run.problems] == ["bursty"]
    assert_allclose(run.duration_s, (time_s[-1] - time_s[0]) * time_s.size / (time_s.size - 1))


def test_a_single_time_stamp_gives_no_spacing_and_says_so(tmp_path):
    path = tmp_path / "one.csv"
    path.write_text("time_s,power_W\n0,23.3\n")
    run = read_log(path)
    assert [p.kind for p in run.problems] == ["assumed_period"]
    assert run.sample_period_s == pytest.approx(0.1024e-3)


def test_a_logger_whose_rate_changes_along_the_ride_keeps_the_hold_integral(tmp_path):
    """A phone app writing every 0.1 s for 10 min at 200 W, then (its Bluetooth connection
    interval changed) every 0.5 s for 10 min at 1000 W: by hand the ride holds
    200 x 600 + 1000 x 600 = 720 kJ. Each row held for the mean step (6000 + 1200 rows over
    1200 s: 0.1667 s) would give 200 x 6000 x 0.1667 + 1000 x 1200 x 0.1667 = 400 kJ, 44% low;
    read on the even grid by sample and hold, it is the hold integral to the grid's rounding
    (one jump of 800 W within one step: under 800 W x 0.17 s = 0.02%), and the note says so."""
    rng = np.random.default_rng(4)
    fast_s = np.arange(6000) * 0.1 + rng.uniform(-0.01, 0.01, 6000)
    slow_s = 600.0 + np.arange(1200) * 0.5 + rng.uniform(-0.01, 0.01, 1200)
    time_s = np.round(np.concatenate((fast_s, slow_s)) - fast_s[0], 4)
    power_W = np.concatenate((np.full(6000, 200.0), np.full(1200, 1000.0)))
    body = "".join(f"{t:.4f},{p:.1f}\n" for t, p in zip(time_s, power_W, strict=True))
    (tmp_path / "rates.csv").write_text("time_s,power_W\n" + body)
    run = read_log(tmp_path / "rates.csv")
    hold_J = float(np.sum(power_W[:-1] * np.diff(time_s))) + 1000.0 * run.sample_period_s
    assert hold_J == pytest.approx(720e3, rel=2e-3)
    assert run.energy_J == pytest.approx(hold_J, rel=2e-4)
    assert run.samples == time_s.size and set(np.unique(run.power_W)) == {200.0, 1000.0}
    (note,) = [p for p in run.problems if p.kind in ("uneven", "bursty")]
    assert "read on an even grid" in note.message and "would be -44% off" in note.message
