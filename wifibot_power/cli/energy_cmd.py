"""`wbpower energy` (see shared/spec/cli.md)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import (
    JsonFlag,
    ModelSpec,
    check_out_dir,
    handles_errors,
    out_dir,
    print_json,
    progress_done,
    stage,
    stdout,
    warn,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.plot_option import PlotFile, check_plot, plot_to
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.energy import EnergyReport, energy_report, speed_sweep
from wifibot_power.errors import UsageError
from wifibot_power.model import load_model
from wifibot_power.outputs import parquet_file, write_set

Speed = Annotated[float | None, typer.Option("--speed", help="Cruise speed [m/s].")]
Dist = Annotated[float | None, typer.Option("--dist", help="Trip distance [m].")]
Steps = Annotated[int, typer.Option("--steps", help="Number of equal stop-and-go steps.")]
TAcc = Annotated[
    float | None,
    typer.Option("--t-acc", help="Acceleration time [s], overriding the model's t_acc(v)."),
]
Payload = Annotated[
    float, typer.Option("--payload", help="Payload carried [kg] (used by accel_inertial).")
]
Profile = Annotated[
    Path | None,
    typer.Option(
        "--profile",
        help="A planned route: CSV of time_s, speed_mps[, yaw_rate_radps, surface]; its energy "
        "from the drive model of --model ('wbpower docs drive-model').",
    ),
]
Sweep = Annotated[
    str | None,
    typer.Option("--sweep", help="'speed': the paper's Figure 5 (2 m and 10 m, 0.1-0.9 m/s)."),
]


def _fmt(value: float, spec: str) -> str:
    return "-" if value is None or not math.isfinite(value) else format(value, spec)


_REPORT_COLUMNS = (
    Col("phase", "text", key=True),
    Col("time s"),
    Col("mean W"),
    Col("energy J"),
    Col("1-step time s"),
    Col("1-step energy J"),
)
_SWEEP_COLUMNS = (
    Col("distance m", key=True),
    Col("speed m/s", key=True),
    Col("1 step J"),
    Col("steps"),
    Col("stop-and-go J"),
    Col("overhead %"),
    Col("1 step J/m"),
    Col("note", "text"),
)


def _print_report(report: EnergyReport) -> None:
    trip, one = report.trip, report.one_step
    title = (
        f"{trip.distance_m:g} m at {trip.speed_mps:g} m/s in {trip.steps} step(s) of "
        # to the table's precision of times (a fitted t_acc is 0.800034 s, not to 1 us)
        f"{trip.step.step_m:g} m (t_acc {_fmt(trip.t_acc_s, '.3f')} s, "
        f"model {report.model_source})"
    )
    one_by_phase = {p.phase: p for p in one.phases}
    rows = []
    nothing = []  # an extension that adds no energy (a zero-mean ripple): said, not a row
    for p in trip.phases:
        q = one_by_phase[p.phase]
        if not p.time_s and not q.time_s and p.energy_J == 0 and q.energy_J == 0:
            nothing.append(p.phase)
            continue
        rows.append(
            [
                p.phase,
                _fmt(p.time_s, ".3f") if p.time_s else "-",
                _fmt(p.mean_power_W, ".3f"),
                _fmt(p.energy_J, ".2f"),
                _fmt(q.time_s, ".3f") if q.time_s else "-",
                _fmt(q.energy_J, ".2f"),
            ]
        )
    rows.append(
        [
            "total",
            _fmt(trip.time_s, ".3f"),
            _fmt(trip.energy_J / trip.time_s, ".3f"),
            _fmt(trip.energy_J, ".2f"),
            _fmt(one.time_s, ".3f"),
            _fmt(one.energy_J, ".2f"),
        ]
    )
    notes = [f"stop-and-go overhead: {report.overhead_pct:.2f} %"]
    if nothing:
        notes.append(f"{', '.join(nothing)} adds 0 J to this trip (no row)")
    if not trip.step.reaches_speed:
        notes.append(
            f"steps too short to reach {trip.speed_mps:g} m/s: triangular profile, "
            f"peak {trip.step.peak_speed_mps:.3f} m/s, no cruise"
        )
    if report.ignored_extensions:
        notes.append(f"ignored unknown extensions: {', '.join(report.ignored_extensions)}")
    styles = [None] * (len(rows) - 1) + ["bold"]
    print_table(stdout, title, _REPORT_COLUMNS, rows, caption="; ".join(notes), row_styles=styles)


def _print_sweep(rows: list[EnergyReport]) -> None:
    cells = []
    for row in rows:
        trip = row.trip
        cells.append(
            [
                f"{trip.distance_m:g}",
                f"{trip.speed_mps:g}",
                f"{row.one_step.energy_J:.1f}",
                str(trip.steps),
                f"{trip.energy_J:.1f}",
                f"{row.overhead_pct:.1f}",
                f"{row.one_step.energy_J / trip.distance_m:.2f}",
                ""
                if trip.step.reaches_speed
                else f"triangular (peak {trip.step.peak_speed_mps:.2f})",
            ]
        )
    print_table(stdout, "Figure 5: trip energy against speed", _SWEEP_COLUMNS, cells)


def _flat(summary: dict[str, object]) -> dict[str, object]:
    return {k: v for k, v in summary.items() if not isinstance(v, list | dict)}


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("energy.parquet and energy_phases.parquet (--sweep: energy_sweep_speed.parquet)")


@app.command("energy", **command_help("energy"))
@handles_errors
@with_wide_option
def energy_command(
    speed: Speed = None,
    dist: Dist = None,
    steps: Steps = 1,
    model: ModelSpec = "paper",
    t_acc: TAcc = None,
    payload: Payload = 0.0,
    sweep: Sweep = None,
    profile: Profile = None,
    json_out: JsonFlag = False,
    out: Out = None,
    plot: PlotFile = None,
) -> None:
    """Energy of a trip in N stop-and-go steps (paper Eq. 5/6), beside the one-step trip."""
    check_out_dir(out)
    if profile is not None:
        _route(profile, model, json_out)
        return
    power_model = load_model(model)
    check_plot(plot)
    if sweep is not None:
        if sweep != "speed":
            raise UsageError(f"unknown sweep '{sweep}'", fix="give --sweep speed")
        rows = speed_sweep(power_model, t_acc_s=t_acc, payload_kg=payload)
        plot_to(plot, "figure5", power_model, t_acc_s=t_acc)
        summaries = [r.summary() for r in rows]
        if out is not None:
            table = parquet_file(_frame(map(_flat, summaries)))
            write_set(out, {"energy_sweep_speed.parquet": table})
        for message in dict.fromkeys(w for r in rows for w in r.warnings):
            warn(message)
        if json_out:
            print_json({"sweep": "speed", "rows": summaries})
        else:
            _print_sweep(rows)
        return
    if speed is None or dist is None:
        raise UsageError(
            "--speed and --dist are needed", fix="e.g. --speed 0.8 --dist 10 --steps 10"
        )
    report = energy_report(power_model, speed, dist, steps, t_acc_s=t_acc, payload_kg=payload)
    plot_to(
        plot,
        "figure5",
        power_model,
        distances_m=(dist,),
        step_m=dist / steps,
        t_acc_s=t_acc,
        trip=(speed, dist, steps),
    )
    summary = report.summary()
    for message in report.warnings:
        warn(message)
    if out is not None:
        # as a set (`outputs.write_set`): never the new phases beside the old trip's row
        phases, trip = _frame(summary["phases"]), _frame([_flat(summary)])
        write_set(
            out,
            {"energy_phases.parquet": parquet_file(phases), "energy.parquet": parquet_file(trip)},
        )
    if json_out:
        print_json(summary)
    else:
        _print_report(report)


def _joules(value: float, digits: int) -> str:
    """An energy to `digits` decimals, a small negative share that rounds to nothing shown as
    0, not -0 (a braking term's few J returned on a route)."""
    return f"{round(value, digits) + 0.0:.{digits}f}"


def _route(profile: Path, model: str, json_out: bool) -> None:
    """`--profile`: a route's energy from the drive model (drive/profile.py)."""
    from wifibot_power.drive.profile import (
        load_drive_model,
        log_surfaces,
        read_profile,
        route_energy,
    )

    if model == "paper":
        raise UsageError(
            "--profile needs a drive model", fix="give --model model.json from 'wbpower fit -o'"
        )
    drive = load_drive_model(model)
    stage(f"reading {profile.name}")  # a log of hours takes seconds
    run = _as_log(profile)
    if run is not None:  # a log: measured beside predicted
        time_s, speed_mps, yaw_radps = run.time_s, run.speed_mps, run.yaw_rate_radps
        surface = log_surfaces(run)
    else:
        time_s, speed_mps, yaw_radps, surface = read_profile(profile)
    try:
        result = route_energy(drive, time_s, speed_mps, yaw_radps, surface)
    except ValueError as exc:
        raise UsageError(
            str(exc), file=profile, fix="name a surface of the model in its surface column"
        ) from None
    progress_done()
    for message in result.warnings:
        warn(message)
    summary = result.summary()
    if run is not None:
        summary["measured_J"] = run.energy_J
    if json_out:
        print_json(summary)
        return
    from wifibot_power.cli.fit_tables import interval_digits

    pi = summary["pi90_J"]
    # every energy to the decimals the route's 90% interval shows, no finer (one decimal
    # without an interval); the mean power to its interval over the route's duration
    digits = interval_digits(pi) if pi else 1
    watts = interval_digits([j / result.time_s for j in pi]) if pi and result.time_s > 0 else 2
    caption = (
        f"90% interval {pi[0]:.{digits}f}-{pi[1]:.{digits}f} J" if pi else ("no held-out interval")
    )
    rows = [[name, _joules(joules, digits)] for name, joules in result.terms_J.items()]
    if result.undetermined_terms:  # one share: the logs could not tell these terms apart
        label = f"not determined ({', '.join(result.undetermined_terms)})"
        rows.append([label, _joules(result.undetermined_J, digits)])
    rows.append(["total", _joules(result.energy_J, digits)])
    title = (
        f"{result.distance_m:.1f} m in {result.time_s:.1f} s, "
        f"mean {result.mean_power_W:.{watts}f} W"
    )
    if run is not None:
        rows.append(["measured", _joules(run.energy_J, digits)])
    columns = (Col("term", "text", key=True), Col("energy J"))
    print_table(stdout, title, columns, rows, caption=caption)


def _as_log(path: Path):
    """The route file as a log wbpower reads, with a speed column (None: a planned route)."""
    from wifibot_power.errors import LogError
    from wifibot_power.io.reader import read_log

    try:
        run = read_log(path)
    except LogError:
        return None
    return run if run.speed_mps is not None else None


def _frame(rows: object) -> object:
    """A DataFrame for `-o`; pandas is imported only when a table is written."""
    import pandas as pd

    return pd.DataFrame(rows)
