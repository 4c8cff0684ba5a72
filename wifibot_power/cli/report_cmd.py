"""`wbpower report PATH... -o DIR` (see shared/spec/cli.md, "Figures")."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import (
    CacheDir,
    Jobs,
    JsonFlag,
    KeepDoubtful,
    check_out_dir,
    handles_errors,
    parse_cache,
    print_json,
    progress,
    progress_done,
    report_skipped,
    stage,
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.typer_app import app
from wifibot_power.io import ReadOptions


@app.command("report", **command_help("report"))
@handles_errors
@with_reading_options
def report_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    out: Annotated[
        Path,
        typer.Option(
            "-o",
            "--out",
            help="Write DIR/report.html and DIR/figures/ (PNG, and SVG of the model figures).",
        ),
    ],
    jobs: Jobs = 0,
    cache: CacheDir = None,
    json_out: JsonFlag = False,
    keep_doubtful: KeepDoubtful = False,
) -> None:
    """Read, segment, fit and diagnose the logs; write one self-contained report.html (opens
    offline: a zoomable trace view with a selection's energy, a sortable table of every
    run, the model figures, what it was made from) and its figures as files
    ('wbpower docs report')."""
    from wifibot_power.report import build_report, check_report_dir, report_figures, write_report
    from wifibot_power.report_page import drive_warnings

    check_out_dir(out)  # before any work
    check_report_dir(out)
    report = build_report(
        paths,
        options,
        wrap=lambda s: progress(s, "reading and segmenting", then="fitting and diagnosing"),
        jobs=jobs,
        cache=parse_cache(cache),
        on_problems=warn_problems,
        keep_doubtful=keep_doubtful,
        command=sys.argv,
    )
    if report.fit is not None:
        for warning in report.fit.warnings:  # as fit prints them (cli.md `warnings`)
            warn(warning)
    for warning in drive_warnings(report.fit):  # as fit prints them beside the drive terms
        warn(f"drive model: {warning}")
    stage("drawing the figures")
    written = write_report(report, out, jobs=jobs)
    progress_done()
    missing = [(name, note) for name, _, draw, note in report_figures(report) if draw is None]
    said = list(dict.fromkeys(note for _, note in missing))
    for note in said:  # one line per reason, each reason once
        warn(f"{', '.join(n for n, why in missing if why == note)}: {note}")
    # a run whose log says nothing to fit (no mode or speed: an instrument's export, not a
    # robot's run) is the expected case of a log to look at, not a skipped input: its trace,
    # levels and energy are the report (exit 0), its reason said once. Runs the fit left out
    # for a fault of their own (no motion found, a doubted segmentation) are skipped, as
    # `fit` says (exit 1).
    unknown = {view.file for view in report.traces if view.mode == "unknown"}
    read = set(map(id, report.read_skipped))
    not_fitted = [s for s in report.skipped if id(s) not in read and s.file in unknown]
    skipped = [s for s in report.skipped if s not in not_fitted]
    for item in not_fitted:
        if not any(item.why in note for note in said):
            warn(f"not in the fit: {item.reason}")
    page = out / "report.html"
    figures = [p for p in written if p.suffix in (".png", ".svg")]
    if json_out:
        print_json(
            {
                "report": str(page),
                "figures": [str(p) for p in figures],
                "not_drawn": [{"figure": n, "reason": note} for n, note in missing],
                "n_runs": len(report.traces),
                "not_fitted": [s.as_dict() for s in not_fitted],
            }
        )
    else:
        print(
            f"wbpower: wrote {len(figures)} figure file(s) into {out / 'figures'}", file=sys.stderr
        )
        print(f"report: {page}")
    raise typer.Exit(report_skipped(skipped))
