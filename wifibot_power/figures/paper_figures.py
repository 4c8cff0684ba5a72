"""The paper's Figures 5 and 7 from a model, with the paper's model beside it.

- `figure5`: trip energy against speed for 2 m and 10 m, in one step and in 1 m steps
  (paper Figure 5, Eq. 5/6, `energy.speed_sweep`), and the stop-and-go overhead against
  speed with the logs' measured overheads as points with their 95% intervals
  (`overhead.StopAndGo`).
- `figure7`: network lifetime gain of the relay scenario against E0A, E0B, distance and
  data rate (paper Figure 7, Eq. 7-11, `lifetime.lifetime_sweep`), a line per data rate.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import (
    PAPER_COLOUR,
    RATE_COLOURS,
    new_figure,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from wifibot_power.model import PowerModel
    from wifibot_power.overhead import StopAndGo

#: a colour per trip of Figure 5: (distance [m], in steps?)
TRIP_COLOURS = {
    (2.0, False): "#e69f00",
    (2.0, True): "#d55e00",
    (10.0, False): "#56b4e9",
    (10.0, True): "#0072b2",
}
OTHER_COLOURS = ("#009e73", "#cc79a7", "#f0e442", "#999999")


def _label(model: PowerModel) -> str:
    if model.source == "paper":
        return "paper"
    return "fitted" if model.source == "fit" else f"fitted ({model.source})"


def figure5(
    model: PowerModel,
    stop_and_go: Sequence[StopAndGo] | None = None,
    *,
    paper: PowerModel | None = None,
    distances_m: Sequence[float] = (2.0, 10.0),
    step_m: float = 1.0,
    speeds_mps: Sequence[float] | None = None,
    t_acc_s: float | None = None,
    trip: tuple[float, float, int] | None = None,
) -> Figure:
    """Left: trip energy [J] against speed [m/s] for each distance in one step and in
    `step_m` steps, from `model` (solid) and the paper's model (dashed), the measured mean
    energies of `stop_and_go`'s trips as points. Right: the stop-and-go overhead [%] of the
    same trips, and of each measured trip, with the measured overheads as points with 95%
    interval bars. Without `stop_and_go` (None: no logs, e.g. `energy --plot`), models only;
    with an empty one, the figure says the logs hold no trip in both 1 and N steps.
    `trip` (speed [m/s], distance [m], steps): the trip asked about (`energy --speed --dist
    --steps --plot`), marked with a star and its energy and overhead from `model`."""
    from wifibot_power.model import paper_model

    paper = paper or paper_model()
    speeds = _figure5_speeds(model, speeds_mps)
    figure = new_figure(11.0, 4.4)
    ax_energy, ax_over = figure.subplots(1, 2)
    # the trips drawn: Figure 5's, plus every measured (distance, steps) pair
    trips = [(float(d), max(1, int(np.ceil(d / step_m - 1e-9)))) for d in distances_m]
    for row in stop_and_go or ():
        if (row.distance_m, row.steps) not in trips:
            trips.append((row.distance_m, row.steps))
    models = [(model, "-")] + ([(paper, "--")] if model != paper else [])
    peak_J = _draw_trip_models(ax_energy, ax_over, trips, models, speeds, t_acc_s)
    _draw_measured(ax_energy, ax_over, stop_and_go)
    if trip is not None:
        _mark_trip(ax_energy, ax_over, model, trip, t_acc_s)
    # another robot's trips can cost a hundredth of the Wifibot's: on a linear scale they
    # lie flat under the paper's curves, so the scale is logarithmic when the two models'
    # largest energies differ tenfold or more
    if len(models) == 2 and min(peak_J) > 0 and max(peak_J) >= 10 * min(peak_J):
        ax_energy.set_yscale("log")
    ax_energy.set_xlabel("speed [m/s]")
    ax_energy.set_ylabel("trip energy [J]")
    ax_energy.set_title("Figure 5: trip energy against speed (Eq. 5/6)", fontsize=10, loc="left")
    ax_over.set_xlabel("speed [m/s]")
    ax_over.set_ylabel("stop-and-go overhead [%]")
    ax_over.set_title("overhead of N steps over one step", fontsize=10, loc="left")
    for ax in (ax_energy, ax_over):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper right" if ax is ax_energy else "upper left")
    return figure


def _mark_trip(
    ax_energy: Axes,
    ax_over: Axes,
    model: PowerModel,
    trip: tuple[float, float, int],
    t_acc_s: float | None,
) -> None:
    """The trip asked about: a star at its energy [J] (and, in N > 1 steps, its overhead
    [%]) from `model`, labelled with the numbers `energy` prints (Eq. 5/6)."""
    from wifibot_power.energy import energy_report

    speed, distance, steps = trip
    report = energy_report(model, speed, distance, steps, t_acc_s=t_acc_s)
    label = (
        f"this trip: {distance:g} m in {steps} step(s) at {speed:g} m/s, "
        f"{report.trip.energy_J:.4g} J"
    )
    ax_energy.plot(
        speed,
        report.trip.energy_J,
        "*",
        ms=15,
        color="#d62728",
        mec="black",
        mew=0.8,
        label=label,
        gid="trip",
        zorder=5,
    )
    if steps > 1:
        ax_over.plot(
            speed,
            report.overhead_pct,
            "*",
            ms=15,
            color="#d62728",
            mec="black",
            mew=0.8,
            label=f"this trip: {report.overhead_pct:.3g}%",
            gid="trip",
            zorder=5,
        )


def _figure5_speeds(model: PowerModel, speeds_mps: Sequence[float] | None) -> np.ndarray:
    """The speeds [m/s] Figure 5's curves are drawn at: `speeds_mps`, else the paper's."""
    if speeds_mps is None:
        # the paper's 0.1-0.9 m/s, widened to the speeds the model was fitted on (another
        # robot's runs may be faster)
        top_mps = max(0.9, (model.speed_range_mps or (0.1, 0.9))[1])
        if top_mps <= 0.9:
            return np.linspace(0.1, 0.9, 33)
        else:  # the paper's last speed kept, so its curves end where it stopped measuring
            return np.union1d(np.linspace(0.1, top_mps, 49), [0.9])
    else:
        return np.asarray(speeds_mps, float)


def _draw_trip_models(
    ax_energy: Axes,
    ax_over: Axes,
    trips: list[tuple[float, int]],
    models: list[tuple[PowerModel, str]],
    speeds: np.ndarray,
    t_acc_s: float | None,
) -> list[float]:
    """Each model's trip energy [J] (and, in steps, its overhead [%]) of each trip
    (distance [m], steps) against speed, where the model holds; returns each model's largest
    energy drawn [J]."""
    from wifibot_power.energy import energy_report

    peak_J = [0.0] * len(models)  # each model's largest energy drawn
    for i, (distance, steps) in enumerate(trips):
        # a distance Figure 5 does not have: a pair of colours of its own
        extra_one = OTHER_COLOURS[(2 * i) % len(OTHER_COLOURS)]
        extra_n = OTHER_COLOURS[(2 * i + 1) % len(OTHER_COLOURS)]
        for which, (m, style) in enumerate(models):
            reports = [energy_report(m, v, distance, steps, t_acc_s=t_acc_s) for v in speeds]
            tag = _label(m)
            # drawn only where the model holds: within the speeds it was fitted on, and where
            # its trip energies are positive (a line fitted at 0.7-1.9 m/s with a negative
            # intercept gives negative energies at 0.1 m/s and overheads of thousands of %)
            one_J = np.array([r.one_step.energy_J for r in reports])
            trip_J = np.array([r.trip.energy_J for r in reports])
            inside = np.array([m.fitted_at(v) for v in speeds], dtype=bool)
            holds = inside & (one_J > 0) & (trip_J > 0)
            if holds.any():
                peak_J[which] = max(peak_J[which], float(one_J[holds].max()))
                if steps > 1:
                    peak_J[which] = max(peak_J[which], float(trip_J[holds].max()))
            if not inside.all():
                low, high = m.speed_range_mps
                tag += f", over {low:.2g}-{high:.2g} m/s"
            one_colour = TRIP_COLOURS.get((distance, False), extra_one)
            n_colour = TRIP_COLOURS.get((distance, True), extra_n)
            ax_energy.plot(
                speeds,
                np.where(holds, one_J, np.nan),
                style,
                color=one_colour,
                lw=1.4,
                label=f"{distance:g} m, 1 step ({tag})",
                gid=f"model:{which}",
            )
            if steps > 1:
                ax_energy.plot(
                    speeds,
                    np.where(holds, trip_J, np.nan),
                    style,
                    color=n_colour,
                    lw=1.4,
                    label=f"{distance:g} m, {steps} steps ({tag})",
                    gid=f"model:{which}",
                )
                ax_over.plot(
                    speeds,
                    np.where(holds, [r.overhead_pct for r in reports], np.nan),
                    style,
                    color=n_colour,
                    lw=1.4,
                    label=f"{distance:g} m in {steps} steps ({tag})",
                    gid=f"model:{which}",
                )
    return peak_J


def _draw_measured(ax_energy: Axes, ax_over: Axes, stop_and_go: Sequence[StopAndGo] | None) -> None:
    """The measured trips of the logs: mean energies [J] as points, overheads [%] with 95%
    interval bars; with none measured (an empty `stop_and_go`), a note that says so."""
    if stop_and_go:
        for row in stop_and_go:
            n_colour = TRIP_COLOURS.get((row.distance_m, True), "#009e73")
            one_colour = TRIP_COLOURS.get((row.distance_m, False), "#009e73")
            ax_energy.plot(
                row.speed_mps,
                row.energy_J,
                "o",
                color=n_colour,
                mec="black",
                mew=0.6,
                ms=5,
                gid="measured",
            )
            ax_energy.plot(
                row.speed_mps,
                row.one_step_energy_J,
                "o",
                color=one_colour,
                mec="black",
                mew=0.6,
                ms=5,
                gid="measured",
            )
        speed = np.array([r.speed_mps for r in stop_and_go])
        value = np.array([r.overhead_pct for r in stop_and_go])
        low = np.array([r.overhead_ci95[0] for r in stop_and_go])
        high = np.array([r.overhead_ci95[1] for r in stop_and_go])
        bars = np.vstack([value - low, high - value])
        bars = np.where(np.isfinite(bars), bars, 0.0)
        ax_over.errorbar(
            speed,
            value,
            yerr=bars,
            fmt="o",
            color="black",
            mfc="white",
            ms=5,
            capsize=3,
            lw=1.0,
            label="measured (logs), 95% CI",
            gid="measured",
        )
        ax_energy.plot([], [], "o", color="white", mec="black", label="measured (logs)")
    elif stop_and_go is not None:
        ax_over.text(
            0.5,
            0.03,  # clear of the legend (upper left)
            "no trip in the logs in both 1 and N steps",
            transform=ax_over.transAxes,
            ha="center",
            va="bottom",
            fontsize=8,
            color="#555555",
        )


#: sweep name -> (axis label, scale of the x values for the axis)
SWEEP_AXES = {
    "e0a": ("E0A, initial energy of A [kJ]", 1e-3),
    "e0b": ("E0B, initial energy of B [kJ]", 1e-3),
    "dist": ("distance B drives [m]", 1.0),
    "rate": ("data rate [Mbit/s]", 1.0),
}


#: Fitted and paper curves closer than this fraction of a panel's gain range are drawn once
#: (at 3.8 in per panel, 0.5% is under a line's width: a dashed line on top of a solid one
#: hid it, and the legend listed six lines where three showed).
COINCIDE_FRACTION = 0.005


def figure7(
    model: PowerModel,
    *,
    paper: PowerModel | None = None,
    sweeps: Sequence[str] = ("e0a", "e0b", "dist", "rate"),
    rates_mbps: Sequence[float] | None = None,
    **scenario: float | None,
) -> Figure:
    """Lifetime gain [%] of the relay scenario (paper Eq. 7-11) against each swept input,
    a line per data rate (paper Table 2) for E0A, E0B and distance; `model` solid, the
    paper's dashed. The data-rate panel has a point per rate, never a line joining rates
    (each rate is its own scenario): the fitted model's filled, the paper's a ring around
    it. Where the two models' curves coincide (within `COINCIDE_FRACTION` of the panel's
    range) the paper's are not drawn again, and the legend says they coincide: it lists
    only what shows. One legend, under the panels. `scenario`: the other inputs
    (`lifetime.network_lifetime` keywords)."""
    from wifibot_power.lifetime import TABLE2
    from wifibot_power.model import paper_model

    paper = paper or paper_model()
    rates = tuple(TABLE2) if rates_mbps is None else tuple(rates_mbps)
    n = len(sweeps)
    columns = 2 if n > 1 else 1
    figure = new_figure(5.5 * columns, 3.8 * ((n + 1) // 2) + 0.6)
    axes = np.atleast_1d(figure.subplots((n + 1) // 2, columns)).ravel()
    models = [model] + ([paper] if model != paper else [])
    curves = _figure7_curves(models, sweeps, rates, scenario)
    coincide, differ_pp = _figure7_coincide(curves, sweeps, len(models))
    shown_rates: list[float] = []
    for ax, sweep in zip(axes, sweeps, strict=False):
        shown_rates += _figure7_panel(ax, sweep, curves, rates, coincide)
    for ax in axes[n:]:
        ax.set_axis_off()
    handles = _figure7_legend(model, models, sweeps, shown_rates, coincide, differ_pp)
    figure.legend(
        handles=handles,
        loc="outside lower center",
        ncol=min(len(handles), 6),
        fontsize=8,
        frameon=False,
    )
    # Eq. 7-11 take the model's idle power as the whole robot's at rest (its embedded
    # system); a log of the motors alone reads ~0 W there (REGBOT: 0.14-1.4 W, a gain of
    # 34% beside the paper's 3-4%), so the figure says which idle power each line stands on
    idle = ", ".join(f"{_label(m)} {m.idle_W:.3g} W" for m in models)
    figure.suptitle(
        "Figure 7: network lifetime gain with B relaying (Eq. 7-11)\n"
        f"idle power (the robot's at rest, radio off): {idle}",
        fontsize=10,
    )
    return figure


#: figure 7's curves: (sweep, rate) -> (x on the panel's axis, lifetime gain [%] of each model)
_Curves = dict[tuple[str, float], tuple[np.ndarray, list[np.ndarray]]]


def _figure7_curves(
    models: list[PowerModel],
    sweeps: Sequence[str],
    rates: tuple[float, ...],
    scenario: dict[str, float | None],
) -> _Curves:
    """Every curve of figure 7: each model's lifetime gain (`lifetime.lifetime_sweep`, Eq.
    7-11) along each sweep, a curve per data rate (the data-rate sweep: one, over the rates)."""
    from wifibot_power.lifetime import lifetime_sweep

    curves: _Curves = {}
    for sweep in sweeps:
        _, scale = SWEEP_AXES[sweep]
        for rate in rates if sweep != "rate" else (0.0,):
            gains, x = [], np.zeros(0)
            for m in models:
                rows = lifetime_sweep(sweep, m, rate, **scenario)
                attribute = "rate_mbps" if sweep == "rate" else _X[sweep]
                x = np.array([getattr(r, attribute) for r in rows]) * scale
                gains.append(np.array([r.improvement_pct for r in rows], dtype=np.float64))
            curves[(sweep, rate)] = (x, gains)
    return curves


def _figure7_coincide(curves: _Curves, sweeps: Sequence[str], n_models: int) -> tuple[bool, float]:
    """Whether the two models' curves coincide (every gap within `COINCIDE_FRACTION` of its
    panel's range), and the largest gap between them [% points]."""
    differ_pp = 0.0  # the largest difference between the models, in % points
    coincide = n_models == 2
    for sweep in sweeps:
        mine = [g for (s, _), (_, gs) in curves.items() if s == sweep for g in gs]
        every = np.concatenate(mine) if mine else np.zeros(0)
        span = float(np.nanmax(every) - np.nanmin(every)) if every.size else 0.0
        for (s, _), (_, gs) in curves.items():
            if s == sweep and len(gs) == 2:
                gap = float(np.nanmax(np.abs(gs[0] - gs[1]))) if gs[0].size else 0.0
                differ_pp = max(differ_pp, gap)
                coincide &= gap <= COINCIDE_FRACTION * max(span, 1e-9)
    return coincide, differ_pp


