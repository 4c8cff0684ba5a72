"""Segmentation of real-like motor logs (tests/realistic.py): from a speed column, and
from power alone with doubts (issue 12). The truth is the generator's encoder speed, not
anything segment.py computes.

Tolerances: the motion interval within 50 ms of the truth (issue 12's criterion), or one
sample where the logger's sample is longer (an ~18 Hz logger: 55 ms).
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from realistic import Scenario, realistic_run

from wifibot_power.changepoint import block_means, robust_sigma_W
from wifibot_power.errors import LogError
from wifibot_power.io.writer import format_log, write_log
from wifibot_power.run import Run, RunMeta
from wifibot_power.segment import MotionParams, _motion_doubts, segment_run
from wifibot_power.simulate import SimConfig, write_simulation

TOLERANCE_S = 0.050

#: realistic runs a new user brings (issue 12): starting moving, ending moving, idle at
#: 0 W (motors only) or above it, braking by shorting or by the drive, two speed levels up
#: or down, an ~18 Hz logger, slow and fast accelerations
SCENARIOS = {
    "short-brake": Scenario(),
    "drive-brake": Scenario(brake="drive"),
    "starts-moving": Scenario(start_moving=True),
    "ends-moving": Scenario(brake="none"),
    "two-levels-up": Scenario(levels_mps=(0.3, 0.6)),
    "two-levels-down": Scenario(levels_mps=(0.6, 0.3), brake="drive"),
    "logger-18Hz": Scenario(period_s=0.055),
    "idle-5W-drive": Scenario(idle_W=5.0, brake="drive"),
    "slow-accel-no-step": Scenario(accel_mps2=0.3, p_on_W=0.0, brake="drive"),
    "fast-coast": Scenario(coast_tau_s=0.02, levels_mps=(0.8,)),
    "noisy-pwm": Scenario(pwm_noise_frac=0.08, noise_W=0.2, brake="drive"),
}


def _interval(seg) -> tuple[float, float]:
    moving = [p for p in seg.phases if p.phase != "idle"]
    return moving[0].t_start_s, moving[-1].t_end_s


def _right(run: Run, seg, truth: dict) -> bool:
    tolerance = max(TOLERANCE_S, run.sample_period_s)
    start, end = _interval(seg)
    return (
        abs(start - truth["motion_start_s"]) <= tolerance
        and abs(end - truth["motion_end_s"]) <= tolerance
    )


# -- with a speed column -------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_speed_column_motion_interval_within_50_ms(name: str, seed: int) -> None:
    run, truth = realistic_run(replace(SCENARIOS[name], seed=seed))
    seg = segment_run(run)
    start, end = _interval(seg)
    tolerance = max(TOLERANCE_S, run.sample_period_s)
    assert start == pytest.approx(truth["motion_start_s"], abs=tolerance)
    assert end == pytest.approx(truth["motion_end_s"], abs=tolerance)
    # a motion from standstill starts speeding up; one that stops ends slowing
    moving = [p.phase for p in seg.phases if p.phase != "idle"]
    if not truth["starts_moving"]:
        assert moving[0] == "accel", moving
    if not truth["ends_moving"]:
        assert moving[-1] == "decel", moving
    # phases cover the run once, and each carries its mean measured speed
    assert seg.phases[0].i_start == 0 and seg.phases[-1].i_end == run.samples
    assert all(a.i_end == b.i_start for a, b in zip(seg.phases, seg.phases[1:], strict=False))
    for p in seg.phases:
        assert p.speed_mps == pytest.approx(np.mean(run.speed_mps[p.i_start : p.i_end]))


def test_speed_column_two_levels_each_its_own_accel_and_cruise() -> None:
    run, truth = realistic_run(Scenario(levels_mps=(0.3, 0.6), brake="drive"))
    seg = segment_run(run)
    names = [p.phase for p in seg.phases]
    assert names == ["idle", "accel", "cruise", "accel", "cruise", "decel", "idle"]
    cruises = seg.of("cruise")
    assert [c.speed_mps for c in cruises] == [
        pytest.approx(0.3, abs=0.005),
        pytest.approx(0.6, abs=0.005),
    ]
    # every boundary against the commanded plan (idle, accel, cruise, accel, cruise, decel,
    # idle): the drive's 10 ms lag shifts the speed, not the power the boundaries are
    # refined on; measured within 9 ms at seed 0, pinned at 15 ms
    plan_starts = [p["t_start_s"] for p in truth["plan"]]
    found_starts = [p.t_start_s for p in seg.phases]
    assert np.abs(np.array(found_starts[1:]) - np.array(plan_starts[1:])).max() <= 0.015
    assert not seg.doubts


def test_speed_column_start_and_end_moving_are_doubts() -> None:
    run, _ = realistic_run(Scenario(start_moving=True))
    assert any("starts moving" in d for d in segment_run(run).doubts)
    run, _ = realistic_run(Scenario(brake="none"))
    assert any("ends moving" in d for d in segment_run(run).doubts)


def test_speed_column_in_a_run_of_unknown_mode_and_a_standing_one() -> None:
    run, _ = realistic_run(Scenario(mode="unknown"))
    assert [p.phase for p in segment_run(run).phases][:3] == ["idle", "accel", "cruise"]
    # a speed column that never moves: a log of unknown mode gets its steady levels
    standing = replace(run, speed_mps=np.zeros(run.samples))
    assert {p.phase for p in segment_run(standing).phases} == {"level"}


# -- from power alone: right, or in doubt ------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_power_only_is_right_or_in_doubt(name: str, seed: int) -> None:
    """Issue 12's key requirement: zero silently wrong segmentations."""
    run, truth = realistic_run(replace(SCENARIOS[name], seed=seed))
    seg = segment_run(replace(run, speed_mps=None))
    assert _right(run, seg, truth) or seg.doubts, (
        f"silently wrong: {_interval(seg)} vs {truth['motion_start_s']}-{truth['motion_end_s']}"
    )


