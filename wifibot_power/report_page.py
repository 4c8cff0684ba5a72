"""report.html: the page `wbpower report` writes (docs/report.md). One self-contained file:
the model figures embedded as PNG, the runs' traces as data for the interactive trace view
(`figures.explorer`, a script of our own inlined: nothing is fetched, ever), a sortable
table of every run with its energy, each run's phase (or level) and spike table as
`segment` prints it, and what the report was made from (cli.md, "Figures": wbpower's
version, the command line, the date, every input with its size and SHA-256).

Every reason something is missing is said once, at the top, and no link points to a figure
that was not drawn (issue 28).
"""

from __future__ import annotations

import base64
import hashlib
import html
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from wifibot_power.figures.trace import TraceView
    from wifibot_power.fit_result import FitResult
    from wifibot_power.io import Skipped
    from wifibot_power.report import Drawn, Report

e = html.escape


@dataclass(frozen=True)
class InputFile:
    """One input of the report: its path as given, its size [bytes] and SHA-256 (hex)."""

    path: str
    size_bytes: int
    sha256: str


@dataclass(frozen=True)
class Provenance:
    """What a report was made from (cli.md, "Figures")."""

    version: str
    command: tuple[str, ...]
    created_utc: str
    inputs: tuple[InputFile, ...]


def input_file(path: str) -> InputFile:
    """Size and SHA-256 of one input, read in 1 MiB blocks (memory bounded; ~1 s per GB)."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            while block := stream.read(1 << 20):
                digest.update(block)
        return InputFile(path, Path(path).stat().st_size, digest.hexdigest())
    except OSError:  # gone since it was read: said, not guessed
        return InputFile(path, -1, "")


def provenance(files: Iterable[str], command: Sequence[str] | None = None) -> Provenance:
    """The provenance of a report of `files` (each once, in the order given); `command`:
    the command line (None: this process's, `sys.argv`)."""
    from wifibot_power import __version__

    argv = list(sys.argv if command is None else command)
    if argv:
        argv[0] = Path(argv[0]).name  # "wbpower", not the venv's path to it
    return Provenance(
        version=__version__,
        command=tuple(argv),
        created_utc=datetime.now(UTC).strftime("%Y-%m-%d %H:%M:%S UTC"),
        inputs=tuple(input_file(f) for f in dict.fromkeys(files)),
    )


STYLE = (
    "body{font-family:sans-serif;max-width:1200px;margin:1em auto;padding:0 1em;color:#222}"
    "img{max-width:100%;height:auto;border:1px solid #ddd}"
    "table{border-collapse:collapse;font-size:0.9em;margin:0.5em 0}"
    "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
    "td:first-child,th:first-child{text-align:left}.note{color:#a00}"
    ".how{color:#555;font-size:0.9em}figure{margin:1em 0}"
    "#wb-canvas{width:100%;height:340px;border:1px solid #ddd;cursor:crosshair;"
    "touch-action:none;display:block}"
    ".wb-controls{margin:0.4em 0}.wb-controls button{margin-right:0.3em}"
    "#wb-readout{font-family:monospace;font-size:0.9em;min-height:2.6em}"
    "#wb-runs th{cursor:pointer;user-select:none}"
    "#wb-runs th[aria-sort=ascending]::after{content:' \\25B2'}"
    "#wb-runs th[aria-sort=descending]::after{content:' \\25BC'}"
    ".wb-scroll{max-height:28em;overflow-y:auto;display:inline-block}"
    "td.text,th.text{text-align:left}code{font-size:0.95em}"
)


def render_html(
    report: Report, drawn: list[tuple[Drawn, bytes | None]], anchors: dict[str, str]
) -> str:
    """The page (module docstring). `drawn`: every figure of the report with its PNG (None:
    not drawn, its `note` says why); the per-run trace figures are files only, the trace
    view shows the runs; `anchors`: each run's id in the page, by run_id."""
    model = [(item, data) for item, data in drawn if not item.name.startswith("trace_")]
    shown = [(item, data) for item, data in model if data is not None]
    missing = [item for item, data in model if data is None]
    views = list(report.traces)
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        "<title>wbpower report</title>",
        f"<style>{STYLE}</style>",
        "</head><body>",
        "<h1>wbpower report</h1>",
        f"<p>Logs: {e(', '.join(report.paths))}: {len(views)} run(s) read"
        + (f", {len(report.read_skipped)} input(s) not read" if report.read_skipped else "")
        + ".</p>",
    ]
    said = _not_drawn_html(missing, parts)
    contents = [("explore", "Explore the runs: the trace view"), ("runs", "Every run")]
    contents += [(item.name, item.title) for item, _ in shown]
    contents.append(("provenance", "What this report was made from"))
    parts.append(
        "<h2>Contents</h2><ul>"
        + "".join(f'<li><a href="#{e(a)}">{e(t)}</a></li>' for a, t in contents)
        + "</ul>"
    )
    parts += _summary_html(report, said)
    if views:
        parts += _explorer_html(views, anchors)
        parts += _runs_html(report, views, anchors, said)
    for item, data in shown:
        parts.append(f'<section id="{e(item.name)}"><h2>{e(item.title)}</h2>')
        if item.how_to_read:
            parts.append(f'<p class="how">{e(item.how_to_read)}</p>')
        encoded = base64.b64encode(data).decode("ascii")
        svg = f", figures/{e(item.name)}.svg" if item.svg else ""
        parts.append(
            f'<figure><img alt="{e(item.title)}" src="data:image/png;base64,{encoded}">'
            f"<figcaption>figures/{e(item.file or '')}{svg}</figcaption></figure></section>"
        )
    if report.read_skipped:
        parts.append("<h2>Inputs not read</h2><ul>")
        parts += [f"<li>{e(s.reason)}</li>" for s in report.read_skipped]
        parts.append("</ul>")
    if report.provenance is not None:
        parts += _provenance_html(report.provenance)
    if views:
        from wifibot_power.figures.explorer import explorer_data, explorer_script

        data = explorer_data(views, anchors)
        parts.append(f'<script type="application/json" id="wb-data">{data}</script>')
        parts.append(f"<script>{explorer_script()}</script>")
    # after loading, the page records how many of its images decoded (the Chromium test and
    # anyone opening the console can read it): <body data-images-loaded="N/M">
    parts.append(
        "<script>window.addEventListener('load',function(){var i=document.images,n=0;"
        "for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0){n++;}}"
        "document.body.setAttribute('data-images-loaded',n+'/'+i.length);});</script>"
    )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _not_drawn_html(missing: Sequence[Drawn], parts: list[str]) -> set[str]:
    """One line per reason, naming the figures it kept from being drawn (no link: there is
    nothing to link to); returns the reasons said."""
    by_reason: dict[str, list[str]] = {}
    for item in missing:
        by_reason.setdefault(item.note.removeprefix("not drawn: "), []).append(item.title)
    if by_reason:
        parts.append('<div id="not-drawn"><h2>Not drawn</h2><ul>')
        for reason, titles in by_reason.items():
            parts.append(f'<li class="note">{e("; ".join(titles))}: {e(reason)}</li>')
        parts.append("</ul></div>")
    return set(by_reason)


