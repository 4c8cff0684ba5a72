"""`wbpower lifetime` (see shared/spec/cli.md)."""

from __future__ import annotations

from typing import Annotated

import typer

from wifibot_power.cli.common import (
    JsonFlag,
    ModelSpec,
    check_out_dir,
    handles_errors,
    out_dir,
    print_json,
    stdout,
    warn,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.plot_option import PlotFile, check_plot, plot_to
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.errors import UsageError
from wifibot_power.lifetime import (
    DEFAULT_DIST_M,
    DEFAULT_E0_J,
    DEFAULT_SPEED_MPS,
    SWEEPS,
    TABLE2,
    LifetimeResult,
    lifetime_sweep,
    network_lifetime,
)
from wifibot_power.model import load_model
from wifibot_power.outputs import parquet_file, write_set

_RATES = "/".join(f"{r:g}" for r in TABLE2)

Rate = Annotated[
    float | None, typer.Option("--rate", help=f"Data rate [Mbit/s]: {_RATES} (paper Table 2).")
]
E0A = Annotated[float, typer.Option("--e0a", help="Initial energy of robot A, the monitor [J].")]
E0B = Annotated[float, typer.Option("--e0b", help="Initial energy of robot B, the relay [J].")]
Dist = Annotated[float, typer.Option("--dist", help="Distance B drives to relay [m].")]
Speed = Annotated[float, typer.Option("--speed", help="Speed of B's trip [m/s].")]
EmbeddedScale = Annotated[
    float,
    typer.Option(
        "--embedded-scale",
        help="Embedded power = idle power x this (0.5 = the paper's half-power system).",
    ),
]
TAcc = Annotated[
    float | None,
    typer.Option("--t-acc", help="Acceleration time of B's trip [s], overriding the model's."),
]
Sweep = Annotated[
    str | None,
    typer.Option("--sweep", help="Vary one input: e0a|e0b|dist|rate (the paper's Figure 7)."),
]

_COLUMNS = (
    ("rate Mbit/s", "rate_mbps", "g"),
    ("E0A kJ", "e0a_J", "kJ"),
    ("E0B kJ", "e0b_J", "kJ"),
    ("dist m", "distance_m", "g"),
    ("speed m/s", "speed_mps", "g"),
    ("travel s", "travel_s", ".2f"),
    ("travel J", "travel_energy_J", ".1f"),
    ("P_A high W", "p_a_high_W", ".3f"),
    ("P_A low W", "p_a_low_W", ".3f"),
    ("P_B W", "p_b_W", ".3f"),
    ("baseline h", "baseline_s", "h"),
    ("lifetime h", "lifetime_s", "h"),
    ("gain %", "improvement_pct", ".3f"),
    ("first dies", "first_to_die", "s"),
    ("note", "note", "s"),
)


#: what a reader looks for first: kept in the first table when the table is split
_FIRST = ("lifetime_s", "baseline_s", "improvement_pct", "first_to_die")
_SWEPT = {"e0a": "e0a_J", "e0b": "e0b_J", "dist": "distance_m", "rate": "rate_mbps"}


def _cell(value: object, spec: str) -> str:
    if spec == "s":
        return str(value)
    if spec == "kJ":
        return f"{float(value) / 1e3:g}"
    if spec == "h":
        return f"{float(value) / 3600:.4f}"
    return format(float(value), spec)


def _print(rows: list[LifetimeResult], title: str, key: str | None) -> None:
    """The rows as table(s): the results first (lifetime, gain), then the inputs and the
    intermediate powers; the swept input (`key`, else the rate) is repeated if split."""
    key = key or "rate_mbps"
    order = sorted(_COLUMNS, key=lambda c: (c[1] != key, c[1] not in _FIRST))
    cols = [
        Col(name, "text" if spec == "s" else "num", key=field == key) for name, field, spec in order
    ]
    cells = []
    for row in rows:
        summary = row.summary()
        cells.append([_cell(summary[field], spec) for _, field, spec in order])
    print_table(stdout, title, cols, cells)


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("lifetime.parquet (--sweep X: lifetime_sweep_X.parquet)")


@app.command("lifetime", **command_help("lifetime"))
@handles_errors
@with_wide_option
def lifetime_command(
    rate: Rate = None,
    e0a: E0A = DEFAULT_E0_J,
    e0b: E0B = DEFAULT_E0_J,
    dist: Dist = DEFAULT_DIST_M,
    speed: Speed = DEFAULT_SPEED_MPS,
    embedded_scale: EmbeddedScale = 1.0,
    model: ModelSpec = "paper",
    t_acc: TAcc = None,
    sweep: Sweep = None,
    json_out: JsonFlag = False,
    out: Out = None,
    plot: PlotFile = None,
) -> None:
    """Relay scenario (paper Eq. 7-11): lifetime of A with B relaying, against A alone."""
    check_out_dir(out)
    if sweep is not None and sweep not in SWEEPS:
        raise UsageError(f"unknown sweep '{sweep}'", fix=f"give --sweep {'|'.join(SWEEPS)}")
    if rate is None and sweep != "rate":
        raise UsageError("--rate is needed", fix=f"give --rate {_RATES}")
    power_model = load_model(model)
    check_plot(plot)
    scenario = {
        "e0a_J": e0a,
        "e0b_J": e0b,
        "distance_m": dist,
        "speed_mps": speed,
        "embedded_scale": embedded_scale,
        "t_acc_s": t_acc,
    }
    rates, sweeps = ((rate,) if rate is not None else None), ((sweep,) if sweep else SWEEPS)
    plot_to(plot, "figure7", power_model, sweeps=sweeps, rates_mbps=rates, **scenario)
    if sweep is None:
        result = network_lifetime(power_model, rate, **scenario)
        for message in result.warnings:
            warn(message)
        if out is not None:
            write_set(out, {"lifetime.parquet": parquet_file(_frame([result.summary()]))})
        if json_out:
            print_json(result.summary())
        else:
            _print([result], "Relay lifetime (paper Eq. 7-11)", None)
        return
    rows = lifetime_sweep(sweep, power_model, rate if rate is not None else 0.0, **scenario)
    summaries = [r.summary() for r in rows]
    for message in dict.fromkeys(w for r in rows for w in r.warnings):
        warn(message)
    if out is not None:
        write_set(out, {f"lifetime_sweep_{sweep}.parquet": parquet_file(_frame(summaries))})
    if json_out:
        print_json({"sweep": sweep, "rows": summaries})
    else:
        _print(rows, f"Relay lifetime against {sweep} (paper Figure 7)", _SWEPT[sweep])


def _frame(rows: object) -> object:
    """A DataFrame for `-o`; pandas is imported only when a table is written."""
    import pandas as pd

    return pd.DataFrame(rows)
