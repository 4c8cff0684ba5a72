"""The drive model's terms per surface (cli.md, "Figures", the drive model): a panel per term
(each has its own unit), a point per surface with its 95% interval; a term shared by every
surface is one point, "all"."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from wifibot_power.figures.style import FIT_COLOUR, new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from wifibot_power.drive.model import DriveModel, TermValue


def drive_terms_figure(model: DriveModel) -> Figure:
    """A panel per fitted term: its value at each surface ("all" for a shared term) with the
    95% interval as a bar; the y axis says the term and its unit."""
    named: dict[str, dict[str, TermValue]] = {n: {"all": t} for n, t in model.terms.items()}
    for surface, terms in model.surfaces.items():
        for name, term in terms.items():
            named.setdefault(name, {})[surface] = term
    columns = min(len(named), 3) or 1
    rows = math.ceil(len(named) / columns) or 1
    figure = new_figure(3.6 * columns, 2.8 * rows)
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    for ax, (name, by_surface) in zip(axes, named.items(), strict=False):
        labels = list(by_surface)
        values = [by_surface[s].value for s in labels]
        low = [v - _finite(by_surface[s].ci95[0], v) for s, v in zip(labels, values, strict=True)]
        high = [_finite(by_surface[s].ci95[1], v) - v for s, v in zip(labels, values, strict=True)]
        ax.errorbar(labels, values, yerr=[low, high], fmt="o", capsize=3, color=FIT_COLOUR)
        unit = next(iter(by_surface.values())).unit
        ax.set_ylabel(f"{name} [{unit}]", fontsize=8)
        ax.set_xlabel("surface", fontsize=8)
    for ax in axes[len(named) :]:
        ax.set_visible(False)
    # one panel is 3.6 in wide: the title on two lines there (on one it was cut at both ends)
    wrap = "\n" if columns < 2 else " "
    from wifibot_power.drive.model import lag_said  # not at the figure registry's import

    lag = lag_said(model.lag_s, model.lag_ci95_s, model.not_determined, short=True)
    figure.suptitle(f"Drive model terms with 95% intervals{wrap}(lag {lag})")
    return figure


def _finite(bound: float, value: float) -> float:
    """An interval bound, or the value itself where the interval could not be made."""
    return bound if math.isfinite(bound) else value
