"""`wbpower segment FILE` (see shared/spec/cli.md)."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from wifibot_power.cli.common import (
    JsonFlag,
    handles_errors,
    print_json,
    stdout,
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.typer_app import app
from wifibot_power.io import ReadOptions


@app.command("segment")
@handles_errors
@with_reading_options
def segment_command(
    path: Annotated[Path, typer.Argument(help="One log file.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
) -> None:
    """Split one log into phases: idle/accel/cruise/decel per step for a motion run, steady
    levels otherwise. Short start-up spikes stay in the phase they start and are listed."""
    from wifibot_power.errors import LogError
    from wifibot_power.io import read_log, single_source
    from wifibot_power.segment import segment_run  # its numerics load only when used

    source = single_source(path)  # with the row of the runs.csv beside it (log-format.md)
    run = read_log(source.path, options, source.overrides, origin=source.origin)
    try:
        segmentation = segment_run(run)
    except LogError as exc:
        raise exc.with_file(path) from None
    warn_problems(run.file, run.problems)
    for doubt in segmentation.doubts:  # cli.md: a doubt is also a warning on stderr
        warn(f"{run.file}: segmentation in doubt: {doubt}")
    if json_out:
        print_json(
            {
                "run_id": segmentation.run_id,
                "file": run.file,
                "mode": run.meta.mode,
                "phases": [p.as_dict() for p in segmentation.phases],
                "spikes": [asdict(s) for s in segmentation.spikes],
                "doubts": list(segmentation.doubts),
            }
        )
        return
    table = Table(
        title=f"{segmentation.run_id} ({run.meta.mode}): {len(segmentation.phases)} phase(s)",
        title_justify="left",
    )
    with_speed = any(p.speed_mps is not None for p in segmentation.phases)
    columns = ["step", "phase", "start s", "end s", "duration s", "mean W", "energy J"]
    for name in columns + (["speed m/s"] if with_speed else []):
        table.add_column(name, justify="left" if name == "phase" else "right")
    for p in segmentation.phases:
        cells = [
            str(p.step),
            p.phase,
            f"{p.t_start_s:.4f}",
            f"{p.t_end_s:.4f}",
            f"{p.duration_s:.4f}",
            f"{p.mean_power_W:.3f}",
            f"{p.energy_J:.2f}",
        ]
        if with_speed:
            cells.append("-" if p.speed_mps is None else f"{p.speed_mps:.3f}")
        table.add_row(*cells)
    stdout.print(table)
    if segmentation.spikes:
        spikes = Table(title=f"{len(segmentation.spikes)} start-up spike(s)", title_justify="left")
        for name in ("start s", "duration s", "peak W", "energy above level J"):
            spikes.add_column(name, justify="right")
        for s in segmentation.spikes:
            spikes.add_row(
                f"{s.t_start_s:.4f}",
                f"{s.duration_s:.4f}",
                f"{s.peak_W:.3f}",
                f"{s.energy_above_level_J:.4f}",
            )
        stdout.print(spikes)
