"""The paper's relay scenario: does moving a second robot closer extend the network's life?

Our reading of paper Eq. 7-11 [1] (the paper's text was not at hand; written down in
docs/paper-reproduction.md):

- Robot A monitors at `R` bit/s and sends everything to a far base station. Per bit it
  spends sensing `e_s` and high-power transmission `e_th`; its embedded system draws
  `P_emb` (the model's idle power, times `embedded_scale`). Alone (Eq. 7):
  `P_A_high = P_emb + R (e_s + e_th)` and A lives `T_0 = E0A / P_A_high`.
- Robot B drives `d` metres at `v` towards A in one step; its travel energy and time
  come from the energy model (Eq. 5/6) (Eq. 8). Meanwhile A still transmits high, so at
  the switch it holds `E_A^{1->2} = E0A - P_A_high t_travel` (Eq. 9).
- Then A transmits at low power to B, `P_A_low = P_emb + R (e_s + e_tl)`, and B receives
  and forwards at low power, `P_B = P_emb + R (e_rx + e_tl)`.
- The network lives until A, the monitor, dies. If B outlives A (Eq. 10):
  `T = t_travel + E_A^{1->2} / P_A_low`. If B dies first, at `t_B = E_B / P_B` after the
  switch, A falls back to high power with what it has left (Eq. 11):
  `T = t_travel + t_B + (E_A^{1->2} - P_A_low t_B) / P_A_high`.
- If B cannot finish the trip (`E0B` below its travel energy), or `d = 0` (B never
  moved, so it is no closer than the base station), the network is A alone: `T = T_0`.

The per-bit costs of Table 2 are printed in nW/bit; we read them as nJ/bit (energy per
bit, i.e. W per bit/s), which is what makes `R * e` a power.

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from wifibot_power.energy import trip_energy
from wifibot_power.errors import UsageError
from wifibot_power.model import PowerModel

NJ = 1e-9  # J per nJ
MBIT = 1e6  # bit/s per Mbit/s


@dataclass(frozen=True)
class RadioCosts:
    """Per-bit energies of one data rate [J/bit] (paper Table 2)."""

    rate_mbps: float
    tx_high_J_per_bit: float
    tx_low_J_per_bit: float
    rx_J_per_bit: float


#: Paper Table 2: data rate [Mbit/s] -> tx high, tx low, rx (printed in nW/bit, read as nJ/bit).
TABLE2: dict[float, RadioCosts] = {
    10.0: RadioCosts(10.0, 95 * NJ, 9.5 * NJ, 70 * NJ),
    54.0: RadioCosts(54.0, 24 * NJ, 2.4 * NJ, 18 * NJ),
    100.0: RadioCosts(100.0, 12 * NJ, 1.2 * NJ, 10 * NJ),
}
#: Paper Table 2: sensing energy [J/bit].
SENSING_J_PER_BIT = 100 * NJ
#: Paper defaults: initial energy of each robot [J], B's trip [m] and speed [m/s].
DEFAULT_E0_J = 480e3
DEFAULT_DIST_M = 10.0
DEFAULT_SPEED_MPS = 0.9

#: Sweep grids (the paper's Figure 7 a/b/c, and the three rates).
SWEEPS: dict[str, tuple[float, ...]] = {
    "e0a": tuple(float(x) for x in np.arange(1, 11) * 100e3),
    "e0b": tuple(float(x) for x in (0.0, 1e3, 10e3, *(np.arange(1, 11) * 100e3))),
    "dist": tuple(float(x) for x in (0, 1, 10, 100, 500, 1e3, 2e3, 5e3, 10e3, 20e3)),
    "rate": tuple(TABLE2),
}


def radio_costs(rate_mbps: float) -> RadioCosts:
    """The Table 2 row of `rate_mbps`; any other rate is a usage error."""
    costs = TABLE2.get(float(rate_mbps))
    if costs is None:
        rates = ", ".join(f"{r:g}" for r in TABLE2)
        raise UsageError(
            f"rate {rate_mbps:g} Mbit/s is not in the paper's Table 2", fix=f"give --rate {rates}"
        )
    return costs


def node_power_W(
    embedded_W: float, rate_bps: float, first_J_per_bit: float, second_J_per_bit: float
) -> float:
    """Power of a robot handling a stream of `rate_bps` [bit/s] (paper Eq. 7, 10-11) [W].

    `P = P_emb + R (e_1 + e_2)`: A monitoring, `e_1 = e_s` (sensing) and `e_2` its
    transmission (high `e_th` to the base station, low `e_tl` to B); B relaying,
    `e_1 = e_rx`, `e_2 = e_tl`.
    """
    return embedded_W + rate_bps * (first_J_per_bit + second_J_per_bit)


def baseline_lifetime_s(e0a_J: float, p_a_high_W: float) -> float:
    """A alone, transmitting high to the base station: `T_0 = E0A / P_A_high` (paper Eq. 7) [s]."""
    return e0a_J / p_a_high_W


def energy_at_switch_J(e0a_J: float, p_a_high_W: float, travel_s: float) -> float:
    """A's energy when B arrives: `E_A^{1->2} = E0A - P_A_high t_travel` (paper Eq. 9) [J]."""
    return e0a_J - p_a_high_W * travel_s


