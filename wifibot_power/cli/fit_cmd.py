"""`wbpower fit PATH...` (see shared/spec/cli.md)."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.table import Table

from wifibot_power.cli.common import (
    CacheDir,
    Jobs,
    JsonFlag,
    KeepDoubtful,
    OutDir,
    handles_errors,
    parse_cache,
    print_json,
    progress,
    report_skipped,
    stdout,
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.typer_app import app
from wifibot_power.io import ReadOptions

if TYPE_CHECKING:
    from wifibot_power.fit import FitResult


def render_table(result: FitResult) -> Table:
    """The paper table: coefficients, 95% intervals, R², the paper's values, n runs."""
    from wifibot_power.fit import format_number

    table = Table(
        title=f"Power model fitted over {result.n_runs} run(s) (95% CI: OLS t intervals by run)",
        title_justify="left",
    )
    for name, justify in [
        ("parameter", "left"),
        ("unit", "left"),
        ("fitted", "right"),
        ("95% CI", "center"),
        ("R²", "right"),
        ("paper", "right"),
        ("n runs", "right"),
    ]:
        table.add_column(name, justify=justify)
    for row in result.table_rows():
        low, high = row["ci95_low"], row["ci95_high"]
        ci = f"[{format_number(low)}, {format_number(high)}]" if math.isfinite(low) else "-"
        table.add_row(
            str(row["parameter"]),
            str(row["unit"]),
            format_number(row["value"]),
            ci,
            format_number(row["r2"], 4),
            format_number(row["paper"], 1),
            str(row["n_runs"]),
        )
    table.caption = f"idle from {result.idle_source}"
    return table


@app.command("fit")
@handles_errors
@with_reading_options
def fit_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
    markdown: Annotated[
        bool, typer.Option("--markdown", help="Print the table as Markdown (for a paper).")
    ] = False,
    out: OutDir = None,
    jobs: Jobs = 0,
    cache: CacheDir = None,
    keep_doubtful: KeepDoubtful = False,
) -> None:
    """Segment every run and fit the paper's power models by least squares over runs."""
    from wifibot_power.fit import fit_logs, write_fit  # pandas and numerics load only here

    result = fit_logs(
        paths,
        options,
        wrap=lambda s: progress(s, "fitting"),
        jobs=jobs,
        cache=parse_cache(cache),
        on_problems=warn_problems,
        keep_doubtful=keep_doubtful,
    )
    if out is not None:
        written = write_fit(result, out)
        if not result.model_complete:
            warn(f"model.json not written: the model is incomplete ({'; '.join(result.notes)})")
        for path in written:
            print(f"wbpower: wrote {path}", file=sys.stderr)
    if json_out:
        print_json(result.summary())
    elif markdown:
        stdout.print(result.to_markdown(), markup=False, highlight=False, end="")
    else:
        stdout.print(render_table(result))
    for note in result.notes:
        warn(note)
    for warning in result.warnings:  # cli.md: also in `fit --json` `warnings`
        warn(warning)
    raise typer.Exit(report_skipped(list(result.skipped)))
