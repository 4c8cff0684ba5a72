"""Fit the paper's power models over runs: what `wbpower fit` computes.

One point per run (the per-run table of `wifibot_power.runtable`), ordinary least squares:

- acceleration power `P_acc(v) = a0 + a1 v` [W] (paper Eq. 1-2; paper: 23.9 + 14.8 v),
- cruise power `P_v(v) = c0 + c1 v` [W] (paper Eq. 3-4; paper: 23.9 + 11.2 v),
- acceleration time `t_acc(v) = t0 + t1 v` [s] (used by paper Eq. 5-6),
- idle power [W] (paper: 23.3 W): mean of idle-mode runs, else of the idle phases of
  motion runs (`idle_source` says which),
- component powers net of idle [W] (paper Table 1: network 4.4, video 2.5, CPU 2.1):
  mean power of the mode's runs minus idle power.

Intervals are the regression's own 95% t intervals with runs as the unit
(`t_{0.975, n-2} * standard error`), see docs/fit.md.

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.cache import MISSING, ParseCache, ResultMemo, code_digest
from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.io import LogSource, ReadOptions, Skipped
from wifibot_power.io.batch import ProblemHook, map_runs
from wifibot_power.io.discover import reasons_in_brief
from wifibot_power.model import LinearFit, PowerModel, paper_model
from wifibot_power.outputs import json_file, json_safe, parquet_file, write_set
from wifibot_power.overhead import StopAndGo, stop_and_go_overheads
from wifibot_power.run import MODES, Run

if TYPE_CHECKING:  # pandas (~0.4 s to import) loads only when a table is asked for
    # numpy (~0.1 s) and the numerics load when something is fitted: a warm `fit --cache`
    # whose runs are all unchanged takes the fit from the cache (`_FitMemo`) and needs none
    import numpy as np
    import pandas as pd

    from wifibot_power.phases import Segmentation

Segmenter = Callable[[Run], "Segmentation"]
NAN_PAIR = (float("nan"), float("nan"))
#: Modes whose runs measure one component with the robot standing (paper Table 1): every run
#: mode but motion, idle and unknown. Derived from `run.MODES` (as `runtable.COMPONENT_MODES`
#: is, in the same order; a test checks) so that fitting needs no pandas.
COMPONENT_MODES = tuple(m for m in MODES if m not in ("motion", "idle", "unknown"))
#: A per-run row as `runtable.run_row` makes it (or a record of `runtable.runs_frame`).
Row = Mapping[str, object]


def fit_line(speed_mps: np.ndarray, values: np.ndarray) -> LinearFit:
    """Ordinary least squares `y = intercept + slope * v` with 95% t intervals and R², by
    `stats.ols` (the least squares every fit and cause uses).

    Standard simple linear regression (e.g. Montgomery & Runger, Applied Statistics,
    Eq. 11-7/11-8 and §11-5): slope = S_xy / S_xx, intercept = ȳ - slope x̄,
    s² = SSE / (n - 2), se(slope) = s / sqrt(S_xx),
    se(intercept) = s sqrt(1/n + x̄² / S_xx), CI = estimate ± t_{0.975, n-2} se.
    Non-finite points are dropped. Fewer than 2 distinct speed levels (`speed_levels`:
    speeds closer than their resolution are one level), or a rank-deficient or
    ill-conditioned design: NaN line, never a slope drawn through float noise. Exactly 2
    points: the line through them, NaN intervals and R² (no degrees of freedom left).
    """
    import numpy as np

    from wifibot_power.stats import ols

    x = np.asarray(speed_mps, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    n = int(x.size)
    if n < 2 or len(speed_levels(x)) < 2:
        return LinearFit(float("nan"), float("nan"), n_runs=n)
    line = ols(np.column_stack([np.ones(n), x]), y)  # the one least-squares path
    if line.rank < 2 or not line.condition < 1e8:  # `OLS.estimable` but for the dof
        return LinearFit(float("nan"), float("nan"), n_runs=n)
    intercept, slope = float(line.coef[0]), float(line.coef[1])
    return LinearFit(
        intercept=intercept,
        slope=slope,
        intercept_ci95=line.ci95(0),
        slope_ci95=line.ci95(1),
        r2=line.r2,
        n_runs=n,
    )


@dataclass(frozen=True)
class MeanEstimate:
    """A mean over runs [W] with its 95% t interval (NaN interval with one run)."""

    value_W: float
    ci95: tuple[float, float]
    n_runs: int
    se_W: float = float("nan")

    @classmethod
    def of(cls, values_W: np.ndarray) -> MeanEstimate:
        """Sample mean and `mean ± t_{0.975, n-1} s / sqrt(n)` (Student's t interval)."""
        import numpy as np

        from wifibot_power.stats import t_quantile

        values = np.asarray(values_W, dtype=np.float64)
        values = values[np.isfinite(values)]
        n = int(values.size)
        if n == 0:
            return cls(float("nan"), NAN_PAIR, 0)
        mean = float(values.mean())
        if n == 1:
            return cls(mean, NAN_PAIR, 1)
        se = float(values.std(ddof=1) / math.sqrt(n))
        t = float(t_quantile(0.975, n - 1))
        return cls(mean, (mean - t * se, mean + t * se), n, se)


def net_of_idle(mode: MeanEstimate, idle: MeanEstimate) -> MeanEstimate:
    """Component power net of idle: `P_mode - P_idle` [W] (paper Table 1).

    Interval by Welch's t: se = sqrt(se_mode² + se_idle²), degrees of freedom by the
    Welch-Satterthwaite equation; NaN when either side has a single run.
    """
    from wifibot_power.stats import t_quantile

    value = mode.value_W - idle.value_W
    if not (mode.n_runs >= 2 and idle.n_runs >= 2):
        return MeanEstimate(value, NAN_PAIR, mode.n_runs)
    var_mode, var_idle = mode.se_W**2, idle.se_W**2
    se = math.sqrt(var_mode + var_idle)
    if se == 0:
        return MeanEstimate(value, (value, value), mode.n_runs, 0.0)
    dof = (var_mode + var_idle) ** 2 / (
        var_mode**2 / (mode.n_runs - 1) + var_idle**2 / (idle.n_runs - 1)
    )
    t = float(t_quantile(0.975, dof))
    return MeanEstimate(value, (value - t * se, value + t * se), mode.n_runs, se)


@dataclass(frozen=True, eq=False)
class FitResult:
    """What `fit` found: the model, its uncertainty, the tables and what was left out.

    `runs` holds a row per readable run (`usable` says whether the fit used it), `phases`
    a row per phase (phases.parquet): pandas tables, made by `tables` when first asked for
    (a command that only prints the model, e.g. a warm `fit --cache --json`, never loads
    pandas). `skipped` lists unreadable and unusable inputs.
    """

    model: PowerModel
    idle: MeanEstimate
    idle_source: str
    components: dict[str, MeanEstimate | None]
    #: runs the fit used
    n_runs: int
    #: makes `(runs, phases)`
    tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]] = field(repr=False)
    skipped: tuple[Skipped, ...] = ()
    notes: tuple[str, ...] = ()
    paper: PowerModel = field(default_factory=paper_model)
    #: the measured stop-and-go overhead of every trip held in 1 and N > 1 steps, beside the
    #: model's (`overhead.stop_and_go_overheads`)
    stop_and_go: tuple[StopAndGo, ...] = ()
    #: why the fitted model is physically implausible or weakly determined (cli.md
    #: `fit --json` `warnings`; `fit_warnings`)
    warnings: tuple[str, ...] = ()

    @functools.cached_property
    def _frames(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        return self.tables()

    @property
    def runs(self) -> pd.DataFrame:
        """A row per readable run (runs.parquet, `runtable.runs_frame`)."""
        return self._frames[0]

    @property
    def phases(self) -> pd.DataFrame:
        """A row per phase of every run (phases.parquet: `Segmentation.frame`'s columns, and
        the run's `file` after its `run_id`)."""
        return self._frames[1]

    @property
    def model_complete(self) -> bool:
        """Whether every coefficient `energy`/`lifetime` need was fitted (model.json loads)."""
        return not unfitted(self.model)

    def summary(self) -> dict[str, object]:
        """The `fit --json` document (cli.md), JSON-safe (NaN -> null)."""

        def linear(fit: LinearFit, paper: LinearFit, unit: str, slope_unit: str) -> dict:
            return {
                f"intercept_{unit}": fit.intercept,
                f"slope_{slope_unit}": fit.slope,
                "intercept_ci95": list(fit.intercept_ci95),
                "slope_ci95": list(fit.slope_ci95),
                "r2": fit.r2,
                "n_runs": fit.n_runs,
                "paper": {f"intercept_{unit}": paper.intercept, f"slope_{slope_unit}": paper.slope},
            }

        model, paper = self.model, self.paper
        out = {
            "n_runs": self.n_runs,
            "accel": linear(model.accel, paper.accel, "W", "W_per_mps"),
            "cruise": linear(model.cruise, paper.cruise, "W", "W_per_mps"),
            "t_acc": linear(model.t_acc, LinearFit(math.nan, math.nan), "s", "s_per_mps"),
            "idle_W": model.idle_W,
            "idle_ci95": list(self.idle.ci95),
            "idle_n_runs": self.idle.n_runs,
            "idle_source": self.idle_source,
            # whether model.json can be written (every coefficient energy/lifetime need)
            "model_complete": self.model_complete,
            "speed_range_mps": model.speed_range_mps,
            "components_W": {m: model.components_W.get(m) for m in COMPONENT_MODES},
            "components_ci95": {m: list(c.ci95) if c else None for m, c in self.components.items()},
            "components_n_runs": {m: c.n_runs if c else 0 for m, c in self.components.items()},
            "paper": {"idle_W": paper.idle_W, "components_W": dict(paper.components_W)},
            "stop_and_go": [s.as_dict() for s in self.stop_and_go],
            "skipped": [s.as_dict() for s in self.skipped],
            "notes": list(self.notes),
            "warnings": list(self.warnings),
        }
        del out["t_acc"]["paper"]
        return json_safe(out)  # type: ignore[return-value]

    def table_rows(self) -> list[dict[str, object]]:
        """The paper table: a row per coefficient, with its interval, R², the paper's value
        and the runs it rests on (what the CLI renders, and `to_markdown` prints)."""
        model, paper = self.model, self.paper
        rows: list[dict[str, object]] = []

        def add(name, unit, value, ci, r2, paper_value, n) -> None:
            rows.append(
                {
                    "parameter": name,
                    "unit": unit,
                    "value": value,
                    "ci95_low": ci[0],
                    "ci95_high": ci[1],
                    "r2": r2,
                    "paper": paper_value,
                    "n_runs": n,
                }
            )

        for label, fit, ref in (
            ("P_acc", model.accel, paper.accel),
            ("P_v", model.cruise, paper.cruise),
        ):
            add(
                f"{label} intercept",
                "W",
                fit.intercept,
                fit.intercept_ci95,
                fit.r2,
                ref.intercept,
                fit.n_runs,
            )
            add(
                f"{label} slope",
                "W/(m/s)",
                fit.slope,
                fit.slope_ci95,
                fit.r2,
                ref.slope,
                fit.n_runs,
            )
        t_acc = model.t_acc
        add(
            "t_acc intercept",
            "s",
            t_acc.intercept,
            t_acc.intercept_ci95,
            t_acc.r2,
            math.nan,
            t_acc.n_runs,
        )
        add(
            "t_acc slope",
            "s/(m/s)",
            t_acc.slope,
            t_acc.slope_ci95,
            t_acc.r2,
            math.nan,
            t_acc.n_runs,
        )
        add(
            "idle", "W", self.idle.value_W, self.idle.ci95, math.nan, paper.idle_W, self.idle.n_runs
        )
        for mode in COMPONENT_MODES:
            estimate = self.components.get(mode)
            add(
                f"{mode} (net of idle)",
                "W",
                estimate.value_W if estimate else math.nan,
                estimate.ci95 if estimate else NAN_PAIR,
                math.nan,
                paper.components_W.get(mode, math.nan),
                estimate.n_runs if estimate else 0,
            )
        return rows

    def to_markdown(self) -> str:
        """The paper table as Markdown (paste into a report)."""

        num = format_number
        lines = [
            "| parameter | unit | fitted | 95% CI | R² | paper | n runs |",
            "| --- | --- | ---: | :---: | ---: | ---: | ---: |",
        ]
        for r in self.table_rows():
            ci = (
                f"[{num(r['ci95_low'])}, {num(r['ci95_high'])}]"
                if math.isfinite(r["ci95_low"])
                else "-"
            )
            lines.append(
                f"| {r['parameter']} | {r['unit']} | {num(r['value'])} | {ci} | "
                f"{num(r['r2'], 4)} | {num(r['paper'], 1)} | {r['n_runs']} |"
            )
        return "\n".join(lines) + "\n"


def format_number(value: float | None, digits: int = 3) -> str:
    """A table cell: fixed digits, "-" for a missing value, no "-0.000"."""
    if value is None or not math.isfinite(value):
        return "-"
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def fit_table(
    runs: pd.DataFrame,
    phases: pd.DataFrame | None = None,
    skipped: tuple[Skipped, ...] = (),
) -> FitResult:
    """Fit the models over the usable rows of a per-run table (`runtable.runs_frame`).

    Callable on any subset of runs (e.g. `diagnose` fitting on the runs it does not hold out).
    """
    if phases is None:
        import pandas as pd

        phases = pd.DataFrame()
    return fit_rows(_records(runs), lambda: (runs, phases), skipped)


def fit_table_model(runs: pd.DataFrame) -> PowerModel:
    """`fit_table(runs).model`, without the rest of a `FitResult` (its stop-and-go table took
    a third of the time): `diagnose` fits the model on ~50 subsets of runs. Read from the
    table's columns (`TableColumns`), not row by row."""
    return TableColumns(runs).model()


class TableColumns:
    """The columns of a per-run table (`runtable.runs_frame`) that the model's fit reads,
    each read once as an array, so that the model of any subset of its rows is fitted
    without making that subset's table (`diagnose` fits ~30 subsets of one table)."""

    def __init__(self, runs: pd.DataFrame) -> None:
        import numpy as np

        self.usable = runs["usable"].to_numpy(dtype=bool)
        self.mode = runs["mode"].to_numpy(dtype=object)
        self.values = {name: runs[name].to_numpy(dtype=np.float64) for name in _FIT_VALUES}

    def model(self, rows: np.ndarray | None = None) -> PowerModel:
        """`fit_table_model` of the table's `rows` (positions, in their order; all rows by
        default): the same numbers as of the table `runs.take(rows)`."""
        import numpy as np

        usable = np.flatnonzero(self.usable) if rows is None else rows[self.usable[rows]]
        columns = _Columns(self.mode[usable], arrays={n: v[usable] for n, v in self.values.items()})
        return _fitted_columns(columns).model


def _records(runs: pd.DataFrame) -> list[Row]:
    """The run-table columns of `runs` as one dict per row. Only those: a diagnose table
    carries ~30 more. Built column by column: to_dict("records")
    boxes every cell through pandas indexing, 10 ms a call."""
    from wifibot_power.runtable import RUN_COLUMNS

    names = [c for c in runs.columns if c in RUN_COLUMNS]
    values = zip(*(runs[c].tolist() for c in names), strict=True)
    return [dict(zip(names, row, strict=True)) for row in values]


def fit_rows(
    rows: Sequence[Row],
    tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]],
    skipped: tuple[Skipped, ...] = (),
) -> FitResult:
    """`fit_table` on per-run rows (`runtable.run_row` dicts or the records of a runs table),
    without pandas: the model (`_fitted`) and the measured stop-and-go overheads beside it
    (`overhead.stop_and_go_overheads`). `tables()` makes the `(runs, phases)` tables of the
    result when they are asked for.
    """
    fitted = _fitted(rows)
    return FitResult(
        model=fitted.model,
        idle=fitted.idle,
        idle_source=fitted.idle_source,
        components=fitted.components,
        n_runs=len(fitted.used),
        tables=tables,
        skipped=tuple(skipped),
        notes=fitted.notes,
        stop_and_go=stop_and_go_overheads(fitted.used, fitted.model),
        warnings=(*incomplete_warning(fitted.model, fitted.notes), *fitted.model.fit_warnings),
    )


