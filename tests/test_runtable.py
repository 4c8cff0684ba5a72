"""The per-run table: hand-built runs with phases whose means and energies are known exactly.

Phases are built here by hand (not by the segmenter), so these tests check the table alone.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from contract import RUNS_PARQUET_COLUMNS
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from wifibot_power.phases import Phase, Segmentation
from wifibot_power.run import Run, RunMeta
from wifibot_power.runtable import RUN_COLUMNS, run_row, runs_frame

PERIOD_S = 0.01


def build(pieces, *, mode="motion", speed_mps=0.5, distance_m=4.0, steps=2, period_s=PERIOD_S):
    """A run and its segmentation from (phase, step, samples) pieces."""
    power = np.concatenate([np.asarray(values, dtype=float) for _, _, values in pieces])
    phases, start = [], 0
    for name, step, values in pieces:
        end = start + len(values)
        mean = float(np.mean(values))
        phases.append(
            Phase(
                step,
                name,
                start,
                end,
                start * period_s,
                end * period_s,
                mean,
                mean * len(values) * period_s,
            )
        )
        start = end
    meta = RunMeta(
        run_id="r1",
        mode=mode,
        speed_mps=speed_mps,
        distance_m=distance_m,
        steps=steps,
        sample_period_s=period_s,
    )
    run = Run("r1.csv", "wbpower-csv", meta, np.arange(power.size) * period_s, power)
    return run, Segmentation("r1", tuple(phases))


# Two steps: idle 20 W, accel ramping 30->40 W (mean exactly 35 W), cruise 30 W, a decel
# at 25 W after step 1 only, idle 20 W between and after.
TWO_STEPS = [
    ("idle", 0, np.full(100, 20.0)),
    ("accel", 1, np.linspace(30.0, 40.0, 50)),
    ("cruise", 1, np.full(200, 30.0)),
    ("decel", 1, np.full(20, 25.0)),
    ("idle", 1, np.full(100, 20.0)),
    ("accel", 2, np.linspace(30.0, 40.0, 50)),
    ("cruise", 2, np.full(200, 30.0)),
    ("idle", 2, np.full(100, 20.0)),
]


def test_row_of_a_two_step_run_matches_hand_values():
    run, segmentation = build(TWO_STEPS)
    row = run_row(run, segmentation)
    # by hand, at 0.01 s per sample:
    #   accel 2 x 50 x 35 W x 0.01 s = 35 J; cruise 2 x 200 x 30 x 0.01 = 120 J;
    #   decel 20 x 25 x 0.01 = 5 J -> motion 160 J; idle 300 x 20 x 0.01 = 60 J -> total 220 J
    #   duration 820 samples = 8.2 s; t_acc = 50 samples = 0.5 s; decel 0.2 s over 2 steps
    expected = {
        "motion_energy_J": 160.0,
        "energy_J": 220.0,
        "duration_s": 8.2,
        "t_acc_s": 0.5,
        "accel_mean_power_W": 35.0,
        "accel_energy_J": 35.0,
        "cruise_mean_power_W": 30.0,
        "cruise_duration_s": 4.0,
        "decel_duration_s": 0.1,
        "decel_mean_power_W": 25.0,
        "idle_mean_power_W": 20.0,
        "idle_duration_s": 3.0,
        "mean_power_W": 220.0 / 8.2,
    }
    for key, value in expected.items():
        # only float rounding separates these from the hand values
        assert_allclose(row[key], value, rtol=1e-12, err_msg=key)
    assert row["steps_found"] == 2
    assert row["usable"] and row["skip_reason"] == ""


def test_phase_means_are_time_weighted():
    # cruise split in two pieces (e.g. a segmenter cut it): 100 samples at 30 W and 300 at 34 W.
    # time-weighted mean = (100*30 + 300*34) / 400 = 33 W; the mean of means would be 32 W.
    pieces = [
        ("idle", 0, np.full(50, 20.0)),
        ("accel", 1, np.full(30, 36.0)),
        ("cruise", 1, np.full(100, 30.0)),
        ("cruise", 1, np.full(300, 34.0)),
        ("idle", 1, np.full(50, 20.0)),
    ]
    run, segmentation = build(pieces, steps=1)
    row = run_row(run, segmentation)
    assert_allclose(row["cruise_mean_power_W"], 33.0, rtol=1e-12)
    assert row["decel_duration_s"] == 0.0 and np.isnan(row["decel_mean_power_W"])


def test_table_recomputes_from_samples_not_from_the_segmenters_numbers():
    run, segmentation = build(TWO_STEPS)
    wrong = Segmentation(
        "r1",
        tuple(
            Phase(p.step, p.phase, p.i_start, p.i_end, p.t_start_s, p.t_end_s, 999.0, 999.0)
            for p in segmentation.phases
        ),
    )
    assert_allclose(run_row(run, wrong)["accel_mean_power_W"], 35.0, rtol=1e-12)


def test_step_count_mismatch_is_unusable_with_reason():
    run, segmentation = build(TWO_STEPS, steps=3)
    row = run_row(run, segmentation)
    assert not row["usable"]
    assert "found 2 step(s), metadata says 3" in row["skip_reason"]


def test_motion_run_without_distance_is_unusable():
    run, segmentation = build(TWO_STEPS, distance_m=None)
    row = run_row(run, segmentation)
    assert not row["usable"] and "without a distance" in row["skip_reason"]


def test_unknown_mode_is_unusable_and_mode_runs_are_usable():
    pieces = [("level", 1, np.full(100, 25.0))]
    run, segmentation = build(pieces, mode="unknown", speed_mps=None, distance_m=None, steps=1)
    assert not run_row(run, segmentation)["usable"]
    run, segmentation = build(pieces, mode="network", speed_mps=None, distance_m=None, steps=1)
    row = run_row(run, segmentation)
    assert row["usable"] and row["mean_power_W"] == 25.0
    assert np.isnan(row["idle_mean_power_W"])  # a network run's level is not idle


#: The reason of a run of unknown mode, as it has always read (other tests and the golden
#: corpora compare it byte for byte).
NO_MODE_REASON = (
    "no mode or speed in its metadata, so it cannot be fitted "
    "(add mode/speed_mps/distance_m/steps to the file's '#' lines or to runs.csv)"
)


def test_unknown_mode_with_a_rate_of_turn_but_no_speed_says_the_drive_model_needs_speed():
    # a turning column looks like enough for the drive model; without a speed column it is
    # not, and the reason says so (one line); without a turning column it is unchanged
    from dataclasses import replace

    pieces = [("level", 1, np.full(100, 25.0))]
    run, segmentation = build(pieces, mode="unknown", speed_mps=None, distance_m=None, steps=1)
    assert run_row(run, segmentation)["skip_reason"] == NO_MODE_REASON
    turning = replace(run, yaw_rate_radps=np.full(100, 0.4))
    reason = run_row(turning, segmentation)["skip_reason"]
    assert reason.startswith(NO_MODE_REASON) and "\n" not in reason
    assert "the drive model needs a speed column (speed_mps, or two wheel speeds)" in reason
    # with a speed column too, the drive model has what it needs: nothing more is said
    both = replace(turning, speed_mps=np.full(100, 0.3))
    assert run_row(both, segmentation)["skip_reason"] == NO_MODE_REASON


def test_phases_that_do_not_cover_the_run_are_reported():
    run, segmentation = build(TWO_STEPS)
    gap = Segmentation("r1", segmentation.phases[:3] + segmentation.phases[4:])
    row = run_row(run, gap)
    assert not row["usable"] and "cover" in row["skip_reason"]


def test_frame_has_the_contract_columns_and_survives_parquet(tmp_path):
    run, segmentation = build(TWO_STEPS)
    frame = runs_frame([run_row(run, segmentation)])
    assert RUNS_PARQUET_COLUMNS <= set(frame.columns)
    assert list(frame.columns) == list(RUN_COLUMNS)
    frame.to_parquet(tmp_path / "runs.parquet", index=False)
    back = pd.read_parquet(tmp_path / "runs.parquet")
    assert_allclose(back["motion_energy_J"], [160.0], rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    lengths=st.lists(st.integers(1, 40), min_size=1, max_size=12),
    seed=st.integers(0, 2**32 - 1),
)
def test_energy_is_additive_over_phases(lengths, seed):
    """Whatever the phase labels and lengths, motion + idle energy is the run's energy and
    the per-phase energies add up to the motion energy."""
    rng = np.random.default_rng(seed)
    names = rng.choice(["idle", "accel", "cruise", "decel"], size=len(lengths))
    pieces = [(str(n), 1, rng.uniform(0.0, 60.0, k)) for n, k in zip(names, lengths, strict=True)]
    run, segmentation = build(pieces, steps=1)
    row = run_row(run, segmentation)
    idle_J = row["idle_mean_power_W"] * row["idle_duration_s"] if "idle" in names else 0.0
    # sums of <= 480 terms of <= 60 W x 0.01 s: float error far below 1e-9 J
    assert_allclose(row["motion_energy_J"] + idle_J, row["energy_J"], rtol=0, atol=1e-9)
    parts = sum(row[f"{p}_energy_J"] for p in ("accel", "cruise", "decel"))
    assert_allclose(parts, row["motion_energy_J"], rtol=0, atol=1e-9)


def test_one_commanded_speed_on_every_cruise_is_that_speed_exactly():
    """Cruises of 0.1, 0.2 and 0.3 s all at 0.3 m/s: their time-weighted mean is
    0.29999999999999993 in floating point, and runs at one speed then counted as two
    speeds, so fit drew a slope through float noise (exit 0 with a model.json)."""
    from wifibot_power.runtable import _cruise_speed

    cruises = tuple(
        Phase(1, "cruise", 0, 1, 0.0, duration_s, 1.0, 1.0, speed_mps=0.3)
        for duration_s in (0.1, 0.2, 0.3)
    )
    assert _cruise_speed(Segmentation("r", cruises)) == (0.3, 1)


def test_a_line_through_one_speed_level_is_not_fitted():
    from wifibot_power.fit import fit_line

    # float noise, and speeds within their resolution (fit.speed_levels), are one level
    for speeds in ([0.3, 0.29999999999999993, 0.3], [0.3, 0.301, 0.3]):
        line = fit_line(np.array(speeds), np.array([27.0, 27.5, 27.2]))
        assert np.isnan(line.slope) and np.isnan(line.intercept)
    line = fit_line(np.array([0.3, 0.6, 0.9]), np.array([27.0, 30.0, 33.0]))
    assert_allclose([line.intercept, line.slope], [24.0, 10.0], rtol=1e-12)


def test_without_a_distance_a_speed_column_gives_the_path_of_the_motion_phases():
    """A log with a speed column and no distance_m (the REGBOT logs): the run's distance is
    the path its motion phases cover, sum of |v| dt, and says where it came from; idle
    samples' speed (an encoder's noise around 0) does not count. With distance_m given, the
    metadata's wins; with neither, no distance and the run is not usable."""
    from dataclasses import replace

    run, seg = build(TWO_STEPS, distance_m=None)
    speed = np.full(run.samples, 0.02)  # idle: noise that must not count
    for p in seg.phases:
        if p.phase in ("accel", "cruise", "decel"):
            speed[p.i_start : p.i_end] = -0.4 if p.step == 2 else 0.5  # backwards counts too
    moving = sum(p.i_end - p.i_start for p in seg.phases if p.phase != "idle" and p.step == 1)
    backwards = sum(p.i_end - p.i_start for p in seg.phases if p.phase != "idle" and p.step == 2)
    row = run_row(replace(run, speed_mps=speed), seg)
    assert row["distance_source"] == "speed column"
    assert row["distance_m"] == pytest.approx((0.5 * moving + 0.4 * backwards) * PERIOD_S)
    given = run_row(replace(run, speed_mps=speed, meta=replace(run.meta, distance_m=3.0)), seg)
    assert (given["distance_m"], given["distance_source"]) == (3.0, "metadata")
    neither = run_row(run, seg)
    assert np.isnan(neither["distance_m"]) and neither["distance_source"] == ""
    assert "without a distance" in neither["skip_reason"]


