"""What `diagnose` does for speed gives the answers it gave before (docs/diagnose.md, "Speed").

The statistics written out instead of importing scipy.stats and scipy.optimize (a second and
a half of every run) are checked against those libraries, bit for bit; the faster refinement
of the within-cruise sinusoid against the sines and cosines it replaced; the one cumulative
sum shared by the per-run row and the trace statistics against each made on its own; and
`report`, which summarises runs in its own worker, against `diagnose`'s summary.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import optimize
from scipy import stats as scipy_stats
from test_diagnose import GRID

from wifibot_power import diagnose, report
from wifibot_power.causes import thermal_drift
from wifibot_power.fit import segment_checked
from wifibot_power.runtable import WindowEnergy, run_row
from wifibot_power.simulate import SimConfig, simulate_runs
from wifibot_power.stats import average_ranks, spearman
from wifibot_power.traces import bounded_minimum


def _same(a: float, b: float) -> bool:
    return a == b or (np.isnan(a) and np.isnan(b))


def test_spearman_is_scipys() -> None:
    """rho to the bit; the p-value to 1e-12 relative (measured within 6e-14: since the third
    session it comes from `stats.betainc`, not scipy.special's stdtr)."""
    rng = np.random.default_rng(0)
    for i in range(400):
        n = int(rng.integers(2, 40))
        x = rng.integers(0, 5, n).astype(float) if i % 2 else rng.normal(size=n)  # ties
        y = x.copy() if i % 7 == 0 else rng.normal(size=n)  # rho = 1: t infinite
        assert (average_ranks(x) == scipy_stats.rankdata(x)).all()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy warns on a constant input
            expected = scipy_stats.spearmanr(x, y)
        rho, p = spearman(x, y)
        assert _same(rho, float(expected[0])), (x, y)
        if np.isnan(p) or float(expected[1]) == 0.0:
            assert _same(p, float(expected[1])), (x, y)
        else:
            assert p == pytest.approx(float(expected[1]), rel=1e-12), (x, y)


def test_bounded_minimum_takes_scipys_steps() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(800) * 0.01
    for _ in range(60):
        hz = rng.uniform(0.5, 10)
        x = rng.uniform(0.2, 2) * np.sin(2 * np.pi * hz * t + rng.uniform(0, 6))
        x = x + rng.normal(0, 1, t.size)

        def f(freq: float, x: np.ndarray = x) -> float:
            return -float(np.abs(np.exp(-2j * np.pi * freq * t) @ x))

        step = 1 / (t.size * 0.01)
        low, high = max(hz - step, step / 4), hz + step
        expected = optimize.minimize_scalar(
            f, bounds=(low, high), method="bounded", options={"xatol": step * 1e-4}
        ).x
        assert bounded_minimum(f, low, high, xatol=step * 1e-4) == expected


def _sines_and_cosines(y: np.ndarray, t: np.ndarray, block_s: float) -> float:
    """The refinement as it was: every candidate's sine and cosine evaluated."""
    detrended = y - np.polyval(np.polyfit(t, y, 1), t)
    freqs = np.fft.rfftfreq(y.size, block_s)
    band = (freqs >= 0.1) & (freqs <= min(20.0, 0.5 / block_s))
    power = np.abs(np.fft.rfft(detrended)) ** 2
    peak = float(freqs[band][np.argmax(power[band])])
    step = float(freqs[1] - freqs[0])
    candidates = np.linspace(max(peak - step, step / 4), peak + step, 41)
    phase = 2 * np.pi * candidates[:, None] * t[None, :]
    sin, cos = np.sin(phase), np.cos(phase)
    ss, cc, sc = (sin * sin).sum(1), (cos * cos).sum(1), (sin * cos).sum(1)
    sy, cy = sin @ detrended, cos @ detrended
    det = ss * cc - sc**2
    explained = (cc * sy**2 - 2 * sc * sy * cy + ss * cy**2) / np.where(det > 0, det, np.inf)
    return float(candidates[np.argmax(explained)])


def test_the_within_cruise_sinusoid_is_the_one_sines_and_cosines_choose() -> None:
    rng = np.random.default_rng(3)
    for _ in range(300):
        n = int(rng.integers(20, 3000))
        t = (np.arange(n) - (n - 1) / 2.0) * 0.01
        y = 20 + rng.normal(0, rng.uniform(0.05, 2), n) + rng.normal(0, 0.01) * t
        y = y + rng.uniform(0, 2) * np.sin(2 * np.pi * rng.uniform(0.1, 15) * t + 1.0)
        columns = thermal_drift._strongest_sinusoid(y, t, 0.01)
        hz = _sines_and_cosines(y, t, 0.01)
        assert (columns[0] == np.sin(2 * np.pi * hz * t)).all()


@pytest.fixture(scope="module")
def segmented():
    config = SimConfig(**GRID, effects={"thermal_drift": 0.01, "cruise_ripple": 1.0}, seed=5)
    runs = [s.run for s in simulate_runs(config) if s.run.meta.mode == "motion"][:6]
    return [(run, segment_checked(run)) for run in runs]


def test_window_energies_are_the_windows_samples_summed(segmented) -> None:
    for run, segmentation in segmented:
        energy = WindowEnergy(run)
        n = run.samples
        # windows in any order, overlapping, empty, at the run's two ends
        starts = np.array([0, 1, n // 2, n // 3, n - 1, n, 7])
        ends = np.array([n, n // 2, n, n // 2 + 5, n, n, 7])
        direct_J = [
            float(run.power_W[a:b].sum(dtype=np.float64)) for a, b in zip(starts, ends, strict=True)
        ]
        got_J = energy.between(starts, ends)
        assert got_J == pytest.approx(np.array(direct_J) * run.sample_period_s, rel=1e-12)
        assert got_J[-1] == 0.0 and got_J[5] == 0.0
        # the row's phase energies come from it and are the phases' samples summed
        row = run_row(run, segmentation, energy)
        for phase, key in (("accel", "accel_energy_J"), ("cruise", "cruise_energy_J")):
            direct_J = sum(
                float(run.power_W[p.i_start : p.i_end].sum())
                for p in segmentation.phases
                if p.phase == phase
            )
            assert row[key] == pytest.approx(direct_J * run.sample_period_s, rel=1e-12)


def test_report_summarises_a_run_as_diagnose_does(segmented) -> None:
    """report's worker keeps what every cause's tests need (the thermal drift's within-run
    creep among them), as `diagnose` does, so its diagnosis is diagnose's."""
    for run, _ in segmented[:2]:
        row, _, summary, _ = report._work(run)
        expected = diagnose.summarize_run(run)
        assert summary.cause_columns == expected.cause_columns
        assert {"creep_s_tp", "creep_s_tt"} <= set(summary.cause_columns)
        alone = run_row(run, segment_checked(run))
        assert all(
            _same(row[k], alone[k]) if isinstance(alone[k], float) else row[k] == alone[k]
            for k in alone
        )