def unfitted(model: PowerModel) -> list[str]:
    """The parts of `model` that `energy`/`lifetime` need and the fit could not give (a
    coefficient that is not a finite number): none for a complete model."""
    return [
        name
        for name, values in (
            ("P_acc", (model.accel.intercept, model.accel.slope)),
            ("P_v", (model.cruise.intercept, model.cruise.slope)),
            ("t_acc", (model.t_acc.intercept, model.t_acc.slope)),
            ("idle power", (model.idle_W,)),
        )
        if not all(math.isfinite(v) for v in values)
    ]


def incomplete_warning(model: PowerModel, notes: Sequence[str] = ()) -> list[str]:
    """What a model lacks (`unfitted`), as a warning, with why (the fit's notes). A fit
    that read every input still exits 0 (cli.md's exit codes); this says the model is not
    all there."""
    missing = unfitted(model)
    if not missing:
        return []
    why = "".join(f"; {note}" for note in notes)
    return [
        f"the model is incomplete (not fitted: {', '.join(missing)}{why}): energy, lifetime "
        "and --model cannot use it, and fit -o writes no model.json"
    ]


@dataclass(frozen=True)
class _Fitted:
    """What `fit_rows` fits: the model and the means it stands on, from the usable rows."""

    model: PowerModel
    idle: MeanEstimate
    idle_source: str
    components: dict[str, MeanEstimate | None]
    used: list[Row]
    notes: tuple[str, ...]