def test_power_only_issue_reproductions() -> None:
    """The observed failures of issue 12 each carry their doubt."""

    def doubts(scenario: Scenario) -> str:
        run, _ = realistic_run(scenario)
        return " | ".join(segment_run(replace(run, speed_mps=None)).doubts)

    # the first 0.2 s of real motion labelled idle: the run started moving
    assert "starts moving" in doubts(Scenario(start_moving=True))
    # stops invented before the end of runs that never stop
    assert "ends moving" in doubts(Scenario(brake="none"))
    # a whole first speed level buried inside accel / one cruise
    assert "level" in doubts(Scenario(levels_mps=(0.3, 0.6), brake="drive"))
    assert "two levels" in doubts(Scenario(levels_mps=(0.6, 0.3), brake="drive"))
    # shorted motors: power drops to 0 W while the wheels coast on
    assert "coasts" in doubts(Scenario())
    # and a clean run with a controlled stop above 0 W idle has none
    assert doubts(Scenario(idle_W=5.0, brake="drive")) == ""


def _hand_run(power_W: np.ndarray) -> Run:
    meta = RunMeta(
        run_id="hand", mode="motion", speed_mps=0.5, distance_m=1.0, steps=1, sample_period_s=1e-3
    )
    return Run("hand.csv", "canonical", meta, np.arange(power_W.size) * 1e-3, power_W)


def _trace(levels: list[tuple[float, float]], seed: int = 0) -> np.ndarray:
    """Flat levels [(seconds, W)] at 1 ms with 0.05 W of noise."""
    parts = [np.full(round(s * 1000), w) for s, w in levels]
    power = np.concatenate(parts)
    return power + np.random.default_rng(seed).normal(0, 0.05, power.size)


def _doubts_of(power: np.ndarray, bounds: list[tuple[int, int, str, int]]) -> list[str]:
    run = _hand_run(power)
    # what _segment_motion hands it: 10 ms means of the 1 ms blocks and their noise
    y10 = block_means(power, 10)
    return _motion_doubts(run, y10, 10, robust_sigma_W(y10), 1e-3, bounds, 1, MotionParams())


def test_doubt_steady_cruise_labelled_decel() -> None:
    # idle 5 W, accel, cruise 9 W; the last second of cruise labelled decel
    power = _trace([(1, 5), (0.5, 10), (3, 9), (1, 5)])
    right = [
        (0, 1000, "idle", 0),
        (1000, 1500, "accel", 1),
        (1500, 4500, "cruise", 1),
        (4500, 5500, "idle", 1),
    ]
    assert _doubts_of(power, right) == []
    wrong = [*right[:2], (1500, 3500, "cruise", 1), (3500, 4500, "decel", 1), right[3]]
    assert any("does not fall" in d for d in _doubts_of(power, wrong))


def test_doubt_idle_stretch_after_power_off_labelled_cruise() -> None:
    power = _trace([(1, 5), (0.5, 10), (3, 9), (1, 5)])
    wrong = [
        (0, 1000, "idle", 0),
        (1000, 1500, "accel", 1),
        (1500, 4800, "cruise", 1),
        (4800, 5500, "idle", 1),
    ]
    assert any("at idle power" in d for d in _doubts_of(power, wrong))


def test_doubt_first_motion_labelled_idle() -> None:
    power = _trace([(1, 5), (0.5, 10), (3, 9), (1, 5)])
    wrong = [
        (0, 1200, "idle", 0),
        (1200, 1500, "accel", 1),
        (1500, 4500, "cruise", 1),
        (4500, 5500, "idle", 1),
    ]
    assert any("motion labelled idle" in d for d in _doubts_of(power, wrong))


def test_doubt_first_level_buried_in_accel() -> None:
    # a first level at 8 W for 2 s, then a second at 11 W: labelled one accel and one cruise
    power = _trace([(1, 5), (0.3, 8.5), (2, 8), (0.3, 11.5), (2, 11), (1, 5)])
    wrong = [
        (0, 1000, "idle", 0),
        (1000, 3600, "accel", 1),
        (3600, 5600, "cruise", 1),
        (5600, 6600, "idle", 1),
    ]
    assert any("no boundary" in d for d in _doubts_of(power, wrong))


def test_step_count_against_metadata_is_a_doubt() -> None:
    run, _ = realistic_run(Scenario(idle_W=5.0, brake="drive", steps=2))
    assert any("metadata says 2" in d for d in segment_run(replace(run, speed_mps=None)).doubts)


# -- the command line ------------------------------------------------------------------------


def _write(run: Run, path) -> None:
    write_log(path, format_log(run.meta, run.power_W))


@pytest.fixture
def sim_dir(tmp_path):
    config = SimConfig(
        speeds_mps=(0.2, 0.5, 0.8),
        trips=((2.0, 1),),
        repeats=1,
        modes=(),
        seed=7,
        sample_period_s=1.024e-3,
    )
    write_simulation(config, tmp_path / "logs")
    return tmp_path / "logs"


