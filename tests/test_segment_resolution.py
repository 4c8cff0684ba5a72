"""Durations of phases a few samples long are known to one sample period (issue 26,
"exact-looking numbers"; docs/segmentation.md, "Resolution")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wifibot_power.segment.resolution import quantized_durations

PERIOD_S = 1 / 6.5  # the skid-steer field robot's logger: 0.154 s a sample


def test_the_exact_looking_t_acc_interval_is_widened_to_a_sample_period() -> None:
    """Issue 26: t_acc = 0.154 s, CI [0.154, 0.154], slope 0.000, no warning, from runs
    whose accelerations are all one sample long. The fit's own least squares (`fit_line`)
    gives that zero-width interval; `Quantized` widens it to ± one period and words the
    warning."""
    from wifibot_power.fit import fit_line

    speed = np.repeat([0.3, 0.6, 0.9, 1.2], 3)
    t_acc = np.full(speed.size, PERIOD_S)  # one sample each
    line = fit_line(speed, t_acc)
    assert line.intercept_ci95[1] - line.intercept_ci95[0] == pytest.approx(0.0, abs=1e-12)
    coarse = quantized_durations(t_acc, np.full(speed.size, PERIOD_S))
    assert coarse is not None and coarse.period_s == PERIOD_S and coarse.runs == speed.size
    low, high = coarse.floor_ci95(line.intercept, line.intercept_ci95)
    assert low <= line.intercept - PERIOD_S and high >= line.intercept + PERIOD_S
    assert high - low >= PERIOD_S  # never narrower than the sample period
    # the slope: each point ± 0.154 s over 0.9 m/s of speeds: ± 2 x 0.154 / 0.9 s per m/s
    s_low, s_high = coarse.floor_slope_ci95(line.slope, line.slope_ci95, speed)
    assert s_high - line.slope == pytest.approx(2 * PERIOD_S / 0.9)
    assert line.slope - s_low == pytest.approx(2 * PERIOD_S / 0.9)
    text = coarse.warning("t_acc")
    assert text.startswith("t_acc is quantized to the sample period: 12 run(s) hold phases of 1")
    assert "± 0.154 s" in text


@pytest.mark.parametrize("samples", [1, 2])
def test_phases_of_one_or_two_samples_are_quantized_and_longer_ones_not(samples: int) -> None:
    """A phase one or two samples long (alone among longer ones too) is quantized; phases of
    three samples or more are not: their scatter over runs shows their error."""
    periods = np.full(4, 0.01)
    assert quantized_durations(np.full(4, samples * 0.01), periods) is not None
    mixed = np.array([samples, 30, 40, 50]) * 0.01
    assert quantized_durations(mixed, periods).runs == 1
    assert quantized_durations(np.array([3, 30, 40, 50]) * 0.01, periods) is None
    # NaN durations (runs without an acceleration) are left out; none left, none quantized
    assert quantized_durations(np.array([np.nan, np.nan]), 0.01) is None


def test_a_wide_interval_is_kept_and_a_nan_one_stays_nan() -> None:
    coarse = quantized_durations(np.array([0.01]), 0.01)
    assert coarse.floor_ci95(0.5, (0.1, 0.9)) == (0.1, 0.9)
    low, high = coarse.floor_ci95(0.5, (math.nan, math.nan))
    assert math.isnan(low) and math.isnan(high)
    # a single speed: no slope to bound
    assert coarse.floor_slope_ci95(0.0, (-1e-9, 1e-9), np.array([0.5, 0.5])) == (-1e-9, 1e-9)


def test_a_power_only_6_5_hz_run_has_one_sample_accelerations() -> None:
    """Where the quantized t_acc comes from: segmentation from power of a 6.5 Hz log puts
    each acceleration (0.3 s of ramp) in one or two samples; `quantized_durations` of the
    accel phases says so."""
    from wifibot_power.run import Run, RunMeta
    from wifibot_power.segment import segment_run

    rng = np.random.default_rng(0)
    pieces = [(10, 28.0), (0.3, 200.0), (8, 150.0), (10, 28.0)]
    power = np.concatenate([np.full(round(s / PERIOD_S), p) for s, p in pieces])
    power += rng.normal(0, 2.0, power.size)
    meta = RunMeta(run_id="slow", mode="motion", speed_mps=1.0, steps=1, sample_period_s=PERIOD_S)
    seg = segment_run(Run("slow.csv", "canonical", meta, None, power))
    (accel,) = seg.of("accel")
    assert accel.i_end - accel.i_start <= 2
    assert quantized_durations(np.array([accel.duration_s]), PERIOD_S) is not None
