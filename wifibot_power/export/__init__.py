"""`wbpower export`: the fitted drive model in the form the robot software people run takes
(cli.md, "`wbpower export --model FILE --to rmf|gazebo`"). One module per target behind
`base.Target`; `TARGETS` is the only list of them. docs/export.md gives each mapping's physics
and source.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from wifibot_power.errors import UsageError
from wifibot_power.export import gazebo, rmf
from wifibot_power.export.base import (
    DriveTerms,
    Export,
    ExportOptions,
    Parameter,
    Target,
    drive_terms,
    read_drive_section,
)
from wifibot_power.power_kind import power_kind_of, unit_doubts

#: `--to` name -> target
TARGETS: dict[str, Target] = {t.name: t for t in (rmf.TARGET, gazebo.TARGET)}

#: the command-line flag of each `ExportOptions` field (for "--X does not apply" messages)
OPTION_FLAGS = {
    "battery_voltage_V": "--voltage",
    "battery_capacity_Ah": "--capacity",
    "charging_current_A": "--charging-current",
    "mass_kg": "--mass",
    "moment_of_inertia_kgm2": "--moment-of-inertia",
    "turn_rate_radps": "--turn-rate",
    "turn_angle_rad": "--turn-angle",
    "speed_mps": "--speed",
}


def export_model(model: str | Path | dict, to: str, options: ExportOptions | None = None) -> Export:
    """Export the drive model of `model` (a model.json path, or its `drive` section as a
    mapping) to the target `to` ("rmf" or "gazebo")."""
    options = options or ExportOptions()
    target = TARGETS.get(to)
    if target is None:
        raise UsageError(f"unknown export target '{to}'", fix=f"give --to {'|'.join(TARGETS)}")
    unused = [OPTION_FLAGS[k] for k in options.given() if k not in target.options]
    if unused:
        raise UsageError(
            f"{', '.join(unused)}: not an option of --to {to}",
            fix=f"leave out {', '.join(unused)}",
        )
    if isinstance(model, dict):
        file, section = "model.json", model
    else:
        file, section = str(model), read_drive_section(model)
    kind = power_kind_of(section)
    if kind != "power":
        logs = "its logs" if kind == "current_proxy" else "some of its logs"
        raise UsageError(
            f"the drive model was fitted on current-only logs ({logs} hold motor currents "
            "times a nominal voltage: voltage_assumed_V): its terms are forces times the "
            f"motors' no-load speed, not the power drawn, and --to {to} takes power parameters",
            file=file,
            fix="fit logs that hold the battery's power (a power column, or its voltage and "
            "current) and export that model",
        )
    exported = target.export(drive_terms(section, options.surface, file=file), options)
    # a model whose speed's unit is in doubt exports wrong values: said with them
    doubts = unit_doubts(section.get("warnings"))
    return replace(exported, warnings=(*doubts, *exported.warnings)) if doubts else exported


__all__ = [
    "TARGETS",
    "DriveTerms",
    "Export",
    "ExportOptions",
    "Parameter",
    "Target",
    "drive_terms",
    "export_model",
    "read_drive_section",
]