def test_segment_prints_doubts_on_stderr_and_in_json(tmp_path, wbpower) -> None:
    run, _ = realistic_run(Scenario(brake="none", idle_W=5.0))
    path = tmp_path / "ends.csv"
    _write(replace(run, speed_mps=None), path)
    result = wbpower("segment", path, "--json")
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    assert any("ends moving" in d for d in doc["doubts"])
    assert "warning" in result.stderr and "ends moving" in result.stderr
    assert all("speed_mps" in p for p in doc["phases"])


def test_fit_leaves_doubtful_runs_out_unless_kept(sim_dir, tmp_path, wbpower) -> None:
    run, _ = realistic_run(Scenario(brake="none", idle_W=23.3, run_id="ends_moving"))
    _write(replace(run, speed_mps=None), sim_dir / "ends_moving.csv")
    result = wbpower("fit", sim_dir, "--json", "--jobs", "1")
    doc = json.loads(result.stdout)
    assert result.exit_code == 1
    (skip,) = [s for s in doc["skipped"] if "ends_moving" in s["file"]]
    assert "segmentation in doubt" in skip["reason"] and "ends moving" in skip["reason"]
    kept = json.loads(wbpower("fit", sim_dir, "--json", "--jobs", "1", "--keep-doubtful").stdout)
    assert kept["n_runs"] == doc["n_runs"] + 1
    assert not any("ends_moving" in s["file"] for s in kept["skipped"])


def test_segment_table_itself_says_it_is_in_doubt(tmp_path, wbpower) -> None:
    # cli.md: "wbpower never presents a segmentation it doubts as if it were sound": the
    # stdout table alone (stderr not seen, e.g. redirected) says so, and why
    run, _ = realistic_run(Scenario(brake="none", idle_W=5.0))
    path = tmp_path / "ends.csv"
    _write(replace(run, speed_mps=None), path)
    result = wbpower("segment", path)
    assert result.exit_code == 0
    title = result.stdout.splitlines()[0]
    assert "phase(s), in doubt: see warnings" in title
    assert "segmentation in doubt: the run ends moving" in " ".join(result.stdout.split())
    sound = tmp_path / "sound.csv"
    _write(replace(realistic_run(Scenario(idle_W=5.0, brake="drive"))[0], speed_mps=None), sound)
    assert "in doubt" not in wbpower("segment", sound).stdout


@pytest.fixture(scope="module")
def doubted_dir(tmp_path_factory):
    """Enough sound runs to fit and diagnose (3 speeds, 2 repeats), and 4 runs that end
    moving (a doubt each)."""
    folder = tmp_path_factory.mktemp("doubted")
    config = SimConfig(
        speeds_mps=(0.2, 0.5, 0.8),
        trips=((2.0, 1),),
        repeats=2,
        modes=(),
        seed=7,
        sample_period_s=1.024e-3,
    )
    write_simulation(config, folder)
    for k in range(4):
        run, _ = realistic_run(Scenario(brake="none", idle_W=23.3, run_id=f"ends{k}", seed=k))
        _write(replace(run, speed_mps=None), folder / f"ends{k}.csv")
    return folder


def _says_kept_in_doubt(text: str) -> None:
    assert "4 run(s) used with their segmentation in doubt (--keep-doubtful)" in text
    # the first three by run_id and file, with their doubt; the fourth counted
    assert "ends0 (ends0.csv: the run ends moving" in text and "ends2 (ends2.csv:" in text
    assert "ends3" not in text and "and 1 more" in text


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_keep_doubtful_says_which_doubted_runs_it_used(doubted_dir, wbpower, command) -> None:
    kept = wbpower(command, doubted_dir, "--json", "--jobs", "1", "--keep-doubtful")
    assert kept.exit_code == 0, kept.stderr
    doc = json.loads(kept.stdout)
    # fit: in `warnings` (cli.md); diagnose: the first of its `notes`
    said = doc["warnings"] if command == "fit" else doc["notes"]
    (line,) = [w for w in said if "in doubt" in w]
    _says_kept_in_doubt(line)
    (warning,) = [w for w in kept.stderr.splitlines() if "in doubt" in w]
    assert warning.startswith("wbpower: warning: ")
    _says_kept_in_doubt(warning)
    # without --keep-doubtful the runs are left out (skipped), not used: nothing to say
    left_out = wbpower(command, doubted_dir, "--json", "--jobs", "1")
    doc = json.loads(left_out.stdout)
    assert not [w for w in doc.get("warnings", []) + doc["notes"] if "used with" in w]
    assert "used with their segmentation in doubt" not in left_out.stderr


def test_run_table_takes_the_measured_speed_and_refuses_two_levels() -> None:
    from wifibot_power.runtable import run_row

    run, _ = realistic_run(Scenario(levels_mps=(0.42,), idle_W=5.0, brake="drive"))
    run = replace(run, meta=replace(run.meta, speed_mps=0.5))  # commanded 0.5, drove 0.42
    row = run_row(run, segment_run(run))
    assert row["speed_mps"] == pytest.approx(0.42, abs=0.005) and row["usable"]
    run, _ = realistic_run(Scenario(levels_mps=(0.3, 0.6), idle_W=5.0, brake="drive"))
    row = run_row(run, segment_run(run))
    assert row["cruise_levels"] == 2 and not row["usable"]
    assert "2 speed levels" in row["skip_reason"]


