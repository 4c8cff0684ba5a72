"""The five reproductions of issue 11: a name must be earned, held-out figures never blow up,
unbalanced designs say what is missing, and the human output never contradicts itself.

Data: `simulate_runs` on test_diagnose's grid, with runs changed after the fact in ways no
cause of causes.md takes (the offcat branch builds a fuller, independent generator).
"""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from test_diagnose import GRID  # noqa: E402  (the grid every diagnose test runs on)

from wifibot_power.diagnose import (
    NOT_NAMED,
    Batch,
    Selection,
    assign_folds,
    diagnose_runs,
    heldout_energy_J,
    motion_runs,
    select_causes,
    summarize_run,
    summary_table,
)
from wifibot_power.diagnose.extended import NotEstimable
from wifibot_power.errors import LogError
from wifibot_power.simulate import SimConfig, simulate_runs

IDLE_W = 23.3  # the simulated robot's idle power


def _moving(sim) -> np.ndarray:
    run = sim.run
    dt = run.sample_period_s
    moving = np.zeros(run.samples, dtype=bool)
    for phase in sim.truth["phases"]:
        if phase["phase"] != "idle":
            moving[round(phase["t_start_s"] / dt) : round(phase["t_end_s"] / dt)] = True
    return moving


def _changed(sims, change) -> list:
    """Each motion run's power with `change(sim, moving)` [W] added to its moving samples."""
    runs = []
    for sim in sims:
        run = sim.run
        if run.meta.mode == "motion":
            moving = _moving(sim)
            run = replace(run, power_W=run.power_W + change(sim, moving) * moving)
        runs.append(run)
    return runs


def _candidate(result, cause: str) -> dict:
    return next(c for c in result.summary()["candidates"] if c["cause"] == cause)


def test_a_jump_between_runs_is_not_named_thermal_drift():
    """Motion power above idle 4% higher from the middle of the session on, with no creep
    inside any run: a change of conditions, not warming windings."""
    sims = simulate_runs(SimConfig(**GRID, seed=101))
    order = {s.truth["run_id"]: s.truth["session_order"] for s in sims}
    middle = np.median(list(order.values()))

    def jump(sim, moving):
        late = order[sim.truth["run_id"]] > middle
        return 0.04 * (sim.run.power_W - IDLE_W) if late else 0.0

    result = diagnose_runs(_changed(sims, jump))
    assert "thermal_drift" not in [f.cause for f in result.findings]
    assert result.findings == ()
    assert result.unexplained
    thermal = _candidate(result, "thermal_drift")
    assert thermal["significant"]  # its signature is there: the trap the issue fell into
    failed = {c["check"] for c in thermal["checks"] if not c["passed"]}
    assert "smooth in motor-on time, not a jump between runs" in failed
    assert "the same creep within runs" in failed
    # and the report says what it would have explained and which check failed
    (rejected,) = [r for r in result.rejected if r["cause"] == "thermal_drift"]
    assert "smooth in motor-on time" in rejected["reason"]
    assert any(r.startswith("thermal_drift:") for r in result.unexplained_reasons)


def test_extra_power_at_the_lowest_speed_only_is_not_named_speed_quadratic():
    """1 W more while moving at 0.2 m/s only: not a parabola in speed."""
    sims = simulate_runs(SimConfig(**GRID, seed=102))
    result = diagnose_runs(
        _changed(sims, lambda sim, moving: 1.0 if sim.run.meta.speed_mps == 0.2 else 0.0)
    )
    assert "speed_quadratic" not in [f.cause for f in result.findings]
    assert result.unexplained
    quad = _candidate(result, "speed_quadratic")
    assert quad["significant"]
    failed = {c["check"] for c in quad["checks"] if not c["passed"]}
    assert "no structure left across speed levels" in failed


