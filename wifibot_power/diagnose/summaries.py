"""What diagnosis keeps of each run (its row and what each cause keeps of it, made in the
worker while the run is in memory) and the per-run table made of them."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes import CAUSES
from wifibot_power.pipeline import DIAGNOSE_PLAN, RunPlan, RunRecord, run_record
from wifibot_power.pipeline.record import Segmenter
from wifibot_power.run import Run
from wifibot_power.runtable import runs_frame

if TYPE_CHECKING:  # pandas (~0.3 s to import) loads where the tables are made, while
    import pandas as pd  # the workers read the logs (`diagnose_logs`)


@dataclass(frozen=True, eq=False)
class RunSummary:
    """What diagnosis keeps of a run: its row (`runtable.run_row`), the statistics each
    cause's tests need (`Cause.run_stats`) and each cause's trace data (`Cause.run_trace`,
    by cause); a run of another mode than motion has only its row."""

    row: dict[str, object]
    cause_columns: dict[str, float] = field(default_factory=dict)
    traces: dict[str, object] = field(default_factory=dict)


def diagnose_plan(segmenter: Segmenter | None = None) -> RunPlan:
    """`pipeline.DIAGNOSE_PLAN`, with `segmenter` (None: `segment.segment_run`)."""
    return DIAGNOSE_PLAN if segmenter is None else replace(DIAGNOSE_PLAN, segmenter=segmenter)


def summary_of(record: RunRecord) -> RunSummary:
    """What diagnosis keeps of a run's record (`pipeline.run_record`)."""
    return RunSummary(record.row, record.causes, record.traces)


def summarize_run(run: Run, segmenter: Segmenter | None = None) -> RunSummary:
    """A run in memory's summary, made as `diagnose_logs` makes it in a worker: its record
    under `diagnose_plan(segmenter)` (motion runs segmented; the phases' and the causes'
    windows' energies from one `runtable.WindowEnergy`)."""
    return summary_of(run_record(run, diagnose_plan(segmenter)))


def session_order(runs: pd.DataFrame) -> np.ndarray:
    """Each run's place among the runs with a `started_at`, in time order (-1: none)."""
    order = np.full(len(runs), -1)
    timed = runs["started_at"].notna()
    if timed.any():
        ranked = runs[timed].sort_values("started_at").index
        order[runs.index.get_indexer(ranked)] = np.arange(len(ranked))
    return order


def with_session_columns(table: pd.DataFrame) -> pd.DataFrame:
    """`table` (changed in place) with each run's place in the session (`session_order`) and
    every cause's session columns (`Cause.session_columns`)."""
    table["session_order"] = session_order(table)
    for cause in CAUSES.values():
        for name, values in cause.session_columns(table).items():
            table[name] = values
    return table


def summary_table(summaries: list[RunSummary]) -> pd.DataFrame:
    """One row per run: its run-table row, each cause's statistics and session columns
    (`Cause.session_columns`), and its place in the session (`session_order`)."""
    import pandas as pd

    runs = runs_frame([s.row for s in summaries])
    extra = pd.DataFrame([s.cause_columns for s in summaries], index=runs.index)
    table = with_session_columns(pd.concat([runs, extra], axis=1))
    # text as Python objects in one block: the held-out folds select rows of this table
    # hundreds of times, and each Arrow-backed text column is a take of its own
    text = [c for c in table.columns if isinstance(table[c].dtype, pd.StringDtype)]
    return table.astype(dict.fromkeys(text, object)).copy()


def trace_data(summaries: Iterable[RunSummary]) -> dict[str, dict[str, object]]:
    """Each cause's per-run trace data (`Cause.run_trace`), by cause, then run_id."""
    out: dict[str, dict[str, object]] = {name: {} for name in CAUSES}
    for summary in summaries:
        for name, data in summary.traces.items():
            out.setdefault(name, {})[str(summary.row["run_id"])] = data
    return out


def motion_runs(runs: pd.DataFrame) -> pd.DataFrame:
    """The usable motion runs, in run_id order (the order `assign_folds` deals folds in)."""
    usable = runs[runs["usable"]]
    return usable[usable["mode"] == "motion"].sort_values("run_id").reset_index(drop=True)
