"""`wbpower export --to rmf|gazebo`: the drive model as Open-RMF's fleet-config parameters and
gz-sim's battery plugin, checked against the schemas those tools' sources document and against
mappings worked out by hand (docs/export.md).

The drive section below is made by hand in cli.md's form; every expected value is computed
here from those numbers, never read back from the exporter.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from wifibot_power.errors import UsageError
from wifibot_power.export import TARGETS, ExportOptions, export_model

# -- the drive model, by hand -----------------------------------------------------------
IDLE_W = 20.0
DRIVE_ON_W = 3.0  # on while moving
QUADRATIC_W_PER_MPS2 = 5.0
EFFECTIVE_MASS_KG = 60.0
BRAKING_MASS_KG = 20.0  # a regenerative drive returns a third of the kinetic energy
ROLLING = {"asphalt": 30.0, "grass": 45.0}  # W/(m/s)
TURNING_ASPHALT_NM = 8.0  # no turning was logged on grass
LAG_S = 0.2


def _term(value: float, unit: str) -> dict:
    return {"value": value, "ci95": [0.9 * value, 1.1 * value], "unit": unit}


def drive_section() -> dict:
    """cli.md's `drive` object: shared terms, per-surface terms, what was not determined."""
    return {
        "terms": {
            "idle_W": _term(IDLE_W, "W"),
            "drive_on_W": _term(DRIVE_ON_W, "W"),
            "quadratic_W_per_mps2": _term(QUADRATIC_W_PER_MPS2, "W/(m/s)^2"),
            "effective_mass_kg": _term(EFFECTIVE_MASS_KG, "kg"),
            "braking_mass_kg": _term(BRAKING_MASS_KG, "kg"),
        },
        "surfaces": {
            "asphalt": {
                "rolling_W_per_mps": _term(ROLLING["asphalt"], "W/(m/s)"),
                "turning_Nm": _term(TURNING_ASPHALT_NM, "N m"),
            },
            "grass": {"rolling_W_per_mps": _term(ROLLING["grass"], "W/(m/s)")},
        },
        "lag_s": LAG_S,
        "n_runs": 12,
        "heldout": {
            "runs": [
                {"run_id": "a1", "surface": "asphalt"},
                {"run_id": "a2", "surface": "asphalt"},
                {"run_id": "g1", "surface": "grass"},
            ],
            "mape_pct": 3.0,
            "median_ape_pct": 2.0,
            "coverage_pi90_pct": 90.0,
        },
        "not_determined": ["turning_Nm[grass]: no turning on surface 'grass' in the data"],
        "warnings": [],
    }


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "model.json"
    path.write_text(json.dumps({"format": "wbpower-model", "drive": drive_section()}))
    return path


def write_model(tmp_path, drive) -> str:
    path = tmp_path / "edited.json"
    path.write_text(json.dumps({"format": "wbpower-model", "drive": drive}))
    return str(path)


BATTERY = {"battery_voltage_V": 24.0, "battery_capacity_Ah": 10.0}
RMF_BATTERY = {**BATTERY, "charging_current_A": 5.0}

# -- what the tools read ------------------------------------------------------------------
#: rmf_fleet_adapter's EasyFullControl.cpp (open-rmf/rmf_ros2 9dedd0f,
#: FleetConfiguration::from_config_files) reads these keys under `rmf_fleet`, each
#: `.as<double>()`; rmf_battery's `make` functions (open-rmf/rmf_battery c9caa39) refuse a
#: value outside these bounds (True: > 0; False: >= 0, PowerSystem::make).
RMF_SCHEMA = {
    "battery_system": {"voltage": True, "capacity": True, "charging_current": True},
    "mechanical_system": {"mass": True, "moment_of_inertia": True, "friction_coefficient": True},
    "ambient_system": {"power": False},
    "tool_system": {"power": False},
}
#: SimpleMotionPowerSink.cpp, compute_friction_energy: `const double g = 9.81`
RMF_G = 9.81


