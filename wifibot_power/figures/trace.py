"""A run's power trace with its phases shaded and labelled, start-up spikes marked and the
speed trace on a second axis when the log has one (cli.md, "Figures").

A long trace is drawn from a min/max envelope per pixel column (`envelope`): 10 M samples
become ~2 000 columns, so drawing takes the same time whatever the log's length
(benchmarks/figures.py measures it). `TraceView` holds only that envelope and the phases,
so a report keeps one per run without keeping the samples.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import (
    PHASE_COLOURS,
    POWER_COLOUR,
    SPEED_COLOUR,
    new_figure,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

#: Pixel columns of a trace figure's envelope (a 12-inch figure at 100 dpi is 1 200 px wide;
#: twice that keeps the envelope finer than the screen).
COLUMNS = 2400
#: A phase is labelled in the plot only when it spans this fraction of the run or more.
LABEL_MIN_FRACTION = 0.04


@dataclass(frozen=True, eq=False)
class Envelope:
    """Min and max of a signal over each column of samples from `time_s[i]` (left edges)."""

    time_s: np.ndarray
    low: np.ndarray
    high: np.ndarray
    mean: np.ndarray
    #: samples in each column (the sum over a column is `mean * count`)
    count: np.ndarray | None = None


def envelope(time_s: np.ndarray, values: np.ndarray, columns: int = COLUMNS) -> Envelope:
    """The min/max/mean envelope of `values` in at most `columns` equal runs of samples
    (vectorised: `np.minimum.reduceat`; the samples themselves when there are fewer)."""
    values = np.asarray(values, dtype=np.float64)
    time_s = np.asarray(time_s, dtype=np.float64)
    n = values.size
    if n <= columns:
        one = np.ones(n, dtype=np.int64)
        return Envelope(time_s.copy(), values.copy(), values.copy(), values.copy(), one)
    starts = np.linspace(0, n, columns + 1).astype(np.int64)[:-1]
    counts = np.diff(np.append(starts, n))
    return Envelope(
        time_s=time_s[starts],
        low=np.minimum.reduceat(values, starts),
        high=np.maximum.reduceat(values, starts),
        mean=np.add.reduceat(values, starts) / counts,
        count=counts,
    )


@dataclass(frozen=True)
class PhaseSpan:
    phase: str
    step: int
    t_start_s: float
    t_end_s: float
    mean_power_W: float
    #: the phase's energy [J] (`Phase.energy_J`, the rectangle rule over its samples)
    energy_J: float = float("nan")


@dataclass(frozen=True)
class SpikeMark:
    t_start_s: float
    duration_s: float
    peak_W: float
    energy_above_level_J: float = float("nan")


@dataclass(frozen=True, eq=False)
class TraceView:
    """What a trace figure needs of a run: its envelope, phases, spikes and doubts."""

    run_id: str
    file: str
    mode: str
    duration_s: float
    samples: int
    power: Envelope
    speed: Envelope | None
    phases: tuple[PhaseSpan, ...]
    spikes: tuple[SpikeMark, ...]
    doubts: tuple[str, ...]
    #: commanded speed, distance and steps from the metadata (None where absent)
    speed_mps: float | None = None
    distance_m: float | None = None
    steps: int | None = None
    #: the run's energy from its start to the left edge of each column of `power`, and to
    #: its end (one more value than columns) [J]: the exact rectangle-rule sums of the
    #: samples (`run.energy_J`), so a span between column edges has its exact energy
    energy_edges_J: np.ndarray | None = None
    #: the end of the last sample's period [s] (the right edge of the last column)
    t_end_s: float | None = None

    @property
    def energy_J(self) -> float:
        """The run's energy [J] (`Run.energy_J`), NaN when the view has no edges."""
        edges = self.energy_edges_J
        return float(edges[-1]) if edges is not None and edges.size else float("nan")


