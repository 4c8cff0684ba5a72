"""What the paper's simulation gets wrong on measured logs, why, and how much a fix gains.

1. Every log is read, segmented and reduced to its per-run row (`runtable.run_row`) and
   trace statistics (`traces.trace_stats`): one run in memory at a time.
2. The baseline is the paper's model (Eq. 1-6) fitted to these logs; it simulates each run's
   motion energy from (speed, distance, steps, payload) alone.
3. Each named cause (the registry `causes.CAUSES`, shared/spec/causes.md) runs its evidence
   test on all runs. A cause is a candidate when its test is significant (p < 1e-3) and its
   estimated size is worth naming; it becomes a finding when adding it to the model also improves
   predictions of runs held out of the fit (>= 5% lower RMSE of run energy, or >= 10% on the
   cruise power trace for the ripple).
4. The extended model holds every finding; its gain is measured on held-out runs the same way,
   nested: for each fold, the causes are chosen again, and fitted, without that fold.
   Held-out means K-fold by run: a run is predicted by a model fitted without it.
5. A candidate is named only when every consequence check of its physics passes (each
   cause's `checks`, causes.md "How a cause earns its name"); one that would have predicted
   but fails a check is reported (`rejected`) and makes the result `unexplained`, as does
   structure left in the extended model's held-out errors (`unexplained_reasons`), rather
   than forcing a name. A fit the training folds cannot identify is "not estimable".
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes import (
    CAUSES,
    POWER_TRACE,
    RUN_ENERGY,
    Check,
    Evidence,
    RunTable,
)
from wifibot_power.causes.extended import (
    PREDICT_COLUMNS,
    NotEstimable,
    predict_columns_J,
    predict_motion_energy_J,
)
from wifibot_power.causes.extended import fit_model as _fit_model
from wifibot_power.causes.registry import ordered
from wifibot_power.errors import LogError
from wifibot_power.fit import TableColumns, segment_checked
from wifibot_power.io import LogSource, ReadOptions, Skipped
from wifibot_power.io.discover import reasons_in_brief
from wifibot_power.model import PowerModel
from wifibot_power.outputs import json_file, parquet_file, write_set
from wifibot_power.phases import Segmentation
from wifibot_power.pipeline import DIAGNOSE_PLAN, gather
from wifibot_power.pipeline.duplicates import ProblemHook
from wifibot_power.residuals import residual_table, structure_reasons
from wifibot_power.run import Run
from wifibot_power.runtable import (
    DOUBT_REASON,
    WindowEnergy,
    admit_doubtful,
    kept_in_doubt,
    run_row,
    runs_frame,
)
from wifibot_power.stats import spearman
from wifibot_power.traces import EMPTY, TraceStats, trace_stats

if TYPE_CHECKING:  # pandas (~0.3 s to import) loads where the tables are made, while
    import pandas as pd  # the workers read the logs (`diagnose_logs`)

    from wifibot_power.cache import ParseCache

#: Smallest held-out gain that makes a significant cause a finding [%].
MIN_GAIN_PCT = {"run_energy": 5.0, "power_trace": 10.0}
#: A gap longer than this between one run's end and the next's start ends a session [s].
SESSION_GAP_S = 30 * 60.0
FOLDS = 5
#: Fewest usable motion runs, and speeds, that causes can be chosen and checked on.
MIN_MOTION_RUNS = 6
MIN_SPEEDS = 2

Segmenter = Callable[[Run], Segmentation]

#: The fits made so far in the diagnosis under way (`diagnose_summaries`), by what they were
#: fitted on: forward selection, the held-out folds and the nested folds fit the same rows
#: with the same causes again and again (a third to a tenth of all fits)
_FITS: ContextVar[dict[tuple, PowerModel | NotEstimable] | None] = ContextVar("_FITS", default=None)


def fit_model(
    runs: pd.DataFrame, causes: Iterable[str] = (), *, strict: bool = False
) -> PowerModel:
    """`causes.extended.fit_model`, fitted once per rows (in their order), causes and
    `strict` within one diagnosis: the same fit of the same rows is the same model, and a
    fit the rows cannot identify raises `NotEstimable` each time it is asked for."""
    causes = ordered(causes)  # a list: the key and the fit both read it (an iterator once)
    return _fitted_once(
        lambda: (runs["file"].tolist(), runs["run_id"].tolist()),
        causes,
        strict,
        lambda: _fit_model(runs, causes, strict=strict),
    )


def _fitted_once(
    rows: Callable[[], tuple[list, list]],
    causes: Iterable[str],
    strict: bool,
    fit: Callable[[], PowerModel],
) -> PowerModel:
    """`fit()`, or what it gave (a model or `NotEstimable`) when the diagnosis under way
    fitted the same `rows` (their files and run ids, in order) with the same causes and
    `strict` before."""
    memo = _FITS.get()
    if memo is None:
        return fit()
    files, run_ids = rows()
    key = (tuple(files), tuple(run_ids), tuple(ordered(causes)), strict)
    if key not in memo:
        try:
            memo[key] = fit()
        except NotEstimable as exc:
            memo[key] = exc
    found = memo[key]
    if isinstance(found, NotEstimable):
        raise NotEstimable(str(found))
    return found


@dataclass(frozen=True, eq=False)
class RunSummary:
    row: dict[str, object]
    trace: TraceStats
    #: the statistics each cause's tests need (`Cause.run_columns`)
    cause_columns: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Finding:
    cause: str
    summary: str
    metric: str
    gain_pct: float
    p_value: float
    estimate: dict[str, object]
    checks: tuple[Check, ...] = ()

    def as_dict(self) -> dict[str, object]:
        return {
            "cause": self.cause,
            "summary": self.summary,
            "metric": self.metric,
            "gain_pct": self.gain_pct,
            "p_value": self.p_value,
            "estimate": self.estimate,
            "checks": [c.as_dict() for c in self.checks],
        }


@dataclass(frozen=True)
class Diagnosis:
    """The result of `diagnose`: a JSON summary (cli.md) plus the tables behind it."""

    n_runs: int
    baseline_model: PowerModel
    extended_model: PowerModel
    runs: pd.DataFrame  # a row per motion run: measured, baseline and extended energy
    findings: tuple[Finding, ...]
    evidence: tuple[Evidence, ...]
    baseline_rmse_J: float
    baseline_mape_pct: float
    extended_rmse_J: float
    extended_mape_pct: float
    #: the extended model's held-out RMSE with its causes chosen on all runs, only their fit
    #: held out (not nested; `extended_rmse_J` is): how much choosing on all runs flatters
    extended_fixed_rmse_J: float
    unexplained: bool
    unexplained_reasons: tuple[str, ...]
    patterns: dict[str, object]
    skipped: tuple[Skipped, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    baseline_label: str = "paper (Eq. 1-6) fitted to these logs"
    #: candidates that predicted but failed a consequence check (`rejected_candidates`)
    rejected: tuple[dict[str, object], ...] = ()
    #: every candidate's checks as last run, by cause
    candidate_checks: dict[str, list[Check]] = field(default_factory=dict)

    @property
    def gain_pct(self) -> float:
        return gain_pct(self.baseline_rmse_J, self.extended_rmse_J)

    def summary(self) -> dict[str, object]:
        """The `diagnose --json` document (cli.md)."""
        return {
            "n_runs": self.n_runs,
            "baseline": {
                "model": self.baseline_label,
                "heldout_rmse_J": self.baseline_rmse_J,
                "heldout_mape_pct": self.baseline_mape_pct,
            },
            "findings": [f.as_dict() for f in self.findings],
            "extended": {
                "causes": [f.cause for f in self.findings],
                "heldout_rmse_J": self.extended_rmse_J,
                "heldout_mape_pct": self.extended_mape_pct,
            },
            "gain_pct": self.gain_pct,
            "unexplained": self.unexplained,
            "unexplained_reasons": list(self.unexplained_reasons),
            "candidates": [
                {
                    **_evidence_dict(e),
                    "named": e.cause in {f.cause for f in self.findings},
                    "checks": [c.as_dict() for c in self.candidate_checks.get(e.cause, [])],
                }
                for e in self.evidence
            ],
            "rejected": list(self.rejected),
            "patterns": self.patterns,
            "notes": list(self.notes),
            "skipped": [s.as_dict() for s in self.skipped],
        }


def _evidence_dict(e: Evidence) -> dict[str, object]:
    return {
        "cause": e.cause,
        "testable": e.testable,
        "p_value": e.p_value,
        "estimate": e.estimate,
        "ci95": list(e.ci95),
        "significant": e.significant,
        "summary": e.summary,
    }


def gain_pct(baseline: float, extended: float) -> float:
    """100 × (1 − extended / baseline) (cli.md `gain_pct`)."""
    return 100.0 * (1.0 - extended / baseline) if baseline > 0 else 0.0


# -- reading ---------------------------------------------------------------------------
def summarize_run(run: Run, segmenter: Segmenter | None = None) -> RunSummary:
    """Segment a run and keep only its row and trace statistics."""
    if run.meta.mode != "motion":
        return RunSummary(run_row(run, Segmentation(run.meta.run_id, ())), EMPTY)
    return summarize_segmented(run, segment_checked(run, segmenter))


def summarize_segmented(run: Run, segmentation: Segmentation) -> RunSummary:
    """A segmented motion run's row, trace statistics and the statistics each cause's tests
    need (`Cause.run_columns`), with the phases' and windows' energies from one
    `runtable.WindowEnergy`: what `diagnose` and `report` keep of it."""
    energy = WindowEnergy(run)
    columns: dict[str, float] = {}
    for cause in CAUSES.values():
        columns.update(cause.run_columns(run, segmentation))
    return RunSummary(
        run_row(run, segmentation, energy), trace_stats(run, segmentation, energy), columns
    )


def diagnose_logs(
    paths: list[Path] | list[str],
    options: ReadOptions | None = None,
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    segmenter: Segmenter | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    reference: PowerModel | None = None,
    keep_doubtful: bool = False,
) -> Diagnosis:
    """Read, segment and summarise every log under `paths` (`pipeline.gather`, `jobs` files
    at a time, one file in memory per worker; `cache` skips parsing files parsed before),
    then diagnose them (module docstring). `reference`, `keep_doubtful`: see
    `diagnose_summaries`."""
    plan = DIAGNOSE_PLAN if segmenter is None else replace(DIAGNOSE_PLAN, segmenter=segmenter)
    gathered = gather(
        paths,
        options,
        plan,
        wrap=wrap,
        jobs=jobs,
        cache=cache,
        on_problems=on_problems,
        tables_after=True,  # the diagnosis after the workers makes tables
    )
    summaries = [
        RunSummary(r.row, EMPTY if r.trace is None else r.trace, r.causes) for r in gathered.records
    ]
    try:
        return diagnose_summaries(
            summaries, gathered.skipped, reference=reference, keep_doubtful=keep_doubtful
        )
    except LogError as exc:  # about the batch: named by what the user gave
        raise exc.with_file(", ".join(map(str, paths))) from None


def diagnose_runs(
    runs: Iterable[Run],
    *,
    segmenter: Segmenter | None = None,
    reference: PowerModel | None = None,
) -> Diagnosis:
    """Diagnose runs already in memory (e.g. simulated); same result as from their logs."""
    summaries = [summarize_run(run, segmenter) for run in runs]
    return diagnose_summaries(summaries, reference=reference)


# -- the diagnosis ---------------------------------------------------------------------
def session_clock(runs: pd.DataFrame) -> pd.DataFrame:
    """Motor-on minutes accumulated in the session before each run and at its middle.

    Runs are ordered by `started_at`; a gap of over 30 min ends a session (motors cool).
    Runs without `started_at` get NaN (thermal drift is then not testable)."""
    import pandas as pd

    runs = runs.copy()
    motion_s = np.where(
        runs["mode"] == "motion",
        runs["t_acc_s"].fillna(0) * runs["steps_found"]
        + runs["cruise_duration_s"].fillna(0)
        + runs["decel_duration_s"].fillna(0) * runs["steps_found"],
        0.0,
    )
    runs["motion_s"] = motion_s
    runs["tau_before_min"] = np.nan
    runs["tau_mid_min"] = np.nan
    runs["session_order"] = -1
    timed = runs["started_at"].notna()
    if not timed.any():
        return runs
    order = runs[timed].sort_values("started_at").index
    start = runs.loc[order, "started_at"]
    end = start + pd.to_timedelta(runs.loc[order, "duration_s"], unit="s")
    new_session = (start - end.shift()).dt.total_seconds().fillna(np.inf) > SESSION_GAP_S
    session = new_session.cumsum()
    before = runs.loc[order, "motion_s"].groupby(session).cumsum() - runs.loc[order, "motion_s"]
    runs.loc[order, "tau_before_min"] = before.to_numpy() / 60.0
    runs.loc[order, "tau_mid_min"] = (before + runs.loc[order, "motion_s"] / 2).to_numpy() / 60.0
    runs.loc[order, "session_order"] = np.arange(len(order))
    return runs


def assign_folds(run_ids: pd.Series, folds: int = FOLDS) -> np.ndarray:
    """K folds by run: a seeded permutation of the sorted run ids, dealt round-robin."""
    k = max(2, min(folds, len(run_ids)))
    order = np.argsort(np.argsort(run_ids.to_numpy().astype(str)))
    permuted = np.random.default_rng(0).permutation(len(run_ids))[order]
    return permuted % k


def heldout_folds(motion: pd.DataFrame, folds: int = FOLDS) -> np.ndarray | str:
    """K folds by run (`assign_folds`) such that the runs left without any one fold span 2
    or more speeds (so the paper's lines can be fitted to predict it); when the plain deal
    does not give that, runs are dealt round-robin within each speed. The reason, when no
    deal can."""
    speed = motion["speed_mps"].to_numpy(np.float64)

    def ok(assigned: np.ndarray) -> bool:
        return all(np.unique(speed[assigned != k]).size >= 2 for k in np.unique(assigned))

    plain = assign_folds(motion["run_id"], folds)
    if ok(plain):
        return plain
    k = int(plain.max()) + 1
    order = np.lexsort((plain, speed))  # by speed, then by the plain deal
    stratified = np.empty(len(speed), dtype=plain.dtype)
    stratified[order] = np.arange(len(speed)) % k
    if ok(stratified):
        return stratified
    k = next(k for k in np.unique(stratified) if np.unique(speed[stratified != k]).size < 2)
    rest_speeds = np.unique(speed[stratified != k])
    out = ", ".join(f"{v:g}" for v in np.setdiff1d(speed[stratified == k], rest_speeds))
    rest = ", ".join(f"{v:g}" for v in rest_speeds)
    return (
        f"runs at {out} m/s cannot be predicted held out: without them every other run is at "
        f"{rest} m/s"
    )


def _missing_data(motion: pd.DataFrame) -> str:
    """One line saying which runs are missing for held-out prediction."""
    counts = motion["speed_mps"].value_counts().sort_index()
    have = ", ".join(f"{n} at {v:g} m/s" for v, n in counts.items())
    return (
        f"add runs so that 2 or more speeds have 2 or more runs each (a line needs 2 "
        f"speeds, and diagnose holds runs out); these logs have {have}"
    )


class HeldOut:
    """A deal of the motion runs into held-out folds, and the runs each fold's model is
    fitted on: the runs of other modes, then the motion runs of the other folds (`train`:
    `pd.concat([others, motion[folds != k]])`, index and all). The two tables are stacked
    once, and the columns the paper's lines and the predictions read are read once from
    them: a fold's fit of the lines alone (most fits) and its prediction select rows of
    those arrays by position, and only a fit with causes makes the fold's table."""

    def __init__(self, all_runs: pd.DataFrame, motion: pd.DataFrame, folds: np.ndarray) -> None:
        import pandas as pd

        others = all_runs[all_runs["mode"].to_numpy() != "motion"]
        self.motion, self.folds = motion, folds
        self.table = pd.concat([others, motion])
        self.columns = TableColumns(self.table)
        self.files = self.table["file"].to_numpy(dtype=object)
        self.run_ids = self.table["run_id"].to_numpy(dtype=object)
        self.predictors = {c: motion[c].to_numpy() for c in PREDICT_COLUMNS}
        self._others = np.arange(len(others))

    def __iter__(self) -> Iterator[int]:
        return iter(np.unique(self.folds).tolist())

    def train_rows(self, k: int) -> np.ndarray:
        return np.concatenate([self._others, self._others.size + np.flatnonzero(self.folds != k)])

    def train(self, k: int) -> pd.DataFrame:
        """The runs fold `k`'s model is fitted on."""
        return self.table.take(self.train_rows(k))

    def held(self, k: int) -> pd.DataFrame:
        """The runs of fold `k` (`motion[folds == k]`)."""
        return self.motion.take(np.flatnonzero(self.folds == k))

    def fit(self, k: int, causes: list[str], *, strict: bool = False) -> PowerModel:
        """`fit_model(self.train(k), causes, strict=strict)`."""
        rows = self.train_rows(k)
        if causes or strict:
            fit = lambda: _fit_model(self.table.take(rows), causes, strict=strict)  # noqa: E731
        else:  # the paper's lines alone, all `_fit_model` fits then
            fit = lambda: self.columns.model(rows)  # noqa: E731
        return _fitted_once(
            lambda: (self.files[rows].tolist(), self.run_ids[rows].tolist()), causes, strict, fit
        )

    def predict(self, model: PowerModel, k: int) -> np.ndarray:
        """`predict_motion_energy_J(model, self.held(k))`."""
        held = np.flatnonzero(self.folds == k)
        return predict_columns_J(model, {c: v[held] for c, v in self.predictors.items()})


def heldout_energy_J(
    all_runs: pd.DataFrame,
    motion: pd.DataFrame,
    folds: np.ndarray,
    causes: Iterable[str],
    *,
    strict: bool = False,
) -> np.ndarray:
    """Motion energy of each motion run predicted by a model fitted without its fold.
    `strict`: raise `NotEstimable` when a fold's training runs cannot identify the model,
    or its prediction is not a finite, positive energy."""
    causes = list(causes)
    predicted = np.full(len(motion), np.nan)
    deal = HeldOut(all_runs, motion, folds)
    for k in deal:
        try:
            model = deal.fit(k, causes, strict=strict)
        except NotEstimable as exc:
            raise NotEstimable(f"without held-out fold {k}, {exc}") from None
        predicted[folds == k] = deal.predict(model, k)
    if strict and not (np.isfinite(predicted).all() and (predicted > 0).all()):
        raise NotEstimable("a held-out prediction is not a finite, positive energy")
    return predicted


@dataclass
class Selection:
    """What forward selection saw, beyond its choice: the checks of every candidate as last
    run, the held-out gain each candidate would have given when last tried [%] (None: not
    estimable), and why a trial could not be estimated."""

    checks: dict[str, list[Check]] = field(default_factory=dict)
    gains: dict[str, float | None] = field(default_factory=dict)
    not_estimable: dict[str, str] = field(default_factory=dict)


def select_causes(
    runs: pd.DataFrame,
    motion: pd.DataFrame,
    folds: np.ndarray,
    measured: np.ndarray,
    baseline_rmse: float,
    blocks: dict[str, tuple[np.ndarray, float]],
    notes: list[str],
    seen: Selection | None = None,
) -> tuple[dict[str, float], dict[frozenset, float], tuple[Evidence, ...]]:
    """Forward selection on held-out error. At each round every cause not yet in the model
    runs its evidence test on top of the model holding the causes found so far; a cause
    whose signature passes and whose consequence checks all pass is eligible (when none
    is, each passing candidate's checks are run again beside the other candidates: two
    causes at once each leave structure where the other's checks look), and the
    eligible one that lowers the held-out RMSE of run energy most is added, while it lowers
    it by >= 5%. Trace causes are judged on their held-out trace gain. A trial whose fit
    the training folds cannot identify is "not estimable", never a number.
    Returns {cause: gain when added [%]}, the RMSE of every cause set tried, and the
    evidence of every cause as last tested; `seen` (if given) is filled with the checks
    and gains behind the choice (`Selection`)."""
    seen = seen if seen is not None else Selection()
    selected: dict[str, float] = {}
    rmse_of: dict[frozenset, float] = {frozenset(): baseline_rmse}
    latest: dict[str, Evidence] = {}
    base_model = fit_model(runs)
    for name, cause in CAUSES.items():  # trace causes: judged on their held-out trace gain
        if cause.metric != POWER_TRACE:
            continue
        table = RunTable(motion, base_model)
        latest[name] = e = cause.evidence(table)
        if not e.passes:
            continue
        gain = cause.heldout_trace_gain_pct(motion, folds, blocks)
        seen.gains[name] = gain
        seen.checks[name] = cause.checks(table, e)
        if gain < MIN_GAIN_PCT[POWER_TRACE]:
            notes.append(
                f"{name}: significant (p = {e.p_value:.2g}) but held-out "
                f"trace gain {gain:.1f}% is below {MIN_GAIN_PCT[POWER_TRACE]:g}%"
            )
        elif all(c.passed for c in seen.checks[name]):
            selected[name] = gain
    current: tuple[str, ...] = ()
    energy_causes = [c for c in CAUSES if CAUSES[c].metric == RUN_ENERGY]
    while True:
        model = fit_model(runs, current)
        table = RunTable(motion, model, current)
        for cause in energy_causes:
            if cause not in current:
                latest[cause] = CAUSES[cause].evidence(table)
        passing = [c for c in energy_causes if c not in current and latest[c].passes]
        if not passing:
            break
        now = rmse_of[frozenset(current)]
        for cause in passing:
            trial = frozenset(current) | {cause}
            if trial not in rmse_of:
                try:
                    pred = heldout_energy_J(runs, motion, folds, sorted(trial), strict=True)
                    rmse_of[trial] = _rmse_mape(measured, pred)[0]
                except NotEstimable as exc:
                    rmse_of[trial] = float("nan")
                    seen.not_estimable[cause] = str(exc)
            seen.checks[cause] = CAUSES[cause].checks(table, latest[cause])
            rmse = rmse_of[trial]
            seen.gains[cause] = gain_pct(now, rmse) if np.isfinite(rmse) else None
        estimable = [c for c in passing if np.isfinite(rmse_of[frozenset(current) | {c}])]
        eligible = [c for c in estimable if all(ch.passed for ch in seen.checks[c])]
        if not eligible and len(estimable) > 1:
            # two causes at once each leave the other's structure in the view where the
            # other's checks look: check each beside the other candidates
            for cause in estimable:
                beside = (*current, *(c for c in estimable if c != cause))
                joint = RunTable(motion, fit_model(runs, beside), beside)
                e = CAUSES[cause].evidence(joint)
                checks = CAUSES[cause].checks(joint, e)
                if e.passes and all(ch.passed for ch in checks):
                    seen.checks[cause] = checks
                    eligible.append(cause)
        for cause in passing:
            if cause not in estimable:
                notes.append(
                    f"{cause}: significant (p = {latest[cause].p_value:.2g}) but its held-out "
                    f"gain is not estimable ({seen.not_estimable.get(cause, '')}): not named"
                )
        if not eligible:
            break
        best = min(eligible, key=lambda c: rmse_of[frozenset(current) | {c}])
        gain = gain_pct(now, rmse_of[frozenset(current) | {best}])
        if gain < MIN_GAIN_PCT[RUN_ENERGY]:
            for cause in eligible:
                notes.append(
                    f"{cause}: significant (p = {latest[cause].p_value:.2g}) but adding "
                    f"it gains {seen.gains[cause]:.1f}% held out "
                    f"(< {MIN_GAIN_PCT[RUN_ENERGY]:g}%): not named"
                )
            break
        selected[best] = gain
        current = (*current, best)
    for cause, e in latest.items():
        if cause not in selected and e.significant and not e.passes and e.estimate > 0:
            notes.append(
                f"{cause}: significant (p = {e.p_value:.2g}) but its size {e.estimate:.3g} "
                f"{CAUSES[cause].unit} is below {CAUSES[cause].min_size:g}: not named"
            )
    evidence = tuple(latest[c] for c in CAUSES)
    return selected, rmse_of, evidence


def rejected_candidates(
    evidence: tuple[Evidence, ...], named: list[str], seen: Selection
) -> list[dict[str, object]]:
    """Candidates whose signature is there, at a size worth naming, that would have predicted
    but fail a consequence of their physics: not named, and structure no name explains
    (causes.md, "How a cause earns its name")."""
    out = []
    for e in evidence:
        if e.cause in named or not e.passes or e.cause not in seen.checks:
            continue
        failed = [c for c in seen.checks[e.cause] if not c.passed]
        if not failed:
            continue
        gain = seen.gains.get(e.cause)
        metric = CAUSES[e.cause].metric
        would = (
            f"would have lowered the held-out error of {metric.replace('_', ' ')} by {gain:.1f}%"
            if gain is not None
            else "its held-out gain is not estimable"
        )
        out.append(
            {
                "cause": e.cause,
                "gain_pct": gain,
                "failed": [c.check for c in failed],
                "reason": f"{e.cause}: its signature is there ({e.summary}, p = "
                f"{e.p_value:.2g}) and it {would}, but "
                + "; ".join(f"'{c.check}' fails: {c.detail}" for c in failed)
                + ": not named",
            }
        )
    return out


def nested_heldout_energy_J(
    runs: pd.DataFrame,
    motion: pd.DataFrame,
    folds: np.ndarray,
    blocks: dict[str, tuple[np.ndarray, float]],
    causes: list[str],
    notes: list[str],
) -> np.ndarray:
    """Motion energy of each motion run predicted by a model whose causes were chosen, as
    well as fitted, without its fold (nested cross-validation): `select_causes` is run again
    on the other folds, with folds of its own. So the extended model's held-out error is not
    flattered by having chosen its causes on the runs it then predicts. A fold whose
    choice differs from `causes` (the findings, chosen on all runs) is noted; one whose
    training runs are too few to choose from (`enough_to_choose`) uses `causes`."""
    import pandas as pd

    others = runs[runs["mode"] != "motion"]
    predicted = np.full(len(motion), np.nan)
    for k in np.unique(folds):
        train_motion = motion[folds != k].reset_index(drop=True)
        train = pd.concat([others, train_motion])
        chosen = causes
        inner_folds = heldout_folds(train_motion) if enough_to_choose(train_motion) else ""
        if not isinstance(inner_folds, str):
            inner_measured = train_motion["motion_energy_J"].to_numpy(np.float64)
            inner_pred = heldout_energy_J(train, train_motion, inner_folds, [])
            selected, _, _ = select_causes(
                train,
                train_motion,
                inner_folds,
                inner_measured,
                _rmse_mape(inner_measured, inner_pred)[0],
                blocks,
                [],
            )
            chosen = list(selected)
        else:
            notes.append(
                f"held-out fold {k}: too few runs without it to choose causes; the findings' "
                "causes are used for it"
            )
        if sorted(chosen) != sorted(causes):
            notes.append(
                f"held-out fold {k}: the causes chosen without its {np.sum(folds == k)} runs "
                f"are {sorted(chosen) or 'none'}, not the findings {sorted(causes) or 'none'}"
            )
        model = fit_model(train, chosen)
        predicted[folds == k] = predict_motion_energy_J(model, motion[folds == k])
    return predicted


def _rmse_mape(measured: np.ndarray, predicted: np.ndarray) -> tuple[float, float]:
    error = predicted - measured
    return float(np.sqrt(np.mean(error**2))), float(100 * np.mean(np.abs(error) / measured))


def _check_estimable(model: PowerModel, motion: pd.DataFrame) -> None:
    """A one-line error when the paper-form lines cannot be fitted to these runs: held out,
    every prediction would be NaN, and the diagnosis would print RMSE nan and a gain of 0%
    (found on REGBOT logs whose steps speed up and stop with no cruise between)."""
    lines = {
        "P_acc(v) (acceleration phases)": (model.accel, "accel_mean_power_W"),
        "P_v(v) (cruise phases)": (model.cruise, "cruise_mean_power_W"),
    }
    for name, (line, column) in lines.items():
        if np.isfinite(line.intercept) and np.isfinite(line.slope):
            continue
        having = int(np.isfinite(motion[column].to_numpy(np.float64)).sum())
        raise LogError(
            f"the paper's model cannot be fitted to these runs: {name} not estimable "
            f"({having} of {len(motion)} usable motion runs have such a phase)",
            fix="diagnose needs motion runs with acceleration and cruise phases at 2 or more "
            "speeds (see 'wbpower segment FILE' for a run's phases)",
        )


def enough_to_choose(motion: pd.DataFrame) -> bool:
    """Whether these motion runs are enough to choose causes on."""
    return len(motion) >= MIN_MOTION_RUNS and motion["speed_mps"].nunique() >= MIN_SPEEDS


def motion_runs(runs: pd.DataFrame) -> pd.DataFrame:
    """The usable motion runs, in run_id order (the order `assign_folds` deals folds in)."""
    usable = runs[runs["usable"]]
    return usable[usable["mode"] == "motion"].sort_values("run_id").reset_index(drop=True)


def summary_table(summaries: list[RunSummary]) -> pd.DataFrame:
    """One row per run: its run-table row, trace statistics and place in its session."""
    import pandas as pd

    runs = runs_frame([s.row for s in summaries])
    traces = pd.DataFrame([s.trace.as_row() for s in summaries], index=runs.index)
    extra = pd.DataFrame([s.cause_columns for s in summaries], index=runs.index)
    table = session_clock(pd.concat([runs, traces, extra], axis=1))
    # text as Python objects in one block: the held-out folds select rows of this table
    # hundreds of times, and each Arrow-backed text column is a take of its own
    text = [c for c in table.columns if isinstance(table[c].dtype, pd.StringDtype)]
    return table.astype(dict.fromkeys(text, object)).copy()


def diagnose_summaries(
    summaries: list[RunSummary],
    skipped: Iterable[Skipped] = (),
    *,
    reference: PowerModel | None = None,
    keep_doubtful: bool = False,
) -> Diagnosis:
    """The diagnosis of summarised runs (module docstring).

    Runs whose segmentation is in doubt are left out (listed in `skipped` with the doubt)
    unless `keep_doubtful` (`runtable.admit_doubtful`), which the first of `notes` then
    says (`runtable.kept_in_doubt`).

    With a `reference` model (`diagnose --model`: e.g. the robot's stored model.json, or
    the paper's), the baseline is that model as given, predicting every run; it is not
    refitted, so nothing is held out for it. Causes are still found, and the extended model
    fitted, on these logs with held-out runs; gain_pct then says how much better than the
    reference the extended model predicts runs it has not seen.
    """
    token = _FITS.set({})
    try:
        return _diagnose(summaries, skipped, reference=reference, keep_doubtful=keep_doubtful)
    finally:
        _FITS.reset(token)


def _check_one_run_per_run_id(summaries: list[RunSummary]) -> None:
    """Raise when two runs have one run_id: their traces would be one (the later's), and
    they would share a fold. A batch of logs never has them (`map_runs` gives path run_ids
    to logs named alike and leaves out a log that claims another's run_id); runs given in
    memory (`diagnose_runs`) can."""
    file_of: dict[str, str] = {}
    for summary in summaries:
        run_id, file = str(summary.row["run_id"]), str(summary.row["file"])
        if run_id in file_of:
            raise LogError(
                f"two runs have the run_id '{run_id}' ({file_of[run_id]} and {file})",
                fix="give each run its own run_id",
            )
        file_of[run_id] = file


def _diagnose(
    summaries: list[RunSummary],
    skipped: Iterable[Skipped],
    *,
    reference: PowerModel | None,
    keep_doubtful: bool,
) -> Diagnosis:
    skipped = list(skipped)
    if not summaries:
        raise LogError(
            "no readable logs",
            fix="each input left out is listed with its own reason",
            skipped=skipped,
        )
    in_doubt = kept_in_doubt([s.row for s in summaries]) if keep_doubtful else None
    if keep_doubtful:
        summaries = [RunSummary(admit_doubtful(s.row), s.trace, s.cause_columns) for s in summaries]
    runs = summary_table(summaries)
    # per-run data is keyed by run_id (here, the folds, the causes' evidence): one run each
    _check_one_run_per_run_id(summaries)
    blocks = {s.row["run_id"]: (s.trace.cruise_blocks_W, s.trace.block_s) for s in summaries}
    for row in runs[~runs["usable"]].itertuples():
        skipped.append(Skipped(str(row.file), f"{row.file}: {row.skip_reason}"))
    doubted = doubted_motion_reason(runs)
    runs = runs[runs["usable"]]
    motion = motion_runs(runs)
    if not enough_to_choose(motion):
        # what left the other inputs out (unreadable, refused, unusable, doubted), most
        # common first: the CLI shows no 'skipped' lines when the batch fails
        doubted_runs = [s for s in skipped if s.why.startswith(DOUBT_REASON)]
        others = [s for s in skipped if not s.why.startswith(DOUBT_REASON)]
        raise LogError(
            f"{len(motion)} usable motion run(s) at {motion['speed_mps'].nunique()} speed(s)"
            + (
                f"; {len(doubted_runs)} more left out for segmentation doubts (first: "
                f"{doubted_runs[0].reason})"
                if doubted_runs
                else ""
            )
            + (f"; left out: {reasons_in_brief(others)}" if others else ""),
            fix=f"diagnose needs at least {MIN_MOTION_RUNS} motion runs at {MIN_SPEEDS} or "
            "more speeds" + (" (--keep-doubtful uses the doubted runs)" if doubted_runs else ""),
            skipped=skipped,
        )
    notes: list[str] = [in_doubt] if in_doubt else []  # said first (cli.md: never as sound)
    baseline_model = fit_model(runs)
    _check_estimable(baseline_model, motion)
    folds = heldout_folds(motion)
    if isinstance(folds, str):
        raise LogError(folds, fix=_missing_data(motion))
    measured = motion["motion_energy_J"].to_numpy(np.float64)
    refit_pred = heldout_energy_J(runs, motion, folds, [])
    refit_rmse, _ = _rmse_mape(measured, refit_pred)
    if reference is None:
        baseline_pred = refit_pred
    else:
        baseline_model = reference
        baseline_pred = predict_motion_energy_J(reference, motion)
    baseline_rmse, baseline_mape = _rmse_mape(measured, baseline_pred)

    # causes are selected against the paper-form model refitted to these logs, whatever
    # the reported baseline is
    seen = Selection()
    selected, energy_rmse, evidence = select_causes(
        runs, motion, folds, measured, refit_rmse, blocks, notes, seen
    )
    causes = list(selected)
    # the extended model's held-out error: causes chosen and fitted without the run's fold
    extended_pred = nested_heldout_energy_J(runs, motion, folds, blocks, causes, notes)
    extended_rmse, extended_mape = _rmse_mape(measured, extended_pred)
    # a finding's own gain compares like with like: the findings' causes held fixed, with and
    # without it (both fitted without the run's fold, both chosen on all runs). Selection
    # tried those sets already; keyed by energy causes only, since the ripple adds no energy
    # (energy.cruise_ripple_energy_J)
    energy_causes = frozenset(c for c in causes if CAUSES[c].metric == RUN_ENERGY)
    fixed_rmse = energy_rmse[energy_causes]
    extended_model = fit_model(runs, causes)
    findings = []
    for e in evidence:
        if e.cause not in selected:
            continue
        cause = CAUSES[e.cause]
        others = tuple(c for c in causes if c != e.cause and CAUSES[c].metric == RUN_ENERGY)
        final_table = RunTable(motion, extended_model, others)
        if cause.metric == RUN_ENERGY:
            # its estimate within the extended model, so it is the value model.json carries
            e = cause.evidence(final_table)
            # its own gain: how much worse the extended model predicts without it
            without = energy_rmse.get(energy_causes - {e.cause})
            if without is None:
                pred = heldout_energy_J(runs, motion, folds, [c for c in causes if c != e.cause])
                without = _rmse_mape(measured, pred)[0]
            gain = gain_pct(without, fixed_rmse)
        else:
            gain = selected[e.cause]
        checks = tuple(cause.checks(final_table, e))
        seen.checks[e.cause] = list(checks)
        findings.append(
            Finding(
                e.cause,
                f"{e.summary} ({cause.signature}, p = {e.p_value:.2g})",
                cause.metric,
                float(gain),
                e.p_value,
                {
                    "parameter": cause.parameter,
                    "value": e.estimate,
                    "ci95": list(e.ci95),
                    "unit": cause.unit,
                    **{k: v for k, v in e.parameters.items() if k != cause.parameter},
                },
                checks,
            )
        )

    table = motion[
        [
            "run_id",
            "file",
            "speed_mps",
            "commanded_speed_mps",
            "distance_m",
            "steps",
            "payload_kg",
            "session_order",
            "tau_before_min",
            # the cruise spectrum's peak of each run: the ripple's evidence, for its figure
            "ripple_hz",
            "ripple_amplitude_W",
            "ripple_p_value",
            "ripple_cruise_s",
        ]
    ].copy()
    table["fold"] = folds
    table["measured_energy_J"] = measured
    table["baseline_energy_J"] = baseline_pred
    table["extended_energy_J"] = extended_pred
    table["baseline_error_pct"] = 100 * (baseline_pred - measured) / measured
    table["extended_error_pct"] = 100 * (extended_pred - measured) / measured
    rejected = rejected_candidates(evidence, causes, seen)
    reasons = unexplained_reasons(table) + [r["reason"] for r in rejected]
    if doubted:
        reasons.append(doubted)
    for r in rejected:
        notes.append(str(r["reason"]))
    return Diagnosis(
        n_runs=len(motion),
        baseline_model=baseline_model,
        extended_model=extended_model,
        runs=table,
        findings=tuple(findings),
        evidence=evidence,
        baseline_rmse_J=baseline_rmse,
        baseline_mape_pct=baseline_mape,
        extended_rmse_J=extended_rmse,
        extended_mape_pct=extended_mape,
        extended_fixed_rmse_J=fixed_rmse,
        unexplained=bool(reasons),
        unexplained_reasons=tuple(reasons),
        rejected=tuple(rejected),
        candidate_checks=dict(seen.checks),
        patterns=error_patterns(table),
        skipped=tuple(skipped),
        notes=tuple(notes),
        baseline_label=(
            "paper (Eq. 1-6) fitted to these logs"
            if reference is None
            else f"the given model ({reference.source}), not refitted"
        ),
    )


COVARIATES = {
    "speed_mps": "speed",
    "steps": "step count",
    "distance_m": "distance",
    "payload_kg": "payload",
    "session_order": "session order",
}


def error_patterns(table: pd.DataFrame) -> dict[str, object]:
    """How the baseline's held-out error goes with each covariate (Spearman rank correlation)."""
    out: dict[str, object] = {}
    for column, label in COVARIATES.items():
        x = table[column].to_numpy(np.float64)
        if np.unique(x).size < 2:
            continue
        for model in ("baseline", "extended"):
            rho, p = spearman(x, table[f"{model}_error_pct"].to_numpy(np.float64))
            out[f"{model}_error_vs_{column}"] = {
                "label": label,
                "spearman_rho": float(rho),
                "p_value": float(p),
            }
    return out


def _doubted_motion(runs: pd.DataFrame) -> pd.DataFrame:
    """The motion runs left out only for their segmentation's doubts."""
    return runs[
        (runs["mode"] == "motion")
        & ~runs["usable"]
        & runs["skip_reason"].astype(str).str.startswith(DOUBT_REASON)
    ]


def doubted_motion_reason(runs: pd.DataFrame) -> str | None:
    """Why runs left out for their segmentation's doubts are themselves unexplained
    structure, or None when there are none: their traces do not fit the phase model (a
    power step inside a cruise, a second level, a burst), so what happens in them is, by
    construction, something the model does not describe (causes.md, "Unexplained"). Leaving
    them out silently would make a batch with an intermittent fault look explained."""
    doubted = _doubted_motion(runs)
    if doubted.empty:
        return None
    n_motion = int((runs["mode"] == "motion").sum())
    names = ", ".join(map(str, doubted["run_id"].head(5)))
    more = f" and {len(doubted) - 5} more" if len(doubted) > 5 else ""
    return (
        f"{len(doubted)} of {n_motion} motion runs were left out because their traces do not "
        f"fit the phase model ({names}{more}; each one's doubt is in 'skipped'): what happens "
        "in them is not in the model (--keep-doubtful diagnoses them anyway)"
    )


def unexplained_reasons(table: pd.DataFrame) -> list[str]:
    """Structure the named causes leave in the held-out errors of the extended model
    (`table`: a row per motion run with its measured and extended energies), judged against
    the spread of repeated runs (`residuals.py`, causes.md "Unexplained"). (Candidates
    rejected by their checks, and runs left out for doubts, are reported apart.)"""
    return structure_reasons(replication_table(table, "extended_energy_J"))


def replication_table(table: pd.DataFrame, predicted: str) -> pd.DataFrame:
    """`residuals.residual_table` of a diagnosis's per-run table (`Diagnosis.runs`) for the
    prediction in column `predicted` (the extended or the baseline energy). A run's
    configuration speed is its commanded one where the metadata gives it: with a speed
    column, runs of one commanded speed measure slightly different speeds, which would
    never repeat."""
    keys = table[["speed_mps", "distance_m", "steps", "payload_kg", "session_order"]].copy()
    commanded = table["commanded_speed_mps"].to_numpy(np.float64)
    keys["speed_mps"] = np.where(np.isfinite(commanded), commanded, keys["speed_mps"])
    return residual_table(
        table["run_id"].to_numpy(),
        table["measured_energy_J"].to_numpy(),
        table[predicted].to_numpy(),
        keys,
    )


def write_diagnosis(result: Diagnosis, out_dir: Path) -> list[Path]:
    """`diagnose -o DIR`: discrepancy.parquet, findings.json, model.json, written as one set
    (`outputs.write_set`: all new, or all as they were; cli.md: "writes nothing partial")."""
    files = {
        "discrepancy.parquet": parquet_file(result.runs),
        "findings.json": json_file(result.summary()),
        "model.json": json_file(result.extended_model.to_json()),
    }
    return write_set(Path(out_dir), files)
