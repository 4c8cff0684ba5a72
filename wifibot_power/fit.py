"""`wbpower fit`: logs -> per-run records -> every model family fitted -> `FitResult`.

Three entry points, by what a user holds:

- `fit_logs(paths)`: log files or folders (`pipeline.gather`, workers, `--cache`);
- `fit_runs(runs)`: runs already in memory (read or simulated), as `diagnose_runs`;
- `fit_table(runs)`: a per-run table (`runtable.runs_frame`, runs.parquet): the paper's
  family alone (a table holds no other family's per-run statistics).

`fit_records` is the composition they share: runs in doubt admitted (`--keep-doubtful`),
each family of `models.FAMILIES` fitted, the inputs left out listed. The paper's fit itself
is `models.paper_fit` (Eq. 1-4 by least squares over runs), its result `fit_result`, its
files `fit_outputs`; the names below stay importable from here.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.cache import MISSING, ParseCache
from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.fit_outputs import stop_and_go_frame, write_fit
from wifibot_power.fit_result import DRIVE, PAPER, FitResult, format_number
from wifibot_power.io import ReadOptions, Skipped
from wifibot_power.io.discover import reasons_in_brief
from wifibot_power.models.paper_fit import (
    COMPONENT_MODES,
    SPEED_RESOLUTION_FRACTION,
    SPEED_RESOLUTION_MPS,
    FitColumns,
    MeanEstimate,
    TableColumns,
    fit_line,
    fit_table_model,
    fit_warnings,
    incomplete_warning,
    net_of_idle,
    speed_levels,
    unfitted,
)
from wifibot_power.pipeline import FIT_PLAN, RunRecord, batch_key, gather, records_of
from wifibot_power.pipeline.batch import Wrap
from wifibot_power.pipeline.duplicates import ProblemHook
from wifibot_power.pipeline.record import Segmenter, segment_checked

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.run import Run

__all__ = [
    "COMPONENT_MODES",
    "SPEED_RESOLUTION_FRACTION",
    "SPEED_RESOLUTION_MPS",
    "FitColumns",
    "FitResult",
    "MeanEstimate",
    "TableColumns",
    "fit_line",
    "fit_logs",
    "fit_records",
    "fit_runs",
    "fit_table",
    "fit_table_model",
    "fit_warnings",
    "format_number",
    "incomplete_warning",
    "net_of_idle",
    "segment_checked",
    "speed_levels",
    "stop_and_go_frame",
    "unfitted",
    "write_fit",
]


def fit_logs(
    paths: str | Path | Sequence[str | Path],
    options: ReadOptions | None = None,
    *,
    wrap: Wrap | None = None,
    segmenter: Segmenter | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    keep_doubtful: bool = False,
) -> FitResult:
    """Read every log under `paths` (one file in memory at a time per worker), segment it,
    and fit every model family over the runs.

    `jobs` worker processes (None or 0: all cores) read and segment files in parallel; the
    result is the same for any `jobs`. `cache` (`wifibot_power.cache.ParseCache`) skips
    parsing files parsed before, segmenting runs segmented before and, when every run's
    record is what it was, the fit itself.

    Unreadable logs and runs the fit cannot use are listed in `FitResult.skipped` with the
    reason; runs whose segmentation is in doubt are among them unless `keep_doubtful`.
    Raises `LogError` when no run at all can be used (nothing to fit).
    """
    plan = FIT_PLAN if segmenter is None else replace(FIT_PLAN, segmenter=segmenter)
    gathered = gather(
        paths, options, plan, wrap=wrap, jobs=jobs, cache=cache, on_problems=on_problems
    )
    key = batch_key(gathered, keep_doubtful)
    if key is not None and cache is not None:
        kept = cache.kept_batch(*key)
        if kept is not MISSING:
            records = gathered.records
            try:
                return FitResult.from_json(
                    kept,
                    lambda: record_tables(admitted(records, keep_doubtful)),
                    _run_ids(records),
                )
            except (KeyError, TypeError, ValueError, WbpowerError):
                pass  # another layout: fit again (and keep that)
    fit, skipped = fit_records(gathered.records, gathered.skipped, keep_doubtful=keep_doubtful)
    if fit is None:
        inputs = len(gathered.records) + len(gathered.skipped)
        raise _nothing_to_fit(inputs, skipped, ", ".join(gathered.paths))
    if key is not None and cache is not None:
        cache.keep_batch(*key, fit.to_json())
    return fit


def fit_runs(
    runs: Iterable[Run], *, segmenter: Segmenter | None = None, keep_doubtful: bool = False
) -> FitResult:
    """`fit_logs` of runs already in memory (e.g. `read_log`'s, or simulated): the same
    result as from their logs."""
    plan = FIT_PLAN if segmenter is None else replace(FIT_PLAN, segmenter=segmenter)
    records = records_of(runs, plan)
    fit, skipped = fit_records(records, keep_doubtful=keep_doubtful)
    if fit is None:
        raise _nothing_to_fit(len(records), skipped, "the runs given")
    return fit


def fit_table(
    runs: pd.DataFrame,
    phases: pd.DataFrame | None = None,
    skipped: tuple[Skipped, ...] = (),
) -> FitResult:
    """The paper family fitted over the usable rows of a per-run table
    (`runtable.runs_frame`, e.g. a runs.parquet), callable on any subset of runs."""
    from wifibot_power.models.paper import fit_rows
    from wifibot_power.runtable import RUN_COLUMNS

    if phases is None:
        import pandas as pd

        phases = pd.DataFrame()
    # the run-table columns only (a diagnose table carries ~30 more), column by column:
    # to_dict("records") boxes every cell through pandas indexing, 10 ms a call
    names = [c for c in runs.columns if c in RUN_COLUMNS]
    values = zip(*(runs[c].tolist() for c in names), strict=True)
    rows = [dict(zip(names, row, strict=True)) for row in values]
    return FitResult({PAPER: fit_rows(rows)}, lambda: (runs, phases), tuple(skipped))


def fit_records(
    records: Sequence[RunRecord],
    read_skipped: Sequence[Skipped] = (),
    *,
    keep_doubtful: bool = False,
) -> tuple[FitResult | None, tuple[Skipped, ...]]:
    """Every model family fitted over the records of a batch (`fit_logs`, `report`), and
    every input left out: the unreadable ones, then the runs the fit cannot use (with
    their reason). None when no family can fit (no usable run). Runs in doubt are made
    usable with `keep_doubtful`, and then named in the result's warnings
    (`runtable.kept_in_doubt`).

    Without a single step run the paper's family does not fit; a batch that gives the drive
    model is then a success (cli.md, "The drive model"): the runs the drive model used are
    not skipped, and a note says the paper's models need step runs."""
    from wifibot_power.models import FAMILIES, FitOptions
    from wifibot_power.runtable import kept_in_doubt

    in_doubt = kept_in_doubt([r.row for r in records]) if keep_doubtful else None
    records = admitted(records, keep_doubtful)
    options = FitOptions(keep_doubtful=keep_doubtful)
    fits = {name: family.fit(records, options) for name, family in FAMILIES.items()}
    fits = {name: fitted for name, fitted in fits.items() if fitted is not None}
    notes: tuple[str, ...] = ()
    unusable = [r for r in records if not r.row["usable"]]
    if PAPER not in fits and DRIVE in fits:
        # free driving: a run the drive model used is used, whatever the paper's reason
        drive_only = [r for r in unusable if r.models.get(DRIVE)]
        unusable = [r for r in unusable if not r.models.get(DRIVE)]
        why = reasons_in_brief([_skipped(r) for r in drive_only]) if drive_only else ""
        notes = (
            "the paper's models (P_acc, P_v, t_acc, idle) need step runs: straight runs at set "
            "speeds, each accelerate / cruise / stop, named by mode and speed_mps "
            f"('wbpower docs log-format'); no usable step run among the {len(records)} run(s), "
            f"so only the drive model was fitted, from the {len(drive_only)} with a speed"
            + (f" (the paper's reasons: {why})" if why else ""),
        )
    # with step runs too, `skipped` is the paper's (cli.md: a run it leaves out is listed);
    # a run the drive model used says which model left it out, and that the other used it
    drive_used = DRIVE in fits and PAPER in fits
    skipped = (
        *read_skipped,
        *(_skipped(r, drive_used and bool(r.models.get(DRIVE))) for r in unusable),
    )
    if not fits:
        return None, skipped
    return (
        FitResult(
            fits,
            lambda: record_tables(records),
            skipped,
            (in_doubt,) if in_doubt else (),
            notes,
            _run_ids(records),
        ),
        skipped,
    )


def _run_ids(records: Sequence[RunRecord]) -> tuple[str, ...]:
    """The records' run_ids, as the runs table holds them (`FitResult.run_ids`)."""
    return tuple(str(r.row["run_id"]) for r in records)


def _skipped(record: RunRecord, drive_used: bool = False) -> Skipped:
    """A run the paper's fit cannot use, with its reason; `drive_used`: the drive model used
    it (free driving beside step runs), which the reason says, naming the paper's models as
    the ones that left it out."""
    file, reason = record.row["file"], record.row["skip_reason"]
    if drive_used:
        return Skipped(
            str(file),
            f"{file}: the paper's models left it out: {reason}; the drive model used it",
        )
    return Skipped(str(file), f"{file}: {reason}")


def admitted(records: Sequence[RunRecord], keep_doubtful: bool) -> list[RunRecord]:
    """The records as `fit_records` fits them: runs in doubt made usable with
    `keep_doubtful` (`runtable.admit_doubtful`)."""
    if not keep_doubtful:
        return list(records)
    from wifibot_power.runtable import admit_doubtful

    return [replace(r, row=admit_doubtful(r.row)) for r in records]


def record_tables(records: Sequence[RunRecord]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The runs and phases tables of a batch's records (pandas is imported here)."""
    from wifibot_power.phases import phase_frame
    from wifibot_power.runtable import runs_frame

    phases = [phase for r in records for phase in r.phases]
    return runs_frame([r.row for r in records]), phase_frame(phases)


def _nothing_to_fit(inputs: int, skipped: Sequence[Skipped], where: str) -> LogError:
    why = reasons_in_brief(list(skipped)) if skipped else "no logs"
    return LogError(
        f"no usable run among {inputs} input(s): {why}",
        file=where,
        fix="each input left out is listed with its own reason",
        skipped=skipped,
    )