def _figure7_panel(
    ax: Axes, sweep: str, curves: _Curves, rates: tuple[float, ...], coincide: bool
) -> list[float]:
    """Draw one panel of figure 7 (the data-rate panel: a point per rate, the paper's a
    ring; the others: a line per rate, the paper's dashed unless they coincide); the rates
    it shows, for the legend."""
    shown_rates: list[float] = []
    label, _ = SWEEP_AXES[sweep]
    if sweep == "rate":
        x, gains = curves[(sweep, 0.0)]
        for xi, gi in zip(x, gains[0], strict=True):  # a point per rate, no line
            ax.plot(xi, gi, "o", ls="none", color=_rate_colour(xi), ms=7, gid="model:0")
            shown_rates.append(float(xi))
        if len(gains) == 2:
            ax.plot(
                x,
                gains[1],
                "o",
                ls="none",
                mfc="none",
                mec=PAPER_COLOUR,
                ms=12,
                mew=1.2,
                gid="model:1",
            )
        ax.set_xticks(x)
    else:
        for rate in rates:
            x, gains = curves[(sweep, rate)]
            colour = _rate_colour(rate)
            ax.plot(x, gains[0], "-", color=colour, lw=1.6, gid="model:0")
            if len(gains) == 2 and not coincide:
                ax.plot(x, gains[1], "--", color=colour, lw=1.2, gid="model:1")
            shown_rates.append(float(rate))
    if sweep == "dist":
        ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel(label)
    ax.set_ylabel("lifetime gain [%]")
    ax.grid(True, alpha=0.3)
    return shown_rates