def test_a_candidate_the_training_folds_cannot_identify_is_not_estimable():
    """The reproduction's "gains -24214089.4% held out": a fold whose training runs hold a
    stopping phase in fewer than 2 runs cannot estimate t_dec; it is "not estimable", never
    a number."""
    sims = simulate_runs(SimConfig(**GRID, effects={"decel_phase": 0.4}, seed=103))
    frame = summary_table([summarize_run(s.run) for s in sims])
    frame = frame[frame["usable"]]
    motion = motion_runs(frame)
    keep = motion["run_id"].iloc[:2].tolist()  # the segmenter "found" a stop in 2 runs only
    hidden = ~frame["run_id"].isin(keep) & (frame["mode"] == "motion")
    frame.loc[hidden, "decel_duration_s"] = 0.0
    motion = motion_runs(frame)
    folds = assign_folds(motion["run_id"])
    with pytest.raises(NotEstimable, match="stopping phase was found in"):
        heldout_energy_J(frame, motion, folds, ["decel_phase"], strict=True)
    measured = motion["motion_energy_J"].to_numpy(np.float64)
    baseline = float(np.sqrt(np.mean((heldout_energy_J(frame, motion, folds, []) - measured) ** 2)))
    seen = select_causes(Batch(frame, motion, folds), baseline)
    assert isinstance(seen, Selection) and "decel_phase" not in seen.selected
    assert seen.gains["decel_phase"] is None
    (note,) = [n for n in seen.notes if n.text.startswith("decel_phase")]
    assert note.kind == NOT_NAMED
    assert "not estimable" in note.text and "%" not in note.text
    assert all(np.isnan(r) or r < 10 * baseline for r in seen.rmse_of.values())


def test_the_human_output_never_says_explained_when_unexplained(monkeypatch):
    from rich.console import Console

    from wifibot_power.cli import diagnose_cmd

    sims = simulate_runs(SimConfig(**GRID, seed=104))
    result = diagnose_runs(
        _changed(sims, lambda sim, moving: 1.0 if sim.run.meta.speed_mps == 0.2 else 0.0)
    )
    assert result.unexplained and result.findings == ()
    assert result.verdict == "unexplained"  # decided by the library; the CLI renders it
    assert result.report().startswith("[[Diagnosis]] no catalogue cause explains")
    console = Console(width=200, record=True)
    monkeypatch.setattr(diagnose_cmd, "stdout", console)  # _findings prints the table
    diagnose_cmd._findings(result)
    text = console.export_text()
    assert "explains these runs" not in text
    assert "no catalogue cause explains" in text
    # too few repeats and nothing else: "cannot tell", not "nothing left" (the review)
    once = diagnose_runs([s.run for s in simulate_runs(SimConfig(**{**GRID, "repeats": 1}))])
    assert once.verdict == "cannot_tell"
    console = Console(width=200, record=True)
    monkeypatch.setattr(diagnose_cmd, "stdout", console)
    diagnose_cmd._findings(once)
    text = console.export_text()
    assert "cannot tell: too few repeated runs to judge" in text
    assert "explains these runs" not in text and "explains what is left" not in text


def _unbalanced(runs_at_fast: int) -> list:
    slow = SimConfig(**{**GRID, "speeds_mps": (0.3,)}, seed=105)  # 6 runs at 0.3 m/s
    fast = SimConfig(**{**GRID, "speeds_mps": (0.6,), "trips": ((2.0, 1), (5.0, 1))}, seed=106)
    fast_runs = [s.run for s in simulate_runs(fast) if s.run.meta.mode == "motion"]
    return [s.run for s in simulate_runs(slow)] + fast_runs[:runs_at_fast]


def test_an_unbalanced_design_says_in_one_line_what_is_missing():
    """6 runs at 0.3 m/s and 1 at 0.6 m/s pass the "6 runs, 2 speeds" rule, but the run at
    0.6 m/s cannot be predicted held out: said in one line, never 'give --t-acc'."""
    with pytest.raises(LogError) as caught:
        diagnose_runs(_unbalanced(1))
    message = str(caught.value)
    assert "--t-acc" not in message and "nan" not in message
    assert "6 at 0.3 m/s, 1 at 0.6 m/s" in message
    assert "\n" not in message


def test_two_runs_at_the_second_speed_diagnose():
    result = diagnose_runs(_unbalanced(2))
    assert result.n_runs == 8
    assert np.isfinite(result.baseline_rmse_J) and np.isfinite(result.extended_rmse_J)


