"""A toy model family and a toy figure, each one module's worth of code, registered by the
tests of tests/test_plugins.py with one line each (issue 24: "a new model family and a new
figure are each one module plus one registry line").

The toy family models a run's cruise power as one constant: per run, the energy [J] and
duration [s] of its cruise phases (from the segmentation the pipeline hands `run_stats`);
fitted, their ratio over all runs; a run's predicted energy is that power times its cruise
time. The toy figure draws each run's cruise energy against its cruise time with the fitted
line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from wifibot_power.figures import FigureSpec
from wifibot_power.models import FitOptions, FittedModel, ModelFamily


@dataclass(frozen=True)
class CruiseConstantFit(FittedModel):
    family: ClassVar[str] = "toy_cruise"

    cruise_power_W: float
    n_runs: int

    def summary(self) -> dict[str, object]:
        return {"cruise_power_W": self.cruise_power_W, "n_runs": self.n_runs}

    def to_json(self) -> dict[str, object]:
        return self.summary()

    def predict_energy_J(self, record) -> float:
        return self.cruise_power_W * float(record.row["cruise_duration_s"])


class CruiseConstant(ModelFamily):
    name: ClassVar[str] = "toy_cruise"

    def run_stats(self, run, segmentation) -> dict[str, float]:
        dt = run.sample_period_s
        cruises = [p for p in segmentation.phases if p.phase == "cruise"]
        energy_J = sum(float(np.sum(run.power_W[p.i_start : p.i_end])) * dt for p in cruises)
        return {
            "energy_J": energy_J,
            "duration_s": sum((p.i_end - p.i_start) * dt for p in cruises),
        }

    def fit(self, records: Sequence, options: FitOptions) -> CruiseConstantFit | None:
        stats = [r.models[self.name] for r in records if r.models[self.name]["duration_s"] > 0]
        if not stats:
            return None
        energy_J = sum(s["energy_J"] for s in stats)
        return CruiseConstantFit(energy_J / sum(s["duration_s"] for s in stats), len(stats))

    def load(self, data, *, file="model.json") -> CruiseConstantFit:
        return CruiseConstantFit(float(data["cruise_power_W"]), int(data["n_runs"]))


def cruise_energy_figure(fit):
    from matplotlib.figure import Figure

    toy = fit.fits["toy_cruise"]
    runs = fit.runs
    figure = Figure(figsize=(4, 3))
    ax = figure.add_subplot()
    ax.plot(runs["cruise_duration_s"], runs["cruise_energy_J"], "o")
    ax.plot(runs["cruise_duration_s"], toy.cruise_power_W * runs["cruise_duration_s"], "-")
    ax.set_xlabel("cruise time [s]")
    ax.set_ylabel("cruise energy [J]")
    return figure


TOY_FIGURE = FigureSpec(
    "toy_cruise_energy",
    "Toy: cruise energy against cruise time",
    "fit (FitResult) with the toy family",
    cruise_energy_figure,
    "A point per run; the line is the toy family's constant cruise power.",
    from_report=lambda report: (report.fit,) if report.fit is not None else "no fit",
)
