"""Open-RMF: the drive model as the fleet config's `battery_system`, `mechanical_system`,
`ambient_system` and `tool_system` (the YAML fragment under `rmf_fleet:`), which
rmf_fleet_adapter turns into rmf_battery's power sinks [1], [2].

How RMF uses them ([1], SimpleMotionPowerSink.cpp, `compute_change_in_charge`): along a
planned trajectory, every 0.5 s step dt adds

    dE = (m |a| |v| + I |alpha| |w|) dt  +  f m g |v| dt,      g = 9.81 m/s^2

(|a|, |alpha|: the magnitudes of the linear and angular accelerations; |v|, |w|: of the
speeds), then dSOC = dE / V_nominal / (capacity * 3600); the ambient sink
(SimpleDevicePowerSink.cpp) adds `power * t` over the whole task, the tool sink likewise. Both
kinetic terms are charged while speeding up *and* while slowing down, and there is no term in
v^2 and no friction moment for turning. The mappings below make RMF's energy equal the drive
model's (cli.md, "The drive model") where RMF's form allows, and say where it does not.

References
----------
[1] open-rmf/rmf_battery, commit c9caa39b1a6b6c65ec6be49908af31d2baa9acc9:
    rmf_battery/src/rmf_battery/agv/SimpleMotionPowerSink.cpp, SimpleDevicePowerSink.cpp,
    MechanicalSystem.cpp (`make`: mass, moment_of_inertia, friction_coefficient > 0),
    BatterySystem.cpp (voltage, capacity, charging_current > 0), PowerSystem.cpp (power >= 0).
[2] open-rmf/rmf_ros2, commit 9dedd0f746e5006d068237e78ca9dfbe47edf622:
    rmf_fleet_adapter/src/rmf_fleet_adapter/agv/EasyFullControl.cpp
    (`FleetConfiguration::from_config_files`: the keys under `rmf_fleet`); an example config
    is open-rmf/rmf_demos, commit e1af33e0e8619a9417bf1d23c4c05246ea1d3802:
    rmf_demos/config/office/tinyRobot_config.yaml.
"""

from __future__ import annotations

import math

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

#: the gravitational acceleration RMF's friction energy uses [m/s^2] ([1],
#: SimpleMotionPowerSink.cpp, `compute_friction_energy`: `const double g = 9.81`): the same
#: constant here makes f m g equal the fitted rolling term exactly
RMF_GRAVITY_MPS2 = 9.81
#: the turn the moment of inertia is made to cost right, unless --turn-angle says [rad]
DEFAULT_TURN_ANGLE_RAD = math.pi / 2
#: what RMF calls each section, and its keys (the schema EasyFullControl.cpp reads, [2])
SCHEMA: dict[str, tuple[str, ...]] = {
    "battery_system": ("voltage", "capacity", "charging_current"),
    "mechanical_system": ("mass", "moment_of_inertia", "friction_coefficient"),
    "ambient_system": ("power",),
    "tool_system": ("power",),
}


def rmf_mass_kg(effective_mass_kg: float, braking_mass_kg: float) -> float:
    """The mass [kg] for which RMF's kinetic term, m |a| |v| charged while speeding up and
    while slowing down ([1]), costs what the drive model's inertial terms cost over any motion
    that ends at the speed it started from (a move from rest to rest):

        m_rmf = (effective_mass_kg - braking_mass_kg) / 2

    Speeding up from v1 to v2 and back, the drive model draws effective_mass_kg (v2^2 - v1^2)/2
    then braking_mass_kg (v1^2 - v2^2)/2 ([`drive.terms`]: m_eff (a v)+ and m_b (a v)-), RMF
    2 m_rmf (v2^2 - v1^2)/2. braking_mass_kg > 0 is energy a regenerative drive returns,
    < 0 energy spent to stop."""
    return (effective_mass_kg - braking_mass_kg) / 2.0


def rmf_friction_coefficient(rolling_W_per_mps: float, mass_kg: float) -> float:
    """RMF's dimensionless friction coefficient f such that its friction power f m g |v|
    ([1], `compute_friction_energy`, g = 9.81 m/s^2) is the drive model's rolling power
    rolling_W_per_mps |v|:

        f = rolling_W_per_mps / (mass_kg * 9.81)

    `mass_kg` is the mass RMF is given (`rmf_mass_kg`), not the robot's: f is an electrical
    equivalent (the drive's efficiency is in the fitted rolling term)."""
    return rolling_W_per_mps / (mass_kg * RMF_GRAVITY_MPS2)