def test_a_periodic_signal_whose_frequency_does_not_follow_speed_is_not_named():
    """A 1 W, 4 Hz oscillation while moving at every speed (a fan, not a wheel): its
    spectral peak is there in every cruise, but f ∝ v fails."""
    sims = simulate_runs(SimConfig(**GRID, seed=107))

    def hum(sim, moving):
        return 1.0 * np.sin(2 * np.pi * 4.0 * sim.run.time_s)

    result = diagnose_runs(_changed(sims, hum))
    assert "cruise_ripple" not in [f.cause for f in result.findings]
    assert result.unexplained
    ripple = _candidate(result, "cruise_ripple")
    failed = {c["check"] for c in ripple["checks"] if not c["passed"]}
    assert "frequency scales with speed (f ∝ v) across runs" in failed


def test_payload_that_also_raises_cruise_power_is_not_named_accel_inertial():
    """Acceleration power rises with payload (the robot's real kI), but so does cruise power
    (0.5 W per kg: e.g. tyres deflecting under load): 'only acceleration is affected' fails."""
    sims = simulate_runs(SimConfig(**GRID, payloads_kg=(0.0, 3.0), seed=108))
    result = diagnose_runs(_changed(sims, lambda sim, moving: 0.5 * sim.run.meta.payload_kg))
    assert "accel_inertial" not in [f.cause for f in result.findings]
    assert result.unexplained
    inertial = _candidate(result, "accel_inertial")
    failed = {c["check"] for c in inertial["checks"] if not c["passed"]}
    assert "only acceleration is affected; cruise does not depend on payload" in failed


def test_the_configuration_table_counts_runs_as_integers(monkeypatch):
    """pandas' iterrows made the per-configuration run count a float ('3.0')."""
    from rich.console import Console

    from wifibot_power.cli import diagnose_cmd

    result = diagnose_runs([s.run for s in simulate_runs(SimConfig(**GRID, seed=107))])
    console = Console(width=200, record=True)
    monkeypatch.setattr(diagnose_cmd, "stdout", console)
    diagnose_cmd._by_configuration(result)
    rows = [line.split("│") for line in console.export_text().splitlines() if "│" in line]
    counts = {cells[5].strip() for cells in rows[1:]}  # the 'runs' column
    assert counts and all(c.isdigit() for c in counts), counts


def _check(finding_or_candidate, name: str):
    checks = finding_or_candidate["checks"]
    return next(c for c in checks if c["check"] == name)


def test_a_smooth_session_drift_with_no_creep_inside_long_enough_runs_is_not_thermal_drift():
    """Motion power above idle grows 1.5% per minute of motor-on time *between* runs, smooth
    in the session, but stays flat inside each run (a run-level effect that follows the
    session clock, not warming windings). At the lab's noise these runs are long enough to
    see that creep within themselves, so its absence counts: the creep check is tested and
    fails, and nothing is named (measured at seeds 103-105: within runs -0.06 to -0.21 %/min
    ± 0.12, 12-14 standard errors from α)."""
    sims = simulate_runs(SimConfig(**GRID, seed=103))

    def stepwise(sim, moving):
        return 0.015 * sim.truth["motor_on_before_run_min"] * (sim.run.power_W - IDLE_W)

    result = diagnose_runs(_changed(sims, stepwise)).summary()
    assert [f["cause"] for f in result["findings"]] == []
    assert result["unexplained"]
    thermal = _candidate_summary(result, "thermal_drift")
    assert thermal["significant"]
    assert _check(thermal, "smooth in motor-on time, not a jump between runs")["passed"]
    creep = _check(thermal, "the same creep within runs")
    assert not creep["passed"]
    assert not creep["detail"].startswith("not testable")


def _candidate_summary(summary: dict, cause: str) -> dict:
    return next(c for c in summary["candidates"] if c["cause"] == cause)


