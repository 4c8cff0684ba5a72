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
        title="Stop-and-go overhead: measured (mean motion energy over runs) vs model (Eq. 5/6)",
        title_justify="left",
    )
    for name in (
        "speed m/s",
        "dist m",
        "steps",
        "runs",
        "N steps J",
        "1 step J",
        "measured %",
        "95% CI %",
        "model %",
    ):
        table.add_column(name, justify="right")
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
        "95% CI from the run-to-run spread (delta method on the log ratio, Welch t); "
        "runs = N-step + 1-step runs"
    )
    table.caption_justify = "left"
    return table


def runs_table(result: FitResult) -> Table:
    """`fit --runs`: each run's energy (total and motion), duration, and whether it was used."""
    runs = result.runs.sort_values(["mode", "speed_mps", "distance_m", "steps", "run_id"])
    table = Table(title=f"Energy of each of {len(runs)} run(s)", title_justify="left")
    for name in (
        "run",
        "mode",
        "speed m/s",
        "dist m",
        "steps",
        "duration s",
        "energy J",
        "motion J",
        "used",
    ):
        table.add_column(name, justify="left" if name in ("run", "mode", "used") else "right")
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