def rmf_moment_of_inertia_kgm2(
    turning_Nm: float, turn_angle_rad: float, turn_rate_radps: float
) -> float:
    """The moment of inertia [kg m^2] for which RMF's rotational term, I |alpha| |w| charged
    while the turn speeds up and while it slows down ([1]), costs a turn in place of
    `turn_angle_rad` at a peak rate of `turn_rate_radps` what the drive model's turning term,
    a friction moment times the rate of turn (turning_Nm |w|), costs:

        I w^2 = turning_Nm * theta   =>   I = turning_Nm * theta / w^2

    (RMF: I w^2/2 to reach w and I w^2/2 to stop; the drive model: turning_Nm theta.) A
    friction moment costs in proportion to the angle, an inertia in proportion to w^2: the
    equivalence holds for this one turn; a turn of angle theta' at w costs I w^2 in RMF,
    turning_Nm theta' in the model."""
    return turning_Nm * turn_angle_rad / turn_rate_radps**2


class RmfTarget(Target):
    name = "rmf"
    file_format = "YAML fragment of an Open-RMF fleet config (rmf_fleet: ...)"
    options = (
        "battery_voltage_V",
        "battery_capacity_Ah",
        "charging_current_A",
        "mass_kg",
        "moment_of_inertia_kgm2",
        "turn_rate_radps",
        "turn_angle_rad",
    )

    def export(self, drive: DriveTerms, options: ExportOptions) -> Export:
        warnings = [drive.surface_note] if drive.surface_note else []
        params: list[Parameter] = []
        params += _battery(options, warnings)
        mass = _mass(drive, options, warnings)
        params.append(mass)
        params.append(_moment_of_inertia(drive, options, warnings))
        params.append(_friction(drive, float(mass.value), warnings))
        idle = _required(drive, "idle_W", "ambient_system.power")
        params.append(Parameter("ambient_system.power", idle.value, "W", "idle_W", interval(idle)))
        params.append(
            Parameter(
                "tool_system.power",
                0.0,
                "W",
                "not fitted",
                "the drive model has no tool term (whatever was on while the logs were taken is "
                "in idle_W, exported as ambient_system.power)",
                fitted=False,
            )
        )
        warnings.append(
            "tool_system.power is 0 W: not from the logs (devices that were on while logging "
            "are in ambient_system.power = idle_W; add a tool's own power here)"
        )
        warnings += _not_expressible(drive, float(mass.value))
        return Export(
            target=self.name,
            file_format=self.file_format,
            surface=drive.surface,
            parameters=tuple(params),
            text=render_yaml(params, drive),
            warnings=tuple(warnings),
        )


def _required(drive: DriveTerms, name: str, what: str):
    term = drive.get(name)
    if term is None:
        raise UsageError(
            f"{what} needs {name}, which the fit did not determine ({drive.why_not(name)})",
            file=drive.file,
            fix="fit logs in which the robot also stands and drives",
        )
    return term


def _battery(options: ExportOptions, warnings: list[str]) -> list[Parameter]:
    given = {
        "voltage": (options.battery_voltage_V, "V", "--voltage"),
        "capacity": (options.battery_capacity_Ah, "Ah", "--capacity"),
        "charging_current": (options.charging_current_A, "A", "--charging-current"),
    }
    present = [key for key, (value, _, _) in given.items() if value is not None]
    if not present:
        warnings.append(
            "battery_system is not written: a battery's nominal voltage, capacity and charging "
            "current are not in power logs (keep your fleet config's, or give "
            "--voltage, --capacity and --charging-current)"
        )
        return []
    if len(present) < len(given):
        missing = [flag for key, (_, _, flag) in given.items() if key not in present]
        raise UsageError(
            "RMF's battery_system needs voltage, capacity and charging_current together",
            fix=f"give also {', '.join(missing)}",
        )
    out = []
    for key, (value, unit, flag) in given.items():
        if not value > 0:
            raise UsageError(
                f"{flag} {value:g}: RMF's BatterySystem::make refuses a value <= 0",
                fix=f"give {flag} > 0",
            )
        out.append(
            Parameter(f"battery_system.{key}", float(value), unit, f"given ({flag})", fitted=False)
        )
    return out