def load_yaml(text: str) -> dict:
    """Parse YAML with a real parser (ruamel.yaml, which the test install brings), else the
    tiny parser below (nested mappings of numbers, comments after '#')."""
    try:
        from ruamel.yaml import YAML
    except ImportError:
        return _tiny_yaml(text)
    return YAML(typ="safe").load(text)


def _tiny_yaml(text: str) -> dict:
    root: dict = {}
    stack = [(-1, root)]
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        indent = len(line) - len(line.lstrip())
        key, _, value = line.strip().partition(":")
        while stack[-1][0] >= indent:
            stack.pop()
        if value.strip():
            stack[-1][1][key] = float(value)
        else:
            stack[-1][1][key] = child = {}
            stack.append((indent, child))
    return root


def check_rmf_schema(doc: dict) -> dict:
    """The fragment is `rmf_fleet:` with only documented sections and keys, each a number RMF
    accepts; returns the sections."""
    assert set(doc) == {"rmf_fleet"}
    fleet = doc["rmf_fleet"]
    assert set(fleet) <= set(RMF_SCHEMA), set(fleet) - set(RMF_SCHEMA)
    for section, keys in fleet.items():
        assert set(keys) == set(RMF_SCHEMA[section]), (section, keys)
        for key, value in keys.items():
            assert isinstance(value, float), (section, key, value)
            assert value > 0 if RMF_SCHEMA[section][key] else value >= 0, (section, key)
    return fleet


# -- RMF: the mappings by hand -------------------------------------------------------------
def test_rmf_yaml_loads_in_rmf_schema_and_maps_each_term(model_file):
    result = export_model(
        model_file, "rmf", ExportOptions(turn_rate_radps=0.5, **RMF_BATTERY, surface="asphalt")
    )
    fleet = check_rmf_schema(load_yaml(result.text))
    assert set(fleet) == set(RMF_SCHEMA)  # every section EasyFullControl needs
    mech = fleet["mechanical_system"]
    # RMF charges m|a||v| speeding up and slowing down: (60 - 20) / 2 = 20 kg
    assert mech["mass"] == pytest.approx(20.0, rel=1e-12)
    # f m g = rolling: 30 / (20 * 9.81)
    assert mech["friction_coefficient"] == pytest.approx(30.0 / (20.0 * 9.81), rel=1e-12)
    # I w^2 = M theta: 8 * (pi/2) / 0.5^2
    assert mech["moment_of_inertia"] == pytest.approx(8.0 * math.pi / 2 / 0.25, rel=1e-12)
    assert fleet["ambient_system"]["power"] == IDLE_W
    assert fleet["tool_system"]["power"] == 0.0
    assert fleet["battery_system"] == {"voltage": 24.0, "capacity": 10.0, "charging_current": 5.0}


def test_rmf_grass_takes_its_own_rolling_term(model_file):
    result = export_model(
        model_file, "rmf", ExportOptions(surface="grass", mass_kg=35.0, moment_of_inertia_kgm2=4.0)
    )
    mech = check_rmf_schema(load_yaml(result.text))["mechanical_system"]
    assert mech["mass"] == 35.0
    assert mech["friction_coefficient"] == pytest.approx(45.0 / (35.0 * 9.81), rel=1e-12)
    assert mech["moment_of_inertia"] == 4.0


def _rmf_motion_energy_J(mass_kg, inertia_kgm2, friction, t_s, v_mps, w_radps):
    """RMF's energy of a motion (SimpleMotionPowerSink.cpp, compute_change_in_charge, before
    the division by voltage): the sum over steps of (m |a| |v| + I |alpha| |w|) dt + f m g |v|
    dt, here on a fine grid instead of RMF's 0.5 s steps."""
    dt = np.diff(t_s)
    v, w = (v_mps[1:] + v_mps[:-1]) / 2, (w_radps[1:] + w_radps[:-1]) / 2
    a, alpha = np.diff(v_mps) / dt, np.diff(w_radps) / dt
    kinetic = (mass_kg * np.abs(a) * np.abs(v) + inertia_kgm2 * np.abs(alpha) * np.abs(w)) * dt
    return float(np.sum(kinetic + friction * mass_kg * RMF_G * np.abs(v) * dt))


