"""The paper's phase model fitted over runs: the least squares and means behind `fit`.

One point per run (the per-run table of `wifibot_power.runtable`), ordinary least squares:

- acceleration power `P_acc(v) = a0 + a1 v` [W] (paper Eq. 1-2; paper: 23.9 + 14.8 v),
- cruise power `P_v(v) = c0 + c1 v` [W] (paper Eq. 3-4; paper: 23.9 + 11.2 v),
- acceleration time `t_acc(v) = t0 + t1 v` [s] (used by paper Eq. 5-6),
- idle power [W] (paper: 23.3 W): mean of idle-mode runs, else of the idle phases of
  motion runs (`idle_source` says which),
- component powers net of idle [W] (paper Table 1: network 4.4, video 2.5, CPU 2.1):
  mean power of the mode's runs minus idle power.

Intervals are the regression's own 95% t intervals with runs as the unit
(`t_{0.975, n-2} * standard error`), see docs/fit.md. The same fit reads per-run rows
(`FitColumns.of_rows`, what `fit` does) or the columns of a per-run table read once
(`FitColumns.of_table`, what `diagnose` does on ~50 subsets of one table): one code path,
`FitColumns.fitted`.

numpy and the numerics are imported inside the functions: a warm `fit --cache` takes the
fit from the cache and loads neither (tests/test_cache.py, `WARM_UNLOADED`).

References
----------
[1] D. Zorbas, T. Razafindralambo, "Modeling the power consumption of a Wifibot and
    studying the role of communication cost in operation time", arXiv:1512.04380.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from wifibot_power.model import LinearFit, PowerModel
from wifibot_power.run import MODES

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd

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
        "and --model cannot use it, and fit -o writes no paper model to model.json (the file "
        "holds the drive model alone when one was fitted)"
    ]


@dataclass(frozen=True)
class Fitted:
    """The paper's model and the means it stands on, fitted from the usable runs."""

    model: PowerModel
    idle: MeanEstimate
    idle_source: str
    components: dict[str, MeanEstimate | None]
    notes: tuple[str, ...]


#: The columns the fit reads besides each run's mode: the values it fits.
FIT_VALUES = (
    "speed_mps",
    "accel_mean_power_W",
    "cruise_mean_power_W",
    "t_acc_s",
    "mean_power_W",
    "idle_mean_power_W",
    "sample_period_s",
)


@dataclass(frozen=True)
class FitColumns:
    """The per-run values the fit reads, one array a column: the one form the fit takes,
    made from per-run rows (`of_rows`: `runtable.run_row` dicts) or from a per-run table's
    columns read once (`of_table`), so that the model of any subset of runs is fitted
    without making that subset's table (`diagnose` fits ~50 subsets of one table)."""

    usable: np.ndarray
    mode: np.ndarray
    values: dict[str, np.ndarray] = field(default_factory=dict)

    @classmethod
    def of_rows(cls, rows: Sequence[Row]) -> FitColumns:
        """The columns of `rows` (a value a row lacks, or None: NaN)."""
        import numpy as np

        return cls(
            np.array([bool(row["usable"]) for row in rows], dtype=bool),
            np.array([row["mode"] for row in rows], dtype=object),
            {n: np.array([row.get(n) for row in rows], dtype=np.float64) for n in FIT_VALUES},
        )

    @classmethod
    def of_table(cls, runs: pd.DataFrame) -> FitColumns:
        """The columns of a per-run table (`runtable.runs_frame`)."""
        import numpy as np

        return cls(
            runs["usable"].to_numpy(dtype=bool),
            runs["mode"].to_numpy(dtype=object),
            {name: runs[name].to_numpy(dtype=np.float64) for name in FIT_VALUES},
        )

    def fitted(self, rows: np.ndarray | None = None) -> Fitted:
        """The fit over the usable runs among `rows` (positions, in their order; all runs
        by default)."""
        import numpy as np

        usable = np.flatnonzero(self.usable) if rows is None else rows[self.usable[rows]]
        return _fitted(self.mode[usable], {n: v[usable] for n, v in self.values.items()})

    def model(self, rows: np.ndarray | None = None) -> PowerModel:
        """`fitted(rows).model`: the same numbers as the fit of the table `runs.take(rows)`."""
        return self.fitted(rows).model


#: `TableColumns(runs).model(rows)`: the name `diagnose` fits its folds by.
TableColumns = FitColumns.of_table


def fit_table_model(runs: pd.DataFrame) -> PowerModel:
    """The paper's model fitted on a per-run table, without the rest of a `FitResult` (its
    stop-and-go table took a third of the time): `diagnose` fits the model on ~50 subsets
    of runs."""
    return FitColumns.of_table(runs).model()


def _fitted(mode: np.ndarray, values: dict[str, np.ndarray]) -> Fitted:
    """Paper Eq. 1-4 by least squares over the motion runs (`fit_line`), idle and Table 1
    component powers as means over runs (`MeanEstimate`, `net_of_idle`); `mode` and
    `values`: of the usable runs."""
    motion = mode == "motion"

    def column(selected: np.ndarray, name: str) -> np.ndarray:
        return values[name][selected]

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
    t_acc = _resolution_floor(
        t_acc, speed, column(motion, "t_acc_s"), column(motion, "sample_period_s"), warnings
    )
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
    return Fitted(model, idle, idle_source, components, tuple(notes))


def _resolution_floor(
    t_acc: LinearFit,
    speed_mps: np.ndarray,
    t_acc_s: np.ndarray,
    sample_period_s: np.ndarray,
    warnings: list[str],
) -> LinearFit:
    """`t_acc` with intervals no narrower than the sample period where the runs' accelerations
    are a sample or two long (a 6.5 Hz log: every t_acc 0.154 s, CI [0.154, 0.154] before),
    and a warning in `warnings` that says so (`segment.resolution`; issue 26)."""
    from dataclasses import replace

    from wifibot_power.segment.resolution import quantized_durations

    coarse = quantized_durations(t_acc_s, sample_period_s)
    if coarse is None:
        return t_acc
    warnings.append(coarse.warning("t_acc"))
    return replace(
        t_acc,
        intercept_ci95=coarse.floor_ci95(t_acc.intercept, t_acc.intercept_ci95),
        slope_ci95=coarse.floor_slope_ci95(t_acc.slope, t_acc.slope_ci95, speed_mps),
    )


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
