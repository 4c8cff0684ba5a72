"""What a model family is: the one interface `fit`, `report` and model.json loop over.

A family (the paper's phase model, the drive model, ...) is one module holding a subclass of
`ModelFamily`, listed once in `models.registry.FAMILIES`. The pipeline calls it twice:

1. in the worker, while the run's samples are in memory: `run_stats(run, segmentation)`,
   the family's per-run statistics (small and picklable: they travel back to the calling
   process and, through `stats_to_json`/`stats_from_json`, into the cache);
2. in the calling process, once per batch: `fit(records, options)`, from the per-run
   records (`pipeline.record.RunRecord`: the run-table row, the phases, each family's
   `run_stats` under its `name`), giving a `FittedModel` or None when these runs cannot fit
   it (e.g. no run of the kind it needs).

A `FittedModel` says itself (`summary()`: its JSON-safe section of `fit --json`), is its
section of model.json (`to_json()`/`family.load(data)`), and predicts a run's energy
(`predict_energy_J(record)`). What a cache keeps of it (`to_cache`) is its model.json section
unless the fit holds more than its model (the paper's: its measured means and overheads).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

if TYPE_CHECKING:
    from wifibot_power.phases import Segmentation
    from wifibot_power.pipeline.record import RunRecord
    from wifibot_power.run import Run


@dataclass(frozen=True)
class FitOptions:
    """What a batch's fit is asked for, the same for every family.

    `keep_doubtful`: runs whose segmentation is in doubt were admitted into the records'
    rows (`runtable.admit_doubtful`; `fit --keep-doubtful`)."""

    keep_doubtful: bool = False


class FittedModel(ABC):
    """A family's fit over a batch of runs."""

    #: the family's name: its section of `fit --json` and model.json
    family: ClassVar[str]

    @abstractmethod
    def summary(self) -> dict[str, object]:
        """JSON-safe: the family's section of `fit --json`."""

    @abstractmethod
    def to_json(self) -> dict[str, object]:
        """The family's section of model.json (what `energy --model` reads back)."""

    @abstractmethod
    def predict_energy_J(self, record: RunRecord) -> float:
        """The run's energy as the model predicts it [J] (NaN: a run it does not predict)."""

    def to_cache(self) -> object:
        """JSON values for a warm `fit --cache` (`ModelFamily.from_cache` reads them back
        exactly); the model.json section by default."""
        return self.to_json()


class ModelFamily(ABC):
    """One way to model a robot's power from its runs (module docstring)."""

    #: its section of `fit --json` and model.json ("paper", "drive", ...)
    name: ClassVar[str]

    def run_stats(self, run: Run, segmentation: Segmentation) -> object:
        """The family's statistics of one run, computed in the worker (vectorised over the
        samples). `segmentation`: the run's phases as the pipeline found them; an empty one
        for a run it did not segment (mode unknown: nothing of the paper's can use it).
        None by default: a family that fits from the run-table rows alone needs nothing."""
        del run, segmentation
        return None

    def stats_to_json(self, stats: object) -> object:
        """`run_stats` as JSON values (for the cache); the value itself by default."""
        return stats

    def stats_from_json(self, kept: object) -> object:
        """The exact inverse of `stats_to_json`."""
        return kept

    @abstractmethod
    def fit(self, records: Sequence[RunRecord], options: FitOptions) -> FittedModel | None:
        """The family fitted over the records of a batch; None when they cannot fit it."""

    @abstractmethod
    def load(self, data: dict[str, object], *, file: str = "model.json") -> FittedModel:
        """The fitted model from its model.json section (`FittedModel.to_json`)."""

    def from_cache(self, kept: object) -> FittedModel:
        """The fitted model `FittedModel.to_cache` kept; raises on another layout (a miss)."""
        return self.load(kept)  # type: ignore[arg-type]
