"""The entry points of diagnosis: logs read in workers (`diagnose_logs`), runs in memory
(`diagnose_runs`), and the files `diagnose -o DIR` writes (`write_diagnosis`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.diagnose.diagnosis import diagnose_summaries
from wifibot_power.diagnose.result import Diagnosis
from wifibot_power.diagnose.summaries import Segmenter, diagnose_plan, summary_of
from wifibot_power.errors import LogError
from wifibot_power.io import LogSource, ReadOptions
from wifibot_power.model import PowerModel
from wifibot_power.outputs import json_file, parquet_file, write_set
from wifibot_power.pipeline import gather, records_of
from wifibot_power.pipeline.duplicates import ProblemHook
from wifibot_power.run import Run

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache


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
    gathered = gather(
        paths,
        options,
        diagnose_plan(segmenter),
        wrap=wrap,
        jobs=jobs,
        cache=cache,
        on_problems=on_problems,
        tables_after=True,  # the diagnosis after the workers makes tables
    )
    summaries = [summary_of(r) for r in gathered.records]
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
    summaries = [summary_of(r) for r in records_of(runs, diagnose_plan(segmenter))]
    return diagnose_summaries(summaries, reference=reference)


def write_diagnosis(result: Diagnosis, out_dir: Path) -> list[Path]:
    """`diagnose -o DIR`: discrepancy.parquet, findings.json, model.json, written as one set
    (`outputs.write_set`: all new, or all as they were; cli.md: "writes nothing partial")."""
    files = {
        "discrepancy.parquet": parquet_file(result.runs),
        "findings.json": json_file(result.summary()),
        "model.json": json_file(result.extended_model.to_json()),
    }
    return write_set(Path(out_dir), files)