def test_thermal_drift_at_field_realism_is_named_only_where_its_creep_is_seen():
    """simulate --realism field on the test grid (validate_diagnose's seeds 1 and 4). α =
    0.0172/min: the creep within runs is seen (measured p = 8e-6) and named, the truth
    inside its interval. α = 0.0070/min: the 2-25 s cruises cannot show 0.7 %/min within
    themselves (2.7 standard errors of the 4.7 a 0.9-power test needs), so the name is not
    earned: unexplained, with the check "not testable here" and how much longer (or more)
    cruises would test it."""
    from wifibot_power.simulate import realism

    def diagnosed(alpha: float, seed: int):
        effects = {"thermal_drift": alpha}
        config = SimConfig(**{**GRID, **realism("field")}, effects=effects, seed=seed)
        return diagnose_runs([s.run for s in simulate_runs(config)])

    alpha = 0.01720273849619655  # validate_diagnose.size("thermal_drift", 1)
    seen = diagnosed(alpha, 1)
    assert [f.cause for f in seen.findings] == ["thermal_drift"]
    assert not seen.unexplained
    (finding,) = seen.findings
    assert all(c.passed for c in finding.checks)
    low, high = finding.estimate["ci95"]
    assert low < alpha < high

    short = diagnosed(0.007018942885969171, 4)  # validate_diagnose.size("thermal_drift", 4)
    assert short.findings == ()
    assert short.unexplained
    (rejected,) = [r for r in short.rejected if r["cause"] == "thermal_drift"]
    assert rejected["failed"] == ["the same creep within runs"]
    assert "not testable here: the runs are too short" in rejected["reason"]
    assert "x as long" in rejected["reason"]
    # the same α and seed with 10 m runs in place of 5 m (cruises of 11-50 s, validate_
    # diagnose's simfield grid): the creep is seen within them, every check passes; its own
    # held-out gain (20.9%) has a 95% interval that reaches zero ([-16, 47]%, issue 27), so
    # the name is not earned on these 30 runs: rejected for that alone
    trips = {"trips": ((2.0, 1), (10.0, 1), (4.0, 4))}
    config = SimConfig(
        **{**GRID, **realism("field"), **trips},
        effects={"thermal_drift": 0.007018942885969171},
        seed=4,
    )
    long = diagnose_runs([s.run for s in simulate_runs(config)])
    assert all(c.passed for c in long.candidate_checks["thermal_drift"])
    (e,) = [e for e in long.evidence if e.cause == "thermal_drift"]
    assert e.ci95[0] < 0.007018942885969171 < e.ci95[1]
    if long.findings:  # named: only with a gain interval above zero
        assert [f.cause for f in long.findings] == ["thermal_drift"]
        assert long.findings[0].gain_ci95[0] > 0
    else:
        (rejected,) = [r for r in long.rejected if r["cause"] == "thermal_drift"]
        assert rejected["failed"] == ["gain interval above zero"]
        assert rejected["gain_ci95"][0] <= 0 < rejected["gain_pct"]


@pytest.mark.parametrize("kind", ["smooth between runs, flat within", "2% step"])
def test_a_session_effect_that_is_not_warming_is_not_thermal_drift_at_field_realism(kind):
    """Two session effects that are not warming, at field realism on the short test grid
    (seed 101, where the review found both named thermal_drift while a creep the runs
    cannot show was let pass): motion power above idle up 0.7 % per motor-on minute
    before the run but flat inside it, and up 2 % from the session's middle on (the jump
    check misses a step this small: p = 0.009 over 27 splits). Neither may be named."""
    from wifibot_power.simulate import realism

    sims = simulate_runs(SimConfig(**{**GRID, **realism("field")}, seed=101))
    order = {s.truth["run_id"]: s.truth["session_order"] for s in sims}
    middle = np.median(list(order.values()))

    def change(sim, moving):
        above_W = sim.run.power_W - IDLE_W
        if kind == "2% step":
            return 0.02 * above_W if order[sim.truth["run_id"]] > middle else 0.0
        return 0.007 * sim.truth["motor_on_before_run_min"] * above_W

    result = diagnose_runs(_changed(sims, change))
    assert result.findings == ()
    assert result.unexplained
    thermal = _candidate(result, "thermal_drift")
    assert thermal["significant"]  # the trend between runs is there; the name is not earned
    creep = next(c for c in thermal["checks"] if c["check"] == "the same creep within runs")
    assert not creep["passed"]


