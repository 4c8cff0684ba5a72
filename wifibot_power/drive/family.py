"""The drive model as a model family (`wifibot_power.models.base.ModelFamily`), the second of
`models.registry.FAMILIES`. Nothing here computes; it names what the pipeline calls:

- `name`: its section of `fit --json` and model.json, "drive";
- `run_stats(run, segmentation)`: in the worker, the run reduced to bins (stats.drive_stats:
  small, picklable; None without a speed); `stats_to_json`/`stats_from_json` for the cache;
- `fit(records, options)`: the model from every run's statistics (each record's
  `models["drive"]`; model.fit_drive_stats; None when no run had a speed);
- `load(section, file=)`: model.json's section back to the model (DriveModel.from_json);
- the fitted `DriveModel` has `family`, `summary()`, `to_json()` and
  `predict_energy_J(record)`.

`fit` with a drive model and no paper model (free driving only) is a success: `fit.fit_records`
says why the paper's models are missing (they need step runs) instead of failing.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar

from wifibot_power.drive.stats import DriveStats, drive_stats
from wifibot_power.models.base import FitOptions, ModelFamily

if TYPE_CHECKING:
    from wifibot_power.drive.model import DriveModel
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run


class DriveFamily(ModelFamily):
    """The drive model family (cli.md, "The drive model")."""

    name: ClassVar[str] = "drive"

    def run_stats(self, run: Run, segmentation: Segmentation | None) -> DriveStats | None:
        # an empty segmentation (a run of unknown mode the pipeline did not segment) has no
        # phases to reconstruct a speed from: the run's own speed column, if any, is used
        return drive_stats(run, segmentation if segmentation and segmentation.phases else None)

    def stats_to_json(self, stats: DriveStats | None) -> object:
        return None if stats is None else stats.to_json()

    def stats_from_json(self, kept: object) -> DriveStats | None:
        return None if kept is None else DriveStats.from_json(kept)  # type: ignore[arg-type]

    def fit(
        self, records: Sequence[object], options: FitOptions | None = None
    ) -> DriveModel | None:
        """From the records' `models["drive"]` (or the statistics themselves)."""
        from wifibot_power.drive.model import fit_drive_stats  # models.base <- drive.model

        del options  # nothing of the paper's options applies to the drive model
        return fit_drive_stats([_stats_of(record) for record in records])

    def load(self, data: dict, *, file: str = "model.json") -> DriveModel:
        from wifibot_power.drive.model import DriveModel

        del file  # errors of a damaged section: drive.profile.load_drive_model names it
        return DriveModel.from_json(data)


def _stats_of(record: object) -> DriveStats | None:
    if isinstance(record, DriveStats) or record is None:
        return record
    return getattr(record, "models", {}).get(DriveFamily.name)


FAMILY = DriveFamily()
