"""The per-run work: one log's run reduced to one frozen `RunRecord`, in the worker.

Every command that reads logs (`fit`, `diagnose`, `report`) runs `run_record` on each run,
with a `RunPlan` saying what it needs of it; only the record travels back to the calling
process, never the samples. A record holds:

- `row`: the run-table row (`runtable.run_row`, runs.parquet's columns);
- `phases`: a row per phase (`Segmentation.rows`, phases.parquet) when the plan keeps them;
- `models`: each model family's per-run statistics (`ModelFamily.run_stats`), by name;
- `causes`: each cause's per-run statistics (`Cause.run_stats`, through the cause
  registry's `run_statistics`), motion runs only, when the plan diagnoses;
- `traces`: each cause's per-run trace data (`Cause.run_trace`, by cause; e.g. the ripple's
  cruise blocks), motion runs only, when the plan diagnoses;
- `view`: the trace figure's envelope (`figures.trace.TraceView`), when the plan draws.

A run of unknown mode (no mode or speed in its metadata) has nothing to fit to: its row is
made from no phases, whatever the plan (here, once). A run is segmented when the plan's
`segment` says so for its mode: `fit` segments every run of known mode, `diagnose` motion
runs only, `report` every run (each trace is drawn).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import datetime
from typing import TYPE_CHECKING

from wifibot_power.errors import LogError, WbpowerError

if TYPE_CHECKING:
    from wifibot_power.cache import ResultMemo
    from wifibot_power.figures.trace import TraceView
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

Segmenter = Callable[["Run"], "Segmentation"]

#: Which runs a plan segments, by mode.
SEGMENT_ALL, SEGMENT_KNOWN, SEGMENT_MOTION = "all", "known", "motion"


@dataclass(frozen=True)
class RunPlan:
    """What a command needs of each run (module docstring)."""

    #: which runs are segmented: every run, every run of known mode, or motion runs
    segment: str = SEGMENT_KNOWN
    #: keep a row per phase
    phases: bool = True
    #: compute each model family's per-run statistics
    families: bool = True
    #: compute the causes' per-run statistics and trace data (motion runs)
    causes: bool = False
    #: keep the trace figure's envelope
    view: bool = False
    #: keep each family's per-sample bins in its statistics (`ModelFamily.run_stats`); False:
    #: only what a fit reads (the drive model's per-trip sums), the bins left out where the
    #: family's statistics can do without them (`without_bins`) and read again from the log
    #: if something asks for them (`gather.ReadAgain`)
    bins: bool = True
    #: None: `segment.segment_run`
    segmenter: Segmenter | None = field(default=None, compare=False)

    def segments(self, mode: str) -> bool:
        """Whether a run of `mode` is segmented."""
        if self.segment == SEGMENT_ALL:
            return True
        if self.segment == SEGMENT_MOTION:
            return mode == "motion"
        return mode != "unknown"

    @property
    def kept(self) -> RunPlan:
        """The plan whose records a cache keeps: with the bins (a kept record makes the
        drive model's sums again from them when a later fit needs them)."""
        return replace(self, bins=True)

    @property
    def keepable(self) -> bool:
        """Whether a cache can keep its records (JSON values: with the default segmenter,
        and neither the causes' trace data nor views, which hold arrays)."""
        return self.segmenter is None and not self.causes and not self.view


#: `fit`: every run of known mode segmented, its phases and the families' statistics (what a
#: fit reads: no bins, unless a cache keeps the records: `gather`)
FIT_PLAN = RunPlan(bins=False)
#: `diagnose`: motion runs segmented, the causes' statistics and trace data
DIAGNOSE_PLAN = RunPlan(segment=SEGMENT_MOTION, phases=False, families=False, causes=True)
#: `report`: all of it, and every run's trace view
REPORT_PLAN = RunPlan(segment=SEGMENT_ALL, causes=True, view=True)


@dataclass(frozen=True, eq=False)
class RunRecord:
    """What a run gives a command (module docstring)."""

    row: dict[str, object]
    phases: tuple[dict[str, object], ...] = ()
    models: dict[str, object] = field(default_factory=dict)
    causes: dict[str, float] = field(default_factory=dict)
    traces: dict[str, object] = field(default_factory=dict)
    view: TraceView | None = None

    @property
    def run_id(self) -> str:
        return str(self.row["run_id"])


def segment_checked(run: Run, segmenter: Segmenter | None = None) -> Segmentation:
    """Segment a run; an unexpected failure of the segmenter becomes a one-line `LogError`
    naming the file, so one run cannot end a batch."""
    if segmenter is None:
        from wifibot_power.segment import segment_run as segmenter  # its own stage

    try:
        return segmenter(run)
    except WbpowerError:
        raise
    except Exception as exc:  # noqa: BLE001 - reported as this file's error, not a traceback
        raise LogError(
            f"segmentation failed ({exc.__class__.__name__}: {exc})",
            file=run.file,
            fix="check the log with 'wbpower segment'",
        ) from None


def run_record(run: Run, plan: RunPlan = FIT_PLAN) -> RunRecord:
    """The record of one run under `plan` (module docstring)."""
    from wifibot_power.phases import Segmentation
    from wifibot_power.runtable import WindowEnergy, run_row

    mode = run.meta.mode
    segmentation = segment_checked(run, plan.segmenter) if plan.segments(mode) else None
    if segmentation is None or mode == "unknown":  # nothing to fit it to: no phases
        fitted = Segmentation(run.meta.run_id, ())
    else:
        fitted = segmentation
    diagnosed = plan.causes and mode == "motion"
    # the phases' and the causes' windows' energies from one pass over the samples
    energy = WindowEnergy(run) if diagnosed else None
    causes: dict[str, float] = {}
    traces: dict[str, object] = {}
    if diagnosed:
        from wifibot_power.causes import RunView, run_statistics

        causes, traces = run_statistics(RunView(run, fitted, energy))
    return RunRecord(
        row=run_row(run, fitted, energy),
        phases=tuple(fitted.rows(run.file)) if plan.phases else (),
        models=family_statistics(run, fitted, plan.bins) if plan.families else {},
        causes=causes,
        traces=traces,
        view=_view(run, segmentation) if plan.view else None,
    )


def family_statistics(run: Run, segmentation: Segmentation, bins: bool = True) -> dict[str, object]:
    """Each model family's per-run statistics (`ModelFamily.run_stats`), by name; without
    `bins`, each made small where it can be (its `without_bins()`, if it has one)."""
    from wifibot_power.models import FAMILIES

    out = {name: family.run_stats(run, segmentation) for name, family in FAMILIES.items()}
    if not bins:
        for name, stats in out.items():
            smaller = getattr(stats, "without_bins", None)
            if smaller is not None:
                out[name] = smaller()
    return out


def _view(run: Run, segmentation: Segmentation | None) -> TraceView:
    from wifibot_power.figures.trace import trace_view
    from wifibot_power.phases import Segmentation

    return trace_view(run, segmentation or Segmentation(run.meta.run_id, ()))


# -- the cache's copy of a record (`fit --cache`) ------------------------------------------
def record_to_json(record: RunRecord, *, phases: bool = True) -> object:
    """A record as JSON values (datetimes as ISO text, NaN kept as NaN); only a plan's
    `keepable` records (no causes' statistics or trace data, no view)."""
    from wifibot_power.models import FAMILIES

    row = record.row
    dates = [k for k, v in row.items() if isinstance(v, datetime)]
    encoded = {k: (v.isoformat() if k in dates else v) for k, v in row.items()}
    return {
        "row": encoded,
        "datetimes": dates,
        "phases": list(record.phases) if phases else [],
        "models": {n: FAMILIES[n].stats_to_json(s) for n, s in record.models.items()},
    }


def record_from_json(stored: object) -> RunRecord:
    """The exact inverse of `record_to_json` (KeyError / TypeError: another layout)."""
    from wifibot_power.models import FAMILIES

    row = dict(stored["row"])  # type: ignore[index]
    for key in stored["datetimes"]:  # type: ignore[index]
        row[key] = datetime.fromisoformat(row[key])
    models = {n: FAMILIES[n].stats_from_json(s) for n, s in stored["models"].items()}  # type: ignore[index]
    return RunRecord(row=row, phases=tuple(stored["phases"]), models=models)  # type: ignore[index]


def record_memo(plan: RunPlan) -> ResultMemo[RunRecord]:
    """How a cache keeps each run's record under `plan`, valid for this code and the model
    families registered now (their statistics are in the record)."""
    from wifibot_power.models import FAMILIES

    return _record_memo(plan, tuple(FAMILIES))


@functools.lru_cache(maxsize=8)
def _record_memo(plan: RunPlan, families: tuple[str, ...]) -> ResultMemo[RunRecord]:
    """Made at first use: its key hashes all of wifibot_power's source (`code_digest`,
    ~11 ms), which a batch without a cache never needs."""
    from wifibot_power.cache import ResultMemo, code_digest

    return ResultMemo(
        key=f"pipeline.run_record {plan!r} families {','.join(families)} {code_digest()}",
        to_json=record_to_json,
        from_json=record_from_json,
    )