def test_the_human_output_says_which_check_could_not_be_tested(tmp_path, wbpower):
    """The human output of a batch whose thermal drift could not be confirmed: unexplained,
    naming the check that the runs are too short to test, and not the paper's model
    explaining the runs."""
    logs = tmp_path / "logs"
    simulated = wbpower(
        "simulate", "-o", str(logs), "--realism", "field", "--effect", "thermal_drift=0.007",
        "--seed", "4", "--speeds", "0.2,0.4,0.6,0.8,0.9", "--trips", "2x1,5x1,4x4",
        "--repeats", "2", "--mode-repeats", "1", "--sample-period", "0.001024",
    )  # fmt: skip
    assert simulated.exit_code == 0, simulated.output
    result = wbpower("diagnose", str(logs))
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    assert "unexplained: thermal_drift:" in text
    assert "'the same creep within runs' fails: not testable here" in text
    assert "thermal_drift: checks passed" not in text


def test_motion_runs_without_a_distance_say_so_in_the_one_line():
    """Real logs (two REGBOT sets) carry a speed but no distance: every motion run is
    unusable, and the error said only "0 usable motion run(s) at 0 speed(s)". It now says
    what left them out and how many, naming the metadata to add."""
    sims = simulate_runs(SimConfig(**GRID, seed=5))
    runs = [
        replace(s.run, meta=replace(s.run.meta, distance_m=None))
        if s.run.meta.mode == "motion"
        else s.run
        for s in sims
    ]
    n_motion = sum(run.meta.mode == "motion" for run in runs)
    with pytest.raises(LogError) as caught:
        diagnose_runs(runs)
    message = str(caught.value)
    assert message.startswith("0 usable motion run(s) at 0 speed(s); left out: ")
    assert f"{n_motion} x motion run without a distance (set distance_m" in message
    assert "\n" not in message


def test_steps_without_a_cruise_are_summarised_not_an_internal_error():
    """A speed column can split a run into accelerations and stops with no cruise (REGBOT's
    voltage steps: accel, decel, accel, decel). `trace_stats` paired each step with the next
    one's start by a strict zip that raised on a run with no step holding both (an internal
    error on 60 of 75 real logs, hidden behind the batch's "0 usable" line); such a run has no
    accel-and-cruise step to take windows of (`traces.step_windows`, whose windows the start
    transient's and the stopping phase's statistics are taken over)."""
    from test_runtable import build

    from wifibot_power.causes import RunView, run_statistics
    from wifibot_power.runtable import WindowEnergy

    def trace_stats(run, segmentation):
        view = RunView(run, segmentation, WindowEnergy(run))
        stats, _ = run_statistics(view)
        return SimpleNamespace(steps=len(view.steps), **stats)

    ramp = np.linspace(30.0, 40.0, 30)
    pieces = [
        ("idle", 0, np.full(50, 20.0)),
        ("accel", 1, ramp),
        ("decel", 1, np.full(10, 25.0)),
        ("accel", 1, ramp),
        ("decel", 1, np.full(10, 25.0)),
        ("idle", 1, np.full(50, 20.0)),
    ]
    run, segmentation = build(pieces, steps=1)
    stats = trace_stats(run, segmentation)
    assert stats.steps == 0 and stats.start_measured_J == 0.0
    # a step with a cruise after one without: only that step's windows, and its stop window
    # runs to the end of the run
    with_cruise = pieces[:3] + [
        ("accel", 2, ramp),
        ("cruise", 2, np.full(40, 30.0)),
        ("idle", 2, np.full(50, 20.0)),
    ]
    run, segmentation = build(with_cruise, steps=2)
    stats = trace_stats(run, segmentation)
    assert stats.steps == 1
    assert stats.end_s == pytest.approx(50 * run.sample_period_s)  # the idle after it, whole
    # a step with a cruise before one without (the review's order): its stop window ends
    # where the next step starts moving (30 idle samples), not 1 s on, through that step's
    # acceleration and stop (2.5 J of "end window excess" per step that was not there)
    cruise_first = [
        ("idle", 0, np.full(50, 20.0)),
        ("accel", 1, ramp),
        ("cruise", 1, np.full(40, 30.0)),
        ("idle", 1, np.full(30, 20.0)),
        ("accel", 2, ramp),
        ("decel", 2, np.full(10, 25.0)),
        ("idle", 2, np.full(150, 20.0)),
    ]
    run, segmentation = build(cruise_first, steps=2)
    stats = trace_stats(run, segmentation)
    assert stats.steps == 1
    assert stats.end_s == pytest.approx(30 * run.sample_period_s)
    assert stats.end_measured_J == pytest.approx(30 * 20.0 * run.sample_period_s)


