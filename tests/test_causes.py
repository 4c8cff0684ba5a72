"""Causes are plugins: one class behind one base, one registry that everything loops over.

A toy cause defined here alone (no other module touched) is simulated, selected, fitted and
used by `energy`; the catalogue's causes each declare what the spec asks of them.
"""

from __future__ import annotations

import pytest
from numpy.testing import assert_allclose

from wifibot_power.causes import CAUSES, Cause, Check, Evidence, RunTable, registered
from wifibot_power.causes.common import coefficient_evidence
from wifibot_power.causes.design import column
from wifibot_power.diagnose import diagnose_runs
from wifibot_power.energy import trip_energy
from wifibot_power.model import paper_model
from wifibot_power.simulate import EFFECTS, SimConfig, parse_effects, simulate_runs

CATALOGUE = (
    "speed_quadratic",
    "start_transient",
    "decel_phase",
    "accel_inertial",
    "thermal_drift",
    "cruise_ripple",
)


class CruiseCubic(Cause):
    """A made-up cause: extra cruise power k3·v³ (cruise only), for the plugin test."""

    name = "cruise_cubic"
    physics = "toy: aerodynamic-like drag in cruise only"
    term = "+ k3 v³ in cruise power"
    unit = "W/(m/s)^3"
    parameter = "k3_W_per_mps3"
    parameters = ("k3_W_per_mps3",)
    min_size = 0.5
    plausible = (0.0, 50.0)
    signature = "cruise power curves with v³"
    default_size = 4.0
    realistic_range = (3.0, 6.0)
    fit_stage = "column"
    energy_stage = "power"

    def power_terms(self, runs, value):
        return {"cruise": value * column(runs, "speed_mps") ** 3}

    def evidence(self, table: RunTable) -> Evidence:
        return coefficient_evidence(self, table, "cruise power rises with v³")

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        return [self.plausible_check(evidence)]

    def energy_J(self, params, trip):
        step = trip.step
        return 0.0, trip.steps * params[self.parameter] * step.speed_mps**3 * step.cruise_s

    def inject(self, size, trace):
        trace.motion_W += size * trace.speed_mps**3 * (trace.kind == 2)
        return {}


def test_the_registry_is_the_catalogue_of_causes_md():
    assert tuple(CAUSES) == CATALOGUE
    assert tuple(EFFECTS) == CATALOGUE
    for name, cause in CAUSES.items():
        assert cause.name == name
        assert cause.parameter in cause.parameters
        assert cause.metric in ("run_energy", "power_trace")
        low, high = cause.plausible
        assert 0 < cause.min_size < high
        # every realistic simulated size is plausible, and the reasoning is written down
        assert low <= cause.realistic_range[0] <= cause.realistic_range[1] <= high
        assert "Plausible" in (type(cause).__doc__ or "")


def test_a_toy_cause_from_this_file_alone_is_simulated_selected_fitted_and_used():
    toy = CruiseCubic()
    with registered(toy):
        assert "cruise_cubic" in EFFECTS
        assert parse_effects(["cruise_cubic=4"]) == {"cruise_cubic": 4.0}
        from test_diagnose import GRID

        config = SimConfig(
            **GRID,
            effects={"cruise_cubic": 4.0},
            seed=5,
        )
        sims = simulate_runs(config)
        # simulated: cruise at 0.8 m/s carries 4 * 0.8³ = 2.05 W more than the paper's line
        run = next(s for s in sims if s.truth["run_id"] == "v0.80_d5_s1_r1")
        assert_allclose(run.truth["cruise_mean_power_W"], 23.9 + 11.2 * 0.8 + 4 * 0.8**3, rtol=1e-3)
        result = diagnose_runs([s.run for s in sims])
        assert [f.cause for f in result.findings] == ["cruise_cubic"]
        (finding,) = result.findings
        # fitted: the stacked fit recovers k3 (a column of ~0.1-3 W on means known to mW)
        assert finding.estimate["value"] == pytest.approx(4.0, rel=0.02)
        assert finding.checks and all(c.passed for c in finding.checks)
        assert finding.gain_pct > 50
        k3 = result.extended_model.extensions["cruise_cubic"]["k3_W_per_mps3"]
        # used by energy: 2 m at 0.8 m/s, t_acc 1 s: cruise (2 - 0.4) / 0.8 = 2 s
        model = paper_model().with_extensions({"cruise_cubic": {"k3_W_per_mps3": k3}}, "t")
        trip = trip_energy(model, 0.8, 2.0, 1, t_acc_s=1.0)
        term = next(p for p in trip.phases if p.phase == "cruise_cubic")
        assert_allclose(term.energy_J, k3 * 0.8**3 * 2.0, rtol=1e-12)
        assert "cruise_cubic" in trip.extensions
    assert "cruise_cubic" not in CAUSES and "cruise_cubic" not in EFFECTS