def _trapezoid(peak, rate, total, n=200_001):
    """A rest-to-rest speed profile: ramp at `rate` to `peak`, hold, ramp down; `total` is
    the distance (or angle) covered."""
    ramp_s = peak / rate
    hold_s = total / peak - ramp_s
    t = np.linspace(0.0, 2 * ramp_s + hold_s, n)
    speed = np.minimum.reduce([rate * t, np.full_like(t, peak), rate * (t[-1] - t)])
    return t, np.clip(speed, 0.0, None)


def test_rmf_energy_of_a_move_and_a_turn_is_the_drive_models(model_file):
    """The exported parameters make RMF's own energy formula give the drive model's energy
    (without idle and v^2, which RMF's motion sink does not hold) for a move from rest to rest
    and for a turn in place, worked out by hand."""
    result = export_model(model_file, "rmf", ExportOptions(turn_rate_radps=0.5))
    mech = load_yaml(result.text)["rmf_fleet"]["mechanical_system"]
    args = (mech["mass"], mech["moment_of_inertia"], mech["friction_coefficient"])
    # 5 m, at most 1 m/s, ramps at 0.5 m/s^2. By hand: rolling 30 W/(m/s) x 5 m = 150 J;
    # speeding up 60 kg x 1^2/2 = 30 J; braking returns 20 kg x 1^2/2 = 10 J: 170 J.
    t, v = _trapezoid(1.0, 0.5, 5.0)
    move_J = _rmf_motion_energy_J(*args, t, v, np.zeros_like(t))
    assert move_J == pytest.approx(170.0, rel=1e-4)
    # a quarter turn in place at 0.5 rad/s, ramps at 2 rad/s^2: 8 N m x pi/2 rad = 12.566 J
    t, w = _trapezoid(0.5, 2.0, math.pi / 2)
    turn_J = _rmf_motion_energy_J(*args, t, np.zeros_like(t), w)
    assert turn_J == pytest.approx(8.0 * math.pi / 2, rel=1e-4)


def test_rmf_each_value_says_its_term_and_what_rmf_cannot_express(model_file):
    result = export_model(model_file, "rmf", ExportOptions(turn_rate_radps=0.5))
    summary = json.loads(json.dumps(result.summary()))
    params = summary["parameters"]
    assert params["mechanical_system.mass"]["from"] == "effective_mass_kg, braking_mass_kg"
    assert params["mechanical_system.friction_coefficient"]["from"] == "rolling_W_per_mps[asphalt]"
    assert params["mechanical_system.moment_of_inertia"]["from"] == "turning_Nm[asphalt]"
    assert params["ambient_system.power"]["from"] == "idle_W"
    assert params["tool_system.power"]["from"] == "not fitted"
    assert summary["error"] is None and summary["target"] == "rmf"
    # in the file: a comment on every value line, naming where it comes from
    values = [line for line in result.text.splitlines() if line.startswith("    ")]
    assert len(values) == 5
    for line in values:
        assert "# " in line and ("from " in line or "not fitted" in line), line
    warnings = "\n".join(summary["warnings"])
    for said in (
        "surfaces asphalt, grass: the terms of 'asphalt'",  # the default surface, said
        "quadratic_W_per_mps2 = 5",
        "drive_on_W = 3 W",
        "braking",
        "lag_s = 0.2",
        "surface 'grass' would be friction_coefficient",
        "battery_system is not written",
        "tool_system.power is 0 W",
        "on a turn of 1.5708 rad at 0.5 rad/s only",
    ):
        assert said in warnings, said


