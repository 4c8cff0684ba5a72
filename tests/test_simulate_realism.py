"""`--realism field` puts into the logs what real logs carry, each at its stated size.

Each part is measured on generated data (logs written and read back where the samples
matter), not read from the simulator's settings: the analyser noise from an idle log, the
PWM tone from the spectrum of a cruise (at its alias below 1 kHz sampling), the run-to-run
spread of motion power and of idle power from many runs' phase means.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.errors import UsageError
from wifibot_power.io import read_log
from wifibot_power.simulate import (
    REALISM,
    SimConfig,
    load_truth,
    realism,
    simulate_runs,
    write_simulation,
)

FIELD = REALISM["field"]


def _only(**kwargs) -> dict[str, float]:
    """Field realism with every other part switched off."""
    return {**REALISM["lab"], "noise_W": 0.0, **kwargs}


@pytest.mark.parametrize("period_s", [0.1024e-3, 1.024e-3])
def test_field_noise_is_0p8_W_at_10_kHz_and_averages_down_at_longer_periods(tmp_path, period_s):
    config = SimConfig(
        speeds_mps=(),
        modes=("idle",),
        mode_repeats=1,
        mode_duration_s=4.0,
        sample_period_s=period_s,
        **realism("field"),
    )
    write_simulation(config, tmp_path)
    run = read_log(tmp_path / "idle_r1.csv")
    # 0.8 W per 0.1024 ms sample; an averaging analyser: sigma * sqrt(0.1024 ms / period).
    # Standard error of a standard deviation from >= 3900 samples is < 1.2%; 4 decimals
    # written add nothing measurable: 3% slack.
    expected_W = 0.8 * np.sqrt(0.1024e-3 / period_s)
    assert_allclose(run.power_W.std(), expected_W, rtol=0.03)


def _tone(power_W: np.ndarray, period_s: float) -> tuple[float, float]:
    """Frequency [Hz] and amplitude [W] of the highest peak of a Hann-windowed spectrum,
    zero-padded 16 times (the peak's scalloping loss is then < 1%)."""
    x = power_W - power_W.mean()
    window = np.hanning(x.size)
    spectrum = np.abs(np.fft.rfft(x * window, 16 * x.size)) * 2 / window.sum()
    freqs = np.fft.rfftfreq(16 * x.size, period_s)
    k = int(np.argmax(spectrum[1:])) + 1
    return float(freqs[k]), float(spectrum[k])


@pytest.mark.parametrize(
    ("period_s", "expected_hz"),
    [
        (0.1024e-3, 1050.0),  # Nyquist 4883 Hz: the tone where it is
        (0.5e-3, 950.0),  # Nyquist 1000 Hz: 1050 Hz folds to 2000 - 1050 = 950 Hz
    ],
)
def test_pwm_tone_is_where_an_averaging_analyser_puts_it(tmp_path, period_s, expected_hz):
    config = SimConfig(
        speeds_mps=(0.5,),
        trips=((4.0, 1),),
        repeats=1,
        mode_repeats=0,
        sample_period_s=period_s,
        **_only(pwm_tone_W=1.0),
    )
    write_simulation(config, tmp_path)
    truth = load_truth(tmp_path / "truth.json")["runs"][0]
    run = read_log(tmp_path / truth["file"])
    (cruise,) = [p for p in truth["phases"] if p["phase"] == "cruise"]
    cut = slice(round(cruise["t_start_s"] / period_s), round(cruise["t_end_s"] / period_s))
    hz, amplitude_W = _tone(run.power_W[cut], period_s)
    # frequency within one bin of the ~7 s cruise (0.14 Hz) plus rounding: 0.5 Hz
    assert hz == pytest.approx(expected_hz, abs=0.5)
    # 1 W attenuated by the mean over one sample: sinc(f T) = 0.981 and 0.605; scalloping
    # < 1%, the cruise's edges a little more (measured within 1%): 3% slack
    by_hand = 1.0 * np.sin(np.pi * 1050 * period_s) / (np.pi * 1050 * period_s)
    assert amplitude_W == pytest.approx(by_hand, rel=0.03)
    # not while the robot stands still
    (idle, *_) = [p for p in truth["phases"] if p["phase"] == "idle"]
    still = run.power_W[: round(idle["t_end_s"] / period_s)]
    assert still.std() < 1e-3


def test_run_to_run_spread_of_motion_and_idle_power():
    config = SimConfig(
        speeds_mps=(0.3, 0.6, 0.9),
        trips=((2.0, 1),),
        repeats=30,
        mode_repeats=0,
        sample_period_s=1.024e-3,
        **_only(motion_spread_rel=0.005, idle_spread_W=0.1),
    )
    spreads, idles = [], []
    for sim in simulate_runs(config):
        run, dt = sim.run, sim.run.sample_period_s
        phases = {p["phase"]: p for p in sim.truth["phases"] if p["step"] in (0, 1)}
        cut = {
            k: slice(round(p["t_start_s"] / dt), round(p["t_end_s"] / dt))
            for k, p in phases.items()
        }
        idle_W = run.power_W[cut["idle"]].mean()
        cruise_W = run.power_W[cut["cruise"]].mean()
        v = sim.run.meta.speed_mps
        # cruise above the run's own idle, against the robot's 0.6 + 11.2 v W above idle
        spreads.append((cruise_W - idle_W) / (0.6 + 11.2 * v) - 1)
        idles.append(idle_W - 23.3)
    # 90 runs: a standard deviation from 90 draws is within 20% of sigma with p > 0.999
    # (chi-square, 89 degrees of freedom: 0.74-1.28 at 0.1%/99.9%); means within 4 se
    assert np.std(spreads, ddof=1) == pytest.approx(0.005, rel=0.2)
    assert np.std(idles, ddof=1) == pytest.approx(0.1, rel=0.2)
    assert abs(np.mean(spreads)) < 4 * 0.005 / np.sqrt(90)
    assert abs(np.mean(idles)) < 4 * 0.1 / np.sqrt(90)


def test_lab_realism_leaves_the_logs_as_they_were():
    config = dict(speeds_mps=(0.5,), trips=((2.0, 1),), repeats=1, sample_period_s=1.024e-3)
    (plain, *_) = simulate_runs(SimConfig(**config, mode_repeats=0))
    (lab, *_) = simulate_runs(SimConfig(**config, mode_repeats=0, **realism("lab")))
    assert np.array_equal(plain.run.power_W, lab.run.power_W)


def test_field_realism_changes_no_analyser_noise_draw():
    """Realism has its own random stream: with it, a log is the lab log plus the realism."""
    config = dict(speeds_mps=(0.5,), trips=((2.0, 1),), repeats=1, sample_period_s=1.024e-3)
    (lab, *_) = simulate_runs(SimConfig(**config, mode_repeats=0))
    (spread, *_) = simulate_runs(
        SimConfig(**config, mode_repeats=0, idle_spread_W=0.1, motion_spread_rel=0.0)
    )
    offset = spread.run.power_W - lab.run.power_W
    assert_allclose(offset, offset[0], atol=1e-12)
    assert offset[0] == pytest.approx(spread.truth["idle_offset_W"])


def test_unknown_realism_is_a_usage_error():
    with pytest.raises(UsageError, match="unknown realism"):
        realism("harsh")
