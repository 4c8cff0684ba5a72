"""wbpower: energy models of a mobile robot from power-analyser logs, and where they go wrong.

The same results as the command line, from a notebook (docs/api.md)::

    import wifibot_power as wb
    result = wb.fit_logs(["sample_logs"])          # wbpower fit sample_logs/
    result.summary()["cruise"]
    diagnosis = wb.diagnose_logs(["sample_logs"])  # wbpower diagnose sample_logs/
    wb.trip_energy(result.model, 0.8, 10.0, 10).energy_J

Every name below loads its module on first use, so `wbpower --help` and the readers stay
quick to import; `dir(wifibot_power)` lists them all.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: name -> the module that defines it (loaded on first use)
_EXPORTS = {
    # reading
    "read_log": "wifibot_power.io",
    "ReadOptions": "wifibot_power.io",
    "Run": "wifibot_power.run",
    # segmenting
    "segment_run": "wifibot_power.segment",
    "Segmentation": "wifibot_power.phases",
    # fitting: logs, runs in memory, a per-run table
    "fit_logs": "wifibot_power.fit",
    "fit_runs": "wifibot_power.fit",
    "fit_table": "wifibot_power.fit",
    "write_fit": "wifibot_power.fit",
    "FitResult": "wifibot_power.fit",
    "FAMILIES": "wifibot_power.models",
    "ModelFamily": "wifibot_power.models",
    "FittedModel": "wifibot_power.models",
    # the models and what they predict
    "PowerModel": "wifibot_power.model",
    "load_model": "wifibot_power.model",
    "paper_model": "wifibot_power.model",
    "trip_energy": "wifibot_power.energy",
    "energy_report": "wifibot_power.energy",
    "network_lifetime": "wifibot_power.lifetime",
    # diagnosing
    "diagnose_logs": "wifibot_power.diagnose",
    "diagnose_runs": "wifibot_power.diagnose",
    # reporting and figures
    "build_report": "wifibot_power.report",
    "write_report": "wifibot_power.report",
    "FIGURES": "wifibot_power.figures",
    # simulating
    "simulate_runs": "wifibot_power.simulate",
    "SimConfig": "wifibot_power.simulate",
    # the per-run records every command is made of
    "gather": "wifibot_power.pipeline",
    "RunRecord": "wifibot_power.pipeline",
}

__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:  # pragma: no cover
    from wifibot_power.diagnose import diagnose_logs, diagnose_runs  # noqa: F401
    from wifibot_power.energy import energy_report, trip_energy  # noqa: F401
    from wifibot_power.figures import FIGURES  # noqa: F401
    from wifibot_power.fit import FitResult, fit_logs, fit_runs, fit_table, write_fit  # noqa: F401
    from wifibot_power.io import ReadOptions, read_log  # noqa: F401
    from wifibot_power.lifetime import network_lifetime  # noqa: F401
    from wifibot_power.model import PowerModel, load_model, paper_model  # noqa: F401
    from wifibot_power.models import FAMILIES, FittedModel, ModelFamily  # noqa: F401
    from wifibot_power.phases import Segmentation  # noqa: F401
    from wifibot_power.pipeline import RunRecord, gather  # noqa: F401
    from wifibot_power.report import build_report, write_report  # noqa: F401
    from wifibot_power.run import Run  # noqa: F401
    from wifibot_power.segment import segment_run  # noqa: F401
    from wifibot_power.simulate import SimConfig, simulate_runs  # noqa: F401


def __getattr__(name: str) -> object:
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'wifibot_power' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The public API (`__all__`) and the module's dunder names (`__version__`): what a
    notebook's completion and `dir(wifibot_power)` show, without importing any of it."""
    return sorted({*__all__, *(name for name in globals() if name.startswith("__"))})
