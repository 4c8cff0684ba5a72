"""`wbpower simulate -o DIR` (see shared/spec/cli.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import (
    JsonFlag,
    check_out_dir,
    handles_errors,
    print_json,
    progress_done,
    stage,
    stdout,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.simulate import (
    COLUMN_SETS,
    COMPRESSIONS,
    EFFECTS,
    REALISM,
    SimConfig,
    WriteOptions,
    parse_effects,
    realism,
    write_simulation,
)


def _free(
    out: Path,
    surfaces: str,
    repeats: int,
    duration_s: float,
    realism_name: str,
    seed: int,
) -> dict[str, object]:
    """`--drive free`: `repeats` runs a surface (drive/simulate.py); what was written."""
    from wifibot_power.drive.simulate import FreeDriveConfig, write_free

    names = tuple(s.strip() for s in surfaces.split(",") if s.strip())
    base = FreeDriveConfig()
    known = set(base.rolling_W_per_mps)
    if not names or not set(names) <= known:
        raise typer.BadParameter(f"--surfaces takes some of: {', '.join(sorted(known))}")
    config = FreeDriveConfig(
        surfaces=names,
        runs_per_surface=repeats,
        run_s=duration_s,
        realism=realism_name,
        seed=seed,
    )
    config.level()  # an unknown realism is a usage error before anything is written
    return write_free(config, out)


def _floats(text: str, option: str) -> tuple[float, ...]:
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise typer.BadParameter(f"{option} takes numbers separated by commas") from None


def _trips(text: str) -> tuple[tuple[float, int], ...]:
    trips = []
    for item in text.split(","):
        distance, _, steps = item.strip().partition("x")
        try:
            trips.append((float(distance), int(steps or 1)))
        except ValueError:
            raise typer.BadParameter(
                "--trips takes DISTANCExSTEPS items, e.g. 2x1,10x1,10x10"
            ) from None
    return tuple(trips)


#: the longer options of `simulate`, declared apart to keep the command short
Effect = Annotated[
    list[str] | None,
    typer.Option(
        "--effect",
        help=f"NAME[=SIZE], repeatable: {', '.join(EFFECTS)} (the causes diagnose names).",
    ),
]
Realism = Annotated[
    str,
    typer.Option(
        "--realism",
        help=f"{'|'.join(REALISM)}: 'field' adds what real logs carry (PWM tone, run-to-run "
        "spread, 0.8 W noise); 'wbpower docs simulator'.",
    ),
]
Noise = Annotated[
    float | None,
    typer.Option(
        "--noise",
        min=0.0,
        help="Analyser noise per 0.1024 ms sample [W] (default 0.3; 0.8 with field).",
    ),
]
Drive = Annotated[
    str,
    typer.Option(
        "--drive",
        help="grid: the paper's experiment; free: a skid-steer robot driven freely (turns, "
        "stops, reversing) with speed and yaw-rate columns ('wbpower docs drive-model').",
    ),
]


def _grid_config(
    *,
    effect: list[str] | None,
    seed: int,
    speeds: str,
    trips: str,
    repeats: int,
    payloads: str | None,
    modes: str,
    mode_repeats: int,
    sample_period: float,
    realism_name: str,
    noise: float | None,
) -> SimConfig:
    """`--drive grid`: the paper's experiment as `simulate`'s options ask for it."""
    level = realism(realism_name)
    if noise is not None:
        level["noise_W"] = noise
    return SimConfig(
        speeds_mps=_floats(speeds, "--speeds"),
        trips=_trips(trips),
        repeats=repeats,
        payloads_kg=_floats(payloads, "--payloads") if payloads else None,
        modes=tuple(m.strip() for m in modes.split(",") if m.strip()),
        mode_repeats=mode_repeats,
        sample_period_s=sample_period,
        **level,
        effects=parse_effects(effect or []),
        seed=seed,
    )


@app.command("simulate", **command_help("simulate"))
@handles_errors
@with_wide_option
def simulate_command(
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder to write the logs into.")],
    effect: Effect = None,
    seed: Annotated[int, typer.Option(help="Random seed: same seed, same logs.")] = 0,
    speeds: Annotated[
        str, typer.Option(help="Speeds [m/s], comma-separated.")
    ] = "0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9",
    trips: Annotated[
        str, typer.Option(help="Trips as DISTANCExSTEPS [m], comma-separated.")
    ] = "2x1,10x1,10x10",
    repeats: Annotated[int, typer.Option(min=1, help="Repeats of each motion run.")] = 3,
    payloads: Annotated[
        str | None,
        typer.Option(help="Payloads [kg], comma-separated (default 0; 0,2,4 with accel_inertial)."),
    ] = None,
    modes: Annotated[
        str, typer.Option(help="Non-motion mode logs (idle,network,video,cpu), or ''.")
    ] = "idle,network,video,cpu",
    mode_repeats: Annotated[int, typer.Option(min=0, help="Repeats of each mode log.")] = 2,
    sample_period: Annotated[
        float, typer.Option("--sample-period", min=1e-6, help="Sample period [s].")
    ] = 0.1024e-3,
    realism_name: Realism = "lab",
    noise: Noise = None,
    columns: Annotated[
        str, typer.Option(help=f"{'|'.join(COLUMN_SETS)}: time, voltage, current, power or power.")
    ] = "full",
    compress: Annotated[
        str, typer.Option(help=f"{'|'.join(COMPRESSIONS)}: how the logs are compressed.")
    ] = "none",
    decimals: Annotated[
        int, typer.Option(min=1, max=9, help="Decimals written for power [W].")
    ] = 4,
    drive: Drive = "grid",
    surfaces: Annotated[
        str, typer.Option(help="With --drive free: the surfaces, comma-separated.")
    ] = "asphalt,grass",
    duration: Annotated[
        float, typer.Option(min=1.0, help="With --drive free: each run's duration [s].")
    ] = 90.0,
    json_out: JsonFlag = False,
) -> None:
    """Write synthetic logs of a physical Wifibot model, with runs.csv and truth.json."""
    # the simulation lives in `wifibot_power.simulate`; the grid's config in `_grid_config`
    check_out_dir(out)
    if drive not in ("grid", "free"):
        raise typer.BadParameter("--drive takes grid or free")
    if drive == "free":
        stage("simulating free driving")
        summary = _free(out, surfaces, repeats, duration, realism_name, seed)
        named = [s.strip() for s in surfaces.split(",") if s.strip()]
        _print_summary({**summary, "surfaces": named}, json_out)
        return
    # checked before anything is simulated or written (cli.md: a usage error, exit 2)
    write = WriteOptions(columns=columns, compress=compress, decimals=decimals)
    config = _grid_config(
        effect=effect,
        seed=seed,
        speeds=speeds,
        trips=trips,
        repeats=repeats,
        payloads=payloads,
        modes=modes,
        mode_repeats=mode_repeats,
        sample_period=sample_period,
        realism_name=realism_name,
        noise=noise,
    )
    summary = write_simulation(
        config, out, write, on_run=lambda k, n: stage(f"simulating: {k} of {n} runs done")
    )
    _print_summary(summary, json_out)


def size_text(n_bytes: float) -> str:
    """A size in bytes as people read it: `87.6 MB`, `912 kB`, `512 B` (SI units)."""
    for unit in ("B", "kB", "MB", "GB"):
        if n_bytes < 1000 or unit == "GB":
            return f"{n_bytes:.0f} {unit}" if unit == "B" else f"{n_bytes:.3g} {unit}"
        n_bytes /= 1000
    return ""  # not reached


def summary_cells(summary: dict[str, object]) -> list[list[str]]:
    """What `simulate` wrote, in words: the logs (count, size), the folder, the effects
    (NAME=SIZE, or none), the seed, the surfaces (free driving)."""
    effects = summary.get("effects")
    cells = [
        ["logs", f"{summary['runs']} files, {size_text(float(summary['csv_bytes']))}"],
        ["folder", f"{summary['out_dir']} (with runs.csv and truth.json)"],
    ]
    if effects is not None:  # the grid; free driving has no effects
        named = ", ".join(f"{k}={v:g}" for k, v in dict(effects).items())
        cells.append(["effects", named or "none"])
    if "surfaces" in summary:
        cells.append(["surfaces", ", ".join(map(str, summary["surfaces"]))])
    cells.append(["seed", str(summary["seed"])])
    return cells


def _print_summary(summary: dict[str, object], json_out: bool) -> None:
    progress_done()
    if json_out:
        print_json(summary)
        return
    cols = (Col("what", "text", key=True), Col("written", "text"))
    print_table(stdout, f"Simulated {summary['runs']} runs", cols, summary_cells(summary))
