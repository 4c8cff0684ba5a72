"""From log files to per-run records, once for every command.

    paths -> find_sources -> kept_outcomes (cache) -> dispatch (workers: read, run_record)
          -> settle (duplicates, run_ids) -> records -> fit / diagnose / report

- `batch`: `map_runs`, in four small steps (find, look up the cache, dispatch to workers,
  settle duplicates and run_id clashes);
- `duplicates`: one result per recording and per run_id;
- `record`: the per-run work (`run_record`) and its frozen result (`RunRecord`), under a
  `RunPlan` that says what a command needs;
- `gather`: logs to records (`gather`), runs in memory to records (`records_of`), what a
  batch's result is kept under in a cache (`batch_key`);
- `preload`: what must be imported before workers fork, in one place.
"""

from wifibot_power.pipeline.batch import map_runs
from wifibot_power.pipeline.gather import Gathered, batch_key, gather, records_of
from wifibot_power.pipeline.preload import preload_tables, preload_work
from wifibot_power.pipeline.record import (
    DIAGNOSE_PLAN,
    FIT_PLAN,
    REPORT_PLAN,
    RunPlan,
    RunRecord,
    run_record,
    segment_checked,
)

__all__ = [
    "DIAGNOSE_PLAN",
    "FIT_PLAN",
    "REPORT_PLAN",
    "Gathered",
    "RunPlan",
    "RunRecord",
    "batch_key",
    "gather",
    "map_runs",
    "preload_tables",
    "preload_work",
    "records_of",
    "run_record",
    "segment_checked",
]
