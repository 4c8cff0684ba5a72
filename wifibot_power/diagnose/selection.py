"""The choice of causes: forward selection on held-out error (`select_causes`), the
candidates a consequence check rejects (`rejected_candidates`), and the extended model's
held-out error with its causes chosen again without each fold (`nested_heldout_energy_J`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes import CAUSES, RUN_ENERGY, Check, Evidence, RunTable
from wifibot_power.diagnose.extended import NotEstimable, predict_motion_energy_J
from wifibot_power.diagnose.folds import (
    Batch,
    enough_to_choose,
    gain_pct,
    heldout_folds,
    rmse_mape,
)
from wifibot_power.diagnose.result import FOLD, NOT_NAMED, Note

if TYPE_CHECKING:
    from wifibot_power.model import PowerModel

#: Smallest held-out gain that makes a significant cause a finding [%].
MIN_GAIN_PCT = {"run_energy": 5.0, "power_trace": 10.0}


@dataclass
class Selection:
    """What forward selection chose and saw: {cause: held-out gain when added [%]}, the
    held-out RMSE of every cause set tried [J], the evidence of every cause as last tested
    (registry order), the checks of every candidate as last run, the held-out gain each
    candidate would have given when last tried [%] (None: not estimable), why a trial could
    not be estimated, and the notes on candidates not named."""

    selected: dict[str, float] = field(default_factory=dict)
    rmse_of: dict[frozenset, float] = field(default_factory=dict)
    evidence: tuple[Evidence, ...] = ()
    checks: dict[str, list[Check]] = field(default_factory=dict)
    gains: dict[str, float | None] = field(default_factory=dict)
    not_estimable: dict[str, str] = field(default_factory=dict)
    notes: list[Note] = field(default_factory=list)


def select_causes(batch: Batch, baseline_rmse: float) -> Selection:
    """Forward selection on held-out error. At each round every cause not yet in the model
    runs its evidence test on top of the model holding the causes found so far; a cause
    whose signature passes and whose consequence checks all pass is eligible (when none
    is, each passing candidate's checks are run again beside the other candidates: two
    causes at once each leave structure where the other's checks look), and the
    eligible one that lowers the held-out RMSE of run energy most is added, while it lowers
    it by >= 5%. Trace causes are judged on their held-out trace gain. A trial whose fit
    the training folds cannot identify is "not estimable", never a number. `baseline_rmse`:
    the held-out RMSE of the paper's lines alone [J]."""
    seen = Selection(rmse_of={frozenset(): baseline_rmse})
    latest: dict[str, Evidence] = {}
    _trace_causes(batch, seen, latest)
    current: tuple[str, ...] = ()
    while True:
        best = _energy_round(batch, seen, latest, current)
        if best is None:
            break
        current = (*current, best)
    for cause, e in latest.items():
        if cause not in seen.selected and e.significant and not e.passes and e.estimate > 0:
            seen.notes.append(
                Note(
                    NOT_NAMED,
                    f"{cause}: significant (p = {e.p_value:.2g}) but its size "
                    f"{e.estimate:.3g} {CAUSES[cause].unit} is below "
                    f"{CAUSES[cause].min_size:g}: not named",
                )
            )
    seen.evidence = tuple(latest[c] for c in CAUSES)
    return seen


def _trace_causes(batch: Batch, seen: Selection, latest: dict[str, Evidence]) -> None:
    """The causes measured on something else than run energy (the power trace): each chosen
    alone on its own held-out gain (`Cause.heldout_trace_gain_pct`), given its trace data."""
    base_model = batch.fit()
    for name, cause in CAUSES.items():
        if cause.metric == RUN_ENERGY:
            continue
        table = RunTable(batch.motion, base_model)
        latest[name] = e = cause.evidence(table)
        if not e.passes:
            continue
        gain = cause.heldout_trace_gain_pct(batch.motion, batch.folds, batch.traces.get(name, {}))
        seen.gains[name] = gain
        seen.checks[name] = cause.checks(table, e)
        if gain < MIN_GAIN_PCT[cause.metric]:
            seen.notes.append(
                Note(
                    NOT_NAMED,
                    f"{name}: significant (p = {e.p_value:.2g}) but held-out "
                    f"trace gain {gain:.1f}% is below {MIN_GAIN_PCT[cause.metric]:g}%",
                )
            )
        elif all(c.passed for c in seen.checks[name]):
            seen.selected[name] = gain


def _energy_round(
    batch: Batch, seen: Selection, latest: dict[str, Evidence], current: tuple[str, ...]
) -> str | None:
    """One round of forward selection among the energy causes on top of `current`: the
    cause added (in `seen.selected`), or None when none is."""
    energy_causes = [c for c in CAUSES if CAUSES[c].metric == RUN_ENERGY]
    table = RunTable(batch.motion, batch.fit(current), current)
    for cause in energy_causes:
        if cause not in current:
            latest[cause] = CAUSES[cause].evidence(table)
    passing = [c for c in energy_causes if c not in current and latest[c].passes]
    if not passing:
        return None
    now = seen.rmse_of[frozenset(current)]
    for cause in passing:
        trial = frozenset(current) | {cause}
        if trial not in seen.rmse_of:
            try:
                seen.rmse_of[trial] = batch.heldout_rmse_J(sorted(trial), strict=True)
            except NotEstimable as exc:
                seen.rmse_of[trial] = float("nan")
                seen.not_estimable[cause] = str(exc)
        seen.checks[cause] = CAUSES[cause].checks(table, latest[cause])
        rmse = seen.rmse_of[trial]
        seen.gains[cause] = gain_pct(now, rmse) if np.isfinite(rmse) else None
    estimable = [c for c in passing if np.isfinite(seen.rmse_of[frozenset(current) | {c}])]
    eligible = [c for c in estimable if all(ch.passed for ch in seen.checks[c])]
    if not eligible and len(estimable) > 1:
        eligible = _eligible_beside_others(batch, seen, current, estimable)
    for cause in passing:
        if cause not in estimable:
            seen.notes.append(
                Note(
                    NOT_NAMED,
                    f"{cause}: significant (p = {latest[cause].p_value:.2g}) but its held-out "
                    f"gain is not estimable ({seen.not_estimable.get(cause, '')}): not named",
                )
            )
    if not eligible:
        return None
    best = min(eligible, key=lambda c: seen.rmse_of[frozenset(current) | {c}])
    gain = gain_pct(now, seen.rmse_of[frozenset(current) | {best}])
    if gain < MIN_GAIN_PCT[RUN_ENERGY]:
        for cause in eligible:
            seen.notes.append(
                Note(
                    NOT_NAMED,
                    f"{cause}: significant (p = {latest[cause].p_value:.2g}) but adding "
                    f"it gains {seen.gains[cause]:.1f}% held out "
                    f"(< {MIN_GAIN_PCT[RUN_ENERGY]:g}%): not named",
                )
            )
        return None
    seen.selected[best] = gain
    return best


def _eligible_beside_others(
    batch: Batch, seen: Selection, current: tuple[str, ...], estimable: list[str]
) -> list[str]:
    """Two causes at once each leave the other's structure in the view where the other's
    checks look: each estimable candidate checked beside the other candidates."""
    eligible = []
    for cause in estimable:
        beside = (*current, *(c for c in estimable if c != cause))
        joint = RunTable(batch.motion, batch.fit(beside), beside)
        e = CAUSES[cause].evidence(joint)
        checks = CAUSES[cause].checks(joint, e)
        if e.passes and all(ch.passed for ch in checks):
            seen.checks[cause] = checks
            eligible.append(cause)
    return eligible


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


def nested_heldout_energy_J(batch: Batch, causes: list[str]) -> tuple[np.ndarray, list[Note]]:
    """Motion energy of each motion run predicted by a model whose causes were chosen, as
    well as fitted, without its fold (nested cross-validation): `select_causes` is run again
    on the other folds, with folds of its own. So the extended model's held-out error is not
    flattered by having chosen its causes on the runs it then predicts. A fold whose
    choice differs from `causes` (the findings, chosen on all runs) is noted; one whose
    training runs are too few to choose from (`enough_to_choose`) uses `causes`."""
    import pandas as pd

    runs, motion, folds = batch.runs, batch.motion, batch.folds
    others = runs[runs["mode"] != "motion"]
    predicted = np.full(len(motion), np.nan)
    notes: list[Note] = []
    for k in np.unique(folds):
        train_motion = motion[folds != k].reset_index(drop=True)
        train = pd.concat([others, train_motion])
        chosen = causes
        inner_folds = heldout_folds(train_motion) if enough_to_choose(train_motion) else ""
        if not isinstance(inner_folds, str):
            inner = Batch(train, train_motion, inner_folds, batch.traces, batch.fits)
            chosen = list(select_causes(inner, inner.heldout_rmse_J([])).selected)
        else:
            notes.append(
                Note(
                    FOLD,
                    f"held-out fold {k}: too few runs without it to choose causes; the "
                    "findings' causes are used for it",
                )
            )
        if sorted(chosen) != sorted(causes):
            notes.append(
                Note(
                    FOLD,
                    f"held-out fold {k}: the causes chosen without its {np.sum(folds == k)} "
                    f"runs are {sorted(chosen) or 'none'}, not the findings "
                    f"{sorted(causes) or 'none'}",
                )
            )
        model: PowerModel = batch.fits.fit(train, chosen)
        predicted[folds == k] = predict_motion_energy_J(model, motion[folds == k])
    return predicted, notes


__all__ = [
    "MIN_GAIN_PCT",
    "Selection",
    "nested_heldout_energy_J",
    "rejected_candidates",
    "rmse_mape",
    "select_causes",
]
