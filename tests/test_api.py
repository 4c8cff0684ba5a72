"""The library gives what the command line gives, and every command has help."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

import wifibot_power as wb
from wifibot_power.cli import app
from wifibot_power.outputs import json_safe
from wifibot_power.simulate import SimConfig, write_simulation

COMMANDS = ["inspect", "segment", "fit", "energy", "lifetime", "diagnose", "simulate"]


@pytest.fixture(scope="module")
def small_logs(tmp_path_factory):
    out = tmp_path_factory.mktemp("logs")
    config = SimConfig(
        speeds_mps=(0.3, 0.6, 0.9),
        trips=((2.0, 1), (3.0, 3)),
        repeats=2,
        mode_repeats=1,
        mode_duration_s=2.0,
        sample_period_s=0.001024,
        effects={"decel_phase": 0.4},
        seed=4,
    )
    write_simulation(config, out)
    return out


def _cli_json(*args: str) -> dict:
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power.cli", *args, "--json"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def _result_of(document: dict, summary: dict) -> dict:
    """A `--json` document less what every document adds (cli.md: `error`, and `skipped` and
    `warnings` where the result has none): what the library's `summary()` gives."""
    document = dict(document)
    assert document.pop("error") is None
    for key in ("skipped", "warnings"):
        if key not in summary:
            assert document.pop(key) == [], key
    return document


def test_fit_from_python_equals_the_command(small_logs):
    from_python = json_safe(wb.fit_logs([small_logs]).summary())
    assert from_python == _result_of(_cli_json("fit", str(small_logs)), from_python)


def test_diagnose_from_python_equals_the_command(small_logs):
    from_python = json_safe(wb.diagnose_logs([small_logs]).summary())
    from_cli = _result_of(_cli_json("diagnose", str(small_logs)), from_python)
    assert from_python == from_cli
    assert [f["cause"] for f in from_cli["findings"]] == ["decel_phase"]


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help(command):
    result = CliRunner().invoke(app, [command, "--help"])
    assert result.exit_code == 0
    assert "Usage" in result.output and "--help" in result.output


def test_version():
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.strip() == f"wbpower {wb.__version__}"


def test_diagnose_in_parallel_equals_one_file_at_a_time(small_logs):
    one = json_safe(wb.diagnose_logs([small_logs], jobs=1).summary())
    two = json_safe(wb.diagnose_logs([small_logs], jobs=2).summary())
    assert one == two


@pytest.mark.parametrize("command", ["inspect", "segment", "fit", "diagnose"])
def test_every_reading_command_takes_the_shared_reading_options(command):
    help_text = CliRunner().invoke(app, [command, "--help"]).output
    for option in ("--supply-voltage", "--current-column", "--voltage-column", "--sample-period"):
        assert option in help_text


def test_fail_on_discrepancy_exits_1_when_a_cause_is_named(small_logs):
    runner = CliRunner()
    plain = runner.invoke(app, ["diagnose", str(small_logs), "--json", "--jobs", "1"])
    failing = runner.invoke(
        app, ["diagnose", str(small_logs), "--json", "--jobs", "1", "--fail-on-discrepancy"]
    )
    assert plain.exit_code == 0
    assert failing.exit_code == 1  # small_logs carries a decel phase: a finding is made
    assert json.loads(failing.stdout)["findings"][0]["cause"] == "decel_phase"


def test_diagnose_against_a_stored_model(small_logs, tmp_path):
    runner = CliRunner()
    assert runner.invoke(app, ["fit", str(small_logs), "-o", str(tmp_path)]).exit_code == 0
    result = runner.invoke(
        app, ["diagnose", str(small_logs), "--json", "--model", str(tmp_path / "model.json")]
    )
    assert result.exit_code == 0, result.output
    assert "not refitted" in json.loads(result.stdout)["baseline"]["model"]


def test_a_command_loads_only_its_own_module():
    """`wbpower energy` does not pay for diagnose's imports (start-up is most of a warm run)."""
    code = (
        "import sys\n"
        "sys.argv = ['wbpower', 'energy', '--help']\n"
        "from wifibot_power.cli import main\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in sys.modules if m.endswith('_cmd')))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "['wifibot_power.cli.energy_cmd']"
