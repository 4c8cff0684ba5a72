"""What every export target shares: the drive model's terms as model.json holds them, the
options a target may take, one exported parameter, and the result of an export.

The drive model is read from model.json's `drive` section as a plain mapping (cli.md, "The
drive model": `terms: {NAME: {value, ci95, unit}}`, `surfaces: {SURFACE: {NAME: ...}}`,
`lag_s`, `not_determined: [str]`, ...), not through the drive lane's classes: a term that the
fit could not determine is absent from `terms` (and from its surface) and named, with its
reason, in `not_determined`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from wifibot_power.errors import UsageError

#: model.json's section that holds the drive model
DRIVE_SECTION = "drive"
#: the terms that are one per surface (cli.md: rolling and turning "per `surface`")
PER_SURFACE_TERMS = ("rolling_W_per_mps", "turning_Nm")
_FIX_MODEL = "give a model.json written by 'wbpower fit -o' from logs with a speed column"


@dataclass(frozen=True)
class Term:
    """One fitted term: its value, 95% interval (None where the fit gave none) and unit."""

    name: str
    value: float
    ci95: tuple[float, float] | None
    unit: str


@dataclass(frozen=True)
class DriveTerms:
    """The drive model's terms for one surface (the per-surface terms of that surface, the
    others shared), and what the model says beyond them."""

    file: str
    #: the surface the per-surface terms are of (None: the model names no surface)
    surface: str | None
    #: every surface the model names (empty: none)
    surfaces: tuple[str, ...]
    terms: dict[str, Term]
    #: the per-surface terms of the other surfaces: {surface: {name: Term}}
    other_surfaces: dict[str, dict[str, Term]]
    lag_s: float | None
    #: the fit's reasons for the terms it could not determine
    not_determined: tuple[str, ...]
    #: how the surface was chosen (a note for the warnings), None when given or only one
    surface_note: str | None = None

    def source(self, name: str) -> str:
        """The name of term `name` as the source of a value: `rolling_W_per_mps[grass]` for
        a per-surface term of a model with surfaces."""
        return f"{name}[{self.surface}]" if self.surface and name in PER_SURFACE_TERMS else name

    def get(self, name: str) -> Term | None:
        """The term `name`, or None when the fit did not determine it."""
        return self.terms.get(name)

    def reason(self, name: str) -> str | None:
        """The fit's reason for not determining `name` (None: it gave none)."""
        keys = (f"{name}[{self.surface}]", name) if self.surface else (name,)
        return next((r for r in self.not_determined if r.startswith(keys)), None)

    def why_not(self, name: str) -> str:
        """Why `name` is not determined, in the fit's words when it gave them."""
        return self.reason(name) or (
            f"{name}: not determined by the fit ({self.file} holds no value for it)"
        )


@dataclass(frozen=True)
class Parameter:
    """One value of the target's file: its name there (dotted for nested keys), value, unit,
    and which fitted term(s) it comes from and how."""

    name: str
    value: float | str | bool
    unit: str
    #: the fitted term(s) it comes from ("idle_W", "rolling_W_per_mps[grass]"), or, when
    #: `fitted` is False, where else it comes from ("given (--voltage)")
    source: str
    #: how: the formula with its numbers, or why
    how: str = ""
    fitted: bool = True

    def as_dict(self) -> dict[str, object]:
        return {"value": self.value, "unit": self.unit, "from": self.source, "how": self.how}

    def comment(self) -> str:
        """The file's comment for this value: its unit, where it comes from and how."""
        unit = f"[{self.unit}] " if self.unit not in ("", "1") else ""
        origin = f"from {self.source}" if self.fitted else self.source
        return " ".join(f"{unit}{origin}{': ' + self.how if self.how else ''}".split())


@dataclass(frozen=True)
class ExportOptions:
    """What a user may give beside the model (None: not given). Each target says which of
    these it takes (`Target.options`); giving one it does not take is a usage error."""

    surface: str | None = None
    #: the battery: nominal voltage [V], capacity [Ah], charging current [A]
    battery_voltage_V: float | None = None
    battery_capacity_Ah: float | None = None
    charging_current_A: float | None = None
    #: RMF: the mass to use when the fit did not determine the inertial terms [kg]
    mass_kg: float | None = None
    #: RMF: the robot's moment of inertia about its yaw axis, given [kg m^2]
    moment_of_inertia_kgm2: float | None = None
    #: RMF: the fleet's nominal angular speed [rad/s] and the turn whose cost the moment of
    #: inertia reproduces [rad]
    turn_rate_radps: float | None = None
    turn_angle_rad: float | None = None
    #: Gazebo: the steady speed whose power the constant load is [m/s]
    speed_mps: float | None = None

    def given(self) -> dict[str, object]:
        return {k: v for k, v in self.__dict__.items() if v is not None and k != "surface"}


@dataclass(frozen=True)
class Export:
    """An exported model: the target's file text, each value's origin, and what the target
    could not express or what was assumed (`warnings`)."""

    target: str
    file_format: str
    surface: str | None
    parameters: tuple[Parameter, ...]
    text: str
    warnings: tuple[str, ...] = field(default=())

    def summary(self) -> dict[str, object]:
        """`export --json`: `{target, parameters: {NAME: {value, unit, from}}, warnings,
        error}` (cli.md conventions), with the surface and the file text."""
        return {
            "target": self.target,
            "format": self.file_format,
            "surface": self.surface,
            "parameters": {p.name: p.as_dict() for p in self.parameters},
            "warnings": list(self.warnings),
            "error": None,
            "text": self.text,
        }


