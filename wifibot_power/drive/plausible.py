"""What physics says a fitted drive model cannot be, checked against the logs' metadata
(docs/drive-model.md, "The mass check").

`effective_mass_kg` is the inertial power's coefficient, m_eff = (m + J_w/r²)/η ([2] Eq. 3,
terms.py): the mass m the drive accelerates, plus the wheels' and motors' rotating inertia
J_w/r² >= 0, over the drive's efficiency η <= 1. It is never under m, the robot's `mass_kg`
plus its `payload_kg` (log-format.md, "Metadata keys"). A speed column too large by a factor
k makes a·v k² too large and the fitted m_eff k² too small: km/h under a `speed_mps` header
(k = 3.6) gives a 30 kg robot an m_eff of 2.3 kg, with every speed term as wrong and nothing
else in the fit to show it (a 3.6x speed is a plausible speed for many robots).

Field logs bias m_eff low without any unit error: acceleration downhill that gravity pays
for, a lag or a filtered speed that blurs a·v. On the real logs measured
(benchmarks/validate_mass_check.py, six electric unicycles with their riders: EUC_core,
docs/real-logs.md) the 95% interval's upper end came down to 0.59 of the mass. So the check
fires only when that upper end is under a third of the mass (`SHORTFALL`). A speed too large
by k is then caught when k > sqrt(SHORTFALL · m_eff/m): 1.7x for a drive with m_eff = m (the
unicycles' hub motors came near it), 2.4x at 50% efficiency, 3.7x for a drive as lossy as the
simulated Wifibot's (m_eff 4.6 m: km/h, 3.6x, is missed there). It says what it found and
doubts the speed terms; it cannot say which unit was meant, nor find a speed too small (m_eff
has no upper bound the logs give).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from wifibot_power.power_kind import UNIT_DOUBT

if TYPE_CHECKING:
    from wifibot_power.drive.model import TermValue
    from wifibot_power.drive.stats import DriveStats

#: The check fires when effective_mass_kg's 95% interval ends under the mass over this (module
#: docstring: field biases measured down to 0.59 of the mass; km/h's k² is 13, mph's 5)
SHORTFALL = 3.0


def mass_warning(stats: Sequence[DriveStats], terms: dict[str, TermValue]) -> str | None:
    """The warning for an effective mass far under the logs' mass (module docstring), or None:
    no log gives a mass, the term is not determined, or it is plausible. `stats`: the fit's
    runs (power logs only: a current proxy's effective_mass_kg is no mass)."""
    masses = [s.mass_kg for s in stats if math.isfinite(getattr(s, "mass_kg", math.nan))]
    term = terms.get("effective_mass_kg")
    if not masses or term is None or not math.isfinite(term.ci95[1]):
        return None
    mass_kg = min(masses)  # the lightest: m_eff is shared, and under each run's own mass
    if not term.ci95[1] < mass_kg / SHORTFALL:
        return None
    # with m_eff >= m the speed is too large by at least sqrt(m / m_eff)
    scale = f" by {math.sqrt(mass_kg / term.value):.1f}x or more" if term.value > 0 else ""
    return UNIT_DOUBT + (
        f"effective_mass_kg {term.value:.3g} kg (95% interval up to {term.ci95[1]:.3g}) is under "
        f"a third of the {mass_kg:g} kg the logs' mass_kg and payload_kg give"
        f"{' (the lightest log)' if len(set(masses)) > 1 else ''}; a drive that speeds up a "
        "mass m draws at least m·a·v (m_eff = (m + wheels' inertia)/efficiency >= m): the speed "
        f"column is likely too large{scale} (km/h under a speed_mps header is 3.6x, mph 2.2x), "
        "which makes every speed term wrong; check the speed's unit"
    )


__all__ = ["SHORTFALL", "mass_warning"]