def test_diagnose_leaves_doubtful_runs_out_unless_kept() -> None:
    from wifibot_power.diagnose import diagnose_summaries, summarize_run
    from wifibot_power.phases import Segmentation
    from wifibot_power.simulate import simulate_runs

    config = SimConfig(
        speeds_mps=(0.2, 0.5, 0.8),
        trips=((2.0, 1),),
        repeats=3,
        modes=(),
        seed=9,
        sample_period_s=1.024e-3,
    )
    runs = [sim.run for sim in simulate_runs(config)]
    doubtful = runs[0].meta.run_id

    def segmenter(run: Run) -> Segmentation:
        seg = segment_run(run)
        return replace(seg, doubts=("a doubt",)) if run.meta.run_id == doubtful else seg

    summaries = [summarize_run(run, segmenter) for run in runs]
    left_out = diagnose_summaries(summaries)
    kept = diagnose_summaries(summaries, keep_doubtful=True)
    assert kept.n_runs == left_out.n_runs + 1 == len(runs)
    (skip,) = left_out.skipped
    assert "segmentation in doubt: a doubt" in skip.reason
    assert kept.skipped == ()
    # a run left out for a doubt is structure the model does not describe: never a silent
    # 'explained' (an intermittent fault shows up exactly so: tests/test_diagnose_field.py)
    assert left_out.unexplained
    assert any(
        f"1 of {len(runs)} motion runs were left out" in r and doubtful in r
        for r in left_out.unexplained_reasons
    )
    assert not any("were left out" in r for r in kept.unexplained_reasons)

    # too few runs left once the doubted ones are out: the one line says why, and the way
    # to use them anyway (found at field realism: 26 of 30 exponential stops were doubted)
    def doubt_most(run: Run) -> Segmentation:
        seg = segment_run(run)
        return replace(seg, doubts=("a doubt",)) if run.meta.speed_mps != 0.2 else seg

    with pytest.raises(LogError) as caught:
        diagnose_summaries([summarize_run(run, doubt_most) for run in runs])
    assert "3 usable motion run(s) at 1 speed(s); 6 more left out for segmentation doubts" in (
        str(caught.value)
    )
    assert "--keep-doubtful" in str(caught.value)
    # the CLI prints no 'skipped' lines when the batch fails: the line itself names a doubted
    # run and its doubt (it said "see each doubt in the warnings above", which were not there)
    assert "doubts (first: " in str(caught.value)
    assert "segmentation in doubt: a doubt" in str(caught.value)
    assert "warnings above" not in str(caught.value)


def test_speed_column_on_simulated_runs_with_a_noisy_speed_estimate() -> None:
    """The simulator's runs (instant stops, the Wifibot's power) with a speed column from
    their truth plus 5 mm/s of white noise, as a speed estimate (not an encoder) gives: a
    standing robot then reads noise around 0, which must not count as motion. Measured
    over this grid: every phase found, no doubt, accel and cruise starts exact (power
    refines them), motion ends 4.1 ms late (half the 9 ms edge window); pinned at 6 ms."""
    from wifibot_power.simulate import simulate_runs

    config = SimConfig(
        speeds_mps=(0.2, 0.5, 0.8),
        trips=((2.0, 1), (10.0, 10)),
        repeats=1,
        modes=(),
        seed=11,
        sample_period_s=1.024e-3,
    )
    rng = np.random.default_rng(0)
    for sim in simulate_runs(config):
        dt, speed = sim.run.sample_period_s, np.zeros(sim.run.samples)
        for p in sim.truth["phases"]:
            a, b = round(p["t_start_s"] / dt), round(p["t_end_s"] / dt)
            ramp = (np.arange(b - a) + 0.5) / (b - a)
            v = {"accel": ramp, "cruise": 1.0, "idle": 0.0}[p["phase"]]
            speed[a:b] = sim.truth["speed_mps"] * v
        run = replace(sim.run, speed_mps=speed + rng.normal(0, 0.005, speed.size))
        seg = segment_run(run)
        assert seg.doubts == ()
        truth = [(p["phase"], p["t_start_s"]) for p in sim.truth["phases"]]
        found = [(p.phase, p.t_start_s) for p in seg.phases]
        assert [n for n, _ in found] == [n for n, _ in truth]
        assert max(abs(f - t) for (_, f), (_, t) in zip(found, truth, strict=True)) <= 0.006
        # a standing robot's speed is the magnitude of its mean signed speed, ~0 here (the
        # mean of |noise| would be 0.8 x 5 mm/s = 4 mm/s); a cruise's is its speed, within
        # the ~4 ms of standing its end takes in (0.5% on the shortest, 0.85 s cruise)
        for p in seg.phases:
            if p.phase == "idle":
                assert p.speed_mps < 0.002, p
            if p.phase == "cruise":
                assert abs(p.speed_mps / sim.truth["speed_mps"] - 1) < 0.006, p


