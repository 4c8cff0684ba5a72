"""The paper's phase model as a model family: the first of `models.registry.FAMILIES`.

It fits from the run-table rows alone (`runtable.run_row`: each run's phase means, speed,
steps, mode), so it has no per-run statistics of its own (`run_stats` is None). Its fit
(`PaperFit`) is the paper table (Eq. 1-4, idle and Table 1 components, `paper_fit.py`) with
the measured stop-and-go overheads beside the model's (`overhead.py`); its model.json
section is the whole of model.json's top level (`PowerModel.to_json`), as before families.

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from wifibot_power.model import LinearFit, PowerModel, paper_model
from wifibot_power.models.base import FitOptions, FittedModel, ModelFamily
from wifibot_power.models.paper_fit import (
    COMPONENT_MODES,
    NAN_PAIR,
    FitColumns,
    MeanEstimate,
    Row,
    incomplete_warning,
    unfitted,
)
from wifibot_power.outputs import json_safe
from wifibot_power.overhead import StopAndGo

if TYPE_CHECKING:
    from wifibot_power.pipeline.record import RunRecord


@dataclass(frozen=True, eq=False)
class PaperFit(FittedModel):
    """The paper's model fitted over runs, its uncertainty and what it rests on."""

    family: ClassVar[str] = "paper"

    model: PowerModel
    idle: MeanEstimate
    idle_source: str
    components: dict[str, MeanEstimate | None]
    #: runs the fit used
    n_runs: int
    notes: tuple[str, ...] = ()
    #: the measured stop-and-go overhead of every trip held in 1 and N > 1 steps, beside the
    #: model's (`overhead.stop_and_go_overheads`)
    stop_and_go: tuple[StopAndGo, ...] = ()
    #: why the fitted model is physically implausible, weakly determined or incomplete
    warnings: tuple[str, ...] = ()
    #: the paper's own coefficients, shown beside
    reference: PowerModel = field(default_factory=paper_model)

    @property
    def model_complete(self) -> bool:
        """Whether every coefficient `energy`/`lifetime` need was fitted (model.json loads)."""
        return not unfitted(self.model)

    def summary(self) -> dict[str, object]:
        """The paper's part of the `fit --json` document (cli.md), JSON-safe (NaN -> null)."""

        def linear(fit: LinearFit, paper: LinearFit, unit: str, slope_unit: str) -> dict:
            return {
                f"intercept_{unit}": fit.intercept,
                f"slope_{slope_unit}": fit.slope,
                "intercept_ci95": list(fit.intercept_ci95),
                "slope_ci95": list(fit.slope_ci95),
                "r2": fit.r2,
                "n_runs": fit.n_runs,
                "paper": {f"intercept_{unit}": paper.intercept, f"slope_{slope_unit}": paper.slope},
            }

        model, paper = self.model, self.reference
        out = {
            "n_runs": self.n_runs,
            "accel": linear(model.accel, paper.accel, "W", "W_per_mps"),
            "cruise": linear(model.cruise, paper.cruise, "W", "W_per_mps"),
            "t_acc": linear(model.t_acc, LinearFit(math.nan, math.nan), "s", "s_per_mps"),
            "idle_W": model.idle_W,
            "idle_ci95": list(self.idle.ci95),
            "idle_n_runs": self.idle.n_runs,
            "idle_source": self.idle_source,
            # whether model.json can be written (every coefficient energy/lifetime need)
            "model_complete": self.model_complete,
            "speed_range_mps": model.speed_range_mps,
            "components_W": {m: model.components_W.get(m) for m in COMPONENT_MODES},
            "components_ci95": {m: list(c.ci95) if c else None for m, c in self.components.items()},
            "components_n_runs": {m: c.n_runs if c else 0 for m, c in self.components.items()},
            "paper": {"idle_W": paper.idle_W, "components_W": dict(paper.components_W)},
            "stop_and_go": [s.as_dict() for s in self.stop_and_go],
            "notes": list(self.notes),
            "warnings": list(self.warnings),
        }
        del out["t_acc"]["paper"]
        return json_safe(out)  # type: ignore[return-value]

    @staticmethod
    def null_summary() -> dict[str, object]:
        """`summary()`'s keys when no run is a step run (free driving only, cli.md "The drive
        model"): every fitted value null, no runs, the paper's own values as always."""
        paper = paper_model()
        nulls = dict.fromkeys(COMPONENT_MODES)
        return {
            "n_runs": 0,
            "accel": None,
            "cruise": None,
            "t_acc": None,
            "idle_W": None,
            "idle_ci95": None,
            "idle_n_runs": 0,
            "idle_source": None,
            "model_complete": False,
            "speed_range_mps": None,
            "components_W": dict(nulls),
            "components_ci95": dict(nulls),
            "components_n_runs": dict.fromkeys(COMPONENT_MODES, 0),
            "paper": {"idle_W": paper.idle_W, "components_W": dict(paper.components_W)},
            "stop_and_go": [],
            "notes": [],
            "warnings": [],
        }

    def to_json(self) -> dict[str, object]:
        """model.json's top level: the fitted `PowerModel`."""
        return self.model.to_json()

    def predict_energy_J(self, record: RunRecord) -> float:
        """A motion run's motion energy from (speed, distance, steps, payload) alone: paper
        Eq. 5/6 per step, times its steps (`energy.trip_energy`); NaN for another run or one
        the model cannot predict (an incomplete model, no speed or distance)."""
        from wifibot_power.energy import trip_energy
        from wifibot_power.errors import WbpowerError

        row = record.row
        if row.get("mode") != "motion":
            return math.nan
        try:
            trip = trip_energy(
                self.model,
                float(row["speed_mps"]),  # type: ignore[arg-type]
                float(row["distance_m"]),  # type: ignore[arg-type]
                int(row["steps"]),  # type: ignore[call-overload]
                payload_kg=float(row.get("payload_kg") or 0.0),  # type: ignore[arg-type]
            )
        except (WbpowerError, ValueError, TypeError):
            return math.nan
        return trip.energy_J

    def to_cache(self) -> dict[str, object]:
        """All of the fit as JSON values (`PaperFamily.from_cache` is the exact round trip:
        floats through repr, NaN kept as NaN)."""
        return {
            "model": self.model.to_json(),
            "idle": dataclasses.asdict(self.idle),
            "idle_source": self.idle_source,
            "components": {
                m: (dataclasses.asdict(c) if c is not None else None)
                for m, c in self.components.items()
            },
            "n_runs": self.n_runs,
            "notes": list(self.notes),
            "stop_and_go": [dataclasses.asdict(s) for s in self.stop_and_go],
            "warnings": list(self.warnings),
        }


