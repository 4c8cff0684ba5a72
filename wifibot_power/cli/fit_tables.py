"""The tables `fit` prints beside the paper table: the measured stop-and-go overhead and,
with `--runs`, each run's energy (renders only; the numbers come from `FitResult`).

Both go through `tables.print_table`, so no width cuts a number (docs/cli-output.md).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
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


_DRIVE_TERM_COLUMNS = (
    Col("term", "text", key=True),
    Col("surface", "text", key=True),
    Col("value"),
    Col("95% CI", justify="center"),
    Col("unit", "text"),
)
_DRIVE_HELDOUT_COLUMNS = (
    Col("held-out runs", key=True),
    Col("MAPE %"),
    Col("median %"),
    Col("in 90% PI %"),
)
_DRIVE_PAPER_COLUMNS = (
    Col("v m/s", key=True),
    Col("phase", "text", key=True),
    Col("paper fit W"),
    Col("± 95% W"),
    Col("drive W"),
    Col("± 95% W"),
    Col("agree", "text"),
)


def _interval(ci95: Sequence[float | None], digits: int = 3) -> str:
    from wifibot_power.fit import format_number

    low, high = ci95
    if low is None or high is None or not (math.isfinite(low) and math.isfinite(high)):
        return "-"
    return f"[{format_number(low, digits)}, {format_number(high, digits)}]"


def interval_digits(ci95: Sequence[float | None], most: int = 6) -> int:
    """Decimals that show an interval's width to two significant digits (a value and its
    interval are printed to the same decimals: digits beyond the interval's own are noise,
    never precision); 3 without an interval."""
    low, high = ci95
    if low is None or high is None or not (math.isfinite(low) and math.isfinite(high)):
        return 3
    width = high - low
    if not width > 0:
        return most
    return int(min(max(1 - math.floor(math.log10(width)), 0), most))


def _term_cells(name: str, surface: str, term: dict) -> list[str]:
    from wifibot_power.fit import format_number

    digits = interval_digits(term["ci95"])
    return [
        name,
        surface,
        format_number(term["value"], digits),
        _interval(term["ci95"], digits),
        term["unit"],
    ]


def print_drive_tables(result: FitResult) -> None:
    """The drive model (cli.md, "The drive model"): each term with its 95% interval and unit
    (per surface), the lag, the terms not determined, held-out accuracy and, on step runs,
    its phase powers beside P_acc(v) and P_v(v); nothing when no run had a speed."""
    drive = result.drive
    if drive is None:
        return
    summary = drive.summary()
    _print_drive_terms(summary)
    if summary["heldout"] is not None:
        _print_drive_heldout(summary["heldout"], result.run_ids)
    _print_drive_beside_paper(result)


def _print_drive_terms(summary: dict) -> None:
    """The terms' table (or, with no term determined, the line saying so), the reasons of
    the terms not determined and the model's warnings under it."""
    cells = [_term_cells(name, "all", t) for name, t in summary["terms"].items()]
    for surface, named in summary["surfaces"].items():
        cells += [_term_cells(name, surface, t) for name, t in named.items()]
    # one reason a line: each says why its term has no number
    not_determined = "".join(f"\n- {r}" for r in summary["not_determined"]) or " none"
    # the drive model's assumptions, said under its table (and in `fit --json` drive.warnings)
    said = "".join(f"\nwarning: {w}" for w in summary["warnings"])
    lag = _lag_said(summary)
    title = f"Drive model over {summary['n_runs']} run(s), power lags speed by {lag}"
    notes = f"not determined:{not_determined}{said}"
    if not cells:  # no term has a number: the reasons, not an empty table's frame
        line = (
            f"Drive model over {summary['n_runs']} run(s): no term determined; the lag "
            f"search's best: {lag}"
        )
        stdout.print(line, markup=False, highlight=False)
        stdout.print(notes, markup=False, highlight=False)
    else:
        title += "; the terms' 95% CI cluster-robust, by run or trip"
        print_table(stdout, title, _DRIVE_TERM_COLUMNS, cells, notes=notes)


def _lag_said(summary: dict) -> str:
    """The lag as `drive.model.lag_said` says it, from the `--json` document's values."""
    from wifibot_power.drive.model import lag_said

    return lag_said(summary["lag_s"], summary.get("lag_ci95_s"), summary["not_determined"])


