"""model.json: versioned, and loads back to the same model (NaN written as null)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

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


# -- a model file is input: validated like a log (issue 29) ------------------------------


def _fitted_model_text() -> str:
    """A model.json as `fit -o` writes it (the paper's numbers, with intervals)."""
    model = PowerModel(
        accel=LinearFit(23.9, 14.8, (23.8, 24.0), (14.6, 15.0), 0.99, 8),
        cruise=LinearFit(23.9, 11.2, (23.8, 24.0), (11.1, 11.3), 0.99, 8),
        idle_W=23.3,
        t_acc=LinearFit(0.0, 1.0, (-0.1, 0.1), (0.9, 1.1), 0.99, 8),
        components_W={"network": 4.4, "video": None},
        speed_range_mps=(0.1, 0.9),
    )
    return json.dumps(json_safe(model.to_json()), indent=2)


HOSTILE = [
    # (what, how the text is changed, what the message says)
    ("NaN", ('"intercept": 23.9', '"intercept": NaN'), "NaN is not a JSON number"),
    ("Infinity", ('"idle_W": 23.3', '"idle_W": Infinity'), "Infinity is not a JSON number"),
    ("-Infinity", ('"slope": 11.2', '"slope": -Infinity'), "-Infinity is not a JSON number"),
    ("1e400", ('"slope": 11.2', '"slope": 1e400'), "beyond a float"),
    ("1e308", ('"slope": 14.8', '"slope": 1e308'), "accel.slope = 1e+308: outside"),
    ("true", ('"idle_W": 23.3', '"idle_W": true'), "idle_W = true: not a number"),
    ("a string", ('"idle_W": 23.3', '"idle_W": "23.3"'), 'idle_W = "23.3": not a number'),
    ("null coefficient", ('"intercept": 23.9', '"intercept": null'), "not a number"),
    ("negative idle", ('"idle_W": 23.3', '"idle_W": -5'), "negative idle"),
    ("2 kW component", ('"network": 4.4', '"network": 2000'), "components_W.network"),
    ("speeds reversed", ("0.1,\n    0.9", "0.9,\n    0.1"), "speed_range_mps"),
    ("R² above 1", ('"r2": 0.99', '"r2": 7'), "r2 = 7"),
    ("bool n_runs", ('"n_runs": 8', '"n_runs": true'), "not a count"),
]


@pytest.mark.parametrize(("what", "change", "message"), HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_model_values_are_one_line_errors(tmp_path, wbpower, what, change, message):
    text = _fitted_model_text()
    assert change[0] in text
    path = tmp_path / "model.json"
    path.write_text(text.replace(change[0], change[1], 1))
    with pytest.raises(UsageError, match=re.escape(message)) as info:
        load_model(path)
    assert str(path) in str(info.value)
    # through every command that reads a model: exit 2, one line, no number computed
    for command in (
        ["energy", "--speed", "0.5", "--dist", "10", "--json"],
        ["lifetime", "--rate", "54", "--json"],
        ["diagnose", Path(__file__).resolve().parents[1] / "sample_logs", "--json"],
    ):
        result = wbpower(*command, "--model", path)
        assert result.exit_code == 2, (command, result.stdout)
        # --json: one document whose `error` is the one line, and no number computed (cli.md)
        document = json.loads(result.stdout)
        assert set(document) == {"error", "skipped", "warnings"}, document
        assert message in document["error"]
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_the_valid_model_loads(tmp_path):
    path = tmp_path / "model.json"
    path.write_text(_fitted_model_text())
    assert load_model(path).idle_W == 23.3


def test_deep_large_and_special_model_files_are_one_line_errors(tmp_path, wbpower):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    with pytest.raises(UsageError, match="nested 100000 deep"):
        load_model(deep)
    brackets_in_text = tmp_path / "text.json"  # brackets inside strings are not nesting
    brackets_in_text.write_text(_fitted_model_text().replace('"fit"', '"[[[[[[[[[[[[\\"]]"'))
    assert load_model(brackets_in_text).source == '[[[[[[[[[[[["]]'
    big = tmp_path / "big.json"
    big.write_text(" " * (2 << 20) + _fitted_model_text())
    with pytest.raises(UsageError, match="bytes, over"):
        load_model(big)
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    with pytest.raises(UsageError, match="not a regular file"):
        load_model(fifo)  # would block forever in open()
    result = wbpower("energy", "--speed", "0.5", "--dist", "10", "--model", deep)
    assert result.exit_code == 2 and "RecursionError" not in result.stderr