def _mass(drive: DriveTerms, options: ExportOptions, warnings: list[str]) -> Parameter:
    effective = drive.get("effective_mass_kg")
    braking = drive.get("braking_mass_kg")
    if options.mass_kg is not None:
        if not options.mass_kg > 0:
            raise UsageError(f"--mass {options.mass_kg:g}: RMF needs a mass > 0", fix="give > 0")
        if effective is not None:
            warnings.append(
                f"--mass {options.mass_kg:g} kg is exported instead of the fitted inertial "
                f"terms (they give {fmt(rmf_mass_kg(effective.value, _braking(braking)))} kg)"
            )
        else:
            warnings.append(
                f"mechanical_system.mass is the given {options.mass_kg:g} kg: "
                f"{drive.why_not('effective_mass_kg')}"
            )
        return Parameter(
            "mechanical_system.mass", float(options.mass_kg), "kg", "given (--mass)", fitted=False
        )
    if effective is None:
        raise UsageError(
            "RMF's mechanical_system.mass needs effective_mass_kg, which the fit did not "
            f"determine ({drive.why_not('effective_mass_kg')})",
            file=drive.file,
            fix="give --mass KG (the robot's mass), or fit logs with starts and stops",
        )
    if braking is None:
        warnings.append(
            "braking_mass_kg is not determined: slowing down is taken to neither return nor "
            f"cost energy (mass = effective_mass_kg / 2); {drive.why_not('braking_mass_kg')}"
        )
        source = "effective_mass_kg"
        how = (
            f"effective_mass_kg / 2 = {fmt(effective.value)} / 2 (braking not determined, "
            "taken as free); RMF charges m|a||v| speeding up and slowing down"
        )
    else:
        source = "effective_mass_kg, braking_mass_kg"
        how = (
            f"(effective_mass_kg - braking_mass_kg) / 2 = ({fmt(effective.value)} - "
            f"{fmt(braking.value)}) / 2: RMF charges m|a||v| speeding up and slowing down"
        )
    mass_kg = rmf_mass_kg(effective.value, _braking(braking))
    if not mass_kg > 0:
        raise UsageError(
            f"RMF needs a mass > 0, and (effective_mass_kg - braking_mass_kg) / 2 = "
            f"{fmt(mass_kg)} kg (the fit has braking return as much as speeding up costs)",
            file=drive.file,
            fix="give --mass KG (the robot's mass)",
        )
    return Parameter("mechanical_system.mass", mass_kg, "kg", source, how)


def _braking(term) -> float:
    return 0.0 if term is None else term.value


def _friction(drive: DriveTerms, mass_kg: float, warnings: list[str]) -> Parameter:
    rolling = _required(drive, "rolling_W_per_mps", "RMF's mechanical_system.friction_coefficient")
    value = rmf_friction_coefficient(rolling.value, mass_kg)
    if not value > 0:
        raise UsageError(
            f"rolling_W_per_mps is {fmt(rolling.value)} W/(m/s): RMF's MechanicalSystem::make "
            "refuses a friction_coefficient <= 0",
            file=drive.file,
            fix="fit logs with more driving, or set friction_coefficient by hand",
        )
    return Parameter(
        "mechanical_system.friction_coefficient",
        value,
        "1",
        drive.source("rolling_W_per_mps"),
        f"rolling_W_per_mps / (mass * {RMF_GRAVITY_MPS2} m/s^2) = "
        f"{fmt(rolling.value)} / ({fmt(mass_kg)} * {RMF_GRAVITY_MPS2}); {interval(rolling)}",
    )


def _moment_of_inertia(drive: DriveTerms, options: ExportOptions, warnings: list[str]) -> Parameter:
    turning = drive.get("turning_Nm")
    name = "mechanical_system.moment_of_inertia"
    if options.moment_of_inertia_kgm2 is not None:
        if not options.moment_of_inertia_kgm2 > 0:
            raise UsageError("--moment-of-inertia: RMF needs a value > 0", fix="give > 0")
        if options.turn_rate_radps is not None or options.turn_angle_rad is not None:
            raise UsageError(
                "--moment-of-inertia and --turn-rate/--turn-angle both set the moment of inertia",
                fix="give one of them",
            )
        if turning is not None:
            warnings.append(
                f"the fitted turning cost ({interval(turning)}) is not exported: "
                "--moment-of-inertia was given instead"
            )
        return Parameter(
            name,
            options.moment_of_inertia_kgm2,
            "kg m^2",
            "given (--moment-of-inertia)",
            fitted=False,
        )
    if turning is None:
        raise UsageError(
            "RMF's mechanical_system.moment_of_inertia cannot be determined: the drive model "
            f"has no rotational-inertia term and {drive.why_not('turning_Nm')}",
            file=drive.file,
            fix="give --moment-of-inertia KGM2 (e.g. m (L^2 + W^2) / 12 of the chassis)",
        )
    if options.turn_rate_radps is None:
        raise UsageError(
            "RMF's mechanical_system.moment_of_inertia is not in the drive model (it has a "
            f"turning friction moment, {interval(turning)}, and no inertia); it can stand for "
            "that moment on a turn at the fleet's angular speed",
            file=drive.file,
            fix="give --turn-rate RADPS (the fleet's limits.angular speed) or "
            "--moment-of-inertia KGM2",
        )
    rate = options.turn_rate_radps
    angle = options.turn_angle_rad if options.turn_angle_rad is not None else DEFAULT_TURN_ANGLE_RAD
    if not (rate > 0 and angle > 0):
        raise UsageError("--turn-rate and --turn-angle must be > 0", fix="give positive values")
    value = rmf_moment_of_inertia_kgm2(turning.value, angle, rate)
    if not value > 0:
        raise UsageError(
            f"turning_Nm is {fmt(turning.value)} N m: RMF's MechanicalSystem::make refuses a "
            "moment_of_inertia <= 0",
            file=drive.file,
            fix="give --moment-of-inertia KGM2",
        )
    where = f" on '{drive.surface}'" if drive.surface else ""
    warnings.append(
        f"moment_of_inertia {fmt(value)} kg m^2 stands for the turning friction moment "
        f"({interval(turning)}{where}) on a turn of {fmt(angle)} rad at {fmt(rate)} rad/s only: "
        f"RMF charges any turn reaching {fmt(rate)} rad/s the same {fmt(value * rate**2)} J, "
        "the model charges turning_Nm x the angle turned"
    )
    return Parameter(
        name,
        value,
        "kg m^2",
        drive.source("turning_Nm"),
        f"turning_Nm * turn angle / turn rate^2 = {fmt(turning.value)} * {fmt(angle)} / "
        f"{fmt(rate)}^2 (a turn in place costs the same in RMF and in the model)",
    )


