"""`wbpower report`: read, segment, fit and diagnose logs once, then draw every figure.

Each log is read and segmented once (`pipeline.gather` with `REPORT_PLAN`, one file in
memory per worker); what comes back per run is its record (`pipeline.RunRecord`: the row and
phases `fit` keeps, the causes' and trace statistics `diagnose` keeps, the trace's envelope
for its figure), never the samples. The fit and the diagnosis are then `fit.fit_records`
and `diagnose.diagnose_summaries`, the same as `wbpower fit` and `wbpower diagnose` give.

A log set the fit or the diagnosis cannot use (no motion metadata, too few runs) still gets
its trace figures; the report says what it cannot draw and why.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.errors import WbpowerError
from wifibot_power.io import LogSource, ReadOptions, Skipped
from wifibot_power.io.discover import reasons_in_brief
from wifibot_power.pipeline import REPORT_PLAN, RunRecord, gather
from wifibot_power.pipeline.duplicates import ProblemHook

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from wifibot_power.cache import ParseCache
    from wifibot_power.diagnose import Diagnosis
    from wifibot_power.drive.traces import HeldOutTrace
    from wifibot_power.figures.trace import TraceView
    from wifibot_power.fit import FitResult
    from wifibot_power.report_page import Provenance


@dataclass(frozen=True, eq=False)
class Report:
    """Everything the report draws: a trace view per run, the fit, the diagnosis (None, with
    the reason, where the logs do not allow one)."""

    paths: tuple[str, ...]
    traces: tuple[TraceView, ...]
    fit: FitResult | None
    fit_problem: str | None
    diagnosis: Diagnosis | None
    diagnosis_problem: str | None
    skipped: tuple[Skipped, ...] = ()
    #: a few runs' held-out drive-model power (`drive.traces.heldout_traces`)
    drive_traces: tuple[HeldOutTrace, ...] = ()
    #: the inputs not read at all (a subset of `skipped`, which also lists the runs the
    #: fit left out: those are in the report, their traces drawn)
    read_skipped: tuple[Skipped, ...] = ()
    #: what the report was made from (`report_page.provenance`)
    provenance: Provenance | None = None


def build_report(
    paths: str | Path | Sequence[str | Path],
    options: ReadOptions | None = None,
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    keep_doubtful: bool = False,
    command: Sequence[str] | None = None,
) -> Report:
    """Read every log under `paths` once (`pipeline.gather` with `REPORT_PLAN`), fit and
    diagnose them (module docstring); `cache` skips parsing files parsed before;
    `keep_doubtful`: as `fit`/`diagnose --keep-doubtful`, runs whose segmentation is in
    doubt are used by both; `command`: the command line the provenance names (None: this
    process's)."""
    from wifibot_power.diagnose import diagnose_summaries, summary_of
    from wifibot_power.fit import fit_records
    from wifibot_power.report_page import files_of, provenance

    gathered = gather(
        paths, options, REPORT_PLAN, wrap=wrap, jobs=jobs, cache=cache, on_problems=on_problems
    )
    records, read_skipped = gathered.records, gathered.skipped
    fit, skipped = fit_records(records, read_skipped, keep_doubtful=keep_doubtful)
    fit_problem = None if fit is not None else _why_no_fit(records, read_skipped, skipped)
    # diagnose's summaries: the causes' and trace statistics of motion runs (none for others)
    summaries = [summary_of(r) for r in records]
    diagnosis = diagnosis_problem = None
    if fit is not None:
        try:
            diagnosis = diagnose_summaries(summaries, read_skipped, keep_doubtful=keep_doubtful)
        except WbpowerError as exc:
            diagnosis_problem = exc.one_line()
    else:  # the fit's own reason: the page and stderr say it once for every figure
        diagnosis_problem = fit_problem
    drive_traces = ()
    if fit is not None and fit.drive is not None:
        from wifibot_power.drive.traces import heldout_traces
        from wifibot_power.models.drive import drive_stats_of

        drive_traces = heldout_traces([drive_stats_of(r) for r in records])
    views = tuple(r.view for r in records if r.view is not None)
    return Report(
        paths=gathered.paths,
        traces=views,
        fit=fit,
        fit_problem=fit_problem,
        diagnosis=diagnosis,
        diagnosis_problem=diagnosis_problem,
        skipped=skipped,
        drive_traces=drive_traces,
        read_skipped=tuple(read_skipped),
        provenance=provenance(files_of(read_skipped, views), command),
    )


def _why_no_fit(
    records: Sequence[RunRecord], read_skipped: Sequence[Skipped], skipped: Sequence[Skipped]
) -> str:
    """Why the fit is missing, as `fit` says it (the runs' own reasons), not a guess: an
    F1/10 car's runs have speed, distance and steps but hold 22-25 speed levels
    (docs/real-logs.md)."""
    unusable = skipped[len(read_skipped) :]  # fit_records puts the unread first
    if not records:
        # every reason, not "N for other reasons" (each input is listed too: issue 26)
        why = (
            reasons_in_brief(list(read_skipped), most=len(read_skipped))
            if read_skipped
            else ("no log was given")
        )
        return f"no log could be read: {why}"
    why = (
        reasons_in_brief(list(unusable), most=len(unusable))
        if unusable
        else "the paper's models need motion runs with speed, distance and steps in "
        "their metadata ('wbpower docs log-format')"
    )
    return f"none of the {len(records)} run(s) read can be fitted: {why}"


@dataclass(frozen=True)
class Drawn:
    """A figure of the report, or why it is missing."""

    name: str
    title: str
    file: str | None
    note: str = ""
    how_to_read: str = ""
    #: also written as figures/NAME.svg
    svg: bool = False


def report_figures(report: Report) -> Iterator[tuple[str, str, Callable[[], Figure] | None, str]]:
    """(name, title, draw() or None, note) of every figure of the report, in the order of the
    figure registry (`figures.FIGURES`): each figure drawn from the report
    (`FigureSpec.from_report`), then each per-run figure once per run (`trace_<run_id>`)."""
    from wifibot_power.figures import FIGURES

    for spec in FIGURES.values():
        if spec.per_run or spec.from_report is None:
            continue
        args = spec.from_report(report)
        if isinstance(args, str):
            yield spec.name, spec.title, None, f"not drawn: {args}"
        else:
            yield spec.name, spec.title, _bind(spec.draw, *args), ""
    safe = _unique_safe([view.run_id for view in report.traces])
    for spec in FIGURES.values():
        if spec.per_run:
            for view in report.traces:
                name = f"{spec.name}_{safe[view.run_id]}"
                yield name, f"Trace: {view.run_id}", _bind(spec.draw, view), ""


def _bind(function: Callable[..., Figure], *args: object) -> Callable[[], Figure]:
    return lambda: function(*args)


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name)[:120] or "run"