def test_a_run_standing_at_its_first_sample_that_speeds_up_at_once_does_not_start_moving():
    """REGBOT's initial-current logs: the robot stands at the log's first sample and speeds
    up at once (~4 m/s²). Averaged over 50 ms its speed read ~0.1 m/s, above the moving
    floor, and 66 of 72 sound logs were doubted as "starting moving"; the doubt now reads
    the first 9 ms (`edge_s`, as a motion's ends are found). The simulator's runs with their
    first idle cut off: the ramp from the first sample is not doubted; cut 0.1 s into the
    ramp (already at 0.4 of its speed), it is."""
    from wifibot_power.simulate import simulate_runs

    config = SimConfig(
        speeds_mps=(0.8,), trips=((4.0, 1),), repeats=1, modes=(), seed=11, sample_period_s=1e-3
    )
    (sim,) = simulate_runs(config)
    dt, speed = sim.run.sample_period_s, np.zeros(sim.run.samples)
    for p in sim.truth["phases"]:
        a, b = round(p["t_start_s"] / dt), round(p["t_end_s"] / dt)
        ramp = (np.arange(b - a) + 0.5) / (b - a)
        speed[a:b] = sim.truth["speed_mps"] * {"accel": ramp, "cruise": 1.0}.get(p["phase"], 0.0)
    accel = next(p for p in sim.truth["phases"] if p["phase"] == "accel")
    for cut_s, doubted in ((0.0, False), (0.1, True)):
        i = round((accel["t_start_s"] + cut_s) / dt)
        run = replace(
            sim.run,
            stamps_s=sim.run.time_s[i:] - sim.run.time_s[i],
            power_W=sim.run.power_W[i:],
            speed_mps=speed[i:],
        )
        seg = segment_run(run)
        assert any("starts moving" in d for d in seg.doubts) == doubted, (cut_s, seg.doubts)


def test_a_crawl_between_two_fast_stretches_is_one_motion_not_two_that_overlap() -> None:
    """An F1/10 car's log (~18 Hz, a speed that jitters by ~0.25 m/s while driving: the
    moving threshold, 5 sd of that jitter, stands far above the standstill threshold): the
    car slows to a crawl (0.25 m/s) between two fast stretches without stopping. The two
    stretches above the moving threshold were made two motions, the first of which ran on
    to the final stop: they overlapped, the second's phases were listed twice (its energy
    counted twice) and a stop was counted where there was none. Seeds 0 and 4 overlapped
    before the fix; every seed must give phases in time order, one motion."""
    dt = 0.055
    pieces = [(2.0, 0.0, 0.0), (0.5, 0.0, 2.0), (5.0, 2.0, 2.0), (0.5, 2.0, 0.25)]
    pieces += [(0.6, 0.25, 0.25), (0.5, 0.25, 2.0), (4.0, 2.0, 2.0), (0.5, 2.0, 0.0)]
    pieces += [(2.0, 0.0, 0.0)]
    plan = np.concatenate([np.linspace(a, b, round(s / dt), endpoint=False) for s, a, b in pieces])
    meta = RunMeta(run_id="crawl", mode="motion", speed_mps=2.0, steps=1, sample_period_s=dt)
    for seed in range(5):
        rng = np.random.default_rng(seed)
        speed = plan + (plan > 1.0) * rng.normal(0.0, 0.25, plan.size)
        power = np.where(plan > 0, 10.0 + 10.0 * speed, 0.0) + rng.normal(0.0, 0.2, plan.size)
        run = Run("crawl.csv", "canonical", meta, np.arange(plan.size) * dt, power, speed_mps=speed)
        phases = segment_run(run).phases
        assert all(
            b.t_start_s >= a.t_end_s - 1e-9 for a, b in zip(phases[:-1], phases[1:], strict=True)
        ), seed
        assert [p.phase for p in phases if p.phase == "idle"] == ["idle", "idle"], seed
        assert sum(p.duration_s for p in phases) == pytest.approx(plan.size * dt, abs=1e-9)
        assert not segment_run(run).doubts, seed


@pytest.mark.parametrize("dt", [0.055, 1e-4])
def test_an_idle_at_another_flat_level_is_not_doubted(dt: float) -> None:
    """With a speed column, an idle is wherever the speed reads standstill, whatever power
    it holds: electronics switched on after the first motion (5 -> 7 W) or the commanded
    speed's lag are not doubts. A doubt leaves the run out of `fit`; a "pushing" doubt for
    idles above the lowest idle's level (merged in the fifth session for the F1/10 car, whose
    motor pushes at its current limit while the speed reads 0.04 m/s) fired on both and was
    taken out in review (docs/segmentation.md)."""
    pieces = [(1.0, 0.0, 0.0), (0.5, 0.0, 2.0), (3.0, 2.0, 2.0), (0.5, 2.0, 0.0)]
    pieces += [(1.5, 0.0, 0.0), (0.5, 0.0, 2.0), (3.0, 2.0, 2.0), (0.5, 2.0, 0.0), (1.0, 0.0, 0.0)]
    speed = np.concatenate([np.linspace(a, b, round(s / dt), endpoint=False) for s, a, b in pieces])
    rng = np.random.default_rng(3)
    time_s = np.arange(speed.size) * dt
    electronics_W = np.where(time_s < 5.0, 5.0, 7.0)  # on after the first motion
    power = electronics_W + np.where(speed > 0, 1.0 + 0.5 * speed, 0.0)
    power = power + rng.normal(0.0, 0.05, speed.size)
    meta = RunMeta(run_id="levels", mode="motion", speed_mps=2.0, steps=2, sample_period_s=dt)
    seg = segment_run(Run("levels.csv", "canonical", meta, time_s, power, speed_mps=speed))
    assert [p.phase for p in seg.phases].count("idle") == 3
    assert not seg.doubts


# -- a stop the ripple hid (docs/segmentation.md, "A stop hidden by the ripple") ------------

