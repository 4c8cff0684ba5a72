"""What the paper's simulation gets wrong on measured logs, why, and how much a fix gains.

1. Every log is read, segmented and reduced to its per-run row (`runtable.run_row`) and what
   each cause keeps of it (`Cause.run_stats`, `Cause.run_trace`): one run in memory at a
   time (`summaries`).
2. The baseline is the paper's model (Eq. 1-6) fitted to these logs; it simulates each run's
   motion energy from (speed, distance, steps, payload) alone (`extended`).
3. Each named cause (the registry `causes.CAUSES`, shared/spec/causes.md) runs its evidence
   test on all runs. A cause is a candidate when its test is significant (p < 1e-3) and its
   estimated size is worth naming; it becomes a finding when adding it to the model also improves
   predictions of runs held out of the fit (>= 5% lower RMSE of run energy, or >= 10% on the
   power trace for a cause measured there) (`selection`).
4. The extended model holds every finding; its gain is measured on held-out runs the same way,
   nested: for each fold, the causes are chosen again, and fitted, without that fold.
   Held-out means K-fold by run: a run is predicted by a model fitted without it (`folds`).
5. A candidate is named only when every consequence check of its physics passes (each
   cause's `checks`, causes.md "How a cause earns its name"); one that would have predicted
   but fails a check is reported (`rejected`) and makes the result `unexplained`, as does
   structure left in the extended model's held-out errors (`unexplained_reasons`), rather
   than forcing a name. A fit the training folds cannot identify is "not estimable".
6. The result (`result.Diagnosis`) carries the verdict and a text report of its own.

Modules, one job each: `summaries` (per run), `extended` (the extended model and the fits
of one diagnosis), `folds` (held-out evaluation), `selection` (the choice of causes),
`diagnosis` (the steps above, put together), `result`, `batch` (the entry points).
"""

from __future__ import annotations

from wifibot_power.diagnose.batch import diagnose_logs, diagnose_runs, write_diagnosis
from wifibot_power.diagnose.diagnosis import (
    COVARIATES,
    diagnose_summaries,
    doubted_motion_reason,
    error_patterns,
    replication_table,
    unexplained_reasons,
)
from wifibot_power.diagnose.extended import (
    PREDICT_COLUMNS,
    Fits,
    NotEstimable,
    fit_model,
    motion_of,
    predict_columns_J,
    predict_motion_energy_J,
    prediction_inputs,
)
from wifibot_power.diagnose.folds import (
    FOLDS,
    MIN_MOTION_RUNS,
    MIN_SPEEDS,
    Batch,
    HeldOut,
    assign_folds,
    enough_to_choose,
    gain_pct,
    heldout_energy_J,
    heldout_folds,
    rmse_mape,
)
from wifibot_power.diagnose.result import (
    FOLD,
    KEPT_IN_DOUBT,
    NOT_NAMED,
    REJECTED,
    VERDICTS,
    Diagnosis,
    Finding,
    Note,
    verdict_of,
)
from wifibot_power.diagnose.selection import (
    MIN_GAIN_PCT,
    Selection,
    nested_heldout_energy_J,
    rejected_candidates,
    select_causes,
)
from wifibot_power.diagnose.summaries import (
    RunSummary,
    Segmenter,
    diagnose_plan,
    motion_runs,
    session_order,
    summarize_run,
    summary_of,
    summary_table,
    trace_data,
)

__all__ = [
    "COVARIATES",
    "FOLD",
    "FOLDS",
    "KEPT_IN_DOUBT",
    "MIN_GAIN_PCT",
    "MIN_MOTION_RUNS",
    "MIN_SPEEDS",
    "NOT_NAMED",
    "PREDICT_COLUMNS",
    "REJECTED",
    "VERDICTS",
    "Batch",
    "Diagnosis",
    "Finding",
    "Fits",
    "HeldOut",
    "Note",
    "NotEstimable",
    "RunSummary",
    "Segmenter",
    "Selection",
    "assign_folds",
    "diagnose_logs",
    "diagnose_plan",
    "diagnose_runs",
    "diagnose_summaries",
    "doubted_motion_reason",
    "enough_to_choose",
    "error_patterns",
    "fit_model",
    "gain_pct",
    "heldout_energy_J",
    "heldout_folds",
    "motion_of",
    "motion_runs",
    "nested_heldout_energy_J",
    "predict_columns_J",
    "predict_motion_energy_J",
    "prediction_inputs",
    "rejected_candidates",
    "replication_table",
    "rmse_mape",
    "select_causes",
    "session_order",
    "summarize_run",
    "summary_of",
    "summary_table",
    "trace_data",
    "unexplained_reasons",
    "verdict_of",
    "write_diagnosis",
]
