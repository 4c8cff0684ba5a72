"""The drive model as a model family (COMMON.md, "Model families"; the `models/` registry of
the pipeline): the thin adapter `fit` will register. Nothing here computes; it names what the
pipeline calls:

- `name`: its model.json section and `fit --json` key, "drive";
- `run_stats(run, segmentation)`: in the worker, the run reduced to bins (stats.drive_stats:
  small, picklable; None without a speed);
- `fit(records, options)`: the model from the records of every run (model.fit_drive_stats;
  None when no run had a speed);
- `load(section)`: model.json's section back to the model (DriveModel.from_json);
- `run_energy_J(model, stats)`: a run's measured and predicted energy over its windows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.drive.model import DriveModel, fit_drive_stats
from wifibot_power.drive.stats import DriveStats, drive_stats
from wifibot_power.drive.windows import assemble, run_windows

if TYPE_CHECKING:
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run


class DriveFamily:
    """The drive model family (cli.md, "The drive model")."""

    name = "drive"

    @staticmethod
    def run_stats(run: Run, segmentation: Segmentation | None) -> DriveStats | None:
        return drive_stats(run, segmentation)

    @staticmethod
    def fit(records: Sequence[DriveStats | None], options: object = None) -> DriveModel | None:
        return fit_drive_stats(records)

    @staticmethod
    def load(section: dict) -> DriveModel:
        return DriveModel.from_json(section)

    @staticmethod
    def run_energy_J(model: DriveModel, stats: DriveStats) -> tuple[float, float]:
        """(measured, predicted) energy [J] of a run over its windows (the lag the model
        found applied; a drop-out's windows in neither)."""
        lag_bins = model.lag_s / stats.bin_s
        windows = assemble([run_windows(stats, model.window_s)], lag_bins, model.surface_names)
        coef = np.array(model.coef)
        kept = np.isfinite(coef)
        predicted = float(np.sum(windows.design[:, kept] @ coef[kept]) * windows.window_s)
        return float(np.sum(windows.power_W) * windows.window_s), predicted


FAMILY = DriveFamily()