def test_rmf_undetermined_braking_is_a_warning_and_a_stated_assumption(tmp_path):
    drive = drive_section()
    del drive["terms"]["braking_mass_kg"]
    drive["not_determined"].append("braking_mass_kg: no braking in the data")
    result = export_model(write_model(tmp_path, drive), "rmf", ExportOptions(turn_rate_radps=0.5))
    mech = load_yaml(result.text)["rmf_fleet"]["mechanical_system"]
    assert mech["mass"] == pytest.approx(EFFECTIVE_MASS_KG / 2, rel=1e-12)
    assert any("braking_mass_kg: no braking in the data" in w for w in result.warnings)


@pytest.mark.parametrize(
    ("edit", "options", "message"),
    [
        (lambda d: d["terms"].pop("effective_mass_kg"), {}, "give --mass KG"),
        (lambda d: d["terms"].pop("idle_W"), {}, "ambient_system.power needs idle_W"),
        (lambda d: d["surfaces"]["asphalt"].pop("rolling_W_per_mps"), {}, "friction_coefficient"),
        (lambda d: d["surfaces"]["asphalt"]["rolling_W_per_mps"].update(value=0.0), {}, "<= 0"),
        (lambda d: d["terms"]["braking_mass_kg"].update(value=70.0), {}, "mass > 0"),
        (lambda d: None, {"surface": "grass"}, "no turning on surface 'grass'"),
        (lambda d: None, {"surface": "ice"}, "the model has surfaces asphalt, grass"),
        (lambda d: None, {"battery_voltage_V": 24.0}, "give also --capacity"),
        (lambda d: None, {"speed_mps": 1.0}, "--speed: not an option of --to rmf"),
        (lambda d: None, {"moment_of_inertia_kgm2": 3.0}, "give one of them"),
    ],
)
def test_rmf_what_cannot_be_exported_is_a_one_line_error(tmp_path, edit, options, message):
    drive = drive_section()
    edit(drive)
    path = write_model(tmp_path, drive)
    with pytest.raises(UsageError) as err:
        export_model(path, "rmf", ExportOptions(**{"turn_rate_radps": 0.5, **options}))
    text = err.value.one_line()
    assert message in text and "\n" not in text
    assert path in text or "--" in text  # names the file, or the option to change


def test_rmf_moment_of_inertia_needs_a_turn_rate_or_a_value(model_file):
    with pytest.raises(UsageError, match="give --turn-rate RADPS"):
        export_model(model_file, "rmf")


def test_given_mass_replaces_the_fitted_one_and_says_so(model_file):
    result = export_model(model_file, "rmf", ExportOptions(mass_kg=50.0, turn_rate_radps=0.5))
    mech = load_yaml(result.text)["rmf_fleet"]["mechanical_system"]
    assert mech["mass"] == 50.0
    assert mech["friction_coefficient"] == pytest.approx(30.0 / (50.0 * 9.81), rel=1e-12)
    assert any(
        "instead of the fitted inertial terms (they give 20 kg)" in w for w in result.warnings
    )


# -- Gazebo ---------------------------------------------------------------------------------
#: gz-sim 93bbf3e, src/systems/battery_plugin/LinearBatteryPlugin.cc and tutorials/battery.md:
#: the plugin's file and name, and the elements it reads (type each `_sdf->Get<T>`)
GZ_FILENAME = "gz-sim-linearbatteryplugin-system"
GZ_NAME = "gz::sim::systems::LinearBatteryPlugin"
GZ_ELEMENTS = {
    "battery_name": str,
    "voltage": float,
    "open_circuit_voltage_constant_coef": float,
    "open_circuit_voltage_linear_coef": float,
    "initial_charge": float,
    "capacity": float,
    "resistance": float,
    "smooth_current_tau": float,
    "power_load": float,
    "enable_recharge": bool,
    "charging_time": float,
    "fix_issue_225": bool,
    "start_draining": bool,
}