#: The columns `_fitted` reads: each run's mode, and the values it fits.
_FIT_VALUES = (
    "speed_mps",
    "accel_mean_power_W",
    "cruise_mean_power_W",
    "t_acc_s",
    "mean_power_W",
    "idle_mean_power_W",
)


@dataclass(frozen=True)
class _Columns:
    """The usable runs' modes, and the values `_fitted` reads of a selection of them: from
    per-run rows, or from the columns of a per-run table read whole (`TableColumns`)."""

    mode: np.ndarray
    rows: Sequence[Row] = ()
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def of_rows(cls, used: Sequence[Row]) -> _Columns:
        import numpy as np

        return cls(np.array([row["mode"] for row in used], dtype=object), rows=used)

    def column(self, selected: np.ndarray, name: str) -> np.ndarray:
        """Column `name` of the `selected` runs (a mask over the usable runs)."""
        import numpy as np

        if name in self.arrays:
            return self.arrays[name][selected]
        # only the selected rows: a row need not hold the values other modes' rows have
        chosen = [row[name] for row, keep in zip(self.rows, selected.tolist(), strict=True) if keep]
        return np.array(chosen, dtype=np.float64)  # None -> NaN


def _fitted(rows: Sequence[Row]) -> _Fitted:
    """Paper Eq. 1-4 by least squares over the motion rows (`fit_line`), idle and Table 1
    component powers as means over runs (`MeanEstimate`, `net_of_idle`)."""
    used = [row for row in rows if row["usable"]]
    return replace(_fitted_columns(_Columns.of_rows(used)), used=used)


