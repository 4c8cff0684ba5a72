"""The drive model end to end through `fit` (issue 25; cli.md "The drive model"): a registered
model family, `fit --json`'s `drive` key, a free-driving batch as a success, the human tables
in 80 columns, model.json read back by `energy --profile` and `export`, the warm cache."""

from __future__ import annotations

import json
import math

import pytest
from test_export import check_gazebo_schema, check_rmf_schema, load_yaml
from typer.testing import CliRunner

from wifibot_power.cli import app
from wifibot_power.model import paper_model
from wifibot_power.models import FAMILIES, ModelFamily
from wifibot_power.models.paper import PaperFamily, PaperFit


def _wbpower(*args: object, width: int = 200):
    result = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": str(width)})
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise AssertionError(f"wbpower raised {result.exception!r}") from result.exception
    return result


@pytest.fixture(scope="module")
def free(tmp_path_factory):
    """Free-driving logs (2 runs a surface, 40 s, asphalt and grass) and `fit -o` of them."""
    root = tmp_path_factory.mktemp("drivefit")
    logs, out = root / "free", root / "fit"
    made = _wbpower(
        "simulate", "-o", logs, "--drive", "free", "--repeats", 2, "--duration", 40, "--seed", 1
    )
    assert made.exit_code == 0, made.output
    fitted = _wbpower("fit", logs, "-o", out, "--json")
    return logs, out, fitted


def test_drive_is_a_registered_family():
    family = FAMILIES["drive"]
    assert isinstance(family, ModelFamily) and list(FAMILIES)[:2] == ["paper", "drive"]


def test_free_driving_fits_the_drive_model_alone_with_exit_0(free):
    logs, _, fitted = free
    assert fitted.exit_code == 0, fitted.output
    doc = json.loads(fitted.stdout)
    assert doc["error"] is None if "error" in doc else True
    assert doc["skipped"] == []
    # the paper's keys null (no step run), with a note saying why
    assert doc["n_runs"] == 0 and doc["accel"] is None and doc["cruise"] is None
    assert doc["idle_W"] is None and doc["model_complete"] is False
    assert any("need step runs" in note for note in doc["notes"])
    drive = doc["drive"]
    assert drive["n_runs"] == 4
    assert set(drive["surfaces"]) == {"asphalt", "grass"}
    truth = json.loads((logs / "truth.json").read_text())
    for surface in ("asphalt", "grass"):
        term = drive["surfaces"][surface]["turning_Nm"]
        assert term["unit"] == "N m"
        # the simulator's true friction moment, within 5% (the interval is checked for
        # coverage over seeds in test_drive_model)
        true_Nm = truth["surfaces"][surface]["turning_Nm"]
        assert abs(term["value"] - true_Nm) < 0.05 * true_Nm
    assert set(drive["heldout"]) >= {"runs", "mape_pct", "median_ape_pct", "coverage_pi90_pct"}


def test_null_paper_section_has_the_fitted_sections_keys():
    fitted = PaperFamily().load(paper_model().to_json()).summary()
    assert set(PaperFit.null_summary()) == set(fitted)


def test_no_speed_gives_a_null_drive_and_an_unchanged_paper_fit(tmp_path):
    logs = tmp_path / "grid"
    made = _wbpower(
        "simulate", "-o", logs, "--speeds", "0.2,0.5,0.8", "--trips", "2x1", "--repeats", 2,
        "--modes", "", "--sample-period", 0.01, "--columns", "power",
    )  # fmt: skip
    assert made.exit_code == 0, made.output
    # the grid has no speed column: the drive model comes from the phases' trapezoid
    doc = json.loads(_wbpower("fit", logs, "--json").stdout)
    assert doc["accel"] is not None and "drive" in doc
    assert doc["drive"] is not None
    assert any("trapezoid" in w for w in doc["drive"]["warnings"])


def test_mode_logs_alone_give_a_null_drive(tmp_path):
    logs = tmp_path / "modes"
    made = _wbpower(
        "simulate", "-o", logs, "--speeds", "0.5", "--trips", "2x1", "--repeats", 1,
        "--modes", "idle", "--mode-repeats", 2, "--sample-period", 0.01,
    )  # fmt: skip
    assert made.exit_code == 0, made.output
    for path in logs.glob("v*"):
        path.unlink()  # mode logs only: no motion, no speed
    manifest = logs / "runs.csv"
    lines = manifest.read_text().splitlines()
    manifest.write_text("\n".join(line for line in lines if not line.startswith("v")) + "\n")
    doc = json.loads(_wbpower("fit", logs, "--json").stdout)
    assert "drive" in doc and doc["drive"] is None


