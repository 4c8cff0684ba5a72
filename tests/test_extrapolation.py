"""A model answers only for the speeds it was fitted on without a word; beyond them it says
so (stderr and a `warnings` key). A fit that cannot determine the model (one speed: no slope)
says so in `warnings` (exit 0: every input was read, cli.md), and `fit -o DIR` leaves no
model.json of an earlier fit beside its tables."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from wifibot_power.energy import energy_report
from wifibot_power.model import load_model, paper_model
from wifibot_power.outputs import json_safe
from wifibot_power.simulate import SimConfig, WriteOptions, write_simulation

WARNING = "outside the 0.1-0.9 m/s the model (paper) was fitted on"


def test_the_paper_model_knows_its_speeds():
    model = paper_model()
    assert model.speed_range_mps == (0.1, 0.9)
    assert model.extrapolation_warnings(0.1) == model.extrapolation_warnings(0.9) == []
    assert WARNING in model.extrapolation_warnings(0.95)[0]
    assert WARNING in model.extrapolation_warnings(0.05)[0]
    assert energy_report(model, 0.5, 10, 1).warnings == ()
    assert WARNING in energy_report(model, 5.0, 10, 1).warnings[0]


@pytest.mark.parametrize(
    ("speed", "warned"), [("5", True), ("0.9", False), ("0.5", False), ("0.02", True)]
)
def test_energy_beyond_the_fitted_speeds_warns(wbpower, speed, warned):
    result = wbpower("energy", "--speed", speed, "--dist", "10", "--json")
    assert result.exit_code == 0
    warnings = json.loads(result.stdout)["warnings"]
    assert bool(warnings) is warned
    assert (WARNING in result.stderr) is warned
    if warned:
        assert f"speed {float(speed):g} m/s" in warnings[0]
    human = wbpower("energy", "--speed", speed, "--dist", "10")
    assert (WARNING in human.stderr) is warned


def test_lifetime_with_b_beyond_the_fitted_speeds_warns(wbpower):
    fast = wbpower("lifetime", "--rate", "54", "--speed", "2", "--json")
    assert fast.exit_code == 0 and WARNING in fast.stderr
    assert WARNING in json.loads(fast.stdout)["warnings"][0]
    usual = wbpower("lifetime", "--rate", "54", "--json")
    assert json.loads(usual.stdout)["warnings"] == [] and usual.stderr == ""


@pytest.fixture(scope="module")
def two_speeds(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("two_speeds")
    config = SimConfig(
        speeds_mps=(0.3, 0.6),
        trips=((2.0, 1),),
        repeats=2,
        modes=("idle",),
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=1.024e-3,
        seed=4,
    )
    write_simulation(config, folder, WriteOptions(columns="power", decimals=3))
    return folder


def test_a_fitted_model_carries_its_speeds_into_model_json(wbpower, two_speeds, tmp_path):
    result = wbpower("fit", two_speeds, "-o", tmp_path / "out", "--json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["speed_range_mps"] == [0.3, 0.6]
    model = load_model(tmp_path / "out" / "model.json")
    assert model.speed_range_mps == (0.3, 0.6)
    assert model.extrapolation_warnings(0.45) == []
    model_json = tmp_path / "out" / "model.json"
    energy = wbpower("energy", "--model", model_json, "--speed", "0.9", "--dist", "2")
    assert "outside the 0.3-0.6 m/s the model (fit) was fitted on" in energy.stderr


def test_a_model_json_carries_the_fits_warnings_to_energy_and_lifetime(
    wbpower, two_speeds, tmp_path
):
    """Two speeds fit a line that cannot be checked: fit warns, and so does every later use
    of its model.json, inside the fitted speeds too (found in review: energy and lifetime
    answered from a weak fit in silence)."""
    fitted = wbpower("fit", two_speeds, "-o", tmp_path / "out", "--json")
    (weak,) = [w for w in json.loads(fitted.stdout)["warnings"] if "speed level" in w]
    model_json = tmp_path / "out" / "model.json"
    assert weak in load_model(model_json).fit_warnings
    for args in (("energy", "--speed", "0.45", "--dist", "2"), ("lifetime", "--rate", "100")):
        used = wbpower(*args, "--model", model_json, "--json")
        assert used.exit_code == 0, used.stderr
        assert f"the model (fit) was fitted with a warning: {weak}" in used.stderr
        assert any(weak in w for w in json.loads(used.stdout)["warnings"])
    assert paper_model().fit_warnings == ()


def test_a_model_json_without_speeds_still_loads(tmp_path):
    data = paper_model().to_json()
    del data["speed_range_mps"]  # written before wbpower recorded the range
    # as wbpower writes it (NaN as null: a model.json with NaN is refused, issue 29)
    (tmp_path / "m.json").write_text(json.dumps(json_safe(data)))
    model = load_model(tmp_path / "m.json")
    assert model.speed_range_mps is None and model.extrapolation_warnings(5.0) == []


def _one_speed(folder: Path) -> Path:
    config = SimConfig(
        speeds_mps=(0.5,),
        trips=((2.0, 1),),
        repeats=2,
        modes=("idle",),
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=1.024e-3,
        seed=4,
    )
    write_simulation(config, folder, WriteOptions(columns="power", decimals=3))
    return folder


def test_fit_on_one_speed_says_its_model_is_incomplete(wbpower, tmp_path):
    folder = _one_speed(tmp_path / "one")
    out = tmp_path / "out"
    result = wbpower("fit", folder, "-o", out, "--json")
    # cli.md's exit codes: 0 "done, every input read"; 1 only for skipped inputs or a
    # --fail-on-* check: the incompleteness is in `warnings` and on stderr instead
    assert result.exit_code == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["model_complete"] is False
    assert any("fewer than 2 distinct speeds" in n for n in summary["notes"])
    (warning,) = [w for w in summary["warnings"] if "the model is incomplete" in w]
    assert "not fitted: P_acc, P_v, t_acc" in warning and "no paper model" in warning
    assert f"wbpower: warning: {warning}" in result.stderr.splitlines()
    # the step runs give the drive model (speed from their phases): model.json holds it alone
    model = json.loads((out / "model.json").read_text())
    assert "accel" not in model and model["drive"] is not None
    human = wbpower("fit", folder)
    assert human.exit_code == 0 and "the model is incomplete" in human.stderr
    # the fit's note is the warning's why, said once: not again as a warning of its own
    assert human.stderr.count("fewer than 2 distinct speeds") == 1


def test_an_incomplete_fit_replaces_the_model_json_of_an_earlier_fit(wbpower, tmp_path):
    # a complete fit into DIR, then one of one speed: its tables, and a model.json without
    # the paper's model (the drive model's alone), never the earlier fit's for `energy
    # --model DIR/model.json` to read as this fit's (a silently wrong number)
    out = tmp_path / "out"
    out.mkdir()
    (out / "model.json").write_text(json.dumps(paper_model().to_json()))
    result = wbpower("fit", _one_speed(tmp_path / "one"), "-o", out, "--json")
    assert result.exit_code == 0, result.stderr
    model = json.loads((out / "model.json").read_text())
    assert "accel" not in model and model["drive"] is not None
    assert not [w for w in json.loads(result.stdout)["warnings"] if "removed" in w]
    energy = wbpower("energy", "--speed", "0.5", "--dist", "2", "--model", out / "model.json")
    assert energy.exit_code == 2 and "incomplete" in energy.stderr


def test_an_incomplete_fit_removes_the_model_json_of_an_earlier_fit(wbpower, tmp_path, monkeypatch):
    # nothing but an incomplete paper model (no drive model: its family fits nothing here):
    # no model.json at all, and the earlier fit's removed with the new tables
    from wifibot_power.models import FAMILIES

    monkeypatch.setattr(type(FAMILIES["drive"]), "fit", lambda self, records, options=None: None)
    out = tmp_path / "out"
    out.mkdir()
    (out / "model.json").write_text(json.dumps(paper_model().to_json()))
    (out / "keep.txt").write_text("not the fit's")
    result = wbpower("fit", _one_speed(tmp_path / "one"), "-o", out, "--json")
    assert result.exit_code == 0, result.stderr
    assert not (out / "model.json").exists()
    assert sorted(p.name for p in out.iterdir()) == [
        "keep.txt",
        "phases.parquet",
        "runs.parquet",
        "stop_and_go.parquet",
    ]
    (removed,) = [w for w in json.loads(result.stdout)["warnings"] if "removed" in w]
    assert str(out / "model.json") in removed and "earlier fit" in removed
    assert removed in result.stderr
    energy = wbpower("energy", "--speed", "0.5", "--dist", "2", "--model", out / "model.json")
    assert energy.exit_code == 2 and "no such model file" in energy.stderr
