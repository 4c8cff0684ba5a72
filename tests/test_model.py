"""model.json: versioned, and loads back to the same model (NaN written as null)."""

from __future__ import annotations

import json

import pytest

from wifibot_power.errors import UsageError
from wifibot_power.model import LinearFit, PowerModel, load_model, paper_model
from wifibot_power.outputs import json_safe, write_json


def _as_json(model: PowerModel) -> str:
    return json.dumps(json_safe(model.to_json()), sort_keys=True)


def test_paper_model_round_trips_through_model_json(tmp_path):
    model = paper_model()  # its fits have NaN intervals and R²: written as null
    write_json(tmp_path / "model.json", model.to_json())
    loaded = load_model(tmp_path / "model.json")
    assert loaded == model
    assert _as_json(loaded) == _as_json(model)
    assert loaded.accel_power_W(1.0) == pytest.approx(23.9 + 14.8)


def test_extended_model_round_trips(tmp_path):
    model = PowerModel(
        accel=LinearFit(24.0, 14.0, (23.5, 24.5), (13.0, 15.0), 0.99, 20),
        cruise=LinearFit(23.8, 11.0, (23.6, 24.0), (10.5, 11.5), 0.998, 20),
        idle_W=23.3,
        t_acc=LinearFit(0.0, 1.0),
        components_W={"network": 4.4, "video": None, "cpu": 2.1},
        extensions={
            "decel_phase": {"t_dec_s": 0.3, "P_dec_intercept_W": 23.9, "P_dec_slope_W_per_mps": 5.6}
        },
        source="diagnose",
    )
    write_json(tmp_path / "model.json", model.to_json())
    assert load_model(tmp_path / "model.json") == model  # no NaN here: plain equality


@pytest.mark.parametrize(
    "content, message",
    [
        ('{"format": "other"}', "not a wbpower model"),
        ('{"format": "wbpower-model", "format_version": 99}', "format version 99"),
        ('{"format": "wbpower-model", "format_version": 1}', "incomplete"),
        ("not json", "cannot read"),
        ("[1, 2]", "not a wbpower model"),
    ],
)
def test_bad_model_files_are_clear_errors(tmp_path, content, message):
    path = tmp_path / "model.json"
    path.write_text(content)
    with pytest.raises(UsageError, match=message) as info:
        load_model(path)
    assert str(path) in str(info.value)


def test_missing_model_file_names_it(tmp_path):
    with pytest.raises(UsageError, match="no such model file"):
        load_model(tmp_path / "absent.json")
