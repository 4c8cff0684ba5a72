"""wbpower on a second robot family: the F1/10 car's log (docs/real-logs.md).

A public log (AhmadAmine998/FrictionMaps, dataset 5, MIT) of a 1:10 race car driven by
hand around a track, its motor controller's (VESC) input current and voltage at ~18 Hz,
converted by benchmarks/real_logs/convert_f1tenth.py; the study is
benchmarks/real_logs/study_f1tenth.py. Data from fetched repositories is kept out of the
repository's commits: `convert_f1tenth.locate` finds the converted files
(WBPOWER_REAL_LOGS, ../shared/real_logs/f1tenth/, else converted from the fetched mirror
into a temporary folder); with none of these the tests that need them are skipped.

What is pinned was measured on the log (2026-11-23) and is checked against the log's own
columns where wbpower does not read them (the motor's phase current, the commanded speed).
"""

from __future__ import annotations

import gzip
import io
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scripts import load_script

from wifibot_power.io import read_log
from wifibot_power.segment import segment_run

ROOT = Path(__file__).resolve().parents[1]
study = load_script("study_f1tenth", ROOT / "benchmarks" / "real_logs" / "study_f1tenth.py")
convert = study.f1tenth

#: rows of each side of the logger's gaps, counted in coreData.csv (1094 + 1 + 691 + 440 =
#: its 2226 rows; the lone row between the first two gaps is dropped)
ROWS = {"ds5.csv.gz": 2226, "ds5_a.csv.gz": 1094, "ds5_b.csv.gz": 691, "ds5_c.csv.gz": 440}
SIDES = ("ds5_a.csv.gz", "ds5_b.csv.gz", "ds5_c.csv.gz")


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    found = convert.locate(tmp_path_factory.mktemp("f1tenth"))
    if found is None:
        pytest.skip(convert.UNAVAILABLE)
    return found


def _frame(folder: Path, name: str) -> pd.DataFrame:
    return pd.read_csv(folder / name, comment="#")


def _mirror() -> Path:
    mirror = Path(convert.os.environ.get(convert.MIRROR_VAR) or convert.DEFAULT_MIRROR)
    if not (mirror / "HEAD").is_file():
        pytest.skip("the fetched mirror is needed to read the source files")
    return mirror


def _source(name: str) -> pd.DataFrame:
    text = convert.git(_mirror(), "show", f"{convert.COMMIT}:{convert.FOLDER}/{name}")
    return pd.read_csv(io.BytesIO(text), index_col=0)


def test_the_files_hold_every_row_with_provenance(folder: Path) -> None:
    for name, rows in ROWS.items():
        assert len(_frame(folder, name)) == rows, name
        with gzip.open(folder / name, "rt") as fh:
            meta = dict(line[2:].rstrip("\n").split(": ", 1) for line in fh if line[:2] == "# ")
        assert meta["source_repo"] == "https://github.com/AhmadAmine998/FrictionMaps"
        assert meta["source_commit"] == convert.COMMIT
        assert meta["source_licence"].startswith("MIT")


def test_conversion_is_byte_for_byte_reproducible(folder: Path, tmp_path: Path) -> None:
    mirror = _mirror()
    convert.convert(mirror, tmp_path / "a", split_at_gaps=True)
    convert.convert(mirror, tmp_path / "b", split_at_gaps=True)
    for name in SIDES:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
        assert (tmp_path / "a" / name).read_bytes() == (folder / name).read_bytes()


def test_the_columns_are_the_sources_and_the_speed_is_the_cars_odometry(folder: Path) -> None:
    """Current and voltage are the VESC's input ones (cI, VI), not the motor's (cM); the
    speed -RPM/7500 agrees with the car's own odometry topic (odomData.csv vx, at its own
    stamps): measured 0.041 m/s RMS (the two topics' stamps differ by 9-47 ms while the
    car speeds up and slows down at up to ~10 m/s²), pinned at 0.06 m/s."""
    core, odom = _source("coreData.csv"), _source("odomData.csv")
    frame = _frame(folder, "ds5.csv.gz")
    np.testing.assert_array_equal(frame["current_A"].to_numpy(), core["cI"].to_numpy())
    np.testing.assert_array_equal(frame["voltage_V"].to_numpy(), core["VI"].to_numpy())
    s0 = core["s"].iloc[0]
    t_core = (core["s"] - s0).to_numpy() + core["ns"].to_numpy() * 1e-9
    t_odom = (odom["s"] - s0).to_numpy() + odom["ns"].to_numpy() * 1e-9
    speed = np.interp(t_odom, t_core, frame["speed_mps"].to_numpy())
    rms = float(np.sqrt(np.mean((odom["vx"].to_numpy() - speed) ** 2)))
    assert rms < 0.06, rms
    # and the car drives forwards: the mean speed is positive (1.3 m/s in the odometry)
    assert frame["speed_mps"].mean() > 1.0