class Target:
    """An export target: one module each (rmf.py, gazebo.py), listed in `TARGETS`."""

    #: the `--to` name
    name: str = ""
    #: what the file is (for --help and --json)
    file_format: str = ""
    #: the `ExportOptions` fields this target takes
    options: tuple[str, ...] = ()

    def export(self, drive: DriveTerms, options: ExportOptions) -> Export:
        raise NotImplementedError


def read_drive_section(path: str | Path) -> dict:
    """model.json's `drive` section; a one-line error naming the file when there is none."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UsageError("no such model file", file=path, fix=_FIX_MODEL) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UsageError(
            f"cannot read the model ({exc.__class__.__name__})", file=path, fix=_FIX_MODEL
        ) from None
    if not isinstance(data, dict):
        raise UsageError("not a wbpower model file", file=path, fix=_FIX_MODEL)
    drive = data.get(DRIVE_SECTION)
    if drive is None:
        raise UsageError(
            "the model has no drive model (no log of the fit had a speed column, or the "
            "model was written before wbpower fitted one)",
            file=path,
            fix=_FIX_MODEL,
        )
    if not isinstance(drive, dict) or not isinstance(drive.get("terms"), dict):
        raise UsageError(
            "the model's drive section has no 'terms'", file=path, fix="re-run 'wbpower fit -o'"
        )
    return drive


def drive_terms(drive: dict, surface: str | None = None, *, file: str = "model.json") -> DriveTerms:
    """The terms of `surface` in a model.json `drive` section (`read_drive_section`). With
    several surfaces and none asked for, the one with the most held-out runs (else the first
    by name) is taken and `surface_note` says so."""
    try:
        shared = _terms(drive.get("terms") or {})
        by_surface = {s: _terms(named or {}) for s, named in (drive.get("surfaces") or {}).items()}
    except (AttributeError, KeyError, TypeError, ValueError) as exc:
        raise UsageError(
            f"the model's drive terms are malformed ({exc})",
            file=file,
            fix="re-run 'wbpower fit -o'",
        ) from None
    names = tuple(sorted(by_surface))
    note = None
    if surface is not None and surface not in by_surface:
        raise UsageError(
            f"--surface {surface}: the model has "
            + (f"surfaces {', '.join(names)}" if names else "no surfaces"),
            file=file,
            fix=f"give --surface {'|'.join(names)}" if names else "leave out --surface",
        )
    if surface is None and names:
        surface = _default_surface(drive, names)
        if len(names) > 1:
            note = (
                f"the model has surfaces {', '.join(names)}: the terms of '{surface}' are "
                "exported (the most held-out runs); give --surface NAME for another"
            )
    terms = dict(shared)
    if surface is not None:
        terms.update(by_surface[surface])
    lag = drive.get("lag_s")
    return DriveTerms(
        file=file,
        surface=surface,
        surfaces=names,
        terms=terms,
        other_surfaces={s: t for s, t in by_surface.items() if s != surface},
        lag_s=None if lag is None else float(lag),
        not_determined=tuple(str(r) for r in drive.get("not_determined") or ()),
        surface_note=note,
    )


def _terms(named: dict) -> dict[str, Term]:
    """{name: Term} of a `{NAME: {value, ci95, unit}}` mapping; a term without a finite value
    is left out (not determined)."""
    out = {}
    for name, entry in named.items():
        value = entry.get("value")
        if value is None or not math.isfinite(float(value)):
            continue
        ci = entry.get("ci95")
        ci95 = None
        if ci is not None and all(c is not None and math.isfinite(float(c)) for c in ci):
            ci95 = (float(ci[0]), float(ci[1]))
        out[name] = Term(name, float(value), ci95, str(entry.get("unit", "")))
    return out


def _default_surface(drive: dict, names: tuple[str, ...]) -> str:
    runs = ((drive.get("heldout") or {}).get("runs")) or []
    counts = {name: sum(1 for r in runs if r.get("surface") == name) for name in names}
    return max(names, key=lambda name: (counts[name], -names.index(name)))


def unexpressed(
    drive: DriveTerms, accounted: set[str], target: str, why: dict[str, str]
) -> list[str]:
    """A warning for each fitted term the target's file does not hold and nothing else has
    spoken for (`accounted`): never dropped silently, a term the drive model gains later
    included (`why` explains the known ones)."""
    return [
        f"not expressible in {target}: {interval(term)} ({why.get(name, 'no counterpart')})"
        for name, term in drive.terms.items()
        if name not in accounted
    ]


def fmt(value: float) -> str:
    """A value as the file shows it: enough digits to carry the fit (6 significant)."""
    return f"{value:.6g}"


def interval(term: Term) -> str:
    """`value unit (95% lo..hi)` for a comment."""
    ci = f", 95% {fmt(term.ci95[0])}..{fmt(term.ci95[1])}" if term.ci95 else ""
    return f"{term.name} = {fmt(term.value)} {term.unit}{ci}"