def _fitted_columns(columns: _Columns) -> _Fitted:
    """`_fitted` of the usable runs' columns (`used` left empty: the caller has the rows)."""
    mode = columns.mode
    motion = mode == "motion"
    column = columns.column

    speed = column(motion, "speed_mps")
    accel = fit_line(speed, column(motion, "accel_mean_power_W"))
    cruise = fit_line(speed, column(motion, "cruise_mean_power_W"))
    t_acc = fit_line(speed, column(motion, "t_acc_s"))
    notes: list[str] = []
    if motion.any() and not math.isfinite(accel.slope):
        notes.append("fewer than 2 distinct speeds among motion runs: P_acc, P_v not fitted")

    idle_runs = mode == "idle"
    if idle_runs.any():
        idle = MeanEstimate.of(column(idle_runs, "mean_power_W"))
        idle_source = "idle runs"
    else:
        idle = MeanEstimate.of(column(motion, "idle_mean_power_W"))
        # said in `warnings` (fit_warnings), not twice
        idle_source = "idle phases of motion runs" if idle.n_runs else "none"

    components: dict[str, MeanEstimate | None] = {}
    for name in COMPONENT_MODES:
        mode_runs = mode == name
        if not mode_runs.any():
            components[name] = None
            continue
        components[name] = net_of_idle(MeanEstimate.of(column(mode_runs, "mean_power_W")), idle)
    warnings = fit_warnings(accel, cruise, speed, idle_source, idle.value_W)
    model = PowerModel(
        accel=accel,
        cruise=cruise,
        idle_W=idle.value_W,
        t_acc=t_acc,
        components_W={m: (c.value_W if c else None) for m, c in components.items()},
        source="fit",
        speed_range_mps=_speed_range(speed),
        fit_warnings=tuple(warnings),
    )
    return _Fitted(model, idle, idle_source, components, [], tuple(notes))