def drive_warnings(fit: FitResult | None) -> tuple[str, ...]:
    """The drive model's warnings (`DriveModel.warnings`), none without one."""
    drive = fit.drive if fit is not None else None
    return tuple(drive.summary()["warnings"]) if drive is not None else ()


def _summary_html(report: Report, said: set[str]) -> list[str]:
    from wifibot_power.models.paper_table import format_number as num

    out: list[str] = []
    rows = report.fit.table_rows() if report.fit is not None else []
    if report.fit is not None and not rows:  # free driving alone: the drive model only
        out.append(
            '<h2>Fitted model</h2><p class="note">The paper\'s models (P_acc, P_v, t_acc, '
            "idle) were not fitted: they need step runs (straight runs at set speeds, each "
            "accelerate / cruise / stop). The drive model fitted from these logs is in "
            "the drive model's sections below.</p>"
        )
    elif report.fit is not None:
        out.append("<h2>Fitted model (95% CI: OLS t intervals by run)</h2><table>")
        out.append(
            "<tr><th>parameter</th><th>unit</th><th>fitted</th><th>95% CI</th><th>R²</th>"
            "<th>paper</th><th>n runs</th></tr>"
        )
        for r in rows:
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
    elif report.fit_problem and report.fit_problem not in said:
        out.append(f'<p class="note">No fit: {e(report.fit_problem)}</p>')
    # the drive model's own warnings, as `fit` prints them beside its terms (a speed unit in
    # doubt makes every figure of it wrong)
    for warning in drive_warnings(report.fit):
        out.append(f'<p class="note">drive model: warning: {e(warning)}</p>')
    d = report.diagnosis
    if d is not None:
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
    elif report.diagnosis_problem and report.diagnosis_problem not in said:
        out.append(f'<p class="note">No diagnosis: {e(report.diagnosis_problem)}</p>')
    return out