def test_without_repeated_runs_nothing_left_is_not_claimed():
    """Structure is judged against the runs' own spread, which only repeated runs of a
    configuration measure (causes.md, "Unexplained"). Real REGBOT logs (15 runs, each at
    its own measured speed and distance, held-out MAPE 27%) came out "the paper's model
    explains these runs". Without repeats, even the null robot's batch now says that the
    spread is unknown, and nothing is named; with them it is not unexplained (seed 11's
    null batch, as in test_diagnose)."""
    once = diagnose_runs([s.run for s in simulate_runs(SimConfig(**{**GRID, "repeats": 1}))])
    assert once.verdict == "cannot_tell"
    assert once.findings == ()
    assert once.unexplained
    (reason,) = once.unexplained_reasons
    n = once.n_runs
    assert reason.startswith(f"the runs' own spread is unknown: {n} runs in {n} configurations")
    twice = diagnose_runs([s.run for s in simulate_runs(SimConfig(**GRID, seed=11))])
    assert not twice.unexplained, twice.unexplained_reasons


def test_runs_without_a_cruise_phase_are_one_line_not_rmse_nan():
    """REGBOT's initial-current logs speed up and stop with no cruise between: the
    paper's P_v(v) cannot be fitted, every held-out prediction was NaN, and diagnose
    printed "RMSE nan J, MAPE nan%. Gain 0.0%" and exited 0. Now a one-line error says
    which line and why."""
    from wifibot_power.segment import segment_run

    def no_cruise(run):
        seg = segment_run(run)
        phases = tuple(replace(p, phase="accel") if p.phase == "cruise" else p for p in seg.phases)
        return replace(seg, phases=phases)

    runs = [s.run for s in simulate_runs(SimConfig(**GRID, seed=5))]
    with pytest.raises(LogError) as caught:
        diagnose_runs(runs, segmenter=no_cruise)
    message = str(caught.value)
    assert message.startswith("the paper's model cannot be fitted to these runs: P_v(v)")
    assert "(0 of " in message and "\n" not in message


def test_runs_with_a_speed_column_repeat_their_commanded_configuration():
    """With a speed column a run's speed is its measured cruise speed, which differs run to
    run (here the simulator's truth plus 5 mm/s of noise, as a speed estimate gives), so
    no configuration repeated and the null came out "the runs' own spread is unknown".
    Runs of one commanded speed (the metadata's `speed_mps`, log-format.md) share a
    configuration: the null batch is neither named nor unexplained."""
    rng = np.random.default_rng(0)
    runs = []
    for sim in simulate_runs(SimConfig(**GRID, seed=11)):
        run, dt = sim.run, sim.run.sample_period_s
        speed = np.zeros(run.samples)
        for p in sim.truth.get("phases", []):
            a, b = round(p["t_start_s"] / dt), round(p["t_end_s"] / dt)
            ramp = (np.arange(b - a) + 0.5) / max(b - a, 1)
            level = {"accel": ramp, "cruise": 1.0}.get(p["phase"], 0.0)
            speed[a:b] = (sim.truth.get("speed_mps") or 0.0) * level
        runs.append(replace(run, speed_mps=speed + rng.normal(0, 0.005, speed.size)))
    result = diagnose_runs(runs)
    measured = result.runs["speed_mps"].round(6)
    assert measured.nunique() == len(measured)  # no two runs measure the same speed
    assert result.findings == ()
    assert not result.unexplained, result.unexplained_reasons


