"""The diagnosis of summarised runs (`diagnose_summaries`): the batch's runs checked and
dealt into folds, the baseline's held-out error, the causes chosen (`selection`), the
extended model's nested held-out error, each finding's own gain and checks, and what is
left unexplained, with the verdict (`result.verdict_of`)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes import CAUSES, RUN_ENERGY, RunTable
from wifibot_power.diagnose.extended import Fits, predict_motion_energy_J
from wifibot_power.diagnose.folds import (
    MIN_MOTION_RUNS,
    MIN_SPEEDS,
    Batch,
    enough_to_choose,
    gain_pct,
    heldout_folds,
    missing_data,
    rmse_mape,
)
from wifibot_power.diagnose.idle import IDLE_OFFSET_J, refer_to_batch_idle
from wifibot_power.diagnose.intervals import energy_errors, gain_ci95, gain_deals
from wifibot_power.diagnose.result import (
    KEPT_IN_DOUBT,
    REJECTED,
    Diagnosis,
    Finding,
    Note,
    verdict_of,
)
from wifibot_power.diagnose.selection import (
    Selection,
    drop_uncertain,
    nested_heldout_energy_J,
    rejected_candidates,
    select_causes,
)
from wifibot_power.diagnose.summaries import (
    RunSummary,
    motion_runs,
    summary_table,
    trace_data,
)
from wifibot_power.errors import LogError
from wifibot_power.io import Skipped
from wifibot_power.io.discover import reasons_in_brief
from wifibot_power.residuals import residual_table, structure, structure_reasons
from wifibot_power.runtable import DOUBT_REASON, admit_doubtful, kept_in_doubt
from wifibot_power.stats import spearman

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel


def diagnose_summaries(
    summaries: list[RunSummary],
    skipped: Iterable[Skipped] = (),
    *,
    reference: PowerModel | None = None,
    keep_doubtful: bool = False,
) -> Diagnosis:
    """The diagnosis of summarised runs (the package's docstring).

    Runs whose segmentation is in doubt are left out (listed in `skipped` with the doubt)
    unless `keep_doubtful` (`runtable.admit_doubtful`), which the first of `notes` then
    says (`runtable.kept_in_doubt`).

    With a `reference` model (`diagnose --model`: e.g. the robot's stored model.json, or
    the paper's), the baseline is that model as given, predicting every run; it is not
    refitted, so nothing is held out for it. Causes are still found, and the extended model
    fitted, on these logs with held-out runs; gain_pct then says how much better than the
    reference the extended model predicts runs it has not seen.
    """
    skipped = list(skipped)
    if not summaries:
        raise LogError(
            "no readable logs",
            fix="each input left out is listed with its own reason",
            skipped=skipped,
        )
    in_doubt = kept_in_doubt([s.row for s in summaries]) if keep_doubtful else None
    if keep_doubtful:
        summaries = [
            RunSummary(admit_doubtful(s.row), s.cause_columns, s.traces) for s in summaries
        ]
    runs = summary_table(summaries)
    # per-run data is keyed by run_id (here, the folds, the causes' evidence): one run each
    _check_one_run_per_run_id(summaries)
    for row in runs[~runs["usable"]].itertuples():
        skipped.append(Skipped(str(row.file), f"{row.file}: {row.skip_reason}"))
    doubted = doubted_motion_reason(runs)
    # each motion run on the batch's idle level: its own idle draw is not motion (`idle`)
    runs = refer_to_batch_idle(runs[runs["usable"]])
    motion = motion_runs(runs)
    if not enough_to_choose(motion):
        raise _too_few(motion, skipped)
    fits = Fits()
    baseline_model = fits.fit(runs)
    _check_estimable(baseline_model, motion)
    folds = heldout_folds(motion)
    if isinstance(folds, str):
        raise LogError(folds, fix=missing_data(motion))
    batch = Batch(runs, motion, folds, trace_data(summaries), fits)
    notes = [Note(KEPT_IN_DOUBT, in_doubt)] if in_doubt else []  # said first (cli.md)
    return _diagnosis(batch, baseline_model, reference, notes, skipped, doubted)


def _too_few(motion: pd.DataFrame, skipped: list[Skipped]) -> LogError:
    """Too few usable motion runs to choose causes on, and what left the other inputs out
    (unreadable, refused, unusable, doubted), most common first: the CLI shows no 'skipped'
    lines when the batch fails."""
    doubted_runs = [s for s in skipped if s.why.startswith(DOUBT_REASON)]
    others = [s for s in skipped if not s.why.startswith(DOUBT_REASON)]
    return LogError(
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


def _diagnosis(
    batch: Batch,
    baseline_model: PowerModel,
    reference: PowerModel | None,
    notes: list[Note],
    skipped: list[Skipped],
    doubted: str | None,
) -> Diagnosis:
    measured = batch.measured
    refit_pred = batch.heldout_energy_J([])
    refit_rmse, _ = rmse_mape(measured, refit_pred)
    if reference is None:
        baseline_pred = refit_pred
    else:
        baseline_model = reference
        # as given: it knows nothing of a run's own idle level, so it is judged on the
        # energies as measured (the offsets `_run_table` adds back are taken off here)
        baseline_pred = predict_motion_energy_J(reference, batch.motion) - batch.motion[
            IDLE_OFFSET_J
        ].to_numpy(np.float64)
    baseline_rmse, baseline_mape = rmse_mape(measured, baseline_pred)
    # causes are selected against the paper-form model refitted to these logs, whatever
    # the reported baseline is
    seen = select_causes(batch, refit_rmse)
    notes += seen.notes
    # a cause whose own gain's interval (over fold deals and the runs drawn) reaches zero
    # is not named (causes.md)
    deals = gain_deals(batch)
    drop_uncertain(deals, seen)
    causes = list(seen.selected)
    # the extended model's held-out error: causes chosen and fitted without the run's fold
    extended_pred, fold_notes = nested_heldout_energy_J(batch, causes)
    notes += fold_notes
    extended_rmse, extended_mape = rmse_mape(measured, extended_pred)
    extended_model = batch.fit(causes)
    findings, fixed_rmse = _findings(batch, seen, extended_model)
    table = _run_table(batch, baseline_pred, extended_pred)
    rejected = rejected_candidates(seen.evidence, causes, seen, deals)
    overall_ci = _overall_ci95(deals, causes, baseline_pred, extended_pred, reference)
    found, spread_unknown = structure(replication_table(table, "extended_energy_J"))
    reasons = found + ([spread_unknown] if spread_unknown else [])
    reasons += [str(r["reason"]) for r in rejected] + ([doubted] if doubted else [])
    notes += [Note(REJECTED, str(r["reason"])) for r in rejected]
    return Diagnosis(
        n_runs=len(batch.motion),
        baseline_model=baseline_model,
        extended_model=extended_model,
        runs=table,
        findings=tuple(findings),
        evidence=seen.evidence,
        baseline_rmse_J=baseline_rmse,
        baseline_mape_pct=baseline_mape,
        extended_rmse_J=extended_rmse,
        extended_mape_pct=extended_mape,
        extended_fixed_rmse_J=fixed_rmse,
        gain_ci95=overall_ci,
        unexplained=bool(reasons),
        unexplained_reasons=tuple(reasons),
        rejected=tuple(rejected),
        candidate_checks=dict(seen.checks),
        patterns=error_patterns(table),
        skipped=tuple(skipped),
        notes=tuple(notes),
        traces={name: dict(data) for name, data in batch.traces.items()},
        verdict=verdict_of(bool(findings), reasons, spread_unknown),
        baseline_label=(
            "paper (Eq. 1-6) fitted to these logs"
            if reference is None
            else f"the given model ({reference.source}), not refitted"
        ),
    )


def _overall_ci95(
    deals: list[Batch],
    causes: list[str],
    baseline_pred: np.ndarray,
    extended_pred: np.ndarray,
    reference: PowerModel | None,
) -> tuple[float, float]:
    """The 95% interval of the overall gain (`intervals`). On the diagnosis's own deal, the
    extended model is the nested one (its causes chosen again without each fold: the
    reported gain); on the further deals, the findings' energy causes fitted without each
    fold (choosing again there would cost a selection per fold per deal). The baseline is
    the refitted paper-form lines on each deal, or the given model, on none."""
    measured = deals[0].measured
    energy = frozenset(c for c in causes if CAUSES[c].metric == RUN_ENERGY)
    extended = energy_errors(deals, energy)
    extended[0] = (extended_pred - measured) ** 2
    if reference is None:
        baseline = energy_errors(deals, frozenset())
        baseline[0] = (baseline_pred - measured) ** 2
    else:
        baseline = np.tile((baseline_pred - measured) ** 2, (len(deals), 1))
    return gain_ci95(baseline, extended)


def _findings(
    batch: Batch, seen: Selection, extended_model: PowerModel
) -> tuple[list[Finding], float]:
    """Each chosen cause as a finding, with its estimate within the extended model (the
    value model.json carries) and its own gain, and the held-out RMSE of the findings'
    energy causes chosen on all runs [J]. A finding's own gain compares like with like: the
    findings' causes held fixed, with and without it (both fitted without the run's fold,
    both chosen on all runs). Selection tried those sets already; keyed by energy causes
    only, since a trace cause adds no energy. Its checks, run again on the extended model,
    replace its candidate's in `seen`; its gain's interval is `drop_uncertain`'s."""
    causes = list(seen.selected)
    energy_causes = frozenset(c for c in causes if CAUSES[c].metric == RUN_ENERGY)
    fixed_rmse = seen.rmse_of.get(energy_causes)
    if fixed_rmse is None:  # a finding dropped for its gain's interval left a set not tried
        fixed_rmse = batch.heldout_rmse_J(sorted(energy_causes))
    findings = []
    for e in seen.evidence:
        if e.cause not in seen.selected:
            continue
        cause = CAUSES[e.cause]
        others = tuple(c for c in causes if c != e.cause and CAUSES[c].metric == RUN_ENERGY)
        final_table = RunTable(batch.motion, extended_model, others)
        if cause.metric == RUN_ENERGY:
            e = cause.evidence(final_table)
            # its own gain: how much worse the extended model predicts without it
            without = seen.rmse_of.get(energy_causes - {e.cause})
            if without is None:
                without = batch.heldout_rmse_J([c for c in causes if c != e.cause])
            gain = gain_pct(without, fixed_rmse)
        else:
            gain = seen.selected[e.cause]
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
                seen.gain_ci95[e.cause],
            )
        )
    return findings, fixed_rmse


def _run_table(batch: Batch, baseline_pred: np.ndarray, extended_pred: np.ndarray) -> pd.DataFrame:
    """A row per motion run: its configuration, fold, measured, baseline and extended
    energy and errors, and the columns each cause's figure panels read. Energies as
    measured: each run's idle offset (`idle`), taken off to compare runs, is added back to
    the measured and the predicted energies alike."""
    table = batch.motion[
        [
            "run_id",
            "file",
            "speed_mps",
            "commanded_speed_mps",
            "distance_m",
            "steps",
            "payload_kg",
            "session_order",
            *(c for cause in CAUSES.values() for c in cause.table_columns),
        ]
    ].copy()
    back_J = batch.motion[IDLE_OFFSET_J].to_numpy(np.float64)
    measured = batch.measured + back_J
    baseline_pred, extended_pred = baseline_pred + back_J, extended_pred + back_J
    table["fold"] = batch.folds
    table["measured_energy_J"] = measured
    table["baseline_energy_J"] = baseline_pred
    table["extended_energy_J"] = extended_pred
    table["baseline_error_pct"] = 100 * (baseline_pred - measured) / measured
    table["extended_error_pct"] = 100 * (extended_pred - measured) / measured
    return table


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