def _unique_safe(run_ids: Sequence[str]) -> dict[str, str]:
    """A file-name-safe name for each run_id, unique in the batch (issue 29: run_ids `a b`
    and `a_b` both gave `trace_a_b.png`, one figure lost): a name two run_ids share gets a
    short hash of each run_id appended, the same for the same run_id in every report."""
    import hashlib
    from collections import Counter

    shared = Counter(_safe(r) for r in set(run_ids))
    return {
        r: _safe(r)
        if shared[_safe(r)] == 1
        else f"{_safe(r)[:111]}_{hashlib.sha1(r.encode()).hexdigest()[:8]}"
        for r in run_ids
    }


#: the list `report` leaves in DIR/figures of the files it wrote there: what a later report
#: may replace (a user's own files there are never deleted: `check_report_dir`)
FIGURES_LIST = ".wbpower-figures"


def check_report_dir(out_dir: str | Path) -> None:
    """Refuse, before any work, an `-o DIR` whose `figures/` holds files an earlier report did
    not write (issue 29: `report -o DIR` replaced DIR/figures whole, deleting a user's
    files there). An earlier report's figures (listed in its `FIGURES_LIST`, or PNGs beside
    its report.html where an older wbpower left no list) are replaced as before."""
    figures = Path(out_dir) / "figures"
    if not figures.is_dir():
        return
    listed = figures / FIGURES_LIST
    if listed.is_file():
        ours = set(listed.read_text(encoding="utf-8").split("\n")) | {FIGURES_LIST}
    elif (Path(out_dir) / "report.html").is_file():
        ours = {p.name for p in figures.iterdir() if p.suffix == ".png" and p.is_file()}
    else:
        ours = set()
    foreign = sorted(p.name for p in figures.iterdir() if p.name not in ours)
    if foreign:
        shown = ", ".join(foreign[:3]) + (
            f" and {len(foreign) - 3} more" if len(foreign) > 3 else ""
        )
        raise WbpowerError(
            f"{figures} holds {len(foreign)} file(s) no wbpower report wrote ({shown}), and a "
            "report replaces that folder whole",
            fix="give another -o DIR, or move those files out of it",
        )


