"""`P_acc(v)` and `P_v(v)`: each run's mean power against its speed, the fitted lines with
their 95% confidence bands, and the paper's lines (paper Eq. 1-4; cli.md, "Figures")."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import (
    FIT_COLOUR,
    PAPER_STYLE,
    PHASE_COLOURS,
    new_figure,
)
from wifibot_power.stats import t_quantile

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from wifibot_power.fit import FitResult
    from wifibot_power.model import LinearFit

#: (column of the runs table, model attribute, title, paper equation)
PANELS = (
    ("accel_mean_power_W", "accel", "acceleration: P_acc(v)", "Eq. 1-2"),
    ("cruise_mean_power_W", "cruise", "cruise: P_v(v)", "Eq. 3-4"),
)


def mean_band(
    speed_mps: np.ndarray, power_W: np.ndarray, line: LinearFit, grid_mps: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """95% confidence band of the fitted line's mean at each speed of `grid_mps`: ordinary
    least squares over the runs (as `fit.fit_line`), `ŷ(v) ± t_{0.975, n-2} s
    sqrt(1/n + (v - v̄)² / S_vv)` (Montgomery & Runger, Eq. 11-31). NaN with < 3 runs."""
    x = np.asarray(speed_mps, dtype=np.float64)
    y = np.asarray(power_W, dtype=np.float64)
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    centre = line.intercept + line.slope * grid_mps
    if x.size < 3 or not math.isfinite(line.slope):
        return np.full_like(centre, np.nan), np.full_like(centre, np.nan)
    s_xx = float(np.sum((x - x.mean()) ** 2))
    s = math.sqrt(float(np.sum((y - line.intercept - line.slope * x) ** 2)) / (x.size - 2))
    leverage = 1 / x.size + (grid_mps - x.mean()) ** 2 / s_xx
    half = t_quantile(0.975, x.size - 2) * s * np.sqrt(leverage)
    return centre - half, centre + half


def power_speed_figure(result: FitResult) -> Figure:
    """Two panels, acceleration and cruise: a point per usable motion run (its phase's mean
    power [W] at its speed [m/s]), the fitted line with its 95% band, the paper's line."""
    figure = new_figure(11.0, 4.2)
    axes = figure.subplots(1, 2)
    runs = result.runs
    motion = runs[(runs["mode"] == "motion") & runs["usable"]]
    for ax, (column, attribute, title, equation) in zip(axes, PANELS, strict=True):
        _panel(
            ax,
            motion["speed_mps"].to_numpy(np.float64),
            motion[column].to_numpy(np.float64),
            getattr(result.model, attribute),
            getattr(result.paper, attribute),
            PHASE_COLOURS[attribute],
            f"{title}, paper {equation}",
        )
    return figure


def _panel(
    ax: Axes,
    speed: np.ndarray,
    power: np.ndarray,
    fit: LinearFit,
    paper: LinearFit,
    colour: str,
    title: str,
) -> None:
    finite = np.isfinite(speed) & np.isfinite(power)
    ax.plot(
        speed[finite],
        power[finite],
        "o",
        ms=4,
        mfc=colour,
        mec="#333333",
        mew=0.5,
        label=f"runs (n = {int(finite.sum())})",
        gid="runs",
    )
    top = max(1.0, float(np.nanmax(speed)) * 1.1) if finite.any() else 1.0
    grid = np.linspace(0.0, top, 200)
    if math.isfinite(fit.slope):
        low, high = mean_band(speed, power, fit, grid)
        sign = "−" if fit.slope < 0 else "+"  # "1.38 − 0.07 v", not "1.38 + -0.07 v"
        ax.fill_between(grid, low, high, color=FIT_COLOUR, alpha=0.25, lw=0, label="95% band")
        ax.plot(
            grid,
            fit.intercept + fit.slope * grid,
            color=FIT_COLOUR,
            lw=1.6,
            label=f"fit: {fit.intercept:.2f} {sign} {abs(fit.slope):.2f} v",
            gid="fit",
        )
    paper_W = paper.intercept + paper.slope * grid
    label = f"paper: {paper.intercept:g} + {paper.slope:g} v"
    # another robot's runs (a few W beside the Wifibot's 24-50 W) are squashed flat when the
    # paper's line sets the scale: the scale is then the runs' and the fit's, and the
    # legend says where the paper's line is
    shown = [power[finite]]
    if math.isfinite(fit.slope):
        shown.append(fit.intercept + fit.slope * grid)
    values = np.concatenate(shown) if finite.any() else np.zeros(0)
    if values.size:
        low_W, high_W = min(0.0, float(values.min())), float(values.max())
        span_W = max(high_W - low_W, 1.0)
        above = float(paper_W.min()) > high_W + 2 * span_W
        if above or float(paper_W.max()) < low_W - 2 * span_W:
            ax.set_ylim(low_W - 0.1 * span_W, high_W + 0.4 * span_W)
            label += f" (off this scale, {'above' if above else 'below'})"
    ax.plot(grid, paper_W, **PAPER_STYLE, label=label, gid="paper")
    ax.set_xlim(0.0, top)
    ax.set_xlabel("speed [m/s]")
    ax.set_ylabel("mean power [W]")
    ax.set_title(title, fontsize=10, loc="left")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
