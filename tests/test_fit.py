"""The fit of the paper's models over runs.

Three layers: the regression formulas against values worked out by hand; the fit over
simulated runs segmented by the simulator's own truth (so fit errors are not mixed with
segmentation errors); and the whole pipeline (`fit_logs`) on logs written to disk.

The truth: the simulator is calibrated to the paper (Zorbas & Razafindralambo,
arXiv:1512.04380): P_acc = 23.9 + 14.8 v, P_v = 23.9 + 11.2 v, idle 23.3 W, Table 1
network 4.4 W, video 2.5 W, CPU 2.1 W net of idle; t_acc = v / (1 m/s²).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from contract import PHASES_PARQUET_COLUMNS
from numpy.testing import assert_allclose

from wifibot_power.fit import (
    MeanEstimate,
    fit_line,
    fit_logs,
    fit_table,
    fit_table_model,
    net_of_idle,
    write_fit,
)
from wifibot_power.model import load_model
from wifibot_power.parallel import can_fork
from wifibot_power.phases import Phase, Segmentation
from wifibot_power.runtable import run_row, runs_frame
from wifibot_power.simulate import SimConfig, simulate_runs, true_parameters, write_simulation

# The truth, written out from the paper (and checked against the simulator's own record below).
TRUE = {
    "accel": (23.9, 14.8),
    "cruise": (23.9, 11.2),
    "idle_W": 23.3,
    "components_W": {"network": 4.4, "video": 2.5, "cpu": 2.1},
}
# Done-when tolerances of issue 3.
TOL_INTERCEPT_W = 0.3
TOL_ACCEL_SLOPE = 0.8
TOL_CRUISE_SLOPE = 0.4
TOL_IDLE_W = 0.1
TOL_COMPONENT_W = 0.2

# Small grid: 3 speeds, a 1-step and a 2-step trip, 10 ms samples (the simulator averages
# its 0.1024 ms noise over the longer period, as an averaging analyser does, so phase means
# carry the same noise as at full rate), short mode runs.
SMALL = dict(
    speeds_mps=(0.2, 0.5, 0.8),
    trips=((2.0, 1), (3.0, 2)),
    repeats=1,
    mode_repeats=2,
    mode_duration_s=3.0,
    sample_period_s=0.01,
    idle_before_s=1.0,
    idle_between_s=1.0,
    idle_after_s=1.0,
)


def truth_segmentation(run, truth) -> Segmentation:
    """The simulator's true phases as a Segmentation of `run`."""
    dt = run.sample_period_s
    phases = []
    for p in truth["phases"]:
        i0, i1 = round(p["t_start_s"] / dt), round(p["t_end_s"] / dt)
        window = run.power_W[i0:i1]
        phases.append(
            Phase(
                p["step"],
                p["phase"],
                i0,
                i1,
                i0 * dt,
                i1 * dt,
                float(window.mean()),
                float(window.sum() * dt),
            )
        )
    return Segmentation(str(truth["run_id"]), tuple(phases))


def fit_with_truth(config: SimConfig):
    sims = simulate_runs(config)
    rows = [run_row(s.run, truth_segmentation(s.run, s.truth)) for s in sims]
    return fit_table(runs_frame(rows)), sims


def assert_recovers_truth(result) -> None:
    summary = result.summary()
    assert abs(summary["accel"]["intercept_W"] - TRUE["accel"][0]) <= TOL_INTERCEPT_W
    assert abs(summary["accel"]["slope_W_per_mps"] - TRUE["accel"][1]) <= TOL_ACCEL_SLOPE
    assert abs(summary["cruise"]["intercept_W"] - TRUE["cruise"][0]) <= TOL_INTERCEPT_W
    assert abs(summary["cruise"]["slope_W_per_mps"] - TRUE["cruise"][1]) <= TOL_CRUISE_SLOPE
    assert abs(summary["idle_W"] - TRUE["idle_W"]) <= TOL_IDLE_W
    for mode, value in TRUE["components_W"].items():
        assert abs(summary["components_W"][mode] - value) <= TOL_COMPONENT_W, mode


# -- the formulas, by hand -----------------------------------------------------------------


