"""The time checks' short cut for a clocked logger that drops samples gives what the plain
computation gives (io/stamps.py `_regular_spread_s`).

Its gaps' steps made the steps' whole spread, so every such log had its steps' quartiles and
mean taken to find a logger stamping on arrival, or uneven stamps, that cannot be there
when the steps between its gaps lie within half the band. The short cut must give the same
period and problems on any stamps (clocked with gaps, jittered around the bands, stamped on
arrival) and be taken on a clocked log with gaps (else it saves nothing).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.errors import LogError
from wifibot_power.io import stamps


def _checked(time_s: np.ndarray, period_s: float):
    """`_check_time`'s period, problems (as tuples) and gaps, or the error's message."""
    try:
        found, problems, gaps = stamps._check_time("x.csv", time_s, lambda i: i + 2, period_s)
    except LogError as error:
        return str(error)
    listed = [(p.kind, p.message, p.t_start_s, p.duration_s) for p in problems]
    return found, listed, None if gaps is None else gaps.tolist()


def _plain_spread(step_s, gaps, low_s, high_s, spacing_s):
    return float(high_s - low_s)


@settings(max_examples=300, deadline=None)
@given(
    n=st.integers(50, 3000),
    period_s=st.sampled_from([0.05, 1e-3, 0.153, 1.024e-4]),
    jitter_pct=st.sampled_from([0.0, 0.1, 0.24, 0.26, 0.4, 0.6, 1.0, 2.0, 5.0, 30.0]),
    gaps=st.lists(st.tuples(st.integers(1, 2999), st.integers(1, 3)), max_size=12),
    decimals=st.integers(3, 9),
    seed=st.integers(0, 2**16),
)
def test_the_short_cut_finds_what_the_plain_checks_find(
    n, period_s, jitter_pct, gaps, decimals, seed
):
    rng = np.random.default_rng(seed)
    step = period_s * (1.0 + jitter_pct / 100.0 * rng.uniform(-0.5, 0.5, n - 1))
    for at, dropped in gaps:
        if at < n - 1:
            step[at] += dropped * period_s
    time_s = np.round(np.concatenate(([0.0], np.cumsum(step))), decimals)
    if not (np.diff(time_s) > 0).all():
        return
    fast = _checked(time_s, period_s)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(stamps, "_regular_spread_s", _plain_spread)
        assert _checked(time_s, period_s) == fast


def test_the_short_cut_is_taken_on_a_clocked_log_with_gaps(monkeypatch):
    # an hour at 20 Hz written to 2 decimals (float noise in the steps), 100 dropped samples
    index = np.arange(72_000, dtype=np.float64)
    for at in range(500, 72_000, 700):
        index[at:] += 1
    time_s = np.round(index * 0.05, 2)

    def not_needed(*args):
        raise AssertionError("the steps' quartiles were taken")

    monkeypatch.setattr(stamps, "_stamped_on_arrival", not_needed)
    period_s, problems, gaps = stamps._check_time("x.csv", time_s, lambda i: i + 2, 0.05)
    assert period_s == 0.05 and gaps is None
    assert [p.kind for p in problems] == ["gap"] * 103
    # a step 0.6% long between the gaps is beyond half the band: looked at as before
    time_s[1000:] += 0.05 * 0.006
    with pytest.raises(AssertionError, match="quartiles"):
        stamps._check_time("x.csv", time_s, lambda i: i + 2, 0.05)
