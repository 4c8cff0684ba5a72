"""wbpower: energy models of a mobile robot from power-analyser logs, and where they go wrong.

The same results as the command line, from a notebook::

    import wifibot_power as wb
    result = wb.fit_logs(["sample_logs"])          # wbpower fit sample_logs/
    result.summary()["cruise"]
    diagnosis = wb.diagnose_logs(["sample_logs"])  # wbpower diagnose sample_logs/
    wb.trip_energy(result.model, 0.8, 10.0, 10).energy_J
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.1.0"

# Loaded on first use, so `wbpower --help` and the readers stay quick to import.
_EXPORTS = {
    "read_log": "wifibot_power.io",
    "ReadOptions": "wifibot_power.io",
    "fit_logs": "wifibot_power.fit",
    "FitResult": "wifibot_power.fit",
    "segment_run": "wifibot_power.segment",
    "trip_energy": "wifibot_power.energy",
    "network_lifetime": "wifibot_power.lifetime",
    "diagnose_logs": "wifibot_power.diagnose",
    "diagnose_runs": "wifibot_power.diagnose",
    "simulate_runs": "wifibot_power.simulate",
    "SimConfig": "wifibot_power.simulate",
    "load_model": "wifibot_power.model",
    "paper_model": "wifibot_power.model",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:  # pragma: no cover
    from wifibot_power.diagnose import diagnose_logs, diagnose_runs  # noqa: F401
    from wifibot_power.energy import trip_energy  # noqa: F401
    from wifibot_power.fit import FitResult, fit_logs  # noqa: F401
    from wifibot_power.io import ReadOptions, read_log  # noqa: F401
    from wifibot_power.lifetime import network_lifetime  # noqa: F401
    from wifibot_power.model import load_model, paper_model  # noqa: F401
    from wifibot_power.segment import segment_run  # noqa: F401
    from wifibot_power.simulate import SimConfig, simulate_runs  # noqa: F401


def __getattr__(name: str) -> object:
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'wifibot_power' has no attribute {name!r}")