#: the words of `_hidden_stop_doubts`' two doubts
HIDDEN_STOP = ("a stop the ripple hid?", "a stop labelled idle?")


def _low_speed_ripple_runs(level: str, ripple_W: float, stop_s: float | None, seed: int):
    """benchmarks/stops_under_ripple.py's grid cell: 0.1-0.3 m/s x (1 m, 10 m, 10 m in ten
    1 m steps) with the simulator's wheel ripple and, if given, its stop phase."""
    from wifibot_power.simulate import realism, simulate_runs

    effects = {"cruise_ripple": ripple_W} | ({"decel_phase": stop_s} if stop_s else {})
    config = SimConfig(
        speeds_mps=(0.1, 0.2, 0.3),
        trips=((1.0, 1), (10.0, 1), (10.0, 10)),
        repeats=1,
        modes=(),
        sample_period_s=1.024e-3,
        seed=seed,
        effects=effects,
        **realism(level),
    )
    return simulate_runs(config)


def _wrong_steps(sim, seg) -> tuple[list[int], list[int]]:
    """Steps whose stop phase is missed (none found, or either end more than 50 ms off the
    truth's), and steps with any phase missing, extra or more than 50 ms off."""
    truth = {(p["step"], p["phase"]): (p["t_start_s"], p["t_end_s"]) for p in sim.truth["phases"]}
    found = {(p.step, p.phase): (p.t_start_s, p.t_end_s) for p in seg.phases}
    missed, wrong = [], []
    for step in sorted({k for k, name in truth if name == "accel"}):
        for name in ("accel", "cruise", "decel"):
            t, f = truth.get((step, name)), found.get((step, name))
            off = (t is None) != (f is None) or (
                t is not None and f is not None and max(abs(t[0] - f[0]), abs(t[1] - f[1])) > 0.05
            )
            if off:
                wrong.append(step)
                if name == "decel" and t is not None:
                    missed.append(step)
    return missed, sorted(set(wrong))


#: cells of the grid where stops were missed with no doubt at all before the hidden-stop
#: doubt (measured, `stops_under_ripple.py --before 2a81759`): a 1 s stop at 0.1 m/s under
#: a 1 W ripple (taken into the cruise), a 0.3 s stop at 0.2-0.3 m/s under a 2 W ripple
#: (taken into the idle after it), and how many stops each cell misses (at least)
HIDDEN_CELLS = [
    ("field", 1.0, 1.0, 1, 1),
    ("field", 1.0, 1.0, 2, 2),
    ("field", 2.0, 0.3, 2, 3),
    ("lab", 1.0, 1.0, 1, 1),
]


@pytest.mark.parametrize(("level", "ripple_W", "stop_s", "seed", "at_least"), HIDDEN_CELLS)
def test_a_stop_the_ripple_hid_is_doubted_at_its_step(level, ripple_W, stop_s, seed, at_least):
    """Every step whose stop phase is missed under a cruise ripple at 0.1-0.3 m/s carries a
    hidden-stop doubt naming that step (its cruise ends off its own ripple, or its idle
    starts above its level), and no right run carries one. Measured on the whole grid
    (ripple 0.5-2 W, stops 0.3-1 s, lab and field, seeds 1-8, 1,296 runs): 99 runs with a
    stop missed, 16 of them with no doubt before, none now; 96 of the 99 carry this doubt
    (the other 3 are doubted otherwise); no right run carries it."""
    missed_total = 0
    for sim in _low_speed_ripple_runs(level, ripple_W, stop_s, seed):
        seg = segment_run(sim.run)
        missed, wrong = _wrong_steps(sim, seg)
        hidden = [d for d in seg.doubts if d.endswith(HIDDEN_STOP)]
        for step in missed:
            assert any(f" of step {step} " in d for d in hidden), (sim.run.meta.run_id, step)
        if not wrong:
            assert not hidden, (sim.run.meta.run_id, hidden)
        missed_total += len(missed)
    # the cell still misses its stops (else this test would show nothing)
    assert missed_total >= at_least


@pytest.mark.parametrize("seed", [1, 2])
@pytest.mark.parametrize("level", ["lab", "field"])
def test_no_hidden_stop_doubt_where_no_stop_is(level: str, seed: int) -> None:
    """The same grid with a 2 W ripple and no stop phase: no run carries a hidden-stop doubt
    (measured: none in 432 runs, seeds 1-8, 0.5-2 W; the tail's rms off the carried-on
    ripple is at most 1.5 times the fit's on right runs at 0.1-0.9 m/s, the bar is 2; an
    idle's start at most 3.8 sd above its level, the bar 6)."""
    for sim in _low_speed_ripple_runs(level, 2.0, None, seed):
        seg = segment_run(sim.run)
        hidden = [d for d in seg.doubts if d.endswith(HIDDEN_STOP)]
        assert not hidden, (sim.run.meta.run_id, hidden)


