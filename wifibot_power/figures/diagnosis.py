"""What `diagnose` found, drawn (cli.md, "Figures"):

- `heldout_error_figure`: the held-out error of each run's motion energy, paper-form model
  against extended model, against speed, step count, distance and session order;
- `findings_figure`: each finding's own evidence. The ripple: the cruise spectrum's peak
  frequency of each run against its speed, with the fitted `f = k v` line (and a run's
  spectrum when the caller has its cruise blocks); an energy cause: each run's held-out
  error per step [J] against speed before and after the cause is added, with the cause's
  estimate and interval.
"""

from __future__ import annotations

from collections.abc import Mapping
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


def heldout_error_figure(diagnosis: Diagnosis) -> Figure:
    """Four panels: held-out error of run motion energy [%] of the paper-form model and of
    the extended model, a point per run, against each covariate. Side by side at discrete
    values (a small offset), so both show."""
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
            ax.set_ylabel("predicted − measured [%]")
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
                runs[f"{name}_error_pct"].to_numpy(np.float64)[known],
                "o",
                ms=3.5,
                color=colour,
                alpha=0.8,
                label=text,
                gid=name,
            )
        ax.axhline(0.0, color="#444444", lw=0.8)
        ax.set_xlabel(label)
        ax.set_ylabel("predicted − measured [%]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    figure.suptitle(
        f"Held-out error of each run's motion energy ({diagnosis.n_runs} runs): "
        f"RMSE {diagnosis.baseline_rmse_J:.3g} J paper-form, "
        f"{diagnosis.extended_rmse_J:.3g} J extended",
        fontsize=10,
    )
    return figure


def findings_figure(
    diagnosis: Diagnosis,
    cruise_blocks: Mapping[str, tuple[np.ndarray, float]] | None = None,
) -> Figure:
    """A panel per finding with its own evidence (module docstring); one panel saying so
    when nothing was named. `cruise_blocks` (run_id -> detrended cruise power in blocks [W],
    block length [s]; `traces.TraceStats`) adds the spectrum of the run with the longest
    cruise to the ripple's evidence."""
    panels: list[tuple[str, Finding | None]] = []
    for finding in diagnosis.findings:
        panels.append(("finding", finding))
        known = set(diagnosis.runs["run_id"])
        # a cause measured on the power trace is shown by the trace's spectrum (its metric,
        # not its name, picks the view: the registry is the only list of causes)
        if finding.metric == "power_trace" and any(r in known for r in cruise_blocks or {}):
            panels.append(("spectrum", finding))
    if not panels:
        panels.append(("none", None))
    figure = new_figure(5.5 * min(len(panels), 2), 4.0 * ((len(panels) + 1) // 2))
    axes = np.atleast_1d(figure.subplots((len(panels) + 1) // 2, min(len(panels), 2))).ravel()
    for ax, (kind, finding) in zip(axes, panels, strict=False):
        if kind == "none":
            # never a bare "nothing" beside an unexplained diagnosis (cli.md)
            text = "no cause named"
            if diagnosis.unexplained:
                text += "\nunexplained: see the diagnosis's reasons"
            ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes)
            ax.set_axis_off()
        elif kind == "spectrum":
            _spectrum(ax, diagnosis, finding, cruise_blocks)
        elif finding.metric == "power_trace":
            _ripple(ax, diagnosis, finding)
        else:
            _energy_cause(ax, diagnosis, finding)
    for ax in axes[len(panels) :]:
        ax.set_axis_off()
    return figure


def _estimate_text(finding: Finding) -> str:
    e = finding.estimate
    low, high = e.get("ci95", [np.nan, np.nan])
    return (
        f"{finding.cause}: {e.get('parameter', '')} = {float(e.get('value', np.nan)):.4g} "
        f"{e.get('unit', '')} [{low:.4g}, {high:.4g}], gain {finding.gain_pct:.1f}%"
    )


def _ripple(ax: Axes, diagnosis: Diagnosis, finding: Finding) -> None:
    from wifibot_power.causes.cruise_ripple import lines_found

    runs = diagnosis.runs
    speed = runs["speed_mps"].to_numpy(np.float64)
    hz = runs["ripple_hz"].to_numpy(np.float64)
    found = lines_found(runs)  # the lines the evidence counts
    ax.plot(
        speed[found],
        hz[found],
        "o",
        ms=4,
        color=PHASE_COLOURS["cruise"],
        mec="#333333",
        mew=0.5,
        label=f"peak of a run's cruise spectrum (n = {int(found.sum())})",
        gid="runs",
    )
    k = float(finding.estimate.get("hz_per_mps", np.nan))
    grid = np.linspace(0.0, max(1.0, float(np.nanmax(speed)) * 1.05), 50)
    ax.plot(grid, k * grid, color="black", lw=1.2, label=f"f = {k:.4g} Hz/(m/s) · v", gid="fit")
    ax.set_xlim(0.0, grid[-1])
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("speed [m/s]")
    ax.set_ylabel("ripple frequency [Hz]")
    ax.set_title(_estimate_text(finding), fontsize=8, loc="left")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")


def _spectrum(
    ax: Axes,
    diagnosis: Diagnosis,
    finding: Finding,
    cruise_blocks: Mapping[str, tuple[np.ndarray, float]],
) -> None:
    # the fastest run with 3 s or more of cruise: its peak stands clear of 0 Hz
    runs = diagnosis.runs.set_index("run_id")
    candidates = [r for r in cruise_blocks if r in runs.index]
    long_enough = [r for r in candidates if cruise_blocks[r][0].size * cruise_blocks[r][1] >= 3]
    run_id = max(long_enough or candidates, key=lambda r: (runs.at[r, "speed_mps"], r))
    blocks, block_s = cruise_blocks[run_id]
    speed = float(runs.at[run_id, "speed_mps"])
    amplitude = np.abs(np.fft.rfft(blocks)) * 2 / max(blocks.size, 1)  # one-sided [W]
    freq = np.fft.rfftfreq(blocks.size, block_s)
    expected = float(finding.estimate.get("hz_per_mps", np.nan)) * speed
    top = min(20.0, 5 * expected) if np.isfinite(expected) and expected > 0 else 20.0
    band = (freq > 0) & (freq <= top)
    ax.plot(freq[band], amplitude[band], color=PHASE_COLOURS["cruise"], lw=1.0, gid="spectrum")
    ax.axvline(
        expected,
        color="black",
        ls="--",
        lw=1.0,
        label=f"k · v = {expected:.3g} Hz at {speed:g} m/s",
    )
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("amplitude [W]")
    ax.set_title(
        f"cruise power spectrum of {run_id} ({blocks.size * block_s:.1f} s of cruise)",
        fontsize=8,
        loc="left",
    )
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)


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
    ax.set_ylabel("measured − predicted, per step [J]")
    ax.set_title(_estimate_text(finding), fontsize=8, loc="left")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