def check_gazebo_schema(text: str) -> dict:
    root = ET.fromstring(text)
    assert root.tag == "plugin"
    assert root.attrib == {"filename": GZ_FILENAME, "name": GZ_NAME}
    values = {}
    for child in root:
        assert child.tag in GZ_ELEMENTS, child.tag
        kind = GZ_ELEMENTS[child.tag]
        if kind is bool:
            assert child.text in ("true", "false")
            values[child.tag] = child.text == "true"
        else:
            values[child.tag] = kind(child.text)
    # what Configure() refuses to load without
    assert values["battery_name"] and values["voltage"] > 0 and values["capacity"] > 0
    assert "power_load" in values
    return values


def test_gazebo_plugin_loads_as_documented_and_is_the_idle_power_by_default(model_file):
    result = export_model(model_file, "gazebo", ExportOptions(**BATTERY))
    values = check_gazebo_schema(result.text)
    assert values["power_load"] == IDLE_W
    assert values["voltage"] == values["open_circuit_voltage_constant_coef"] == 24.0
    assert values["capacity"] == 10.0
    assert values["fix_issue_225"] and values["start_draining"]
    warnings = "\n".join(result.warnings)
    assert "give --speed V" in warnings and "rolling_W_per_mps = 30" in warnings
    assert "effective_mass_kg = 60" in warnings and "turning_Nm = 8" in warnings
    assert "lag_s = 0.2" in warnings and "surfaces not exported: grass" in warnings


def test_gazebo_load_at_a_steady_speed_by_hand(model_file):
    result = export_model(
        model_file, "gazebo", ExportOptions(speed_mps=0.5, surface="grass", **BATTERY)
    )
    values = check_gazebo_schema(result.text)
    # idle + drive on + rolling on grass at 0.5 m/s + quadratic at 0.5 m/s
    assert values["power_load"] == pytest.approx(20.0 + 3.0 + 22.5 + 1.25, rel=1e-12)
    summary = result.summary()["parameters"]["power_load"]
    assert summary["from"] == "idle_W, drive_on_W, rolling_W_per_mps[grass], quadratic_W_per_mps2"
    # every element has its origin in a comment just before it
    lines = result.text.splitlines()
    for i, line in enumerate(lines):
        if line.strip().startswith("<") and not line.strip().startswith(("<!--", "<plugin", "</")):
            assert lines[i - 1].strip().startswith("<!--"), line


def test_a_term_no_target_knows_is_said_not_dropped(tmp_path):
    drive = drive_section()
    drive["terms"]["tyre_pressure_W_per_bar"] = _term(2.0, "W/bar")
    path = write_model(tmp_path, drive)
    for target, options in (("rmf", {"turn_rate_radps": 0.5}), ("gazebo", BATTERY)):
        result = export_model(path, target, ExportOptions(**options))
        assert any("tyre_pressure_W_per_bar = 2 W/bar" in w for w in result.warnings), target


def test_gazebo_steady_load_without_the_optional_terms(tmp_path):
    drive = drive_section()
    del drive["terms"]["drive_on_W"]  # a model without the term: nothing to say
    del drive["terms"]["quadratic_W_per_mps2"]  # not determined: said
    drive["not_determined"].append("quadratic_W_per_mps2 cannot be told apart from idle_W")
    options = ExportOptions(speed_mps=-0.5, surface="asphalt", **BATTERY)  # reversing
    result = export_model(write_model(tmp_path, drive), "gazebo", options)
    assert check_gazebo_schema(result.text)["power_load"] == pytest.approx(20.0 + 15.0)
    assert any("left out of <power_load>: quadratic_W_per_mps2" in w for w in result.warnings)
    assert not any("drive_on_W" in w for w in result.warnings)