def test_ripple_continuation_carries_a_sinusoid_on_and_refuses_what_is_not_one() -> None:
    """`_ripple_continuation` on hand-made means: a line plus a sinusoid over 3.3 cycles,
    its frequency 3% off the periodogram's bins, carried on over a tail of a third within
    1% of its amplitude; under two cycles, a sinusoid below noise's bar, and one near the
    means' Nyquist frequency are refused (None)."""
    from wifibot_power.segment import _ripple_continuation

    n, fit_n = 300, 200
    x = np.arange(n, dtype=np.float64)
    rng = np.random.default_rng(5)

    def trace(cycles: float, amplitude_W: float) -> np.ndarray:
        return 25.0 + 0.002 * x + amplitude_W * np.sin(2 * np.pi * cycles * x / fit_n + 0.7)

    clean = trace(3.3, 1.0)
    carried, fit_rms_W = _ripple_continuation(clean, fit_n, 0.01)
    assert np.max(np.abs(carried - clean[fit_n:])) < 0.01
    assert fit_rms_W < 0.01
    noisy = clean + 0.05 * rng.standard_normal(n)
    carried, fit_rms_W = _ripple_continuation(noisy, fit_n, 0.05)
    assert np.sqrt(np.mean((noisy[fit_n:] - carried) ** 2)) < 1.2 * 0.05
    assert _ripple_continuation(trace(1.5, 1.0), fit_n, 0.01) is None
    assert _ripple_continuation(trace(3.3, 0.1), fit_n, 0.05) is None
    assert _ripple_continuation(trace(70.0, 1.0), fit_n, 0.01) is None
    assert _ripple_continuation(25.0 + 0.2 * rng.standard_normal(n), fit_n, 0.2) is None


def test_hidden_stop_doubts_by_hand() -> None:
    """`_motion_doubts` on hand-made 10 ms means (noise 0.05 W, idle 23.3 W, a cruise with a
    1 W ripple at 0.25 Hz): a stop inside the cruise's last second (a drop of 0.56 W, then
    a fall to idle + 0.6 W, the ripple fading) is doubted at the cruise (here, without the
    simulator's noise on the drop, the jump test sees it too), a stop of 0.3 s at idle +
    0.5 W inside the idle after it at the idle; the same trace without either is not
    doubted."""
    rng = np.random.default_rng(3)
    dt = 0.01
    t = np.arange(0, 30.0, dt)
    idle_W, cruise_W = 23.3, 23.3 + 0.6 + 1.12
    ripple = np.sin(2 * np.pi * 0.25 * t + 0.4)
    power = np.full(t.size, idle_W)
    moving = (t >= 2.0) & (t < 26.0)
    power[moving] = cruise_W + ripple[moving]
    power = power + 0.05 * rng.standard_normal(t.size)
    bounds = [  # in 1 ms blocks
        (0, 2000, "idle", 0),
        (2000, 2200, "accel", 1),
        (2200, 26000, "cruise", 1),
        (26000, 10 * t.size, "idle", 1),
    ]

    def doubts(values: np.ndarray) -> list[str]:
        run = _hand_run(np.repeat(values, 10))
        y10 = block_means(run.power_W, 10)
        return _motion_doubts(
            run, y10, 10, robust_sigma_W(y10), 1e-3, bounds, 1, MotionParams(), {1}
        )

    assert doubts(power) == []
    stopping = power.copy()
    stop = (t >= 25.0) & (t < 26.0)
    fade = 1.0 - (t[stop] - 25.0)  # the speed falling to 0
    stopping[stop] = idle_W + 0.6 + 0.56 * fade + ripple[stop] * fade
    stopping[stop] += 0.05 * rng.standard_normal(int(stop.sum()))
    (found,) = [d for d in doubts(stopping) if d.endswith(HIDDEN_STOP)]
    assert found.startswith("the cruise of step 1 ends off its own ripple")
    idling = power.copy()
    idling[(t >= 26.0) & (t < 26.3)] += 0.5
    (found,) = [d for d in doubts(idling) if d.endswith(HIDDEN_STOP)]
    assert found.startswith("the idle of step 1 stands") and found.endswith(HIDDEN_STOP[1])


def test_ripple_continuations_side_by_side_are_each_windows_own() -> None:
    """`_ripple_continuations` of windows of different lengths as padded rows: each the
    window's own `_ripple_continuation` (the same fit; the periodogram's grid differs with
    the padding, so not bit for bit: within 1% of the ripple's amplitude), and refused
    windows refused alike."""
    from wifibot_power.segment import _ripple_continuation, _ripple_continuations

    rng = np.random.default_rng(9)
    windows = []
    for n, cycles, amplitude_W in [
        (120, 3.1, 1.0),
        (256, 7.4, 0.5),
        (90, 1.2, 1.0),
        (200, 4.6, 2.0),
    ]:
        x = np.arange(n, dtype=np.float64)
        fit_n = 2 * n // 3
        values = 24.0 - 0.001 * x + amplitude_W * np.sin(2 * np.pi * cycles * x / fit_n + n)
        windows.append((values + 0.02 * rng.standard_normal(n), fit_n, 0.02))
    together = _ripple_continuations(windows)
    for window, found in zip(windows, together, strict=True):
        alone = _ripple_continuation(*window)
        assert (found is None) == (alone is None)
        if alone is not None:
            assert found[0].shape == alone[0].shape
            assert np.max(np.abs(found[0] - alone[0])) < 0.01
            assert found[1] == pytest.approx(alone[1], rel=0.05)
    assert together[2] is None  # 1.2 cycles before the tail
    assert sum(found is not None for found in together) == 3