def _speed_range(speed_mps: np.ndarray) -> tuple[float, float] | None:
    """The lowest and highest speed the motion runs were fitted on (None without any)."""
    import numpy as np

    finite = speed_mps[np.isfinite(speed_mps)]
    return (float(finite.min()), float(finite.max())) if finite.size else None


#: Two speeds closer than this are one speed level: the larger of an absolute floor [m/s]
#: and a fraction of the speed (what a commanded or measured robot speed can be trusted to:
#: wheel slip, encoder counts, a controller's steady error). docs/fit.md, "Warnings".
SPEED_RESOLUTION_MPS = 0.005
SPEED_RESOLUTION_FRACTION = 0.02


def speed_levels(speeds_mps: np.ndarray) -> list[list[float]]:
    """The distinct speeds grouped into levels: sorted, a speed joins the level before it
    when it is closer to that level's largest speed than the resolution
    (max(`SPEED_RESOLUTION_MPS`, `SPEED_RESOLUTION_FRACTION` x the larger speed))."""
    import numpy as np

    speeds = np.asarray(speeds_mps, dtype=np.float64)
    # the finite speeds as Python floats in one call (not one numpy scalar at a time)
    distinct = sorted(set(speeds[np.isfinite(speeds)].tolist()))
    levels: list[list[float]] = []
    for v in distinct:
        if levels and v - levels[-1][-1] < max(SPEED_RESOLUTION_MPS, SPEED_RESOLUTION_FRACTION * v):
            levels[-1].append(v)
        else:
            levels.append([v])
    return levels


