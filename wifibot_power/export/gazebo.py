"""Gazebo: the drive model as the `<power_load>` of gz-sim's battery system, the SDF
`<plugin>` element of `gz::sim::systems::LinearBatteryPlugin` [1], [2].

How Gazebo uses it ([1], `OnUpdateVoltage`): every step, the current drawn is the sum of the
consumers' power loads over the battery voltage, i = sum(P) / V, and the charge falls by
i dt / 3600 Ah; the voltage is e0 + e1 (1 - q/c) - r i. `<power_load>` is a constant [W]: the
battery knows nothing of the robot's speed, so of the drive model only a constant power can be
expressed, the robot standing (idle_W) or driving steadily at one speed (`--speed`):

    P = idle_W + rolling_W_per_mps |v| + quadratic_W_per_mps2 v^2

The plugin refuses to load without `<battery_name>`, `<voltage>` and a `<capacity>` > 0, and
e0 (`<open_circuit_voltage_constant_coef>`) defaults to 0 V, which stops the battery at its first
update: those are written from the battery the user names. `<fix_issue_225>` true (else the
charge falls 100 times too fast, [2], "Known limitations"); `<start_draining>` true (else the
battery drains only once a topic says so).

Gazebo classic's LinearBatteryConsumerPlugin [3] takes the same constant `<power_load>`.

References
----------
[1] gazebosim/gz-sim, commit 93bbf3ed1bd25df32709fee40d6935bf36d2bac8:
    src/systems/battery_plugin/LinearBatteryPlugin.cc and .hh (the SDF parameters, `Configure`,
    `OnUpdateVoltage`; plugin file `gz-sim-linearbatteryplugin-system`, name
    `gz::sim::systems::LinearBatteryPlugin`).
[2] same commit: tutorials/battery.md, examples/worlds/linear_battery_demo.sdf.
[3] gazebosim/gazebo-classic, plugins/LinearBatteryConsumerPlugin.cc (commit
    2217b19ed4c9c738dd820a4e4c448f030b96b26e): `<link_name>`, `<battery_name>`,
    `<power_load>` [W].
"""

from __future__ import annotations

import re
from xml.sax.saxutils import escape

from wifibot_power.errors import UsageError
from wifibot_power.export.base import (
    DriveTerms,
    Export,
    ExportOptions,
    Parameter,
    Target,
    fmt,
    interval,
    unexpressed,
)

PLUGIN_FILENAME = "gz-sim-linearbatteryplugin-system"
PLUGIN_NAME = "gz::sim::systems::LinearBatteryPlugin"
BATTERY_NAME = "linear_battery"


def steady_power_W(
    idle_W: float,
    drive_on_W: float,
    rolling_W_per_mps: float,
    quadratic_W_per_mps2: float,
    speed_mps: float,
) -> float:
    """The drive model's power [W] driving straight at a steady speed (no acceleration, no
    turning): P = idle_W + drive_on_W [v != 0] + rolling_W_per_mps |v| + quadratic_W_per_mps2
    v^2 (cli.md, "The drive model"; the terms of wifibot_power/drive/terms.py)."""
    v = abs(speed_mps)
    return (
        idle_W
        + (drive_on_W if v > 0 else 0.0)
        + rolling_W_per_mps * v
        + quadratic_W_per_mps2 * v * v
    )


class GazeboTarget(Target):
    name = "gazebo"
    file_format = "SDF <plugin> element of gz-sim's LinearBatteryPlugin"
    options = ("battery_voltage_V", "battery_capacity_Ah", "speed_mps")

    def export(self, drive: DriveTerms, options: ExportOptions) -> Export:
        warnings: list[str] = []
        if drive.surface_note:
            warnings.append(drive.surface_note)
        battery = _battery(options)
        load = _power_load(drive, options.speed_mps, warnings)
        warnings += _not_expressible(drive, options.speed_mps)
        params = (*battery, load)
        return Export(
            target=self.name,
            file_format=self.file_format,
            surface=drive.surface,
            parameters=params,
            text=render_sdf(params, drive),
            warnings=tuple(warnings),
        )


def _battery(options: ExportOptions) -> tuple[Parameter, ...]:
    voltage, capacity = options.battery_voltage_V, options.battery_capacity_Ah
    if voltage is None or capacity is None:
        raise UsageError(
            "gz-sim's LinearBatteryPlugin does not load without the battery's <voltage> and "
            "<capacity> (not in power logs)",
            fix="give --voltage V and --capacity AH",
        )
    if not (voltage > 0 and capacity > 0):
        raise UsageError(
            "--voltage and --capacity must be > 0 (the plugin refuses a capacity <= 0)",
            fix="give positive values",
        )
    return (
        Parameter("battery_name", BATTERY_NAME, "", "fixed", "a name", fitted=False),
        Parameter("voltage", float(voltage), "V", "given (--voltage)", fitted=False),
        Parameter(
            "open_circuit_voltage_constant_coef",
            float(voltage),
            "V",
            "given (--voltage)",
            "an ideal battery: constant voltage (else e0 = 0 V stops it at once)",
            fitted=False,
        ),
        Parameter("capacity", float(capacity), "Ah", "given (--capacity)", fitted=False),
        Parameter(
            "fix_issue_225", True, "", "fixed", "else the charge falls 100x too fast", fitted=False
        ),
        Parameter(
            "start_draining",
            True,
            "",
            "fixed",
            "the robot draws power from the start (else only once a topic says so)",
            fitted=False,
        ),
    )