def test_model_json_carries_the_drive_model_and_the_cache_keeps_it(free, tmp_path):
    logs, out, fitted = free
    model = json.loads((out / "model.json").read_text())
    assert model["drive"]["terms"] == json.loads(fitted.stdout)["drive"]["terms"]
    cache = tmp_path / "cache"
    cold = _wbpower("fit", logs, "--json", "--cache", cache)
    warm = _wbpower("fit", logs, "--json", "--cache", cache)
    assert warm.exit_code == cold.exit_code == 0
    assert json.loads(warm.stdout) == json.loads(cold.stdout)
    assert json.loads(warm.stdout)["drive"]["terms"] == model["drive"]["terms"]


def test_human_fit_shows_the_drive_terms_in_80_columns(free, monkeypatch):
    from wifibot_power.cli import common

    logs, _, fitted = free
    monkeypatch.setattr(common.stdout, "width", 80)  # a terminal of 80 columns
    result = _wbpower("fit", logs)
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert max(len(line) for line in text.splitlines()) <= 80
    assert "Drive model over 4 run(s)" in text and "lags speed by 0.20 s" in text
    # the lag's interval and the terms' interval note read apart (one "95% CI" each)
    flat = " ".join(text.split())
    lag_low, lag_high = json.loads(fitted.stdout)["drive"]["lag_ci95_s"]
    assert f"lags speed by 0.20 s [{lag_low:.2f}, {lag_high:.2f}]; the terms' 95% CI" in flat
    for cell in ("turning_Nm", "rolling_W_per_mps", "asphalt", "grass", "N m", "kg"):
        assert cell in text
    assert "held-out runs" in text and "MAPE %" in text and "in 90% PI %" in text
    assert "not determined: none" in text
    assert "need step runs" in result.stderr
    # every term's value and interval, to the decimals that show the interval's width to two
    # significant digits (no digit finer than the interval says anything about)
    drive = json.loads(fitted.stdout)["drive"]
    terms = [*drive["terms"].values(), *(t for s in drive["surfaces"].values() for t in s.values())]
    for term in terms:
        low, high = term["ci95"]
        d = max(1 - math.floor(math.log10(high - low)), 0)
        assert f"{term['value']:.{d}f}" in text
        assert f"[{low:.{d}f}, {high:.{d}f}]" in text
        assert f"{term['value']:.{d + 1}f}" not in text


