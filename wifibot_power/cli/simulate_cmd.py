"""`wbpower simulate -o DIR` (see shared/spec/cli.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import JsonFlag, check_out_dir, handles_errors, print_json, stdout
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


@app.command("simulate", **command_help("simulate"))
@handles_errors
@with_wide_option
def simulate_command(
    out: Annotated[Path, typer.Option("-o", "--out", help="Folder to write the logs into.")],
    effect: Annotated[
        list[str] | None,
        typer.Option(
            "--effect",
            help=f"NAME[=SIZE], repeatable: {', '.join(EFFECTS)} (the causes diagnose names).",
        ),
    ] = None,
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
    realism_name: Annotated[
        str,
        typer.Option(
            "--realism",
            help=f"{'|'.join(REALISM)}: 'field' adds what real logs carry (PWM tone, run-to-run "
            "spread, 0.8 W noise); docs/simulator.md.",
        ),
    ] = "lab",
    noise: Annotated[
        float | None,
        typer.Option(
            "--noise",
            min=0.0,
            help="Analyser noise per 0.1024 ms sample [W] (default 0.3; 0.8 with field).",
        ),
    ] = None,
    columns: Annotated[
        str, typer.Option(help=f"{'|'.join(COLUMN_SETS)}: time, voltage, current, power or power.")
    ] = "full",
    compress: Annotated[
        str, typer.Option(help=f"{'|'.join(COMPRESSIONS)}: how the logs are compressed.")
    ] = "none",
    decimals: Annotated[
        int, typer.Option(min=1, max=9, help="Decimals written for power [W].")
    ] = 4,
    drive: Annotated[
        str,
        typer.Option(
            "--drive",
            help="grid: the paper's experiment; free: a skid-steer robot driven freely (turns, "
            "stops, reversing) with speed and yaw-rate columns (docs/drive-model.md).",
        ),
    ] = "grid",
    surfaces: Annotated[
        str, typer.Option(help="With --drive free: the surfaces, comma-separated.")
    ] = "asphalt,grass",
    duration: Annotated[
        float, typer.Option(min=1.0, help="With --drive free: each run's duration [s].")
    ] = 90.0,
    json_out: JsonFlag = False,
) -> None:
    """Write synthetic logs of a physical Wifibot model, with runs.csv and truth.json."""
    # long only by its signature: typer reads the command's 18 options from it (issue 24
    # allows it); the body is short and the simulation lives in `wifibot_power.simulate`
    check_out_dir(out)
    if drive not in ("grid", "free"):
        raise typer.BadParameter("--drive takes grid or free")
    if drive == "free":
        _print_summary(_free(out, surfaces, repeats, duration, realism_name, seed), json_out)
        return
    # checked before anything is simulated or written (cli.md: a usage error, exit 2)
    write = WriteOptions(columns=columns, compress=compress, decimals=decimals)
    level = realism(realism_name)
    if noise is not None:
        level["noise_W"] = noise
    config = SimConfig(
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
    _print_summary(write_simulation(config, out, write), json_out)


def _print_summary(summary: dict[str, object], json_out: bool) -> None:
    if json_out:
        print_json(summary)
        return
    cells = [[key, str(value)] for key, value in summary.items()]
    print_table(stdout, "simulated", (Col("what", "text", key=True), Col("value", "text")), cells)
