"""The report's interactive trace view (docs/report.md, "Exploring the runs"): every run's
power envelope embedded in report.html as compact arrays, drawn on a canvas by a small
script of our own (`explorer.js`, beside this module): zoom, pan, and a selection's
duration, energy and mean power, offline, nothing fetched.

What is embedded per run is its `TraceView`: the min/max envelope of its power per column
(`trace.COLUMNS` columns; the same envelope the trace figure draws), each column's energy,
its phases and start-up spikes. A selection's energy is the cumulative energy at the
column edges (`TraceView.energy_edges_J`: the exact rectangle-rule sums of the samples,
paper Eq. 1's integral as `Run.energy_J`) interpolated inside the two columns the
selection's ends fall in; the page shows the bound on that interpolation, each end's
partial column's duration times its max - min power. A selection from column edge to
column edge (the whole run, or a phase) has its exact energy.

Sizes: the display envelope is quantised to 16 bits over the run's power range (a step of
range/65 535: 0.6 mW on a 40 W range); column times and energies are float32 (a run's
total is summed in float64 by the page: relative error < 1e-7).
"""

from __future__ import annotations

import base64
import json
from collections.abc import Mapping, Sequence
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.figures.style import PHASE_COLOURS, POWER_COLOUR, SPEED_COLOUR

if TYPE_CHECKING:
    from wifibot_power.figures.trace import Envelope, TraceView

#: the largest value of the 16-bit codes of the display envelope
QUANTA = 65535


def _b64(values: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(values, dtype=dtype).tobytes()).decode("ascii")


def _quantised(envelope: Envelope) -> dict[str, object]:
    """The envelope's low and high as 16-bit codes over [lowest, highest] (`v = v0 + code *
    dv`), little-endian as the browser's typed arrays read them."""
    low = np.asarray(envelope.low, np.float64)
    high = np.asarray(envelope.high, np.float64)
    finite = np.isfinite(low) & np.isfinite(high)
    v0 = float(low[finite].min()) if finite.any() else 0.0
    top = float(high[finite].max()) if finite.any() else 1.0
    dv = (top - v0) / QUANTA or 1.0

    def codes(v: np.ndarray, rounding: np.ufunc) -> np.ndarray:
        # low rounded down and high up: the band drawn holds every sample
        return np.clip(rounding((np.where(finite, v, v0) - v0) / dv), 0, QUANTA)

    return {
        "v0": v0,
        "dv": dv,
        "lo": _b64(codes(low, np.floor), "<u2"),
        "hi": _b64(codes(high, np.ceil), "<u2"),
    }


def run_data(view: TraceView, anchor: str) -> dict[str, object]:
    """One run's embedded data (module docstring), JSON-safe; `anchor`: its id in the page."""
    power = view.power
    edges_t = np.append(np.asarray(power.time_s, np.float64), view.t_end_s or view.duration_s)
    edges_J = view.energy_edges_J
    column_J = np.diff(edges_J) if edges_J is not None else np.zeros(power.time_s.size)
    data: dict[str, object] = {
        "id": view.run_id,
        "anchor": anchor,
        "mode": view.mode,
        "samples": view.samples,
        "t": _b64(edges_t, "<f4"),
        "e": _b64(column_J, "<f4"),
        "p": _quantised(power),
        "phases": [
            [p.phase, p.step, *map(_num, (p.t_start_s, p.t_end_s, p.mean_power_W))]
            for p in view.phases
        ],
        "spikes": [[_num(s.t_start_s), _num(s.peak_W)] for s in view.spikes],
        "doubts": list(view.doubts),
    }
    if view.speed is not None:
        data["v"] = _quantised(view.speed)
    return data


def explorer_script() -> str:
    """The page's script (`explorer.js`), inlined as it is."""
    return resources.files("wifibot_power.figures").joinpath("explorer.js").read_text("utf-8")


def explorer_data(views: Sequence[TraceView], anchors: Mapping[str, str]) -> str:
    """Every run's data and the colours, as the JSON the script reads (a `<script
    type="application/json">` block: `</` is escaped so no value can close it)."""
    motion = [k for k, v in enumerate(views) if v.mode == "motion"]
    document = {
        "colours": {**PHASE_COLOURS, "power": POWER_COLOUR, "speed": SPEED_COLOUR},
        "runs": [run_data(v, anchors[v.run_id]) for v in views],
        # the run shown first: the first that moves (its phases say most), else the first
        "first": motion[0] if motion else 0,
    }
    text = json.dumps(document, separators=(",", ":"), allow_nan=False)
    return text.replace("</", "<\\/")


def _num(value: float) -> float | None:
    """A number for JSON: None where it is not finite."""
    return float(value) if np.isfinite(value) else None