def _drifted_table(alpha_per_min: float):
    """Noise-free phase means of the paper's robot warming at `alpha_per_min`: 4 speeds,
    each at motor-on times 2, 10 and 18 min (so drift is uncorrelated with speed), 5 s
    cruises, t_acc = v / (1 m/s²)."""
    import pandas as pd

    idle_W = 23.3
    rows = []
    for v in (0.2, 0.4, 0.6, 0.8):
        for tau in (2.0, 10.0, 18.0):
            factor = 1 + alpha_per_min * tau
            accel_W = idle_W + (23.9 + 14.8 * v - idle_W) * factor
            cruise_W = idle_W + (23.9 + 11.2 * v - idle_W) * factor
            rows.append(
                dict(
                    speed_mps=v,
                    t_acc_s=v,
                    payload_kg=0.0,
                    tau_mid_min=tau,
                    steps_found=1,
                    cruise_duration_s=5.0,
                    accel_mean_power_W=accel_W,
                    cruise_mean_power_W=cruise_W,
                    accel_energy_J=accel_W * v,
                    cruise_energy_J=cruise_W * 5.0,
                    idle_mean_power_W=idle_W,
                )
            )
    return pd.DataFrame(rows), idle_W


@pytest.mark.parametrize("alpha", [0.003, 0.01, 0.02])
def test_thermal_alpha_recovers_the_drift_net_of_what_the_lines_absorb(alpha):
    """The lines fitted to drifted means absorb the mean drift (factor 1 + α τ̄, τ̄ = 10 min):
    the ratio's slope is b = α / (1 + α τ̄), so α = b / (1 - b τ̄). Noise-free, balanced data:
    α back to 1e-9 relative; without the correction it would be 3-17% low."""
    from wifibot_power.causes.design import stacked_fit
    from wifibot_power.causes.thermal_drift import thermal_alpha

    runs, idle_W = _drifted_table(alpha)
    cold = paper_model().with_extensions({}, "t")
    coef, _, _ = stacked_fit(runs, [], cold)
    estimate, (low, high), p_value = thermal_alpha(runs, coef, idle_W)
    assert estimate == pytest.approx(alpha, rel=1e-9)
    assert p_value < 1e-6


def test_the_significance_gate():
    """Evidence counts only below ALPHA = 1e-3 and at a size worth naming."""
    from wifibot_power.causes import ALPHA

    name, size = "decel_phase", CAUSES["decel_phase"].min_size
    assert Evidence(name, True, ALPHA / 2, size).passes
    assert not Evidence(name, True, ALPHA * 2, size).significant
    assert not Evidence(name, True, ALPHA / 2, size * 0.9).passes
    assert not Evidence(name, False, 0.0, size).significant  # not testable: never significant
    assert not Evidence(name, True, float("nan"), size).significant


def test_thermal_ratio_ignores_an_offset_of_a_runs_whole_trace():
    """A run whose every sample sits 0.3 W higher (the electronics' or the analyser's zero
    moved) has the same motion power above idle: its ratio must not move, while the ratio
    of the idle logs' idle_W would (0.3 W against ~3 W above idle at 0.2 m/s is ~10%)."""
    import numpy as np

    from wifibot_power.causes.design import stacked_fit
    from wifibot_power.causes.thermal_drift import above_idle_ratio

    runs, idle_W = _drifted_table(0.01)
    cold = paper_model().with_extensions({}, "t")
    coef, _, _ = stacked_fit(runs, [], cold)
    before = above_idle_ratio(runs, coef, idle_W)
    shifted = runs.copy()
    offset_W = np.where(np.arange(len(runs)) % 2 == 0, 0.3, -0.3)  # mean 0: the lines' idle
    shifted["accel_energy_J"] += offset_W * shifted["t_acc_s"] * shifted["steps_found"]
    shifted["cruise_energy_J"] += offset_W * shifted["cruise_duration_s"]
    shifted["idle_mean_power_W"] += offset_W
    after = above_idle_ratio(shifted, coef, idle_W)
    np.testing.assert_allclose(after, before, rtol=0, atol=1e-12)
    # without each run's own idle (a log with no idle phases: the idle logs' level is used)
    # the offset reads as motion power: 5-10% of the ratio here
    blind = shifted.assign(idle_mean_power_W=float("nan"))
    assert np.max(np.abs(above_idle_ratio(blind, coef, idle_W) - before)) > 0.05