def _power_load(drive: DriveTerms, speed_mps: float | None, warnings: list[str]) -> Parameter:
    idle = drive.get("idle_W")
    if idle is None:
        raise UsageError(
            f"<power_load> needs idle_W, which the fit did not determine "
            f"({drive.why_not('idle_W')})",
            file=drive.file,
            fix="fit logs in which the robot also stands still",
        )
    if speed_mps is None:
        return Parameter("power_load", idle.value, "W", "idle_W", f"{interval(idle)} (standing)")
    rolling = drive.get("rolling_W_per_mps")
    if rolling is None:
        raise UsageError(
            f"--speed needs rolling_W_per_mps ({drive.why_not('rolling_W_per_mps')})",
            file=drive.file,
            fix="leave out --speed (the load is then idle_W)",
        )
    optional = {}  # the steady terms a model may lack: 0 when it does, said when not determined
    for name in ("drive_on_W", "quadratic_W_per_mps2"):
        term = drive.get(name)
        if term is None and drive.reason(name):
            warnings.append(f"left out of <power_load>: {drive.reason(name)}")
        optional[name] = 0.0 if term is None else term.value
    value = steady_power_W(
        idle.value,
        optional["drive_on_W"],
        rolling.value,
        optional["quadratic_W_per_mps2"],
        speed_mps,
    )
    used = ["idle_W", "drive_on_W", drive.source("rolling_W_per_mps"), "quadratic_W_per_mps2"]
    used = [n for n in used if n not in optional or drive.get(n) is not None]
    v = fmt(abs(speed_mps))
    return Parameter(
        "power_load",
        value,
        "W",
        ", ".join(used),
        "idle_W + drive_on_W + rolling_W_per_mps |v| + quadratic_W_per_mps2 v^2 at v = "
        f"{v} m/s: {fmt(idle.value)} + {fmt(optional['drive_on_W'])} + {fmt(rolling.value)} * "
        f"{v} + {fmt(optional['quadratic_W_per_mps2'])} * {v}^2 (driving steadily)",
    )


def _not_expressible(drive: DriveTerms, speed_mps: float | None) -> list[str]:
    out = []
    constant = "gz-sim's battery drains a constant <power_load>"
    steady = ("drive_on_W", "rolling_W_per_mps", "quadratic_W_per_mps2")
    if speed_mps is None:
        lost = [interval(t) for n in steady if (t := drive.get(n)) is not None]
        if lost:
            out.append(
                f"<power_load> is idle_W, the robot standing: {constant}; not expressed: "
                f"{'; '.join(lost)} (give --speed V for the load of steady driving at V)"
            )
    why = {
        "effective_mass_kg": f"{constant}: no acceleration",
        "braking_mass_kg": f"{constant}: no braking",
        "turning_Nm": f"{constant}: no turning",
    }
    out += unexpressed(drive, {"idle_W", *steady}, "Gazebo", why)
    if drive.lag_s:
        out.append(
            f"not expressible in Gazebo: the lag of power behind speed, lag_s = "
            f"{fmt(drive.lag_s)} s"
        )
    others = [s for s, terms in sorted(drive.other_surfaces.items()) if terms]
    if others:
        out.append(
            "not expressible in Gazebo: per-surface terms (one load per battery); surfaces "
            f"not exported: {', '.join(others)} (give --surface NAME)"
        )
    return out


def render_sdf(params: tuple[Parameter, ...], drive: DriveTerms) -> str:
    """The `<plugin>` element, each value with its origin as a comment before it."""
    surface = f", surface '{drive.surface}'" if drive.surface else ""
    lines = [
        f'<plugin filename="{PLUGIN_FILENAME}" name="{PLUGIN_NAME}">',
        f"  <!-- {_comment(f'wbpower export to gazebo: the drive model of {drive.file}{surface}')}"
        ". Put it in the robot's <model>. -->",
    ]
    for p in params:
        lines.append(f"  <!-- {_comment(p.comment())} -->")
        lines.append(f"  <{p.name}>{escape(_sdf_value(p.value))}</{p.name}>")
    lines.append("</plugin>")
    return "\n".join(lines) + "\n"


def _sdf_value(value: float | str | bool) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _comment(text: str) -> str:
    """Text an XML comment may hold (no `--`, one line)."""
    text = re.sub(r"--([a-z][\w-]*)", r"option '\1'", " ".join(str(text).split()))
    while "--" in text:
        text = text.replace("--", "- -")
    return text + " " if text.endswith("-") else text  # "--->" would end it early


TARGET = GazeboTarget()
