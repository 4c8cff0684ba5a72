"""The paper's model extended by any set of named causes, fitted on any subset of runs (the
held-out machinery of `diagnose` calls it on training folds only), its prediction of each
run's motion energy, and the fits one diagnosis has made (`Fits`). Loops over the registry;
names no cause.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.design import column_causes, power_factor, stacked_fit
from wifibot_power.causes.registry import CAUSES, ordered
from wifibot_power.energy import trip_energy
from wifibot_power.fit import fit_table_model
from wifibot_power.model import PowerModel

if TYPE_CHECKING:
    import pandas as pd


class NotEstimable(Exception):  # noqa: N818 (a result, not a failure)
    """The runs given cannot identify the model asked for (why: the message)."""


def motion_of(runs: pd.DataFrame) -> pd.DataFrame:
    """The usable motion runs of `runs`: ``runs[(runs["mode"] == "motion") & runs["usable"]]``,
    the mask made in numpy for the per-run table's own column types (text as objects,
    `usable` bool: pandas' comparison of the text column and `&` of two Series cost more
    than the selection, ~30-70 times a diagnosis); pandas' expression for any others (a
    missing value is not usable, a missing mode not motion)."""
    mode, usable = runs["mode"], runs["usable"]
    if mode.dtype == object and usable.dtype == bool:
        return runs[(mode.to_numpy() == "motion") & usable.to_numpy()]
    return runs[(mode == "motion") & usable]


def fit_model(
    runs: pd.DataFrame, causes: Iterable[str] = (), *, strict: bool = False
) -> PowerModel:
    """The paper's model fitted on `runs` (fit.fit_table_model: paper Eq. 1-4 by least squares
    over runs), extended jointly by `causes` in their fit stages (`Cause`): "scale" causes
    estimated against the column causes first, then one stacked least-squares fit of the
    phase means with the column causes' terms (means above idle divided by the scale
    factors), then the causes estimated from their own phases or spectra.

    `strict`: raise `NotEstimable` when the runs cannot identify the fit (a rank-deficient
    or ill-conditioned stacked design, a cause's `identifiable` reason, a line through
    fewer than 2 speeds) instead of returning numbers that mean nothing.
    """
    base = fit_table_model(runs)
    causes = ordered(causes)
    if not (causes or strict):
        return base  # the paper's lines alone: most of a diagnosis's fits
    motion = motion_of(runs)
    if strict:
        problem = _not_estimable(motion, base, causes)
        if problem:
            raise NotEstimable(problem)
    if not causes:
        return base
    columns = column_causes(causes)
    extensions: dict[str, dict[str, float]] = {}
    for name in causes:
        if CAUSES[name].fit_stage == "scale":
            coef, _, _ = stacked_fit(motion, columns, base)
            params = CAUSES[name].estimate(motion, coef, base)
            if params:
                extensions[name] = params
    coef, fit, _ = stacked_fit(motion, columns, base.with_extensions(extensions, "diagnose"))
    if strict and not fit.estimable:
        raise NotEstimable(
            f"the stacked fit of {', '.join(columns) or 'the lines'} is ill-conditioned "
            f"(rank {fit.rank} of {fit.p}, condition number {fit.condition:.2g})"
        )
    accel = replace(base.accel, intercept=coef["a0"], slope=coef["a1"])
    cruise = replace(base.cruise, intercept=coef["c0"], slope=coef["c1"])
    model = replace(base, accel=accel, cruise=cruise).with_extensions(extensions, "diagnose")
    for name in causes:
        cause = CAUSES[name]
        if cause.fit_stage == "scale":
            continue
        params = cause.estimate(motion, coef, model)
        if params:
            extensions[name] = params
    return model.with_extensions(extensions, source="diagnose")


def _not_estimable(motion: pd.DataFrame, base: PowerModel, causes: list[str]) -> str | None:
    speeds = np.unique(motion["speed_mps"].to_numpy(np.float64))
    if speeds.size < 2:
        if not speeds.size:
            return "no motion runs"
        return f"its runs are all at {speeds[0]:g} m/s (a line needs 2 speeds)"
    lines = (base.accel, base.cruise, base.t_acc)
    if not all(np.isfinite([line.intercept for line in lines] + [line.slope for line in lines])):
        return "the paper's lines cannot be fitted on its runs"
    for name in causes:
        reason = CAUSES[name].identifiable(motion)
        if reason:
            return f"{name}: {reason}"
    return None


#: The columns of a run its predicted motion energy is simulated from, beside what the
#: causes' energy terms read (`Cause.trip_inputs`).
PREDICT_COLUMNS = ("speed_mps", "distance_m", "steps", "payload_kg")


def prediction_inputs(runs: pd.DataFrame) -> dict[str, np.ndarray]:
    """What `predict_columns_J` reads of `runs`: the `PREDICT_COLUMNS`, and each cause's
    keyword arguments of `energy.trip_energy` (`Cause.trip_inputs`), an array each."""
    columns = {c: runs[c].to_numpy() for c in PREDICT_COLUMNS}
    for cause in CAUSES.values():
        columns.update(cause.trip_inputs(runs))
    return columns


def predict_motion_energy_J(model: PowerModel, runs: pd.DataFrame) -> np.ndarray:
    """Motion energy of each run as the model simulates it from (v, D, N, payload) alone:
    paper Eq. 5/6 per step with the model's extensions (energy.trip_energy), with what each
    cause's term reads of the run (`Cause.trip_inputs`: e.g. the motor-on minutes into its
    session that precede it)."""
    return predict_columns_J(model, prediction_inputs(runs))


def predict_columns_J(model: PowerModel, columns: dict[str, np.ndarray]) -> np.ndarray:
    """`predict_motion_energy_J` of runs given as their `prediction_inputs` (arrays, a run
    each): `diagnose` predicts each held-out fold from the columns read once."""
    # the columns as Python lists (itertuples boxes every column of a ~60-column table)
    values = [columns[c].tolist() for c in PREDICT_COLUMNS]
    keywords = [k for k in columns if k not in PREDICT_COLUMNS]
    extra = [np.asarray(columns[k], dtype=np.float64).tolist() for k in keywords]
    out = np.empty(len(values[0]))
    for i, (speed, distance, steps, payload, *given) in enumerate(
        zip(*values, *extra, strict=True)
    ):
        trip = trip_energy(  # a run per iteration, not a sample
            model,
            speed,
            distance,
            int(steps),
            payload_kg=payload,
            **dict(zip(keywords, given, strict=True)),
        )
        out[i] = trip.energy_J
    return out


class Fits:
    """The fits made in one diagnosis, by what they were fitted on: forward selection, the
    held-out folds and the nested folds fit the same rows with the same causes again and
    again (a third to a tenth of all fits). Made per diagnosis and passed to what fits."""

    def __init__(self) -> None:
        self._made: dict[tuple, PowerModel | NotEstimable] = {}

    def fit(
        self, runs: pd.DataFrame, causes: Iterable[str] = (), *, strict: bool = False
    ) -> PowerModel:
        """`fit_model(runs, causes, strict=strict)`, fitted once per rows (in their order),
        causes and `strict`: the same fit of the same rows is the same model, and a fit the
        rows cannot identify raises `NotEstimable` each time it is asked for."""
        causes = ordered(causes)  # a list: the key and the fit both read it (an iterator once)
        return self.once(
            lambda: (runs["file"].tolist(), runs["run_id"].tolist()),
            causes,
            strict,
            lambda: fit_model(runs, causes, strict=strict),
        )

    def once(
        self,
        rows: Callable[[], tuple[list, list]],
        causes: Iterable[str],
        strict: bool,
        fit: Callable[[], PowerModel],
    ) -> PowerModel:
        """`fit()`, or what it gave (a model or `NotEstimable`) when these fits hold the
        same `rows` (their files and run ids, in order) fitted with the same causes and
        `strict`."""
        files, run_ids = rows()
        key = (tuple(files), tuple(run_ids), tuple(ordered(causes)), strict)
        if key not in self._made:
            try:
                self._made[key] = fit()
            except NotEstimable as exc:
                self._made[key] = exc
        found = self._made[key]
        if isinstance(found, NotEstimable):
            raise NotEstimable(str(found))
        return found


__all__ = [
    "Fits",
    "NotEstimable",
    "fit_model",
    "power_factor",
    "predict_columns_J",
    "predict_motion_energy_J",
    "prediction_inputs",
]
