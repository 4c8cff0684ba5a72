"""A fitted idle_W checked against the logs' own standing power (drive/standing.py
`idle_against_standing`; docs/drive-model.md, "Current-only logs": issue 25, a confident wrong
answer is the worst outcome). A current proxy's force form tells idle from the rolling force by
its few standing windows only; where the moving windows hold power the form does not (here: an
arc that draws its full rolling force, where the form counts half), thousands of them put it
into the constant, and the fit reported an idle the standing samples contradict."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from wifibot_power.drive import fit_drive
from wifibot_power.drive.stats import drive_stats
from wifibot_power.run import Run, RunMeta

#: the simulated proxy's standing draw, rolling force and spin moment [W] (force form: u_0 F)
IDLE_W, ROLLING_W, SPIN_W = 10.0, 60.0, 100.0


def _run(
    k: int, arc_full_rolling: bool, seed: int = 0, stands: bool = True, noise_W: float = 2.0
) -> Run:
    """100 Hz: stand 2.5 s, straight 3 s (a speed per run), an arc 60 s (a rate of turn per
    run), a spin 4 s (another), stand 2.5 s: few standing windows against many moving. The
    proxy: idle, the rolling force while moving, the spin's moment spinning, half of it on an
    arc, and on an arc the rolling force in full (`arc_full_rolling`: the inner side still
    drives) or half (the force form's arc). `stands` False: it drives straight where it stood."""
    rng = np.random.default_rng(seed + 100 * k)
    period_s = 0.01
    arc_radps, spin_radps = 0.3 + 0.1 * k, 0.6 + 0.1 * k
    knots_t = [0, 2.5, 2.8, 5.5, 5.8, 65.5, 65.8, 69.5, 69.8, 72.3]
    speed_mps = 0.3 + 0.1 * k
    knots_v = [0, 0, speed_mps, speed_mps, speed_mps, speed_mps, 0, 0, 0, 0]
    knots_w = [0, 0, 0, 0, arc_radps, arc_radps, spin_radps, spin_radps, 0, 0]
    if not stands:  # moving from the first sample to the last
        knots_v[0], knots_v[-1] = speed_mps, speed_mps
    t = np.arange(0, 72.3, period_s)
    v, w = np.interp(t, knots_t, knots_v), np.interp(t, knots_t, knots_w)
    translating, turning = np.abs(v) > 1e-3, np.abs(w) > 1e-3
    arc = translating & turning
    rolling = ROLLING_W * np.where(arc & ~arc_full_rolling, 0.5, 1.0) * (translating | turning)
    moment = SPIN_W * np.where(arc, 0.5, 1.0) * turning
    power = IDLE_W + rolling + moment + rng.normal(0.0, noise_W, t.size)
    meta = RunMeta(
        run_id=f"r{k}",
        sample_period_s=period_s,
        extra={"surface": "floor", "voltage_assumed_V": "24 (nominal: motor currents only)"},
    )
    return Run(f"r{k}.csv", "wbpower-csv", meta, t, power, speed_mps=v, yaw_rate_radps=w)


def _fit(arc_full_rolling: bool):
    runs = [_run(k, arc_full_rolling) for k in range(6)]
    return fit_drive(runs), runs


def test_the_standing_power_is_the_standing_bins_mean_with_stops_as_clusters():
    from wifibot_power.drive.standing import standing_power, standing_stops

    runs = [_run(k, True) for k in range(6)]
    standing = standing_power([standing_stops(drive_stats(run)) for run in runs])
    # each run stands at its start and end: 12 stops, each read at the true idle (noise 2 W)
    assert standing.stops == 12
    assert abs(standing.mean_W - IDLE_W) < 0.5
    assert standing.se_W < 0.5


def test_an_idle_the_standing_samples_contradict_is_not_determined():
    model, _ = _fit(arc_full_rolling=True)
    reasons = [r for r in model.not_determined if r.startswith("idle_W: not determined")]
    assert "idle_W" not in model.terms, model.terms["idle_W"]
    assert len(reasons) == 1 and "standing power" in reasons[0], model.not_determined
    assert any(w.startswith("idle_W") and "standing still" in w for w in model.warnings)


def test_an_idle_the_standing_samples_confirm_is_reported():
    # the same robot whose arcs draw what the force form says: idle is the standing draw
    model, _ = _fit(arc_full_rolling=False)
    idle = model.terms["idle_W"]
    assert idle.ci95[0] <= IDLE_W <= idle.ci95[1], idle
    assert not any(r.startswith("idle_W") for r in model.not_determined)
    assert not any(w.startswith("idle_W") for w in model.warnings)


def _standing_W(stats) -> float:
    """The mean power of the bins that stand, with a second of standing either side (this
    file's own reading; standing.py `standing_power` is tested against it above)."""
    parts = []
    for s in stats:
        still = (np.abs(s.speed_mps) < 0.02) & (np.abs(s.yaw_rate_radps) < 0.05)
        reach = int(round(1.0 / s.bin_s))
        margin = np.convolve(~still, np.ones(2 * reach + 1), mode="same") == 0
        parts.append(s.power_W[margin & still])
    return float(np.mean(np.concatenate(parts)))


def test_a_proxys_idle_is_not_reported_when_the_logs_never_stand():
    # the force form's arcs exactly, so the fit's constant is right here (10 W): but nothing
    # in these logs measures the standstill current, and on BorealTC such a constant was 4-7
    # times the standing power
    model = fit_drive([_run(k, False, stands=False) for k in range(6)])
    assert "idle_W" not in model.terms, model.terms["idle_W"]
    assert any("no bin of these logs stands" in r for r in model.not_determined)
    # not measured, which is all these logs say: not "not the power they draw standing"
    (warning,) = [w for w in model.warnings if w.startswith("idle_W")]
    assert "is not measured: no bin of these logs stands" in warning
    assert "draw standing still" not in warning


DRIVE = Path(os.environ.get("WBPOWER_REAL_DRIVE") or "/work/real_drive") / "borealtc"


@pytest.mark.skipif(not DRIVE.is_dir(), reason=f"no converted BorealTC logs in {DRIVE}")
@pytest.mark.parametrize("surface", ["flooring", "asphalt", "ice", "snow"])
def test_a_real_proxys_idle_that_carries_the_moving_force_is_not_reported(surface):
    # `fit` of these folders gave idle_W 87-119 W with intervals clear of the logs' standing
    # power (16-24 W): such an idle is not the robot's standstill draw
    from wifibot_power.io import read_log

    runs = [read_log(path) for path in sorted((DRIVE / surface).rglob("*.csv.gz"))]
    model = fit_drive(runs)
    standing = _standing_W([drive_stats(run) for run in runs])
    assert standing < 30.0
    assert "idle_W" not in model.terms, (surface, model.terms["idle_W"], standing)
    assert any(r.startswith("idle_W: not determined") for r in model.not_determined)


VULPI = DRIVE.parent / "vulpi"


@pytest.mark.skipif(not VULPI.is_dir(), reason=f"no converted Vulpi logs in {VULPI}")
def test_a_real_proxy_that_never_stands_reports_no_idle():
    # `fit` of the whole Vulpi set gave idle_W 132 [71, 193] W from logs that never stand
    from wifibot_power.io import read_log

    runs = [read_log(path) for path in sorted(VULPI.rglob("*.csv.gz"))]
    model = fit_drive(runs)
    assert "idle_W" not in model.terms, model.terms["idle_W"]


def _stops_by_convolution(stats) -> tuple[np.ndarray, np.ndarray]:
    """The stops as idleproxy first wrote them (a convolution over each bin's neighbours):
    the reference the running count must equal."""
    from wifibot_power.drive.identify import MAX_LAG_S
    from wifibot_power.drive.windows import STANDING_MPS, STANDING_RADPS

    reach = int(round(MAX_LAG_S / stats.bin_s))
    with np.errstate(invalid="ignore"):
        still = (np.abs(stats.speed_mps) < STANDING_MPS) & (
            np.abs(stats.yaw_rate_radps) < STANDING_RADPS
        )
    still &= np.isfinite(stats.power_W)
    moving = np.concatenate((np.zeros(reach), ~still, np.zeros(reach)))
    stands = ~(np.convolve(moving, np.ones(2 * reach + 1), mode="valid") > 0)
    if not stands.any():
        return np.zeros(0, np.intp), np.zeros(0)
    label = np.cumsum(np.r_[stands[0], stands[1:] & ~stands[:-1]])[stands] - 1
    return np.bincount(label), np.bincount(label, weights=stats.power_W[stands])


@pytest.mark.parametrize("seed", range(6))
def test_a_runs_stops_are_the_convolutions_bin_for_bin(seed):
    """`standing_stops`' running count of moving neighbours finds the stops a convolution
    does, at the edges of a run too (short stops, motion in the first and last second,
    NaN drop-outs); fails when the count's window is a bin short on either side."""
    from wifibot_power.drive.standing import standing_stops

    rng = np.random.default_rng(seed)
    run = _run(seed % 3, False, seed, stands=bool(seed % 2))
    v = run.speed_mps.copy()
    for start in rng.integers(0, v.size - 300, 4):  # short stops and bursts of motion
        v[start : start + rng.integers(50, 250)] = 0.0 if rng.random() < 0.5 else 0.2
    v[rng.integers(0, v.size, 20)] = np.nan
    run = Run(
        run.file,
        run.format,
        run.meta,
        run.stamps_s,
        run.power_W,
        speed_mps=v,
        yaw_rate_radps=run.yaw_rate_radps,
    )
    stats = drive_stats(run)
    made = standing_stops(stats)
    bins, sums = _stops_by_convolution(stats)
    np.testing.assert_array_equal(made.bins, bins)
    np.testing.assert_array_equal(made.power_sum_W, sums)


def test_a_proxy_folder_is_fitted_without_reading_its_logs_again(tmp_path, monkeypatch):
    """The idle check's stops are made in the workers (`WorkerStats.standing`): a plain
    `fit_logs` of current-proxy logs, whose records leave the bins out, never reads a log
    again for them (it read all 71 BorealTC logs a second time). Noisy enough that no run
    keeps its bins for a lag search over the windows (`drive.sums.AT_RISK_SHARE`)."""
    from wifibot_power.fit import fit_logs
    from wifibot_power.pipeline.gather import ReadAgain

    for k in range(6):
        run = _run(k, True, noise_W=20.0)
        header = "".join(f"# {key}: {value}\n" for key, value in run.meta.extra.items())
        columns = np.column_stack((run.stamps_s, run.power_W, run.speed_mps, run.yaw_rate_radps))
        with open(tmp_path / f"r{k}.csv", "w") as f:
            f.write(f"# wbpower-log: 1\n# run_id: r{k}\n{header}")
            f.write("time_s,power_W,speed_mps,yaw_rate_radps\n")
            np.savetxt(f, columns, delimiter=",", fmt="%.6g")
    called = []
    monkeypatch.setattr(ReadAgain, "__call__", lambda self: called.append(self))
    result = fit_logs([tmp_path], jobs=1)
    assert result.drive is not None and result.drive.power_kind == "current_proxy"
    assert called == []
    assert any("idle_W" in r and "standing power" in r for r in result.drive.not_determined)


def _cut(run: Run, keep_s: float) -> Run:
    keep = run.stamps_s < keep_s
    return Run(
        run.file,
        run.format,
        run.meta,
        run.stamps_s[keep],
        run.power_W[keep],
        speed_mps=run.speed_mps[keep],
        yaw_rate_radps=run.yaw_rate_radps[keep],
    )


def test_a_set_that_stood_once_is_still_checked():
    """Five runs that never stand and one cut after its first stop (30 bins standing at
    10 W): the fit's constant, 55 W from the moving windows, is withheld against that one
    stop's reading (it was reported, with an interval excluding 10 W, when one stop meant
    no check)."""
    from wifibot_power.drive.standing import standing_power, standing_stops

    runs = [_run(k, True, stands=False) for k in range(5)] + [_cut(_run(5, True), 66.0)]
    standing = standing_power([standing_stops(drive_stats(run)) for run in runs])
    assert standing.stops == 1 and abs(standing.mean_W - IDLE_W) < 0.5
    model = fit_drive(runs)
    assert "idle_W" not in model.terms
    assert any("idle_W" in r and "one stop" in r for r in model.not_determined)


def test_exact_logs_give_no_difference_to_judge_and_no_crash():
    """Both standard errors 0 (noise-free idle and standing readings): no check, no
    ZeroDivisionError from Welch's degrees of freedom; with only the standing one 0, the
    test rests on the idle's (a difference of 2 W at a standard error of 0.1 W is flagged)."""
    from wifibot_power.drive.identify import Identified
    from wifibot_power.drive.standing import Standing, idle_against_standing

    def fitted(idle_W: float, variance: float) -> Identified:
        return Identified(
            columns=("idle_W", "rolling_W_per_mps[floor]"),
            kept=np.array([True, True]),
            coef=np.array([idle_W, 60.0]),
            cov=np.diag([variance, 1.0]),
            dof=5,
            clusters=6,
            lag_bins=0.0,
            not_determined=(),
            residual_W=None,
        )

    exact = fitted(IDLE_W + 2.0, 0.0)
    assert idle_against_standing(exact, Standing(IDLE_W, 0.0, 100, 3), True) == (exact, None)
    _, warning = idle_against_standing(
        fitted(IDLE_W + 2.0, 0.01), Standing(IDLE_W, 0.0, 100, 3), True
    )
    assert warning is not None and "20.0 standard errors apart" in warning


def test_drop_outs_of_the_power_alone_leave_a_stop_standing():
    """A stop whose power drops out every 0.5 s (speed logged: the robot known still) is
    still a stop: its logged bins are its reading (they were counted as motion, and a
    neighbourhood of a second either side of each drop-out with them: no bin stood)."""
    from wifibot_power.drive.standing import standing_stops

    run = _run(0, False)
    standing_at = run.stamps_s < 2.5  # the first stop, 2.5 s
    power = run.power_W.copy()
    power[standing_at & (np.round(run.stamps_s * 100) % 50 == 0)] = np.nan
    run = Run(
        run.file,
        run.format,
        run.meta,
        run.stamps_s,
        power,
        speed_mps=run.speed_mps,
        yaw_rate_radps=run.yaw_rate_radps,
    )
    stops = standing_stops(drive_stats(run))
    clean = standing_stops(drive_stats(_run(0, False)))
    assert stops.bins.size == clean.bins.size and stops.bins[0] > 0
    assert abs(stops.power_sum_W[0] / stops.bins[0] - IDLE_W) < 1.0
