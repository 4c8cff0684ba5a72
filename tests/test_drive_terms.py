"""The drive model's terms are honest (issue 25): a term the data do not hold (not excited,
pushed against its physical bound, or with an interval wider than any power the logs show)
is in `not_determined` with its reason, never a number; an interval never crosses the bound
the term was fitted under; the human table prints the digits the interval supports."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from wifibot_power.drive import DriveModel, fit_drive
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.terms import TERM_BY_NAME
from wifibot_power.run import Run, RunMeta

BOREALTC_FLOORING = Path("/work/real_drive/borealtc/flooring")


def _reported(model: DriveModel):
    yield from (("all", name, t) for name, t in model.terms.items())
    for surface, named in model.surfaces.items():
        yield from ((surface, name, t) for name, t in named.items())


def _assert_bounded_intervals(model: DriveModel) -> None:
    for surface, name, term in _reported(model):
        low, high = term.ci95
        assert low <= term.value <= high, (surface, name, term)
        if TERM_BY_NAME[name].non_negative:
            assert low >= 0.0, (surface, name, term)


def _reason(model: DriveModel, column: str) -> str:
    (reason,) = [r for r in model.not_determined if r.startswith(f"{column}:")]
    return reason


def _straight_runs(profiles, period_s: float = 0.02, seed: int = 0) -> list[Run]:
    """Logs of a robot driving straight (no turning column): speed from knots (time, speed),
    power from the true terms (idle 10 W, drive on 2 W, rolling 20 W/(m/s), v^2 6 W/(m/s)^2,
    m_eff 25 kg, braking 8 kg) with 0.5 W of noise."""
    rng = np.random.default_rng(seed)
    runs = []
    for k, (knots_t, knots_v) in enumerate(profiles):
        t = np.arange(0, knots_t[-1], period_s)
        v = np.interp(t, knots_t, knots_v)
        av = np.gradient(v, period_s) * v
        power = (
            10 + 2 * (v != 0) + 20 * np.abs(v) + 6 * v**2
            + 25 * np.maximum(av, 0) + 8 * np.minimum(av, 0)
        )  # fmt: skip
        power = power + rng.normal(0, 0.5, t.size)
        meta = RunMeta(run_id=f"r{k}", sample_period_s=period_s)
        runs.append(Run(f"r{k}.csv", "wbpower-csv", meta, t, power, speed_mps=v))
    return runs


def test_a_term_the_data_push_below_its_bound_is_not_determined():
    # a robot whose power falls with v^2 (no physics term does that): the fit bounded by
    # physics holds the v^2 term at 0; reported as "0.000 [-x, x]" it would look exact
    config = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=5, quadratic_W_per_mps2=-6.0)
    model = fit_drive([as_run(r) for r in simulate_free(config)])
    assert "quadratic_W_per_mps2" not in model.terms
    reason = _reason(model, "quadratic_W_per_mps2")
    assert "held at its physical bound 0" in reason and "W/(m/s)^2" in reason
    # the data push it below 0: the reason says so, with the unbounded least squares' value
    assert "these logs would make it negative" in reason
    unbounded = float(reason.split("without the bounds: ")[1].split()[0])
    assert unbounded < 0
    _assert_bounded_intervals(model)
    # it stays out of the model.json section's terms, and the others keep their numbers
    assert "quadratic_W_per_mps2" not in model.to_json()["terms"]
    assert {"idle_W", "effective_mass_kg", "braking_mass_kg"} <= set(model.terms)


def test_an_interval_is_clipped_at_the_bound_it_was_fitted_under():
    # a small v^2 term (1 W/(m/s)^2) whose 95% half-width is larger than its estimate: the
    # symmetric interval would say "maybe negative" of a term physics keeps >= 0
    config = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=7, quadratic_W_per_mps2=1.0)
    model = fit_drive([as_run(r) for r in simulate_free(config)])
    term = model.terms["quadratic_W_per_mps2"]
    low, high = term.ci95
    assert term.value - (high - term.value) < 0  # the symmetric interval crossed 0
    assert low == 0.0 and high > term.value > 0
    _assert_bounded_intervals(model)


def test_constant_speed_leaves_the_inertial_terms_not_determined():
    # each run at one speed from its first sample to its last (a log cut out of a cruise):
    # nothing speeds up or brakes, so neither inertial term has a number
    speeds = (0.3, 0.5, 0.7, 0.9, 1.1, 1.3)
    runs = _straight_runs([((0.0, 20.0), (v, v)) for v in speeds])
    model = fit_drive(runs)
    for column, what in (
        ("effective_mass_kg", "no speeding up"),
        ("braking_mass_kg", "no braking"),
    ):
        assert column not in model.terms
        assert what in _reason(model, column)
    assert any(r.startswith("turning_Nm") for r in model.not_determined)
    _assert_bounded_intervals(model)


def test_no_braking_is_not_determined():
    # each run stands, speeds up to its speed and is cut while still moving: speeding up is
    # in the data, braking is not
    profiles = [((0.0, 3.0, 3.0 + v, 20.0), (0.0, 0.0, v, v)) for v in (0.4, 0.7, 1.0, 1.3)]
    model = fit_drive(_straight_runs(profiles * 2, seed=1))
    assert "braking_mass_kg" not in model.terms
    assert "no braking" in _reason(model, "braking_mass_kg")
    low, high = model.terms["effective_mass_kg"].ci95
    assert low <= 25 <= high
    _assert_bounded_intervals(model)


def test_no_turning_nor_reversing_leaves_turning_alone_not_determined():
    config = FreeDriveConfig(runs_per_surface=3, run_s=60.0, seed=7, turning=False,
                             reversing=False)  # fmt: skip
    model = fit_drive([as_run(r) for r in simulate_free(config)])
    assert [r.split(":")[0] for r in model.not_determined] == [
        "turning_Nm[asphalt]",
        "turning_Nm[grass]",
    ]
    _assert_bounded_intervals(model)


@pytest.mark.skipif(not BOREALTC_FLOORING.is_dir(), reason="needs /work/real_drive (not in git)")
def test_borealtc_flooring_has_no_fake_exact_term():
    # the Husky on flooring (current proxy, 10 runs): the fit held rolling, v^2 and the
    # effective mass at 0 and printed them as "0.000 [-29251, 29251]"; braking came out
    # 2404 kg [-2444, 7253]: none of them is a measurement
    from wifibot_power.io.reader import read_log

    runs = [read_log(path) for path in sorted(BOREALTC_FLOORING.glob("*.csv*"))]
    model = fit_drive(runs)
    for column in ("rolling_W_per_mps[flooring]", "quadratic_W_per_mps2", "effective_mass_kg"):
        assert "held at its physical bound 0" in _reason(model, column)
    reported = {name for _, name, _ in _reported(model)}
    assert reported.isdisjoint({"quadratic_W_per_mps2", "effective_mass_kg"})
    # braking sits at the looseness rule's edge: its interval leaves 88.8 W open where it
    # acts against the power's sd of 89.5 W there (with the edge speeds' 0.7 s box mean of
    # 6.5 Hz logs, 112 W against 96.7: not determined); reported or not, its interval holds
    # 0: no sign, let alone a mass, is claimed
    if "braking_mass_kg" in reported:
        low, high = model.terms["braking_mass_kg"].ci95
        assert low < 0 < high
    else:
        assert "more than the power varies there" in _reason(model, "braking_mass_kg")
    for _, name, term in _reported(model):
        assert term.value != 0.0, name
        low, high = term.ci95
        # no term that claims a value (its interval without 0) has an interval wider than
        # the whole power the Husky draws (~170 W mean)
        if low > 0 or high < 0:
            assert (high - low) * (1.0 if name.endswith("_W") else 0.25) < 400, (name, term)
    _assert_bounded_intervals(model)
    # the terms not reported still predict: held-out accuracy as before this rule
    assert model.heldout is not None and math.isfinite(model.heldout.mape_pct)
