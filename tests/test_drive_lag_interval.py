"""The lag's 95% interval (drive/laginterval.py; docs/drive-model.md, "The lag's interval"):
a cluster bootstrap of the lag search, `lag_ci95_s` beside `lag_s`, and a lag the interval
leaves open reported as not determined (cli.md, "The drive model": never a number that only
looks exact)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose

from wifibot_power.cli.fit_tables import _lag_said
from wifibot_power.drive import fit_drive
from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.laginterval import LagInterval, lag_interval, searches
from wifibot_power.drive.model import DriveModel, fit_drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats
from wifibot_power.run import Run, RunMeta


def _lag_entries(model: DriveModel) -> list[str]:
    return [reason for reason in model.not_determined if reason.startswith("lag_s:")]


@pytest.fixture(scope="module")
def sharp_model() -> DriveModel:
    """Free driving at field realism (starts, stops, speeding up: the lag is timed by every
    change), 12 runs; the true lag 0.2 s."""
    config = FreeDriveConfig(seed=7, runs_per_surface=6, run_s=90.0, realism="field")
    return fit_drive([as_run(r) for r in simulate_free(config)])


def test_sharp_lag_gets_a_narrow_interval_holding_the_truth(sharp_model):
    low, high = sharp_model.lag_ci95_s
    assert low <= FreeDriveConfig().lag_s <= high
    assert low <= sharp_model.lag_s <= high
    assert high - low < 0.02  # a tenth of the lag (the simulator's: ~0.004 s)
    assert _lag_entries(sharp_model) == []
    said = _lag_said(sharp_model.summary())
    assert said.startswith(f"{sharp_model.lag_s:.2f} s [") and "not determined" not in said


def _steady_run(k: int) -> Run:
    """20 Hz, 60 s at one speed from the first sample to the last (no start from rest, no
    change of speed): nothing times the power against the speed. Power 10 + 20 v + 8 v^2 W
    and 1 W of noise."""
    rng = np.random.default_rng(k)
    t = np.arange(0, 60.0, 0.05)
    v = np.full(t.size, 0.3 + 0.1 * k)
    power = 10 + 20 * v + 8 * v**2 + rng.normal(0.0, 1.0, t.size)
    meta = RunMeta(run_id=f"steady{k}", sample_period_s=0.05, extra={"surface": "floor"})
    return Run(f"steady{k}.csv", "wbpower-csv", meta, t, power, speed_mps=v, yaw_rate_radps=0 * t)


def test_flat_criterion_makes_the_lag_not_determined():
    model = fit_drive([_steady_run(k) for k in range(12)])
    low, high = model.lag_ci95_s
    # the search's minimum is noise: the replicates' spread over the grid
    assert high - low > 0.5
    [entry] = _lag_entries(model)
    assert "not determined" in entry and f"{model.lag_s:.2f} s" in entry
    said = _lag_said(model.summary())
    assert "not determined" in said and f"[{low:.2f}, {high:.2f}]" in said


def test_round_trip_and_older_model_json(sharp_model):
    data = json.loads(json.dumps(sharp_model.to_json()))
    assert data["lag_ci95_s"] == list(sharp_model.lag_ci95_s)
    again = DriveModel.from_json(data)
    assert again.lag_ci95_s == sharp_model.lag_ci95_s
    assert again.summary() == sharp_model.summary()
    # a model.json written before the interval: loads, no interval, predicts the same
    del data["lag_ci95_s"]
    older = DriveModel.from_json(data)
    assert older.lag_ci95_s is None
    assert older.summary()["lag_ci95_s"] is None
    assert older.coef == again.coef and older.lag_s == again.lag_s
    assert _lag_said(older.summary()) == f"{older.lag_s:.2f} s"


def _grams(true_lag: int, clusters: int = 6, seed: int = 0, noise: float = 0.0) -> FoldGrams:
    """Per-cluster sums of windows whose power is 10 + 30 a v `true_lag` bins after a smooth
    speed (a few sinusoids), read at the whole lags 0..8, 1 W of noise; `noise`: the sd of
    white noise on the a v column as read, calibrated as regressors.py does (its share of the
    column's sum of squares: gram.py `corrected_gram`)."""
    rng = np.random.default_rng(seed)
    n, dt, lags = 3000, 0.05, np.arange(9)
    xx, xy, yy, count, said = [], [], [], [], []
    for _ in range(clusters):
        freq, phase = rng.uniform(0.1, 0.5, 5)[:, None], rng.uniform(0, 6.3, 5)[:, None]
        amp = rng.uniform(0.1, 0.3, 5)[:, None]

        def av(t, freq=freq, phase=phase, amp=amp):
            v = 0.5 + np.sum(amp * np.sin(2 * np.pi * freq * t + phase), axis=0)
            a = np.sum(amp * 2 * np.pi * freq * np.cos(2 * np.pi * freq * t + phase), axis=0)
            return v * a

        t = np.arange(n) * dt
        read = av(t) + noise * rng.standard_normal(n)
        reliability = 1.0 - n * noise**2 / float(read @ read)
        X = np.column_stack((np.ones(n), reliability * read))
        said.append([0.0, (1.0 - reliability) * float(X[:, 1] @ X[:, 1])])
        Y = np.column_stack(
            [10 + 30 * av(t + (lag - true_lag) * dt) + rng.normal(0, 1, n) for lag in lags]
        )
        xx.append(X.T @ X)
        xy.append(X.T @ Y)
        band = np.zeros((2, lags.size))
        band[0], band[1, :-1] = np.sum(Y * Y, axis=0), np.sum(Y[:, :-1] * Y[:, 1:], axis=0)
        yy.append(band)
        count.append(n)
    return FoldGrams(
        np.array(count), np.array(xx), np.array(xy), np.array(yy), lags, np.array(said)
    )


@pytest.mark.parametrize("true_lag", [0, 1, 4, 7, 8])  # an end, the parabola, the quartic
@pytest.mark.parametrize("noise", [0.0, 0.1])
def test_each_replicate_is_the_fits_own_lag_search(true_lag, noise):
    grams = _grams(true_lag, noise=noise)
    found, _ = grams.search(-1)
    assert abs(found - true_lag) < (0.1 if noise == 0 else 1.0)
    # every cluster once: the fit's search itself, whichever refinement it takes
    assert_allclose(searches(grams, np.ones((1, grams.folds))), [found], atol=1e-9)
    # a replicate is the search over the clusters it drew, counted as often
    weights = np.array([[2.0, 0, 1, 0, 3, 0], [0, 1, 1, 1, 1, 2]])
    for row, w in zip(searches(grams, weights), weights, strict=True):
        drawn = np.repeat(np.arange(grams.folds), w.astype(int))
        parts = (grams.count, grams.xx, grams.xy, grams.yy)
        alone = FoldGrams(*(a[drawn] for a in parts), grams.lags, grams.noise[drawn])
        assert_allclose(row, alone.search(-1)[0], atol=1e-9)


def test_interval_and_its_rules():
    grams = _grams(4)
    found = grams.search(-1)[0]
    sharp = lag_interval(grams, found, 0.05)
    low, high = sharp.ci95_s
    assert low <= 0.2 <= high and high - low < 0.05 and sharp.determined
    grid = (0.0, 1.0)
    wide = LagInterval(0.6, (0.1, 0.8), grid, 1000, 12)
    assert not wide.determined and "spans 70%" in wide.reason()
    cut = LagInterval(0.6, (0.55, 1.0), grid, 1000, 12)
    assert not cut.determined and "reaches the longest lag tried" in cut.reason()
    at_zero = LagInterval(0.0, (0.0, 0.1), grid, 1000, 12)  # 0 is physics' bound: determined
    assert at_zero.determined and at_zero.reason() is None
    one = FoldGrams(*(a[:1] for a in (grams.count, grams.xx, grams.xy, grams.yy)), grams.lags)
    alone = lag_interval(one, found, 0.05)
    assert not alone.determined and "no interval (1 cluster:" in alone.reason()
    none = FoldGrams(*(a[:0] for a in (grams.count, grams.xx, grams.xy, grams.yy)), grams.lags)
    unsearched = lag_interval(none, 0.0, 0.05)
    assert "not searched" in unsearched.reason() and "minimum" not in unsearched.reason()


def test_lag_at_the_grids_first_lag_reaches_half_a_bin():
    # every replicate's search ends at lag 0, where it is not refined: the interval says the
    # half bin it is known to, not [0, 0]
    grams = _grams(0)
    found = grams.search(-1)[0]
    assert found == 0.0
    low, high = lag_interval(grams, found, 0.05).ci95_s
    assert low == 0.0 and 0.025 <= high < 0.1


def test_interval_is_the_bootstraps_percentiles_widened_for_few_clusters():
    # 5 clusters: t(0.975, 4) = 2.776 (Student's table) over z = 1.960, x sqrt(5/4) = 1.584
    grams = _grams(4, clusters=5)
    found = grams.search(-1)[0]
    draws = np.random.default_rng(0).multinomial(5, np.full(5, 0.2), size=1000).astype(float)
    low, high = np.quantile(searches(grams, draws), [0.025, 0.975])
    assert low <= found <= high
    widen = 2.776 / 1.960 * np.sqrt(5 / 4)
    got = lag_interval(grams, found, 1.0, seed=0).ci95_s
    assert_allclose(
        (found - got[0], got[1] - found), widen * np.array([found - low, high - found]), rtol=1e-3
    )


def test_interval_from_the_windows_is_the_one_from_the_sums():
    # fit_drive_stats(direct=True) bootstraps sums made from the windows (laginterval.py
    # `cluster_grams_of_windows`), the fit the workers' per-trip sums: the same numbers
    config = FreeDriveConfig(seed=3, runs_per_surface=3, run_s=60.0, realism="field")
    stats = [drive_stats(as_run(r)) for r in simulate_free(config)]
    from_sums, from_windows = fit_drive_stats(stats), fit_drive_stats(stats, direct=True)
    assert_allclose(from_windows.lag_s, from_sums.lag_s, atol=1e-9)
    assert_allclose(from_windows.lag_ci95_s, from_sums.lag_ci95_s, atol=1e-9)
    assert from_sums.lag_ci95_s[1] > from_sums.lag_ci95_s[0]


def test_a_replicate_with_collinear_columns_is_searched_as_the_fit_searches_it():
    # one column twice (one speed only makes |v| and v^2 one regressor): the Gram is singular,
    # the search's pseudo-inverse is taken (not the plain inverse), the same lag
    grams = _grams(4)
    G = grams.folds
    xx = np.zeros((G, 3, 3))
    xx[:, :2, :2] = grams.xx
    xx[:, 2, :2] = xx[:, :2, 2] = grams.xx[:, 1]
    xx[:, 2, 2] = grams.xx[:, 1, 1]
    xy = np.concatenate([grams.xy, grams.xy[:, 1:2]], axis=1)
    twice = FoldGrams(grams.count, xx, xy, grams.yy, grams.lags)
    found = twice.search(-1)[0]
    assert abs(found - 4) < 0.1
    assert_allclose(searches(twice, np.ones((1, G))), [found], atol=1e-9)


def test_the_terms_figure_says_the_lag_as_fit_does(sharp_model):
    """The terms figure's title gave the lag as a bare number ("(lag 0.61 s)") where `fit`
    says it is not determined: both now read `drive.model.lag_said`."""
    pytest.importorskip("matplotlib")
    from wifibot_power.figures.drive_terms import drive_terms_figure

    low, high = sharp_model.lag_ci95_s
    sharp = drive_terms_figure(sharp_model).get_suptitle()
    assert f"(lag {sharp_model.lag_s:.2f} s [{low:.2f}, {high:.2f}])" in sharp
    flat_model = fit_drive([_steady_run(k) for k in range(12)])
    flat = drive_terms_figure(flat_model).get_suptitle()
    assert f"(lag {flat_model.lag_s:.2f} s, not determined)" in flat


def test_no_interval_from_too_few_searched_replicates_says_so():
    """Review: 2 clusters whose replicates could not be searched were said to have "2
    cluster: at least 2 are needed"; now the replicates are named."""
    from wifibot_power.drive.laginterval import LagInterval

    few = LagInterval(0.1, (np.nan, np.nan), (0.0, 1.0), replicates=0, clusters=2)
    assert not few.determined
    assert "only 0 bootstrap replicate(s) of 2 clusters" in few.reason()
    one = LagInterval(0.1, (np.nan, np.nan), (0.0, 1.0), replicates=0, clusters=1)
    assert "1 cluster: at least 2 are needed" in one.reason()
