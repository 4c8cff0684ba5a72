"""Each consequence check passes on runs with its cause's physics, and fails when one
consequence is broken in the run table (the view the check reads), the rest left as it is.

One simulated batch (test_diagnose's grid) with a stop phase of 0.4 s and a 3 J start
transient; tables are changed after summarising, so each test breaks exactly one thing.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_diagnose import GRID  # noqa: E402  (the grid every diagnose test runs on)

from wifibot_power import diagnose
from wifibot_power.causes import CAUSES, RunTable
from wifibot_power.causes.extended import fit_model
from wifibot_power.simulate import SimConfig, simulate_runs


@pytest.fixture(scope="module")
def frame():
    config = SimConfig(**GRID, effects={"decel_phase": 0.4, "start_transient": 3.0}, seed=9)
    summaries = [diagnose.summarize_run(s.run) for s in simulate_runs(config)]
    table = diagnose.summary_table(summaries)
    return table[table["usable"]].reset_index(drop=True)


def _checks(frame, cause: str) -> dict[str, bool]:
    others = tuple(c for c in ("start_transient", "decel_phase") if c != cause)
    motion = diagnose.motion_runs(frame)
    table = RunTable(motion, fit_model(frame, others), others)
    evidence = CAUSES[cause].evidence(table)
    assert evidence.passes
    return {c.check: c.passed for c in CAUSES[cause].checks(table, evidence)}


@pytest.mark.parametrize("cause", ["decel_phase", "start_transient"])
def test_every_check_passes_on_the_causes_own_physics(frame, cause):
    assert all(_checks(frame, cause).values())


def test_a_stop_the_traces_do_not_show_fails_visible(frame):
    changed = frame.copy()
    motion = changed["mode"] == "motion"
    hidden = motion & (np.arange(len(changed)) % 3 == 0)  # a third of the runs: no decel
    changed.loc[hidden, "decel_duration_s"] = 0.0
    checks = _checks(changed, "decel_phase")
    assert not checks["a stopping phase visible after each cruise"]
    assert checks["plausible size"]


def test_energy_after_the_stop_fails_of_the_estimated_length(frame):
    """Power that stays above idle after the stop phase ends (50% more energy in the window
    after each cruise than the stop phases hold)."""
    changed = frame.copy()
    motion = changed["mode"] == "motion"
    idle_W = fit_model(frame).idle_W
    above_J = changed["end_measured_J"] - idle_W * changed["end_s"]
    changed.loc[motion, "end_measured_J"] += 0.5 * above_J[motion]
    checks = _checks(changed, "decel_phase")
    assert not checks["of the estimated length"]
    assert checks["a stopping phase visible after each cruise"]


def _long_stops(frame, window_share: float):
    """The table with every stop phase 1.6 s long (longer than the 1 s window), its mean
    power above idle kept, and the window after each cruise holding `window_share` times the
    stop's mean power above idle x 1 s."""
    changed = frame.copy()
    motion = changed["mode"] == "motion"
    idle_W = fit_model(frame).idle_W
    steps = changed["steps_found"].clip(lower=1)
    above_W = changed["decel_mean_power_W"] - idle_W
    changed.loc[motion, "decel_duration_s"] = 1.6
    changed.loc[motion, "end_s"] = 1.0 * steps[motion]
    changed.loc[motion, "end_measured_J"] = (idle_W + window_share * above_W[motion]) * steps[
        motion
    ]
    return changed


def test_a_stop_longer_than_the_window_passes_of_the_estimated_length(frame):
    """A stop of 1.6 s whose power falls linearly to idle holds 1.375 x its flat share in
    the first second (2m x (1 - 1/3.2) for a mean m above idle): the window is inside the
    stop, between that share and the whole stop (1.6 m). Before, the share alone was the
    expected energy and such stops failed (fieldgen's exponential stops of 1.6 s at seed
    4: ratio 1.28)."""
    checks = _checks(_long_stops(frame, 1.375), "decel_phase")
    assert checks["of the estimated length"]


@pytest.mark.parametrize("share", [0.6, 2.2])
def test_a_long_stop_fails_below_its_share_or_above_the_whole_stop(frame, share):
    """Less than the flat share less 25% (0.75), or more than the whole 1.6 s stop plus
    25% (2.0), in the window: not the stop phase's energy."""
    checks = _checks(_long_stops(frame, share), "decel_phase")
    assert not checks["of the estimated length"]


def test_extra_energy_per_metre_fails_grows_with_steps_not_distance(frame):
    """0.3 J per metre of the trip added to the acceleration phases: per distance, not per
    step."""
    changed = frame.copy()
    motion = changed["mode"] == "motion"
    extra_J = 0.3 * changed["distance_m"]
    accel_s = changed["t_acc_s"] * changed["steps_found"]
    changed.loc[motion, "accel_energy_J"] += extra_J[motion]
    changed.loc[motion, "accel_mean_power_W"] += (extra_J / accel_s)[motion]
    checks = _checks(changed, "start_transient")
    assert not checks["grows with steps, not with distance or speed"]
