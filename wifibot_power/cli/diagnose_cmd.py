"""`wbpower diagnose PATH...` (see shared/spec/cli.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from wifibot_power.cli.common import (
    EXIT_OK,
    EXIT_SKIPPED,
    CacheDir,
    Jobs,
    JsonFlag,
    KeepDoubtful,
    check_out_dir,
    handles_errors,
    out_dir,
    parse_cache,
    print_json,
    progress,
    progress_done,
    report_skipped,
    stdout,
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.plot_option import PlotFile, check_plot, plot_to
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.io import ReadOptions

if TYPE_CHECKING:
    from wifibot_power.diagnose import Diagnosis


_CONFIG_COLUMNS = (
    Col("speed m/s", key=True),
    Col("dist m", key=True),
    Col("steps", key=True),
    Col("payload kg"),
    Col("runs"),
    Col("measured J"),
    Col("paper-form J"),
    Col("error %"),
    Col("extended J"),
    Col("error %"),
)
_PATTERN_COLUMNS = (
    Col("error of", "text", key=True),
    Col("against", "text", key=True),
    Col("rho"),
    Col("p"),
)
_FINDING_COLUMNS = (
    Col("cause", "text", key=True),
    Col("estimate"),
    Col("95% CI"),
    Col("p"),
    Col("gain %"),
    Col("gain 95% CI"),
    Col("metric", "text"),
    Col("evidence", "text"),
)


def _nothing_added(result: Diagnosis) -> bool:
    """No cause named: the extended model is the paper-form model, run for run (its columns
    and rows would repeat the baseline's: issue 28)."""
    runs = result.runs
    return not result.findings and bool(
        (runs["extended_energy_J"] == runs["baseline_energy_J"]).all()
    )


def _by_configuration(result: Diagnosis) -> None:
    keys = ["speed_mps", "distance_m", "steps", "payload_kg"]
    grouped = result.runs.groupby(keys, sort=True).agg(
        runs=("run_id", "size"),
        measured=("measured_energy_J", "mean"),
        baseline=("baseline_energy_J", "mean"),
        baseline_err=("baseline_error_pct", "mean"),
        extended=("extended_energy_J", "mean"),
        extended_err=("extended_error_pct", "mean"),
    )
    cells = [
        [
            f"{speed:.2f}",
            f"{dist:g}",
            str(steps),
            f"{payload:g}",
            str(int(row.runs)),  # iterrows makes the count a float
            f"{row.measured:.1f}",
            f"{row.baseline:.1f}",
            f"{row.baseline_err:+.2f}",
            f"{row.extended:.1f}",
            f"{row.extended_err:+.2f}",
        ]
        for (speed, dist, steps, payload), row in grouped.iterrows()
    ]
    columns, caption = _CONFIG_COLUMNS, None
    if _nothing_added(result):
        columns, cells = columns[:-2], [row[:-2] for row in cells]
        caption = "no cause named: the extended model is the paper-form model"
    print_table(
        stdout,
        "Measured vs simulated motion energy (held-out), mean over repeats",
        columns,
        cells,
        caption=caption,
    )


def _patterns(result: Diagnosis) -> None:
    cells = [
        [
            key.split("_error_vs_")[0],
            value["label"],
            f"{value['spearman_rho']:+.2f}",
            f"{value['p_value']:.2g}",
        ]
        for key, value in result.patterns.items()
        if not (_nothing_added(result) and key.startswith("extended_"))
    ]
    print_table(
        stdout,
        "Pattern of the paper-form model's error (Spearman rank correlation)",
        _PATTERN_COLUMNS,
        cells,
    )


def _interval(ci95: tuple[float, float]) -> str:
    low, high = ci95
    return f"[{low:.1f}, {high:.1f}]" if math.isfinite(low) else "-"


def _findings(result: Diagnosis) -> None:
    cells = []
    for f in result.findings:
        est = f.estimate
        low, high = est["ci95"]
        ci = f"[{low:.4g}, {high:.4g}]" if math.isfinite(low) else "-"
        cells.append(
            [
                f.cause,
                f"{est['value']:.4g} {est['unit']}",
                ci,
                f"{f.p_value:.2g}",
                f"{f.gain_pct:.1f}",
                _interval(f.gain_ci95),
                f.metric,
                f.summary,
            ]
        )
    if not result.findings:
        # the library's verdict: never "explains" while structure is left (cli.md)
        verdict = result.verdict_text
        if result.unexplained:
            verdict += " (see 'unexplained' below)"
        stdout.print(f"Findings: no cause named: {verdict}", markup=False, highlight=False)
        return
    for f in result.findings:
        failed = [c for c in f.checks if not c.passed]
        if failed:  # a finding's checks all pass by construction; shown if ever not
            cells.append([f.cause, "", "", "", "", "", "", f"check failed: {failed[0].detail}"])
    print_table(stdout, "Findings: named causes ('wbpower docs causes')", _FINDING_COLUMNS, cells)


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("discrepancy.parquet, findings.json and the extended model.json")


@app.command("diagnose", **command_help("diagnose"))
@handles_errors
@with_wide_option
@with_reading_options
def diagnose_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
    out: Out = None,
    jobs: Jobs = 0,
    cache: CacheDir = None,
    model: Annotated[
        str | None,
        typer.Option(
            "--model",
            help="Baseline: 'paper' or a model.json (e.g. the robot's stored model), used as "
            "given; default: the paper's model fitted to these logs.",
        ),
    ] = None,
    fail_on_discrepancy: Annotated[
        bool, typer.Option("--fail-on-discrepancy", help="Exit 1 when any finding is made (CI).")
    ] = False,
    plot: PlotFile = None,
    keep_doubtful: KeepDoubtful = False,
) -> None:
    """What the paper's model gets wrong on these logs, the named cause, the held-out gain."""
    check_out_dir(out)
    # imported here: scipy.stats alone costs a second, which no other command should pay
    from wifibot_power.diagnose import KEPT_IN_DOUBT, REJECTED, diagnose_logs, write_diagnosis
    from wifibot_power.model import load_model

    reference = load_model(model) if model is not None else None
    check_plot(plot)

    result = diagnose_logs(
        paths,
        options,
        wrap=lambda s: progress(
            s, "reading and segmenting", then="diagnosing: fits on held-out folds"
        ),
        jobs=jobs,
        cache=parse_cache(cache),
        on_problems=warn_problems,
        reference=reference,
        keep_doubtful=keep_doubtful,
    )
    progress_done()
    plot_to(plot, "heldout_error", result)
    for note in result.notes:  # the doubted runs it used: a warning too (cli.md)
        if note.kind == KEPT_IN_DOUBT:
            warn(note.text)
    if out is not None:
        write_diagnosis(result, out)
    if json_out:
        print_json(result.summary())
    else:
        _by_configuration(result)
        _patterns(result)
        _findings(result)
        stdout.print(result.headline())
        for finding in result.findings:
            passed = ", ".join(c.check for c in finding.checks if c.passed)
            stdout.print(f"{finding.cause}: checks passed: {passed}")
        for reason in result.unexplained_reasons:
            stdout.print(f"[bold]unexplained:[/bold] {reason}")
        for note in result.notes:
            if note.kind != REJECTED:  # a rejected candidate is printed as a reason
                stdout.print(f"note: {note.text}")
    code = report_skipped(list(result.skipped))
    if fail_on_discrepancy and result.findings:
        code = EXIT_SKIPPED
    raise typer.Exit(code or EXIT_OK)