def _explorer_html(views: Sequence[TraceView], anchors: dict[str, str]) -> list[str]:
    options = "".join(
        f'<option value="{k}">{e(v.run_id)} ({e(v.mode)})</option>' for k, v in enumerate(views)
    )
    out = [
        '<section id="explore"><h2>Explore the runs: the trace view</h2>',
        '<p class="how">Power [W] against time [s] of one run, its phases shaded (idle grey, '
        "accel orange, cruise sky blue, decel pink, level green), each phase's mean power a "
        "thin line, start-up spikes as red triangles, the speed on the right when the log has "
        "one. <b>Wheel</b>: zoom at the pointer; <b>drag</b>: select a span (its duration, "
        "energy and mean power below); <b>shift+drag</b>: pan; <b>double-click</b>: the whole "
        "run; keys on the focused trace: + − ← → Esc. Drawn from each run's min/max envelope "
        "(2 400 columns); a selection's energy is exact between column edges, and the ± "
        "bounds what the two partial columns at its ends can add ('wbpower docs report').</p>",
        f'<div class="wb-controls"><label>Run <select id="wb-run">{options}</select></label> '
        '<button id="wb-zoom-in">Zoom in</button><button id="wb-zoom-out">Zoom out</button>'
        '<button id="wb-left">◀ Pan</button><button id="wb-right">Pan ▶</button>'
        '<button id="wb-zoom-sel">Zoom to the selection</button>'
        '<button id="wb-whole">Whole run</button></div>',
        '<canvas id="wb-canvas" tabindex="0" aria-label="power trace of the chosen run"></canvas>',
        '<p id="wb-readout" aria-live="polite">(the trace view needs JavaScript; the runs\' '
        "trace figures are in figures/)</p>",
    ]
    for k, view in enumerate(views):
        out.append(
            f'<div class="wb-run-phases" data-run="{k}" id="{e(anchors[view.run_id])}"'
            + (" hidden" if k else "")
            + ">"
        )
        out += _phase_tables(view)
        out.append("</div>")
    out.append("</section>")
    return out


def _phase_tables(view: TraceView) -> list[str]:
    """A run's phases (or levels) and start-up spikes, the columns `segment` prints."""
    title = f"{view.run_id} ({view.mode}): {len(view.phases)} phase(s)"
    if view.doubts:
        title += f", in doubt: {'; '.join(view.doubts)}"
    out = [f"<h3{' class=note' if view.doubts else ''}>{e(title)}</h3><table>"]
    out.append(
        "<tr><th>step</th><th class=text>phase</th><th>start s</th><th>end s</th>"
        "<th>duration s</th><th>mean W</th><th>energy J</th></tr>"
    )
    for p in view.phases:
        out.append(
            f"<tr><td>{p.step}</td><td class=text>{e(p.phase)}</td><td>{_f(p.t_start_s, 4)}"
            f"</td><td>{_f(p.t_end_s, 4)}</td><td>{_f(p.t_end_s - p.t_start_s, 4)}</td>"
            f"<td>{_f(p.mean_power_W, 3)}</td><td>{_f(p.energy_J, 2)}</td></tr>"
        )
    out.append("</table>")
    if view.spikes:
        out.append(f"<h3>{len(view.spikes)} start-up spike(s)</h3><table>")
        out.append(
            "<tr><th>start s</th><th>duration s</th><th>peak W</th>"
            "<th>energy above level J</th></tr>"
        )
        for s in view.spikes:
            out.append(
                f"<tr><td>{_f(s.t_start_s, 4)}</td><td>{_f(s.duration_s, 4)}</td>"
                f"<td>{_f(s.peak_W, 3)}</td><td>{_f(s.energy_above_level_J, 4)}</td></tr>"
            )
        out.append("</table>")
    return out


def _f(value: float | None, places: int) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.{places}f}"