def fit_warnings(
    accel: LinearFit,
    cruise: LinearFit,
    speeds_mps: np.ndarray,
    idle_source: str,
    idle_W: float,
) -> list[str]:
    """Why a fitted model is physically implausible or weakly determined (cli.md `fit`):
    a negative slope or intercept (power cannot fall with speed, nor be negative at rest),
    fewer than three distinct speed levels (two points fix a line but cannot check it),
    speeds closer than their resolution (grouped by `speed_levels`), and idle power taken
    from the idle phases of motion runs (no idle-mode run measured it)."""
    warnings: list[str] = []
    for label, fit in (("P_acc", accel), ("P_v", cruise)):
        for name, value, unit in (
            ("slope", fit.slope, "W/(m/s)"),
            ("intercept", fit.intercept, "W"),
        ):
            if math.isfinite(value) and value < 0:
                warnings.append(
                    f"{label} {name} is negative ({value:.3g} {unit}): not physical; check the "
                    "runs' speeds and their segmentation (wbpower segment)"
                )
    if math.isfinite(idle_W) and idle_W < 0:
        warnings.append(f"idle power is negative ({idle_W:.3g} W): check the current sign")
    levels = speed_levels(speeds_mps)
    if speeds_mps.size and len(levels) < 3:
        listed = ", ".join(f"{lv[0]:g}" for lv in levels)
        warnings.append(
            f"the motion runs hold {len(levels)} distinct speed level(s) ({listed} m/s): "
            "a line through fewer than three speeds cannot be checked against them"
        )
    for level in levels:
        if len(level) > 1:
            warnings.append(
                f"speeds {', '.join(f'{v:g}' for v in level)} m/s are closer than their "
                f"resolution (max({SPEED_RESOLUTION_MPS:g} m/s, "
                f"{SPEED_RESOLUTION_FRACTION:.0%})): counted as one speed level"
            )
    if idle_source == "idle phases of motion runs":
        warnings.append(
            "idle power is taken from the idle phases of motion runs (no idle-mode run): "
            "it holds whatever the segmentation called idle"
        )
    return warnings


def _default_segmenter() -> Segmenter:
    from wifibot_power.segment import segment_run  # imported late: segment is its own stage

    return segment_run


def segment_checked(run: Run, segmenter: Segmenter | None = None) -> Segmentation:
    """Segment a run; an unexpected failure of the segmenter becomes a one-line `LogError`
    naming the file, so one run cannot end a batch (`fit` and `diagnose` both use it)."""
    segment = segmenter or _default_segmenter()
    try:
        return segment(run)
    except WbpowerError:
        raise
    except Exception as exc:  # noqa: BLE001 - reported as this file's error, not a traceback
        raise LogError(
            f"segmentation failed ({exc.__class__.__name__}: {exc})",
            file=run.file,
            fix="check the log with 'wbpower segment'",
        ) from None


def _result_to_json(result: tuple[dict[str, object], list[dict[str, object]]]) -> object:
    """A run's row and phase rows as JSON values (datetimes as ISO text, NaN kept as NaN)."""
    row, phases = result
    dates = [k for k, v in row.items() if isinstance(v, datetime)]
    encoded = {k: (v.isoformat() if k in dates else v) for k, v in row.items()}
    return {"row": encoded, "datetimes": dates, "phases": phases}


def _result_from_json(stored: object) -> tuple[dict[str, object], list[dict[str, object]]]:
    row = dict(stored["row"])  # type: ignore[index]
    for key in stored["datetimes"]:  # type: ignore[index]
        row[key] = datetime.fromisoformat(row[key])
    return row, list(stored["phases"])  # type: ignore[index]


@functools.lru_cache(maxsize=1)
def result_memo() -> ResultMemo[tuple[dict[str, object], list[dict[str, object]]]]:
    """How `fit --cache` keeps each run's row and phases (valid for this code only). Made at
    first use: its key hashes all of wifibot_power's source (`code_digest`, ~11 ms of reading
    and hashing), which a fit without a cache never needs."""
    return ResultMemo(
        key=f"fit.run_row+segment_run {code_digest()}",
        to_json=_result_to_json,
        from_json=_result_from_json,
    )


