"""Held-out evaluation: the deal of motion runs into K folds by run, the batch a diagnosis
works on (`Batch`), and each run's motion energy predicted by a model fitted without its
fold (`heldout_energy_J`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.diagnose.extended import (
    Fits,
    NotEstimable,
    predict_columns_J,
    prediction_inputs,
)
from wifibot_power.diagnose.extended import fit_model as _fit_model
from wifibot_power.fit import TableColumns
from wifibot_power.model import PowerModel

if TYPE_CHECKING:
    import pandas as pd

FOLDS = 5
#: Fewest usable motion runs, and speeds, that causes can be chosen and checked on.
MIN_MOTION_RUNS = 6
MIN_SPEEDS = 2


def assign_folds(run_ids: pd.Series, folds: int = FOLDS) -> np.ndarray:
    """K folds by run: a seeded permutation of the sorted run ids, dealt round-robin."""
    k = max(2, min(folds, len(run_ids)))
    order = np.argsort(np.argsort(run_ids.to_numpy().astype(str)))
    permuted = np.random.default_rng(0).permutation(len(run_ids))[order]
    return permuted % k


def heldout_folds(motion: pd.DataFrame, folds: int = FOLDS) -> np.ndarray | str:
    """K folds by run (`assign_folds`) such that the runs left without any one fold span 2
    or more speeds (so the paper's lines can be fitted to predict it); when the plain deal
    does not give that, runs are dealt round-robin within each speed. The reason, when no
    deal can."""
    speed = motion["speed_mps"].to_numpy(np.float64)

    def ok(assigned: np.ndarray) -> bool:
        return all(np.unique(speed[assigned != k]).size >= 2 for k in np.unique(assigned))

    plain = assign_folds(motion["run_id"], folds)
    if ok(plain):
        return plain
    k = int(plain.max()) + 1
    order = np.lexsort((plain, speed))  # by speed, then by the plain deal
    stratified = np.empty(len(speed), dtype=plain.dtype)
    stratified[order] = np.arange(len(speed)) % k
    if ok(stratified):
        return stratified
    k = next(k for k in np.unique(stratified) if np.unique(speed[stratified != k]).size < 2)
    rest_speeds = np.unique(speed[stratified != k])
    out = ", ".join(f"{v:g}" for v in np.setdiff1d(speed[stratified == k], rest_speeds))
    rest = ", ".join(f"{v:g}" for v in rest_speeds)
    return (
        f"runs at {out} m/s cannot be predicted held out: without them every other run is at "
        f"{rest} m/s"
    )


def missing_data(motion: pd.DataFrame) -> str:
    """One line saying which runs are missing for held-out prediction."""
    counts = motion["speed_mps"].value_counts().sort_index()
    have = ", ".join(f"{n} at {v:g} m/s" for v, n in counts.items())
    return (
        f"add runs so that 2 or more speeds have 2 or more runs each (a line needs 2 "
        f"speeds, and diagnose holds runs out); these logs have {have}"
    )


def enough_to_choose(motion: pd.DataFrame) -> bool:
    """Whether these motion runs are enough to choose causes on."""
    return len(motion) >= MIN_MOTION_RUNS and motion["speed_mps"].nunique() >= MIN_SPEEDS


def gain_pct(baseline: float, extended: float) -> float:
    """100 × (1 − extended / baseline) (cli.md `gain_pct`)."""
    return 100.0 * (1.0 - extended / baseline) if baseline > 0 else 0.0


def rmse_mape(measured: np.ndarray, predicted: np.ndarray) -> tuple[float, float]:
    """RMSE [J] and MAPE [%] of predicted run energies."""
    error = predicted - measured
    return float(np.sqrt(np.mean(error**2))), float(100 * np.mean(np.abs(error) / measured))


class HeldOut:
    """A deal of the motion runs into held-out folds, and the runs each fold's model is
    fitted on: the runs of other modes, then the motion runs of the other folds (`train`:
    `pd.concat([others, motion[folds != k]])`, index and all). The two tables are stacked
    once, and the columns the paper's lines and the predictions read are read once from
    them: a fold's fit of the lines alone (most fits) and its prediction select rows of
    those arrays by position, and only a fit with causes makes the fold's table. Fits are
    kept in `fits` (the diagnosis's, or the deal's own)."""

    def __init__(
        self,
        all_runs: pd.DataFrame,
        motion: pd.DataFrame,
        folds: np.ndarray,
        fits: Fits | None = None,
    ) -> None:
        import pandas as pd

        others = all_runs[all_runs["mode"].to_numpy() != "motion"]
        self.motion, self.folds = motion, folds
        self.fits = fits if fits is not None else Fits()
        self.table = pd.concat([others, motion])
        self.columns = TableColumns(self.table)
        self.files = self.table["file"].to_numpy(dtype=object)
        self.run_ids = self.table["run_id"].to_numpy(dtype=object)
        self.predictors = prediction_inputs(motion)
        self._others = np.arange(len(others))

    def __iter__(self) -> Iterator[int]:
        return iter(np.unique(self.folds).tolist())

    def train_rows(self, k: int) -> np.ndarray:
        return np.concatenate([self._others, self._others.size + np.flatnonzero(self.folds != k)])

    def train(self, k: int) -> pd.DataFrame:
        """The runs fold `k`'s model is fitted on."""
        return self.table.take(self.train_rows(k))

    def held(self, k: int) -> pd.DataFrame:
        """The runs of fold `k` (`motion[folds == k]`)."""
        return self.motion.take(np.flatnonzero(self.folds == k))

    def fit(self, k: int, causes: list[str], *, strict: bool = False) -> PowerModel:
        """`fit_model(self.train(k), causes, strict=strict)`."""
        rows = self.train_rows(k)
        if causes or strict:
            fit = lambda: _fit_model(self.table.take(rows), causes, strict=strict)  # noqa: E731
        else:  # the paper's lines alone, all `_fit_model` fits then
            fit = lambda: self.columns.model(rows)  # noqa: E731
        return self.fits.once(
            lambda: (self.files[rows].tolist(), self.run_ids[rows].tolist()), causes, strict, fit
        )

    def predict(self, model: PowerModel, k: int) -> np.ndarray:
        """`predict_motion_energy_J(model, self.held(k))`."""
        held = np.flatnonzero(self.folds == k)
        return predict_columns_J(model, {c: v[held] for c, v in self.predictors.items()})


def heldout_energy_J(
    all_runs: pd.DataFrame,
    motion: pd.DataFrame,
    folds: np.ndarray,
    causes: Iterable[str],
    *,
    strict: bool = False,
    fits: Fits | None = None,
) -> np.ndarray:
    """Motion energy of each motion run predicted by a model fitted without its fold.
    `strict`: raise `NotEstimable` when a fold's training runs cannot identify the model,
    or its prediction is not a finite, positive energy. `fits`: the diagnosis's fits."""
    causes = list(causes)
    predicted = np.full(len(motion), np.nan)
    deal = HeldOut(all_runs, motion, folds, fits)
    for k in deal:
        try:
            model = deal.fit(k, causes, strict=strict)
        except NotEstimable as exc:
            raise NotEstimable(f"without held-out fold {k}, {exc}") from None
        predicted[folds == k] = deal.predict(model, k)
    if strict and not (np.isfinite(predicted).all() and (predicted > 0).all()):
        raise NotEstimable("a held-out prediction is not a finite, positive energy")
    return predicted


@dataclass(frozen=True, eq=False)
class Batch:
    """What held-out evaluation and the choice of causes work on: the usable runs of every
    mode, the usable motion runs in run_id order (`motion_runs`), their deal into folds,
    each cause's per-run trace data (by cause, then run_id), and the diagnosis's fits."""

    runs: pd.DataFrame
    motion: pd.DataFrame
    folds: np.ndarray
    traces: Mapping[str, Mapping[str, object]] = field(default_factory=dict)
    fits: Fits = field(default_factory=Fits)

    @cached_property
    def measured(self) -> np.ndarray:
        """Each motion run's measured motion energy [J]."""
        return self.motion["motion_energy_J"].to_numpy(np.float64)

    def fit(self, causes: Iterable[str] = ()) -> PowerModel:
        """The model fitted on all the batch's runs with `causes`."""
        return self.fits.fit(self.runs, causes)

    def heldout_energy_J(self, causes: Iterable[str], *, strict: bool = False) -> np.ndarray:
        return heldout_energy_J(
            self.runs, self.motion, self.folds, causes, strict=strict, fits=self.fits
        )

    def heldout_rmse_J(self, causes: Iterable[str], *, strict: bool = False) -> float:
        """The RMSE of `heldout_energy_J` against the measured energies [J]."""
        return rmse_mape(self.measured, self.heldout_energy_J(causes, strict=strict))[0]