def energy_edges_J(power: Envelope, sample_period_s: float) -> np.ndarray:
    """The cumulative energy [J] at each column edge of a power envelope (`TraceView`):
    0, then the rectangle-rule sum `sum(P_i) dt` (paper Eq. 1's integral, as
    `run.energy_J`) of every sample up to each column's end."""
    count = power.count if power.count is not None else np.ones(power.mean.size, np.int64)
    sums_W = power.mean * count
    return np.concatenate([[0.0], np.cumsum(sums_W)]) * sample_period_s


def trace_view(run: Run, segmentation: Segmentation, columns: int = COLUMNS) -> TraceView:
    """The `TraceView` of a segmented run (the samples are reduced to an envelope here)."""
    speed = None if run.speed_mps is None else envelope(run.time_s, run.speed_mps, columns)
    meta = run.meta
    power = envelope(run.time_s, run.power_W, columns)
    t_end = float(run.time_s[-1]) + run.sample_period_s if run.samples else 0.0
    return TraceView(
        run_id=segmentation.run_id or meta.run_id,
        file=run.file,
        mode=meta.mode,
        duration_s=run.duration_s,
        samples=run.samples,
        power=power,
        speed=speed,
        phases=tuple(
            PhaseSpan(p.phase, p.step, p.t_start_s, p.t_end_s, p.mean_power_W, p.energy_J)
            for p in segmentation.phases
        ),
        spikes=tuple(
            SpikeMark(s.t_start_s, s.duration_s, s.peak_W, s.energy_above_level_J)
            for s in segmentation.spikes
        ),
        doubts=tuple(segmentation.doubts),
        speed_mps=meta.speed_mps if meta.mode == "motion" else None,
        distance_m=meta.distance_m if meta.mode == "motion" else None,
        steps=meta.steps if meta.mode == "motion" else None,
        energy_edges_J=energy_edges_J(power, run.sample_period_s),
        t_end_s=t_end,
    )


def _title(view: TraceView) -> str:
    parts = [f"{view.run_id} ({view.mode})"]
    if view.speed_mps is not None:
        parts.append(f"{view.speed_mps:g} m/s")
    if view.distance_m is not None:
        parts.append(f"{view.distance_m:g} m in {view.steps} step(s)")
    parts.append(f"{view.samples:,} samples, {view.duration_s:.1f} s")
    return ", ".join(parts)


