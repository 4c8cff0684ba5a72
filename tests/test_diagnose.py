"""diagnose finds an effect hidden in simulated data, and only that one.

Data come from `simulate` with one cause of causes.md at a size drawn from its realistic
range; diagnose sees only the runs (their samples and metadata), never the truth, which
is used here only to score. Grid: 5 speeds x (2 m, 5 m, 4 m in 4 steps) x 2 repeats = 30
motion runs at 1.024 ms (the analyser's 0.1024 ms samples averaged by ten).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from wifibot_power.diagnose import diagnose_runs
from wifibot_power.simulate import EFFECTS, SimConfig, simulate_runs

GRID = dict(
    speeds_mps=(0.2, 0.4, 0.6, 0.8, 0.9),
    trips=((2.0, 1), (5.0, 1), (4.0, 4)),
    repeats=2,
    mode_repeats=1,
    mode_duration_s=2.0,
    sample_period_s=0.001024,
)
WHEEL_HZ_PER_MPS = 1 / (np.pi * 0.13)  # the simulated wheel: f = v / (pi d), d = 0.13 m


def _size(cause: str, seed: int) -> float:
    low, high = EFFECTS[cause][2]
    return float(np.random.default_rng([seed, 99]).uniform(low, high))


def _diagnose(effects: dict[str, float], seed: int, reference=None, **grid):
    config = SimConfig(**{**GRID, **grid}, effects=effects, seed=seed)
    sims = simulate_runs(config)
    return diagnose_runs([s.run for s in sims], reference=reference), sims


@pytest.mark.parametrize("seed", [11, 12])
def test_null_robot_yields_no_finding(seed):
    result, _ = _diagnose({}, seed)
    assert result.findings == ()
    assert not result.unexplained, result.unexplained_reasons
    # the paper-form model already predicts these runs: held-out error well under 0.1%
    assert result.baseline_mape_pct < 0.1


ENERGY_CAUSES = [
    "speed_quadratic",
    "start_transient",
    "decel_phase",
    "thermal_drift",
    "accel_inertial",
]


@pytest.mark.parametrize("seed", [21, 22])
@pytest.mark.parametrize("cause", ENERGY_CAUSES)
def test_each_energy_cause_is_named_alone_with_a_large_heldout_gain(cause, seed):
    size = _size(cause, seed)
    grid = {"payloads_kg": (0.0, 3.0)} if cause == "accel_inertial" else {}
    result, _ = _diagnose({cause: size}, seed, **grid)
    assert [f.cause for f in result.findings] == [cause]
    (finding,) = result.findings
    assert finding.metric == "run_energy"
    # issue 5 asks >= 30%; docs/diagnose.md measured >= 90% over 8 seeds: 80% leaves room
    assert finding.gain_pct >= 80.0
    assert result.gain_pct >= 80.0
    assert finding.p_value < 1e-3
    # the estimate recovers the hidden size. Measured (docs/diagnose.md, 8 seeds each): at
    # most 0.1% off for every cause but thermal drift, so 1% (10x slack) catches a 4% bias;
    # thermal drift, whose drift over a 30-run session is a few %, up to 5.2% (7.5% at other
    # seeds): 10%. Its estimator's own exactness is pinned in test_causes.py.
    tolerance = 0.1 if cause == "thermal_drift" else 0.01
    assert finding.estimate["value"] == pytest.approx(size, rel=tolerance)
    # and it is the value the extended model (model.json) carries
    extension = result.extended_model.extensions[cause]
    assert extension[finding.estimate["parameter"]] == pytest.approx(finding.estimate["value"])
    assert not result.unexplained, result.unexplained_reasons


@pytest.mark.parametrize("seed", [31, 32])
def test_cruise_ripple_is_named_with_a_frequency_that_scales_with_speed(seed):
    size = _size("cruise_ripple", seed)
    result, _ = _diagnose({"cruise_ripple": size}, seed)
    assert [f.cause for f in result.findings] == ["cruise_ripple"]
    (finding,) = result.findings
    assert finding.metric == "power_trace"
    assert finding.gain_pct >= 50.0  # docs: >= 74% measured, even with a 5x noisier analyser
    assert finding.estimate["value"] == pytest.approx(size, rel=0.05)
    # f = k v: k is the wheel's 1/(pi d), within its interval and 2%
    low, high = finding.estimate["hz_per_mps_ci95_low"], finding.estimate["hz_per_mps_ci95_high"]
    assert finding.estimate["hz_per_mps"] == pytest.approx(WHEEL_HZ_PER_MPS, rel=0.02)
    assert low <= WHEEL_HZ_PER_MPS <= high
    assert finding.estimate["r2"] > 0.99
    # a zero-mean ripple changes no run's energy: no energy gain is claimed for it, and the
    # extended model predicts energy as the refitted paper form does (diagnose relies on it to
    # key held-out errors by energy causes only)
    assert abs(result.gain_pct) < 5.0
    assert result.extended_fixed_rmse_J == result.baseline_rmse_J


@pytest.mark.parametrize(
    "pair",
    [
        ("start_transient", "decel_phase"),  # same energy signature, told apart by location
        ("speed_quadratic", "thermal_drift"),
    ],
)
def test_a_pair_of_effects_yields_both(pair):
    seed = 41
    sizes = {c: _size(c, seed) for c in pair}
    result, _ = _diagnose(sizes, seed)
    assert sorted(f.cause for f in result.findings) == sorted(pair)
    assert result.gain_pct >= 80.0
    for finding in result.findings:
        # each estimate is made with the other cause in the model, as model.json holds it
        # pairs: measured up to 6.1% for thermal drift beside another cause (docs), the others
        # within 0.5%: 10% and 2%
        tolerance = 0.1 if finding.cause == "thermal_drift" else 0.02
        assert finding.estimate["value"] == pytest.approx(sizes[finding.cause], rel=tolerance)
        extension = result.extended_model.extensions[finding.cause]
        assert extension[finding.estimate["parameter"]] == pytest.approx(finding.estimate["value"])


def test_structure_no_cause_explains_is_reported_as_unexplained():
    """Battery sag within each run (power rising 0.2 W per second of motion, reset between
    runs) is in no catalogue: diagnose must say unexplained rather than force a name."""
    config = SimConfig(**GRID, seed=3)
    runs = []
    for sim in simulate_runs(config):
        run = sim.run
        if run.meta.mode == "motion":
            dt = run.sample_period_s
            moving = np.zeros(run.samples, dtype=bool)
            for phase in sim.truth["phases"]:
                if phase["phase"] != "idle":
                    moving[round(phase["t_start_s"] / dt) : round(phase["t_end_s"] / dt)] = True
            run = replace(run, power_W=run.power_W + 0.2 * np.cumsum(moving) * dt * moving)
        runs.append(run)
    result = diagnose_runs(runs)
    assert result.unexplained
    assert result.findings == ()


def test_extended_model_carries_the_named_term_for_energy_and_lifetime():
    from wifibot_power.energy import trip_energy

    result, _ = _diagnose({"decel_phase": 0.5}, 51)
    extension = result.extended_model.extensions["decel_phase"]
    assert extension["t_dec_s"] == pytest.approx(0.5, rel=0.1)
    # a 1 m step at 0.5 m/s now costs the stopping phase the paper's model leaves out
    with_stop = trip_energy(result.extended_model, 0.5, 1.0, 1).energy_J
    without = trip_energy(result.baseline_model, 0.5, 1.0, 1).energy_J
    # by hand: P_dec(0.5) = 23.9 + 0.5 * 11.2 * 0.5 / 2 = 25.3 W for 0.5 s, and the stop covers
    # 0.5 * 0.5 / 2 m that the cruise no longer does: - (23.9 + 11.2 * 0.5) * 0.25 s
    assert with_stop - without == pytest.approx(25.3 * 0.5 - 29.5 * 0.25, rel=0.1)


def test_a_ripple_too_small_to_name_is_a_note_not_unexplained():
    """0.1 W is below the 0.2 W worth naming: it scales with speed, so it is explained
    structure, just small; a note says so."""
    result, _ = _diagnose({"cruise_ripple": 0.1}, 61)
    assert result.findings == ()
    assert not result.unexplained, result.unexplained_reasons
    assert any(n.text.startswith("cruise_ripple") for n in result.notes)


def _moving(sim) -> np.ndarray:
    """The samples of a simulated run's true motion phases."""
    dt_s, mask = sim.run.sample_period_s, np.zeros(sim.run.power_W.size, dtype=bool)
    for phase in sim.truth["phases"]:
        if phase["phase"] != "idle":
            mask[round(phase["t_start_s"] / dt_s) : round(phase["t_end_s"] / dt_s)] = True
    return mask


