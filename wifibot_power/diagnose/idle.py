"""Each motion run referred to the batch's idle level: what diagnosis compares runs on.

A run's whole trace sits on its embedded system's idle draw, and that draw moves between
runs (electronics, radio, the analyser's zero: 0.1 W run to run at field realism,
docs/simulator.md). It is not motion power, yet on a run of T seconds of motion it moves
the motion energy by ``ΔP_idle · T``: 5 J on a 10 m run at 0.2 m/s, where a 1%/min
thermal drift moves it by a few joules. Left in, the longest runs' idle offsets hold most
of the batch's held-out squared error, so a cause's held-out gain and its interval
(`intervals`) measure those offsets more than the cause; in the phase means the same
offsets are most of the spread of repeated runs, against which speed_quadratic's lack of
fit is judged.

Each run measures its own idle level in its idle phases (`idle_mean_power_W`, before,
between and after its steps). Its motion is then taken on the batch's idle level: the
run's phase means lose its offset ``ΔP = P_idle,run - P_idle,batch``, its phase and motion
energies ``ΔP`` times their duration (the paper's model, Eq. 1-6, has one idle level in
its intercepts; the per-run offset is a known, measured part of each run, as
`thermal_drift.above_idle_ratio` already takes it). The batch's level is the mean of its
motion runs' own levels. A run without idle phases keeps its values (offset 0). The
diagnosis reports energies as measured: the offsets are added back to the measured and
the predicted energies alike (`IDLE_OFFSET_J`), which leaves every error as it is.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

#: The columns of each run's idle offset from the batch's level [W] (0: not measured), and
#: of that offset over its time in motion [J].
IDLE_OFFSET = "idle_offset_W"
IDLE_OFFSET_J = "idle_offset_J"
#: Each motion phase's mean power [W] and energy [J] (their ratio is its duration).
PHASES = (
    ("accel_mean_power_W", "accel_energy_J"),
    ("cruise_mean_power_W", "cruise_energy_J"),
    ("decel_mean_power_W", "decel_energy_J"),
)


def refer_to_batch_idle(runs: pd.DataFrame) -> pd.DataFrame:
    """`runs` with each motion run's powers and energies taken on the batch's idle level
    (module docstring), its offset in `IDLE_OFFSET` and `IDLE_OFFSET_J`; other modes' rows
    unchanged."""
    runs = runs.copy()
    motion = (runs["mode"] == "motion").to_numpy()
    own_W = runs["idle_mean_power_W"].to_numpy(np.float64)
    idle_s = np.nan_to_num(runs["idle_duration_s"].to_numpy(np.float64))
    measured = motion & np.isfinite(own_W) & (idle_s > 0)
    offset_W = np.zeros(len(runs))
    if measured.any():
        offset_W[measured] = own_W[measured] - own_W[measured].mean()
    motion_s = np.zeros(len(runs))
    for mean, energy in PHASES:
        mean_W, energy_J = runs[mean].to_numpy(np.float64), runs[energy].to_numpy(np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            seconds = np.nan_to_num(energy_J / mean_W, nan=0.0, posinf=0.0, neginf=0.0)
        motion_s += seconds
        runs[mean] = mean_W - offset_W
        runs[energy] = energy_J - offset_W * seconds
    runs[IDLE_OFFSET] = offset_W
    runs[IDLE_OFFSET_J] = offset_W * motion_s
    runs["motion_energy_J"] = runs["motion_energy_J"].to_numpy(np.float64) - runs[IDLE_OFFSET_J]
    runs["idle_mean_power_W"] = own_W - offset_W
    return runs


__all__ = ["IDLE_OFFSET", "IDLE_OFFSET_J", "refer_to_batch_idle"]