#: the runs table: heading, sort type, cell value of a run
RUN_COLUMNS = (
    ("run", "text"),
    ("mode", "text"),
    ("speed m/s", "number"),
    ("distance m", "number"),
    ("steps", "number"),
    ("samples", "number"),
    ("duration s", "number"),
    ("energy J", "number"),
    ("mean power W", "number"),
    ("phases", "number"),
    ("in the fit", "text"),
)


def _runs_html(
    report: Report, views: Sequence[TraceView], anchors: dict[str, str], said: set[str]
) -> list[str]:
    """Every run read: a row each with its energy (`TraceView.energy_J`, the samples'
    rectangle-rule sum as `inspect`), sortable by any column (click a heading)."""
    left_out = {s.file: s.why for s in report.skipped}
    in_fit = report.fit is not None
    out = [
        '<section id="runs"><h2>Every run</h2>',
        f'<p class="how">{len(views)} run(s). Click a heading to sort by it (again: the other '
        "way); click a run to show it in the trace view. Energy: the sum of the samples' "
        "power times their period (paper Eq. 1; the same as <code>inspect</code>).</p>",
        '<div class="wb-scroll"><table id="wb-runs"><thead><tr>'
        + "".join(
            f'<th data-type="{kind}"{" class=text" if kind == "text" else ""}>{e(name)}</th>'
            for name, kind in RUN_COLUMNS
        )
        + "</tr></thead><tbody>",
    ]
    for k, view in enumerate(views):
        duration = (view.t_end_s or view.duration_s) - float(view.power.time_s[0])
        energy = view.energy_J
        mean = energy / duration if duration > 0 else float("nan")
        why = left_out.get(view.file)
        if why is None:
            fit = "yes" if in_fit else "no"
        else:
            fit = "no" if why in said or any(why in s for s in said) else f"no: {why}"
        cells = [
            (view.run_id, f'<a href="#explore" data-run="{k}">{e(view.run_id)}</a>'),
            (view.mode, e(view.mode)),
            _number(view.speed_mps, 3),
            _number(view.distance_m, 3),
            _number(view.steps, 0),
            _number(view.samples, 0),
            _number(duration, 3),
            _number(energy, 2),
            _number(mean, 3),
            _number(len(view.phases), 0),
            (fit, e(fit)),
        ]
        out.append(
            "<tr>"
            + "".join(
                f'<td data-v="{e(str(v))}"{" class=text" if kind == "text" else ""}>{shown}</td>'
                for (v, shown), (_, kind) in zip(cells, RUN_COLUMNS, strict=True)
            )
            + "</tr>"
        )
    out.append("</tbody></table></div></section>")
    return out


def _number(value: float | int | None, places: int) -> tuple[str, str]:
    """(sort key, shown text) of a number; blank where unknown."""
    if value is None or not math.isfinite(value):
        return "", "-"
    return repr(float(value)), f"{value:,.{places}f}"


def _provenance_html(p: Provenance) -> list[str]:
    import shlex

    total = sum(max(f.size_bytes, 0) for f in p.inputs)
    out = [
        '<section id="provenance"><h2>What this report was made from</h2><table>',
        f"<tr><td>wbpower</td><td class=text>{e(p.version)}</td></tr>",
        f"<tr><td>command</td><td class=text><code>{e(shlex.join(p.command))}</code></td></tr>",
        f"<tr><td>date</td><td class=text>{e(p.created_utc)}</td></tr>",
        f"<tr><td>inputs</td><td class=text>{len(p.inputs)} file(s), {total:,} bytes</td></tr>",
        "</table>",
        f"<details{' open' if len(p.inputs) <= 10 else ''}><summary>every input with its "
        "size and SHA-256</summary><table><tr><th>file</th><th>bytes</th><th>SHA-256</th></tr>",
    ]
    for f in p.inputs:
        size = f"{f.size_bytes:,}" if f.size_bytes >= 0 else "gone"
        out.append(
            f"<tr><td>{e(f.path)}</td><td>{size}</td><td class=text><code>{e(f.sha256)}"
            "</code></td></tr>"
        )
    out.append("</table></details></section>")
    return out


def files_of(report_skipped: Sequence[Skipped], views: Sequence[TraceView]) -> list[str]:
    """Every input of a report: each run's log, then each input not read."""
    return [v.file for v in views] + [s.file for s in report_skipped]