def test_a_heldout_run_does_not_change_its_own_baseline_prediction():
    """Its motion power 20% higher: its measured energy moves, the prediction made without
    its fold does not (its idle phases, which the prediction reads, are left as they were)."""
    sims = simulate_runs(SimConfig(**GRID, seed=71))
    runs = [s.run for s in sims]
    before = diagnose_runs(runs).runs.set_index("run_id")
    victim = next(s for s in sims if s.run.meta.mode == "motion")
    boosted = victim.run.power_W * np.where(_moving(victim), 1.2, 1.0)
    changed = [replace(r, power_W=boosted) if r is victim.run else r for r in runs]
    after = diagnose_runs(changed).runs.set_index("run_id")
    run_id = victim.run.meta.run_id
    assert after.loc[run_id, "measured_energy_J"] > before.loc[run_id, "measured_energy_J"] * 1.1
    assert after.loc[run_id, "baseline_energy_J"] == pytest.approx(
        before.loc[run_id, "baseline_energy_J"], rel=1e-6
    )


def test_a_runs_own_idle_level_moves_its_prediction_by_that_level_over_its_motion():
    """diagnose/idle.py: a run's whole trace 0.5 W higher (its electronics' draw that run)
    is not motion: its measured energy and both predictions move by 0.5 W times its time in
    motion, its errors do not, and no other run's prediction moves. Taking the referral out
    (or adding the offset back to one side only) fails this."""
    sims = simulate_runs(SimConfig(**GRID, seed=71))
    runs = [s.run for s in sims]
    before = diagnose_runs(runs).runs.set_index("run_id")
    victim = next(s for s in sims if s.run.meta.mode == "motion")
    changed = [replace(r, power_W=r.power_W + 0.5) if r is victim.run else r for r in runs]
    after = diagnose_runs(changed).runs.set_index("run_id")
    run_id = victim.run.meta.run_id
    motion_s = _moving(victim).sum() * victim.run.sample_period_s
    for column in ("measured_energy_J", "baseline_energy_J", "extended_energy_J"):
        moved = after.loc[run_id, column] - before.loc[run_id, column]
        assert moved == pytest.approx(0.5 * motion_s, rel=0.01), column
    others = after.index != run_id
    np.testing.assert_allclose(
        after.loc[others, "baseline_energy_J"], before.loc[others, "baseline_energy_J"], rtol=1e-6
    )