def _check_profile(logs, model) -> None:
    """`energy --profile` of a fitted log from `model` (a fit -o model.json): its measured
    energy within the 90% interval, the terms' shares adding up to the energy."""
    log = sorted(logs.glob("free_*.csv"))[0]
    result = _wbpower("energy", "--profile", log, "--model", model, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    low, high = doc["pi90_J"]
    assert low < doc["measured_J"] < high
    shares_J = sum(doc["terms_J"].values()) + doc["undetermined_J"]
    assert abs(shares_J - doc["energy_J"]) < 1e-6 * doc["energy_J"]


def _check_exports(model) -> None:
    """`export --to rmf|gazebo` of `model`: each loads in its tool's documented schema."""
    rmf = _wbpower("export", "--model", model, "--to", "rmf", "--turn-rate", 0.5)
    assert rmf.exit_code == 0, rmf.output
    fleet = check_rmf_schema(load_yaml(rmf.stdout))
    assert fleet["mechanical_system"]["mass"] > 0
    gz = _wbpower("export", "--model", model, "--to", "gazebo", "--voltage", 24, "--capacity", 10)
    assert gz.exit_code == 0, gz.output
    assert check_gazebo_schema(gz.stdout)["power_load"] > 0


def test_energy_profile_of_a_fitted_log_is_within_its_interval(free):
    logs, out, _ = free
    _check_profile(logs, out / "model.json")


def test_a_route_on_a_surface_the_model_lacks_names_the_models_surfaces(free, tmp_path):
    logs, out, _ = free
    route = tmp_path / "route.csv"
    route.write_text("time_s,speed_mps,surface\n0,0,ice\n1,0.5,ice\n2,0.5,ice\n3,0,ice\n")
    result = _wbpower("energy", "--profile", route, "--model", out / "model.json")
    assert result.exit_code == 2
    (line,) = result.stderr.strip().splitlines()
    assert "surface 'ice' is not one the model was fitted on (its surfaces: asphalt, grass)" in line
    assert "name a surface of the model" in line


@pytest.mark.parametrize(
    ("rows", "said"),
    [
        # an arc at 2 m/s turning 0.4 rad/s, written in deg/s (22.9: under the absurd 30)
        ([(k / 10, 2.0, 22.9) for k in range(40)], ("line 2", "4.7 g", "deg/s divided by 57.3")),
        ([(k / 10, 2.0, 45.0) for k in range(40)], ("line 2", "absurd yaw rate")),
        ([(k / 10, 60.0, 0.0) for k in range(40)], ("line 2", "absurd speed")),
    ],
)
def test_a_route_in_the_wrong_units_is_refused_as_a_log_is(free, tmp_path, rows, said):
    """A planned route's rate of turn in deg/s gave a turning energy 57x: now each of a log's
    unit checks refuses it with its line (a planned route does not spin out)."""
    _, out, _ = free
    route = tmp_path / "route.csv"
    body = "\n".join(f"{t:.1f},{v},{w},grass" for t, v, w in rows)
    route.write_text("time_s,speed_mps,yaw_rate_radps,surface\n" + body + "\n")
    result = _wbpower("energy", "--profile", route, "--model", out / "model.json")
    assert result.exit_code == 2
    (line,) = result.stderr.strip().splitlines()
    assert str(route) in line and all(part in line for part in said), line
    # the same route in rad/s is a route
    right = tmp_path / "right.csv"
    body = "\n".join(f"{k / 10:.1f},2.0,0.4,grass" for k in range(40))
    right.write_text("time_s,speed_mps,yaw_rate_radps,surface\n" + body + "\n")
    assert _wbpower("energy", "--profile", right, "--model", out / "model.json").exit_code == 0


def test_a_route_naming_a_surface_for_a_model_of_none_is_told_to_leave_it_out(tmp_path):
    import dataclasses

    import numpy as np

    from wifibot_power.drive import fit_drive
    from wifibot_power.drive.profile import route_energy
    from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free

    config = FreeDriveConfig(seed=2, runs_per_surface=3, run_s=60.0)
    runs = [as_run(r) for r in simulate_free(config)]
    # the same logs without their surface (a robot's logs that name none)
    runs = [dataclasses.replace(r, meta=dataclasses.replace(r.meta, extra={})) for r in runs]
    model = fit_drive(runs)
    assert list(model.surface_names) == ["unknown"]  # drive/stats.py UNKNOWN_SURFACE
    t = np.arange(0.0, 10.0, 0.1)
    with pytest.raises(ValueError, match="fitted on logs that name none: leave the surface out"):
        route_energy(model, t, np.full(t.size, 0.5), None, "asphalt")


def test_export_of_fit_o_model_loads_in_each_tools_schema(free):
    _, out, _ = free
    _check_exports(out / "model.json")


# -- figures (cli.md, "Figures": the drive model) -------------------------------------------
@pytest.fixture(scope="module")
def free_fit(free):
    from wifibot_power.fit import fit_logs

    logs, _, _ = free
    return fit_logs(logs)


def test_drive_energy_figure_draws_each_heldout_run_with_its_interval(free_fit):
    from wifibot_power.figures import FIGURES

    drive = free_fit.drive
    figure = FIGURES["drive_energy"].draw(drive)
    ax = figure.axes[0]
    assert ax.get_xlabel() == "measured energy [J]" and "[J]" in ax.get_ylabel()
    # one errorbar container per surface, a point per held-out run, bars = the pi90
    containers = ax.containers
    assert {c.get_label() for c in containers} == {"asphalt", "grass"}
    points = sum(len(c.lines[0].get_xdata()) for c in containers)
    assert points == len(drive.heldout.runs)
    for container in containers:
        x = container.lines[0].get_xdata()
        for run in (r for r in drive.heldout.runs if r.surface == container.get_label()):
            assert run.measured_J in list(x)
        segments = container.lines[2][0].get_segments()
        spans = sorted(v for s in segments for v in (float(s[0][1]), float(s[1][1])))
        label = container.get_label()
        wanted = sorted(v for r in drive.heldout.runs if r.surface == label for v in r.pi90_J)
        assert spans == pytest.approx(wanted)


def test_drive_terms_figure_has_a_panel_per_term_with_its_unit(free_fit):
    from wifibot_power.figures import FIGURES

    drive = free_fit.drive
    figure = FIGURES["drive_terms"].draw(drive)
    visible = [ax for ax in figure.axes if ax.get_visible()]
    names = set(drive.terms) | {n for terms in drive.surfaces.values() for n in terms}
    assert len(visible) == len(names)
    by_label = {ax.get_ylabel().split(" [")[0]: ax for ax in visible}
    assert set(by_label) == names
    turning = by_label["turning_Nm"]
    assert turning.get_ylabel() == "turning_Nm [N m]"
    assert [t.get_text() for t in turning.get_xticklabels()] == ["asphalt", "grass"]
    # the points are the fitted values
    y = list(turning.containers[0].lines[0].get_ydata())
    assert y == [drive.surfaces[s]["turning_Nm"].value for s in ("asphalt", "grass")]


def test_drive_power_figure_and_report_on_free_driving(free, tmp_path):
    from wifibot_power.figures import FIGURES
    from wifibot_power.report import build_report

    logs, _, _ = free
    report = build_report(logs)
    traces = report.drive_traces
    assert 2 <= len(traces) <= 3 and {t.surface for t in traces} == {"asphalt", "grass"}
    figure = FIGURES["drive_power"].draw(traces)
    assert len(figure.axes) == len(traces)
    for ax, trace in zip(figure.axes, traces, strict=True):
        assert ax.get_ylabel() == "power [W]" and trace.run_id in ax.get_title()
        measured, predicted = ax.get_lines()
        assert list(measured.get_ydata()) == list(trace.measured_W)
        assert list(predicted.get_ydata()) == list(trace.predicted_W)
    assert figure.axes[-1].get_xlabel() == "time [s]"
    # the traces are the runs' own windows, predicted by a model that did not see the run:
    # their measured energy is the run's, their predicted energy is not the in-sample one
    import numpy as np

    from wifibot_power.drive.stats import drive_stats
    from wifibot_power.io import read_log

    drive = report.fit.drive
    for trace in traces:
        stats = drive_stats(read_log(logs / f"{trace.run_id}.csv"))
        measured_J, in_sample_J = drive.run_energy_J(stats)
        window_s = float(np.diff(trace.time_s).min())
        # (the same windows; the power at the fold's lag, which is the model's to 0.002 bin:
        # the windows' sum moves by that times the power at the run's ends, 0.005 J of
        # 2614 J here; one window more or less would be 6-44 J)
        assert abs(trace.measured_W.sum() * window_s - measured_J) < 1e-5 * measured_J
        heldout_J = trace.predicted_W.sum() * window_s
        assert abs(heldout_J - in_sample_J) > 1e-3 * measured_J
        assert not np.allclose(trace.predicted_W, trace.measured_W)
        assert abs(heldout_J - measured_J) < 0.5 * measured_J
    out = tmp_path / "report"
    result = _wbpower("report", logs, "-o", out)
    assert result.exit_code == 0, result.output
    drawn = {p.stem for p in (out / "figures").iterdir()}
    assert {"drive_power", "drive_energy", "drive_terms"} <= drawn
    assert "power_speed" not in drawn
    assert "power_speed: not drawn: the paper's models" in result.stderr
    # no empty table of the paper's parameters: a note says why there is none
    page = (out / "report.html").read_text()
    assert "<th>parameter</th>" not in page
    assert "were not fitted: they need step runs" in page


# -- the paper's step runs (sample_logs): the drive model beside P_acc(v) and P_v(v) --------
def _sample_steps(tmp_path):
    """9 one-step runs of sample_logs at 0.2, 0.5 and 0.8 m/s, and an idle log."""
    import shutil
    from pathlib import Path

    sample = Path(__file__).resolve().parents[1] / "sample_logs"
    logs = tmp_path / "steps"
    logs.mkdir()
    for speed in ("0.20", "0.50", "0.80"):
        for r in (1, 2, 3):
            name = f"v{speed}_d10_s1_r{r}.csv.gz"
            shutil.copy(sample / name, logs / name)
    shutil.copy(sample / "idle_r1.csv.gz", logs / "idle_r1.csv.gz")
    return logs


def test_step_runs_drive_model_beside_the_papers_lines(tmp_path, monkeypatch):
    from wifibot_power.fit import fit_logs

    logs = _sample_steps(tmp_path)
    result = fit_logs(logs)
    drive = result.drive
    assert drive is not None and result.has_paper
    # no speed column: the speed is the phases' trapezoid, and that is said
    assert any("trapezoid" in w for w in drive.summary()["warnings"])
    rows = result.drive_vs_paper()
    assert [r.speed_mps for r in rows] == [0.2, 0.5, 0.8]
    for row in rows:
        assert row.accel_agree and row.cruise_agree, row
        # the paper's own lines (23.9 + 14.8 v, 23.9 + 11.2 v), which sample_logs follow
        assert abs(row.cruise_W - (23.9 + 11.2 * row.speed_mps)) < 0.3
        assert abs(row.accel_W - (23.9 + 14.8 * row.speed_mps)) < 0.5
    from wifibot_power.cli import common

    monkeypatch.setattr(common.stdout, "width", 80)
    shown = _wbpower("fit", logs)
    assert shown.exit_code == 0, shown.output
    assert "beside the" in shown.stdout and "P_acc(v) and P_v(v)" in shown.stdout
    assert max(len(line) for line in shown.stdout.splitlines()) <= 80
    table = shown.stdout[shown.stdout.index("paper's step runs") :]
    assert table.count(" yes ") == 6


def test_step_runs_heldout_energy_beside_the_papers(tmp_path, monkeypatch):
    # issue 25: on the step runs the drive model's held-out run-energy error is reported
    # beside the paper model's: diagnose's baseline (the paper's lines refitted without each
    # fold), both over each run's motion energy
    from wifibot_power import diagnose_logs
    from wifibot_power.diagnose.baseline import heldout_beside_paper
    from wifibot_power.fit import fit_logs

    logs = _sample_steps(tmp_path)
    result = fit_logs(logs)
    beside = heldout_beside_paper(result)
    assert beside is not None and beside.n_runs == 9
    assert beside.paper_mape_pct == pytest.approx(diagnose_logs([logs]).baseline_mape_pct)
    # the drive model's: its held-out runs (one trip each here) over the table's motion energy
    motion_J = dict(zip(result.runs["run_id"], result.runs["motion_energy_J"], strict=True))
    errors = [
        abs(r["predicted_J"] - r["measured_J"]) / motion_J[r["run_id"]] * 100
        for r in result.drive.summary()["heldout"]["runs"]
        if r["run_id"] in motion_J and motion_J[r["run_id"]] > 0
    ]
    assert len(errors) == 9
    assert beside.drive_mape_pct == pytest.approx(sum(errors) / 9)
    # sample_logs stop over 0.3 s, which the paper's Eq. 5/6 leaves out (~2%); the drive
    # model's braking term holds most of it
    assert beside.drive_mape_pct < beside.paper_mape_pct / 5
    from wifibot_power.cli import common

    monkeypatch.setattr(common.stdout, "width", 80)
    shown = _wbpower("fit", logs).stdout
    assert f"{beside.paper_mape_pct:.2f}%" in shown and f"{beside.drive_mape_pct:.2f}%" in shown
    # every phase agrees here: nothing to explain; a disagreement is explained under the table
    assert "where they disagree" not in shown
    from dataclasses import replace

    from wifibot_power.fit_result import FitResult

    rows = result.drive_vs_paper()
    apart = (replace(rows[0], cruise_W=rows[0].paper_cruise_W + 1, cruise_ci95=(30.0, 30.0)),)
    monkeypatch.setattr(FitResult, "drive_vs_paper", lambda self: apart + rows[1:])
    shown = _wbpower("fit", logs).stdout
    assert "where they disagree" in shown and " no " in shown


def test_no_heldout_beside_the_papers_without_both_models(free):
    # free driving alone: no paper model, nothing to set beside it
    from wifibot_power.diagnose.baseline import heldout_beside_paper
    from wifibot_power.fit import fit_logs

    result = fit_logs(free[0])
    assert result.drive is not None and heldout_beside_paper(result) is None
    assert "paper's model (Eq. 1-6" not in _wbpower("fit", free[0]).stdout


# -- batches of free driving and step runs (issue 25 (d), (e)) --------------------------------
def _step_runs(folder, speeds: str):
    made = _wbpower(
        "simulate", "-o", folder, "--speeds", speeds, "--trips", "2x1", "--repeats", 2,
        "--modes", "", "--sample-period", 0.01, "--seed", 3,
    )  # fmt: skip
    assert made.exit_code == 0, made.output
    return folder


def test_free_driving_beside_step_runs_is_used_by_the_drive_model(free, tmp_path):
    # cli.md: the drive model is identified from every motion log with a speed column (or
    # a step run's phases); the paper's fit lists the free runs in `skipped`, saying that
    # it is the paper's models that left them out and that the drive model used them
    logs, _, _ = free
    grid = _step_runs(tmp_path / "grid", "0.2,0.5,0.8")
    result = _wbpower("fit", logs, grid, "--json")
    assert result.exit_code == 1, result.output  # cli.md: some input skipped
    doc = json.loads(result.stdout)
    assert doc["n_runs"] == 6 and doc["model_complete"] is True
    assert doc["drive"]["n_runs"] == 4 + 6
    # the free runs' surfaces are in the drive model: it used them
    assert {"asphalt", "grass"} <= set(doc["drive"]["surfaces"])
    free_logs = sorted(p.name for p in logs.glob("free_*.csv"))
    assert sorted(s["file"].rsplit("/", 1)[-1] for s in doc["skipped"]) == free_logs
    for skip in doc["skipped"]:
        assert "the paper's models left it out: no mode or speed" in skip["reason"]
        assert skip["reason"].endswith("the drive model used it")


def test_incomplete_paper_model_still_writes_the_drive_model(free, tmp_path):
    # one speed of step runs (the paper's lines need two) beside free driving: the paper's
    # model is incomplete, and fit -o's model.json holds the drive model without the paper's
    # section; energy --profile and export read it end to end
    logs, _, _ = free
    one = _step_runs(tmp_path / "one", "0.5")
    out = tmp_path / "out"
    result = _wbpower("fit", logs, one, "-o", out, "--json")
    assert result.exit_code == 1, result.output
    doc = json.loads(result.stdout)
    assert doc["model_complete"] is False and doc["drive"] is not None
    (incomplete,) = [w for w in doc["warnings"] if "the model is incomplete" in w]
    assert "holds the drive model alone" in incomplete
    model = json.loads((out / "model.json").read_text())
    assert "accel" not in model and "cruise" not in model
    assert model["drive"]["terms"] == doc["drive"]["terms"]
    # the paper's Eq. 5/6 cannot use it, and says so
    paper = _wbpower("energy", "--speed", 0.5, "--dist", 2, "--model", out / "model.json")
    assert paper.exit_code == 2 and "incomplete" in paper.stderr
    # ... and says what the file can do (re-running `fit -o` would write it again)
    assert "holds the drive model only" in paper.stderr and "--profile" in paper.stderr
    assert "re-run" not in paper.stderr
    _check_profile(logs, out / "model.json")
    _check_exports(out / "model.json")


def test_heldout_beside_paper_sums_a_runs_trips_but_not_a_run_id_with_a_hash(monkeypatch):
    """A run cut into trips ("b#0", "b#1") is their sum; a run whose own run_id ends in
    "#digits" ("a#2" beside "a") stays its own run (it was folded into "a": n_runs 1, the
    errors summed)."""
    from types import SimpleNamespace

    import pandas as pd

    from wifibot_power.diagnose import baseline

    runs = pd.DataFrame({"run_id": ["a", "a#2", "b"], "motion_energy_J": [100.0, 100.0, 100.0]})
    trips = [("a", 100.0, 101.0), ("a#2", 100.0, 101.0), ("b#0", 50.0, 51.0), ("b#1", 50.0, 51.0)]
    held = {"runs": [{"run_id": r, "measured_J": m, "predicted_J": p} for r, m, p in trips]}
    result = SimpleNamespace(
        drive=SimpleNamespace(summary=lambda: {"heldout": held}), model_complete=True, runs=runs
    )
    paper = (["a", "a#2", "b"], [100.0] * 3, [103.0] * 3)
    monkeypatch.setattr(baseline, "paper_heldout_motion_J", lambda runs: paper)
    beside = baseline.heldout_beside_paper(result)
    assert beside.n_runs == 3
    assert beside.drive_mape_pct == pytest.approx((1.0 + 1.0 + 2.0) / 3)
    assert beside.paper_mape_pct == pytest.approx(3.0)


def test_the_terms_figure_title_fits_a_single_panel(tmp_path):
    """One determined term (BorealTC flooring's case): the figure is one 3.6 in panel, and its
    title stays inside it (drawn, its extent within the figure's), on two lines."""
    import matplotlib

    matplotlib.use("Agg")
    from wifibot_power.drive.model import DriveModel, TermValue
    from wifibot_power.figures.drive_terms import drive_terms_figure

    model = DriveModel(
        terms={"braking_mass_kg": TermValue(19.0, (-122.0, 159.0), "W/(m/s^2)")},
        surfaces={},
        lag_s=0.26,
        n_runs=10,
        heldout=None,
        not_determined=(),
        warnings=(),
    )
    figure = drive_terms_figure(model)
    renderer = figure.canvas.get_renderer()
    title = figure._suptitle.get_window_extent(renderer)
    frame = figure.bbox
    assert title.x0 >= frame.x0 and title.x1 <= frame.x1
    assert "\n" in figure._suptitle.get_text()


def test_the_heldout_caption_says_the_coverage_is_of_the_trips_with_an_interval():
    """A trip predicted at 0 J has no interval and is out of the coverage (drive/heldout.py):
    the human table, which counts every trip, says of how many the coverage is."""
    from wifibot_power.cli.fit_tables import _without_interval

    runs = [{"predicted_J": 0.0}, {"predicted_J": 12.5}, {"predicted_J": 3.0}]
    assert _without_interval(runs) == " (of the 2 trips with one: 1 predicted at 0 J have none)"
    assert _without_interval(runs[1:]) == ""


def test_the_heldout_caption_says_which_runs_are_trips_and_what_measured_covers(free):
    """The human table counts held-out runs, trips of a log among them ("a#2"): the caption
    says how many and of how many logs, and that measured is over the predicted windows (a
    drop-out's energy in neither: the log's own energy can be more)."""
    from wifibot_power.cli.fit_tables import _trips_said

    runs = [{"run_id": "a#1"}, {"run_id": "a#2"}, {"run_id": "b"}, {"run_id": "c#1"}]
    run_ids = ("a", "b", "c", "d#2")
    said = "; 3 of the 4 are trips of 2 log(s) cut at their stops (run_id#k)"
    assert _trips_said(runs, run_ids) == said
    assert _trips_said(runs[2:3], run_ids) == ""
    # a log whose own run_id holds '#', held out whole, is no trip
    assert _trips_said([*runs, {"run_id": "d#2"}], run_ids) == said.replace("of the 4", "of the 5")
    logs, _, _ = free
    shown = _wbpower("fit", logs)
    assert shown.exit_code == 0, shown.output
    text = " ".join(shown.stdout.split())
    assert "measured and predicted over the same 0.5 s windows" in text


def test_the_heldout_caption_counts_no_log_whose_own_run_id_holds_a_hash(free, tmp_path):
    """A log's own run_id may hold '#' (`free_003_asphalt#2`): held out whole under it, it is
    no trip, and the caption counts trips as the drive model names them (`run_id#k` of a
    log cut at its stops: `drive.heldout.trip_log`), not every id with a '#'."""
    import csv
    import shutil

    logs, _, fitted = free
    held = json.loads(fitted.stdout)["drive"]["heldout"]["runs"]
    whole = sorted(r["run_id"] for r in held if "#" not in r["run_id"])[0]  # a log not cut
    trips = [r["run_id"] for r in held if "#" in r["run_id"]]
    cut = len({run_id.rsplit("#", 1)[0] for run_id in trips})
    assert trips and cut >= 1
    copied = tmp_path / "free"
    shutil.copytree(logs, copied)
    renamed = f"{whole}#2"
    log = copied / f"{whole}.csv"
    log.write_text(log.read_text().replace(f"# run_id: {whole}\n", f"# run_id: {renamed}\n"))
    with open(copied / "runs.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for row in rows:
        row["run_id"] = renamed if row["run_id"] == whole else row["run_id"]
    with open(copied / "runs.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    doc = json.loads(_wbpower("fit", copied, "--json").stdout)
    assert renamed in [r["run_id"] for r in doc["drive"]["heldout"]["runs"]]
    shown = _wbpower("fit", copied)
    assert shown.exit_code == 0, shown.output
    text = " ".join(shown.stdout.split())
    said = f"; {len(trips)} of the {len(held)} are trips of {cut} log(s) cut at their stops"
    assert said in text


def test_fewer_than_four_trips_give_no_heldout_accuracy_and_say_so():
    """Three runs that never stop are three trips: no K-fold accuracy of so few (heldout.py
    MIN_TRIPS), `heldout` null in the document and the reason in its warnings."""
    import numpy as np

    from wifibot_power.drive import fit_drive
    from wifibot_power.drive.heldout import MIN_TRIPS
    from wifibot_power.run import Run, RunMeta

    def steady(k: int) -> Run:
        rng = np.random.default_rng(k)
        t = np.arange(0, 60.0, 0.05)
        v = 0.3 + 0.1 * k + 0.05 * np.sin(t / (3.0 + k))
        power = 10 + 20 * v + 8 * v**2 + rng.normal(0.0, 1.0, t.size)
        meta = RunMeta(run_id=f"steady{k}", sample_period_s=0.05, extra={"surface": "floor"})
        return Run(f"steady{k}.csv", "wbpower-csv", meta, t, power, speed_mps=v)

    assert MIN_TRIPS == 4
    model = fit_drive([steady(k) for k in range(3)])
    doc = model.summary()
    assert doc["heldout"] is None
    assert "fewer than 4 trips: no held-out accuracy" in doc["warnings"]


def test_a_route_table_shows_a_share_that_rounds_to_nothing_as_0_not_minus_0():
    from wifibot_power.cli.energy_cmd import _joules

    assert _joules(-0.3, 0) == "0" and _joules(-0.04, 1) == "0.0"
    assert _joules(-12.6, 0) == "-13" and _joules(5.25, 1) == f"{5.25:.1f}"


def test_a_route_that_crosses_surfaces_takes_each_surfaces_terms(free, tmp_path):
    """A route whose `surface` column changes (cli.md allows the column): each window takes
    its surface's terms, as a log's windows do in the fit; the energy is the two routes'
    sum, each surface's term named with its surface."""
    logs, out, _ = free
    model = out / "model.json"

    def route(path, surfaces) -> None:
        rows = ["time_s,speed_mps,yaw_rate_radps,surface"]
        for i in range(400):
            t = 0.1 * i
            rows.append(f"{t:.1f},{0.0 if t < 2 or t > 38 else 0.5},0.0,{surfaces(t)}")
        path.write_text("\n".join(rows) + "\n")

    route(tmp_path / "cross.csv", lambda t: "asphalt" if t < 20 else "grass")
    route(tmp_path / "asphalt.csv", lambda t: "asphalt")
    route(tmp_path / "grass.csv", lambda t: "grass")
    docs = {}
    for name in ("cross", "asphalt", "grass"):
        result = _wbpower(
            "energy", "--profile", tmp_path / f"{name}.csv", "--model", model, "--json"
        )
        assert result.exit_code == 0, result.output
        docs[name] = json.loads(result.stdout)
    cross = docs["cross"]
    terms = cross["terms_J"]
    assert {"rolling_W_per_mps[asphalt]", "rolling_W_per_mps[grass]"} <= set(terms)
    assert "rolling_W_per_mps" not in terms
    # half the driving on each: its rolling share is half of each one-surface route's
    for surface in ("asphalt", "grass"):
        whole = docs[surface]["terms_J"]["rolling_W_per_mps"]
        assert terms[f"rolling_W_per_mps[{surface}]"] == pytest.approx(whole / 2, rel=0.05)
    assert sum(terms.values()) + cross["undetermined_J"] == pytest.approx(cross["energy_J"])
    shown = _wbpower("energy", "--profile", tmp_path / "cross.csv", "--model", model)
    assert "rolling_W_per_mps[grass]" in shown.stdout  # not taken for a rich style


def test_a_route_crossing_surfaces_with_a_row_naming_none_is_refused(free, tmp_path):
    _, out, _ = free
    path = tmp_path / "gap.csv"
    path.write_text("time_s,speed_mps,surface\n0,0,asphalt\n1,0.5,\n2,0.5,grass\n3,0,grass\n")
    result = _wbpower("energy", "--profile", path, "--model", out / "model.json")
    assert result.exit_code == 2
    assert "leaves some rows without one" in result.stderr and "Traceback" not in result.output


def test_a_log_with_a_surface_column_given_as_a_route_takes_each_samples_surface(free, tmp_path):
    """`energy --profile LOG` of a log whose `surface` column changes (BorealTC's mixed runs):
    each sample's surface, as the fit reads it (stats.py `sample_surfaces`), not a refusal
    ("the model has several surfaces: name one")."""
    logs, out, _ = free
    rows = ["time_s,power_W,speed_mps,yaw_rate_radps,surface"]
    offset_s = 0.0
    for path in (
        sorted(logs.glob("free_*_asphalt.csv"))[0],
        sorted(logs.glob("free_*_grass.csv"))[0],
    ):
        surface = path.stem.rsplit("_", 1)[1]
        lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")][1:]
        for line in lines:
            t, rest = line.split(",", 1)
            rows.append(f"{float(t) + offset_s:.3f},{rest},{surface}")
        offset_s += float(lines[-1].split(",", 1)[0]) + 0.05
    log = tmp_path / "both.csv"
    log.write_text("# wbpower-log: 1\n# run_id: both\n" + "\n".join(rows) + "\n")
    result = _wbpower("energy", "--profile", log, "--model", out / "model.json", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert {"rolling_W_per_mps[asphalt]", "rolling_W_per_mps[grass]"} <= set(doc["terms_J"])
    low, high = doc["pi90_J"]
    assert low < doc["measured_J"] < high
