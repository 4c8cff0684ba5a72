"""Figures: one function per figure, each returning a `matplotlib.figure.Figure` built from
result objects (never re-reading logs), so tests inspect its axes, labels and artists.

`FIGURES` is the one list: name -> what it draws, the function that draws it, and what of a
report it is drawn from (`FigureSpec.from_report`); `wbpower report` draws every figure of
it, in its order, and `--plot` draws one by name. Adding a figure is one module with its
drawing function and one entry here. matplotlib (Agg backend, no pyplot) is imported inside
the drawing functions only, so importing this package costs no start-up time.
`style.save_figure` writes a figure as PNG or SVG.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from wifibot_power.figures.diagnosis import findings_figure, heldout_error_figure
from wifibot_power.figures.drive_energy import drive_energy_figure
from wifibot_power.figures.drive_power import drive_power_figure
from wifibot_power.figures.drive_terms import drive_terms_figure
from wifibot_power.figures.paper_figures import figure5, figure7
from wifibot_power.figures.power_speed import power_speed_figure
from wifibot_power.figures.style import PHASE_COLOURS, save_figure
from wifibot_power.figures.trace import TraceView, trace_figure, trace_view

if TYPE_CHECKING:
    from wifibot_power.fit_result import FitResult
    from wifibot_power.report import Report

#: What a report gives a figure: the arguments of its `draw`, or why it cannot be drawn.
ReportArgs = Callable[["Report"], "tuple[object, ...] | str"]


@dataclass(frozen=True)
class FigureSpec:
    name: str
    title: str
    #: what the figure is drawn from
    source: str
    draw: Callable[..., object]
    #: how to read it (docs/report.md says more)
    how_to_read: str
    #: the report's arguments for `draw`, or why it cannot be drawn (None: not in reports)
    from_report: ReportArgs | None = None
    #: drawn once per run of the report, from each run's `TraceView`
    per_run: bool = False


def _fit(report: Report) -> tuple[object, ...] | str:
    if report.fit is None:
        return str(report.fit_problem)
    if not report.fit.has_paper:
        return "; ".join(report.fit.notes)  # why the paper's models were not fitted
    return (report.fit,)


def _drive(report: Report) -> tuple[object, ...] | str:
    if report.fit is None:
        return str(report.fit_problem)
    drive = report.fit.drive
    return (drive,) if drive is not None else "no drive model (no log has a speed)"


def _drive_heldout(report: Report) -> tuple[object, ...] | str:
    drive = _drive(report)
    if isinstance(drive, str):
        return drive
    if drive[0].heldout is None:  # type: ignore[attr-defined]
        return "no held-out accuracy (fewer than 4 trips)"
    return drive


def _drive_traces(report: Report) -> tuple[object, ...] | str:
    drive = _drive(report)
    if isinstance(drive, str):
        return drive
    return (report.drive_traces,) if report.drive_traces else "fewer than two runs to hold out"


def _complete_model(report: Report) -> FitResult | str:
    """The report's fit when its model is complete, else why not."""
    fit = report.fit
    if fit is None:
        return str(report.fit_problem)
    if not fit.model_complete:
        return f"the model is incomplete ({'; '.join(fit.notes) or 'see fit'})"
    return fit


def _figure5(report: Report) -> tuple[object, ...] | str:
    fit = _complete_model(report)
    return fit if isinstance(fit, str) else (fit.model, fit.stop_and_go)


def _figure7(report: Report) -> tuple[object, ...] | str:
    fit = _complete_model(report)
    return fit if isinstance(fit, str) else (fit.model,)


def _diagnosis(report: Report) -> tuple[object, ...] | str:
    d = report.diagnosis
    return (d,) if d is not None else str(report.diagnosis_problem)


def _findings(report: Report) -> tuple[object, ...] | str:
    d = report.diagnosis
    return (d, d.traces) if d is not None else str(report.diagnosis_problem)