def _paper_grid_field(seed: int, effects: dict[str, float] | None = None) -> SimConfig:
    """The reference study's grid (9 speeds x (2 m, 10 m, 10 m in 10 steps) x 3 repeats, 81
    motion runs, `simulate`'s default) at `simulate --realism field`: validate_diagnose's
    `simfield-paper` suite."""
    from wifibot_power.simulate import PAPER_SPEEDS_MPS, PAPER_TRIPS, realism

    grid = {**GRID, **realism("field"), "speeds_mps": PAPER_SPEEDS_MPS, "trips": PAPER_TRIPS}
    return SimConfig(**{**grid, "repeats": 3}, effects=effects or {}, seed=seed)


def test_thermal_drift_on_the_paper_grid_at_field_realism_gains_what_its_size_allows():
    """Issue 11's ">= 30% held out" for thermal drift: on the tests' 30 runs the runs' idle
    spread caps any model's gain at 19-30% for the smaller α (validate_diagnose simfield);
    on the study's own 81-run session the drift builds up beyond it. Seed 6 (α = 0.0045/min)
    is the lowest of seeds 1-8 there: measured gain 49.7% (most any model could gain:
    53.9%), estimate 0.3% off. Asserted: named alone, explained, the truth in its interval
    and within 3%, gain >= 45% (4.7 points below the measured, for numeric drift)."""
    alpha = 0.004544390616952501  # validate_diagnose.size("thermal_drift", 6)
    sims = simulate_runs(_paper_grid_field(6, {"thermal_drift": alpha}))
    result = diagnose_runs([s.run for s in sims])
    assert [f.cause for f in result.findings] == ["thermal_drift"]
    assert not result.unexplained, result.unexplained_reasons
    (finding,) = result.findings
    low, high = finding.estimate["ci95"]
    assert low < alpha < high
    assert finding.estimate["value"] == pytest.approx(alpha, rel=0.03)
    assert finding.gain_pct >= 45.0


def test_a_low_speed_extra_on_the_paper_grid_at_field_realism_is_not_speed_quadratic():
    """The review's case (0.4 W more at the lowest speed only, named speed_quadratic
    on the tests' 30 runs) on the study's 81 runs: the lack of fit the v² term leaves is
    seen (measured p = 6e-8, 3e-9 and 0.002 in acceleration at seeds 3-5), the check fails
    and nothing is named. Seed 5, the weakest."""
    sims = simulate_runs(_paper_grid_field(5))
    result = diagnose_runs(
        _changed(sims, lambda sim, moving: 0.4 if sim.run.meta.speed_mps == 0.1 else 0.0)
    )
    assert result.findings == ()
    assert result.unexplained
    quad = _candidate(result, "speed_quadratic")
    assert quad["significant"]
    failed = {c["check"] for c in quad["checks"] if not c["passed"]}
    assert "no structure left across speed levels" in failed


def test_start_transient_on_the_paper_grid_holds_the_truth_in_its_interval():
    """Found this session, on the study's grid in the lab (0.3 W noise, seed 2, E_start =
    4.16 J): named, but estimated 3.56 J with a 95% interval of 3.53-3.59 J. The design
    spread the lump over the acceleration phase (E / t_acc), right only when the
    acceleration outlasts the transient; at 0.1 m/s it lasts 0.1 s against the simulator's
    0.2 s pulse (τ = 50 ms), and those runs weigh most in that column. Now such runs'
    acceleration row is their acceleration and cruise together (causes/design.py): 4.158 J
    (4.160 J without the 0.1 m/s runs), the truth inside a ±0.006 J interval. Asserted: the
    truth in the interval and the estimate within 0.5%."""
    from wifibot_power.simulate import PAPER_SPEEDS_MPS, PAPER_TRIPS

    E = 4.156534748032614  # validate_diagnose.size("start_transient", 2)
    grid = {**GRID, "speeds_mps": PAPER_SPEEDS_MPS, "trips": PAPER_TRIPS, "repeats": 3}
    config = SimConfig(**grid, noise_W=0.3, effects={"start_transient": E}, seed=2)
    result = diagnose_runs([s.run for s in simulate_runs(config)])
    (finding,) = [f for f in result.findings if f.cause == "start_transient"]
    low, high = finding.estimate["ci95"]
    assert low < E < high
    assert finding.estimate["value"] == pytest.approx(E, rel=0.005)
