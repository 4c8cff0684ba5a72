"""The paper model's held-out run energy from a fit's runs table: diagnose's baseline (the
paper's Eq. 1-6 refitted without each fold, K-fold by run, `folds.heldout_folds`), for `fit`
to set beside the drive model's held-out error on the same step runs (issue 25: "its
held-out run-energy error is reported beside the paper model's")."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd


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
