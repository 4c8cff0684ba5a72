"""What `diagnose` does for speed gives the answers it gave before (docs/diagnose.md, "Speed").

The statistics written out instead of importing scipy.stats (a second of every run) are
checked against it, bit for bit (the refinement of a sinusoid's frequency, which replaced
scipy.optimize's bounded minimisation, is in tests/test_sinusoid.py); the one cumulative
sum shared by the per-run row and the trace statistics against each made on its own; and
`report`, which summarises runs in its own worker, against `diagnose`'s summary.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy import stats as scipy_stats
from test_diagnose import GRID

from wifibot_power import diagnose
from wifibot_power.diagnose.extended import motion_of, predict_motion_energy_J
from wifibot_power.fit import TableColumns, fit_table, fit_table_model, segment_checked
from wifibot_power.runtable import WindowEnergy, run_row
from wifibot_power.simulate import SimConfig, simulate_runs
from wifibot_power.stats import average_ranks, spearman


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
    """report's per-run record keeps what every cause's tests need (the thermal drift's
    within-run creep among them), as `diagnose` does, so its diagnosis is diagnose's."""
    from wifibot_power.causes import RunView, run_statistics
    from wifibot_power.pipeline import DIAGNOSE_PLAN, REPORT_PLAN, run_record

    for run, _ in segmented[:2]:
        record = run_record(run, REPORT_PLAN)
        row = record.row
        # the causes' hooks run on the run directly, not through a record
        expected, _ = run_statistics(RunView(run, segment_checked(run), WindowEnergy(run)))
        assert record.causes == expected
        assert run_record(run, DIAGNOSE_PLAN).causes == expected
        assert diagnose.summarize_run(run).cause_columns == expected
        assert {"creep_s_tp", "creep_s_tt"} <= set(record.causes)
        alone = run_row(run, segment_checked(run))
        assert all(
            _same(row[k], alone[k]) if isinstance(alone[k], float) else row[k] == alone[k]
            for k in alone
        )


@pytest.fixture(scope="module")
def table():
    """A diagnose table (`diagnose.summary_table`): 30 motion runs and a run of each other
    mode, the second motion run unusable."""
    sims = simulate_runs(SimConfig(**GRID, seed=3))
    summaries = [diagnose.summarize_run(s.run) for s in sims]
    first = next(i for i, s in enumerate(summaries) if s.row["mode"] == "motion")
    summaries[first + 1].row.update(usable=False, skip_reason="test")
    return diagnose.summary_table(summaries)


def _frames_equal(a, b) -> bool:
    return a.equals(b) and a.index.equals(b.index) and (a.dtypes == b.dtypes).all()


@pytest.mark.parametrize("with_others", [True, False])
def test_a_held_out_deal_is_its_folds_tables(table, with_others) -> None:
    """`diagnose.HeldOut` takes each fold's rows from one stacked table and from its
    columns read once: its tables are the concat per fold it replaced (index and all: the
    other modes' index labels repeat the motion runs' 0, 1, ..., so rows are taken by
    position), its fits that of `fit_model` on them (the lines alone from the columns, with
    causes from the table) and its predictions `predict_motion_energy_J` of the fold."""
    runs = table[table["usable"]]
    runs = runs if with_others else runs[runs["mode"] == "motion"]
    motion = diagnose.motion_runs(runs)
    folds = diagnose.assign_folds(motion["run_id"])
    others = runs[runs["mode"] != "motion"]
    assert with_others == (len(others) > 0)
    deal = diagnose.HeldOut(runs, motion, folds)
    assert list(deal) == sorted(set(folds.tolist()))
    for k in deal:
        train = pd.concat([others, motion[folds != k]])
        assert _frames_equal(deal.train(k), train)
        assert _frames_equal(deal.held(k), motion[folds == k])
        for causes in ([], ["decel_phase", "start_transient"]):
            model = diagnose.fit_model(train, causes)
            assert json.dumps(deal.fit(k, causes).to_json()) == json.dumps(model.to_json())
            predicted = predict_motion_energy_J(model, motion[folds == k])
            assert np.array_equal(deal.predict(model, k), predicted)


def test_motion_of_is_the_pandas_selection(table) -> None:
    expected = table[(table["mode"] == "motion") & table["usable"]]
    assert _frames_equal(motion_of(table), expected)
    assert _frames_equal(motion_of(table.iloc[::-1]), expected.iloc[::-1])
    # other column types than the per-run table's (a library caller's table): pandas' own
    # semantics, a missing `usable` not usable, a missing mode not motion (the review's
    # cases: numpy's bool of NaN is True, and a comparison with pd.NA raises)
    odd = table.copy()
    odd["usable"] = odd["usable"].astype(object)
    odd.loc[odd.index[odd["mode"] == "motion"][:3], "usable"] = np.nan
    odd["mode"] = odd["mode"].astype("string")
    odd.loc[odd.index[5], "mode"] = pd.NA
    expected = odd[(odd["mode"] == "motion") & odd["usable"]]
    assert len(expected) < (table["mode"] == "motion").sum() - 3
    assert _frames_equal(motion_of(odd), expected)


def test_a_fit_asked_with_an_iterator_of_causes_fits_them(table) -> None:
    """`diagnose.Fits` keys its memo by the causes and fits them: an iterator read
    once for the key left the fit none, and the causeless model was kept under the causes'
    key (the review's case)."""
    runs = table[table["usable"]]
    causes = ["decel_phase", "start_transient"]
    fits = diagnose.Fits()
    from_iterator = fits.fit(runs, iter(causes))
    from_list = fits.fit(runs, causes)
    expected = diagnose.fit_model(runs, causes)
    assert json.dumps(from_iterator.to_json()) == json.dumps(expected.to_json())
    assert json.dumps(from_list.to_json()) == json.dumps(expected.to_json())


