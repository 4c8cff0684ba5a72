"""The windows' regressors' rates of change (windows.py `RunWindows.rates`) by central
differences written out (`_gradient`): numpy's `np.gradient` to the bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from wifibot_power.drive.windows import _gradient


@settings(max_examples=200, deadline=None)
@given(
    size=st.integers(2, 900),
    seed=st.integers(0, 2**32 - 1),
    step=st.sampled_from([0.5, 0.05 * 10, 1 / 3, 0.3, 2.0, 1e-3]),
    odd=st.sampled_from([None, np.nan, np.inf, -np.inf, -0.0, 0.0]),
)
def test_the_rates_are_numpys_gradient_to_the_bit(size, seed, step, odd):
    rng = np.random.default_rng(seed)
    values = rng.normal(0, 1, size) * 10.0 ** rng.uniform(-8, 8, size)
    if odd is not None:  # a drop-out's NaN, an overflow, a signed zero somewhere
        values[rng.integers(size, size=max(1, size // 50))] = odd
    with np.errstate(invalid="ignore"):  # (inf - inf, as numpy's own)
        made, numpy_s = _gradient(values, step), np.gradient(values, step)
    assert made.dtype == numpy_s.dtype and made.shape == numpy_s.shape
    assert np.array_equal(made, numpy_s, equal_nan=True)
    assert np.array_equal(np.signbit(made), np.signbit(numpy_s))