def relay_lifetime_s(
    e_a_switch_J: float,
    e_b_switch_J: float,
    p_a_low_W: float,
    p_a_high_W: float,
    p_b_W: float,
    travel_s: float,
) -> tuple[float, str]:
    """Network lifetime once B relays, and which robot dies first (paper Eq. 10-11) [s].

    A dies first (`E_B / P_B >= E_A^{1->2} / P_A_low`, Eq. 10):
    `T = t_travel + E_A^{1->2} / P_A_low`. B dies first (Eq. 11): after `t_B = E_B / P_B`,
    A falls back to high power, `T = t_travel + t_B + (E_A^{1->2} - P_A_low t_B) / P_A_high`.
    """
    a_low_s = e_a_switch_J / p_a_low_W
    b_s = e_b_switch_J / p_b_W
    if b_s >= a_low_s:
        return travel_s + a_low_s, "A"
    return travel_s + b_s + (e_a_switch_J - p_a_low_W * b_s) / p_a_high_W, "B"


@dataclass(frozen=True)
class LifetimeResult:
    """One scenario of the relay simulation and its outcome."""

    rate_mbps: float
    e0a_J: float
    e0b_J: float
    distance_m: float
    speed_mps: float
    embedded_scale: float
    embedded_W: float
    p_a_high_W: float
    p_a_low_W: float
    p_b_W: float
    travel_s: float
    travel_energy_J: float
    e_a_switch_J: float
    relayed: bool
    lifetime_s: float
    baseline_s: float
    first_to_die: str
    note: str
    #: why the answer may not hold (B's speed outside the model's fitted range)
    warnings: tuple[str, ...] = ()

    @property
    def improvement_pct(self) -> float:
        return 100.0 * (self.lifetime_s / self.baseline_s - 1.0)

    def summary(self) -> dict[str, object]:
        """The `lifetime --json` object (cli.md), plus the intermediate quantities."""
        return {
            "rate_mbps": self.rate_mbps,
            "e0a_J": self.e0a_J,
            "e0b_J": self.e0b_J,
            "distance_m": self.distance_m,
            "speed_mps": self.speed_mps,
            "lifetime_s": self.lifetime_s,
            "baseline_s": self.baseline_s,
            "improvement_pct": self.improvement_pct,
            "first_to_die": self.first_to_die,
            "embedded_scale": self.embedded_scale,
            "embedded_W": self.embedded_W,
            "p_a_high_W": self.p_a_high_W,
            "p_a_low_W": self.p_a_low_W,
            "p_b_W": self.p_b_W,
            "travel_s": self.travel_s,
            "travel_energy_J": self.travel_energy_J,
            "e_a_switch_J": self.e_a_switch_J,
            "relayed": self.relayed,
            "note": self.note,
            "warnings": list(self.warnings),
        }


