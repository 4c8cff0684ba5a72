"""Start-up spikes of a motion run: an inrush or breakaway at the start of an acceleration
(causes.md `start_transient`), reported with the phases."""

from __future__ import annotations

import numpy as np

from wifibot_power.changepoint import median
from wifibot_power.phases import Spike
from wifibot_power.run import Run
from wifibot_power.segment.common import _line, _time_at
from wifibot_power.segment.search import _Step

#: A start-up spike holds at least this fraction of its acceleration's energy: an inrush
#: or breakaway worth reporting changes the phase's energy by more than the 1% that the
#: per-run energies are compared at (the simulator's start_transient: 20-40%).
SPIKE_MIN_FRACTION = 0.01


def _start_spikes(
    run: Run, y: np.ndarray, block: int, sigma_b: float, steps: list[_Step]
) -> list[Spike]:
    """Start-up transients: the first blocks of an acceleration that stand out above the
    line fitted to the rest of that acceleration."""
    spikes = []
    dt = run.sample_period_s
    for st in steps:
        seg = y[st.t0 : st.t1]
        if seg.size < 20:
            continue
        tail = seg[seg.size // 2 :]
        x = np.arange(seg.size, dtype=np.float64)
        slope, tail_intercept = _line(tail)
        intercept = tail_intercept - slope * (seg.size // 2)  # the line at x = 0
        excess = seg - (intercept + slope * x)
        # a spike starts at the first block: where that block stands within 6 sd of noise
        # (+ 0.5 W) of the line, it stands within the bar below whatever the tail's scatter
        # (the bar is at least that), so the tail's median is not taken (most steps)
        if not excess[0] > 6.0 * sigma_b + 0.5:
            continue
        # above the tail's own scatter, not only the analyser's: a ripple during the ramp
        # (sample_logs: 1 W) bends it, and a hump of the ripple at its start was taken for
        # a spike of 0.27 s (drawn in red on the README's trace figure)
        tail_scatter_W = 1.4826 * float(median(np.abs(excess[seg.size // 2 :])))
        out = excess > 6.0 * max(sigma_b, tail_scatter_W) + 0.5
        if not out[0]:
            continue
        n_out = int(np.argmin(out)) if not out.all() else out.size
        i0, i1 = st.t0 * block, (st.t0 + n_out) * block
        above_J = float(np.sum(excess[:n_out]) * block * dt)
        if above_J < SPIKE_MIN_FRACTION * float(np.sum(seg)) * block * dt:
            # a step of a fraction of a watt where the ramp starts (sample_logs: 0.01 J of a
            # 15 J acceleration) is no inrush: reported, it was drawn as a start-up spike
            continue
        spikes.append(
            Spike(
                t_start_s=_time_at(run, i0),
                duration_s=(i1 - i0) * dt,
                peak_W=float(run.power_W[i0:i1].max()),
                energy_above_level_J=above_J,
            )
        )
    return spikes