def test_fit_line_matches_hand_computation():
    # x = 0, 1, 2; y = 1, 3, 2: x̄ = 1, ȳ = 2, Sxx = 2, Sxy = 1 -> slope 0.5, intercept 1.5
    # residuals -0.5, 1, -0.5: SSE = 1.5, SST = 2 -> R² = 0.25; s² = 1.5 / (3 - 2) = 1.5
    # se(slope) = sqrt(1.5 / 2) = 0.8660254; se(intercept) = sqrt(1.5 (1/3 + 1/2)) = 1.1180340
    # t(0.975, 1 dof) = 12.7062047 (Student's t table)
    fit = fit_line(np.array([0.0, 1.0, 2.0]), np.array([1.0, 3.0, 2.0]))
    assert_allclose([fit.intercept, fit.slope, fit.r2], [1.5, 0.5, 0.25], rtol=1e-12)
    # the table's t has 9 digits: 1e-7 relative
    assert_allclose(
        fit.slope_ci95, [0.5 - 12.7062047 * 0.8660254, 0.5 + 12.7062047 * 0.8660254], rtol=1e-7
    )
    assert_allclose(
        fit.intercept_ci95, [1.5 - 12.7062047 * 1.1180340, 1.5 + 12.7062047 * 1.1180340], rtol=1e-7
    )
    assert fit.n_runs == 3


def test_fit_line_exact_line_has_zero_width_interval():
    fit = fit_line(np.array([0.1, 0.4, 0.9, 0.9]), 2.0 + 3.0 * np.array([0.1, 0.4, 0.9, 0.9]))
    assert_allclose([fit.intercept, fit.slope, fit.r2], [2.0, 3.0, 1.0], rtol=1e-12)
    assert_allclose(fit.slope_ci95, [3.0, 3.0], atol=1e-9)


def test_fit_line_degenerate_cases():
    one_speed = fit_line(np.array([0.5, 0.5, 0.5]), np.array([1.0, 2.0, 3.0]))
    assert math.isnan(one_speed.slope) and one_speed.n_runs == 3
    two = fit_line(np.array([0.0, 1.0]), np.array([1.0, 3.0]))
    # stats.ols solves by SVD: exact up to float rounding (a few ulps), not bit-exact
    assert (two.intercept, two.slope) == pytest.approx((1.0, 2.0), rel=1e-12)
    assert math.isnan(two.slope_ci95[0]) and math.isnan(two.r2)
    with_nan = fit_line(np.array([0.0, 1.0, 2.0, 3.0]), np.array([1.0, 3.0, 5.0, np.nan]))
    assert with_nan.n_runs == 3 and with_nan.slope == pytest.approx(2.0, rel=1e-12)


def test_fit_line_interval_covers_the_true_slope_95_percent_of_the_time():
    # 2000 seeded experiments of 6 runs with Gaussian scatter: coverage ~ Binomial(2000, 0.95),
    # sd 0.0049, so [0.933, 0.967] is a +-3.5 sd band; a z-instead-of-t or a wrong se breaks it.
    rng = np.random.default_rng(42)
    speed = np.array([0.1, 0.3, 0.5, 0.7, 0.9, 0.9])
    hits = 0
    for _ in range(2000):
        values = 23.9 + 11.2 * speed + rng.normal(0.0, 0.5, speed.size)
        low, high = fit_line(speed, values).slope_ci95
        hits += low <= 11.2 <= high
    assert 0.933 <= hits / 2000 <= 0.967


def test_mean_estimate_and_net_of_idle_by_hand():
    # values 1, 2, 3: mean 2, s = 1, se = 1/sqrt(3); t(0.975, 2 dof) = 4.3026527
    estimate = MeanEstimate.of(np.array([1.0, 2.0, 3.0]))
    half = 4.3026527 / math.sqrt(3)
    assert_allclose([estimate.value_W, *estimate.ci95], [2.0, 2.0 - half, 2.0 + half], rtol=1e-7)
    # equal variances and sizes: Welch dof = 4, se = sqrt(2/3); t(0.975, 4) = 2.7764451
    net = net_of_idle(MeanEstimate.of(np.array([6.0, 7.0, 8.0])), estimate)
    half = 2.7764451 * math.sqrt(2.0 / 3.0)
    assert_allclose([net.value_W, *net.ci95], [5.0, 5.0 - half, 5.0 + half], rtol=1e-7)


# -- over simulated runs, truth-segmented -------------------------------------------------