def _print_drive_heldout(held: dict, run_ids: tuple[str, ...]) -> None:
    """The held-out accuracy's one-row table; `run_ids`: the batch's (`FitResult.run_ids`)."""
    print_table(
        stdout,
        "Drive model, held-out accuracy (K-fold by run): each run's energy predicted by "
        "a model fitted without it",
        _DRIVE_HELDOUT_COLUMNS,
        [
            [
                str(len(held["runs"])),
                _num(held["mape_pct"], ".2f"),
                _num(held["median_ape_pct"], ".2f"),
                _num(held["coverage_pi90_pct"], ".1f"),
            ]
        ],
        caption="MAPE: mean absolute % error of run energy; in 90% PI: how often the "
        "90% prediction interval held the measured energy; measured and predicted over the "
        "same 0.5 s windows (a drop-out's energy, unknown, is in neither: a log's whole "
        "energy can be more)"
        + _trips_said(held["runs"], run_ids)
        + _without_interval(held["runs"]),
    )


def _trips_said(runs: list[dict], run_ids: Iterable[str]) -> str:
    """The caption's note on runs held out as trips: a long log is cut into trips at its
    stops (drive/moving.py), each held out on its own as `run_id#k` (cli.md: "a long
    free-driving log may be cut into trips at its stops"); told from a log whose own run_id
    holds '#' by the batch's `run_ids`, as the trips are named (`drive.heldout.trip_log`)."""
    from wifibot_power.drive.heldout import trip_log

    known = set(run_ids)
    of_log = [trip_log(str(run["run_id"]), known) for run in runs]
    trips = [log for log in of_log if log is not None]
    if not trips:
        return ""
    logs = len(set(trips))
    return (
        f"; {len(trips)} of the {len(runs)} are trips of {logs} log(s) cut at their stops "
        "(run_id#k)"
    )


def _without_interval(runs: list[dict]) -> str:
    """The caption's note on the trips predicted at 0 J: they have no interval and are not in
    the coverage (drive/heldout.py), so its share is of fewer trips than the table counts."""
    none = sum(1 for run in runs if run["predicted_J"] == 0)
    return (
        f" (of the {len(runs) - none} trips with one: {none} predicted at 0 J have none)"
        if none
        else ""
    )


def _print_drive_beside_paper(result: FitResult) -> None:
    """On step runs: the drive model's mean phase powers beside P_acc(v) and P_v(v), and its
    held-out run-energy error beside the paper model's."""
    from wifibot_power.fit import format_number

    rows = result.drive_vs_paper()
    if not rows:
        return
    cells = []
    for row in rows:
        phases = (
            ("accel", row.paper_accel_W, row.paper_accel_ci95, row.accel_W, row.accel_ci95,
             row.accel_agree),
            ("cruise", row.paper_cruise_W, row.paper_cruise_ci95, row.cruise_W,
             row.cruise_ci95, row.cruise_agree),
        )  # fmt: skip
        for phase, paper, paper_ci, power, ci, agree in phases:
            cells.append(
                [
                    f"{row.speed_mps:g}",
                    phase,
                    format_number(paper, 2),
                    format_number((paper_ci[1] - paper_ci[0]) / 2, 3),
                    format_number(power, 2),
                    format_number((ci[1] - ci[0]) / 2, 3),
                    "yes" if agree else "no",
                ]
            )
    print_table(
        stdout,
        "Drive model on the paper's step runs: its mean phase powers beside the fitted "
        "P_acc(v) and P_v(v)",
        _DRIVE_PAPER_COLUMNS,
        cells,
        caption="paper fit: the fitted line at v, ± the 95% interval of its mean; drive: "
        "the drive model's mean power over an acceleration ramp of t_acc(v) or a cruise at "
        "v, ± its 95% interval; agree: the intervals overlap",
    )
    said = []
    if not all(row.accel_agree and row.cruise_agree for row in rows):
        said.append(DISAGREE_NOTE)
    from wifibot_power.diagnose.baseline import heldout_beside_paper

    beside = heldout_beside_paper(result)
    if beside is not None:
        said.append(
            f"held-out run energy, error over each run's motion energy ({beside.n_runs} "
            f"step runs, K-fold by run): drive model MAPE {beside.drive_mape_pct:.2f}%, "
            f"the paper's model (Eq. 1-6, diagnose's baseline) {beside.paper_mape_pct:.2f}%"
        )
    for line in said:
        stdout.print(line, markup=False, highlight=False)


#: Said under the step runs' table where a phase power disagrees (docs/drive-model.md, "The
#: paper's step runs"): why the two models may differ beyond their intervals.
DISAGREE_NOTE = (
    "where they disagree: the drive model is fitted over every phase, stops included, with "
    "one form at all speeds, the paper's lines to each phase's mean alone; power that does "
    "not follow the drive model's terms shows there, not as a wider interval: e.g. a stop "
    "whose power is not one braking mass times a v (the simulator's decel_phase, half the "
    "rolling power over 0.3 s at every speed: its cruise 0.01-0.03 W off) ('wbpower docs "
    "drive-model')"
)