def _not_expressible(drive: DriveTerms, mass_kg: float) -> list[str]:
    """What RMF's sinks cannot express, with its size."""
    why = {"drive_on_W": "no power drawn only while moving: RMF leaves it out of every move"}
    quadratic = drive.get("quadratic_W_per_mps2")
    if quadratic is not None:
        why["quadratic_W_per_mps2"] = (
            f"no v^2 term in SimpleMotionPowerSink: RMF leaves out {fmt(quadratic.value)} W at "
            f"1 m/s, {fmt(quadratic.value * 0.25)} W at 0.5 m/s"
        )
    # idle, rolling, the inertial terms and turning are exported (or a given value replaced
    # them, which _mass and _moment_of_inertia said)
    accounted = {
        "idle_W",
        "rolling_W_per_mps",
        "effective_mass_kg",
        "braking_mass_kg",
        "turning_Nm",
    }
    out = unexpressed(drive, accounted, "RMF", why)
    if drive.get("braking_mass_kg") is not None:
        out.append(
            "not expressible in RMF: braking apart from speeding up (RMF charges m|a||v| on "
            "both): the exported mass makes a move from rest to rest cost right, not each phase"
        )
    if drive.lag_s:
        out.append(
            f"not expressible in RMF: the lag of power behind speed, lag_s = {fmt(drive.lag_s)} "
            "s (it shifts power in time, not a move's energy)"
        )
    for surface, terms in sorted(drive.other_surfaces.items()):
        said = []
        rolling = terms.get("rolling_W_per_mps")
        if rolling is not None:
            said.append(
                f"friction_coefficient {fmt(rmf_friction_coefficient(rolling.value, mass_kg))} "
                f"({interval(rolling)})"
            )
        turning = terms.get("turning_Nm")
        if turning is not None:
            said.append(interval(turning))
        if said:
            out.append(
                f"not expressible in RMF: per-surface terms (one mechanical_system per fleet); "
                f"surface '{surface}' would be {', '.join(said)} (give --surface {surface})"
            )
    return out


def render_yaml(params: list[Parameter], drive: DriveTerms) -> str:
    """The fragment under `rmf_fleet:`, each value with its origin as a comment (written by
    hand: RMF reads it with yaml-cpp; a handful of numbers need no YAML library)."""
    by_section: dict[str, list[Parameter]] = {}
    for p in params:
        section, _, _ = p.name.partition(".")
        by_section.setdefault(section, []).append(p)
    surface = f", surface '{drive.surface}'" if drive.surface else ""
    lines = [
        f"# wbpower export --to rmf: the drive model of {drive.file}{surface}",
        "# Merge under rmf_fleet: of an Open-RMF fleet config (read by rmf_fleet_adapter).",
        "# Each value says which fitted term it comes from.",
        "rmf_fleet:",
    ]
    for section in SCHEMA:
        if section not in by_section:
            continue
        lines.append(f"  {section}:")
        for p in by_section[section]:
            key = p.name.partition(".")[2]
            lines.append(f"    {key}: {_yaml_number(float(p.value))} # {p.comment()}")
    return "\n".join(lines) + "\n"


def _yaml_number(value: float) -> str:
    """A float YAML (1.1 and 1.2) and yaml-cpp's as<double>() read back exactly."""
    mantissa, e, exponent = repr(float(value)).partition("e")
    if "." not in mantissa:  # YAML 1.1 reads 1e-05 as a string, 1.0e-05 as a float
        mantissa += ".0"
    return mantissa + e + exponent


TARGET = RmfTarget()
