"""The per-run table: one row per run, from its samples and its segmentation.

This is what `fit` fits over (one point per run) and what `fit -o` writes as
`runs.parquet` (cli.md). Phase means and energies are recomputed here from the run's
own samples over each phase's sample range, so the table does not depend on how the
segmenter rounded its own numbers, and energies stay exactly additive (rectangle rule,
`wifibot_power.run.energy_J`): `motion_energy_J + idle energy == energy_J`.

Column meanings (units in the names):

- `motion_energy_J`: energy over the `accel`, `cruise` and `decel` phases (idle excluded).
- `t_acc_s`: mean duration of the `accel` phases over the steps.
- `accel_mean_power_W`, `cruise_mean_power_W`, `decel_mean_power_W`, `idle_mean_power_W`:
  time-weighted mean power over all phases of that name in the run (energy / duration).
- `decel_duration_s`: mean `decel` duration per step (0 when no stopping phase was found).
- `steps_found`: steps the segmentation found (motion runs), to check against `steps`.
- `spike_energy_J`: energy of the start-up spikes above their phase's level.
- `speed_mps`: the run's speed: the time-weighted mean of its cruise phases' speeds when
  they carry one (phases from a speed column, or the commanded speed), else the metadata's.
- `commanded_speed_mps`: the metadata's `speed_mps` (log-format.md: the commanded speed),
  NaN without one: with a speed column, runs of one commanded speed share it where their
  measured `speed_mps` differ (diagnose's configurations, `residuals.py`).
- `distance_m`, `distance_source`: the run's distance from its metadata (`"metadata"`);
  without one, on a log with a speed column, the path its motion phases cover, sum of
  |v|·dt over their samples (`"speed column"`: the wheels' path, forward or back, as the
  speed column measures or commands it); else NaN (`""`), and a motion run is not usable.
- `cruise_levels`: how many speed levels its cruise phases hold (`fit.speed_levels`); a
  run with more than one is not usable (`fit` takes one speed per run).
- `doubts`: the segmentation's doubts (`Segmentation.doubts`) joined by "; ", empty when
  the phases fit the trace.
- `usable`, `skip_reason`: whether `fit` can use the run, and why not. A run whose
  segmentation is in doubt is not usable (its reason starts with `DOUBT_REASON`) unless
  `admit_doubtful` lets it in (`fit`/`diagnose --keep-doubtful`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.phases import Phase, Segmentation
from wifibot_power.run import Run
from wifibot_power.segment.common import speed_across_gaps

if TYPE_CHECKING:  # pandas (~0.45 s to import) loads only when the table is asked for
    import pandas as pd

#: Phases whose energy is motion energy (cli.md `fit`: idle excluded).
MOTION_PHASES = ("accel", "cruise", "decel")

#: Modes whose mean power, net of idle, is a component power (paper Table 1).
COMPONENT_MODES = ("network", "video", "cpu")

#: Columns of runs.parquet, in order.
RUN_COLUMNS = (
    "run_id",
    "file",
    "mode",
    "speed_mps",
    "commanded_speed_mps",
    "distance_m",
    "distance_source",
    "steps",
    "payload_kg",
    "started_at",
    "samples",
    "sample_period_s",
    "duration_s",
    "energy_J",
    "mean_power_W",
    "motion_energy_J",
    "steps_found",
    "t_acc_s",
    "accel_mean_power_W",
    "accel_energy_J",
    "cruise_mean_power_W",
    "cruise_duration_s",
    "cruise_energy_J",
    "decel_duration_s",
    "decel_mean_power_W",
    "decel_energy_J",
    "idle_mean_power_W",
    "idle_duration_s",
    "spike_energy_J",
    "doubts",
    "cruise_levels",
    "usable",
    "skip_reason",
)

#: How the skip reason of a run left out for its segmentation's doubts starts.
DOUBT_REASON = "segmentation in doubt: "


class WindowEnergy:
    """Energy [J] of windows of a run's samples (rectangle rule, Eq. 1's integral over the
    window), for any windows at once: one pass of `np.add.reduceat` over the samples at the
    windows' sorted edges, pairwise-summed between them, shared by `run_row` and the
    causes' windows (`causes.run_statistics`). No array as long as the run is made (a
    cumulative sum of the samples was one: 1.8 ms per 300 k samples, against 0.06 ms for
    the pass)."""

    def __init__(self, run: Run) -> None:
        self._power_W = run.power_W
        self._period_s = run.sample_period_s

    def between(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Energy of samples ``starts[k]`` up to, not including, ``ends[k]`` [J] (0 <= start
        <= end <= samples)."""
        starts = np.asarray(starts, dtype=np.int64)
        ends = np.asarray(ends, dtype=np.int64)
        edges, where = np.unique(np.concatenate([starts, ends]), return_inverse=True)
        before_W = np.zeros(edges.size)
        inside = edges[(edges > 0) & (edges < self._power_W.size)]
        if self._power_W.size:
            # the samples between consecutive edges, summed; a prefix at each edge after 0
            pieces_W = np.add.reduceat(self._power_W, np.r_[0, inside], dtype=np.float64)
            prefix_W = np.cumsum(pieces_W)
            before_W[edges > 0] = prefix_W[: int(np.count_nonzero(edges > 0))]
        before_W = before_W[where]
        return (before_W[starts.size :] - before_W[: starts.size]) * self._period_s