def fit_logs(
    paths: str | Path | Sequence[str | Path],
    options: ReadOptions | None = None,
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    segmenter: Segmenter | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    keep_doubtful: bool = False,
) -> FitResult:
    """Read every log under `paths` (one file in memory at a time per worker), segment it,
    build the per-run table and fit the paper's models over the usable runs (see module
    docstring).

    `jobs` worker processes (None or 0: all cores) read and segment files in parallel; only
    each run's row and phases come back, and the result is the same for any `jobs`.
    `cache` (`wifibot_power.cache.ParseCache`) skips parsing files parsed before, segmenting
    runs segmented before and, when every run's row is what it was, the fit itself.

    Unreadable logs and runs the fit cannot use are listed in `FitResult.skipped` with the
    reason; runs whose segmentation is in doubt are among them unless `keep_doubtful`.
    Raises `LogError` when no run at all can be used (nothing to fit).
    """
    paths = [paths] if isinstance(paths, str | Path) else list(paths)

    def work(run: Run) -> tuple[dict[str, object], list[dict[str, object]]]:
        # a row per phase (`Segmentation.rows`): plain values, small to send back and to
        # keep, and the phases table is built once from all of them
        from wifibot_power.phases import Segmentation
        from wifibot_power.runtable import run_row

        if run.meta.mode == "unknown":  # nothing to fit it to: not worth segmenting
            return run_row(run, Segmentation(run.meta.run_id, ())), []
        segmentation = segment_checked(run, segmenter)
        return run_row(run, segmentation), segmentation.rows(run.file)

    # with the default segmenter, what a run gives is a function of its content and of this
    # code: a cache keeps it (a custom segmenter's is not kept: its code is not known here)
    memo = result_memo() if segmenter is None and cache is not None else None
    results, read_skipped = map_runs(
        [Path(p) for p in paths],
        options or ReadOptions(),
        work,
        wrap=wrap,
        jobs=jobs,
        cache=cache,
        memo=memo,
        on_problems=on_problems,
        prepare=_import_work_modules,
    )
    rows = [row for row, _ in results]
    phase_rows = [phase for _, phases in results for phase in phases]
    batch = None
    if cache is not None and memo is not None:
        batch = _fit_batch(paths, options or ReadOptions(), keep_doubtful, rows, read_skipped)
    if batch is not None:
        kept = cache.kept_batch(*batch)
        if kept is not MISSING:
            try:
                return _fit_from_json(
                    kept, lambda: _tables(_admitted(rows, keep_doubtful), phase_rows)
                )
            except (KeyError, TypeError, ValueError, WbpowerError):
                pass  # another layout: fit again (and keep that)
    fit, skipped = fit_gathered(rows, phase_rows, read_skipped, keep_doubtful=keep_doubtful)
    if fit is None:
        why = reasons_in_brief(list(skipped)) if skipped else "no logs"
        raise LogError(
            f"no usable run among {len(rows) + len(read_skipped)} input(s): {why}",
            file=", ".join(map(str, paths)),
            fix="see 'wbpower inspect' for what each log holds",
        )
    if batch is not None:
        cache.keep_batch(*batch, _fit_to_json(fit))
    return fit


def _fit_batch(
    paths: Sequence[str | Path],
    options: ReadOptions,
    keep_doubtful: bool,
    rows: list[dict[str, object]],
    read_skipped: Sequence[Skipped],
) -> tuple[object, str] | None:
    """What names a `fit_logs` batch in the cache (the paths, the reading options, this code)
    and a digest of everything its fit depends on: every run's row (as kept: the rows are
    the fit's only input, `fit_gathered`), the inputs left out, `keep_doubtful`. A changed
    log changes its row (its content is checked per file first) and so misses; a run whose
    row is unchanged gives the same fit. None when a row cannot be written as JSON."""
    import dataclasses
    import hashlib
    import json

    key = result_memo().key
    inputs = [key, [str(p) for p in paths], dataclasses.asdict(options), keep_doubtful]
    try:
        content = json.dumps(
            [
                key,
                [_result_to_json((row, [])) for row in rows],
                [s.as_dict() for s in read_skipped],
                keep_doubtful,
            ]
        )
    except (TypeError, ValueError):
        return None
    return inputs, hashlib.sha256(content.encode()).hexdigest()


def _fit_to_json(fit: FitResult) -> dict[str, object]:
    """A `FitResult` as JSON values, all but its tables (`_fit_from_json` is the exact round
    trip: floats through repr, NaN kept as NaN)."""
    import dataclasses

    return {
        "model": fit.model.to_json(),
        "idle": dataclasses.asdict(fit.idle),
        "idle_source": fit.idle_source,
        "components": {
            m: (dataclasses.asdict(c) if c is not None else None) for m, c in fit.components.items()
        },
        "n_runs": fit.n_runs,
        "skipped": [s.as_dict() for s in fit.skipped],
        "notes": list(fit.notes),
        "stop_and_go": [dataclasses.asdict(s) for s in fit.stop_and_go],
        "warnings": list(fit.warnings),
    }


def _fit_from_json(
    kept: object, tables: Callable[[], tuple[pd.DataFrame, pd.DataFrame]]
) -> FitResult:
    """The `FitResult` `_fit_to_json` kept, with `tables()` making its tables when asked for."""

    def mean(d: dict) -> MeanEstimate:
        return MeanEstimate(d["value_W"], tuple(d["ci95"]), d["n_runs"], d["se_W"])

    def stop_and_go(d: dict) -> StopAndGo:
        return StopAndGo(**{**d, "overhead_ci95": tuple(d["overhead_ci95"])})

    return FitResult(
        model=PowerModel.from_json(kept["model"]),  # type: ignore[index]
        idle=mean(kept["idle"]),  # type: ignore[index]
        idle_source=kept["idle_source"],  # type: ignore[index]
        components={m: (mean(c) if c else None) for m, c in kept["components"].items()},  # type: ignore[index]
        n_runs=kept["n_runs"],  # type: ignore[index]
        tables=tables,
        skipped=tuple(Skipped(**s) for s in kept["skipped"]),  # type: ignore[index]
        notes=tuple(kept["notes"]),  # type: ignore[index]
        stop_and_go=tuple(stop_and_go(s) for s in kept["stop_and_go"]),  # type: ignore[index]
        warnings=tuple(kept["warnings"]),  # type: ignore[index]
    )


