"""`wbpower fit PATH...` (see shared/spec/cli.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from wifibot_power.cli.common import (
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
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.plot_option import PlotFile, check_plot, plot_to
from wifibot_power.cli.tables import MARKDOWN, Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.io import ReadOptions

if TYPE_CHECKING:
    from wifibot_power.fit import FitResult


#: the parameter is the key (repeated if the table is split); numbers never cut
COLUMNS = (
    Col("parameter", "text", key=True),
    Col("unit", "text"),
    Col("fitted"),
    Col("95% CI", justify="center"),
    Col("R²"),
    Col("paper"),
    Col("n runs"),
)


def table_cells(result: FitResult) -> list[list[str]]:
    """The paper table's cells: coefficients, 95% intervals, R², the paper's values, n runs."""
    from wifibot_power.fit import format_number

    cells = []
    for row in result.table_rows():
        low, high = row["ci95_low"], row["ci95_high"]
        ci = f"[{format_number(low)}, {format_number(high)}]" if math.isfinite(low) else "-"
        cells.append(
            [
                str(row["parameter"]),
                str(row["unit"]),
                format_number(row["value"]),
                ci,
                format_number(row["r2"], 4),
                format_number(row["paper"], 1),
                str(row["n_runs"]),
            ]
        )
    return cells


def print_fit_table(result: FitResult) -> None:
    from wifibot_power.cli.common import stdout  # rich loads here: `--json` never draws

    print_table(
        stdout,
        f"Power model fitted over {result.n_runs} run(s) (95% CI: OLS t intervals by run)",
        COLUMNS,
        table_cells(result),
        caption=f"idle from {result.idle_source}",
    )


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("runs.parquet, phases.parquet, stop_and_go.parquet and model.json (for --model)")


@app.command("fit", **command_help("fit"))
@handles_errors
@with_wide_option
@with_reading_options
def fit_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
    markdown: Annotated[
        bool,
        typer.Option("--markdown", help="Print every table as Markdown (for a paper)."),
    ] = False,
    out: Out = None,
    jobs: Jobs = 0,
    cache: CacheDir = None,
    runs: Annotated[bool, typer.Option("--runs", help="Also print each run's energy.")] = False,
    plot: PlotFile = None,
    keep_doubtful: KeepDoubtful = False,
) -> None:
    """Segment every run and fit the paper's power models by least squares over runs."""
    check_out_dir(out)
    from wifibot_power.fit import fit_logs, write_fit  # pandas and numerics load only here

    check_plot(plot)
    result = fit_logs(
        paths,
        options,
        wrap=lambda s: progress(s, "reading and segmenting", then="fitting the models"),
        jobs=jobs,
        cache=parse_cache(cache),
        on_problems=warn_problems,
        keep_doubtful=keep_doubtful,
    )
    progress_done()
    if result.has_paper or result.drive is None:
        plot_to(plot, "power_speed", result)
    else:  # free driving: the drive model's held-out energies are fit's one figure
        plot_to(plot, "drive_energy", result.drive)
    warnings = list(result.warnings)
    if out is not None:
        stale = out / "model.json"
        if not result.writes_model and stale.is_file():
            # written with the tables, as one set: a model.json of an earlier fit beside
            # these tables would be read by `energy --model` as this fit's
            warnings.append(
                f"removed {stale}, the model of an earlier fit: this fit's model is "
                "incomplete, and energy --model would have read the old one as this fit's"
            )
        write_fit(result, out)  # said by handles_errors (common.say_written)
    if json_out:
        print_json({**result.summary(), "warnings": warnings})
    else:  # the tables; with --markdown, each as Markdown (tables.MARKDOWN)
        from wifibot_power.cli.fit_tables import (
            print_drive_tables,
            print_runs_table,
            print_stop_and_go_table,
        )

        token = MARKDOWN.set(markdown)
        try:
            if result.has_paper:
                print_fit_table(result)
            print_stop_and_go_table(result)
            print_drive_tables(result)
            if runs:
                print_runs_table(result)
        finally:
            MARKDOWN.reset(token)
    # an incomplete paper model: its notes are the why of its warning (incomplete_warning)
    if result.model_complete or not result.has_paper:
        for note in result.notes:
            warn(note)
    for warning in warnings:  # cli.md: also in `fit --json` `warnings`
        warn(warning)
    # an incomplete model (e.g. one speed: no slope) is in `warnings`, not the exit code:
    # cli.md's exit 1 is for skipped inputs and --fail-on-* checks (docs/fit.md)
    raise typer.Exit(report_skipped(list(result.skipped)))
