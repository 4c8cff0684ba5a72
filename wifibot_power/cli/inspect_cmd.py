"""`wbpower inspect FILE...` (see shared/spec/cli.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from wifibot_power.cli.common import (
    JsonFlag,
    handles_errors,
    print_json,
    progress,
    report_skipped,
    stdout,
    warn,
    with_reading_options,
)
from wifibot_power.cli.typer_app import app
from wifibot_power.inspect import inspect_logs
from wifibot_power.io import ReadOptions


@app.command("inspect")
@handles_errors
@with_reading_options
def inspect_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
) -> None:
    """What is in each log: format, samples, period, duration, mean power, energy, metadata."""
    rows, skipped = inspect_logs(paths, options, wrap=lambda s: progress(s, "reading"))
    for row in rows:
        for problem in row["problems"]:
            warn(f"{row['file']}: {problem}")
    if json_out:
        # the JSON document stays the list of cli.md; skipped inputs go to stderr (and exit 1)
        print_json(rows)
    else:
        table = Table(title=f"{len(rows)} log(s)", title_justify="left")
        for name, justify in [
            ("file", "left"),
            ("format", "left"),
            ("run_id", "left"),
            ("mode", "left"),
            ("samples", "right"),
            ("period ms", "right"),
            ("duration s", "right"),
            ("mean W", "right"),
            ("energy J", "right"),
            ("problems", "left"),
        ]:
            table.add_column(name, justify=justify)
        for row in rows:
            meta = row["meta"]
            table.add_row(
                Path(str(row["file"])).name,
                str(row["format"]),
                str(row["run_id"]),
                str(meta["mode"]),
                f"{row['samples']:,}",
                f"{row['sample_period_s'] * 1e3:.5g}",
                f"{row['duration_s']:.3f}",
                f"{row['mean_power_W']:.3f}",
                f"{row['energy_J']:.1f}",
                _problems_cell(row["problems"]),
            )
        stdout.print(table)
        for row in rows:
            if row["channels"]:
                summed = ", ".join(
                    f"{c['name']} {c['mean_power_W']:.3f} W" for c in row["channels"]
                )
                name = Path(str(row["file"])).name
                stdout.print(f"{name}: power is the sum of channels {summed}", highlight=False)
    raise typer.Exit(report_skipped(skipped))


def _problems_cell(problems: list[str], shown: int = 2) -> str:
    if not problems:
        return "-"
    more = f"; and {len(problems) - shown} more (see stderr)" if len(problems) > shown else ""
    return "; ".join(problems[:shown]) + more