def _mean(d: dict) -> MeanEstimate:
    return MeanEstimate(d["value_W"], tuple(d["ci95"]), d["n_runs"], d["se_W"])


def fit_rows(rows: Sequence[Row]) -> PaperFit:
    """The paper's model fitted on per-run rows (`runtable.run_row` dicts, or the records of
    a runs table), without pandas: the model (`paper_fit.FitColumns`) and the measured
    stop-and-go overheads beside it (`overhead.stop_and_go_overheads`)."""
    from wifibot_power.overhead import stop_and_go_overheads

    fitted = FitColumns.of_rows(rows).fitted()
    used = [row for row in rows if row["usable"]]
    return PaperFit(
        model=fitted.model,
        idle=fitted.idle,
        idle_source=fitted.idle_source,
        components=fitted.components,
        n_runs=len(used),
        notes=fitted.notes,
        stop_and_go=stop_and_go_overheads(used, fitted.model),
        warnings=(*incomplete_warning(fitted.model, fitted.notes), *fitted.model.fit_warnings),
    )


class PaperFamily(ModelFamily):
    """The paper's phase model (module docstring)."""

    name: ClassVar[str] = "paper"

    def fit(self, records: Sequence[RunRecord], options: FitOptions) -> PaperFit | None:
        """The fit of the usable rows; None when no row is usable."""
        del options  # doubtful rows were admitted into the records (`FitOptions`)
        rows = [record.row for record in records]
        if not any(row["usable"] for row in rows):
            return None
        return fit_rows(rows)

    def load(self, data: dict[str, object], *, file: str = "model.json") -> PaperFit:
        """A model.json's paper model as a fit of unknown uncertainty (no runs, no means)."""
        model = PowerModel.from_json(data, file=file)
        none = MeanEstimate(model.idle_W, NAN_PAIR, 0)
        return PaperFit(model, none, "model.json", {m: None for m in COMPONENT_MODES}, 0)

    def from_cache(self, kept: object) -> PaperFit:
        def stop_and_go(d: dict) -> StopAndGo:
            return StopAndGo(**{**d, "overhead_ci95": tuple(d["overhead_ci95"])})

        return PaperFit(
            model=PowerModel.from_json(kept["model"]),  # type: ignore[index]
            idle=_mean(kept["idle"]),  # type: ignore[index]
            idle_source=kept["idle_source"],  # type: ignore[index]
            components={m: (_mean(c) if c else None) for m, c in kept["components"].items()},  # type: ignore[index]
            n_runs=kept["n_runs"],  # type: ignore[index]
            notes=tuple(kept["notes"]),  # type: ignore[index]
            stop_and_go=tuple(stop_and_go(s) for s in kept["stop_and_go"]),  # type: ignore[index]
            warnings=tuple(kept["warnings"]),  # type: ignore[index]
        )
