"""The drive model's held-out run energies (cli.md, "Figures", the drive model): each run held
out of the fit (K-fold by run or trip, drive/heldout.py), its predicted energy against the
measured one with the 90% prediction interval, and the line where they are equal."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import PAPER_STYLE, new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from wifibot_power.drive.model import DriveModel

#: One colour per surface, in the order the model names them (Okabe-Ito).
SURFACE_COLOURS = ("#0072b2", "#e69f00", "#009e73", "#cc79a7", "#56b4e9", "#d55e00")


def drive_energy_figure(model: DriveModel) -> Figure:
    """Predicted [J] against measured [J] energy of each held-out run, the 90% interval as a
    vertical bar, a colour per surface; the dashed line is predicted = measured. The title
    gives MAPE, median error and how many intervals hold the measured energy."""
    figure = new_figure(6.0, 5.0)
    ax = figure.subplots()
    held = model.heldout
    if held is None or not held.runs:
        ax.text(0.5, 0.5, "no held-out accuracy (fewer than 4 trips)", ha="center")
    else:
        surfaces = sorted({r.surface for r in held.runs})
        for k, surface in enumerate(surfaces):
            rows = [r for r in held.runs if r.surface == surface]
            measured = np.array([r.measured_J for r in rows])
            predicted = np.array([r.predicted_J for r in rows])
            low = np.array([r.pi90_J[0] for r in rows], dtype=np.float64)
            high = np.array([r.pi90_J[1] for r in rows], dtype=np.float64)
            ax.errorbar(
                measured,
                predicted,
                yerr=np.vstack([predicted - low, high - predicted]),
                fmt="o",
                ms=4,
                capsize=2,
                color=SURFACE_COLOURS[k % len(SURFACE_COLOURS)],
                label=surface,
            )
        every = [r.measured_J for r in held.runs] + [r.predicted_J for r in held.runs]
        span = np.array([min(every), max(every)])
        ax.plot(span, span, **PAPER_STYLE, label="predicted = measured")
        ax.legend(fontsize=8)
        ax.set_title(
            f"MAPE {held.mape_pct:.1f}%, median {held.median_ape_pct:.1f}%, "
            f"{held.coverage_pi90_pct:.0f}% in the 90% interval",
            fontsize=9,
        )
    ax.set_xlabel("measured energy [J]")
    ax.set_ylabel("predicted energy, held out [J]")
    figure.suptitle("Drive model: held-out run energy, predicted against measured")
    return figure
