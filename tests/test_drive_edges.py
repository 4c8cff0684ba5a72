"""The inertial regressors' edge speeds, the speed noise they are corrected for, and the
|x| of a noisy window mean (drive/regressors.py; docs/drive-model.md, "Validation")."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from wifibot_power.drive import fit_drive
from wifibot_power.drive.regressors import (
    ZERO_READING,
    _denoised_abs,
    _edge_means,
    calibrated,
    edge_half_bins,
    edge_kernel,
    edge_speeds,
    sample_gain,
    speed_noise_per_sample,
)
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free


def _cubic_bins(bins: int, bin_s: float):
    """Bin means of v(t) = 0.3 + 0.8 t - 0.5 t^2 + 0.09 t^3 (exact: its integral over each
    bin over the bin), and v itself."""

    def integral(t):
        return 0.3 * t + 0.4 * t**2 - 0.5 * t**3 / 3 + 0.09 * t**4 / 4

    edges_s = np.arange(bins + 1) * bin_s
    means = np.diff(integral(edges_s)) / bin_s
    return means, lambda t: 0.3 + 0.8 * t - 0.5 * t**2 + 0.09 * t**3


def test_edge_speed_is_exact_for_a_cubic_speed():
    # Richardson's (4 A(w) - A(2w)) / 3 of bin means is exact for a cubic speed; a box mean
    # (the former edge speed) is off by v'' w^2 / 24: a corner smeared into the next window
    means, v = _cubic_bins(200, 0.05)
    edges = np.arange(10, 190, 10)
    for half in (1, 2, 4):
        assert_allclose(edge_speeds(means, edges, half), v(edges * 0.05), atol=1e-12)
    assert np.max(np.abs(_edge_means(means, edges, 2) - v(edges * 0.05))) > 1e-4


def test_edge_kernel_is_the_edge_speed():
    rng = np.random.default_rng(3)
    speed = rng.standard_normal(400)
    for half in (1, 3):
        weights, centres = edge_kernel(half)
        edge = 200
        by_kernel = weights @ speed[(edge + centres - 0.5).astype(int)]
        assert_allclose(edge_speeds(speed, np.array([edge]), half)[0], by_kernel, rtol=1e-12)
        assert_allclose(weights.sum(), 1.0, rtol=1e-12)


def test_noise_estimate_of_a_quantized_speed():
    # 1 cm/s of white noise quantized to 2 cm/s steps on a speed that ramps and holds: the
    # noise is sqrt(0.01^2 + 0.02^2 / 12) = 0.0115 (quantization adds step^2/12); the median
    # of successive differences (stats.py) reads one step, 0.021
    rng = np.random.default_rng(0)
    t = np.arange(20000) * 0.05
    true = np.clip(np.abs(((t / 6.0) % 2.0) - 1.0) * 3.0 - 0.5, 0.0, 1.2)
    speed = np.round((true + 0.01 * rng.standard_normal(t.size)) / 0.02) * 0.02
    assert_allclose(speed_noise_per_sample(speed, 1.0), np.sqrt(1e-4 + 4e-4 / 12), rtol=0.04)
    # a fast logger's bins are means of their samples: the noise is per sample (the bins'
    # noise is a third of the 20 Hz one's here, so the ramps' corners, not clipped, weigh
    # more: 6% high)
    fast = true.repeat(10) + 0.01 * rng.standard_normal(t.size * 10)
    bins = fast.reshape(-1, 10).mean(axis=1)
    assert_allclose(speed_noise_per_sample(bins, 10.0), 0.01, rtol=0.08)


def test_sample_gain_of_a_slow_logger_interpolated():
    # a 6.5 Hz logger's bins interpolate its samples (stats.py `_held`): the edge speed's
    # noise over a sample's is the sum of its squared weights on the samples
    rng = np.random.default_rng(1)
    period_s, bin_s = 1 / 6.5, 0.05
    samples = rng.standard_normal(40000)
    middles = (np.arange(samples.size) + 0.5) * period_s
    centres = (np.arange(int(middles[-1] / bin_s) - 2) + 0.5) * bin_s
    bins = np.interp(centres, middles, samples)
    per_bin = bin_s / period_s
    half = edge_half_bins(per_bin)
    edges = np.arange(100, bins.size - 100, 10)
    weights, kernel_centres = edge_kernel(half)
    predicted = np.sqrt(sample_gain(weights, kernel_centres, per_bin))
    assert_allclose(edge_speeds(bins, edges, half).std(), predicted, rtol=0.03)
    assert_allclose(speed_noise_per_sample(bins, per_bin), 1.0, rtol=0.03)


def test_calibration_undoes_the_attenuation_of_a_noisy_regressor():
    # y = 30 x with x sparse (speeding up in a third of the windows), read as x + u with a
    # known, unequal noise variance: least squares on the read x is biased towards 0 by
    # sum(u^2) / sum(x^2 + u^2); on the calibrated one it is not
    rng = np.random.default_rng(2)
    x = np.where(rng.random(200000) < 0.3, rng.exponential(0.4, 200000), 0.0)
    noise_var = np.where(rng.random(x.size) < 0.5, 0.01, 0.04)
    read = x + np.sqrt(noise_var) * rng.standard_normal(x.size)
    y = 30.0 * x + rng.standard_normal(x.size)
    naive = read @ y / (read @ read)
    up, _ = calibrated(read, -read, noise_var, noise_var)
    assert naive < 30 * 0.9
    assert_allclose(up @ y / (up @ up), 30.0, rtol=0.01)


def test_denoised_abs_is_unbiased_at_zero():
    rng = np.random.default_rng(4)
    z = rng.standard_normal(2_000_000)
    assert_allclose(np.mean(np.sqrt(np.maximum(z * z - 1, 0))), ZERO_READING, atol=0.001)
    s = 0.002
    assert abs(np.mean(_denoised_abs(s * z, s))) < 0.002 * s
    # far from 0 it reads |x| (the root's own bias, -s^2 / 2|x|, is 2e-6 here)
    assert_allclose(np.mean(_denoised_abs(1.0 + s * z, s)), 1.0, atol=1e-5)


def test_effective_mass_from_exact_logs_is_not_smeared():
    # a 20 Hz log with nothing but the logger's own averaging (no noise, quantization,
    # drop-outs or gain): the edge speeds' 200 ms box mean smeared the speed profile's
    # corners into the next window and read 30.5-30.7 kg for 30; extrapolated, within 0.1 kg
    off = dict.fromkeys(
        ("power_noise_W", "speed_noise_mps", "speed_step_mps", "yaw_noise_radps",
         "dropouts_per_min", "gain_spread"), 0.0,
    )  # fmt: skip
    for seed in (0, 1, 2):
        config = FreeDriveConfig(seed=seed, runs_per_surface=3, run_s=60.0, realism_overrides=off)
        model = fit_drive([as_run(r) for r in simulate_free(config)])
        assert abs(model.terms["effective_mass_kg"].value - 30.0) < 0.15, seed
        assert abs(model.terms["braking_mass_kg"].value - 10.0) < 0.05, seed