def test_the_whole_log_is_read_with_the_loggers_gaps_missing(folder: Path) -> None:
    """The ROS logger stamps rows as they arrive (steps of 20-86 ms): judged by its own
    pattern (issue 26), its 1.6 s without a sample after t = 56.60 s (line 1107) and two
    shorter ones are time missing, reported with their lines, not a refusal; the energy is
    that of the time covered. (Refused before: 'a gap over 0.1523 s'.)"""
    run = read_log(folder / "ds5.csv.gz")
    gaps = [p for p in run.problems if p.kind == "gap"]
    longest = max(gaps, key=lambda p: p.duration_s)
    assert "line 1107" in longest.message and "t = 56.6002 s" in longest.message
    assert longest.duration_s == pytest.approx(1.6 - run.sample_period_s, abs=0.05)
    missing_s = sum(p.duration_s for p in gaps)
    span_s = run.time_s[-1] - run.time_s[0] + run.sample_period_s
    assert run.duration_s + missing_s == pytest.approx(span_s, rel=1e-9)


@pytest.mark.parametrize("name", SIDES)
def test_each_side_reads_as_input_current_times_voltage(folder: Path, name: str) -> None:
    frame = _frame(folder, name)
    run = read_log(folder / name)
    power_W = frame["voltage_V"].to_numpy() * frame["current_A"].to_numpy()
    (uneven,) = [p for p in run.problems if p.kind == "uneven"]
    if "read on an even grid" in uneven.message:
        # ds5_b: each row held for the mean step would miss the hold integral by 1.9%, over
        # the 1% bar; the grid (-1.5%) is nearer (issue 26; io/holdgrid.py). Every sample is
        # a logged row, in order, at an even step: none made up
        t = frame["time_s"].to_numpy()
        rows = np.searchsorted(t, run.time_s + 1e-9, side="right") - 1
        assert np.all(np.diff(rows) >= 0) and rows[0] == 0
        np.testing.assert_allclose(run.power_W, power_W[rows], rtol=0, atol=1e-9)
        np.testing.assert_array_equal(run.speed_mps, frame["speed_mps"].to_numpy()[rows])
        assert np.ptp(np.diff(run.time_s)) < 1e-9
    else:
        np.testing.assert_allclose(run.power_W, power_W, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(run.speed_mps, frame["speed_mps"].to_numpy())
    # regeneration is read as data and reported: 67, 38 and 33 samples below -1 W
    negative = [p for p in run.problems if p.kind == "negative"]
    assert len(negative) == 1 and f"{int(np.sum(power_W < -1.0))} sample(s)" in negative[0].message
    # the stamps are uneven (steps of 20-86 ms): the period is their mean step, and the
    # energy follows the stamps, sum P_i (t_i+1 - t_i): measured +0.33%, -1.5% (on the grid;
    # +1.9% each row held for the mean step) and -1.0% off (at the median step, as before
    # issue 26, 6.7%, 8.5% and 3.6% high), pinned at 2%
    step_s = np.diff(frame["time_s"].to_numpy())
    stamps_J = np.sum(power_W[:-1] * step_s) + power_W[-1] * run.sample_period_s
    assert run.energy_J == pytest.approx(stamps_J, rel=0.02)
    # and the ROS logger's longer steps (up to 86 ms) are its own pattern, not gaps: under
    # 1.5 x its 90th-percentile step (~64 ms; issue 26, "judge gaps by the logger's own
    # pattern"; before, 2-11 short gaps a side against 1.5 x the median step)
    assert not [p for p in run.problems if p.kind == "gap"]


@pytest.fixture(scope="module")
def studies(folder: Path) -> dict[str, object]:
    return {name: study.study_log(folder / name) for name in SIDES}


def test_motions_from_the_speed_column_match_the_truth(studies) -> None:
    """Measured: 11 of 12, 9 of 11 and 3 of 3 true motions found with both ends within the
    tolerance (2 sample periods, 105-110 ms), the matched ends at a median of 0 ms and at
    worst 65 ms off. The three missed are blips of 2-3 samples (0.08-0.14 s) above
    0.1 m/s, shorter than the segmenter's 0.1 s shortest stretch, inside stops."""
    right = {name: s.with_speed.right for name, s in studies.items()}
    assert right == {"ds5_a.csv.gz": 11, "ds5_b.csv.gz": 9, "ds5_c.csv.gz": 3}
    for s in studies.values():
        attempt = s.with_speed
        assert attempt.in_order  # no phase overlaps another (two motions made one)
        errors_s = np.abs(attempt.start_errors_s + attempt.end_errors_s)
        assert np.median(errors_s) <= 0.010  # measured 0 ms
        missed = len(s.truth) - attempt.right
        short = [b - a for a, b in s.truth if b - a < 0.15]
        assert missed <= len(short)


def test_without_the_speed_column_nothing_is_silently_wrong(studies) -> None:
    """Power alone finds 53, 19 and 14 motions for 12, 11 and 3 (every burst of throttle a
    step), none right, and says so in 27-60 doubts: doubted, not silently wrong."""
    for s in studies.values():
        assert s.without_speed.outcome == "doubted"
        assert len(s.without_speed.motions) > len(s.truth)


@pytest.mark.parametrize("name", SIDES)
def test_idles_where_the_motor_pushes_are_doubted(folder: Path, name: str) -> None:
    """The speed reads standstill (< 0.1 m/s) while the motor pushes at its current limit:
    every idle phase whose median motor (phase) current, a column wbpower does not read,
    exceeds 20 A should be doubted as pushing; no idle at standstill power (< 2 W)."""
    frame = _frame(folder, name)
    seg = segment_run(read_log(folder / name))
    doubted = set()
    for doubt in seg.doubts:
        found = re.match(r"the idle of step \d+ \(([\d.]+)-([\d.]+) s\) .* pushing", doubt)
        if found:
            doubted.add(found.groups())
    time_s, motor_A = frame["time_s"].to_numpy(), np.abs(frame["motor_current_A"].to_numpy())
    pushing = 0
    for phase in seg.phases:
        if phase.phase != "idle":
            continue
        key = (f"{phase.t_start_s:.3f}", f"{phase.t_end_s:.3f}")  # as the doubt prints them
        inside = (time_s >= phase.t_start_s) & (time_s < phase.t_end_s)
        if np.median(motor_A[inside]) > 20.0:
            pushing += 1
            assert key in doubted, (key, seg.doubts)
        if phase.mean_power_W < 2.0:
            assert key not in doubted, key
    assert pushing >= 1  # measured: 5, 4 and 1


def test_fit_and_diagnose_refuse_a_hand_driven_run_with_the_reason(folder: Path) -> None:
    """A run driven by hand holds 22-25 speed levels; the paper's model takes one speed a
    run: diagnose stops with that reason (exit 2), not a number. fit gives the drive model
    of these runs instead (cli.md, "The drive model": free driving is a success) and says
    the paper's reason in its note."""
    said = study.batch(folder)
    assert said["diagnose"].startswith("exit 2: "), said["diagnose"]
    assert "speed levels; fit takes one speed per run" in said["diagnose"]
    assert said["fit"].startswith("Drive model over 3 run(s)"), said["fit"]
    import subprocess
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        for name in SIDES:
            (Path(scratch) / name).write_bytes((folder / name).read_bytes())
        done = subprocess.run(
            [sys.executable, "-m", "wifibot_power", "fit", scratch, "--json"],
            capture_output=True,
            text=True,
            check=False,
        )
    doc = json.loads(done.stdout)
    assert doc["accel"] is None and doc["drive"]["n_runs"] == 3
    assert any("speed levels; fit takes one speed per run" in note for note in doc["notes"])


def test_the_report_says_why_nothing_is_fitted_as_fit_does(folder: Path, tmp_path: Path) -> None:
    """report's headline said "the paper's models need motion runs with speed, distance and
    steps in their metadata" whatever left the runs out; these runs have all three, and
    are left out for their 22-25 speed levels: the report now gives fit's reasons."""
    from wifibot_power.report import build_report

    for name in SIDES:
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    built = build_report(tmp_path)
    # the drive model fits (free driving is a success); the paper's figures say why not,
    # with fit's reasons
    assert built.fit is not None and not built.fit.has_paper
    from wifibot_power.figures import FIGURES

    why = FIGURES["power_speed"].from_report(built)
    assert isinstance(why, str) and "speed levels; fit takes one speed per run" in why
    assert "in their metadata" not in why
