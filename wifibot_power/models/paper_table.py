"""The paper table of a `PaperFit`: a row per coefficient with its interval, R², the paper's
value and the runs it rests on (what `fit` prints, `--markdown` writes and the report
shows)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from wifibot_power.models.paper_fit import COMPONENT_MODES, NAN_PAIR

if TYPE_CHECKING:
    from wifibot_power.models.paper import PaperFit


def format_number(value: float | None, digits: int = 3) -> str:
    """A table cell: fixed digits, "-" for a missing value, no "-0.000"."""
    if value is None or not math.isfinite(value):
        return "-"
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def table_rows(fit: PaperFit) -> list[dict[str, object]]:
    """The paper table's rows: P_acc, P_v and t_acc (intercept, slope), idle, then each
    component net of idle."""
    model, paper = fit.model, fit.reference
    rows: list[dict[str, object]] = []

    def add(name, unit, value, ci, r2, paper_value, n) -> None:
        keys = ("parameter", "unit", "value", "ci95_low", "ci95_high", "r2", "paper", "n_runs")
        values = (name, unit, value, ci[0], ci[1], r2, paper_value, n)
        rows.append(dict(zip(keys, values, strict=True)))

    for label, line, ref, units in (
        ("P_acc", model.accel, paper.accel, ("W", "W/(m/s)")),
        ("P_v", model.cruise, paper.cruise, ("W", "W/(m/s)")),
        ("t_acc", model.t_acc, None, ("s", "s/(m/s)")),
    ):
        for part, unit, value, ci, ref_value in (
            ("intercept", units[0], line.intercept, line.intercept_ci95, ref and ref.intercept),
            ("slope", units[1], line.slope, line.slope_ci95, ref and ref.slope),
        ):
            paper_value = math.nan if ref_value is None else ref_value
            add(f"{label} {part}", unit, value, ci, line.r2, paper_value, line.n_runs)
    idle = fit.idle
    add("idle", "W", idle.value_W, idle.ci95, math.nan, paper.idle_W, idle.n_runs)
    for mode in COMPONENT_MODES:
        estimate = fit.components.get(mode)
        add(
            f"{mode} (net of idle)",
            "W",
            estimate.value_W if estimate else math.nan,
            estimate.ci95 if estimate else NAN_PAIR,
            math.nan,
            paper.components_W.get(mode, math.nan),
            estimate.n_runs if estimate else 0,
        )
    return rows


def to_markdown(fit: PaperFit) -> str:
    """The paper table as Markdown (paste into a report)."""
    num = format_number
    lines = [
        "| parameter | unit | fitted | 95% CI | R² | paper | n runs |",
        "| --- | --- | ---: | :---: | ---: | ---: | ---: |",
    ]
    for r in table_rows(fit):
        low = r["ci95_low"]
        ci = f"[{num(low)}, {num(r['ci95_high'])}]" if math.isfinite(low) else "-"  # type: ignore[arg-type]
        lines.append(
            f"| {r['parameter']} | {r['unit']} | {num(r['value'])} | {ci} | "  # type: ignore[arg-type]
            f"{num(r['r2'], 4)} | {num(r['paper'], 1)} | {r['n_runs']} |"  # type: ignore[arg-type]
        )
    return "\n".join(lines) + "\n"