def test_simulator_truth_is_the_paper():
    truth = true_parameters(SimConfig())
    assert_allclose(
        [truth["accel"]["intercept_W"], truth["accel"]["slope_W_per_mps"]],
        TRUE["accel"],
        rtol=1e-12,
    )
    assert_allclose(
        [truth["cruise"]["intercept_W"], truth["cruise"]["slope_W_per_mps"]],
        TRUE["cruise"],
        rtol=1e-12,
    )
    assert truth["idle_W"] == TRUE["idle_W"] and truth["components_W"] == TRUE["components_W"]


@pytest.mark.parametrize("noise_W", [0.3, 3.0])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fit_recovers_truth_over_seeds_and_noise(seed, noise_W):
    result, sims = fit_with_truth(SimConfig(**SMALL, seed=seed, noise_W=noise_W))
    assert_recovers_truth(result)
    motion = [s for s in sims if s.truth["mode"] == "motion"]
    assert result.summary()["accel"]["n_runs"] == len(motion) == 6
    assert result.n_runs == len(sims) == 14
    # t_acc = v / a with a = 1 m/s² (truth): intercept 0 s, slope 1 s/(m/s); the truth's
    # phases are whole samples, so within one 10 ms sample
    assert_allclose([result.model.t_acc.intercept, result.model.t_acc.slope], [0.0, 1.0], atol=0.01)


def test_intervals_contain_the_truth_and_r2_is_high():
    result, _ = fit_with_truth(SimConfig(**SMALL, seed=3, noise_W=1.0))
    accel, cruise = result.model.accel, result.model.cruise
    assert accel.slope_ci95[0] <= TRUE["accel"][1] <= accel.slope_ci95[1]
    assert cruise.intercept_ci95[0] <= TRUE["cruise"][0] <= cruise.intercept_ci95[1]
    assert accel.r2 > 0.99 and cruise.r2 > 0.99


def test_idle_falls_back_to_idle_phases_and_components_are_null_without_mode_runs():
    result, _ = fit_with_truth(SimConfig(**{**SMALL, "mode_repeats": 0}, seed=4))
    assert result.idle_source == "idle phases of motion runs"
    assert abs(result.model.idle_W - TRUE["idle_W"]) <= TOL_IDLE_W
    assert result.summary()["components_W"] == {"network": None, "video": None, "cpu": None}
    assert any("idle phases" in warning for warning in result.warnings)


def test_the_model_alone_is_the_fit_tables_model():
    """`fit_table_model` (diagnose's ~30 folds) skips the stop-and-go table of a
    `FitResult`; its model is the very one `fit_table` gives, unusable rows left out too."""
    sims = simulate_runs(SimConfig(**SMALL, seed=5))
    rows = [run_row(s.run, truth_segmentation(s.run, s.truth)) for s in sims]
    rows[1]["usable"], rows[1]["skip_reason"] = False, "test"
    frame = runs_frame(rows)
    assert fit_table_model(frame).to_json() == fit_table(frame).model.to_json()


def test_unusable_runs_are_left_out_of_the_fit():
    sims = simulate_runs(SimConfig(**SMALL, seed=5))
    rows = [run_row(s.run, truth_segmentation(s.run, s.truth)) for s in sims]
    # corrupt one motion run's accel power by +100 W and mark it unusable: the fit must ignore it
    bad = next(r for r in rows if r["mode"] == "motion")
    bad["accel_mean_power_W"] += 100.0
    bad["usable"], bad["skip_reason"] = False, "test"
    result = fit_table(runs_frame(rows))
    assert_recovers_truth(result)
    assert result.summary()["accel"]["n_runs"] == 5


def test_summary_has_the_contract_keys():
    result, _ = fit_with_truth(SimConfig(**SMALL, seed=0))
    summary = result.summary()
    assert {"n_runs", "accel", "cruise", "idle_W", "components_W", "skipped"} <= set(summary)
    for part in ("accel", "cruise"):
        assert {"intercept_W", "slope_W_per_mps", "intercept_ci95", "slope_ci95", "r2"} <= set(
            summary[part]
        )
    assert set(summary["components_W"]) == {"network", "video", "cpu"}


def test_paper_table_puts_fitted_and_paper_values_side_by_side():
    result, _ = fit_with_truth(SimConfig(**SMALL, seed=0))
    rows = {r["parameter"]: r for r in result.table_rows()}
    assert rows["P_acc slope"]["paper"] == 14.8 and rows["P_v intercept"]["paper"] == 23.9
    assert rows["network (net of idle)"]["paper"] == 4.4 and rows["idle"]["n_runs"] == 2
    text = result.to_markdown()
    assert text.splitlines()[0].startswith("| parameter | unit | fitted | 95% CI | R² | paper")
    assert "| P_v slope | W/(m/s) |" in text