@pytest.mark.parametrize("stop_s", [0.3, 0.6])
def test_hidden_stop_doubts_on_fieldgens_runs_only_where_the_stop_is_wrong(stop_s: float):
    """tests/fieldgen.py's robot (an independent generator: exponential stops, a wheel
    ripple with a second harmonic, which the doubt's single sinusoid does not model), 1 W
    ripple, 0.1-0.9 m/s, 2 m and 10 m: a hidden-stop doubt only on runs whose stop is more
    than 50 ms off its truth. Measured (seeds 1-3, 5 tau = 0.5, 1, 1.67 s, with and without
    the ripple, 180 runs): 150 right, none doubted so; of the 30 wrong (stops of 1.67 s
    after the ripple, longer than `max_decel_wavy_s`) 14 carry the doubt, and 2 have no
    doubt at all (6 before it)."""
    import fieldgen

    batch = fieldgen.Batch(
        trips=((2.0, 1), (10.0, 1)),
        repeats=1,
        idle_runs=0,
        effects={"decel_phase": stop_s, "cruise_ripple": 1.0},
        seed=1,
    )
    generated = fieldgen.generate(batch)
    right = 0
    for g, run in zip(generated, fieldgen.to_runs(generated), strict=True):
        v, d = g.meta["speed_mps"], g.meta["distance_m"]
        tau, t_acc = g.truth["tau_stop_s"], g.truth["t_acc_s"]
        (start_s,) = g.truth["phase_starts_s"]
        stop_start_s = start_s + t_acc + (d - v * t_acc / 2 - v * tau) / v
        seg = segment_run(run)
        decel = seg.of("decel")
        is_right = len(decel) == 1 and (
            abs(decel[0].t_start_s - stop_start_s) <= 0.05
            and abs(decel[0].t_end_s - stop_start_s - 5 * tau) <= 0.05
        )
        if is_right:
            right += 1
            assert not [x for x in seg.doubts if x.endswith(HIDDEN_STOP)], run.meta.run_id
    assert right >= 5  # the check has runs to look at


@pytest.mark.parametrize("seed", [105, 112, 114])
def test_red_noise_in_an_idle_is_not_a_stop_labelled_idle(seed: int) -> None:
    """fieldgen's null robot (1/f noise of 0.05 W, no stop phase, no ripple): its idles
    wander 0.075-0.13 W off their median for 0.35-0.53 s, over 6 sd of a mean of white
    noise that long. Found by validation the hour the doubt was merged (5 of 24 null batches
    unexplained through the runs it left out); an idle must also stand `min_excess_W` above
    its level (what the segmenter calls the drive on). These three seeds each had one."""
    import fieldgen

    runs = fieldgen.to_runs(fieldgen.generate(fieldgen.Batch(effects={}, seed=seed)))
    doubts = [d for r in runs for d in segment_run(r).doubts if d.endswith(HIDDEN_STOP)]
    assert doubts == []


def _idle_doubts(y10: np.ndarray, spans: list, ends_moving: bool = False) -> list[str]:
    """`_hidden_stop_doubts` on 10 ms means of noise sd 0.05 W, each idle at its median."""
    from wifibot_power.segment import MotionParams, _hidden_stop_doubts
    from wifibot_power.segment.common import _Means10

    levels = {k: float(np.median(y10[a:b])) for k, (a, b, n, _) in enumerate(spans) if n == "idle"}
    means = _Means10(y10, 0.05, 0.0, 0.01)
    return _hidden_stop_doubts(means, spans, levels, MotionParams(), set(), ends_moving)


def test_a_next_step_labelled_late_is_not_a_stop_labelled_idle() -> None:
    """Found in review: the idle test left out an idle's first 50 ms, not its last, so the
    next step's start labelled 40 ms late (within the 50 ms a boundary may be off) stood
    0.5 W above the idle's level: "a stop labelled idle?". Both ends are left out now."""
    rng = np.random.default_rng(1)
    y10 = np.r_[np.full(100, 5.0), np.full(200, 10.0), np.full(40, 5.0), np.full(200, 10.0)]
    y10 = np.r_[y10, np.full(100, 5.0)] + rng.normal(0.0, 0.05, 640)

    def spans(idle_end: int) -> list:
        return [(0, 100, "idle", 0), (100, 300, "cruise", 1), (300, idle_end, "idle", 1)] + [
            (idle_end, 540, "cruise", 2),
            (540, 640, "idle", 2),
        ]

    assert _idle_doubts(y10, spans(340)) == []  # the boundary where it is
    assert _idle_doubts(y10, spans(344)) == []  # 40 ms late
    # a stop labelled idle is still seen: 0.6 W for the first 0.15 s of a 0.4 s idle
    stop = y10.copy()
    stop[300:315] += 0.6
    (doubt,) = _idle_doubts(stop, spans(340))
    assert doubt.startswith("the idle of step 1 stands") and doubt.endswith("a stop labelled idle?")


def test_the_last_idle_of_a_run_that_ends_moving_is_not_a_stop_labelled_idle() -> None:
    """Found in review: a run that ends moving is doubted as such, and the "motion labelled
    idle" test passes over its last idle; the stop-labelled-idle test did not, and gave a
    second, misleading reason ("a stop labelled idle?") for motion that is not a stop."""
    rng = np.random.default_rng(2)
    y10 = np.r_[np.full(100, 5.0), np.full(200, 10.0), np.full(100, 5.0)]
    y10 = y10 + rng.normal(0.0, 0.05, 400)
    y10[300:320] += 0.6  # the last idle starts above its level
    spans = [(0, 100, "idle", 0), (100, 300, "cruise", 1), (300, 400, "idle", 1)]
    assert _idle_doubts(y10, spans)  # looked at when the run ends standing
    assert _idle_doubts(y10, spans, ends_moving=True) == []
