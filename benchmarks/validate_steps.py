"""The drive model on the paper's step runs (docs/drive-model.md, "The paper's step runs: what
the v² term was, and what is left"): prints the tables that section quotes.

1. Agreement: for sample_logs and for simulated step runs (`wbpower simulate`'s paper grid at
   sample_logs' options: 1.024 ms, 2 decimals, no mode logs) with sample_logs' effects
   (decel_phase 0.3 s and cruise_ripple 1 W; seeds 1-5), each alone and none (seeds 1-3):
   how many of the 18 phase powers (accel and cruise at 9 speeds) agree with the paper's
   lines (`FitResult.drive_vs_paper`), how many of the drive model's intervals hold the
   simulator's line (truth.json), its largest cruise error, v², and the held-out errors
   beside the paper's (`diagnose.baseline.heldout_beside_paper`).
2. The windows against the truth: on one set without effects and one with the stop, the
   least squares of the windows' mean power on the window means of the simulator's own
   per-sample quantities (1, moving, v, v², (a v)+, (a v)-: from truth.json's phases) beside
   the same on the drive model's windows (drive/windows.py `run_windows`): what the windows
   cost, and what the simulator's stop does to a model of the drive model's form.

    .venv/bin/python benchmarks/validate_steps.py [--seeds=N]

About a minute on 2 shared cores (the logs are written to a temporary folder).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT)]

from wifibot_power import fit_logs  # noqa: E402
from wifibot_power.diagnose.baseline import heldout_beside_paper  # noqa: E402
from wifibot_power.simulate import (  # noqa: E402
    SimConfig,
    WriteOptions,
    parse_effects,
    write_simulation,
)

SAMPLE_EFFECTS = ["decel_phase=0.3", "cruise_ripple=1.0"]
SETS = (
    ("sample_logs' effects", SAMPLE_EFFECTS, 5),
    ("decel_phase 0.3 s only", ["decel_phase=0.3"], 3),
    ("cruise_ripple 1 W only", ["cruise_ripple=1.0"], 3),
    ("no effects (the paper's ideal robot)", [], 3),
)


def simulate(folder: Path, effects: list[str], seed: int) -> Path:
    config = SimConfig(sample_period_s=0.001024, modes=(), seed=seed,
                       effects=parse_effects(effects))  # fmt: skip
    write_simulation(config, folder, WriteOptions(columns="power", compress="gz", decimals=2))
    return folder


def agreement(folder: Path) -> dict[str, object]:
    result = fit_logs([folder])
    truth = json.loads((folder / "truth.json").read_text())["parameters"]
    agree = hold = 0
    worst = (0.0, 0.0)
    for row in result.drive_vs_paper():
        v = row.speed_mps
        for line, ok, value, ci in (
            ("accel", row.accel_agree, row.accel_W, row.accel_ci95),
            ("cruise", row.cruise_agree, row.cruise_W, row.cruise_ci95),
        ):
            true_W = truth[line]["intercept_W"] + truth[line]["slope_W_per_mps"] * v
            agree += ok
            hold += ci[0] <= true_W <= ci[1]
            if line == "cruise" and abs(value - true_W) > abs(worst[0]):
                worst = (value - true_W, v)
    quadratic = result.drive.terms.get("quadratic_W_per_mps2")
    beside = heldout_beside_paper(result)
    return {
        "agree": agree,
        "hold": hold,
        "worst": worst,
        "v2": None if quadratic is None else (quadratic.value, *quadratic.ci95),
        "drive_pct": beside.drive_mape_pct if beside else float("nan"),
        "paper_pct": beside.paper_mape_pct if beside else float("nan"),
    }


def windows_against_truth(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    """The least squares coefficients (idle, drive-on, rolling, v², m_eff, braking) of the
    windows' power on the simulator's exact window means, and on the model's windows."""
    from wifibot_power.drive.stats import _bin_of, drive_stats
    from wifibot_power.drive.windows import run_windows
    from wifibot_power.io.discover import find_logs
    from wifibot_power.io.reader import read_log
    from wifibot_power.segment import segment_run

    truth = {r["run_id"]: r for r in json.loads((folder / "truth.json").read_text())["runs"]}
    exact_rows, model_rows, power = [], [], []
    for source in find_logs([folder])[0]:
        run = read_log(source.path, overrides=source.read_overrides, origin=source.origin)
        if run.meta.mode != "motion":
            continue
        windows = run_windows(drive_stats(run, segment_run(run)))
        stats, n, count = windows.stats, windows.n, windows.count
        dt, top = run.sample_period_s, truth[run.meta.run_id]["speed_mps"]
        v, a, moving = np.zeros(run.samples), np.zeros(run.samples), np.zeros(run.samples)
        for phase in truth[run.meta.run_id]["phases"]:
            i, j = round(phase["t_start_s"] / dt), round(phase["t_end_s"] / dt)
            rise = (np.arange(j - i) + 0.5) / (j - i)  # the simulator's: the sample's middle
            shape = {"accel": rise, "cruise": 1.0 + 0 * rise, "decel": 1.0 - rise}
            if phase["phase"] in shape:
                v[i:j] = top * shape[phase["phase"]]
                a[i:j] = {"accel": 1, "cruise": 0, "decel": -1}[phase["phase"]] * top / (j - i) / dt
                moving[i:j] = 1.0
        which = _bin_of(run.time_s - run.time_s[0], stats.bins) // n
        keep = which < count
        per_sample = (
            np.ones(run.samples),
            moving,
            v,
            v * v,
            np.maximum(a * v, 0),
            np.minimum(a * v, 0),
        )
        counts = np.bincount(which[keep], minlength=count)
        exact = np.column_stack(
            [np.bincount(which[keep], x[keep], count) / counts for x in per_sample]
        )
        reg = windows.regressors()
        model = np.column_stack([np.ones(count), reg["moving"], reg["abs_speed"], reg["speed2"],
                                 reg["av_up"], reg["av_down"]])  # fmt: skip
        mean_W, ok = windows.power_at(0)
        good = ok & windows.ok
        exact_rows.append(exact[good])
        model_rows.append(model[good])
        power.append(mean_W[good])
    y = np.concatenate(power)
    fits = [np.linalg.lstsq(np.vstack(rows), y, rcond=None)[0] for rows in (exact_rows, model_rows)]
    return fits[0], fits[1]


