"""Trip energy (paper Eq. 5/6) and the causes.md extension terms, against hand-worked cases.

Tolerances: every expected value below is a few float operations on exact decimal inputs, so
the only error is float rounding; rtol=1e-12 is ~1e4 ulps and still fails on any wrong term.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from wifibot_power.energy import (
    energy_report,
    speed_sweep,
    step_kinematics,
    trip_energy,
)
from wifibot_power.errors import UsageError
from wifibot_power.model import LinearFit, paper_model

RTOL = 1e-12
PAPER = paper_model()


def with_ext(**extensions: dict[str, float]):
    return PAPER.with_extensions(extensions, source="test")


def test_paper_trip_by_hand():
    # v = 0.8 m/s, D = 10 m, N = 10 steps, t_acc = 1 s (the reference command).
    # P_acc = 23.9 + 14.8*0.8 = 35.74 W ; P_v = 23.9 + 11.2*0.8 = 32.86 W
    # s = 1 m, s_acc = 0.8*1/2 = 0.4 m, cruise (1 - 0.4)/0.8 = 0.75 s
    # E_step = 35.74*1 + 32.86*0.75 = 35.74 + 24.645 = 60.385 J ; trip = 603.85 J in 17.5 s
    # one step: cruise (10 - 0.4)/0.8 = 12 s -> 35.74 + 32.86*12 = 430.06 J in 13 s
    report = energy_report(PAPER, 0.8, 10.0, 10, t_acc_s=1.0)
    assert_allclose(report.trip.energy_J, 603.85, rtol=RTOL)
    assert_allclose(report.trip.time_s, 17.5, rtol=RTOL)
    assert_allclose(report.one_step.energy_J, 430.06, rtol=RTOL)
    assert_allclose(report.one_step.time_s, 13.0, rtol=RTOL)
    assert_allclose(report.overhead_pct, 100 * (603.85 / 430.06 - 1), rtol=RTOL)
    phases = {p.phase: p for p in report.trip.phases}
    assert_allclose(phases["accel"].energy_J, 357.40, rtol=RTOL)
    assert_allclose(phases["cruise"].energy_J, 246.45, rtol=RTOL)
    assert_allclose(phases["cruise"].mean_power_W, 32.86, rtol=RTOL)


def test_model_t_acc_used_when_not_overridden():
    # t_acc(v) = 0.5 + 1.0 v -> 1.0 s at 0.5 m/s; P_acc(0.5) = 31.3 W, P_v(0.5) = 29.5 W
    # s_acc = 0.25 m; 1 step of 2 m: cruise 1.75/0.5 = 3.5 s -> 31.3 + 29.5*3.5 = 134.55 J
    model = replace(PAPER, t_acc=LinearFit(0.5, 1.0))
    trip = trip_energy(model, 0.5, 2.0, 1)
    assert_allclose(trip.t_acc_s, 1.0, rtol=RTOL)
    assert_allclose(trip.energy_J, 134.55, rtol=RTOL)


def test_triangular_step_by_hand():
    # v = 0.8 m/s, t_acc = 1 s -> a = 0.8 m/s², s_acc = 0.4 m; steps of 0.2 m never reach v.
    # From rest at a: s = a t²/2 -> t = sqrt(2*0.2/0.8) = sqrt(0.5) s, v_peak = a t = sqrt(0.32)
    # E_step = P_acc(v_peak) * t = (23.9 + 14.8*sqrt(0.32)) * sqrt(0.5)
    report = energy_report(PAPER, 0.8, 2.0, 10, t_acc_s=1.0)
    step = report.trip.step
    assert not step.reaches_speed
    assert_allclose(step.peak_speed_mps, math.sqrt(0.32), rtol=RTOL)
    assert_allclose(step.accel_s, math.sqrt(0.5), rtol=RTOL)
    assert step.cruise_s == 0.0
    expected_step_J = (23.9 + 14.8 * math.sqrt(0.32)) * math.sqrt(0.5)
    assert_allclose(report.trip.energy_J, 10 * expected_step_J, rtol=RTOL)
    assert_allclose(report.trip.time_s, 10 * math.sqrt(0.5), rtol=RTOL)
    assert report.summary()["reaches_speed"] is False


def test_triangular_profile_is_continuous_at_the_boundary():
    # At s = s_acc = 0.4 m both branches give v_peak = v, t = t_acc, no cruise: 35.74 J.
    below = trip_energy(PAPER, 0.8, 0.4 * (1 - 1e-12), 1, t_acc_s=1.0)
    above = trip_energy(PAPER, 0.8, 0.4 * (1 + 1e-12), 1, t_acc_s=1.0)
    assert not below.step.reaches_speed and above.step.reaches_speed
    assert_allclose([below.energy_J, above.energy_J], [35.74, 35.74], rtol=1e-9)


@settings(max_examples=200, deadline=None)
@given(
    speed=st.floats(0.01, 3.0),
    step=st.floats(0.0, 20.0),
    t_acc=st.floats(0.0, 10.0),
    t_dec=st.floats(0.0, 5.0),
)
def test_step_times_never_negative_and_cover_the_step(speed, step, t_acc, t_dec):
    kin = step_kinematics(speed, step, t_acc, t_dec)
    assert kin.accel_s >= 0 and kin.cruise_s >= 0 and kin.decel_s >= 0
    assert kin.peak_speed_mps <= speed * (1 + 1e-12)
    # distance of the trapezoid/triangle in the speed-time plane equals the step
    covered_m = kin.peak_speed_mps * (kin.accel_s + kin.decel_s) / 2 + speed * kin.cruise_s
    assert_allclose(covered_m, step, rtol=1e-9, atol=1e-12)


def test_one_step_has_no_overhead():
    report = energy_report(PAPER, 0.5, 7.0, 1, t_acc_s=1.3)
    assert report.overhead_pct == 0.0


@settings(max_examples=200, deadline=None)
@given(
    speed=st.floats(0.05, 2.0),
    distance=st.floats(0.5, 50.0),
    t_acc=st.floats(0.05, 5.0),
    steps=st.integers(1, 50),
)
def test_overhead_grows_with_steps(speed, distance, t_acc, steps):
    # Per trip E_N = N t_acc (P_acc - P_v/2) + P_v D / v while steps reach v, and
    # 23.9 sqrt(2 D t_acc N / v) + 29.6 D once they do not: both rise with N.
    fewer = energy_report(PAPER, speed, distance, steps, t_acc_s=t_acc)
    more = energy_report(PAPER, speed, distance, steps + 1, t_acc_s=t_acc)
    assert more.overhead_pct > fewer.overhead_pct


@settings(max_examples=200, deadline=None)
@given(
    speed=st.floats(0.05, 1.19),
    dv=st.floats(0.01, 0.5),
    distance=st.floats(0.5, 50.0),
    t_acc=st.floats(0.05, 5.0),
    steps=st.integers(1, 20),
)
def test_energy_per_metre_falls_with_speed_under_the_paper_model(speed, dv, distance, t_acc, steps):
    # dE_step/dv = 9.2 t_acc - 23.9 s / v² < 0 while s >= v t_acc / 2 and v < 1.3 m/s;
    # triangular steps cost 23.9 sqrt(2 s t_acc / v) + 29.6 s, also falling with v.
    faster = min(speed + dv, 1.2)
    slow = trip_energy(PAPER, speed, distance, steps, t_acc_s=t_acc)
    fast = trip_energy(PAPER, faster, distance, steps, t_acc_s=t_acc)
    assert fast.energy_J / distance < slow.energy_J / distance


def test_figure5_sweep_covers_the_paper_grid():
    rows = speed_sweep(PAPER, t_acc_s=1.0)
    assert len(rows) == 2 * 9
    assert {(r.trip.distance_m, r.trip.steps) for r in rows} == {(2.0, 2), (10.0, 10)}
    assert sorted({round(r.trip.speed_mps, 9) for r in rows}) == [
        0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9,
    ]  # fmt: skip
    row = next(r for r in rows if r.trip.distance_m == 10.0 and abs(r.trip.speed_mps - 0.8) < 1e-9)
    assert_allclose(row.trip.energy_J, 603.85, rtol=RTOL)  # the hand case above


# -- extensions: one hand case per causes.md term (v = 0.8, t_acc = 1, P_acc 35.74, P_v 32.86) --
def test_speed_quadratic_term():
    # 1 m in 1 step: cruise 0.75 s. k2 = 2: cruise 2*0.64*0.75 = 0.96 J, accel 2*0.64/3*1 J
    base = 35.74 + 32.86 * 0.75
    trip = trip_energy(with_ext(speed_quadratic={"k2_W_per_mps2": 2.0}), 0.8, 1.0, 1, t_acc_s=1.0)
    assert_allclose(trip.energy_J, base + 0.96 + 2 * 0.64 / 3, rtol=RTOL)


def test_start_transient_term():
    # 4 m in 4 steps: 4 * (35.74 + 32.86*0.75) + 4 * 5 J
    trip = trip_energy(with_ext(start_transient={"E_start_J": 5.0}), 0.8, 4.0, 4, t_acc_s=1.0)
    assert_allclose(trip.energy_J, 4 * (35.74 + 32.86 * 0.75) + 20.0, rtol=RTOL)


def test_decel_phase_term():
    # t_dec = 0.5 s covers 0.8*0.5/2 = 0.2 m; cruise (1 - 0.4 - 0.2)/0.8 = 0.5 s
    # P_dec = 20 + 10*0.8 = 28 W for 0.5 s = 14 J; time 1 + 0.5 + 0.5 = 2 s
    decel = {"t_dec_s": 0.5, "P_dec_intercept_W": 20.0, "P_dec_slope_W_per_mps": 10.0}
    trip = trip_energy(with_ext(decel_phase=decel), 0.8, 1.0, 1, t_acc_s=1.0)
    assert_allclose(trip.energy_J, 35.74 + 32.86 * 0.5 + 14.0, rtol=RTOL)
    assert_allclose(trip.time_s, 2.0, rtol=RTOL)


def test_decel_phase_triangular_step():
    # s = 0.3 m < 0.4 + 0.2: a = 0.8, a_dec = 1.6 m/s²; s = v_p²/(2*0.8) + v_p²/(2*1.6)
    # = v_p² * 15/16 -> v_p = sqrt(0.32); accel v_p/0.8 s, decel v_p/1.6 s
    decel = {"t_dec_s": 0.5, "P_dec_intercept_W": 20.0, "P_dec_slope_W_per_mps": 10.0}
    trip = trip_energy(with_ext(decel_phase=decel), 0.8, 0.3, 1, t_acc_s=1.0)
    v_peak = math.sqrt(0.32)
    expected = (23.9 + 14.8 * v_peak) * v_peak / 0.8 + (20 + 10 * v_peak) * v_peak / 1.6
    assert_allclose(trip.step.peak_speed_mps, v_peak, rtol=RTOL)
    assert_allclose(trip.energy_J, expected, rtol=RTOL)


def test_accel_inertial_term():
    # kI = 1.5, payload 2 kg: 1.5 * 2 * 0.8² / 2 = 0.96 J per step
    model = with_ext(accel_inertial={"kI": 1.5})
    trip = trip_energy(model, 0.8, 1.0, 1, t_acc_s=1.0, payload_kg=2.0)
    assert_allclose(trip.energy_J, 35.74 + 32.86 * 0.75 + 0.96, rtol=RTOL)
    no_payload = trip_energy(model, 0.8, 1.0, 1, t_acc_s=1.0)
    assert_allclose(no_payload.energy_J, 35.74 + 32.86 * 0.75, rtol=RTOL)


def test_thermal_drift_term():
    # 10 m in 1 step: 430.06 J in 13 s; above idle 430.06 - 23.3*13 = 127.16 J
    # from cold the factor averages 1 + 0.01 * (13/60) / 2
    trip = trip_energy(with_ext(thermal_drift={"alpha_per_min": 0.01}), 0.8, 10.0, 1, t_acc_s=1.0)
    assert_allclose(trip.energy_J, 430.06 + 127.16 * 0.01 * (13 / 60) / 2, rtol=RTOL)


def test_cruise_ripple_adds_no_energy():
    ripple = {"amplitude_W": 3.0, "hz_per_mps": 2.0}
    trip = trip_energy(with_ext(cruise_ripple=ripple), 0.8, 10.0, 1, t_acc_s=1.0)
    assert_allclose(trip.energy_J, 430.06, rtol=RTOL)


def test_energy_is_the_sum_of_its_phases():
    model = with_ext(
        speed_quadratic={"k2_W_per_mps2": 1.0},
        start_transient={"E_start_J": 2.0},
        decel_phase={"t_dec_s": 0.3, "P_dec_intercept_W": 25.0, "P_dec_slope_W_per_mps": 5.0},
    )
    trip = trip_energy(model, 0.6, 5.0, 3, t_acc_s=0.8)
    assert_allclose(trip.energy_J, sum(p.energy_J for p in trip.phases), rtol=RTOL)
    assert {p.phase for p in trip.phases} >= {"accel", "cruise", "decel", "start_transient"}


def test_incomplete_extension_is_a_usage_error():
    with pytest.raises(UsageError, match="decel_phase.*t_dec_s"):
        trip_energy(with_ext(decel_phase={"P_dec_intercept_W": 1.0}), 0.8, 1.0, 1)


def test_unknown_extension_is_reported_not_used():
    report = energy_report(with_ext(warp_drive={"x": 1.0}), 0.8, 10.0, 1, t_acc_s=1.0)
    assert report.ignored_extensions == ("warp_drive",)
    assert_allclose(report.trip.energy_J, 430.06, rtol=RTOL)


@pytest.mark.parametrize(
    ("speed", "distance", "steps", "t_acc"),
    [(0.0, 1.0, 1, 1.0), (0.5, 0.0, 1, 1.0), (0.5, 1.0, 0, 1.0), (0.5, 1.0, 1, -1.0)],
)
def test_bad_inputs_are_usage_errors(speed, distance, steps, t_acc):
    with pytest.raises(UsageError):
        trip_energy(PAPER, speed, distance, steps, t_acc_s=t_acc)


# -- against the simulated robot (wifibot_power/simulate.py): same physics, independent code --
# The simulator builds power sample by sample from drive, rolling friction and inertia with
# a = 1 m/s² (t_acc = v / 1 s), which averages to the paper's lines over each phase. Its
# stop phase draws 23.3 + 0.6 + 0.5*11.2*v(t) W on a linear ramp down: mean 23.9 + 2.8 v.
SIM_EXTENSIONS = {
    "none": ({}, {}),
    "start_transient": ({"start_transient": 3.0}, {"start_transient": {"E_start_J": 3.0}}),
    "speed_quadratic": ({"speed_quadratic": 5.0}, {"speed_quadratic": {"k2_W_per_mps2": 5.0}}),
    "decel_phase": (
        {"decel_phase": 0.4},
        {"decel_phase": {"t_dec_s": 0.4, "P_dec_intercept_W": 23.9, "P_dec_slope_W_per_mps": 2.8}},
    ),
    "accel_inertial": ({"accel_inertial": 6.0}, {"accel_inertial": {"kI": 6.0}}),
    "thermal_drift": ({"thermal_drift": 0.02}, {"thermal_drift": {"alpha_per_min": 0.02}}),
    "cruise_ripple": (
        {"cruise_ripple": 1.0},
        {"cruise_ripple": {"amplitude_W": 1.0, "hz_per_mps": 1 / (math.pi * 0.13)}},
    ),
}


@pytest.mark.parametrize("cause", list(SIM_EXTENSIONS))
def test_trip_energy_matches_the_simulated_robot(cause):
    from wifibot_power.simulate import SimConfig, simulate_runs

    effects, extensions = SIM_EXTENSIONS[cause]
    dt_s = 1e-3
    # thermal drift needs a long trip from cold to be visible: 10 m at 0.1 m/s (~100 s)
    long_only = cause == "thermal_drift"
    config = SimConfig(
        speeds_mps=(0.1,) if long_only else (0.5, 0.9),
        trips=((10.0, 1),) if long_only else ((10.0, 10), (2.0, 1)),
        repeats=1,
        modes=(),
        noise_W=0.0,
        sample_period_s=dt_s,
        effects=effects,
        seed=0,
    )
    model = replace(PAPER, t_acc=LinearFit(0.0, 1.0)).with_extensions(extensions, source="test")
    checked = 0
    for sim in simulate_runs(config):
        truth = sim.truth
        if cause == "thermal_drift" and truth["motor_on_before_run_min"] > 0:
            continue  # energy assumes a trip from cold; later runs in the session are warm
        trip = trip_energy(
            model, truth["speed_mps"], truth["distance_m"], truth["steps"],
            payload_kg=truth["payload_kg"],
        )  # fmt: skip
        # Tolerance: the simulator rounds each cruise to whole samples (<= dt/2 at < 40 W per
        # step); an unfinished ripple cycle leaves at most A / (pi f) J per cruise.
        atol_J = truth["steps"] * dt_s * 40.0
        if cause == "cruise_ripple":
            atol_J += truth["steps"] * 1.0 / (math.pi * truth["speed_mps"] / (math.pi * 0.13))
        assert_allclose(trip.energy_J, truth["motion_energy_J"], rtol=0, atol=atol_J)
        sensitive = cause in ("start_transient", "speed_quadratic", "decel_phase", "thermal_drift")
        if sensitive or (cause == "accel_inertial" and truth["payload_kg"] > 0):
            # the term itself is well above the tolerance, so leaving it out would fail
            base = trip_energy(
                replace(model, extensions={}), truth["speed_mps"], truth["distance_m"],
                truth["steps"], t_acc_s=trip.t_acc_s,
            )  # fmt: skip
            assert abs(trip.energy_J - base.energy_J) > 10 * atol_J
        checked += 1
    assert checked >= 1


@pytest.mark.parametrize("speed_mps", [math.nan, math.inf, 0.0, -0.5])
def test_a_speed_that_is_no_positive_number_is_named_as_the_speed(speed_mps):
    # a NaN speed made t_acc(v) NaN, and the error told the user to fix --t-acc
    with pytest.raises(UsageError, match=r"^speed .* m/s") as error:
        trip_energy(paper_model(), speed_mps, 10.0, 1)
    assert "give a speed > 0" in error.value.one_line()
