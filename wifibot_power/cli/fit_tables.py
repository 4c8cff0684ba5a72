"""The tables `fit` prints beside the paper table: the measured stop-and-go overhead and,
with `--runs`, each run's energy (renders only; the numbers come from `FitResult`)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from rich.table import Table

if TYPE_CHECKING:
    from wifibot_power.fit import FitResult


def _num(value: object, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


def stop_and_go_table(result: FitResult) -> Table | None:
    """Measured overhead of each trip held in 1 and N > 1 steps, beside the model's; None
    when the logs hold no such pair."""
    if not result.stop_and_go:
        return None
    table = Table(
        title="Stop-and-go overhead, measured vs model (Eq. 5/6): D m in N steps against 1",
        title_justify="left",
    )
    for name in (
        "v m/s",
        "D m",
        "N",
        "runs",
        "E_N J",
        "E_1 J",
        "meas.\n%",
        "95% CI\n%",
        "model\n%",
    ):
        table.add_column(name, justify="right", no_wrap=True)
    for row in result.stop_and_go:
        low, high = row.overhead_ci95
        ci = f"[{low:.2f}, {high:.2f}]" if math.isfinite(low) else "-"
        table.add_row(
            f"{row.speed_mps:g}",
            f"{row.distance_m:g}",
            str(row.steps),
            f"{row.n_runs}+{row.one_step_n_runs}",
            f"{row.energy_J:.1f}",
            f"{row.one_step_energy_J:.1f}",
            f"{row.overhead_pct:.2f}",
            ci,
            _num(row.model_overhead_pct, ".2f"),
        )
    table.caption = (
        "E_N, E_1: mean motion energy of the N-step and 1-step runs (runs: their counts); "
        "95% CI from the run-to-run spread (delta method on the log ratio, Welch t)"
    )
    table.caption_justify = "left"
    return table


def runs_table(result: FitResult) -> Table:
    """`fit --runs`: each run's energy (total and motion), duration, and whether it was used."""
    runs = result.runs.sort_values(["mode", "speed_mps", "distance_m", "steps", "run_id"])
    # no rules: nine columns fit in 80 without cutting a run id or a number
    table = Table(
        title=f"Energy of each of {len(runs)} run(s)",
        title_justify="left",
        box=None,
        pad_edge=False,
    )
    for name in ("run", "mode", "v m/s", "D m", "N", "time s", "E J", "motion J", "used"):
        left = name in ("run", "mode", "used")
        table.add_column(
            name, justify="left" if left else "right", no_wrap=True, min_width=len(name)
        )
    for row in runs.itertuples(index=False):
        table.add_row(
            str(row.run_id),
            str(row.mode),
            _num(row.speed_mps, "g"),
            _num(row.distance_m, "g"),
            str(row.steps) if row.mode == "motion" else "-",
            _num(row.duration_s, ".2f"),
            _num(row.energy_J, ".1f"),
            _num(row.motion_energy_J, ".1f") if row.mode == "motion" else "-",
            "yes" if row.usable else "no",
        )
    return table