def network_lifetime(
    model: PowerModel,
    rate_mbps: float,
    *,
    e0a_J: float = DEFAULT_E0_J,
    e0b_J: float = DEFAULT_E0_J,
    distance_m: float = DEFAULT_DIST_M,
    speed_mps: float = DEFAULT_SPEED_MPS,
    embedded_scale: float = 1.0,
    t_acc_s: float | None = None,
) -> LifetimeResult:
    """Lifetime of the two-robot network against A alone (paper Eq. 7-11, our reading above)."""
    costs = radio_costs(rate_mbps)
    if not math.isfinite(e0a_J) or e0a_J <= 0:
        raise UsageError(f"--e0a {e0a_J} J", fix="give A's initial energy, finite and > 0")
    if math.isnan(e0b_J) or e0b_J < 0:
        raise UsageError(f"--e0b {e0b_J} J", fix="give B's initial energy >= 0")
    if not math.isfinite(distance_m) or distance_m < 0:
        raise UsageError(f"--dist {distance_m} m", fix="give --dist >= 0")
    if not math.isfinite(speed_mps) or speed_mps <= 0:
        raise UsageError(f"--speed {speed_mps} m/s", fix="give --speed > 0")
    if not math.isfinite(embedded_scale) or embedded_scale < 0:
        raise UsageError(f"--embedded-scale {embedded_scale}", fix="give a scale >= 0")
    rate_bps = costs.rate_mbps * MBIT
    embedded_W = model.idle_W * embedded_scale
    p_a_high_W = node_power_W(embedded_W, rate_bps, SENSING_J_PER_BIT, costs.tx_high_J_per_bit)
    p_a_low_W = node_power_W(embedded_W, rate_bps, SENSING_J_PER_BIT, costs.tx_low_J_per_bit)
    p_b_W = node_power_W(embedded_W, rate_bps, costs.rx_J_per_bit, costs.tx_low_J_per_bit)
    baseline_s = baseline_lifetime_s(e0a_J, p_a_high_W)
    common = {
        "rate_mbps": costs.rate_mbps,
        "e0a_J": float(e0a_J),
        "e0b_J": float(e0b_J),
        "distance_m": float(distance_m),
        "speed_mps": float(speed_mps),
        "embedded_scale": float(embedded_scale),
        "embedded_W": embedded_W,
        "p_a_high_W": p_a_high_W,
        "p_a_low_W": p_a_low_W,
        "p_b_W": p_b_W,
        "baseline_s": baseline_s,
    }
    alone = LifetimeResult(
        **common,
        travel_s=0.0,
        travel_energy_J=0.0,
        e_a_switch_J=float(e0a_J),
        relayed=False,
        lifetime_s=baseline_s,
        first_to_die="A",
        note="B never moved: A alone",
    )
    if distance_m == 0:
        return alone
    # Eq. 8: B's trip, one step, from the energy model.
    travel = trip_energy(model, speed_mps, distance_m, 1, t_acc_s=t_acc_s)
    travel_s, travel_J = travel.time_s, travel.energy_J
    alone = replace(alone, warnings=tuple(model.warnings_at(speed_mps)))
    e_a_switch_J = energy_at_switch_J(e0a_J, p_a_high_W, travel_s)
    moved = {"travel_s": travel_s, "travel_energy_J": travel_J, "e_a_switch_J": e_a_switch_J}
    if e0b_J < travel_J:
        # B dies on the road (at its mean travel power); the network is A alone.
        b_dies_s = e0b_J / (travel_J / travel_s)
        first = "B" if b_dies_s < baseline_s else "A"
        return replace(alone, **moved, first_to_die=first, note="B ran out before arriving")
    if e_a_switch_J <= 0:
        return replace(alone, **moved, note="A died before B arrived")
    lifetime_s, first = relay_lifetime_s(
        e_a_switch_J, e0b_J - travel_J, p_a_low_W, p_a_high_W, p_b_W, travel_s
    )
    return LifetimeResult(
        **common,
        **moved,
        warnings=alone.warnings,
        relayed=True,
        lifetime_s=lifetime_s,
        first_to_die=first,
        note="B relays; A dies first" if first == "A" else "B relays, dies; A back to high",
    )


def lifetime_sweep(
    sweep: str,
    model: PowerModel,
    rate_mbps: float,
    values: tuple[float, ...] | None = None,
    **scenario: float | None,
) -> list[LifetimeResult]:
    """The scenario with one input varied over a grid (the paper's Figure 7 a/b/c; `rate`).

    `sweep` is `e0a`, `e0b`, `dist` or `rate`; `values` overrides the default grid.
    """
    if sweep not in SWEEPS:
        raise UsageError(f"unknown sweep '{sweep}'", fix=f"give --sweep {'|'.join(SWEEPS)}")
    grid = SWEEPS[sweep] if values is None else tuple(values)
    keyword = {"e0a": "e0a_J", "e0b": "e0b_J", "dist": "distance_m"}.get(sweep)
    rows = []
    for value in grid:
        if sweep == "rate":
            rows.append(network_lifetime(model, value, **scenario))
        else:
            rows.append(network_lifetime(model, rate_mbps, **{**scenario, keyword: value}))
    return rows