def trace_figure(
    view: TraceView | Run,
    segmentation: Segmentation | None = None,
    *,
    width_in: float = 12.0,
    height_in: float = 3.4,
) -> Figure:
    """The power trace of one run [W] against time [s]: one shaded span per phase (colour by
    phase name, `style.PHASE_COLOURS`), each phase's mean power as a short line, labels on
    phases wide enough to hold one, start-up spikes as triangles at their peak, the speed
    [m/s] on a right-hand axis when the log has a speed column, and any doubt about the
    segmentation printed under the title. Takes a `TraceView`, or a run and its
    segmentation."""
    if segmentation is not None:
        view = trace_view(view, segmentation)
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    figure = new_figure(width_in, height_in, layout=None)
    # fixed margins [in] (constrained layout would double the drawing time of a trace)
    figure.subplots_adjust(
        left=0.75 / width_in,
        right=1 - (0.75 if view.speed is not None else 0.25) / width_in,
        top=1 - (0.55 if view.doubts else 0.35) / height_in,
        bottom=0.8 / height_in,
    )
    ax = figure.add_subplot()
    env = view.power
    t_end = view.duration_s if view.duration_s > 0 else float(env.time_s[-1])
    _shade_phases(ax, view)
    ax.fill_between(
        env.time_s, env.low, env.high, step="post", color=POWER_COLOUR, lw=0.6, alpha=0.9
    )
    ax.plot(env.time_s, env.mean, drawstyle="steps-post", color=POWER_COLOUR, lw=0.5)
    ax.set_xlim(float(env.time_s[0]) if env.time_s.size else 0.0, t_end)
    low = float(np.nanmin(env.low)) if env.low.size else 0.0
    high = float(np.nanmax(env.high)) if env.high.size else 1.0
    pad = 0.08 * (high - low or 1.0)
    ax.set_ylim(low - pad, high + 3 * pad)  # headroom for the phase labels
    _label_phases(ax, view, t_end, high + 1.6 * pad)
    if view.spikes:
        ax.plot(
            [s.t_start_s for s in view.spikes],
            [s.peak_W for s in view.spikes],
            "v",
            color="#d62728",
            ms=6,
            gid="spikes",
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("power [W]")
    ax.grid(True, axis="y", alpha=0.3)
    handles = [Patch(color=PHASE_COLOURS[n], alpha=0.5, label=n) for n in _names(view)]
    handles.append(Line2D([], [], color=POWER_COLOUR, lw=2, label="power (min/max per column)"))
    if view.spikes:
        handles.append(Line2D([], [], ls="", marker="v", color="#d62728", label="start-up spike"))
    if view.speed is not None:
        _speed_axis(ax, view)
        handles.append(Line2D([], [], color=SPEED_COLOUR, label="speed"))
    figure.legend(handles=handles, loc="lower center", fontsize=8, ncol=len(handles), frameon=False)
    title = _title(view)
    if view.doubts:
        # wrapped to the axes' width (about 150 characters at 9 pt on 12 in): a long doubt
        # ran off the figure's right edge
        title += "\n" + "\n".join(textwrap.wrap("in doubt: " + "; ".join(view.doubts), 150))
    ax.set_title(title, fontsize=9, loc="left", color="#b00000" if view.doubts else "black")
    return figure


def _shade_phases(ax: Axes, view: TraceView) -> None:
    """One shaded span per phase (colour by phase name; adjacent levels alternate their
    strength) and each phase's mean power [W] as a line across it."""
    levels = 0
    for i, p in enumerate(view.phases):
        alpha = 0.28
        if p.phase == "level":  # adjacent levels share a colour: alternate its strength
            alpha = 0.18 if levels % 2 == 0 else 0.36
            levels += 1
        span = ax.axvspan(
            p.t_start_s, p.t_end_s, color=PHASE_COLOURS.get(p.phase, "#dddddd"), alpha=alpha, lw=0
        )
        span.set_gid(f"phase:{p.phase}:{i}")
        ax.hlines(p.mean_power_W, p.t_start_s, p.t_end_s, colors="#444444", lw=0.8, alpha=0.8)


def _label_phases(ax: Axes, view: TraceView, t_end: float, y_W: float) -> None:
    """Each phase's name at height `y_W` [W] over the phases wide enough to hold one."""
    for p in view.phases:
        if (p.t_end_s - p.t_start_s) >= LABEL_MIN_FRACTION * t_end:
            label = p.phase if p.phase != "level" else f"level {p.step}"
            if p.phase in ("accel", "cruise", "decel") and (view.steps or 1) > 1:
                label = f"{p.phase} {p.step}"
            ax.text(
                (p.t_start_s + p.t_end_s) / 2,
                y_W,
                label,
                ha="center",
                va="center",
                fontsize=8,
                clip_on=True,
            )


def _speed_axis(ax: Axes, view: TraceView) -> None:
    """The speed [m/s] on a right-hand axis (the log has a speed column)."""
    ax2 = ax.twinx()
    ax2.plot(view.speed.time_s, view.speed.mean, color=SPEED_COLOUR, lw=1.0, drawstyle="steps-post")
    ax2.set_ylabel("speed [m/s]", color=SPEED_COLOUR)
    ax2.set_ylim(bottom=min(0.0, float(np.nanmin(view.speed.low))))


def _names(view: TraceView) -> list[str]:
    seen = dict.fromkeys(p.phase for p in view.phases)
    return [n for n in PHASE_COLOURS if n in seen]
