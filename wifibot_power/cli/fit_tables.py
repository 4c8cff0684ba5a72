"""The tables `fit` prints beside the paper table: the measured stop-and-go overhead and,
with `--runs`, each run's energy (renders only; the numbers come from `FitResult`).

Both go through `tables.print_table`, so no width cuts a number (docs/cli-output.md).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from wifibot_power.cli.common import stdout
from wifibot_power.cli.tables import Col, print_table

if TYPE_CHECKING:
    from wifibot_power.fit import FitResult

_OVERHEAD_COLUMNS = (
    Col("v m/s", key=True),
    Col("D m", key=True),
    Col("N", key=True),
    Col("runs"),
    Col("E_N J"),
    Col("E_1 J"),
    Col("measured %"),
    Col("95% CI %"),
    Col("model %"),
)
_RUN_COLUMNS = (
    Col("run", "text", key=True),
    Col("mode", "text"),
    Col("v m/s"),
    Col("D m"),
    Col("N"),
    Col("time s"),
    Col("E J"),
    Col("motion J"),
    Col("used", "text"),
)


def _num(value: object, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


def print_stop_and_go_table(result: FitResult) -> None:
    """Measured overhead of each trip held in 1 and N > 1 steps, beside the model's; nothing
    when the logs hold no such pair."""
    if not result.stop_and_go:
        return
    cells = []
    for row in result.stop_and_go:
        low, high = row.overhead_ci95
        cells.append(
            [
                f"{row.speed_mps:g}",
                f"{row.distance_m:g}",
                str(row.steps),
                f"{row.n_runs}+{row.one_step_n_runs}",
                f"{row.energy_J:.1f}",
                f"{row.one_step_energy_J:.1f}",
                f"{row.overhead_pct:.2f}",
                f"[{low:.2f}, {high:.2f}]" if math.isfinite(low) else "-",
                _num(row.model_overhead_pct, ".2f"),
            ]
        )
    print_table(
        stdout,
        "Stop-and-go overhead, measured vs model (Eq. 5/6): D m in N steps against 1",
        _OVERHEAD_COLUMNS,
        cells,
        caption=(
            "E_N, E_1: mean motion energy of the N-step and 1-step runs (runs: their counts); "
            "95% CI from the run-to-run spread (delta method on the log ratio, Welch t)"
        ),
    )


def print_runs_table(result: FitResult) -> None:
    """`fit --runs`: each run's energy (total and motion), duration, and whether it was used."""
    runs = result.runs.sort_values(["mode", "speed_mps", "distance_m", "steps", "run_id"])
    cells = [
        [
            str(row.run_id),
            str(row.mode),
            _num(row.speed_mps, "g"),
            _num(row.distance_m, "g"),
            str(row.steps) if row.mode == "motion" else "-",
            _num(row.duration_s, ".2f"),
            _num(row.energy_J, ".1f"),
            _num(row.motion_energy_J, ".1f") if row.mode == "motion" else "-",
            "yes" if row.usable else "no",
        ]
        for row in runs.itertuples(index=False)
    ]
    print_table(stdout, f"Energy of each of {len(runs)} run(s)", _RUN_COLUMNS, cells)