def test_fit_table_model_reads_columns_as_fit_table_reads_rows(table) -> None:
    """`fit.fit_table_model` reads the table's columns whole; `fit_table` its records one
    by one. The same model: on the table, on it with a motion run's values missing (NaN)
    and an idle run unusable, and without its idle run (idle from the idle phases) or its
    other modes."""
    variants = [table]
    holed = table.copy()
    motion_rows = np.flatnonzero(holed["mode"] == "motion")
    holed.loc[holed.index[motion_rows[3]], ["accel_mean_power_W", "t_acc_s"]] = np.nan
    holed.loc[holed.index[motion_rows[5]], "cruise_mean_power_W"] = np.nan
    holed.loc[holed["mode"] == "idle", "usable"] = False
    variants += [holed, table[table["mode"] != "idle"], table[table["mode"] == "motion"]]
    variants += [table.iloc[:0]]
    for frame in variants:  # as JSON text: NaN (no line through no runs) equals NaN
        columns, rows = fit_table_model(frame).to_json(), fit_table(frame).model.to_json()
        assert json.dumps(columns) == json.dumps(rows)


def test_table_columns_fit_any_rows_as_their_table(table) -> None:
    """`fit.TableColumns(table).model(rows)` (a fold's lines from columns read once) is
    `fit_table_model(table.take(rows))`: rows in any order, repeated, an unusable one
    among them, the other modes' or none of them."""
    columns = TableColumns(table)
    rng = np.random.default_rng(1)
    assert not table["usable"].all()
    for size in (len(table), 20, 12):
        rows = rng.choice(len(table), size, replace=size > len(table) // 2)
        expected = fit_table_model(table.take(rows)).to_json()
        assert json.dumps(columns.model(rows).to_json()) == json.dumps(expected)


PANDAS_BESIDE = r"""
import os, sys
import wifibot_power.parallel as parallel
from wifibot_power.diagnose import diagnose_logs
from wifibot_power.errors import LogError

report = sys.argv[2]
original = parallel._run_task


def _run_task(index):
    with open(report, "a") as f:  # what the worker inherited from the parent at the fork
        f.write(f"{os.getpid()} {'pandas' in sys.modules}\n")
    return original(index)


parallel._run_task = _run_task  # looked up by name in the forked workers
import threading
import wifibot_power.pipeline.preload as preload

importing = preload.preload_tables


def _import_pandas():
    with open(report, "a") as f:
        f.write(f"beside {threading.current_thread() is threading.main_thread()}\n")
    importing()


preload.preload_tables = _import_pandas
loaded_before = "pandas" in sys.modules
try:
    diagnose_logs([sys.argv[1]], jobs=2)
except LogError:
    pass
print(os.getpid(), loaded_before, "pandas" in sys.modules)
"""


def test_diagnose_loads_pandas_beside_its_workers_not_before(tmp_path) -> None:
    """pandas (~0.3 s of CPU to import) is what the diagnosis after the workers needs, not
    their work: `diagnose_logs` imports it in a thread while the forked workers read the
    logs (`map_runs(beside=...)`), so that the ~0.3 s overlaps their work instead of coming
    before it. No worker inherits it (the parent had not loaded it when they were forked),
    and it is loaded when the diagnosis runs."""
    import subprocess
    import sys

    from wifibot_power.parallel import can_fork
    from wifibot_power.simulate import write_simulation

    if not can_fork():
        pytest.skip("workers are forked on Linux only")
    logs = tmp_path / "logs"
    write_simulation(SimConfig(**GRID, seed=3), logs)
    report = tmp_path / "inherited.txt"
    done = subprocess.run(
        [sys.executable, "-c", PANDAS_BESIDE, str(logs), str(report)],
        capture_output=True,
        text=True,
        check=True,
    )
    parent, loaded_before, loaded_after = done.stdout.split()
    lines = [line.split() for line in report.read_text().splitlines()]
    assert [line for line in lines if line[0] == "beside"] == [["beside", "False"]]
    tasks = [line for line in lines if line[0] != "beside"]
    assert len(tasks) >= 6 and all(pid != parent for pid, _ in tasks)
    assert {inherited for _, inherited in tasks} == {"False"}
    assert (loaded_before, loaded_after) == ("False", "True")


def test_a_true_k2_whose_acceleration_estimate_reads_negative_is_still_named():
    """speed_quadratic (6.08 W/(m/s)²) beside start_transient (4.36 J) at field realism,
    seed 3 (validate_offcat's pair): acceleration's own k2 reads -0.15 beside 5.76 in
    cruise, its standard error ~3 (difference p = 0.07). The check once failed on that sign
    alone; it fails only when acceleration's k2 is shown below zero or different."""
    from test_diagnose_idle import FIELD

    from wifibot_power.diagnose import diagnose_runs
    from wifibot_power.simulate import SimConfig, simulate_runs

    effects = {"speed_quadratic": 6.082208291569159, "start_transient": 4.362050556457076}
    sims = simulate_runs(SimConfig(**FIELD, effects=effects, seed=3))
    result = diagnose_runs([s.run for s in sims])
    assert sorted(f.cause for f in result.findings) == ["speed_quadratic", "start_transient"]
    (finding,) = [f for f in result.findings if f.cause == "speed_quadratic"]
    (same,) = [c for c in finding.checks if c.check.startswith("same k2")]
    assert same.passed and "k2 -0.1" in same.detail, same.detail