def _phase_sums(
    run: Run, phases: Sequence[Phase], energy: WindowEnergy | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Energy [J] and duration [s] of each phase, from the run's samples (vectorised)."""
    period_s = run.sample_period_s
    if not phases:
        return np.zeros(0), np.zeros(0)
    starts = np.array([p.i_start for p in phases], dtype=np.int64)
    ends = np.array([p.i_end for p in phases], dtype=np.int64)
    energy = energy or WindowEnergy(run)
    return energy.between(starts, ends), (ends - starts) * period_s


def _check_cover(run: Run, segmentation: Segmentation) -> str | None:
    """Why the phases do not cover the run's samples exactly once in order, or None."""
    if not segmentation.phases:
        return "segmentation found no phases"
    starts = np.array([p.i_start for p in segmentation.phases])
    ends = np.array([p.i_end for p in segmentation.phases])
    if starts[0] != 0 or ends[-1] != run.samples or np.any(starts[1:] != ends[:-1]):
        return (
            f"phases do not cover the {run.samples} samples exactly once "
            f"(first {starts[0]}, last {ends[-1]})"
        )
    if np.any(ends <= starts):
        return "segmentation returned an empty phase"
    return None


def _cruise_speed(segmentation: Segmentation) -> tuple[float | None, int]:
    """The run's speed from its cruise phases' measured speeds (a speed column: their
    time-weighted mean), and how many speed levels they hold (`fit.speed_levels`); None
    and 0 when no cruise phase carries a speed."""
    from wifibot_power.models.paper_fit import speed_levels

    cruises = [p for p in segmentation.phases if p.phase == "cruise" and p.speed_mps is not None]
    if not cruises:
        return None, 0
    durations = np.array([p.duration_s for p in cruises])
    speeds = np.array([p.speed_mps for p in cruises], dtype=np.float64)
    if durations.sum() <= 0:
        return None, 0
    if np.all(speeds == speeds[0]):
        # one value (e.g. the commanded speed on every cruise): that value exactly, so runs
        # at one speed stay at one speed (a weighted mean gives 0.29999999999999993 for 0.3)
        return float(speeds[0]), 1
    return float(np.sum(speeds * durations) / durations.sum()), len(speed_levels(speeds))


def run_row(
    run: Run, segmentation: Segmentation, energy: WindowEnergy | None = None
) -> dict[str, object]:
    """One row of the per-run table (the columns of `RUN_COLUMNS`); `energy`: the run's
    `WindowEnergy` when the caller has it already.

    Means are time-weighted over phases: `sum(E_phase) / sum(t_phase)`; a phase kind the
    run does not have gives NaN. Whether `fit` can use the run is decided here
    (`usable`, `skip_reason`), from metadata and from what the segmentation found.
    """
    meta = run.meta
    period_s = run.sample_period_s
    run_energy_J, run_mean_W = run.energy_and_mean()  # one pass over the samples for both
    speed_mps, cruise_levels = _cruise_speed(segmentation)
    if speed_mps is None:
        speed_mps = meta.speed_mps
    row: dict[str, object] = {
        "run_id": meta.run_id,
        "file": run.file,
        "mode": meta.mode,
        "speed_mps": speed_mps if speed_mps is not None else np.nan,
        "commanded_speed_mps": meta.speed_mps if meta.speed_mps is not None else np.nan,
        "distance_m": np.nan,
        "distance_source": "",
        "steps": int(meta.steps),
        "payload_kg": float(meta.payload_kg),
        "started_at": meta.started_at,
        "samples": run.samples,
        "sample_period_s": period_s,
        "duration_s": run.duration_s,
        "energy_J": run_energy_J,
        "mean_power_W": run_mean_W,
        "spike_energy_J": float(sum(s.energy_above_level_J for s in segmentation.spikes)),
        "doubts": "; ".join(segmentation.doubts),
        "cruise_levels": cruise_levels,
    }
    cover_problem = _check_cover(run, segmentation)
    phases = segmentation.phases if cover_problem is None else ()
    if meta.distance_m is not None:
        row.update(distance_m=meta.distance_m, distance_source="metadata")
    elif run.speed_mps is not None and meta.mode == "motion":
        covered_m = _path_m(run, phases)
        if covered_m > 0:
            row.update(distance_m=covered_m, distance_source="speed column")
    row.update(_phase_columns(run, phases, energy, run_mean_W))
    reason = cover_problem if meta.mode == "motion" else None
    turning_only = run.yaw_rate_radps is not None and run.speed_mps is None
    reason = reason or usability(row, turning_only=turning_only)
    row["usable"] = reason is None
    row["skip_reason"] = reason or ""
    return row


def _phase_columns(
    run: Run, phases: Sequence[Phase], energy: WindowEnergy | None, run_mean_W: float
) -> dict[str, object]:
    """The row's columns made from the phases (`run_row`): energies and mean powers by phase
    name, the steps found, the acceleration time; an idle run's idle columns are the whole
    run's (`run_mean_W`)."""
    meta = run.meta
    energies_J, durations_s = _phase_sums(run, phases, energy)
    names = np.array([p.phase for p in phases], dtype=object)
    step_numbers = np.array([p.step for p in phases], dtype=np.int64)

    def total(name: str) -> tuple[float, float]:
        mask = names == name
        return float(energies_J[mask].sum()), float(durations_s[mask].sum())

    def mean_W(name: str) -> float:
        energy, duration = total(name)
        return energy / duration if duration > 0 else float("nan")

    is_motion = np.isin(names, MOTION_PHASES)
    steps_found = int(np.unique(step_numbers[is_motion & (step_numbers >= 1)]).size)
    accel_mask = names == "accel"
    accel_steps = max(int(np.unique(step_numbers[accel_mask]).size), 1)
    decel_energy_J, decel_total_s = total("decel")
    return dict(
        motion_energy_J=float(energies_J[is_motion].sum()),
        steps_found=steps_found,
        # a step's accel may be cut in pieces by a segmenter; its time is the pieces' sum
        t_acc_s=float(durations_s[accel_mask].sum()) / accel_steps
        if accel_mask.any()
        else float("nan"),
        accel_mean_power_W=mean_W("accel"),
        accel_energy_J=total("accel")[0],
        cruise_mean_power_W=mean_W("cruise"),
        cruise_duration_s=total("cruise")[1],
        cruise_energy_J=total("cruise")[0],
        decel_duration_s=decel_total_s / steps_found if steps_found else 0.0,
        decel_mean_power_W=mean_W("decel"),
        decel_energy_J=decel_energy_J,
        idle_mean_power_W=mean_W("idle") if meta.mode != "idle" else run_mean_W,
        idle_duration_s=total("idle")[1] if meta.mode != "idle" else run.duration_s,
    )


def _path_m(run: Run, phases: Sequence[Phase]) -> float:
    """Path the run's motion phases cover by its speed column [m]: sum of |v|·dt over their
    samples (rectangle rule, as the energies; idle samples, whose speed is noise around 0 on
    an encoder, are left out). Unknown (NaN) speeds are filled as `segment` fills them (a
    straight line across, `speed_across_gaps`; its doubt says so), never summed as NaN."""
    speed = np.abs(speed_across_gaps(run.speed_mps)[0])
    total = sum(float(speed[p.i_start : p.i_end].sum()) for p in phases if p.phase in MOTION_PHASES)
    return total * run.sample_period_s


#: What the reason of a run of unknown mode adds when its log has a rate of turn but no speed
#: (`usability`): the drive model, which needs no metadata, cannot use it either.
DRIVE_NEEDS_SPEED = (
    "; the drive model needs a speed column (speed_mps, or two wheel speeds) besides the "
    "rate of turn"
)


def usability(row: dict[str, object], *, turning_only: bool = False) -> str | None:
    """Why `fit` cannot use this run (one line that says what to do), or None; `turning_only`:
    the log has a turning column but no speed column, which a run of unknown mode's reason
    says (a rate of turn looks like enough for the drive model; it is not)."""
    mode = row["mode"]
    if mode == "unknown":
        return (
            "no mode or speed in its metadata, so it cannot be fitted "
            "(add mode/speed_mps/distance_m/steps to the file's '#' lines or to runs.csv)"
        ) + (DRIVE_NEEDS_SPEED if turning_only else "")
    if mode != "motion":
        return None
    if not np.isfinite(row["speed_mps"]) or row["speed_mps"] <= 0:
        return "motion run without a speed (set speed_mps in its metadata or runs.csv)"
    if not np.isfinite(row["distance_m"]) or row["distance_m"] <= 0:
        return (
            "motion run without a distance (set distance_m in its metadata or runs.csv, or "
            "give its speed column)"
        )
    # a motion log without a commanded speed is free driving (log-format.md, "Speed"): not a
    # step run cut wrong, so no advice to split it or to fix a step count it never gave
    free = not np.isfinite(row.get("commanded_speed_mps", np.nan))
    if int(row.get("cruise_levels", 0) or 0) > 1:
        if free:
            return _free_driving(f"its cruises hold {row['cruise_levels']} speed levels")
        return (
            f"its cruises hold {row['cruise_levels']} speed levels; fit takes one speed per "
            "run (split the log at the level change)"
        )
    if row["steps_found"] != row["steps"]:
        if free and row["steps"] == 1:
            return _free_driving(f"its speed column shows {row['steps_found']} motion(s)")
        return (
            f"segmentation found {row['steps_found']} step(s), metadata says {row['steps']} "
            "(check the steps value, or the log is not one clean stop-and-go run)"
        )
    if not np.isfinite(row["accel_mean_power_W"]):
        return "no acceleration phase found (check the log holds motion)"
    fragment = _motion_fragment(row)
    if fragment is not None:
        return fragment
    if row.get("doubts"):
        return (
            f"{DOUBT_REASON}{row['doubts']} (check it with 'wbpower segment'; "
            "--keep-doubtful uses it anyway)"
        )
    return None


def _free_driving(found: str) -> str:
    """The reason a free-driving motion log (no commanded speed) is not one of the paper's
    step runs, with what its segmentation `found`."""
    return (
        f"free driving (no commanded speed_mps): {found}, and the paper's models need step "
        "runs at one set speed"
    )


#: A motion run's motion phases must last at least this share of the time its distance takes
#: at its speed (`_motion_fragment`): the speed is the commanded (maximum) one
#: (log-format.md), so at 1 no real run falls short; half leaves room for a speed given as a
#: mean and for phase boundaries a sample off.
MIN_MOTION_SHARE = 0.5


def _motion_fragment(row: dict[str, object]) -> str | None:
    """Why a motion run's measured energy would be a fragment of its motion, or None: its
    motion phases last less than `MIN_MOTION_SHARE` of distance / speed (issue 26: a 14.3 m
    run at 0.24 m/s whose power-only segmentation found 0.31 s of motion, 58 J of a 6.7 kJ
    log, the rest labelled idle). Not a doubt: `--keep-doubtful` does not let it in."""
    motion_s = float(row["duration_s"]) - float(row.get("idle_duration_s") or 0.0)
    needed_s = float(row["distance_m"]) / float(row["speed_mps"])
    if motion_s >= MIN_MOTION_SHARE * needed_s:
        return None
    return (
        f"its motion phases last {motion_s:.3g} s, yet {float(row['distance_m']):.3g} m at "
        f"{float(row['speed_mps']):.3g} m/s takes {needed_s:.3g} s: the segmentation found a "
        f"fragment of the motion ({float(row['motion_energy_J']):.4g} J of the log's "
        f"{float(row['energy_J']):.4g} J), not its energy (check it with 'wbpower segment'; "
        "a speed column says where the robot moves)"
    )


def admit_doubtful(row: dict[str, object]) -> dict[str, object]:
    """The row with a run left out only for its segmentation's doubts made usable
    (`--keep-doubtful`); any other row unchanged. The doubt test comes last in
    `usability`, so such a run passed every other test."""
    if row["usable"] or not str(row["skip_reason"]).startswith(DOUBT_REASON):
        return row
    return {**row, "usable": True, "skip_reason": ""}


#: How the warning of `fit`/`diagnose --keep-doubtful` about the doubted runs they used
#: starts (`kept_in_doubt`): fit's `warnings`, diagnose's `notes`, a warning on stderr.
KEPT_IN_DOUBT = "used with their segmentation in doubt (--keep-doubtful): "


def kept_in_doubt(rows: Sequence[dict[str, object]], shown: int = 3) -> str | None:
    """What `admit_doubtful` lets into a fit, said (cli.md: "wbpower never presents a
    segmentation it doubts as if it were sound"): how many runs, and the first `shown` by
    run_id and file with their doubts. `rows` as before admission; None when it admits none.
    """
    doubted = [
        row
        for row in rows
        if not row["usable"] and str(row["skip_reason"]).startswith(DOUBT_REASON)
    ]
    if not doubted:
        return None
    named = [f"{row['run_id']} ({Path(str(row['file'])).name}: {row['doubts']})" for row in doubted]
    more = f"; and {len(doubted) - shown} more" if len(doubted) > shown else ""
    return (
        f"{len(doubted)} run(s) {KEPT_IN_DOUBT}{'; '.join(named[:shown])}{more}. Their phases "
        "may not describe them, nor the result they enter (check each with 'wbpower segment')"
    )


def runs_frame(rows: Sequence[dict[str, object]]) -> pd.DataFrame:
    """The per-run table (runs.parquet) from `run_row` rows, columns in `RUN_COLUMNS` order."""
    import pandas as pd

    frame = pd.DataFrame(list(rows), columns=list(RUN_COLUMNS))
    frame["started_at"] = pd.to_datetime(frame["started_at"], utc=True)
    frame["usable"] = frame["usable"].astype(bool)
    for column in ("steps", "samples", "steps_found", "cruise_levels"):
        frame[column] = frame[column].astype(np.int64)
    return frame