def write_report(report: Report, out_dir: str | Path, *, jobs: int | None = 1) -> list[Path]:
    """`DIR/figures/*.png`, the model figures also as `DIR/figures/*.svg` (not the runs'
    traces: 0.4 MB and 0.3 s each, 36 MB for 89 runs; `segment --plot F.svg` draws one),
    and `DIR/report.html` (`report_page.render_html`: one file that opens offline). `jobs`
    worker processes draw the figures (None or 0: all cores). Returns the files written.

    The report is built in a temporary folder next to DIR and put in place whole once it is
    complete (`outputs.staged_folder`): until then the old report and figures are untouched,
    and after, `figures/` holds this report's figures only, none of an older one's. A Ctrl-C
    or an error part way writes nothing (cli.md: "writes nothing partial")."""
    from wifibot_power.figures import FIGURES
    from wifibot_power.outputs import staged_folder, write_atomic
    from wifibot_power.parallel import map_ordered

    out_dir = Path(out_dir)
    items = list(report_figures(report))

    def draw_one(
        item: tuple[str, str, Callable[[], Figure] | None, str],
    ) -> tuple[bytes, bytes | None] | None:
        from wifibot_power.figures.style import png_bytes, svg_bytes

        name, _, draw, _ = item
        if draw is None:
            return None
        figure = draw()
        data = png_bytes(figure), (None if name.startswith("trace_") else svg_bytes(figure))
        figure.clear()  # one figure in memory at a time per worker
        return data

    import matplotlib.figure  # noqa: F401 - once, before workers are forked

    images = map_ordered(items, draw_one, jobs=jobs)
    written: list[Path] = []
    drawn: list[tuple[Drawn, bytes | None]] = []
    with staged_folder(out_dir) as stage:
        for (name, title, _, note), both in zip(items, images, strict=True):
            spec = FIGURES.get(name) or next(
                (f for f in FIGURES.values() if f.per_run and name.startswith(f"{f.name}_")), None
            )
            how = spec.how_to_read if spec else ""
            data, svg = both if both is not None else (None, None)
            file = f"{name}.png" if data is not None else None
            for suffix, content in ((".png", data), (".svg", svg)):
                if content is not None:
                    target = stage / "figures" / f"{name}{suffix}"
                    write_atomic(target, lambda tmp, c=content: tmp.write_bytes(c))
                    written.append(out_dir / "figures" / f"{name}{suffix}")
            drawn.append((Drawn(name, title, file, note, how, svg is not None), data))
        if not written:  # no figure drawn: still a figures/ folder, and no old one left
            (stage / "figures").mkdir()
        names = "\n".join(p.name for p in written)
        (stage / "figures" / FIGURES_LIST).write_text(names, encoding="utf-8")
        page = render_html(report, drawn)
        write_atomic(stage / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    written.append(out_dir / "report.html")
    return written


def render_html(report: Report, drawn: list[tuple[Drawn, bytes | None]]) -> str:
    """The page (`report_page.render_html`), each run's anchor its trace figure's name."""
    from wifibot_power.report_page import render_html as page

    safe = _unique_safe([v.run_id for v in report.traces])
    return page(report, drawn, {run_id: f"trace_{name}" for run_id, name in safe.items()})
