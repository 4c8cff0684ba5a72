"""A new model family and a new figure are each one module plus one registry line
(tests/toy_plugins.py), exercised end to end through the CLI: `fit --json` shows the family's
section, `fit -o` writes it into model.json beside the paper's model, `fit --cache` keeps its
per-run statistics and its fit, and `report` draws the figure (issue 24)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from toy_plugins import TOY_FIGURE, CruiseConstant

from wifibot_power.figures import FIGURES
from wifibot_power.io import read_log
from wifibot_power.models import FAMILIES
from wifibot_power.segment import segment_run

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
LOGS = [f"v{v}_d2_s1_r1.csv.gz" for v in ("0.30", "0.60", "0.90")] + ["idle_r1.csv.gz"]


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("plugins")
    for name in LOGS:
        shutil.copy(SAMPLE_LOGS / name, folder / name)
    return folder


@pytest.fixture
def toy_family(monkeypatch):
    """The toy family registered: one line (`FAMILIES[name] = family`), undone after."""
    monkeypatch.setitem(FAMILIES, CruiseConstant.name, CruiseConstant())


@pytest.fixture
def toy_figure(monkeypatch):
    monkeypatch.setitem(FIGURES, TOY_FIGURE.name, TOY_FIGURE)


def _cruise_power_W(folder: Path) -> tuple[float, int]:
    """The toy model's one number worked out here, from the logs and their phases: the cruise
    samples' energy over their time, all runs together."""
    energy_J = time_s = 0.0
    runs = 0
    for log in sorted(folder.glob("*.csv.gz")):
        run = read_log(log)
        if run.meta.mode == "unknown":
            continue
        spans = [(p.i_start, p.i_end) for p in segment_run(run).phases if p.phase == "cruise"]
        runs += bool(spans)
        energy_J += sum(float(run.power_W[a:b].sum()) for a, b in spans) * run.sample_period_s
        time_s += sum(b - a for a, b in spans) * run.sample_period_s
    return energy_J / time_s, runs


def test_a_registered_family_has_its_section_in_fit_json_and_model_json(
    logs, toy_family, wbpower, tmp_path
) -> None:
    out = tmp_path / "out"
    result = wbpower("fit", logs, "--json", "--jobs", "2", "-o", out)
    assert result.exit_code == 0, result.stderr
    document = json.loads(result.stdout)
    expected_W, runs = _cruise_power_W(logs)
    assert runs == 3  # the three motion runs; idle has no cruise
    assert document["toy_cruise"]["n_runs"] == runs
    assert document["toy_cruise"]["cruise_power_W"] == pytest.approx(expected_W, rel=1e-12)
    model = json.loads((out / "model.json").read_text())
    assert model["toy_cruise"] == document["toy_cruise"]
    # the paper's model stays model.json's top level, and loads as before
    from wifibot_power.model import load_model

    assert load_model(out / "model.json").accel.slope == document["accel"]["slope_W_per_mps"]


def test_the_paper_sections_are_the_same_with_or_without_another_family(
    logs, wbpower, monkeypatch
) -> None:
    plain = json.loads(wbpower("fit", logs, "--json").stdout)
    monkeypatch.setitem(FAMILIES, CruiseConstant.name, CruiseConstant())
    with_toy = json.loads(wbpower("fit", logs, "--json").stdout)
    assert with_toy.pop("toy_cruise") and with_toy == plain


def test_a_family_is_kept_by_the_cache(logs, toy_family, wbpower, tmp_path, monkeypatch) -> None:
    cache = tmp_path / "cache"
    cold = json.loads(wbpower("fit", logs, "--json", "--cache", cache).stdout)
    # warm: neither segmented nor fitted again; the family's statistics and fit from the cache
    monkeypatch.setattr(CruiseConstant, "run_stats", lambda *a: pytest.fail("worked on"))
    monkeypatch.setattr(CruiseConstant, "fit", lambda *a: pytest.fail("fitted"))
    warm = json.loads(wbpower("fit", logs, "--json", "--cache", cache).stdout)
    assert warm == cold and "toy_cruise" in warm


def test_the_family_predicts_a_run(logs, toy_family) -> None:
    from wifibot_power.fit import fit_logs
    from wifibot_power.pipeline import gather

    fit = fit_logs([logs])
    record = next(r for r in gather([logs]).records if r.row["mode"] == "motion")
    toy = fit.fits["toy_cruise"]
    assert toy.predict_energy_J(record) == pytest.approx(
        toy.cruise_power_W * record.row["cruise_duration_s"], rel=1e-12
    )
    # the paper's family predicts the same run by Eq. 5/6, near its measured motion energy
    paper = fit.paper_fit.predict_energy_J(record)
    assert np.isfinite(paper) and paper == pytest.approx(record.row["motion_energy_J"], rel=0.1)


def test_a_registered_figure_is_drawn_by_report(
    logs, toy_family, toy_figure, wbpower, tmp_path
) -> None:
    out = tmp_path / "report"
    result = wbpower("report", logs, "-o", out, "--json", "--jobs", "1")
    assert result.exit_code == 0, result.stderr
    figures = [Path(p).name for p in json.loads(result.stdout)["figures"]]
    assert "toy_cruise_energy.png" in figures
    # after the model and diagnosis figures, before the runs' traces
    assert figures.index("toy_cruise_energy.png") < figures.index("trace_idle_r1.png")
    assert (out / "figures" / "toy_cruise_energy.png").read_bytes().startswith(b"\x89PNG")
    assert "Toy: cruise energy against cruise time" in (out / "report.html").read_text()