# -- the pipeline on logs written to disk ----------------------------------------------------


def _truth_segmenter(truth_by_id):
    return lambda run: truth_segmentation(run, truth_by_id[run.meta.run_id])


@pytest.fixture(scope="module")
def sim_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("fitlogs")
    config = SimConfig(**SMALL, seed=7, noise_W=0.3)
    write_simulation(config, out)
    return out, {s.truth["run_id"]: s.truth for s in simulate_runs(config)}


def test_fit_logs_recovers_truth_and_writes_a_model_that_loads_back(sim_dir, tmp_path):
    folder, truth = sim_dir
    result = fit_logs([folder], segmenter=_truth_segmenter(truth))
    assert_recovers_truth(result)
    assert result.skipped == () and result.n_runs == 14
    written = write_fit(result, tmp_path / "out")
    assert sorted(p.name for p in written) == [
        "model.json",
        "phases.parquet",
        "runs.parquet",
        "stop_and_go.parquet",
    ]
    assert load_model(tmp_path / "out" / "model.json") == result.model
    runs = pd.read_parquet(tmp_path / "out" / "runs.parquet")
    assert len(runs) == 14
    phases = pd.read_parquet(tmp_path / "out" / "phases.parquet")
    # one row per truth phase of every run
    assert len(phases) == sum(len(t["phases"]) for t in truth.values())
    assert PHASES_PARQUET_COLUMNS <= set(phases.columns)


def test_fit_logs_lists_unusable_and_unreadable_inputs(sim_dir, tmp_path):
    folder, truth = sim_dir
    work = tmp_path / "logs"
    work.mkdir()
    for path in folder.glob("*.csv"):
        if path.name != "runs.csv":
            (work / path.name).write_bytes(path.read_bytes())
    # a run whose metadata says 3 steps while the log (and its truth) has 2
    two_step = next(k for k, t in truth.items() if t["mode"] == "motion" and t["steps"] == 2)
    target = work / f"{two_step}.csv"
    target.write_text(target.read_text().replace("# steps: 2", "# steps: 3"))
    (work / "garbage.csv").write_bytes(b"\x00\x01 not a log \xff")
    result = fit_logs([work], segmenter=_truth_segmenter(truth))
    reasons = {s.file: s.reason for s in result.skipped}
    assert set(reasons) == {str(target), str(work / "garbage.csv")}
    assert "metadata says 3" in reasons[str(target)]
    assert result.n_runs == 13
    assert_recovers_truth(result)


def test_segmenter_failure_on_one_run_skips_it_only(sim_dir):
    folder, truth = sim_dir
    victim = next(iter(truth))

    def flaky(run):
        if run.meta.run_id == victim:
            raise IndexError("boom")
        return truth_segmentation(run, truth[run.meta.run_id])

    result = fit_logs([folder], segmenter=flaky)
    assert [s.reason for s in result.skipped if "IndexError" in s.reason]
    assert result.n_runs == len(truth) - 1


# -- end to end with the real segmenter --------------------------------------------------
# Logs at 1.024 ms (the sample_logs/ period: each value the mean of ten 0.1024 ms analyser
# samples), written to disk and read back, then one run set at the paper's full 0.1024 ms
# rate in memory. "Noisier analyser": 2 W per 0.1024 ms sample, ~7x the default 0.3 W.


@pytest.mark.parametrize("seed,noise_W", [(11, 0.3), (12, 0.3), (13, 2.0), (14, 2.0)])
def test_fit_logs_with_the_segmenter_recovers_truth(tmp_path, seed, noise_W):
    pytest.importorskip("wifibot_power.segment")
    config = SimConfig(**{**SMALL, "sample_period_s": 0.001024}, seed=seed, noise_W=noise_W)
    write_simulation(config, tmp_path)
    result = fit_logs([tmp_path])
    assert result.skipped == ()
    assert_recovers_truth(result)


def test_segmenter_and_fit_at_the_paper_sample_rate():
    segment = pytest.importorskip("wifibot_power.segment")
    sims = simulate_runs(SimConfig(**{**SMALL, "sample_period_s": 0.1024e-3}, seed=15))
    rows = [run_row(s.run, segment.segment_run(s.run)) for s in sims]
    result = fit_table(runs_frame(rows))
    assert result.n_runs == len(sims)
    assert_recovers_truth(result)


