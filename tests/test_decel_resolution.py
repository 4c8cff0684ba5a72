"""decel_phase's t_dec interval on decel phases a sample or two long (issue 26, "exact-looking
numbers"): never narrower than the sample period, however alike the runs' durations."""

from __future__ import annotations

import numpy as np
import pandas as pd

from wifibot_power.causes.decel_phase import decel_parameters
from wifibot_power.model import paper_model


def _runs(duration_s: np.ndarray, period_s: float) -> pd.DataFrame:
    speeds = np.repeat([0.3, 0.6, 0.9], 3)
    return pd.DataFrame(
        {
            "speed_mps": speeds,
            "decel_duration_s": duration_s,
            "decel_mean_power_W": 24.0 + 3.0 * speeds,
            "sample_period_s": np.full(speeds.size, period_s),
        }
    )


def test_one_sample_decels_get_the_sample_period_as_their_interval() -> None:
    period_s = 1 / 6.5  # every decel one sample of a 6.5 Hz log: their spread is zero
    params = decel_parameters(_runs(np.full(9, period_s), period_s), paper_model())
    low, high = params["t_dec_ci95"]
    assert low <= params["t_dec_s"] - period_s and high >= params["t_dec_s"] + period_s


def test_many_sample_decels_keep_their_spread_interval() -> None:
    # the same durations at 1 kHz: ~300 samples each, their scatter is their error
    durations = 0.30 + 0.01 * np.arange(9) / 8
    params = decel_parameters(_runs(durations, 0.001), paper_model())
    low, high = params["t_dec_ci95"]
    assert high - low < 0.02  # t(8) x sd/sqrt(9) ~ 0.0063 s either side