def test_run_energy_and_mean_power_are_the_samples_own_to_the_bit():
    """The row sums the samples once for both (`Run.energy_and_mean`): the same floats as
    the rectangle rule (`run.energy_J(power, period)`) and numpy's mean of the samples, on
    noisy samples whose sum rounds."""
    from wifibot_power.run import energy_J

    rng = np.random.default_rng(4)
    for n in (1, 7, 1000, 131_073):
        power = 23.3 + rng.normal(0, 3, n)
        run, segmentation = build([("idle", 0, power)], mode="idle")
        row = run_row(run, segmentation)
        assert row["energy_J"] == energy_J(power, PERIOD_S) == run.energy_J
        assert row["mean_power_W"] == float(power.mean()) == run.mean_power_W
        assert row["idle_mean_power_W"] == float(power.mean())


def test_a_runs_energy_is_summed_once_for_the_row_and_the_drive_statistics(monkeypatch):
    """`Run.energy_and_mean` is made once a run (the run table's row and the drive model's
    statistics both read it: one pass over the samples, not two), and what the drive
    statistics keep is the row's energy to the bit."""
    from wifibot_power.drive.stats import drive_stats

    run, segmentation = build(TWO_STEPS)
    calls = []
    real_sum = np.sum
    monkeypatch.setattr(np, "sum", lambda *a, **k: calls.append(a[0].size) or real_sum(*a, **k))
    row = run_row(run, segmentation)
    stats = drive_stats(run, segmentation)
    monkeypatch.undo()
    assert calls.count(run.samples) == 1  # the samples summed whole once
    assert stats is not None and stats.energy_J == row["energy_J"] == energy_J_of(run)
    assert run.energy_and_mean() is run.energy_and_mean()


def energy_J_of(run) -> float:
    """The rectangle rule on the run's samples, made afresh."""
    from wifibot_power.run import energy_J

    return energy_J(run.power_W, run.sample_period_s)