def test_gazebo_needs_the_battery(model_file):
    with pytest.raises(UsageError, match="give --voltage V and --capacity AH"):
        export_model(model_file, "gazebo")


# -- the model file ---------------------------------------------------------------------------
def test_a_model_without_a_drive_model_is_a_one_line_error(tmp_path):
    path = tmp_path / "paper.json"
    path.write_text(json.dumps({"format": "wbpower-model", "idle_W": 23.3}))
    for target in TARGETS:
        with pytest.raises(UsageError) as err:
            export_model(path, target, ExportOptions())
        assert str(path) in err.value.one_line() and "no drive model" in err.value.one_line()
    path.write_text(json.dumps({"drive": None}))
    with pytest.raises(UsageError, match="no drive model"):
        export_model(path, "rmf")
    path.write_text("{not json")
    with pytest.raises(UsageError, match="cannot read the model"):
        export_model(path, "rmf")


def test_a_model_without_surfaces_exports_its_terms(tmp_path):
    drive = drive_section()
    asphalt = drive.pop("surfaces")["asphalt"]
    drive["terms"].update(asphalt)
    result = export_model(write_model(tmp_path, drive), "rmf", ExportOptions(turn_rate_radps=0.5))
    assert result.surface is None
    assert not any("surface" in w for w in result.warnings)
    assert result.summary()["parameters"]["mechanical_system.friction_coefficient"]["from"] == (
        "rolling_W_per_mps"
    )
    with pytest.raises(UsageError, match="the model has no surfaces"):
        export_model(write_model(tmp_path, drive), "rmf", ExportOptions(surface="grass"))


def test_sdf_comments_stay_comments_whatever_the_file_name(tmp_path, model_file):
    odd = tmp_path / "a--b-"
    odd.mkdir()
    path = odd / "model.json-"
    path.write_text(model_file.read_text())
    result = export_model(path, "gazebo", ExportOptions(**BATTERY))
    check_gazebo_schema(result.text)  # parses: no "--" inside a comment


# -- the command line -------------------------------------------------------------------------
def test_cli_export_end_to_end(wbpower, model_file, tmp_path):
    result = wbpower("export", "--model", model_file, "--to", "rmf", "--turn-rate", "0.5")
    assert result.exit_code == 0, result.stderr
    check_rmf_schema(load_yaml(result.stdout))
    assert "wbpower: warning: not expressible in RMF: quadratic_W_per_mps2" in result.stderr

    out = tmp_path / "battery.sdf"
    args = ("--voltage", "24", "--capacity", "10", "--speed", "0.5")
    result = wbpower("export", "--model", model_file, "--to", "gazebo", *args, "-o", out)
    assert result.exit_code == 0 and result.stdout == ""
    assert check_gazebo_schema(out.read_text())["power_load"] == pytest.approx(39.25)

    result = wbpower("export", "--model", model_file, "--to", "gazebo", *args, "--json")
    doc = json.loads(result.stdout)
    assert doc["error"] is None and doc["parameters"]["power_load"]["value"] == pytest.approx(39.25)
    assert doc["warnings"] and doc["text"] == out.read_text()


def test_cli_errors_are_one_line_and_json_still_parses(wbpower, tmp_path):
    missing = tmp_path / "none.json"
    result = wbpower("export", "--model", missing, "--to", "rmf")
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and str(missing) in result.stderr
    result = wbpower("export", "--model", missing, "--to", "rmf", "--json")
    assert result.exit_code == 2 and "no such model file" in json.loads(result.stdout)["error"]
    result = wbpower("export", "--model", missing, "--to", "nowhere")
    assert result.exit_code == 2 and result.stderr.count("\n") == 1


def test_cli_refuses_an_output_it_cannot_write_before_any_work(wbpower, model_file, tmp_path):
    result = wbpower("export", "--model", model_file, "--to", "rmf", "-o", tmp_path)
    assert result.exit_code == 2 and "is a folder" in result.stderr
