"""What `diagnose` found, drawn (cli.md, "Figures"):

- `heldout_error_figure`: the held-out error of each run's motion energy, paper-form model
  against extended model, against speed, step count, distance and session order;
- `findings_figure`: each finding's own evidence: the panels a cause draws of itself
  (`Cause.panels`: the ripple's peak frequencies against speed, and a run's spectrum when
  the caller has the runs' traces), else each run's held-out error per step [J] against
  speed before and after the cause is added, with the cause's estimate and interval.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import (
    BASELINE_COLOUR,
    EXTENDED_COLOUR,
    PHASE_COLOURS,
    new_figure,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from wifibot_power.diagnose import Diagnosis, Finding

#: covariate column of `Diagnosis.runs` -> axis label (with its unit)
COVARIATES = {
    "speed_mps": "speed [m/s]",
    "steps": "steps per trip [-]",
    "distance_m": "distance [m]",
    "session_order": "session order (run number) [-]",
}


#: The residual of every figure: measured − predicted (what the model misses; positive where
#: the robot used more than predicted), as docs/diagnose.md's relative errors and the
#: findings' per-step panel. `Diagnosis.runs`' `*_error_pct` columns are predicted −
#: measured, so their sign is turned here.
RESIDUAL = "measured − predicted"


def heldout_error_figure(diagnosis: Diagnosis) -> Figure:
    """Four panels: held-out error of run motion energy, measured − predicted [%] of the
    measured (`RESIDUAL`), of the paper-form model and of the extended model, a point per
    run, against each covariate. Side by side at discrete values (a small offset), so both
    show."""
    figure = new_figure(11.0, 6.4)
    axes = figure.subplots(2, 2).ravel()
    runs = diagnosis.runs
    causes = ", ".join(f.cause for f in diagnosis.findings) or "no cause"
    for ax, (column, label) in zip(axes, COVARIATES.items(), strict=True):
        x = runs[column].to_numpy(np.float64)
        known = np.isfinite(x) & (x >= 0)
        if not known.any() or np.unique(x[known]).size < 2:
            ax.text(
                0.5,
                0.5,
                f"{label.split(' [')[0]}: one value only\nor not in the logs",
                ha="center",
                va="center",
                transform=ax.transAxes,
                fontsize=9,
            )
            ax.set_xlabel(label)
            ax.set_ylabel(f"{RESIDUAL} [%]")
            ax.set_xticks([])  # no 0-1 scale that no data drew
            ax.set_yticks([])
            continue
        values = np.unique(x[known])
        # discrete values: the two models side by side, a little apart
        offset = 0.012 * float(values[-1] - values[0]) if values.size < 30 else 0.0
        for name, colour, shift, text in (
            ("baseline", BASELINE_COLOUR, -offset, "paper-form"),
            ("extended", EXTENDED_COLOUR, offset, f"extended ({causes})"),
        ):
            ax.plot(
                x[known] + shift,
                -runs[f"{name}_error_pct"].to_numpy(np.float64)[known],  # measured − predicted
                "o",
                ms=3.5,
                color=colour,
                alpha=0.8,
                label=text,
                gid=name,
            )
        ax.axhline(0.0, color="#444444", lw=0.8)
        ax.set_xlabel(label)
        ax.set_ylabel(f"{RESIDUAL} [%]")
        ax.grid(True, alpha=0.3)
    # the legend under the panels: inside one it covered a run's point
    handles, labels = axes[0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    figure.suptitle(
        f"Held-out error of each run's motion energy ({diagnosis.n_runs} runs): "
        f"RMSE {diagnosis.baseline_rmse_J:.3g} J paper-form, "
        f"{diagnosis.extended_rmse_J:.3g} J extended",
        fontsize=10,
    )
    return figure


def findings_figure(
    diagnosis: Diagnosis,
    traces: Mapping[str, Mapping[str, object]] | None = None,
) -> Figure:
    """The panels of each finding with its own evidence (module docstring; a cause draws
    its own, `Cause.panels`, else the energy cause's panel here); one panel saying so when
    nothing was named. `traces` (each cause's per-run trace data by cause, then run_id:
    `Diagnosis.traces`) adds the panels that read traces (the ripple's spectrum)."""
    from wifibot_power.causes import CAUSES, PanelView

    panels: list[Callable[[Axes], None]] = []
    for finding in diagnosis.findings:
        view = PanelView(
            diagnosis.runs,
            finding.estimate,
            _estimate_text(finding),
            (traces or {}).get(finding.cause, {}),
            PHASE_COLOURS,
        )
        cause = CAUSES.get(finding.cause)
        drawn = cause.panels(view) if cause is not None else None
        panels += drawn if drawn is not None else [_bind(_energy_cause, diagnosis, finding)]
    if not panels:
        panels.append(_bind(_nothing_named, diagnosis))
    # no empty panel: up to three in a row; more in rows of two, an odd last one as wide as
    # the row
    columns = len(panels) if len(panels) <= 3 else 2
    rows = (len(panels) + columns - 1) // columns
    figure = new_figure(5.0 * columns if columns < 3 else 15.0, 4.0 * rows)
    grid = figure.add_gridspec(rows, columns)
    for k, draw in enumerate(panels):
        row, col = divmod(k, columns)
        last_alone = k == len(panels) - 1 and col == 0 and columns == 2
        draw(figure.add_subplot(grid[row, :] if last_alone else grid[row, col]))
    return figure


def _bind(draw: Callable[..., None], *args: object) -> Callable[[Axes], None]:
    return lambda ax: draw(ax, *args)


def _nothing_named(ax: Axes, diagnosis: Diagnosis) -> None:
    # never a bare "nothing" beside an unexplained diagnosis (cli.md)
    text = "no cause named"
    if diagnosis.unexplained:
        text += "\nunexplained: see the diagnosis's reasons"
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
    ax.set_axis_off()


def _estimate_text(finding: Finding) -> str:
    """A finding's panel title in words: what the cause is (its physics, causes.md), then
    its estimate (the headline parameter's value, unit and 95% interval: the parameter's
    code name is `diagnose`'s, not a title) and the gain."""
    from wifibot_power.causes import CAUSES

    e = finding.estimate
    low, high = e.get("ci95", [np.nan, np.nan])
    cause = CAUSES.get(finding.cause)
    what = cause.physics if cause is not None else finding.cause.replace("_", " ")
    return (
        f"{what[:1].upper()}{what[1:]}\nestimate {float(e.get('value', np.nan)):.4g} "
        f"{e.get('unit', '')} [{low:.4g}, {high:.4g}], gain {finding.gain_text()}"
    )


def _energy_cause(ax: Axes, diagnosis: Diagnosis, finding: Finding) -> None:
    runs = diagnosis.runs
    speed = runs["speed_mps"].to_numpy(np.float64)
    steps = runs["steps"].to_numpy(np.float64)
    measured = runs["measured_energy_J"].to_numpy(np.float64)
    for name, colour, text in (
        ("baseline", "#d55e00", "paper-form"),
        ("extended", "#009e73", "extended"),
    ):
        per_step = (measured - runs[f"{name}_energy_J"].to_numpy(np.float64)) / steps
        for many, marker in ((False, "o"), (True, "s")):
            chosen = (steps > 1) == many
            if chosen.any():
                ax.plot(
                    speed[chosen],
                    per_step[chosen],
                    marker,
                    ms=3.5,
                    color=colour,
                    alpha=0.8,
                    mfc=colour if many else "none",
                    label=f"{text}, {'N > 1' if many else '1'} step(s)",
                    gid=name,
                )
    ax.axhline(0.0, color="#444444", lw=0.8)
    ax.set_xlabel("speed [m/s]")
    ax.set_ylabel(f"{RESIDUAL}, per step [J]")
    ax.set_title(_estimate_text(finding), fontsize=8, loc="left")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