#: Every figure, in the order a report shows them (the per-run figures after the others).
FIGURES: dict[str, FigureSpec] = {
    spec.name: spec
    for spec in (
        FigureSpec(
            "power_speed",
            "P_acc(v) and P_v(v)",
            "fit (FitResult)",
            power_speed_figure,
            "A point per run: the mean power of its acceleration (left) and cruise (right) "
            "phases at its speed; the fitted line with its 95% confidence band; the paper's "
            "line dashed. A point far from the band is a run to look at.",
            from_report=_fit,
        ),
        FigureSpec(
            "figure5",
            "Paper Figure 5: stop-and-go energy against speed",
            "a model (PowerModel) and the measured overheads (FitResult.stop_and_go)",
            figure5,
            "Left: trip energy for 2 m and 10 m in one step and in 1 m steps, fitted model "
            "solid, paper dashed, the logs' means as points. Right: the overhead of N steps "
            "over one; points with bars are measured (95% CI), lines are the models.",
            from_report=_figure5,
        ),
        FigureSpec(
            "figure7",
            "Paper Figure 7: relay lifetime gain",
            "a model (PowerModel)",
            figure7,
            "Lifetime gain of the two-robot network over A alone against E0A, E0B, distance "
            "and data rate, a line per rate (paper Table 2); fitted model solid, paper "
            "dashed.",
            from_report=_figure7,
        ),
        FigureSpec(
            "heldout_error",
            "Held-out error against speed, steps, distance, session order",
            "diagnose (Diagnosis)",
            heldout_error_figure,
            "Each run's motion energy predicted by a model fitted without it, minus the "
            "measured energy, in %: the paper-form model (orange) and the model extended by "
            "the named causes (green). A trend in orange that green removes is what a cause "
            "explained; a trend left in green is unexplained.",
            from_report=_diagnosis,
        ),
        FigureSpec(
            "findings",
            "Each finding's evidence",
            "diagnose (Diagnosis) and its causes' trace data (Diagnosis.traces)",
            findings_figure,
            "For the ripple: each run's spectral peak against its speed and the fitted "
            "f = k v line, and one run's cruise spectrum. For an energy cause: what each "
            "run's measured energy exceeds the prediction by, per step, before and after the "
            "cause is added.",
            from_report=_findings,
        ),
        FigureSpec(
            "drive_power",
            "Drive model: held-out runs' power over time",
            "held-out traces (drive.traces.HeldOutTrace), from the runs' drive statistics",
            drive_power_figure,
            "For a few runs (one per surface first), each window's measured mean power (dark) "
            "and the drive model's prediction (blue) when identified without that run. Where "
            "blue misses dark at turns, stops or on one surface, a term is missing or wrong.",
            from_report=_drive_traces,
        ),
        FigureSpec(
            "drive_energy",
            "Drive model: held-out run energy, predicted against measured",
            "a drive model (DriveModel.heldout)",
            drive_energy_figure,
            "A point per run (or trip) held out of the fit: predicted against measured "
            "energy, the 90% prediction interval as a bar, a colour per surface. Points on the "
            "dashed line are exact; about 9 bars in 10 should cross it.",
            from_report=_drive_heldout,
        ),
        FigureSpec(
            "drive_terms",
            "Drive model: the terms per surface",
            "a drive model (DriveModel)",
            drive_terms_figure,
            "A panel per term, its unit on the axis: the value at each surface (or 'all' for "
            "a shared term) with its 95% interval. Surfaces whose intervals do not overlap "
            "differ in that term.",
            from_report=_drive,
        ),
        FigureSpec(
            "trace",
            "Power trace and phases",
            "a run's samples and segmentation (TraceView)",
            trace_figure,
            "Each shaded span is one phase (colour by phase name, the same in every figure), "
            "its mean power a thin line; triangles mark start-up spikes; the speed, when the "
            "log has one, is on the right axis. Check that the spans sit on the edges of the "
            "trace.",
            per_run=True,
        ),
    )
}


__all__ = [
    "FIGURES",
    "PHASE_COLOURS",
    "FigureSpec",
    "TraceView",
    "drive_energy_figure",
    "drive_power_figure",
    "drive_terms_figure",
    "figure5",
    "figure7",
    "findings_figure",
    "heldout_error_figure",
    "power_speed_figure",
    "save_figure",
    "trace_figure",
    "trace_view",
]
