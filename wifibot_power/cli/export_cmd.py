"""`wbpower export` (see shared/spec/cli.md and docs/export.md)."""

from __future__ import annotations

import os
import sys
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import JsonFlag, handles_errors, json_defaults, print_json, warn
from wifibot_power.cli.help import command_help
from wifibot_power.cli.typer_app import app
from wifibot_power.errors import UsageError
from wifibot_power.export import TARGETS, ExportOptions, export_model

#: the `--to` choices: the registry's targets (no list of them here)
To = StrEnum("To", {name: name for name in TARGETS})


ModelFile = Annotated[
    Path, typer.Option("--model", help="A model.json from 'wbpower fit -o' with a drive model.")
]
ToOption = Annotated[
    To,
    typer.Option(
        "--to",
        help="; ".join(f"{t.name}: {t.file_format}" for t in TARGETS.values()) + ".",
    ),
]
Surface = Annotated[
    str | None,
    typer.Option("--surface", help="Whose per-surface terms to export (default: said on stderr)."),
]
OutFile = Annotated[
    Path | None, typer.Option("-o", "--out", help="Write the file here instead of stdout.")
]


def _number(flag: str, help_text: str) -> object:
    return Annotated[float | None, typer.Option(flag, help=help_text)]


BatteryVoltage = _number("--voltage", "The battery's nominal voltage [V] (rmf, gazebo).")
BatteryCapacity = _number("--capacity", "The battery's capacity [Ah] (rmf, gazebo).")
ChargingCurrent = _number("--charging-current", "The battery's charging current [A] (rmf).")
Mass = _number("--mass", "rmf: the mass [kg] when the fit has no inertial term, or instead of it.")
MomentOfInertia = _number(
    "--moment-of-inertia", "rmf: the robot's moment of inertia about its yaw axis [kg m^2]."
)
TurnRate = _number(
    "--turn-rate",
    "rmf: the fleet's angular speed [rad/s]: the moment of inertia then stands for the fitted "
    "turning moment on a turn at that rate.",
)
TurnAngle = _number("--turn-angle", "rmf: that turn's angle [rad] (default pi/2).")
Speed = _number(
    "--speed",
    "gazebo: the load is the power of steady driving at this speed [m/s] (default: idle).",
)


@app.command("export", **command_help("export"))
@handles_errors
def export_command(
    model: ModelFile,
    to: ToOption,
    surface: Surface = None,
    out: OutFile = None,
    battery_voltage: BatteryVoltage = None,
    battery_capacity: BatteryCapacity = None,
    charging_current: ChargingCurrent = None,
    mass: Mass = None,
    moment_of_inertia: MomentOfInertia = None,
    turn_rate: TurnRate = None,
    turn_angle: TurnAngle = None,
    speed: Speed = None,
    json_out: JsonFlag = False,
) -> None:
    """Write the fitted drive model as Open-RMF's or Gazebo's power parameters, each value
    saying which fitted term it comes from; what the target cannot express is said on stderr."""
    options = ExportOptions(
        surface=surface,
        battery_voltage_V=battery_voltage,
        battery_capacity_Ah=battery_capacity,
        charging_current_A=charging_current,
        mass_kg=mass,
        moment_of_inertia_kgm2=moment_of_inertia,
        turn_rate_radps=turn_rate,
        turn_angle_rad=turn_angle,
        speed_mps=speed,
    )
    # the `--json` document also when the command fails (cli.md: `common.JsonDocument`)
    json_defaults(target=to.value, parameters={})
    _check_out_file(out)
    result = export_model(model, to.value, options)
    for message in result.warnings:
        warn(message)
    if out is not None:
        _write(out, result.text)
    if json_out:
        print_json(result.summary())
    elif out is None:
        sys.stdout.write(result.text)


def _check_out_file(out: Path | None) -> None:
    """Refuse an `-o FILE` that cannot be written before any work is done (cli.md)."""
    if out is None:
        return
    if out.is_dir():
        raise UsageError(f"-o {out}: is a folder", fix="give a file name to write")
    parent = out.absolute().parent
    if not parent.is_dir():
        raise UsageError(f"-o {out}: no folder {parent}", fix="create it or give another path")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"-o {out}: {parent} is not writable", fix="give another path")


def _write(out: Path, text: str) -> None:
    """Write whole or not at all (a temporary file renamed over `out`), as a set of one
    (`outputs.write_set`): under its folder's lock, and counted as written, so that a Ctrl-C
    once it is in place exits 3, not 130 (docs/errors.md)."""
    from wifibot_power.outputs import write_set

    write_set(out.absolute().parent, {out.name: lambda tmp: tmp.write_text(text, "utf-8")})
