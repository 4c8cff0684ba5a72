"""The paper model's held-out run energy from a fit's runs table: diagnose's baseline (the
paper's Eq. 1-6 refitted without each fold, K-fold by run, `folds.heldout_folds`), for `fit`
to set beside the drive model's held-out error on the same step runs (issue 25: "its
held-out run-energy error is reported beside the paper model's": `heldout_beside_paper`,
which `fit` prints under the drive model's step-run table)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd

    from wifibot_power.fit_result import FitResult


def paper_heldout_motion_J(runs: pd.DataFrame) -> tuple[list[str], np.ndarray, np.ndarray] | None:
    """The run_ids of the usable motion runs of `runs` (`runtable.runs_frame`'s rows: fit's
    runs table), in run_id order, each one's measured motion energy [J] and that predicted by
    the paper's model fitted without its fold, as `diagnose` measures and predicts its
    baseline (each run on the batch's idle level: `idle.refer_to_batch_idle`). None when
    the runs cannot be dealt into folds that each leave two speeds to fit on, or a fold's
    model cannot be fitted."""
    from wifibot_power.diagnose.extended import Fits, NotEstimable
    from wifibot_power.diagnose.folds import Batch, heldout_folds
    from wifibot_power.diagnose.idle import refer_to_batch_idle
    from wifibot_power.diagnose.summaries import motion_runs, with_session_columns

    usable = with_session_columns(runs[runs["usable"].astype(bool)].copy())
    usable = refer_to_batch_idle(usable)
    motion = motion_runs(usable)
    if len(motion) < 2:
        return None
    folds = heldout_folds(motion)
    if isinstance(folds, str):
        return None
    batch = Batch(usable, motion, folds, {}, Fits())
    try:
        predicted = batch.heldout_energy_J([], strict=True)
    except NotEstimable:
        return None
    return motion["run_id"].tolist(), batch.measured, predicted


@dataclass(frozen=True)
class HeldOutBeside:
    """On the step runs both models used: each one's held-out error of a run's energy [J]
    over the run's motion energy (accel, cruise and decel; idle excluded: the energy the
    paper's Eq. 5/6 predicts), as a mean absolute percentage over `n_runs` runs. The drive
    model's: its K-fold by trip (a run's trips summed) over the run table's motion energy;
    the paper's: diagnose's baseline, on the batch's idle level as diagnose takes it
    (`paper_heldout_motion_J`)."""

    n_runs: int
    drive_mape_pct: float
    paper_mape_pct: float


def heldout_beside_paper(result: FitResult) -> HeldOutBeside | None:
    """A fit's drive model's held-out run energy beside the paper model's on the step runs
    both used (`HeldOutBeside`); None without both models, or when the paper's cannot be
    held out (too few speeds for its folds). Reads the runs table (pandas)."""
    from wifibot_power.drive.heldout import trip_log

    drive = result.drive
    if drive is None or not result.model_complete:
        return None
    held = drive.summary()["heldout"]
    if not held:
        return None
    runs = result.runs
    paper = paper_heldout_motion_J(runs)
    if paper is None:
        return None
    run_ids, paper_measured_J, paper_predicted_J = paper
    motion_J = dict(zip(runs["run_id"], runs["motion_energy_J"].tolist(), strict=True))
    # a run cut into trips (stops of `drive.windows.STOP_S`) is their sum: "RUN#k"
    drive_J: dict[str, list[float]] = {}
    for trip in held["runs"]:  # type: ignore[union-attr]
        name = str(trip["run_id"])
        run_id = trip_log(name, motion_J) or name
        sums = drive_J.setdefault(run_id, [0.0, 0.0])
        sums[0] += float(trip["measured_J"])
        sums[1] += float(trip["predicted_J"])
    drive_pct, paper_pct = [], []
    paper_J = zip(run_ids, paper_measured_J, paper_predicted_J, strict=True)
    for run_id, measured, guess in paper_J:
        if run_id in drive_J and motion_J[run_id] > 0 and measured > 0:
            error_J = abs(drive_J[run_id][1] - drive_J[run_id][0])
            drive_pct.append(error_J / motion_J[run_id] * 100)
            paper_pct.append(abs(float(guess) - float(measured)) / measured * 100)
    if not drive_pct:
        return None
    n = len(drive_pct)
    return HeldOutBeside(n, sum(drive_pct) / n, sum(paper_pct) / n)
