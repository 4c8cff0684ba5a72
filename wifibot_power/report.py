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

import base64
import html
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

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


def build_report(
    paths: str | Path | Sequence[str | Path],
    options: ReadOptions | None = None,
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    on_problems: ProblemHook | None = None,
    keep_doubtful: bool = False,
) -> Report:
    """Read every log under `paths` once (`pipeline.gather` with `REPORT_PLAN`), fit and
    diagnose them (module docstring); `cache` skips parsing files parsed before;
    `keep_doubtful`: as `fit`/`diagnose --keep-doubtful`, runs whose segmentation is in
    doubt are used by both."""
    from wifibot_power.diagnose import diagnose_summaries, summary_of
    from wifibot_power.fit import fit_records

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
    else:
        diagnosis_problem = "no fit to diagnose"
    drive_traces = ()
    if fit is not None and fit.drive is not None:
        from wifibot_power.drive.traces import heldout_traces
        from wifibot_power.models.drive import drive_stats_of

        drive_traces = heldout_traces([drive_stats_of(r) for r in records])
    return Report(
        paths=gathered.paths,
        traces=tuple(r.view for r in records if r.view is not None),
        fit=fit,
        fit_problem=fit_problem,
        diagnosis=diagnosis,
        diagnosis_problem=diagnosis_problem,
        skipped=skipped,
        drive_traces=drive_traces,
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
        "their metadata (log-format.md)"
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
    """`DIR/figures/*.png` and `DIR/report.html` (every image embedded as base64 PNG, so the
    one file opens offline). `jobs` worker processes draw the figures (None or 0: all
    cores). Returns the files written.

    The report is built in a temporary folder next to DIR and put in place whole once it is
    complete (`outputs.staged_folder`): until then the old report and figures are untouched,
    and after, `figures/` holds this report's figures only, none of an older one's. A Ctrl-C
    or an error part way writes nothing (cli.md: "writes nothing partial")."""
    from wifibot_power.figures import FIGURES
    from wifibot_power.outputs import staged_folder, write_atomic
    from wifibot_power.parallel import map_ordered

    out_dir = Path(out_dir)
    items = list(report_figures(report))

    def draw_one(item: tuple[str, str, Callable[[], Figure] | None, str]) -> bytes | None:
        from wifibot_power.figures.style import png_bytes

        name, _, draw, _ = item
        if draw is None:
            return None
        figure = draw()
        data = png_bytes(figure)
        figure.clear()  # one figure in memory at a time per worker
        return data

    import matplotlib.figure  # noqa: F401 - once, before workers are forked

    images = map_ordered(items, draw_one, jobs=jobs)
    written: list[Path] = []
    drawn: list[tuple[Drawn, bytes | None]] = []
    with staged_folder(out_dir) as stage:
        for (name, title, _, note), data in zip(items, images, strict=True):
            spec = FIGURES.get(name) or next(
                (f for f in FIGURES.values() if f.per_run and name.startswith(f"{f.name}_")), None
            )
            how = spec.how_to_read if spec else ""
            file = f"{name}.png" if data is not None else None
            if file:
                write_atomic(stage / "figures" / file, lambda tmp, data=data: tmp.write_bytes(data))
                written.append(out_dir / "figures" / file)
            drawn.append((Drawn(name, title, file, note, how), data))
        if not written:  # no figure drawn: still a figures/ folder, and no old one left
            (stage / "figures").mkdir()
        names = "\n".join(p.name for p in written)
        (stage / "figures" / FIGURES_LIST).write_text(names, encoding="utf-8")
        page = render_html(report, drawn)
        write_atomic(stage / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    written.append(out_dir / "report.html")
    return written


def render_html(report: Report, drawn: list[tuple[Drawn, bytes | None]]) -> str:
    """The self-contained report page: tables of the fit and diagnosis, every figure inline."""
    e = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        "<title>wbpower report</title>",
        "<style>body{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;"
        "color:#222}img{max-width:100%;height:auto;border:1px solid #ddd}"
        "table{border-collapse:collapse;font-size:0.9em;margin:0.5em 0}"
        "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
        "td:first-child,th:first-child{text-align:left}.note{color:#a00}"
        ".how{color:#555;font-size:0.9em}figure{margin:1em 0}</style>",
        "</head><body>",
        "<h1>wbpower report</h1>",
        f"<p>Logs: {e(', '.join(report.paths))}: {len(report.traces)} run(s) read"
        + (f", {len(report.skipped)} skipped or not usable" if report.skipped else "")
        + ".</p>",
    ]
    parts += _summary_html(report)
    # a table of contents: the model figures by name, then the runs' traces on one line
    links = [
        f'<a href="#{e(item.name)}">{e(item.title)}</a>'
        for item, _ in drawn
        if not item.name.startswith("trace_")
    ]
    runs = [
        f'<a href="#{e(item.name)}">{e(item.name.removeprefix("trace_"))}</a>'
        for item, _ in drawn
        if item.name.startswith("trace_")
    ]
    parts.append("<h2>Figures</h2><ul>" + "".join(f"<li>{link}</li>" for link in links))
    if runs:
        parts.append(f"<li>Runs' traces: {' · '.join(runs)}</li>")
    parts.append("</ul>")
    traces_started = False
    for item, data in drawn:
        if item.name.startswith("trace_") and not traces_started:
            parts.append("<h2>Runs: power traces with their phases</h2>")
            parts.append(f'<p class="how">{e(item.how_to_read)}</p>')
            traces_started = True
        tag = "h3" if item.name.startswith("trace_") else "h2"
        parts.append(f'<section id="{e(item.name)}"><{tag}>{e(item.title)}</{tag}>')
        if item.how_to_read and not item.name.startswith("trace_"):
            parts.append(f'<p class="how">{e(item.how_to_read)}</p>')
        if data is None:
            parts.append(f'<p class="note">{e(item.note)}</p>')
        else:
            encoded = base64.b64encode(data).decode("ascii")
            parts.append(
                f'<figure><img alt="{e(item.title)}" src="data:image/png;base64,{encoded}">'
                f"<figcaption>figures/{e(item.file or '')}</figcaption></figure>"
            )
        parts.append("</section>")
    if report.skipped:
        parts.append("<h2>Skipped or not usable</h2><ul>")
        parts += [f"<li>{e(s.reason)}</li>" for s in report.skipped]
        parts.append("</ul>")
    # after loading, the page records how many of its images decoded (the Chromium test and
    # anyone opening the console can read it): <body data-images-loaded="N/M">
    parts.append(
        "<script>window.addEventListener('load',function(){var i=document.images,n=0;"
        "for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0){n++;}}"
        "document.body.setAttribute('data-images-loaded',n+'/'+i.length);});</script>"
    )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _summary_html(report: Report) -> list[str]:
    from wifibot_power.models.paper_table import format_number as num

    e = html.escape
    out: list[str] = []
    if report.fit is None:
        out.append(f'<p class="note">Fit: {e(report.fit_problem or "")}</p>')
    else:
        out.append("<h2>Fitted model (95% CI: OLS t intervals by run)</h2><table>")
        out.append(
            "<tr><th>parameter</th><th>unit</th><th>fitted</th><th>95% CI</th><th>R²</th>"
            "<th>paper</th><th>n runs</th></tr>"
        )
        for r in report.fit.table_rows():
            low = r["ci95_low"]
            ci = f"[{num(low)}, {num(r['ci95_high'])}]" if np.isfinite(low) else "-"
            out.append(
                f"<tr><td>{e(str(r['parameter']))}</td><td>{e(str(r['unit']))}</td>"
                f"<td>{num(r['value'])}</td><td>{ci}</td><td>{num(r['r2'], 4)}</td>"
                f"<td>{num(r['paper'], 1)}</td><td>{r['n_runs']}</td></tr>"
            )
        out.append("</table>")
        if report.fit.stop_and_go:
            out.append("<h3>Stop-and-go overhead: measured vs model (Eq. 5/6)</h3><table>")
            out.append(
                "<tr><th>speed m/s</th><th>dist m</th><th>steps</th><th>N steps J</th>"
                "<th>1 step J</th><th>measured %</th><th>95% CI %</th><th>model %</th></tr>"
            )
            for s in report.fit.stop_and_go:
                low, high = s.overhead_ci95
                out.append(
                    f"<tr><td>{s.speed_mps:g}</td><td>{s.distance_m:g}</td><td>{s.steps}</td>"
                    f"<td>{s.energy_J:.1f}</td><td>{s.one_step_energy_J:.1f}</td>"
                    f"<td>{s.overhead_pct:.2f}</td><td>[{num(low, 2)}, {num(high, 2)}]</td>"
                    f"<td>{num(s.model_overhead_pct, 2)}</td></tr>"
                )
            out.append("</table>")
        # a weak or implausible fit says so here too, as `fit` does (cli.md `warnings`)
        for warning in report.fit.warnings:
            out.append(f'<p class="note">warning: {e(warning)}</p>')
    d = report.diagnosis
    if d is None:
        out.append(f'<p class="note">Diagnosis: {e(report.diagnosis_problem or "")}</p>')
    else:
        out.append("<h2>Diagnosis</h2><ul>")
        for f in d.findings:
            out.append(f"<li><b>{e(f.cause)}</b> (gain {f.gain_text()}): {e(f.summary)}</li>")
        if not d.findings:
            out.append("<li>no cause named</li>")
        out.append(
            f"<li>held-out RMSE of run energy: {d.baseline_rmse_J:.3g} J ({e(d.baseline_label)})"
            f" → {d.extended_rmse_J:.3g} J extended; gain {d.gain_text()}</li>"
        )
        if d.unexplained:
            out.append(f'<li class="note">unexplained: {e("; ".join(d.unexplained_reasons))}</li>')
        out.append("</ul>")
    return out
