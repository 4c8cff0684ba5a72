"""The entry points of diagnosis: logs read in workers (`diagnose_logs`), runs in memory
(`diagnose_runs`), and the files `diagnose -o DIR` writes (`write_diagnosis`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from wifibot_power.diagnose.diagnosis import diagnose_summaries
from wifibot_power.diagnose.result import Diagnosis
from wifibot_power.diagnose.summaries import Segmenter, summarize_run
from wifibot_power.errors import LogError
from wifibot_power.fit import _import_work_modules
from wifibot_power.io import LogSource, ReadOptions
from wifibot_power.io.batch import ProblemHook, map_runs
from wifibot_power.model import PowerModel
from wifibot_power.outputs import json_file, parquet_file, write_set
from wifibot_power.run import Run


def diagnose_logs(
    paths: list[Path] | list[str],
    options: ReadOptions | None = None,
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    segmenter: Segmenter | None = None,
    jobs: int | None = 1,
    on_problems: ProblemHook | None = None,
    reference: PowerModel | None = None,
    keep_doubtful: bool = False,
) -> Diagnosis:
    """Read, segment and summarise every log under `paths` (`jobs` files at a time, one file
    in memory per worker), then diagnose them (module docstring). `reference`,
    `keep_doubtful`: see `diagnose_summaries`."""
    summaries, skipped = map_runs(
        [Path(p) for p in paths],
        options or ReadOptions(),
        lambda run: summarize_run(run, segmenter),
        wrap=wrap,
        jobs=jobs,
        on_problems=on_problems,
        prepare=_import_work_modules,
        # the tables' library loads while the workers read: the diagnosis after them needs it
        beside=_import_pandas,
    )
    try:
        return diagnose_summaries(
            summaries, skipped, reference=reference, keep_doubtful=keep_doubtful
        )
    except LogError as exc:  # about the batch: named by what the user gave
        raise exc.with_file(", ".join(map(str, paths))) from None


def _import_pandas() -> None:
    import pandas  # noqa: F401


def diagnose_runs(
    runs: Iterable[Run],
    *,
    segmenter: Segmenter | None = None,
    reference: PowerModel | None = None,
) -> Diagnosis:
    """Diagnose runs already in memory (e.g. simulated); same result as from their logs."""
    summaries = [summarize_run(run, segmenter) for run in runs]
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