def test_a_given_model_is_the_baseline_as_it_is():
    from wifibot_power.model import paper_model

    result, _ = _diagnose({"decel_phase": 0.4}, 81, reference=paper_model())
    row = result.runs.set_index("run_id").loc["v0.40_d2_s1_r1"]
    # paper Eq. 5/6 by hand, t_acc = 1 s (paper_model): P_acc(0.4) = 23.9 + 14.8 * 0.4 = 29.82 W
    # for 1 s; s_acc = 0.2 m; cruise (2 - 0.2) / 0.4 = 4.5 s at 23.9 + 11.2 * 0.4 = 28.38 W
    assert row["baseline_energy_J"] == pytest.approx(29.82 + 4.5 * 28.38, rel=1e-9)
    assert "not refitted" in result.summary()["baseline"]["model"]
    assert [f.cause for f in result.findings] == ["decel_phase"]


def test_a_heldout_fold_never_sees_the_causes_chosen_because_of_it(monkeypatch):
    """Nested cross-validation: the extended model's held-out prediction of a run uses causes
    chosen without the run's fold. A stand-in `select_causes` names decel_phase only when
    one marked run is among the runs it chooses from; the marked run's fold must then be
    predicted without it, and every other fold with it."""
    from wifibot_power import diagnose
    from wifibot_power.diagnose import selection

    runs = [s.run for s in simulate_runs(SimConfig(**GRID, seed=73))]
    result = diagnose_runs(runs)
    table = result.runs.set_index("run_id")
    marked = "v0.60_d5_s1_r1"
    marked_fold = table.loc[marked, "fold"]
    seen: list[frozenset] = []

    def stand_in(batch, baseline_rmse):
        seen.append(frozenset(batch.motion["run_id"]))
        chosen = {"decel_phase": 50.0} if marked in set(batch.motion["run_id"]) else {}
        return diagnose.Selection(selected=chosen)

    monkeypatch.setattr(selection, "select_causes", stand_in)
    frame = diagnose.summary_table([diagnose.summarize_run(r) for r in runs])
    motion = diagnose.motion_runs(frame)
    folds = diagnose.assign_folds(motion["run_id"])
    batch = diagnose.Batch(frame, motion, folds)
    nested, notes = diagnose.nested_heldout_energy_J(batch, ["decel_phase"])
    without = diagnose.heldout_energy_J(frame, motion, folds, [])
    with_decel = diagnose.heldout_energy_J(frame, motion, folds, ["decel_phase"])
    in_marked = folds == marked_fold
    assert np.array_equal(nested[in_marked], without[in_marked])
    assert np.array_equal(nested[~in_marked], with_decel[~in_marked])
    assert not np.array_equal(with_decel[in_marked], without[in_marked])  # the test can tell
    # one choice per fold, each from the other folds' runs only
    all_ids = set(motion["run_id"])
    assert sorted(seen, key=sorted) == sorted(
        (frozenset(all_ids - set(motion["run_id"][folds == k])) for k in np.unique(folds)),
        key=sorted,
    )
    assert [n.text for n in notes] == [
        f"held-out fold {marked_fold}: the causes chosen without its {in_marked.sum()} runs are "
        "none, not the findings ['decel_phase']"
    ]
    assert [n.kind for n in notes] == [diagnose.FOLD]


def test_folds_too_small_to_choose_on_use_the_findings_and_say_so():
    # 6 motion runs (the fewest diagnose takes): without a fold, 4 or 5 are left, too few to
    # choose causes on, so every fold is predicted with the findings' causes, and a note says so
    grid = {**GRID, "speeds_mps": (0.4, 0.6, 0.8), "trips": ((2.0, 1), (4.0, 4)), "repeats": 1}
    result = diagnose_runs([s.run for s in simulate_runs(SimConfig(**grid, seed=74))])
    assert result.n_runs == 6
    too_few = [n for n in result.notes if "too few runs without it" in n.text]
    assert len(too_few) == result.runs["fold"].nunique() == 5
    assert result.extended_rmse_J == result.extended_fixed_rmse_J
