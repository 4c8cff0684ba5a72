"""The measured stop-and-go overhead: how much more the logs spent on a trip made in N steps.

For every (speed, distance, payload) that the logs hold both in one step and in N > 1 steps
(cli.md, `fit`):

    overhead = mean motion energy in N steps / mean motion energy in one step - 1   [%]

beside the fitted model's overhead of the same trip (paper Eq. 5/6, `energy.trip_energy`).

The 95% interval comes from the run-to-run spread of each mean, by the delta method on the
log of the ratio of means with a Welch-Satterthwaite t:

    ln R = ln m_N - ln m_1,   se² = s_N² / (n_N m_N²) + s_1² / (n_1 m_1²),
    dof = se⁴ / [ (s_N² / (n_N m_N²))² / (n_N - 1) + (s_1² / (n_1 m_1²))² / (n_1 - 1) ],
    R in exp(ln R ± t_{0.975, dof} se)

(the log keeps the interval of a ratio positive and asymmetric, as Fieller's is; with
the run-to-run spreads of a robot's trips, a few % of the mean, the two agree to the digits
shown). `tests/test_overhead.py` measures its coverage by simulation. With a single run on
either side there is no spread to measure: the interval is NaN.

The energy is the runs' motion energy (accel + cruise + decel phases, idle excluded:
`runtable.run_row`), so waiting time between steps does not count as overhead.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wifibot_power.model import PowerModel

if TYPE_CHECKING:  # numpy loads when an overhead is computed, not for `StopAndGo` alone
    import numpy as np

NAN_PAIR = (float("nan"), float("nan"))


@dataclass(frozen=True)
class StopAndGo:
    """One trip measured in N steps and in one step (a row of `stop_and_go`, cli.md)."""

    speed_mps: float
    distance_m: float
    steps: int
    payload_kg: float
    #: mean motion energy of the N-step runs and of the one-step runs [J]
    energy_J: float
    one_step_energy_J: float
    n_runs: int
    one_step_n_runs: int
    overhead_pct: float
    overhead_ci95: tuple[float, float]
    #: the fitted model's overhead of the same trip (paper Eq. 5/6) [%]; NaN if not fitted
    model_overhead_pct: float

    def as_dict(self) -> dict[str, object]:
        return {
            "speed_mps": self.speed_mps,
            "distance_m": self.distance_m,
            "steps": self.steps,
            "payload_kg": self.payload_kg,
            "energy_J": self.energy_J,
            "one_step_energy_J": self.one_step_energy_J,
            "n_runs": self.n_runs,
            "one_step_n_runs": self.one_step_n_runs,
            "overhead_pct": self.overhead_pct,
            "overhead_ci95": list(self.overhead_ci95),
            "model_overhead_pct": self.model_overhead_pct,
        }


def ratio_of_means_ci95(
    numerator: np.ndarray, denominator: np.ndarray
) -> tuple[float, tuple[float, float]]:
    """Ratio of two sample means and its 95% interval (delta method on the log, Welch t;
    module docstring). NaN interval when either sample has fewer than two values."""
    import numpy as np

    from wifibot_power.stats import t_quantile

    a = np.asarray(numerator, dtype=np.float64)
    b = np.asarray(denominator, dtype=np.float64)
    m_a, m_b = float(a.mean()), float(b.mean())
    ratio = m_a / m_b
    if a.size < 2 or b.size < 2 or m_a <= 0 or m_b <= 0:
        return ratio, NAN_PAIR
    var_a = float(a.var(ddof=1)) / (a.size * m_a**2)
    var_b = float(b.var(ddof=1)) / (b.size * m_b**2)
    se = math.sqrt(var_a + var_b)
    if se == 0:
        return ratio, (ratio, ratio)
    dof = (var_a + var_b) ** 2 / (var_a**2 / (a.size - 1) + var_b**2 / (b.size - 1))
    half = float(t_quantile(0.975, dof)) * se
    return ratio, (ratio * math.exp(-half), ratio * math.exp(half))


def _key(value: object) -> float:
    # speeds and distances from metadata: equal when equal to 1e-9 (0.1 + 0.2 != 0.3)
    return round(float(value), 9)


def stop_and_go_overheads(
    rows: Iterable[Mapping[str, object]], model: PowerModel | None = None
) -> tuple[StopAndGo, ...]:
    """The measured overhead of every trip held in one step and in N > 1 steps.

    `rows`: per-run rows (`runtable.run_row` dicts or the records of a runs table); the
    usable motion runs with a finite motion energy are used. `model`: the fitted model whose
    Eq. 5/6 overhead goes beside (NaN without a complete model). Rows are sorted by
    distance, speed, payload, steps.
    """
    import numpy as np

    groups: dict[tuple[float, float, float, int], list[float]] = {}
    for row in rows:
        if not row.get("usable", True) or row.get("mode") != "motion":
            continue
        values = [row.get(k) for k in ("speed_mps", "distance_m", "steps", "motion_energy_J")]
        if any(v is None or not math.isfinite(float(v)) for v in values):
            continue
        speed, distance, steps, energy = (float(v) for v in values)
        if speed <= 0 or distance <= 0 or energy <= 0:
            continue
        payload = float(row.get("payload_kg") or 0.0)
        key = (_key(distance), _key(speed), _key(payload), int(steps))
        groups.setdefault(key, []).append(energy)

    out = []
    for (distance, speed, payload, steps), energies in sorted(groups.items()):
        one = groups.get((distance, speed, payload, 1))
        if steps <= 1 or one is None:
            continue
        ratio, (low, high) = ratio_of_means_ci95(np.array(energies), np.array(one))
        out.append(
            StopAndGo(
                speed_mps=speed,
                distance_m=distance,
                steps=steps,
                payload_kg=payload,
                energy_J=float(np.mean(energies)),
                one_step_energy_J=float(np.mean(one)),
                n_runs=len(energies),
                one_step_n_runs=len(one),
                overhead_pct=100.0 * (ratio - 1.0),
                overhead_ci95=(100.0 * (low - 1.0), 100.0 * (high - 1.0)),
                model_overhead_pct=model_overhead_pct(model, speed, distance, steps, payload),
            )
        )
    return tuple(out)


def model_overhead_pct(
    model: PowerModel | None, speed_mps: float, distance_m: float, steps: int, payload_kg: float
) -> float:
    """The model's stop-and-go overhead of the trip (paper Eq. 5/6 via `energy.energy_report`);
    NaN when the model lacks a coefficient the trip needs."""
    from wifibot_power.energy import energy_report
    from wifibot_power.errors import WbpowerError

    if model is None:
        return float("nan")
    try:
        report = energy_report(model, speed_mps, distance_m, steps, payload_kg=payload_kg)
        value = report.overhead_pct
    except (WbpowerError, ZeroDivisionError, ValueError):
        return float("nan")
    return float(value) if math.isfinite(value) else float("nan")