def test_a_jump_beside_a_line_is_found_where_it_is_and_straight_lines_rarely_show_one():
    """`step_beside_line` (thermal drift's 'smooth, not a jump' check). Straight lines with
    white errors, 30 runs: at the check's 1e-3 the Bonferroni p flags at most that share
    (1000 draws: binomial 99.9% bound 5; measured 1). Without the factor over the 27 splits
    20 of them would be flagged (measured). A 3% step under 0.5% scatter, after run 12, is
    found there (measured p = 7e-6), with its size within 3 standard errors."""
    import numpy as np

    from wifibot_power.causes.thermal_drift import step_beside_line

    rng = np.random.default_rng(5)
    tau = np.sort(rng.uniform(0, 15, 30))
    flagged = 0
    for _ in range(1000):
        ratio = 0.01 * tau + rng.normal(0, 0.005, tau.size)
        flagged += step_beside_line(ratio, tau)[0] < 1e-3
    assert flagged <= 5
    ratio = 0.01 * tau + rng.normal(0, 0.005, tau.size) + 0.03 * (np.arange(30) >= 12)
    p_value, after, size, se, splits = step_beside_line(ratio, tau)
    assert (after, splits) == (12, 27)
    assert p_value < 1e-4
    assert abs(size - 0.03) < 3 * se
    assert step_beside_line(ratio[:4], tau[:4]) is None


def _creep_check(
    within_per_min: float, scatter: float, alpha: float, alpha_ci: float, model_idle_W=23.0
):
    """The creep-within-runs check on 10 synthetic runs: each with S_tt = 1, 6 W above its
    own idle, tau 0, so a run's slope is within·6/60 W/s plus ±`scatter` (alternating: the
    fit's standard error is then known); the between-run α with a ±`alpha_ci` interval."""
    from types import SimpleNamespace

    import numpy as np
    import pandas as pd

    from wifibot_power.causes.base import Evidence, RunTable

    n = 10
    noise = scatter * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    runs = pd.DataFrame(
        {
            "creep_s_tt": np.ones(n),
            "creep_s_tp": within_per_min * 6.0 / 60.0 + noise,
            "creep_power_W": np.full(n, 29.3),
            "idle_mean_power_W": np.full(n, 23.3),
            "tau_mid_min": np.zeros(n),
        }
    )
    evidence = Evidence("thermal_drift", True, 1e-9, alpha, (alpha - alpha_ci, alpha + alpha_ci))
    table = RunTable(runs, SimpleNamespace(idle_W=model_idle_W))
    return CAUSES["thermal_drift"]._creep_within_runs(table, evidence)


def test_the_creep_check_names_what_it_saw():
    """Each way the check ends (docs/diagnose.md, "What the checks cost"). The fit's
    standard error is scatter·sqrt(n/(n-1))/sqrt(n)/0.1 [1/min]: 0.0001 W/s of scatter gives
    0.00033 /min, 0.001 gives 0.0033."""
    seen = _creep_check(0.01, 1e-4, alpha=0.01, alpha_ci=0.002)
    assert seen.passed and seen.detail.startswith("within runs 1%/min")
    contradicts = _creep_check(0.0, 1e-4, alpha=0.01, alpha_ci=0.002)
    assert not contradicts.passed
    assert contradicts.detail.startswith("the creep within runs contradicts α")
    # precise enough to see α (30 standard errors), none seen, yet within the wide
    # between-run interval's reach: absent where it would show
    absent = _creep_check(0.0, 1e-4, alpha=0.01, alpha_ci=0.03)
    assert not absent.passed
    assert absent.detail.startswith("not seen where the runs could show it")
    # 3 standard errors where 4.7 are needed: too short to tell, and that is no name
    short = _creep_check(0.01, 1e-3, alpha=0.01, alpha_ci=0.01)
    assert not short.passed
    assert short.detail.startswith("not testable here: the runs are too short")
    # the power above idle is each run's own: the idle logs' level (0.3 W apart) changes nothing
    assert _creep_check(0.01, 1e-4, 0.01, 0.002, model_idle_W=23.3).detail == seen.detail