def _admitted(rows: list[dict[str, object]], keep_doubtful: bool) -> list[dict[str, object]]:
    """The rows as `fit_gathered` fits them: runs in doubt made usable with `keep_doubtful`."""
    if not keep_doubtful:
        return rows
    from wifibot_power.runtable import admit_doubtful

    return [admit_doubtful(row) for row in rows]


def fit_gathered(
    rows: list[dict[str, object]],
    phase_rows: list[dict[str, object]],
    read_skipped: Sequence[Skipped],
    *,
    keep_doubtful: bool = False,
) -> tuple[FitResult | None, tuple[Skipped, ...]]:
    """The fit of the per-run rows and phase rows the workers gathered (`fit_logs`, and
    `report`, which gathers more per run in the same pass), and every input left out: the
    unreadable ones, then the runs the fit cannot use (with their reason). None when no run
    can be used. Runs in doubt are made usable with `keep_doubtful`, and then named in the
    fit's `warnings` (`runtable.kept_in_doubt`)."""
    from wifibot_power.runtable import kept_in_doubt

    in_doubt = kept_in_doubt(rows) if keep_doubtful else None
    rows = _admitted(rows, keep_doubtful)
    unusable = [
        Skipped(str(row["file"]), f"{row['file']}: {row['skip_reason']}")
        for row in rows
        if not row["usable"]
    ]
    skipped = tuple(read_skipped) + tuple(unusable)
    if not any(row["usable"] for row in rows):
        return None, skipped
    fit = fit_rows(rows, lambda: _tables(rows, phase_rows), skipped)
    if in_doubt:  # the doubted runs it used are said, never passed off as sound (cli.md)
        fit = replace(fit, warnings=(in_doubt, *fit.warnings))
    return fit, skipped


def _import_work_modules() -> None:
    """What `fit_logs`' work on a file imports (the run table, the segmenter), imported once
    here, before workers are forked, rather than once in every worker. Not pandas: the run
    table's rows and the fit need none (`fit --json` never loads it; the tables do).
    numpy's submodules that load at first use: `numpy.ma` (`np.median`'s NaN check imports
    it, ~9 ms of CPU) and `numpy.fft` (the segmenter's ripple continuation, diagnose's trace
    statistics), which every worker would otherwise import for itself. `diagnose` and
    `report` do the same work and more, and prepare their workers with this too."""
    import numpy.fft  # noqa: F401
    import numpy.ma  # noqa: F401

    import wifibot_power.runtable  # noqa: F401
    import wifibot_power.segment  # noqa: F401


def _tables(
    rows: list[dict[str, object]], phase_rows: list[dict[str, object]]
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The runs and phases tables of `fit_logs` (pandas is imported here, when asked for)."""
    from wifibot_power.phases import phase_frame
    from wifibot_power.runtable import runs_frame

    return runs_frame(rows), phase_frame(phase_rows)


def write_fit(result: FitResult, out_dir: Path) -> list[Path]:
    """`fit -o DIR`: runs.parquet, phases.parquet, stop_and_go.parquet, model.json, written
    as one set (`outputs.write_set`: all new, or all as they were).

    model.json is written only when the model is complete (`FitResult.model_complete`):
    a model with unfitted coefficients would only fail later, in `energy --model`. Then a
    model.json an earlier fit left in DIR is removed with the same set: beside this fit's
    tables it would be read by `energy --model DIR/model.json` as this fit's model.
    """
    files = {
        "runs.parquet": parquet_file(result.runs),
        "phases.parquet": parquet_file(result.phases),
        "stop_and_go.parquet": parquet_file(stop_and_go_frame(result)),
    }
    if result.model_complete:
        files["model.json"] = json_file(result.model.to_json())
    stale = () if result.model_complete else ("model.json",)
    return write_set(Path(out_dir), files, remove=stale)


def stop_and_go_frame(result: FitResult) -> pd.DataFrame:
    """The rows of `stop_and_go` as a table (stop_and_go.parquet): the interval as two
    columns, `overhead_ci95_low_pct` and `overhead_ci95_high_pct`."""
    import pandas as pd

    from wifibot_power.overhead import StopAndGo

    columns = [k for k in StopAndGo.__dataclass_fields__ if k != "overhead_ci95"]
    rows = []
    for item in result.stop_and_go:
        row = {k: getattr(item, k) for k in columns}
        row["overhead_ci95_low_pct"], row["overhead_ci95_high_pct"] = item.overhead_ci95
        rows.append(row)
    return pd.DataFrame(rows, columns=[*columns, "overhead_ci95_low_pct", "overhead_ci95_high_pct"])
