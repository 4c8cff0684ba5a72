"""The fitted drive model (`DriveModel`) and how it is fitted: `fit_drive(runs)` from runs (a
notebook), `fit_drive_stats(stats)` from the per-run statistics a pipeline's workers computed
(`stats.drive_stats`). `summary()` is cli.md's `drive` object of `fit --json`; `to_json()` and
`from_json()` its section of model.json.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from wifibot_power.drive.heldout import (
    HeldOut,
    HeldOutRun,
    heldout_accuracy,
    heldout_from_sums,
    lag_grid_of,
)
from wifibot_power.drive.identify import (
    WindowSearch,
    identify,
    identify_moments,
    lag_grid,
    lag_search,
)
from wifibot_power.drive.laginterval import (
    LagInterval,
    cluster_grams_of_table,
    cluster_grams_of_windows,
    lag_interval,
)
from wifibot_power.drive.lagsums import SumsTable
from wifibot_power.drive.plausible import mass_warning
from wifibot_power.drive.standing import idle_against_standing, run_stops, standing_power
from wifibot_power.drive.stats import UNKNOWN_SURFACE, DriveStats, drive_stats
from wifibot_power.drive.sums import RunSums, sums_of, windows_of
from wifibot_power.drive.terms import TERM_BY_NAME, TERMS, term_unit
from wifibot_power.drive.windows import WINDOW_S, assemble, run_windows
from wifibot_power.power_kind import PROXY_WARNING, power_kind_of

if TYPE_CHECKING:
    from wifibot_power.drive.identify import Identified
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

#: model.json's drive section format
FORMAT_VERSION = 1
#: With fewer runs than this, the clusters of the covariance are trips, not runs (a trip
#: count of clusters is needed for the sandwich to be of full rank; trips of one log share its
#: slow drifts, so the intervals may be too narrow: said in `warnings`).
MIN_RUN_CLUSTERS = 10


@dataclass(frozen=True)
class TermValue:
    value: float
    ci95: tuple[float, float]
    unit: str

    def as_dict(self) -> dict[str, object]:
        """JSON-safe: an interval that could not be made (one cluster) is null, not NaN."""
        ci95 = [None if math.isnan(x) else x for x in self.ci95]
        return {"value": self.value, "ci95": ci95, "unit": self.unit}


@dataclass(frozen=True)
class DriveModel:
    """The drive model: each term's value with its 95% interval (per surface for the
    per-surface terms), the lag, held-out accuracy, and what the data could not determine."""

    terms: dict[str, TermValue]
    surfaces: dict[str, dict[str, TermValue]]
    lag_s: float
    n_runs: int
    heldout: HeldOut | None
    not_determined: tuple[str, ...]
    warnings: tuple[str, ...]
    #: for predictions: the design's columns, their coefficients (NaN: not determined), the
    #: covariance of the determined ones, and the window the model was fitted on [s]
    columns: tuple[str, ...] = ()
    coef: tuple[float, ...] = ()
    cov: tuple[tuple[float, ...], ...] = ()
    window_s: float = WINDOW_S
    surface_names: tuple[str, ...] = field(default=())
    #: degrees of freedom of the intervals (clusters - 1)
    dof: int = 0
    #: what its logs' "power" is (terms.py `POWER_KINDS`): "current_proxy" when every log
    #: holds motor currents only (the force form: its terms are not the battery's power)
    power_kind: str = "power"
    #: the lag's 95% interval [s] (laginterval.py: a cluster bootstrap of the lag search);
    #: None from a model.json written before it was made, or with fewer than 2 clusters
    lag_ci95_s: tuple[float, float] | None = None
    #: the model family's name (`models.base.FittedModel.family`)
    family: ClassVar[str] = "drive"

    def __post_init__(self) -> None:
        if self.columns:  # on this version's design (`_aligned`)
            columns, coef = _aligned(self.columns, self.coef, self.surface_names)
            object.__setattr__(self, "columns", columns)
            object.__setattr__(self, "coef", coef)

    def predict_energy_J(self, record: object) -> float:
        """A run's energy as the model predicts it [J], over the windows of its statistics
        (`record.models["drive"]`, or a `DriveStats`); NaN for a run without them."""
        return self.run_energy_J(record)[1]

    def run_energy_J(self, record: object) -> tuple[float, float]:
        """(measured, predicted) energy [J] of a run over its windows, the lag applied (a
        drop-out's windows in neither); NaN for a run without drive statistics."""
        stats = record if isinstance(record, DriveStats) else None
        if stats is None:
            stats = getattr(record, "models", {}).get(self.family)
            stats = getattr(stats, "stats", stats)  # as a warm cache kept it (KeptStats)
        if stats is None:
            return math.nan, math.nan
        rw = run_windows(stats, self.window_s)
        windows = assemble([rw], self.lag_s / stats.bin_s, self.surface_names)
        coef = np.array(self.coef)
        kept = np.isfinite(coef)
        predicted_W = windows.design[:, kept] @ coef[kept]
        return (
            float(np.sum(windows.power_W) * windows.window_s),
            float(np.sum(predicted_W) * windows.window_s),
        )

    def to_cache(self) -> dict[str, object]:
        """What `fit --cache` keeps (`models.base.FittedModel.to_cache`): model.json's section
        (`models.drive.KeptDrive` reads it back)."""
        return self.to_json()

    def summary(self) -> dict[str, object]:
        """cli.md's `drive` object (JSON-safe)."""
        return {
            "terms": {name: term.as_dict() for name, term in self.terms.items()},
            "surfaces": {
                surface: {name: term.as_dict() for name, term in named.items()}
                for surface, named in self.surfaces.items()
            },
            "lag_s": self.lag_s,
            "lag_ci95_s": None if self.lag_ci95_s is None else list(self.lag_ci95_s),
            "n_runs": self.n_runs,
            "heldout": self.heldout.as_dict() if self.heldout is not None else None,
            "not_determined": list(self.not_determined),
            "warnings": list(self.warnings),
        }

    def coefficient(self, name: str, surface: str | None = None) -> float:
        """A term's value (NaN when not determined); per-surface terms need `surface`."""
        column = f"{name}[{surface}]" if TERM_BY_NAME[name].per_surface else name
        if column not in self.columns:
            return math.nan
        return self.coef[self.columns.index(column)]

    def to_json(self) -> dict[str, object]:
        """model.json's `drive` section: the summary and what predictions need."""
        heldout = self.heldout
        return {
            "format": FORMAT_VERSION,
            **self.summary(),
            # not in the summary: cli.md's `drive` object has no such key (its warnings say it)
            "power_kind": self.power_kind,
            "columns": list(self.columns),
            "coef": [None if math.isnan(c) else c for c in self.coef],
            "cov": [[None if math.isnan(v) else v for v in row] for row in self.cov],
            "window_s": self.window_s,
            "surface_names": list(self.surface_names),
            "dof": self.dof,
            "relative_rms": heldout.relative_rms if heldout else None,
            "relative_dof": heldout.dof if heldout else None,
        }

    @classmethod
    def from_json(cls, data: dict) -> DriveModel:
        def terms_of(named: dict) -> dict[str, TermValue]:
            return {
                name: TermValue(
                    float(t["value"]),
                    tuple(math.nan if x is None else float(x) for x in t["ci95"]),
                    t["unit"],
                )
                for name, t in named.items()
            }

        held = data.get("heldout")
        heldout = None
        if held is not None:
            heldout = HeldOut(
                runs=tuple(
                    HeldOutRun(
                        r["run_id"],
                        r["surface"],
                        r["measured_J"],
                        r["predicted_J"],
                        tuple(r["pi90_J"]),
                    )
                    for r in held["runs"]
                ),
                mape_pct=math.nan if held["mape_pct"] is None else held["mape_pct"],
                median_ape_pct=(
                    math.nan if held["median_ape_pct"] is None else held["median_ape_pct"]
                ),
                coverage_pi90_pct=(
                    math.nan if held["coverage_pi90_pct"] is None else held["coverage_pi90_pct"]
                ),
                relative_rms=data["relative_rms"],
                dof=data["relative_dof"],
            )
        return cls(
            terms=terms_of(data["terms"]),
            surfaces={s: terms_of(named) for s, named in data["surfaces"].items()},
            lag_s=float(data["lag_s"]),
            lag_ci95_s=_interval_of(data.get("lag_ci95_s")),
            n_runs=int(data["n_runs"]),
            heldout=heldout,
            not_determined=tuple(data["not_determined"]),
            warnings=tuple(data["warnings"]),
            columns=tuple(data["columns"]),
            coef=tuple(math.nan if c is None else float(c) for c in data["coef"]),
            cov=tuple(
                tuple(math.nan if v is None else float(v) for v in row) for row in data["cov"]
            ),
            window_s=float(data["window_s"]),
            surface_names=tuple(data["surface_names"]),
            dof=int(data["dof"]),
            power_kind=power_kind_of(data),
        )


def lag_said(
    lag_s: float,
    lag_ci95_s: tuple[float, float] | list[float] | None,
    not_determined: tuple[str, ...] | list[str],
    short: bool = False,
) -> str:
    """The lag with its 95% interval, and "not determined" when `not_determined` has the lag's
    entry (laginterval.py): "0.26 s [0.21, 0.33]", "0.61 s (not determined, 95% CI [0.50,
    1.00] s; the predictions use it)", "0.04 s (not determined, no interval; ...)"; `short`
    (a figure's title): "0.61 s, not determined". What `fit` prints and the terms figure's
    title say alike."""
    ci = lag_ci95_s
    if any(reason.startswith("lag_s:") for reason in not_determined):
        if short:
            return f"{lag_s:.2f} s, not determined"
        interval = f"95% CI [{ci[0]:.2f}, {ci[1]:.2f}] s" if ci is not None else "no interval"
        return f"{lag_s:.2f} s (not determined, {interval}; the predictions use it)"
    return f"{lag_s:.2f} s [{ci[0]:.2f}, {ci[1]:.2f}]" if ci is not None else f"{lag_s:.2f} s"


def _interval_of(given: list | None) -> tuple[float, float] | None:
    """model.json's `lag_ci95_s` (absent from an older model.json: None)."""
    if given is None or any(x is None for x in given):
        return None
    low, high = (float(x) for x in given)
    return low, high


def _aligned(
    columns: tuple[str, ...], coef: tuple[float, ...], surfaces: tuple[str, ...]
) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """Columns and coefficients on this version's design columns: a term the model did not
    have (a model.json written before `turning_coulomb_W` was a term) is not determined
    (NaN); the covariance, over the determined columns in design order, is unchanged. A
    column this version does not know is a damaged or newer file (ValueError)."""
    from wifibot_power.drive.windows import design_columns

    given = dict(zip(columns, coef, strict=True))
    design = design_columns(surfaces)
    unknown = set(given) - set(design)
    if unknown:
        raise ValueError(f"unknown drive-model columns {sorted(unknown)}")
    return design, tuple(given.get(c, math.nan) for c in design)


def fit_drive(
    runs: Sequence[Run],
    segmentations: Sequence[Segmentation | None] | None = None,
    **options: object,
) -> DriveModel | None:
    """The drive model of `runs` (None when no run has a speed). `segmentations` (one per run)
    let a step run without a speed column take the speed of its phases."""
    segs = list(segmentations) if segmentations is not None else [None] * len(runs)
    return fit_drive_stats([drive_stats(run, seg) for run, seg in zip(runs, segs, strict=True)])


def fit_drive_stats(
    stats_list: Sequence[DriveStats | None],
    *,
    window_s: float = WINDOW_S,
    seed: int = 0,
    sums: Sequence[RunSums | None] | None = None,
    direct: bool = False,
) -> DriveModel | None:
    """The drive model from per-run statistics (`stats.drive_stats`); None when none has a
    speed. See identify.py and heldout.py for the method. `sums`: each run's `RunSums` as
    the workers made them (sums.py; made here when missing); the fit reads only these
    (lagsums.py). `direct`: fit from the windows instead, every lag searched by least
    squares over them (the reference the sums are tested against)."""
    given = list(sums) if sums is not None else [None] * len(stats_list)
    pairs = [(s, m) for s, m in zip(stats_list, given, strict=True) if s is not None]
    if not pairs:
        return None
    # the runs in the order of their run ids (then files: a batch's run ids are unique,
    # pipeline/duplicates.py, a library caller's need not be), as the paper's folds deal them
    # (diagnose/folds.py `assign_folds`): the held-out folds, the lag's bootstrap draws and
    # every sum are then the same whatever order the logs were given in
    pairs.sort(key=lambda pair: (str(pair[0].run_id), str(pair[0].file)))
    if not direct:
        run_sums = [
            m if m is not None and m.window_s == _window_of(s, window_s) else sums_of(s, window_s)
            for s, m in pairs
        ]
        kept = [(s, m) for s, m in zip(pairs, run_sums, strict=True) if m.windows]
        if not kept:
            return None
        stats = [s for (s, _), _ in kept]
        return _fit_from_sums(stats, [m for _, m in kept], window_s, seed)
    return _fit_from_windows([s for s, _ in pairs], window_s, seed, direct)


def _window_of(stats: DriveStats, window_s: float) -> float:
    """The window [s] `run_windows(stats, window_s)` makes (a whole number of bins)."""
    return max(int(round(window_s / stats.bin_s)), 1) * stats.bin_s


def _fit_from_sums(
    stats: list[DriveStats], sums: list[RunSums], window_s: float, seed: int
) -> DriveModel:
    """`fit_drive_stats` from the runs' sums (lagsums.py); a lag search whose sum of squares
    cannot be taken from sums (gram.py `CANCELLATION`) is made over the windows, as
    `lag_search` does."""
    surfaces = tuple(sorted({name for m in sums for name in m.surfaces}))
    table = SumsTable(sums, surfaces)
    search_windows = _window_search(stats, window_s, surfaces, table.trip_base)
    everything = np.ones(table.trips, dtype=bool)
    grams = table.fold_grams(np.zeros(table.trips, int), 1, lag_grid_of(table))
    lag_bins = (grams.search(-1) or search_windows(None))[0]
    by_run = len(sums) >= MIN_RUN_CLUSTERS
    fitted = identify_moments(table.at_lag(lag_bins).moments(everything, by_run), lag_bins)
    heldout = heldout_from_sums(table, by_run, seed=seed, search_windows=search_windows)
    by_cluster = cluster_grams_of_table(table, by_run, lag_grid_of(table))
    lag = lag_interval(by_cluster, lag_bins, stats[0].bin_s, seed=seed)
    model = _model(stats, fitted, heldout, lag, table.window_s, surfaces)
    return _with_noise_warning(model, [m.reliability for m in sums])


def _window_search(
    stats: list[DriveStats], window_s: float, surfaces: tuple[str, ...], trip_base: np.ndarray
):
    """`search(train)`: the lag search by least squares over the windows of the `train` trips
    (a bool per trip; None: every trip), the windows made at the first call and assembled
    once for every call (identify.py `WindowSearch`)."""
    made: list[WindowSearch] = []

    def search(train: np.ndarray | None) -> tuple[float, np.ndarray]:
        if not made:
            made.append(WindowSearch([windows_of(s, window_s) for s in stats], surfaces))
        return made[0].search_trips(train, trip_base)

    return search


def _fit_from_windows(
    stats_list: list[DriveStats], window_s: float, seed: int, direct: bool
) -> DriveModel | None:
    """`fit_drive_stats` from the windows (its `direct`)."""
    runs = [run_windows(s, window_s) for s in stats_list]
    runs = [rw for rw in runs if rw.count]
    if not runs:
        return None
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    lag_bins, _ = lag_search(runs, surfaces, gram=not direct)
    windows = assemble(runs, lag_bins, surfaces)
    by_run = len(runs) >= MIN_RUN_CLUSTERS
    clusters = windows.run if by_run else windows.trip
    fitted = identify(windows, lag_bins, clusters)
    heldout = heldout_accuracy(runs, surfaces, by_run, seed=seed, gram=not direct)
    stats = [rw.stats for rw in runs]
    by_cluster = cluster_grams_of_windows(runs, surfaces, by_run, lag_grid(runs))
    lag = lag_interval(by_cluster, lag_bins, stats[0].bin_s, seed=seed)
    model = _model(stats, fitted, heldout, lag, windows.window_s, surfaces)
    return _with_noise_warning(model, [rw.reliability for rw in runs])


def _model(
    stats: list[DriveStats],
    fitted: Identified,
    heldout: HeldOut | None,
    lag: LagInterval,
    window_s: float,
    surfaces: tuple[str, ...],
) -> DriveModel:
    """The `DriveModel` of a fit over `stats`' runs (each with a window), with its warnings;
    a lag the logs do not determine (laginterval.py) is in `not_determined`."""
    warnings: list[str] = []
    if len(stats) < MIN_RUN_CLUSTERS:
        warnings.append(
            f"only {len(stats)} run(s): the intervals are robust by trip (the runs cut at their "
            f"stops), not by run (>= {MIN_RUN_CLUSTERS} runs); trips of one log share its slow "
            "drifts, so the intervals may be too narrow"
        )
    warnings += _data_warnings(stats)
    if heldout is None:
        warnings.append("fewer than 4 trips: no held-out accuracy")
    proxies = sum(s.current_proxy for s in stats)
    kind = "power" if not proxies else "current_proxy" if proxies == len(stats) else "mixed"
    # a proxy's idle against the logs' own standing power (identify.py)
    proxy = kind == "current_proxy"
    standing = standing_power([run_stops(s) for s in stats]) if proxy else None
    fitted, idle_warning = idle_against_standing(fitted, standing, proxy)
    warnings += [idle_warning] if idle_warning else []
    terms, per_surface = _terms(fitted, surfaces, force_form=kind == "current_proxy")
    # a proxy's effective_mass_kg is no mass (its force form), and mixed with one not a power's
    said = mass_warning(stats, terms) if kind == "power" else None
    warnings += [said] if said else []
    k = np.flatnonzero(fitted.kept)
    return DriveModel(
        terms=terms,
        surfaces=per_surface,
        lag_s=lag.lag_s,
        lag_ci95_s=lag.ci95_s if np.isfinite(lag.ci95_s).all() else None,
        n_runs=len(stats),
        heldout=heldout,
        not_determined=tuple(reason for _, reason in fitted.not_determined)
        + ((lag.reason(),) if not lag.determined else ()),
        warnings=tuple(warnings),
        columns=fitted.columns,
        coef=tuple(float(c) for c in fitted.coef),
        cov=tuple(tuple(float(v) for v in row) for row in fitted.cov) if k.size else (),
        window_s=window_s,
        surface_names=surfaces,
        dof=fitted.dof,
        power_kind=kind,
    )


#: A run's speeding-up or braking column is "mostly noise" when its reliability (regressors.py
#: `reliability`: the share of the column's sum of squares that is not the edge speeds' noise)
#: is under this: more of it is noise than signal.
MOSTLY_NOISE = 0.5


def _with_noise_warning(model: DriveModel, reliabilities: list[tuple[float, float]]):
    """`model` with a warning when some runs' inertial columns were mostly noise
    (`inertial_noise_warning`)."""
    said = inertial_noise_warning(reliabilities)
    return model if said is None else replace(model, warnings=(*model.warnings, said))


def inertial_noise_warning(reliabilities: list[tuple[float, float]]) -> str | None:
    """What regression calibration did to the runs whose speeding-up or braking column was
    mostly noise (reliability under `MOSTLY_NOISE`; regressors.py `calibrated` multiplies the
    column by it, to 0 where the noise estimate is the whole column's): such a run says little
    or nothing about effective_mass_kg and braking_mass_kg, which the other runs' speeding up
    and braking then carry. None when no run's was."""
    low = [min(pair) for pair in reliabilities if min(pair) < MOSTLY_NOISE]
    if not low:
        return None
    zeroed = sum(value <= 0.0 for value in low)
    return (
        f"{len(low)} of {len(reliabilities)} run(s): their speeding-up or braking column is "
        f"mostly noise (the edge speeds' noise is over {100 * (1 - MOSTLY_NOISE):.0f}% of its "
        f"sum of squares; {zeroed} of them all noise), so regression calibration shrank it "
        "towards 0 (to 0 where all noise): those runs add little or nothing to "
        "effective_mass_kg and braking_mass_kg, which come from the other runs' speeding up "
        "and braking (a speed log with less noise, or faster, makes them count)"
    )


def _data_warnings(stats: list[DriveStats]) -> list[str]:
    """What the logs' data make the fit assume (a log without turning, speeds from phases,
    current-only logs): a warning each, in the model's `warnings`."""
    warnings: list[str] = []
    if any(not s.has_turning for s in stats) and any(s.has_turning for s in stats):
        warnings.append(
            "some logs have no turning column: their windows count as driving straight, which "
            "biases the turning and rolling terms if those robots turned"
        )
    if any(s.speed_from_phases for s in stats):
        warnings.append(
            "the speed of step runs without a speed column is the trapezoid of their phases "
            "(constant acceleration, the paper's experiment), not a measurement"
        )
    proxies = sum(s.current_proxy for s in stats)
    if proxies:
        warnings.append(
            f"{proxies} of {len(stats)} log(s) {PROXY_WARNING} (voltage_assumed_V): "
            "their power is a nominal voltage times current, ~ torque, so the terms take their "
            "force form ('wbpower docs drive-model', 'Current-only logs'): each coefficient is a "
            "force (or moment) times the motors' no-load speed, rolling_W_per_mps is a constant "
            "force's [W], turning_coulomb_W a constant scrubbing moment's while turning [W] "
            "(a motor current holds no drivers' step: no drive_on_W), quadratic_W_per_mps2 a "
            "viscous force's "
            "[W/(m/s)], effective_mass_kg "
            "and braking_mass_kg multiply d|v|/dt [W/(m/s^2)], turning_Nm |yaw rate| "
            "[W/(rad/s)]; not the battery's power"
            + (
                "; mixed with power logs, their terms are not comparable"
                if proxies < len(stats)
                else ""
            )
        )
    return warnings


def _terms(
    fitted: Identified, surfaces: tuple[str, ...], *, force_form: bool = False
) -> tuple[dict[str, TermValue], dict[str, dict[str, TermValue]]]:
    """The shown terms of a fit with their 95 % intervals and units: the shared ones, and
    those of each named surface (`name[surface]` columns); a current proxy's in the force
    form's units (terms.py `FORCE_FORM_UNITS`: its effective_mass_kg is no mass)."""
    ci = fitted.ci95()
    named_surfaces = surfaces != (UNKNOWN_SURFACE,)
    terms: dict[str, TermValue] = {}
    per_surface: dict[str, dict[str, TermValue]] = {}
    for j, column in enumerate(fitted.columns):
        if not fitted.shown[j]:
            continue
        name, _, rest = column.partition("[")
        value = TermValue(
            float(fitted.coef[j]), (float(ci[j, 0]), float(ci[j, 1])), term_unit(name, force_form)
        )
        if rest and named_surfaces:
            per_surface.setdefault(rest[:-1], {})[name] = value
        else:
            terms[name] = value
    return terms, per_surface


__all__ = ["TERMS", "DriveModel", "TermValue", "fit_drive", "fit_drive_stats", "lag_said"]
