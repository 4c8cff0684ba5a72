"""What a drive model's "power" is: the power drawn, or a current proxy (docs/drive-model.md,
"Current-only logs"); and whether its speed's unit is in doubt (drive/plausible.py). Plain
Python (no numpy): `export` reads it from a model.json before anything else."""

from __future__ import annotations

#: `DriveModel.power_kind`: the power drawn (a power column or V x I), a current proxy (every
#: log a nominal voltage times motor currents: the force form), or both mixed (not comparable)
POWER_KINDS = ("power", "current_proxy", "mixed")
#: The words of the drive model's current-proxy warning (model.py `_data_warnings`), which
#: `power_kind_of` reads in model files written before `power_kind` was kept.
PROXY_WARNING = "hold motor currents only"


def power_kind_of(section: dict) -> str:
    """A model.json drive section's `power_kind`; for a file written before it was kept, read
    from its current-proxy warning ("N of M log(s) hold motor currents only", "...not
    comparable" when mixed), so that an older proxy model is not taken for a power model."""
    kind = section.get("power_kind")
    if kind in POWER_KINDS:
        return str(kind)
    for warning in section.get("warnings") or ():
        if PROXY_WARNING in str(warning):
            return "mixed" if "not comparable" in str(warning) else "current_proxy"
    return "power"


#: How a warning that the speed's unit is in doubt starts (drive/plausible.py `mass_warning`):
#: what reads a fitted model (a route's energy, an export, the report) says these again
#: (`unit_doubts`), as the terms it uses are then wrong.
UNIT_DOUBT = "speed unit in doubt: "


def unit_doubts(warnings: object) -> tuple[str, ...]:
    """The drive model's `warnings` (a model.json section's list, or `DriveModel.warnings`)
    that doubt its speed's unit (`UNIT_DOUBT`)."""
    return tuple(str(w) for w in warnings or () if str(w).startswith(UNIT_DOUBT))
