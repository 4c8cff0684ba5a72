"""The sample checks' short cuts give what the plain computation gives.

`_median_10_digits` replaces a partial sort of every time step by two counting passes when a
guess from a subsample is confirmed; its value must be the plain median's, rounded to 10
significant digits, on any steps (regular with float noise, jittered, gapped, random), and
the short cut must actually be taken on a regular log (else it saves nothing).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from wifibot_power.io.validate import _median_10_digits, check_samples


def _plain(steps: np.ndarray) -> float:
    return float(f"{float(np.median(steps)):.10g}")


@settings(max_examples=300, deadline=None)
@given(
    steps=arrays(
        np.float64,
        st.integers(1, 400),
        elements=st.floats(1e-9, 1e3, allow_nan=False, allow_infinity=False),
    )
)
def test_median_of_any_positive_steps_is_the_plain_one(steps):
    assert _median_10_digits(steps.copy())[0] == _plain(steps)


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(2, 5000),
    period_s=st.sampled_from([1.024e-4, 1.00352e-3, 0.055, 1e-6, 0.1]),
    start_s=st.floats(0, 1e4),
    decimals=st.integers(4, 9),
    gaps=st.lists(st.integers(0, 4999), max_size=5),
)
def test_median_of_written_time_stamps_is_the_plain_one(n, period_s, start_s, decimals, gaps):
    # time stamps as a log writes them (rounded to `decimals`), with a few dropped samples
    index = np.arange(n, dtype=np.float64)
    for gap in gaps:
        index[gap:] += 3
    time_s = np.round(start_s + index * period_s, decimals)
    steps = np.diff(time_s)
    if steps.size and steps.min() > 0:
        assert _median_10_digits(steps.copy())[0] == _plain(steps)


def test_the_short_cut_is_taken_on_a_regular_log():
    # 1 M samples at 0.1024 ms written with 7 decimals, up to ~100 s: float noise in the steps
    time_s = np.round(np.arange(1_000_000) * 1.024e-4, 7)
    steps = np.diff(time_s)
    assert np.unique(steps).size > 1  # the steps do carry float noise
    period_s, reordered = _median_10_digits(steps)
    assert (period_s, reordered) == (1.024e-4, False)
    assert np.array_equal(steps, np.diff(time_s))  # left as it was


def test_gaps_are_found_whichever_way_the_median_went():
    # 20 000 samples at 1 ms, two dropped samples after sample 5000: one gap of 2 ms, by hand
    index = np.arange(20_000, dtype=np.float64)
    index[5001:] += 2
    time_s = index * 1e-3
    power_W = np.full(index.size, 23.3) + np.sin(index)
    period_s, problems = check_samples("x.csv", time_s, power_W, default_period_s=1e-3)
    assert period_s == 1e-3
    assert [(p.kind, round(p.duration_s, 9)) for p in problems] == [("gap", 0.002)]
    assert problems[0].message.startswith("line 5003: 2 ms of samples dropped after t = 5 s")
