"""The simulator puts each effect into the logs at the stated size, and no effect gives the paper.

Effects are measured from logs written to disk and read back (not from the simulator's
internals); truth.json only supplies phase boundaries and session state.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.io import read_log
from wifibot_power.simulate import SimConfig, load_truth, write_simulation

PERIOD_S = 0.1024e-3


def _write(tmp_path, name, **kwargs):
    config = SimConfig(**{"repeats": 1, "mode_repeats": 0, "sample_period_s": PERIOD_S, **kwargs})
    out = tmp_path / name
    write_simulation(config, out)
    truth = load_truth(out / "truth.json")
    runs = {r["run_id"]: (read_log(out / r["file"]), r) for r in truth["runs"]}
    return runs, truth


def _phase_power(run, truth_run, phase):
    """Mean measured power over each truth phase of that name, and the sample slices."""
    dt = run.sample_period_s
    slices = [
        slice(round(p["t_start_s"] / dt), round(p["t_end_s"] / dt))
        for p in truth_run["phases"]
        if p["phase"] == phase
    ]
    return np.array([run.power_W[s].mean() for s in slices]), slices


def test_no_effect_phase_averages_follow_the_paper(tmp_path):
    runs, _ = _write(tmp_path, "null", speeds_mps=(0.2, 0.5, 0.9), trips=((2.0, 1), (3.0, 3)))
    for run, truth_run in runs.values():
        v = truth_run["speed_mps"]
        accel, _ = _phase_power(run, truth_run, "accel")
        cruise, _ = _phase_power(run, truth_run, "cruise")
        idle, _ = _phase_power(run, truth_run, "idle")
        # paper Eq. 2 and 4: 23.9 + 14.8 v and 23.9 + 11.2 v; idle 23.3 W. 0.1 W is the
        # issue's bound; noise on a phase mean (0.3 W / sqrt(>= 1900 samples)) is < 0.01 W.
        assert_allclose(accel.mean(), 23.9 + 14.8 * v, atol=0.1)
        assert_allclose(cruise.mean(), 23.9 + 11.2 * v, atol=0.1)
        assert_allclose(idle.mean(), 23.3, atol=0.1)


def test_mode_logs_carry_table1_powers(tmp_path):
    runs, _ = _write(tmp_path, "modes", speeds_mps=(), mode_repeats=1, mode_duration_s=2.0)
    expected_W = {
        "idle_r1": 23.3,
        "network_r1": 23.3 + 4.4,
        "video_r1": 23.3 + 2.5,
        "cpu_r1": 23.3 + 2.1,
    }
    for run_id, power_W in expected_W.items():
        assert_allclose(runs[run_id][0].mean_power_W, power_W, atol=0.01)


def _paired(tmp_path, effect, size, **grid):
    """Same seed with and without one effect: identical noise, so the difference is the effect."""
    base, _ = _write(tmp_path, "base", **grid)
    with_effect, truth = _write(tmp_path, effect, effects={effect: size}, **grid)
    return base, with_effect, truth


def test_speed_quadratic_adds_k2_v_squared_in_cruise(tmp_path):
    k2 = 6.0
    _, runs, _ = _paired(
        tmp_path, "speed_quadratic", k2, speeds_mps=(0.3, 0.6, 0.9), trips=((2.0, 1),)
    )
    speeds = np.array([r["speed_mps"] for _, r in runs.values()])
    excess = np.array(
        [
            _phase_power(run, r, "cruise")[0].mean() - (23.9 + 11.2 * r["speed_mps"])
            for run, r in runs.values()
        ]
    )
    fitted_k2 = np.sum(excess * speeds**2) / np.sum(speeds**4)  # least squares through the origin
    assert_allclose(fitted_k2, k2, rtol=0.03)


def test_start_transient_adds_E_start_per_step_at_the_start(tmp_path):
    e_start_J = 4.0
    base, runs, _ = _paired(
        tmp_path, "start_transient", e_start_J, speeds_mps=(0.5,), trips=((3.0, 3),)
    )
    (run_id,) = runs
    run, truth_run = runs[run_id]
    extra_W = run.power_W - base[run_id][0].power_W
    starts = [p["t_start_s"] for p in truth_run["phases"] if p["phase"] == "accel"]
    assert len(starts) == 3
    for t0 in starts:
        i0 = round(t0 / PERIOD_S)
        window = slice(i0, i0 + round(0.2 / PERIOD_S))
        # 4 decimals written per sample: rounding error on a 0.2 s sum is < 0.2 * 1e-4 J
        assert_allclose(extra_W[window].sum() * PERIOD_S, e_start_J, rtol=1e-3)
    total_extra_J = extra_W.sum() * PERIOD_S
    assert_allclose(total_extra_J, 3 * e_start_J, rtol=1e-3)


def test_decel_phase_lasts_t_dec_between_cruise_and_idle(tmp_path):
    t_dec_s = 0.5
    _, runs, _ = _paired(tmp_path, "decel_phase", t_dec_s, speeds_mps=(0.8,), trips=((4.0, 2),))
    ((run, truth_run),) = runs.values()
    decels = [p for p in truth_run["phases"] if p["phase"] == "decel"]
    assert len(decels) == 2
    cruise, _ = _phase_power(run, truth_run, "cruise")
    idle, _ = _phase_power(run, truth_run, "idle")
    decel, slices = _phase_power(run, truth_run, "decel")
    for d in decels:
        assert_allclose(d["t_end_s"] - d["t_start_s"], t_dec_s, atol=PERIOD_S)
    # stopping costs power between idle and cruise: 23.9 + 0.5 * 11.2 * mean speed (v/2) = 26.14 W
    assert np.all(decel > idle.max() + 1.0) and np.all(decel < cruise.min() - 1.0)
    assert_allclose(decel, 23.9 + 0.5 * 11.2 * 0.8 / 2, atol=0.05)


def test_accel_inertial_scales_with_payload(tmp_path):
    k_inertial = 3.0
    _, runs, _ = _paired(
        tmp_path, "accel_inertial", k_inertial, speeds_mps=(0.6,), trips=((2.0, 1),)
    )
    by_payload = {
        r["payload_kg"]: _phase_power(run, r, "accel")[0].mean() for run, r in runs.values()
    }
    assert sorted(by_payload) == [0.0, 2.0, 4.0]
    for payload_kg in (2.0, 4.0):
        # kI * payload * a * v averaged over a linear ramp: kI * payload * a * v / 2, a = 1 m/s^2
        expected_W = k_inertial * payload_kg * 1.0 * 0.6 / 2
        assert_allclose(by_payload[payload_kg] - by_payload[0.0], expected_W, rtol=0.03)


def test_thermal_drift_grows_with_motor_on_time(tmp_path):
    alpha_per_min = 0.02
    _, runs, _ = _paired(
        tmp_path,
        "thermal_drift",
        alpha_per_min,
        speeds_mps=(0.3, 0.5, 0.9),
        trips=((10.0, 1),),
        repeats=2,
    )
    ratios, on_min = [], []
    for run, r in runs.values():
        cruise, slices = _phase_power(run, r, "cruise")
        above_idle_W = cruise.mean() - 23.3
        ratios.append(above_idle_W / (0.6 + 11.2 * r["speed_mps"]) - 1.0)
        # motor-on minutes at the middle of the cruise: before the run + accel + half the cruise
        mid_cruise_s = r["t_acc_s"] + (slices[0].stop - slices[0].start) * PERIOD_S / 2
        on_min.append(r["motor_on_before_run_min"] + mid_cruise_s / 60)
    slope = np.polyfit(on_min, ratios, 1)[0]
    assert max(on_min) > 1.0  # the session is long enough to see the drift
    assert_allclose(slope, alpha_per_min, rtol=0.05)


def test_cruise_ripple_has_amplitude_A_at_wheel_frequency(tmp_path):
    amplitude_W = 1.5
    _, runs, truth = _paired(
        tmp_path, "cruise_ripple", amplitude_W, speeds_mps=(0.4, 0.8), trips=((8.0, 1),)
    )
    hz_per_mps = truth["parameters"]["ripple_hz_per_mps"]
    for run, r in runs.values():
        _, (cruise,) = _phase_power(run, r, "cruise")
        x = run.power_W[cruise] - run.power_W[cruise].mean()
        spectrum = np.abs(np.fft.rfft(x * np.hanning(x.size))) * 2 / np.hanning(x.size).sum()
        freqs = np.fft.rfftfreq(x.size, PERIOD_S)
        peak = np.argmax(spectrum[1:]) + 1
        # frequency resolution 1/T_cruise (~0.1 Hz); wheel frequency v / (pi * 0.13 m)
        assert_allclose(freqs[peak], hz_per_mps * r["speed_mps"], atol=1.5 / (x.size * PERIOD_S))
        assert_allclose(hz_per_mps, 1 / (np.pi * 0.13), rtol=1e-9)
        assert_allclose(spectrum[peak], amplitude_W, rtol=0.1)


def test_same_seed_same_logs_and_different_seed_differs(tmp_path):
    a, _ = _write(tmp_path, "a", speeds_mps=(0.5,), trips=((2.0, 1),), seed=7)
    b, _ = _write(tmp_path, "b", speeds_mps=(0.5,), trips=((2.0, 1),), seed=7)
    c, _ = _write(tmp_path, "c", speeds_mps=(0.5,), trips=((2.0, 1),), seed=8)
    (ra, _), (rb, _), (rc, _) = (next(iter(x.values())) for x in (a, b, c))
    assert np.array_equal(ra.power_W, rb.power_W)
    assert not np.array_equal(ra.power_W, rc.power_W)


@pytest.mark.parametrize("spec", ["decel_phase=abc", "nonsense", "cruise_ripple=-1"])
def test_bad_effect_spec_is_a_usage_error(spec):
    from wifibot_power.errors import UsageError
    from wifibot_power.simulate import parse_effects

    with pytest.raises(UsageError):
        parse_effects([spec])


def test_ramp_speed_is_taken_at_the_middle_of_each_sample():
    """Each sample of a linear ramp carries the speed at its middle, so the samples' sum times
    dt is the ramp's exact distance v1 * t / 2 (a midpoint moved by 0.01 sample fails this)."""
    from wifibot_power.simulate import _plan_samples

    dt = 0.5
    plan = [("accel", 1, 4, 0.0, 1.0), ("cruise", 1, 2, 1.0, 1.0), ("decel", 1, 4, 1.0, 0.0)]
    speed, accel, kind, bounds = _plan_samples(plan, dt)
    assert_allclose(speed[:4], [0.125, 0.375, 0.625, 0.875], rtol=0, atol=1e-15)
    assert_allclose(speed[4:6], 1.0, rtol=0, atol=1e-15)
    assert_allclose(speed[6:], [0.875, 0.625, 0.375, 0.125], rtol=0, atol=1e-15)
    # distance of each ramp: 1 m/s * (4 * 0.5 s) / 2 = 1 m
    assert_allclose(speed[:4].sum() * dt, 1.0, rtol=0, atol=1e-15)
    assert_allclose(accel, [0.5] * 4 + [0.0] * 2 + [-0.5] * 4, rtol=0, atol=1e-15)
    assert kind.tolist() == [1] * 4 + [2] * 2 + [3] * 4
    assert bounds.tolist() == [0, 4, 6, 10]


@pytest.mark.parametrize(
    ("options", "noise_W"),
    [((), 0.3), (("--realism", "field"), 0.8), (("--noise", "0.55"), 0.55)],
)
def test_the_simulate_command_takes_the_noise_of_its_options(tmp_path, wbpower, options, noise_W):
    """`--noise` overrides the realism level's noise (cli help: default 0.3, 0.8 with field);
    truth.json says the noise the logs were written with."""
    out = tmp_path / "logs"
    small = ("--speeds", "0.5", "--trips", "2x1", "--repeats", "1", "--modes", "")
    result = wbpower("simulate", "-o", out, *small, *options, "--json")
    assert result.exit_code == 0, result.stderr
    assert load_truth(out / "truth.json")["noise_W"] == noise_W
