"""Logs to per-run records: `map_runs` with the per-run work (`record.run_record`), the
cache's copy of each record, and what a batch's result is kept under.

`fit`, `diagnose` and `report` each call `gather` with their `RunPlan`, then compose the
records into their result (`fit.fit_records`, `diagnose.diagnose_summaries`,
`report.build_report`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import wifibot_power.pipeline.preload as preload
from wifibot_power.io.discover import Skipped
from wifibot_power.io.options import ReadOptions
from wifibot_power.pipeline.batch import Wrap, map_runs
from wifibot_power.pipeline.duplicates import ProblemHook
from wifibot_power.pipeline.record import (
    FIT_PLAN,
    RunPlan,
    RunRecord,
    record_memo,
    record_to_json,
    run_record,
)

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache
    from wifibot_power.run import Run


@dataclass(frozen=True)
class Gathered:
    """The records of a batch, in the order of its logs, and every input left out (unreadable,
    or a run_id another log has) with its reason."""

    paths: tuple[str, ...]
    options: ReadOptions
    plan: RunPlan
    records: list[RunRecord]
    skipped: list[Skipped]
    #: the cache they went through (None: none)
    cache: ParseCache | None = None


def gather(
    paths: str | Path | Sequence[str | Path],
    options: ReadOptions | None = None,
    plan: RunPlan = FIT_PLAN,
    *,
    wrap: Wrap | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    tables_after: bool = False,
) -> Gathered:
    """Read every log under `paths` (one file in memory at a time per worker, `jobs` workers:
    None or 0, all cores) and reduce each run to its record under `plan`.

    `cache` skips parsing files parsed before and, for a plan whose records it can keep
    (`RunPlan.keepable`), the per-run work on content seen before. `tables_after`: the
    caller makes pandas tables next, so pandas is imported while the workers work."""
    paths = [paths] if isinstance(paths, str | Path) else list(paths)
    options = options or ReadOptions()
    if cache is not None and plan.keepable:
        plan = plan.kept  # with the bins (`RunPlan.kept`)
    memo = record_memo(plan) if cache is not None and plan.keepable else None
    records, skipped = map_runs(
        [Path(p) for p in paths],
        options,
        lambda run: run_record(run, plan),
        wrap=wrap,
        jobs=jobs,
        cache=cache,
        memo=memo,
        on_problems=on_problems,
        prepare=lambda: preload.preload_work(plan),
        beside=preload.preload_tables if tables_after else None,
    )
    if not plan.bins:
        ReadAgain(paths, options, plan, jobs).watch(records)
    return Gathered(tuple(str(p) for p in paths), options, plan, records, skipped, cache)


class ReadAgain:
    """The bins a plan left out of a batch's records (`RunPlan.bins` False: each family's
    statistics' `without_bins`), read again from the logs when something asks for one
    run's (e.g. a drive fit's lag search whose sums would lose their digits,
    drive/model.py): every such run of the batch at once, each log with the batch's
    options and its manifest values, in `jobs` workers. Each statistics object with bins
    left out gets this as its `read_again` and its bins back by `bins_from`."""

    def __init__(
        self, paths: list[str | Path], options: ReadOptions, plan: RunPlan, jobs: int | None
    ) -> None:
        self.paths, self.options, self.jobs = paths, options, jobs
        self.plan = plan.kept
        #: file -> [(family name, its statistics)] still without their bins
        self.waiting: dict[str, list[tuple[str, object]]] = {}

    def watch(self, records: Sequence[RunRecord]) -> None:
        for record in records:
            for name, stats in record.models.items():
                if getattr(stats, "bins_left_out", False):
                    self.waiting.setdefault(str(record.row["file"]), []).append((name, stats))
                    stats.read_again = self  # type: ignore[attr-defined]

    def __call__(self) -> None:
        waiting, self.waiting = self.waiting, {}
        if not waiting:
            return
        records, _ = map_runs(
            [Path(p) for p in self.paths],
            self.options,
            lambda run: run_record(run, self.plan),
            jobs=self.jobs,
            only=set(waiting),
        )
        again = {str(record.row["file"]): record for record in records}
        for file, items in waiting.items():
            for name, stats in items:
                if file not in again:
                    from wifibot_power.errors import LogError

                    raise LogError(
                        "the log could not be read again (changed or removed while read)",
                        file=file,
                        fix="read the logs again when no program writes them",
                    )
                stats.bins_from(again[file].models[name])  # type: ignore[attr-defined]


def records_of(runs: Iterable[Run], plan: RunPlan = FIT_PLAN) -> list[RunRecord]:
    """The records of runs already in memory (e.g. simulated), in this process: with their
    bins (there is no log to read them again from)."""
    return [run_record(run, plan.kept) for run in runs]


def batch_key(gathered: Gathered, *settings: object) -> tuple[object, str] | None:
    """What names a batch's result in the cache (its paths, reading options, plan, this code
    and `settings`, e.g. `keep_doubtful`) and a digest of everything the result depends on:
    every record (its row and its families' statistics; not its phases), the inputs left
    out, `settings`. A changed log changes its record (its content is checked per file
    first) and so misses. None without a cache, for a plan it cannot keep, or when a record
    cannot be written as JSON."""
    if gathered.cache is None or not gathered.plan.keepable:
        return None
    key = record_memo(gathered.plan).key
    inputs = [key, list(gathered.paths), dataclasses.asdict(gathered.options), *settings]
    try:
        content = json.dumps(
            [
                key,
                [record_to_json(r, phases=False) for r in gathered.records],
                [s.as_dict() for s in gathered.skipped],
                *settings,
            ]
        )
    except (TypeError, ValueError):
        return None
    return inputs, hashlib.sha256(content.encode()).hexdigest()
