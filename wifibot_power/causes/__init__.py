"""The named causes of shared/spec/causes.md, one module each, and their registry.

Each cause is a `Cause` subclass (`base.py`) holding its physics, its term in the stacked
regression, its evidence test (one signature: ``evidence(table: RunTable) -> Evidence``),
its consequence checks, its energy term for `energy.trip_energy`, its injection for
`simulate`, and its plausible size range with the reasoning; and everything of its own that
the diagnosis carries: its per-run statistics and trace data, made in the worker
(`run_stats`, `energy_windows`, `run_trace`, over a `RunView`; `run_statistics` runs them
all), its covariates over the batch (`session_columns`, `trip_inputs`), its trace metric and
its figure panels (`panels`). `CAUSES` below is the only
list of them: fitting, energy, simulation, selection and reporting loop over it and never
name a cause. To add a cause: one module here, one line below, one row in causes.md, and
its tests (docs/diagnose.md, "Adding a cause"); `register`/`registered` add one from
outside the package (e.g. a test's toy cause).

The extended model (`fit_model`, `predict_motion_energy_J`) is in `diagnose.extended`, which
loads the fitting code; importing this package loads numpy only.
"""

from __future__ import annotations

from wifibot_power.causes.accel_inertial import AccelInertial
from wifibot_power.causes.base import (
    ALPHA,
    CHECK_ALPHA,
    POWER_TRACE,
    RUN_ENERGY,
    Cause,
    Check,
    Evidence,
    PanelView,
    RunTable,
    RunView,
    SimTrace,
    TripTerms,
)
from wifibot_power.causes.cruise_ripple import CruiseRipple
from wifibot_power.causes.decel_phase import DecelPhase
from wifibot_power.causes.registry import (
    CAUSES,
    ordered,
    register,
    registered,
    run_statistics,
    unregister,
)
from wifibot_power.causes.speed_quadratic import SpeedQuadratic
from wifibot_power.causes.start_transient import StartTransient
from wifibot_power.causes.thermal_drift import ThermalDrift

CAUSES.update(
    {
        c.name: c
        for c in (
            SpeedQuadratic(),
            StartTransient(),
            DecelPhase(),
            AccelInertial(),
            ThermalDrift(),
            CruiseRipple(),
        )
    }
)


__all__ = [
    "ALPHA",
    "CAUSES",
    "CHECK_ALPHA",
    "POWER_TRACE",
    "RUN_ENERGY",
    "Cause",
    "Check",
    "Evidence",
    "PanelView",
    "RunTable",
    "RunView",
    "SimTrace",
    "TripTerms",
    "ordered",
    "register",
    "registered",
    "run_statistics",
    "unregister",
]
