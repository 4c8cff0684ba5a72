"""What every named cause of shared/spec/causes.md provides: the `Cause` base class.

A cause is one module holding one subclass of `Cause` (its physics, its term in the
stacked regression, its evidence test, its consequence checks, its energy term for
`energy.trip_energy`, its injection for `simulate`, its plausible size range), registered
once in `wifibot_power.causes`. Everything else loops over the registry.

Importing this module loads numpy only (`wbpower energy` and `simulate` read the registry,
and must not pay for pandas or scipy); the tables passed in are pandas frames.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, ClassVar, Protocol

import numpy as np

from wifibot_power.traces import StepWindows, step_windows

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes

    from wifibot_power.energy import StepKinematics
    from wifibot_power.model import PowerModel
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

#: Significance level of every evidence test (strict: six causes are tested on every batch).
ALPHA = 1e-3
#: A consequence "must not be there" fails only when the data show it at this level, and one
#: that "must be there" passes only when they show it at this level.
CHECK_ALPHA = 1e-3
#: A "must not be there" structure fails a check only when it is also material: at least this
#: fraction of what the cause itself explains (phase means known to mW make 1% effects
#: significant in the lab; speed_quadratic's structure left, start_transient's per-metre part)
MATERIAL_FRACTION = 0.1

RUN_ENERGY = "run_energy"
POWER_TRACE = "power_trace"


@dataclass(frozen=True)
class Check:
    """One consequence of a cause's physics, tested on the runs (causes.md, cli.md `checks`)."""

    check: str
    passed: bool
    detail: str

    def as_dict(self) -> dict[str, object]:
        return {"check": self.check, "passed": bool(self.passed), "detail": self.detail}


@dataclass(frozen=True)
class Evidence:
    """What one evidence test found on a batch of runs."""

    cause: str
    testable: bool
    p_value: float = float("nan")
    estimate: float = float("nan")
    ci95: tuple[float, float] = (float("nan"), float("nan"))
    parameters: dict[str, float] = field(default_factory=dict)
    summary: str = ""

    @property
    def significant(self) -> bool:
        return self.testable and bool(np.isfinite(self.p_value)) and self.p_value < ALPHA

    @property
    def passes(self) -> bool:
        """Significant and at least the smallest size worth naming."""
        from wifibot_power.causes.registry import CAUSES

        return self.significant and self.estimate >= CAUSES[self.cause].min_size