def _figure7_legend(
    model: PowerModel,
    models: list[PowerModel],
    sweeps: Sequence[str],
    shown_rates: list[float],
    coincide: bool,
    differ_pp: float,
) -> list[Line2D]:
    """Figure 7's one legend for every panel: a colour per rate shown, then what the line
    styles mean (only what shows: the paper's lines are not drawn where they coincide)."""
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], color=_rate_colour(r), lw=2, marker="o", ms=5, label=f"{r:g} Mbit/s")
        for r in dict.fromkeys(shown_rates)
    ]
    fitted = _label(model)
    if len(models) == 1:
        handles.append(Line2D([], [], color="#555555", lw=1.6, label=fitted))
    elif coincide:
        handles.append(
            Line2D(
                [],
                [],
                color="#555555",
                lw=1.6,
                label=f"{fitted} = paper within {differ_pp:.2g} % points (lines drawn once)",
            )
        )
    else:
        handles.append(Line2D([], [], color="#555555", lw=1.6, label=f"{fitted} (solid, filled)"))
        handles.append(
            Line2D(
                [],
                [],
                color="#555555",
                ls="--",
                lw=1.2,
                marker="o",
                mfc="none",
                ms=7,
                label="paper (dashed, ring)",
            )
        )
    if len(models) == 2 and coincide and "rate" in sweeps:
        handles.append(
            Line2D(
                [],
                [],
                ls="none",
                marker="o",
                mfc="none",
                mec=PAPER_COLOUR,
                ms=9,
                label="paper (ring)",
            )
        )
    return handles


def _rate_colour(rate: float) -> str:
    return RATE_COLOURS.get(float(rate), "#999999")


_X = {"e0a": "e0a_J", "e0b": "e0b_J", "dist": "distance_m"}