def main(argv: list[str]) -> None:
    seeds_cap = next((int(a.split("=", 1)[1]) for a in argv if a.startswith("--seeds=")), 5)
    print("| logs | seed | agree (of 18) | drive intervals holding the line | largest cruise "
          "error [W] | v² [W/(m/s)²] | held-out, drive / paper [%] |")  # fmt: skip
    print("|---|---:|---:|---:|---:|---|---|")

    def line(label: str, seed: object, found: dict) -> None:
        error, at = found["worst"]
        v2 = found["v2"]
        shown = "not determined" if v2 is None else f"{v2[0]:.3f} [{v2[1]:.2f}, {v2[2]:.2f}]"
        print(f"| {label} | {seed} | {found['agree']} | {found['hold']} | {error:+.4f} at {at:g} "
              f"| {shown} | {found['drive_pct']:.3f} / {found['paper_pct']:.2f} |")  # fmt: skip

    line("sample_logs", 2015, agreement(ROOT / "sample_logs"))
    with tempfile.TemporaryDirectory(prefix="wbpower_steps_") as tmp:
        made = {}
        for label, effects, seeds in SETS:
            for seed in range(1, min(seeds, seeds_cap) + 1):
                folder = simulate(Path(tmp) / f"{len(made)}", effects, seed)
                made[(label, seed)] = folder
                line(label, seed, agreement(folder))
        names = ("idle", "drive-on", "rolling", "v²", "m_eff", "braking")
        print("\nleast squares of the windows' power (seed 1):\n")
        print("| logs | regressors | " + " | ".join(names) + " |")
        print("|---|---|" + "---:|" * len(names))
        for label in ("no effects (the paper's ideal robot)", "decel_phase 0.3 s only"):
            exact, model = windows_against_truth(made[(label, 1)])
            for kind, coef in (("the simulator's exact window means", exact),
                               ("the drive model's windows", model)):  # fmt: skip
                print(f"| {label} | {kind} | " + " | ".join(f"{c:.4f}" for c in coef) + " |")
    print("\ntruth: idle 23.3, drive-on 0.6, rolling 11.2, v² 0, m_eff 18.4 (4.6 x 4 kg), "
          "braking: none (the stop draws 0.6 + 5.6 v, not a braking mass times a v)")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
