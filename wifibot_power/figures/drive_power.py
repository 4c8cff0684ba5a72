"""The drive model's held-out power over time (cli.md, "Figures", the drive model): for a few
runs, each window's measured mean power and the power the drive model predicts for it when
identified without that run (`drive.traces.heldout_traces`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from wifibot_power.figures.style import FIT_COLOUR, POWER_COLOUR, new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from wifibot_power.drive.traces import HeldOutTrace


def drive_power_figure(traces: Sequence[HeldOutTrace]) -> Figure:
    """A panel per held-out run: measured mean power per window [W] (dark) and the held-out
    prediction (blue) against time [s]."""
    figure = new_figure(10.0, 2.4 * max(len(traces), 1) + 0.6)
    axes = figure.subplots(max(len(traces), 1), 1, squeeze=False)[:, 0]
    for ax, trace in zip(axes, traces, strict=False):
        ax.plot(trace.time_s, trace.measured_W, color=POWER_COLOUR, lw=1.0, label="measured")
        ax.plot(
            trace.time_s, trace.predicted_W, color=FIT_COLOUR, lw=1.0, label="predicted (held out)"
        )
        ax.set_title(f"{trace.run_id} ({trace.surface})", fontsize=9)
        ax.set_ylabel("power [W]")
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    figure.suptitle("Drive model: held-out runs' power, measured and predicted")
    return figure
