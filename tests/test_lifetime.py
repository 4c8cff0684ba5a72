"""Relay lifetime (our reading of paper Eq. 7-11) against hand-worked cases and limits.

Tolerances: expected values are a handful of float operations on exact decimal inputs;
rtol=1e-12 only absorbs rounding, and any wrong power term moves results by > 1e-4.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from wifibot_power.errors import UsageError
from wifibot_power.lifetime import (
    SWEEPS,
    lifetime_sweep,
    network_lifetime,
    relay_lifetime_s,
)
from wifibot_power.model import paper_model

RTOL = 1e-12
PAPER = paper_model()

# Hand numbers for the paper's defaults at 100 Mbit/s, t_acc = 1 s:
# P_emb = 23.3 W (idle); R = 1e8 bit/s; e_s = 100, e_th = 12, e_tl = 1.2, e_rx = 10 nJ/bit
P_A_HIGH = 23.3 + 1e8 * (100e-9 + 12e-9)  # 34.5 W
P_A_LOW = 23.3 + 1e8 * (100e-9 + 1.2e-9)  # 33.42 W
P_B = 23.3 + 1e8 * (10e-9 + 1.2e-9)  # 24.42 W
# B's trip, 10 m at 0.9 m/s in one step: P_acc = 23.9 + 14.8*0.9 = 37.22 W for 1 s,
# s_acc = 0.45 m, cruise 9.55/0.9 s at P_v = 23.9 + 11.2*0.9 = 33.98 W
T_TRAVEL = 1 + 9.55 / 0.9
E_TRAVEL = 37.22 + 33.98 * 9.55 / 0.9
E_A_SWITCH = 480e3 - P_A_HIGH * T_TRAVEL


def test_powers_by_hand():
    r = network_lifetime(PAPER, 100, t_acc_s=1.0)
    assert_allclose([r.p_a_high_W, r.p_a_low_W, r.p_b_W], [34.5, 33.42, 24.42], rtol=RTOL)
    assert_allclose([r.travel_s, r.travel_energy_J], [T_TRAVEL, E_TRAVEL], rtol=RTOL)
    assert_allclose(r.e_a_switch_J, E_A_SWITCH, rtol=RTOL)


def test_a_dies_first_by_hand():
    # B holds 480 kJ - 397.8 J at 24.42 W (~19640 s) > A's 479.6 kJ at 33.42 W (~14351 s)
    r = network_lifetime(PAPER, 100, t_acc_s=1.0)
    assert r.first_to_die == "A" and r.relayed
    assert_allclose(r.baseline_s, 480e3 / 34.5, rtol=RTOL)
    assert_allclose(r.lifetime_s, T_TRAVEL + E_A_SWITCH / P_A_LOW, rtol=RTOL)
    expected_pct = 100 * ((T_TRAVEL + E_A_SWITCH / P_A_LOW) / (480e3 / 34.5) - 1)
    assert_allclose(r.improvement_pct, expected_pct, rtol=1e-9)


def test_b_dies_first_by_hand():
    # E0B = 100 kJ: B lasts t_B = (100e3 - E_TRAVEL)/24.42 s (~4079 s) after arriving;
    # A then has E_A_SWITCH - 33.42 t_B left, spent at 34.5 W.
    r = network_lifetime(PAPER, 100, e0b_J=100e3, t_acc_s=1.0)
    t_b = (100e3 - E_TRAVEL) / P_B
    expected = T_TRAVEL + t_b + (E_A_SWITCH - P_A_LOW * t_b) / P_A_HIGH
    assert r.first_to_die == "B"
    assert_allclose(r.lifetime_s, expected, rtol=RTOL)
    assert r.baseline_s < r.lifetime_s < T_TRAVEL + E_A_SWITCH / P_A_LOW


def test_b_never_moved_gives_no_gain():
    r = network_lifetime(PAPER, 54, distance_m=0.0)
    assert not r.relayed
    assert r.lifetime_s == r.baseline_s and r.improvement_pct == 0.0


def test_b_that_cannot_finish_the_trip_gives_no_gain():
    r = network_lifetime(PAPER, 10, e0b_J=E_TRAVEL * 0.99, t_acc_s=1.0)
    assert not r.relayed and r.improvement_pct == 0.0 and r.first_to_die == "B"


def test_infinite_e0b_takes_the_a_dies_first_branch():
    r = network_lifetime(PAPER, 100, e0b_J=math.inf, t_acc_s=1.0)
    assert r.first_to_die == "A"
    assert_allclose(r.lifetime_s, T_TRAVEL + E_A_SWITCH / P_A_LOW, rtol=RTOL)
    # and the branch function itself, with no trip at all
    assert relay_lifetime_s(100.0, math.inf, 2.0, 4.0, 1.0, 0.0) == (50.0, "A")


def test_branch_function_b_first_by_hand():
    # A 100 J, B 10 J at 1 W: B dies at 10 s; A used 2*10 = 20 J, 80 J left at 4 W = 20 s
    assert relay_lifetime_s(100.0, 10.0, 2.0, 4.0, 1.0, 0.0) == (30.0, "B")


def test_half_power_embedded_system():
    # P_emb = 23.3 * 0.5 = 11.65 W -> P_A_high = 11.65 + 11.2 = 22.85 W
    r = network_lifetime(PAPER, 100, embedded_scale=0.5, t_acc_s=1.0)
    assert_allclose(r.p_a_high_W, 22.85, rtol=RTOL)
    assert_allclose(r.baseline_s, 480e3 / 22.85, rtol=RTOL)
    full = network_lifetime(PAPER, 100, t_acc_s=1.0)
    assert r.improvement_pct > full.improvement_pct  # radio is a larger share of the power


def test_rate_not_in_table2_is_a_usage_error():
    with pytest.raises(UsageError, match="Table 2"):
        network_lifetime(PAPER, 11)


@settings(max_examples=200, deadline=None)
@given(
    rate=st.sampled_from([10.0, 54.0, 100.0]),
    e0a=st.floats(1e3, 2e6),
    e0b=st.floats(0.0, 2e6),
    dist=st.floats(0.0, 5e3),
    speed=st.floats(0.05, 1.5),
    scale=st.floats(0.0, 2.0),
)
def test_relay_never_hurts_and_never_beats_low_power_throughout(rate, e0a, e0b, dist, speed, scale):
    # A never draws more than P_A_high, so T >= T_0; and never less than P_A_low once it
    # spent P_A_high during the trip, so T <= E0A / P_A_low.
    r = network_lifetime(
        PAPER, rate, e0a_J=e0a, e0b_J=e0b, distance_m=dist, speed_mps=speed, embedded_scale=scale
    )
    assert r.lifetime_s >= r.baseline_s * (1 - 1e-12)
    assert r.lifetime_s <= e0a / r.p_a_low_W * (1 + 1e-12)


@settings(max_examples=100, deadline=None)
@given(e0b=st.floats(0.0, 1e6), extra=st.floats(0.0, 1e6))
def test_more_energy_in_b_never_shortens_the_network(e0b, extra):
    less = network_lifetime(PAPER, 54, e0b_J=e0b, t_acc_s=1.0)
    more = network_lifetime(PAPER, 54, e0b_J=e0b + extra, t_acc_s=1.0)
    assert more.lifetime_s >= less.lifetime_s * (1 - 1e-12)


def test_sweeps_cover_their_grids_and_both_branches():
    rates = lifetime_sweep("rate", PAPER, 0.0, t_acc_s=1.0)
    assert [r.rate_mbps for r in rates] == [10.0, 54.0, 100.0]
    e0b = lifetime_sweep("e0b", PAPER, 54, t_acc_s=1.0)
    assert [r.e0b_J for r in e0b] == list(SWEEPS["e0b"])
    assert {r.first_to_die for r in e0b} == {"A", "B"}
    dist = lifetime_sweep("dist", PAPER, 54, t_acc_s=1.0)
    assert dist[0].distance_m == 0.0 and dist[0].improvement_pct == 0.0
    e0a = lifetime_sweep("e0a", PAPER, 54, values=(100e3, 200e3), t_acc_s=1.0)
    assert [r.e0a_J for r in e0a] == [100e3, 200e3]
    with pytest.raises(UsageError):
        lifetime_sweep("speed", PAPER, 54)


# -- every row of the paper's Table 2 (Figure 7's rate sweep rests on all three) ------------
# Worked by hand from Table 2 (nW/bit read as nJ/bit) and Eq. 7-11, paper model (idle 23.3 W),
# B's trip as above (10 m at 0.9 m/s, t_acc = 1 s: 11.6111 s). e_s = 100 nJ/bit throughout.
#
# 10 Mbit/s (e_th 95, e_tl 9.5, e_rx 70): R = 1e7 bit/s
#   P_A_high = 23.3 + 1e7 * (100 + 95) e-9  = 23.3 + 1.95   = 25.25 W
#   P_A_low  = 23.3 + 1e7 * (100 + 9.5) e-9 = 23.3 + 1.095  = 24.395 W
#   P_B      = 23.3 + 1e7 * (70 + 9.5) e-9  = 23.3 + 0.795  = 24.095 W
#   T_0 = 480e3 / 25.25 = 19009.90 s
#   E_A^{1->2} = 480e3 - 25.25 * 11.6111 = 479706.82 J; A dies first (B: ~19905 s > ~19664 s)
#   T = 11.6111 + 479706.82 / 24.395 = 11.6111 + 19664.145 = 19675.756 s -> gain 3.503 %
# 54 Mbit/s (e_th 24, e_tl 2.4, e_rx 18): R = 5.4e7 bit/s
#   P_A_high = 23.3 + 5.4e7 * 124e-9   = 23.3 + 6.696  = 29.996 W
#   P_A_low  = 23.3 + 5.4e7 * 102.4e-9 = 23.3 + 5.5296 = 28.8296 W
#   P_B      = 23.3 + 5.4e7 * 20.4e-9  = 23.3 + 1.1016 = 24.4016 W
#   T_0 = 480e3 / 29.996 = 16002.13 s
#   E_A^{1->2} = 480e3 - 29.996 * 11.6111 = 479651.71 J
#   T = 11.6111 + 479651.71 / 28.8296 = 11.6111 + 16637.474 = 16649.085 s -> gain 4.043 %
# 100 Mbit/s (e_th 12, e_tl 1.2, e_rx 10): the numbers at the top of this file
#   (34.5, 33.42, 24.42 W); T_0 = 13913.04 s; E_A^{1->2} = 480e3 - 34.5 * 11.6111 = 479599.42 J;
#   T = 11.6111 + 479599.42 / 33.42 = 11.6111 + 14350.671 = 14362.282 s,
#   gain 3.229 %.
# B dies first with E0B = 100 kJ: t_B = (100e3 - 397.83) / P_B (397.83 J = E_TRAVEL), then
#   T = 11.6111 + t_B + (E_A^{1->2} - P_A_low t_B) / P_A_high. At 54 Mbit/s:
#   t_B = 99602.17 / 24.4016 = 4081.79 s; A left 479651.71 - 28.8296 * 4081.79 = 361975.1 J
#   at 29.996 W = 12067.45 s; T = 16160.85 s.
# Literal values (rounded as above) are checked to rtol 2e-6 (the 6-7 digits kept by hand);
# the formulas on exact decimals to RTOL.
TABLE2_BY_HAND = {
    # rate: (e_th, e_tl, e_rx) nJ/bit, (P_A_high, P_A_low, P_B) W, T_0 s, T s, T(E0B=100 kJ) s
    10.0: ((95, 9.5, 70), (25.25, 24.395, 24.095), 19009.90, 19675.756, None),
    54.0: ((24, 2.4, 18), (29.996, 28.8296, 24.4016), 16002.13, 16649.085, 16160.85),
    100.0: ((12, 1.2, 10), (34.5, 33.42, 24.42), 13913.04, 14362.282, None),
}


def _check_table2_row(rate: float) -> None:
    (e_th, e_tl, e_rx), powers, t0, t_relay, t_b_first = TABLE2_BY_HAND[rate]
    r = network_lifetime(PAPER, rate, t_acc_s=1.0)
    r_bits = rate * 1e6
    by_formula = [
        23.3 + r_bits * (100 + e_th) * 1e-9,
        23.3 + r_bits * (100 + e_tl) * 1e-9,
        23.3 + r_bits * (e_rx + e_tl) * 1e-9,
    ]
    assert_allclose([r.p_a_high_W, r.p_a_low_W, r.p_b_W], by_formula, rtol=RTOL)
    assert_allclose([r.p_a_high_W, r.p_a_low_W, r.p_b_W], powers, rtol=RTOL)
    assert_allclose(r.baseline_s, t0, rtol=2e-6)
    assert r.first_to_die == "A" and r.relayed
    e_switch = 480e3 - by_formula[0] * T_TRAVEL
    assert_allclose(r.lifetime_s, T_TRAVEL + e_switch / by_formula[1], rtol=RTOL)
    assert_allclose(r.lifetime_s, t_relay, rtol=2e-6)
    b = network_lifetime(PAPER, rate, e0b_J=100e3, t_acc_s=1.0)
    t_b = (100e3 - E_TRAVEL) / by_formula[2]
    expected = T_TRAVEL + t_b + (e_switch - by_formula[1] * t_b) / by_formula[0]
    assert b.first_to_die == "B"
    assert_allclose(b.lifetime_s, expected, rtol=RTOL)
    if t_b_first is not None:
        assert_allclose(b.lifetime_s, t_b_first, rtol=2e-6)


@pytest.mark.parametrize("rate", [10.0, 54.0, 100.0])
def test_every_table2_row_by_hand(rate):
    _check_table2_row(rate)


def test_a_typo_in_table2_is_caught(monkeypatch):
    # the 54 Mbit/s rx cost mistyped 18 -> 81 nJ/bit: B's power changes (and so the lifetime
    # when B dies first), though with the default E0B = 480 kJ B still outlives A
    import wifibot_power.lifetime as lifetime

    typo = lifetime.RadioCosts(54.0, 24e-9, 2.4e-9, 81e-9)
    monkeypatch.setitem(lifetime.TABLE2, 54.0, typo)
    with pytest.raises(AssertionError):
        _check_table2_row(54.0)