def test_table_numbers_never_show_negative_zero_or_nan():
    from wifibot_power.fit import format_number

    assert format_number(-0.0001) == "0.000"
    assert format_number(-0.0006) == "-0.001"
    assert format_number(float("nan")) == "-" and format_number(None) == "-"


COLD_FIT_MODULES = r"""
import sys
from wifibot_power.cli import main
sys.argv = ["wbpower", "fit", sys.argv[1], "--json", "--jobs", "1"]  # read here too
try:
    main()
except SystemExit:
    pass
print("pandas" in sys.modules, file=sys.stderr)
"""


def test_cold_fit_json_never_imports_pandas(sim_dir) -> None:
    """`fit --json` reads, segments and fits without pandas: its import (~0.45 s of CPU, 6%
    of a cold `fit` of the 10 kHz power-only bench corpus, issue 14; in each forked worker
    when the reading imported it, as pyarrow's `to_numpy` does) comes only with the tables
    (`-o`, `--runs`, `FitResult.runs`). One job: the logs are read in this process."""
    import json
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", COLD_FIT_MODULES, str(sim_dir[0])],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(done.stdout)["cruise"]["n_runs"] > 0
    assert done.stderr.strip().splitlines()[-1] == "False"


WORKER_IMPORTS = r"""
import os, sys
import wifibot_power.parallel as parallel

command, folder, report = sys.argv[1:4]
# only the command's own module: another's imports (diagnose's pandas loads numpy.ma) would
# hide what this one's workers miss
if command == "fit":
    from wifibot_power.fit import fit_logs as run
else:
    from wifibot_power.diagnose import diagnose_logs as run
from wifibot_power.errors import LogError

original = parallel._run_task


def _run_task(index):
    before = set(sys.modules)
    result = original(index)
    with open(report, "a") as f:
        f.write(f"{os.getpid()} " + " ".join(sorted(set(sys.modules) - before)) + "\n")
    return result


parallel._run_task = _run_task  # looked up by name in the forked workers
print(os.getpid())
try:
    run([folder], jobs=2)
except LogError:
    pass  # too few runs to diagnose: the workers' part is what is looked at
"""


@pytest.mark.parametrize("command", ["fit", "diagnose"])
def test_forked_workers_import_nothing_the_parent_could_have(sim_dir, tmp_path, command):
    """`fit` and `diagnose` import what their work on a file needs (the segmenter, numpy.ma
    that `np.median` loads at its first call, numpy.fft for the ripple) before forking
    workers, so no worker imports a module of its own: ~9-15 ms of CPU each, in every
    worker (issue 14). Each task writes its process and the modules it imported; every
    task ran in a worker, and none imported anything. Each command runs in a process of
    its own that imports only that command's module. (Measured before the change: numpy.ma
    in every fit worker, numpy.fft and the segmenter in every diagnose worker.)"""
    import subprocess
    import sys

    if not can_fork():
        pytest.skip("workers are forked on Linux only")
    report = tmp_path / "imports.txt"
    done = subprocess.run(
        [sys.executable, "-c", WORKER_IMPORTS, command, str(sim_dir[0]), str(report)],
        capture_output=True,
        text=True,
        check=True,
    )
    parent = done.stdout.split()[0]
    tasks = [line.split(" ", 1) for line in report.read_text().splitlines()]
    assert len(tasks) == 14  # one a log
    assert {pid for pid, _ in tasks} and parent not in {pid for pid, _ in tasks}
    assert [modules for _, modules in tasks if modules] == []


CODE_DIGEST_USE = r"""
import sys
from wifibot_power.cache import ParseCache, code_digest
from wifibot_power.fit import fit_logs

fit_logs([sys.argv[1]])
print(code_digest.cache_info().misses)
fit_logs([sys.argv[1]], cache=ParseCache(sys.argv[2]))
print(code_digest.cache_info().misses)
"""


def test_only_a_cached_fit_hashes_the_source(sim_dir, tmp_path) -> None:
    """The cache's key hashes all of wifibot_power's source (`code_digest`, ~11 ms a command);
    a fit without a cache never computes it (nor does importing `wifibot_power.fit`). With
    a cache it is computed, once (by the cache itself; the fit's key reuses it)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", CODE_DIGEST_USE, str(sim_dir[0]), str(tmp_path / "cache")],
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.split() == ["0", "1"]
