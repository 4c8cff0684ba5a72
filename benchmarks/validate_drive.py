"""Validation of the drive model (docs/drive-model.md, "Validation"): prints the tables the docs
quote.

1. The simulator (`simulate --drive free`, drive/simulate.py) at field realism, 2 surfaces,
   12 runs of 90 s a seed. First the identification alone over seeds 0..M-1 (default 200:
   enough that 95% and 85% coverage are told apart, the Wilson interval of each share
   printed): how often each term's 95% interval holds its true value, its bias in standard
   errors and the seeds' spread over the mean standard error (a bias or a too narrow
   interval). Then the whole fit over seeds 0..N-1 (default 20): the same per term, the lag
   found, held-out run energy MAPE, median APE and how often the 90% intervals hold the
   measured energy.
2. Stress rows: a 6.5 Hz logger with odometry-grade rate of turn (0.03 rad/s noise; M/2 and
   N/2 seeds), and the lab (1 kHz, exact speed; M/2 and N/4 seeds). Each identification
   table ends with the lag's row: how often its 95% interval (drive/laginterval.py) holds
   the true lag, beside the joint sandwich's linearised interval.
3. The paper's step runs (sample_logs/): the speed is their phases' trapezoid
   (stats.speed_from_phases); the drive model's mean acceleration and cruise power at each
   speed beside the paper model's lines P_acc(v), P_v(v) fitted to the same logs, with
   intervals; held-out energy error beside the paper model's (diagnose's baseline).

    .venv/bin/python benchmarks/validate_drive.py [--seeds=N] [--many=M] [--no-stress]
        [--no-steps] [--write-docs]

`--write-docs` puts what it prints into docs/drive-model.md between its "simulator
validation" markers. About 6 minutes with the defaults on 2 shared cores.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT)]

from wifibot_power.drive import fit_drive  # noqa: E402
from wifibot_power.drive.identify import identify, lag_grid, lag_search  # noqa: E402
from wifibot_power.drive.laginterval import cluster_grams_of_windows, lag_interval  # noqa: E402
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free  # noqa: E402
from wifibot_power.drive.stats import drive_stats  # noqa: E402
from wifibot_power.drive.windows import assemble, run_windows  # noqa: E402
from wifibot_power.stats import t_quantile  # noqa: E402


def _terms(model, config):
    truth = config.truth()
    for name, value in truth["terms"].items():
        yield name, value, model.terms.get(name)
    for surface, named in truth["surfaces"].items():
        for name, value in named.items():
            yield f"{name}[{surface}]", value, model.surfaces.get(surface, {}).get(name)


def wilson95(hits: int, n: int) -> tuple[float, float]:
    """The Wilson score 95% interval of a proportion hits/n [%] (Wilson 1927; Brown, Cai &
    DasGupta 2001 recommend it over the normal approximation for n of tens to hundreds)."""
    z = 1.959964
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return 100 * (centre - half), 100 * (centre + half)


def _identified(config: FreeDriveConfig):
    """The identification alone (lag search and `identify`, as `fit_drive_stats` does it,
    without its held-out folds): per true term, (estimate, standard error, interval holds);
    and the lag's: the lag found [s], its 95% interval (laginterval.py: the cluster bootstrap
    of the search, clusters the runs), whether it is determined, and the half-width of the
    joint sandwich's (identify.py `lag_var_s2`, t(G - 1): the alternative it was chosen
    over)."""
    stats = [drive_stats(as_run(r)) for r in simulate_free(config)]
    runs = [run_windows(s) for s in stats]
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    lag_bins, _ = lag_search(runs, surfaces)
    windows = assemble(runs, lag_bins, surfaces)
    fitted = identify(windows, lag_bins, windows.run)
    truth = config.truth()
    true = dict(truth["terms"])
    for surface, named in truth["surfaces"].items():
        true.update({f"{name}[{surface}]": value for name, value in named.items()})
    se = fitted.half_width() / t_quantile(0.975, fitted.dof)
    ci = fitted.ci95()
    out = {}
    for j, column in enumerate(fitted.columns):
        if column in true:
            held = bool(ci[j, 0] <= true[column] <= ci[j, 1])
            out[column] = (true[column], float(fitted.coef[j]), float(se[j]), held)
    bin_s = runs[0].stats.bin_s
    grams = cluster_grams_of_windows(runs, surfaces, True, lag_grid(runs))
    lag = lag_interval(grams, lag_bins, bin_s)
    sandwich = t_quantile(0.975, fitted.dof) * np.sqrt(fitted.lag_var_s2)
    return out, (lag.lag_s, lag.ci95_s, lag.determined, sandwich)


def coverage_suite(out: list[str], label: str, seeds: range, **config_args) -> None:
    """How often each term's 95% interval holds its truth over many seeds, with the Wilson
    interval of that share, and whether a miss is a bias (mean - truth in standard errors)
    or a too narrow interval (the seeds' sd over the mean standard error)."""
    rows: dict[str, list[tuple[float, float, float, bool]]] = {}
    lags = []
    started = time.perf_counter()
    for seed in seeds:
        config = FreeDriveConfig(seed=seed, runs_per_surface=6, run_s=90.0, **config_args)
        found, lag = _identified(config)
        lags.append(lag)
        for name, row in found.items():
            rows.setdefault(name, []).append(row)
    took = time.perf_counter() - started
    out += [
        f"\n### {label}: identification over {len(seeds)} seeds x 12 runs of 90 s, {took:.0f} s\n",
        "| term | true | mean estimate | bias [SE] | sd over seeds / mean SE | "
        "95% interval holds truth | its 95% interval |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    every = []
    for name, values in rows.items():
        true, estimate, se, held = (np.array(v, dtype=float) for v in zip(*values, strict=True))
        hits = int(held.sum())
        every.append(held)
        low, high = wilson95(hits, held.size)
        bias_se = (np.nanmean(estimate) - true[0]) / np.nanmean(se)
        spread = np.nanstd(estimate, ddof=1) / np.nanmean(se)
        out.append(
            f"| {name} | {true[0]:g} | {np.nanmean(estimate):.3f} | {bias_se:+.2f} | "
            f"{spread:.2f} | {100 * hits / held.size:.0f}% ({hits}/{held.size}) | "
            f"{low:.0f}-{high:.0f}% |"
        )
    held = np.concatenate(every)
    low, high = wilson95(int(held.sum()), held.size)
    out.append(
        f"| all terms | | | | | {100 * held.mean():.1f}% ({int(held.sum())}/{held.size}) | "
        f"{low:.1f}-{high:.1f}% |"
    )
    out += lag_rows(lags, FreeDriveConfig().lag_s)


def lag_rows(lags: list, true_s: float) -> list[str]:
    """The lag found over the seeds and how often its 95% interval holds the true lag
    (laginterval.py's cluster bootstrap; and, beside it, the joint sandwich's linearised
    interval, lag +- t(G - 1) SE, the alternative it was chosen over)."""
    found = np.array([lag for lag, *_ in lags])
    low, high = (np.array([ci[k] for _, ci, *_ in lags]) for k in (0, 1))
    held = (low <= true_s) & (true_s <= high)
    undetermined = sum(not determined for *_, determined, _ in lags)
    sandwich = np.array([half for *_, half in lags])
    by_sandwich = np.abs(found - true_s) <= sandwich
    n = found.size
    a, b = wilson95(int(held.sum()), n)
    c, d = wilson95(int(by_sandwich.sum()), n)
    return [
        f"| lag_s (not in 'all terms') | {true_s:g} | {np.mean(found):.4f} | | | "
        f"{100 * held.mean():.0f}% ({int(held.sum())}/{n}) | {a:.0f}-{b:.0f}% |",
        f"\nlag found: {np.mean(found):.4f} s (sd over seeds {np.std(found, ddof=1):.4f}; true "
        f"{true_s:g} s); its 95% interval (cluster bootstrap of the search) holds it in "
        f"{int(held.sum())}/{n} seeds ({100 * held.mean():.1f}%, Wilson 95% {a:.0f}-{b:.0f}%), "
        f"median width {np.median(high - low):.4f} s, not determined in {undetermined}; the "
        f"joint sandwich's (lag ± t SE) would hold it in {int(by_sandwich.sum())}/{n} "
        f"({100 * by_sandwich.mean():.1f}%, {c:.0f}-{d:.0f}%), median width "
        f"{np.median(2 * sandwich):.4f} s",
    ]


def simulator_suite(out: list[str], label: str, seeds: range, **config_args) -> None:
    hits: dict[str, list[bool]] = {}
    values: dict[str, list[float]] = {}
    truth_of: dict[str, float] = {}
    lags, mape, median, coverage, n_trips = [], [], [], [], []
    lag_held, lag_width, lag_undetermined = [], [], 0
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
        lag_held.append(
            model.lag_ci95_s is not None
            and model.lag_ci95_s[0] <= config.lag_s <= model.lag_ci95_s[1]
        )
        lag_width.append(np.diff(model.lag_ci95_s)[0] if model.lag_ci95_s else np.nan)
        lag_undetermined += any(r.startswith("lag_s:") for r in model.not_determined)
        mape.append(model.heldout.mape_pct)
        median.append(model.heldout.median_ape_pct)
        coverage.append(model.heldout.coverage_pi90_pct)
        n_trips.append(len(model.heldout.runs))
    took = time.perf_counter() - started
    out += [
        f"\n### {label}: the whole fit over {len(seeds)} seeds x 12 runs of 90 s, {took:.0f} s\n",
        "| term | true | mean estimate | sd over seeds | 95% interval holds truth |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, got in hits.items():
        estimates = np.array(values[name])
        out.append(
            f"| {name} | {truth_of[name]:g} | {np.nanmean(estimates):.3f} | "
            f"{np.nanstd(estimates, ddof=1):.3f} | {100 * np.mean(got):.0f}% "
            f"({sum(got)}/{len(got)}) |"
        )
    all_hits = np.concatenate([np.array(h) for h in hits.values()])
    out.append(
        f"| all terms | | | | {100 * all_hits.mean():.1f}% ({all_hits.sum()}/{all_hits.size}) |"
    )
    trips = int(np.sum(n_trips))
    held = int(round(np.sum(np.array(coverage) / 100 * np.array(n_trips))))
    low, high = wilson95(held, trips)
    out += [
        f"\nlag found: {np.mean(lags):.3f} s (sd {np.std(lags, ddof=1):.3f}; true "
        f"{FreeDriveConfig().lag_s:g} s); its 95% interval (`lag_ci95_s`) holds it in "
        f"{sum(lag_held)}/{len(lag_held)} seeds, median width {np.nanmedian(lag_width):.4f} s, "
        f"not determined in {lag_undetermined}",
        f"held-out trips ({trips} over the seeds, K-fold by trip): MAPE "
        f"{np.mean(mape):.2f}% (seeds: {np.min(mape):.2f}-{np.max(mape):.2f}%), median APE "
        f"{np.mean(median):.2f}%, 90% intervals hold the measured energy of {held} "
        f"({100 * held / trips:.1f}%, Wilson 95% {low:.1f}-{high:.1f}%; seeds: "
        f"{np.min(coverage):.0f}-{np.max(coverage):.0f}%)",
    ]


def step_suite(out: list[str]) -> None:
    from wifibot_power import fit_logs
    from wifibot_power.diagnose.baseline import heldout_beside_paper

    say = out.append
    logs = ROOT / "sample_logs"
    started = time.perf_counter()
    result = fit_logs([logs])
    model = result.drive
    rows = result.drive_vs_paper()
    beside = heldout_beside_paper(result)
    say(f"\n## The paper's step runs (sample_logs): {model.n_runs} motion runs, "
          f"{time.perf_counter() - started:.0f} s\n")  # fmt: skip
    say("drive model terms (speed = the phases' trapezoid):")
    for name, term in model.terms.items():
        say(f"- {name}: {term.value:.3f} [{term.ci95[0]:.3f}, {term.ci95[1]:.3f}] {term.unit}")
    for reason in model.not_determined:
        say(f"- not determined: {reason}")
    say(f"- lag {model.lag_s:.3f} s; warnings: {'; '.join(model.warnings) or 'none'}")
    say(
        "\n| v [m/s] | t_acc [s] | P_acc paper fit [W] | P_acc drive [W] | within | "
        "P_v paper fit [W] | P_v drive [W] | within |"
    )
    say("|---:|---:|---:|---:|:---:|---:|---:|:---:|")
    for row in rows:
        cells = [f"{row.speed_mps:g}", f"{result.model.t_acc.at(row.speed_mps):.2f}"]
        for paper, (low, high), value, (d_low, d_high), agree in (
            (row.paper_accel_W, row.paper_accel_ci95, row.accel_W, row.accel_ci95,
             row.accel_agree),
            (row.paper_cruise_W, row.paper_cruise_ci95, row.cruise_W, row.cruise_ci95,
             row.cruise_agree),
        ):  # fmt: skip
            cells += [
                f"{paper:.2f} [{low:.2f}, {high:.2f}]",
                f"{value:.2f} [{d_low:.2f}, {d_high:.2f}]",
                "yes" if agree else "**no**",
            ]
        say("| " + " | ".join(cells) + " |")
    held = model.heldout
    say(
        f"\nheld-out energy error: drive model MAPE {held.mape_pct:.2f}% (median "
        f"{held.median_ape_pct:.2f}%, {len(held.runs)} trips incl. idle, 90% intervals hold "
        f"{held.coverage_pi90_pct:.0f}%); over each run's motion energy ({beside.n_runs} runs, "
        f"`heldout_beside_paper`): drive model MAPE {beside.drive_mape_pct:.2f}%, paper "
        f"model (diagnose's baseline) {beside.paper_mape_pct:.2f}%"
    )


DOCS = ROOT / "docs" / "drive-model.md"
BEGIN, END = "<!-- simulator validation: begin -->", "<!-- simulator validation: end -->"


def main(argv: list[str]) -> None:
    seeds = 20
    many = 200
    for arg in argv:
        if arg.startswith("--seeds="):
            seeds = int(arg.split("=", 1)[1])
        if arg.startswith("--many="):
            many = int(arg.split("=", 1)[1])
    out: list[str] = [
        f"Printed by `.venv/bin/python benchmarks/validate_drive.py --seeds={seeds} "
        f"--many={many}{' --write-docs' if '--write-docs' in argv else ''}`."
    ]
    slow = {"sample_period_s": 1 / 6.5, "yaw_noise_radps": 0.03}
    coverage_suite(out, "Field realism (20 Hz logger)", range(many), realism="field")
    simulator_suite(out, "Field realism (20 Hz logger)", range(seeds), realism="field")
    if "--no-stress" not in argv:
        label = "Stress: 6.5 Hz logger, odometry-grade rate of turn"
        coverage_suite(
            out, label, range(100, 100 + max(many // 2, 3)), realism="field",
            realism_overrides=slow,
        )  # fmt: skip
        simulator_suite(
            out, label, range(100, 100 + max(seeds // 2, 3)), realism="field",
            realism_overrides=slow,
        )  # fmt: skip
        coverage_suite(out, "Lab (1 kHz)", range(200, 200 + max(many // 2, 3)), realism="lab")
        simulator_suite(out, "Lab (1 kHz)", range(200, 200 + max(seeds // 4, 3)), realism="lab")
    if "--no-steps" not in argv:
        step_suite(out)
    text = "\n".join(out) + "\n"
    print(text, end="")
    if "--write-docs" in argv:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from validate_drive_real import write_between

        write_between(DOCS, BEGIN, END, text)


if __name__ == "__main__":
    main(sys.argv[1:])