class WindowEnergies(Protocol):
    """What `RunView.energy` is (`runtable.WindowEnergy`): energy [J] of windows of the run's
    samples, ``between(starts, ends)``, any windows at once (one pass over the samples)."""

    def between(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class RunView:
    """What a cause's per-run hooks (`Cause.run_stats`, `Cause.run_trace`) see of one
    segmented motion run, in the worker while its samples are in memory: the run, its
    segmentation, the energy of any windows of its samples (shared with the run's row), the
    windows of its steps (`traces.step_windows`, made once for every cause), and the energy
    of each window a cause asked for (`Cause.energy_windows`), by cause: all of them from
    one `energy.between`, whose sums depend on the set of edges it is given."""

    run: Run
    segmentation: Segmentation
    energy: WindowEnergies
    window_J: dict[str, np.ndarray] = field(default_factory=dict)
    #: what a cause's hooks share of this run (e.g. a spectrum both read), by cause
    memo: dict[str, object] = field(default_factory=dict)

    @cached_property
    def steps(self) -> StepWindows:
        return step_windows(self.segmentation, self.run.samples)

    def windows_of(self, cause: Cause) -> tuple[list[int], list[int]]:
        """The windows `cause` asks for (`Cause.energy_windows`), made once per run."""
        key = f"{cause.name}:windows"
        if key not in self.memo:
            self.memo[key] = cause.energy_windows(self) or ([], [])
        return self.memo[key]  # type: ignore[return-value]

    def window_energies_J(self, cause: Cause) -> np.ndarray:
        """The energies [J] of the windows `cause` asked for (`Cause.energy_windows`): as
        summed with every cause's (`registry.run_statistics`), or alone."""
        if cause.name not in self.window_J:
            starts, ends = self.windows_of(cause)
            self.window_J[cause.name] = self.energy.between(starts, ends) if starts else np.zeros(0)
        return self.window_J[cause.name]


@dataclass(frozen=True, eq=False)
class PanelView:
    """What a cause's figure panels (`Cause.panels`) draw from: the diagnosis's per-run
    table (`Diagnosis.runs`, with the cause's `table_columns`), the finding's estimate
    (`Finding.estimate`), the title every finding's panel carries, this cause's per-run
    trace data (`Cause.run_trace`, by run_id) and the figures' colours by phase."""

    runs: pd.DataFrame
    estimate: Mapping[str, object]
    title: str
    traces: Mapping[str, object]
    colours: Mapping[str, str]


@dataclass(frozen=True, eq=False)
class RunTable:
    """What every evidence test and check is given: the usable motion runs (one row each:
    `runtable.run_row` columns, each cause's `run_stats` and `session_columns`), the model
    fitted with the causes already found, and those causes' names."""

    runs: pd.DataFrame
    model: PowerModel
    given: tuple[str, ...] = ()


@dataclass(frozen=True)
class TripTerms:
    """What a cause's energy term sees of one trip (`energy.trip_energy`)."""

    model: PowerModel
    step: StepKinematics
    steps: int
    payload_kg: float
    #: motor-on minutes accumulated in the session before the trip (0: from cold)
    motor_on_before_min: float
    #: energy above idle of the phase-power terms so far, and the trip's motor-on time
    motion_above_idle_J: float = 0.0
    motion_time_s: float = 0.0


@dataclass(eq=False)
class SimTrace:
    """A simulated motion run being built (`simulate`), for a cause to add its power to.

    Arrays are per sample; `kind` is 0 idle, 1 accel, 2 cruise, 3 decel; `plan` lists the
    phases as (phase, step, n_samples, v_start, v_end) starting at `bounds[:-1]`."""

    motion_W: np.ndarray
    speed_mps: np.ndarray
    accel_mps2: np.ndarray
    kind: np.ndarray
    plan: list[tuple[str, int, int, float, float]]
    bounds: np.ndarray
    dt_s: float
    target_speed_mps: float
    payload_kg: float
    motor_on_before_min: float
    robot: object
    rng: np.random.Generator

    @property
    def moving(self) -> np.ndarray:
        return self.kind > 0


class Cause:
    """Base class of a named cause. Subclasses set the class attributes and override the
    hooks their physics needs; the defaults add nothing.

    Fitting (`diagnose.extended.fit_model`) runs in three stages, given by `fit_stage`:
    ``"scale"`` causes multiply motion power above idle (`power_factor`) and are estimated
    first; ``"column"`` causes are linear in their parameter and enter the one stacked
    least-squares fit of the acceleration and cruise means (`power_terms`,
    `lump_J_per_step`); ``"after"`` causes are estimated from their own phases or spectra
    once the lines are known (`estimate`).

    Energy (`energy.trip_energy`) adds terms in three stages, given by `energy_stage`:
    ``"power"`` terms are part of the phase power (counted in the energy above idle),
    ``"lump"`` terms are fixed energies, ``"scale"`` terms act on the energy above idle.
    """

    #: the name in causes.md
    name: ClassVar[str]
    physics: ClassVar[str]
    #: the form added to the model (causes.md)
    term: ClassVar[str]
    #: unit of the headline parameter (the SIZE of `simulate --effect`)
    unit: ClassVar[str]
    #: headline parameter key in `model.extensions[name]`
    parameter: ClassVar[str]
    #: every key of `model.extensions[name]` that the energy term reads
    parameters: ClassVar[tuple[str, ...]]
    metric: ClassVar[str] = RUN_ENERGY
    #: smallest size worth naming (below it, a note)
    min_size: ClassVar[float]
    #: physically plausible range of the headline parameter; why: the class docstring
    plausible: ClassVar[tuple[float, float]]
    #: the signature, in words (causes.md)
    signature: ClassVar[str]
    #: simulate: SIZE when only the name is given, and the realistic range tests draw from
    default_size: ClassVar[float]
    realistic_range: ClassVar[tuple[float, float]]
    #: simulate: payloads the default grid needs for the effect to be visible (None: any)
    grid_payloads_kg: ClassVar[tuple[float, ...] | None] = None
    #: covariates of the run table along which its own physics puts what it explains, so
    #: the spread check (`causes.spread`) does not hold them against it (accel_inertial: the
    #: payload, whose inertia it is)
    own_patterns: ClassVar[tuple[str, ...]] = ()
    fit_stage: ClassVar[str] = "after"
    energy_stage: ClassVar[str] = "lump"
    #: the name of the trip phase its energy is reported as
    energy_phase: ClassVar[str | None] = None
    #: simulate: the order effects are applied in (multiplicative ones last)
    inject_order: ClassVar[int] = 0

    #: every column its `run_stats` and `session_columns` add to the run table: its own
    #: fields, which nothing outside causes/ names (tests/test_architecture.py)
    columns: ClassVar[tuple[str, ...]] = ()
    #: the columns of `run_stats` and `session_columns` kept in the diagnosis's per-run
    #: table (`Diagnosis.runs`, discrepancy.parquet): what its figure panels read
    table_columns: ClassVar[tuple[str, ...]] = ()

    # -- per-run statistics --------------------------------------------------------------
    def energy_windows(self, view: RunView) -> tuple[list[int], list[int]] | None:
        """Windows of the run's samples (start and end indices) whose energies `run_stats`
        reads (``view.window_energies_J(self)``; the windows: ``view.windows_of(self)``), or
        None."""
        del view
        return None

    def run_stats(self, view: RunView) -> dict[str, float]:
        """Per-run statistics this cause's tests need (columns of the run table), computed in
        the worker while the run's samples are in memory (`diagnose.summarize_run`), for
        motion runs; vectorised over samples. Runs of other modes have none (NaN)."""
        del view
        return {}

    def run_trace(self, view: RunView) -> object | None:
        """Per-run trace data its trace metric (`heldout_trace_gain_pct`) and its figure
        panels need beyond the table's numbers (picklable, small: e.g. block means of a
        cruise), or None."""
        del view
        return None

    def session_columns(self, runs: pd.DataFrame) -> dict[str, np.ndarray]:
        """Covariates of each run that depend on the batch (e.g. a session clock), added as
        columns of the run table (`runs`: every run, with `session_order`, the run's place
        among the timed runs by `started_at`, -1 when it has none)."""
        del runs
        return {}

    def trip_inputs(self, runs: pd.DataFrame) -> dict[str, np.ndarray]:
        """Keyword arguments of `energy.trip_energy` this cause's energy term reads from each
        run when the model simulates it (arrays, a value per run of `runs`)."""
        del runs
        return {}

    # -- fitting -------------------------------------------------------------------------
    def power_terms(self, runs: pd.DataFrame, value: float) -> dict[str, np.ndarray]:
        """("column" causes) Added modelled power per run: during acceleration as a
        polynomial in u = t / t_acc (``ramp0 + ramp1 u + ramp2 u²``) and in cruise
        (``cruise``) [W], for the parameter `value`."""
        del runs, value
        return {}

    def lump_J_per_step(self, runs: pd.DataFrame, value: float) -> np.ndarray | None:
        """("column" causes) A fixed energy per step [J] the parameter `value` adds."""
        del runs, value
        return None

    #: ("column" causes with a lump) How long after each acceleration starts the lump may
    #: still be spent [s]: a run whose acceleration is shorter holds part of it in its cruise
    #: (`design.stacked_design`).
    lump_within_s: ClassVar[float] = 0.0

    def power_factor(self, runs: pd.DataFrame, params: dict[str, float]) -> np.ndarray | None:
        """("scale" causes) Per-run factor on the mean motion power above idle."""
        del runs, params
        return None

    def estimate(
        self, runs: pd.DataFrame, coef: dict[str, float], model: PowerModel
    ) -> dict[str, float] | None:
        """The extension parameters of this cause on `runs` (usable motion runs), given the
        stacked fit's coefficients `coef` and the model so far; None: nothing to add.
        A "column" cause's parameter is its coefficient."""
        del runs, model
        if self.fit_stage == "column":
            return {self.parameter: float(coef[self.parameter])}
        return None

    def identifiable(self, runs: pd.DataFrame) -> str | None:
        """Why this cause's parameters cannot be estimated from `runs`, or None. A fold whose
        training runs cannot identify a cause gives "not estimable", never a number."""
        del runs
        return None

    # -- naming --------------------------------------------------------------------------
    def evidence(self, table: RunTable) -> Evidence:
        """Its signature, tested on top of `table.model` (fitted with `table.given`)."""
        raise NotImplementedError

    def checks(self, table: RunTable, evidence: Evidence) -> list[Check]:
        """Every consequence its physics implies (causes.md), plus the plausible size."""
        return [self.plausible_check(evidence)]

    def plausible_check(self, evidence: Evidence) -> Check:
        low, high = self.plausible
        value = evidence.estimate
        ok = bool(np.isfinite(value) and low <= value <= high)
        return Check(
            "plausible size",
            ok,
            f"{self.parameter} = {value:.3g} {self.unit}, plausible {low:g} to {high:g} "
            f"({'inside' if ok else 'outside'})",
        )

    def heldout_trace_gain_pct(
        self, runs: pd.DataFrame, folds: np.ndarray, traces: Mapping[str, object]
    ) -> float:
        """("power_trace" causes) Held-out gain on the power trace [%]; `traces`: run_id ->
        the run's `run_trace`."""
        raise NotImplementedError

    def heldout_trace_errors(
        self, runs: pd.DataFrame, folds: np.ndarray, traces: Mapping[str, object]
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """("power_trace" causes, optional) Each run's summed squared held-out trace error
        without and with the cause (arrays in the order of `runs`), whose sums give
        `heldout_trace_gain_pct`: what the gain's interval resamples (diagnose). None: not
        broken down by run (the interval is then over fold deals alone)."""
        del runs, folds, traces
        return None

    # -- figures -------------------------------------------------------------------------
    def panels(self, view: PanelView) -> list[Callable[[Axes], None]] | None:
        """The panels of the findings figure that show this cause's evidence, each drawing
        on the axes it is given; None: the figure's default panel for an energy cause
        (`figures.diagnosis`)."""
        del view
        return None

    # -- energy --------------------------------------------------------------------------
    def stop_time_s(self, params: dict[str, float]) -> float:
        """Time the robot takes to stop at the end of each step [s] (kinematics)."""
        del params
        return 0.0

    def energy_J(self, params: dict[str, float], trip: TripTerms) -> tuple[float, float] | None:
        """(time [s], energy [J]) this term adds to the whole trip, or None."""
        del params, trip
        return None

    # -- simulation ----------------------------------------------------------------------
    def inject(self, size: float, trace: SimTrace) -> dict[str, object]:
        """Add this effect of SIZE `size` to `trace.motion_W` (in place); truth entries."""
        del size, trace
        return {}

    def sim_parameters(self, size: float) -> dict[str, float]:
        """The extension parameters a simulated effect of SIZE `size` stands for (as far as
        SIZE fixes them)."""
        return {self.parameter: float(size)}
