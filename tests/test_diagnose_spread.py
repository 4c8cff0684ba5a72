"""The spread check (causes/spread.py, issue 27): a cause is named only when what it
explains is spread over the runs as its physics says, not concentrated at one pattern (one
speed level, distance, step count, payload or session stretch) that no cause has.

Data: `simulate_runs` at field realism on test_diagnose's grid, with power added after the
fact to the runs at the slowest speed only (no cause of causes.md has that form).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_diagnose import GRID  # noqa: E402  (the grid every diagnose test runs on)

from wifibot_power.causes.spread import SPREAD_CHECK, patterns
from wifibot_power.diagnose import diagnose_runs
from wifibot_power.simulate import SimConfig, realism, simulate_runs


def _in_phases(sim, phases: tuple[str, ...]) -> np.ndarray:
    dt = sim.run.sample_period_s
    mask = np.zeros(sim.run.samples, dtype=bool)
    for phase in sim.truth["phases"]:
        if phase["phase"] in phases:
            mask[round(phase["t_start_s"] / dt) : round(phase["t_end_s"] / dt)] = True
    return mask


def _slowest_level_extra(seed: int, power_W: float, phases: tuple[str, ...]):
    """The field-realism test grid with `power_W` more in `phases` of the 0.2 m/s runs."""
    sims = simulate_runs(SimConfig(**{**GRID, **realism("field")}, seed=seed))
    runs = []
    for sim in sims:
        run = sim.run
        if run.meta.mode == "motion" and run.meta.speed_mps == 0.2:
            run = replace(run, power_W=run.power_W + power_W * _in_phases(sim, phases))
        runs.append(run)
    return diagnose_runs(runs)


@pytest.mark.parametrize("seed", [1, 3])
def test_acceleration_power_at_the_slowest_speed_only_is_not_named_start_transient(seed):
    """3 W more while accelerating at 0.2 m/s only (0.6 J a step there, nothing elsewhere).
    Without the spread check, start_transient is named at both seeds with every other
    check passed and nothing unexplained (measured: own gain 28.3% and 30.7%): its column,
    E / t_acc, is largest at the slowest speed. Its share belongs in every speed and
    distance; here it sits at one speed level, so it is not named, and the batch is
    unexplained with that pattern."""
    result = _slowest_level_extra(seed, 3.0, ("accel",))
    assert result.findings == ()
    assert result.unexplained
    (rejected,) = [r for r in result.rejected if r["cause"] == "start_transient"]
    assert rejected["failed"] == [SPREAD_CHECK]
    assert "what it explains sits at runs at 0.2 m/s" in rejected["reason"]
    assert any("runs at 0.2 m/s" in r for r in result.unexplained_reasons)


def test_a_small_extra_at_the_slowest_speed_is_not_named_speed_quadratic():
    """Found in review (third session, a strict xfail until issue 27's spread check): 0.4 W
    more while moving at 0.2 m/s only, at field realism, seed 3, was named speed_quadratic
    with nothing unexplained: the line through the raised lowest speed leaves a U that k2
    v² fits, and what v² cannot fit has a lack-of-fit p of 0.011 in each phase. Beside a
    power at 0.2 m/s, k2 is no longer seen (measured p = 0.76), and that power is seen
    beside k2 (p = 6e-7 on the 10 m grid): the v² term was standing in for one level."""
    result = _slowest_level_extra(3, 0.4, ("accel", "cruise"))
    assert "speed_quadratic" not in [f.cause for f in result.findings]
    assert result.unexplained
    (rejected,) = [r for r in result.rejected if r["cause"] == "speed_quadratic"]
    assert SPREAD_CHECK in rejected["failed"]
    assert "runs at 0.2 m/s" in rejected["reason"]


def test_a_true_start_transient_passes_the_spread_check():
    """The same grid and seed with a start transient of 3 J in every step: its share is in
    every speed and distance, the check passes and it is named."""
    config = SimConfig(**{**GRID, **realism("field")}, effects={"start_transient": 3.0}, seed=1)
    result = diagnose_runs([s.run for s in simulate_runs(config)])
    assert [f.cause for f in result.findings] == ["start_transient"]
    (check,) = [c for c in result.findings[0].checks if c.check == SPREAD_CHECK]
    assert check.passed


def test_patterns_are_levels_and_late_stretches_with_runs_on_both_sides():
    import pandas as pd

    runs = pd.DataFrame(
        {
            "speed_mps": [0.2, 0.2, 0.4, 0.4, 0.6, 0.6, 0.6, 0.8],
            "distance_m": [2.0] * 8,
            "steps": [1, 4, 1, 4, 1, 4, 1, 1],
            "payload_kg": [0.0, 0.0, 3.0, 3.0, 0.0, 0.0, 3.0, 3.0],
            "session_order": [0, 1, 2, 3, 4, 5, 6, 7],
        }
    )
    found = dict(patterns(runs, own=("payload_kg",)))
    # 0.8 m/s has one run: no level of its own; one distance: no pattern; payload is own
    assert "runs at 0.8 m/s" not in found
    assert not any("m payload" in w or " kg payload" in w for w in found)
    assert not any(w.startswith("runs over") for w in found)
    assert found["runs at 0.6 m/s"].tolist() == [0, 0, 0, 0, 1, 1, 1, 0]
    assert found["runs in 4 step(s)"].sum() == 3
    late = [w for w in found if w.startswith("the runs from session position")]
    assert late == [
        "the runs from session position 4 of 8 on",
        "the runs from session position 5 of 8 on",
        "the runs from session position 6 of 8 on",
    ]
    assert found[late[1]].tolist() == [0, 0, 0, 0, 1, 1, 1, 1]
