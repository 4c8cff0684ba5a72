"""Validation of the drive model (docs/drive-model.md, "Validation"): prints the tables the docs
quote.

1. The simulator (`simulate --drive free`, drive/simulate.py) at field realism, 2 surfaces,
   12 runs of 90 s a seed, seeds 0..N-1 (default 20): how often each term's 95% interval
   holds its true value, the mean estimate beside the truth, the lag found; held-out run
   energy MAPE, median APE and how often the 90% intervals hold the measured energy.
2. Stress rows, same size, 10 seeds each: a 6.5 Hz logger with odometry-grade rate of turn
   (0.03 rad/s noise), and the lab (1 kHz, exact speed).
3. The paper's step runs (sample_logs/): the speed is their phases' trapezoid
   (stats.speed_from_phases); the drive model's mean acceleration and cruise power at each
   speed beside the paper model's lines P_acc(v), P_v(v) fitted to the same logs, with
   intervals; held-out energy error beside the paper model's (diagnose's baseline).

    .venv/bin/python benchmarks/validate_drive.py [--seeds=N] [--no-steps]

About 3 minutes for 20 seeds on 2 shared cores.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT)]

from wifibot_power.drive import fit_drive  # noqa: E402
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free  # noqa: E402


def _terms(model, config):
    truth = config.truth()
    for name, value in truth["terms"].items():
        yield name, value, model.terms.get(name)
    for surface, named in truth["surfaces"].items():
        for name, value in named.items():
            yield f"{name}[{surface}]", value, model.surfaces.get(surface, {}).get(name)


def simulator_suite(label: str, seeds: range, **config_args) -> None:
    hits: dict[str, list[bool]] = {}
    values: dict[str, list[float]] = {}
    truth_of: dict[str, float] = {}
    lags, mape, median, coverage, n_trips = [], [], [], [], []
    started = time.perf_counter()
    for seed in seeds:
        config = FreeDriveConfig(seed=seed, runs_per_surface=6, run_s=90.0, **config_args)
        model = fit_drive([as_run(r) for r in simulate_free(config)])
        for name, true, fitted in _terms(model, config):
            truth_of[name] = true
            inside = fitted is not None and fitted.ci95[0] <= true <= fitted.ci95[1]
            hits.setdefault(name, []).append(inside)
            values.setdefault(name, []).append(fitted.value if fitted else np.nan)
        lags.append(model.lag_s)
        mape.append(model.heldout.mape_pct)
        median.append(model.heldout.median_ape_pct)
        coverage.append(model.heldout.coverage_pi90_pct)
        n_trips.append(len(model.heldout.runs))
    took = time.perf_counter() - started
    print(f"\n## {label}: {len(seeds)} seeds x 12 runs of 90 s, {took:.0f} s\n")
    print("| term | true | mean estimate | sd over seeds | 95% interval holds truth |")
    print("|---|---:|---:|---:|---:|")
    for name, got in hits.items():
        estimates = np.array(values[name])
        print(
            f"| {name} | {truth_of[name]:g} | {np.nanmean(estimates):.3f} | "
            f"{np.nanstd(estimates, ddof=1):.3f} | {100 * np.mean(got):.0f}% "
            f"({sum(got)}/{len(got)}) |"
        )
    all_hits = np.concatenate([np.array(h) for h in hits.values()])
    print(f"| all terms | | | | {100 * all_hits.mean():.1f}% ({all_hits.sum()}/{all_hits.size}) |")
    print(
        f"\nlag found: {np.mean(lags):.3f} s (sd {np.std(lags, ddof=1):.3f}; true "
        f"{FreeDriveConfig().lag_s:g} s)"
    )
    print(
        f"held-out trips ({np.sum(n_trips)} over the seeds, K-fold by trip): MAPE "
        f"{np.mean(mape):.2f}% (seeds: {np.min(mape):.2f}-{np.max(mape):.2f}%), median APE "
        f"{np.mean(median):.2f}%, 90% intervals hold the measured energy in "
        f"{np.mean(coverage):.1f}% (seeds: {np.min(coverage):.0f}-{np.max(coverage):.0f}%)"
    )


def step_suite() -> None:
    from wifibot_power import diagnose_logs, fit_logs
    from wifibot_power.drive.profile import step_phase_powers
    from wifibot_power.io.discover import find_logs
    from wifibot_power.io.reader import read_log
    from wifibot_power.segment import segment_run

    logs = ROOT / "sample_logs"
    started = time.perf_counter()
    sources, _ = find_logs([logs])
    runs, segs = [], []
    for source in sources:
        run = read_log(source.path, overrides=source.read_overrides, origin=source.origin)
        if run.meta.mode != "motion":
            continue
        runs.append(run)
        segs.append(segment_run(run))
    model = fit_drive(runs, segs)
    paper = fit_logs([logs])
    table, _ = paper.tables()
    motion = table[table["usable"] & (table["mode"] == "motion")]
    print(f"\n## The paper's step runs (sample_logs): {len(runs)} motion runs, "
          f"{time.perf_counter() - started:.0f} s\n")  # fmt: skip
    print("drive model terms (speed = the phases' trapezoid):")
    for name, term in model.terms.items():
        print(f"- {name}: {term.value:.3f} [{term.ci95[0]:.3f}, {term.ci95[1]:.3f}] {term.unit}")
    for reason in model.not_determined:
        print(f"- not determined: {reason}")
    print(f"- lag {model.lag_s:.3f} s; warnings: {'; '.join(model.warnings) or 'none'}")
    print(
        "\n| v [m/s] | t_acc [s] | P_acc paper fit [W] | P_acc drive [W] | within | "
        "P_v paper fit [W] | P_v drive [W] | within |"
    )
    print("|---:|---:|---:|---:|:---:|---:|---:|:---:|")
    for speed in sorted(motion["speed_mps"].round(2).unique()):
        rows = motion[motion["speed_mps"].round(2) == speed]
        t_acc = float(rows["t_acc_s"].mean())
        drive = step_phase_powers(model, float(speed), t_acc)
        cells = [f"{speed:g}", f"{t_acc:.2f}"]
        for phase, column, line in (
            ("accel", "accel_mean_power_W", paper.model.accel),
            ("cruise", "cruise_mean_power_W", paper.model.cruise),
        ):
            low, high = _line_band(motion["speed_mps"], motion[column], float(speed))
            value, (d_low, d_high) = drive[phase]
            overlap = d_low <= high and low <= d_high
            cells += [
                f"{line.at(float(speed)):.2f} [{low:.2f}, {high:.2f}]",
                f"{value:.2f} [{d_low:.2f}, {d_high:.2f}]",
                "yes" if overlap else "**no**",
            ]
        print("| " + " | ".join(cells) + " |")
    held = model.heldout
    baseline = diagnose_logs([logs])
    # like with like: the drive model's held-out error in J over each run's motion energy
    # (idle excluded), the denominator of the paper model's error
    motion_J = dict(zip(motion["run_id"], motion["motion_energy_J"], strict=True))
    over_motion = [
        abs(r.measured_J - r.predicted_J) / motion_J[r.run_id] * 100
        for r in held.runs
        if r.run_id in motion_J
    ]
    print(
        f"\nheld-out energy error: drive model MAPE {held.mape_pct:.2f}% (median "
        f"{held.median_ape_pct:.2f}%, {len(held.runs)} trips incl. idle, 90% intervals hold "
        f"{held.coverage_pi90_pct:.0f}%); paper model (diagnose baseline, motion energy per "
        f"run) MAPE {baseline.baseline_mape_pct:.2f}%; the drive model's held-out error over "
        f"each run's motion energy: MAPE {np.mean(over_motion):.2f}% ({len(over_motion)} runs)"
    )


def _line_band(speed, power, at: float) -> tuple[float, float]:
    """The 95% interval of the least-squares line's mean at `at` (P = a + b v)."""
    from wifibot_power.stats import t_quantile

    x = np.asarray(speed, float)
    y = np.asarray(power, float)
    X = np.column_stack((np.ones_like(x), x))
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    residual = y - X @ coef
    dof = x.size - 2
    cov = residual @ residual / dof * np.linalg.inv(X.T @ X)
    g = np.array([1.0, at])
    half = t_quantile(0.975, dof) * float(np.sqrt(g @ cov @ g))
    mid = float(g @ coef)
    return mid - half, mid + half


def main(argv: list[str]) -> None:
    seeds = 20
    for arg in argv:
        if arg.startswith("--seeds="):
            seeds = int(arg.split("=", 1)[1])
    simulator_suite("Field realism (20 Hz logger)", range(seeds), realism="field")
    if "--no-stress" not in argv:
        slow = {"sample_period_s": 1 / 6.5, "yaw_noise_radps": 0.03}
        simulator_suite(
            "Stress: 6.5 Hz logger, odometry-grade rate of turn",
            range(100, 100 + max(seeds // 2, 3)),
            realism="field",
            realism_overrides=slow,
        )
        simulator_suite("Lab (1 kHz)", range(200, 200 + max(seeds // 4, 3)), realism="lab")
    if "--no-steps" not in argv:
        step_suite()


if __name__ == "__main__":
    main(sys.argv[1:])
