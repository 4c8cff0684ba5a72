"""`wbpower segment FILE` (see shared/spec/cli.md)."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from wifibot_power.cli.common import (
    JsonFlag,
    check_out_dir,
    handles_errors,
    out_dir,
    print_json,
    progress_done,
    stage,
    stdout,
    warn,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.plot_option import PlotFile, check_plot, plot_to
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.errors import UsageError
from wifibot_power.io import ReadOptions

if TYPE_CHECKING:
    from wifibot_power.phases import Segmentation
    from wifibot_power.run import Run

_PHASE_COLUMNS = (
    Col("step", key=True),
    Col("phase", "text", key=True),
    Col("start s"),
    Col("end s"),
    Col("duration s"),
    Col("mean W"),
    Col("energy J"),
)
_SPIKE_COLUMNS = (
    Col("start s", key=True),
    Col("duration s"),
    Col("peak W"),
    Col("energy above level J"),
)


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("phases.parquet and spikes.parquet")


@app.command("segment", **command_help("segment"))
@handles_errors
@with_wide_option
@with_reading_options
def segment_command(
    path: Annotated[Path, typer.Argument(help="One log file.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
    out: Out = None,
    plot: PlotFile = None,
) -> None:
    """Split one log into phases: idle/accel/cruise/decel per step for a motion run (turn
    where a turning column shows the robot turning while standing), steady levels
    otherwise. Short start-up spikes stay in the phase they start and are listed."""
    check_out_dir(out)  # before any work (cli.md)
    from wifibot_power.io.options import is_bag_folder

    if path.is_dir() and not is_bag_folder(path):  # a ROS 2 bag is a folder, and one log
        raise UsageError(
            f"{path}: is a folder; segment takes one file",
            fix="name one log in it, or give the folder to inspect or fit",
        )
    from wifibot_power.errors import LogError
    from wifibot_power.io import read_log, single_source
    from wifibot_power.segment import segment_run  # its numerics load only when used

    check_plot(plot)
    source = single_source(path)  # with the row of the runs.csv beside it (log-format.md)
    stage(f"reading {path.name}")  # a long log (10 M samples) takes seconds
    run = read_log(source.path, options, source.overrides, origin=source.origin)
    stage("segmenting")
    try:
        segmentation = segment_run(run)
    except LogError as exc:
        raise exc.with_file(path) from None
    progress_done()
    plot_to(plot, "trace", run, segmentation)
    warn_problems(run.file, run.problems)
    for doubt in segmentation.doubts:  # cli.md: a doubt is also a warning on stderr
        warn(f"{run.file}: segmentation in doubt: {doubt}")
    if out is not None:
        write_segmentation(segmentation, run.file, out)  # said by common.say_written
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
    _print_segmentation(run, segmentation)


def _print_segmentation(run: Run, segmentation: Segmentation) -> None:
    """`segment`'s tables on stdout: the phases (speed and |yaw rate| columns when a phase
    has them; a title and caption that say when the segmentation is in doubt), then the
    start-up spikes."""
    with_speed = any(p.speed_mps is not None for p in segmentation.phases)
    # a turning column: each phase's mean |yaw rate| (a `turn` phase spins in place)
    with_yaw = any(p.yaw_rate_radps is not None for p in segmentation.phases)
    cells = [
        [
            str(p.step),
            p.phase,
            f"{p.t_start_s:.4f}",
            f"{p.t_end_s:.4f}",
            f"{p.duration_s:.4f}",
            f"{p.mean_power_W:.3f}",
            f"{p.energy_J:.2f}",
        ]
        + (["-" if p.speed_mps is None else f"{p.speed_mps:.3f}"] if with_speed else [])
        + (["-" if p.yaw_rate_radps is None else f"{p.yaw_rate_radps:.3f}"] if with_yaw else [])
        for p in segmentation.phases
    ]
    title = f"{segmentation.run_id} ({run.meta.mode}): {len(segmentation.phases)} phase(s)"
    caption = None
    if segmentation.doubts:  # cli.md: never presented as sound, on stdout alone either
        title += ", in doubt: see warnings"
        caption = f"segmentation in doubt: {'; '.join(segmentation.doubts)}"
    columns = _PHASE_COLUMNS + ((Col("speed m/s"),) if with_speed else ())
    columns += (Col("|yaw rate| rad/s"),) if with_yaw else ()
    print_table(stdout, title, columns, cells, caption=caption)
    if segmentation.spikes:
        spikes = [
            [
                f"{s.t_start_s:.4f}",
                f"{s.duration_s:.4f}",
                f"{s.peak_W:.3f}",
                f"{s.energy_above_level_J:.4f}",
            ]
            for s in segmentation.spikes
        ]
        title = f"{len(segmentation.spikes)} start-up spike(s)"
        print_table(stdout, title, _SPIKE_COLUMNS, spikes)


def write_segmentation(segmentation: Segmentation, file: str, out: Path) -> list[Path]:
    """`segment -o DIR`, written as one set (`outputs.write_set`): `phases.parquet`, a row
    per phase, fit's phases.parquet columns (`phases.PHASE_COLUMNS`) and `doubts`
    (the segmentation's doubts joined by "; ", on every row; empty when it fits), and
    `spikes.parquet`, a row per start-up spike with its `run_id`."""
    import pandas as pd

    from wifibot_power.outputs import parquet_file, write_set
    from wifibot_power.phases import Spike

    phases = segmentation.frame(file)
    phases["speed_mps"] = phases["speed_mps"].astype("float64")  # None -> NaN, never object
    # (yaw_rate_radps: float64 from `phase_frame` already)
    phases["doubts"] = pd.Series(["; ".join(segmentation.doubts)] * len(phases), dtype=object)
    spike_columns = list(Spike.__dataclass_fields__)
    spikes = pd.DataFrame(
        [{"run_id": segmentation.run_id, **asdict(s)} for s in segmentation.spikes],
        columns=["run_id", *spike_columns],
    )
    spikes[spike_columns] = spikes[spike_columns].astype("float64")
    return write_set(
        out, {"phases.parquet": parquet_file(phases), "spikes.parquet": parquet_file(spikes)}
    )
