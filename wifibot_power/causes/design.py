"""The stacked least-squares problem every cause's term enters, and what its coefficients
predict. Loops over the registry; names no cause.

Acceleration and cruise phase means of every run are stacked into one least-squares problem:
the paper's two lines (paper Eq. 1-4) plus a column per "column" cause. A cause's column is
the mean, over the phase, of the power its term adds per unit of its parameter: during the
acceleration ramp, power is a polynomial in u = t / t_acc (``ramp0 + ramp1 u + ramp2 u²``),
whose mean over u in [0, 1] is ``ramp0 + ramp1 / 2 + ramp2 / 3``, and a fixed energy per
step adds ``E / t_acc`` to the acceleration mean. "Scale" causes divide the means above
idle by their factor first.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.registry import CAUSES, ordered
from wifibot_power.stats import OLS, ols

if TYPE_CHECKING:
    import pandas as pd

    from wifibot_power.model import PowerModel

LINE_COEFFICIENTS = ("a0", "a1", "c0", "c1")
RAMP_KEYS = ("ramp0", "ramp1", "ramp2", "cruise")


def column(runs: pd.DataFrame, name: str) -> np.ndarray:
    return runs[name].to_numpy(np.float64)


def power_factor(runs: pd.DataFrame, extensions: dict[str, dict[str, float]]) -> np.ndarray:
    """Product of the "scale" causes' factors on motion power above idle, per run."""
    factor = np.ones(len(runs))
    for name in ordered(extensions):
        f = CAUSES[name].power_factor(runs, extensions[name])
        if f is not None:
            factor = factor * f
    return factor


def column_causes(causes: Iterable[str]) -> list[str]:
    return [c for c in ordered(causes) if CAUSES[c].fit_stage == "column"]


def stacked_design(
    runs: pd.DataFrame, causes: Iterable[str], idle_W: float, factor: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Design matrix, response and coefficient names of the stacked fit: accel rows
    ``a0 + a1 v + Σ columns``, cruise rows ``c0 + c1 v + Σ columns``; with a `factor`, the
    means above idle are first divided by it."""
    v = column(runs, "speed_mps")
    t_acc = column(runs, "t_acc_s")
    factor = np.ones_like(v) if factor is None else factor
    y_acc = idle_W + (column(runs, "accel_mean_power_W") - idle_W) / factor
    y_cr = idle_W + (column(runs, "cruise_mean_power_W") - idle_W) / factor
    one, zero = np.ones_like(v), np.zeros_like(v)
    acc_cols, cr_cols = [one, v, zero, zero], [zero, zero, one, v]
    names = list(LINE_COEFFICIENTS)
    for name in column_causes(causes):
        cause = CAUSES[name]
        terms = cause.power_terms(runs, 1.0)
        lump = cause.lump_J_per_step(runs, 1.0)
        acc = terms.get("ramp0", zero) + terms.get("ramp1", zero) / 2 + terms.get("ramp2", zero) / 3
        if lump is not None:
            acc = acc + lump / t_acc  # a fixed energy spread over the acceleration phase
        acc_cols.append(np.broadcast_to(acc, v.shape))
        cr_cols.append(np.broadcast_to(terms.get("cruise", zero), v.shape))
        names.append(cause.parameter)
    X_acc, X_cr = np.column_stack(acc_cols), np.column_stack(cr_cols)
    mixed, w_acc = mixed_rows(runs, causes)
    if mixed.any():
        # an acceleration shorter than a lump's time holds only part of the lump, the rest
        # is in the cruise: such a run's acceleration row is its acceleration and cruise
        # together (their time-weighted mean, whose lump column is steps / time however the
        # lump is split), not a mean that reads the lump short. The rows stay in place
        # (acceleration rows first), as the causes' checks index them; a check of one phase
        # leaves these rows out of its acceleration rows (`mixed_rows`)
        both = w_acc[:, None] * X_acc + (1.0 - w_acc)[:, None] * X_cr
        X_acc = np.where(mixed[:, None], both, X_acc)
        y_acc = np.where(mixed, w_acc * y_acc + (1.0 - w_acc) * y_cr, y_acc)
    return np.vstack([X_acc, X_cr]), np.concatenate([y_acc, y_cr]), names


def mixed_rows(runs: pd.DataFrame, causes: Iterable[str]) -> tuple[np.ndarray, np.ndarray]:
    """Which runs' acceleration rows of `stacked_design` are their acceleration and cruise
    together (the acceleration is shorter than the time a lump cause among `causes` may
    take, `Cause.lump_within_s`), and each run's acceleration share of that time. Such a
    row is mostly cruise (a 0.1 s acceleration beside seconds of cruise): a check of the
    acceleration phase alone leaves it out."""
    within_s = max((CAUSES[c].lump_within_s for c in column_causes(causes)), default=0.0)
    t_acc = column(runs, "t_acc_s")
    accel_s = t_acc * column(runs, "steps_found")
    with np.errstate(invalid="ignore", divide="ignore"):
        w_acc = accel_s / (accel_s + column(runs, "cruise_duration_s"))
    return t_acc < within_s, w_acc


def stacked_fit(
    runs: pd.DataFrame, causes: Iterable[str], model: PowerModel
) -> tuple[dict[str, float], OLS, list[str]]:
    """The stacked fit with the given causes' columns; "scale" causes from the model."""
    X, y, names = stacked_design(runs, causes, model.idle_W, power_factor(runs, model.extensions))
    fit = ols(X, y)
    return dict(zip(names, map(float, fit.coef), strict=True)), fit, names


def phase_power_terms(
    runs: pd.DataFrame, coef: dict[str, float], causes: Iterable[str] | None = None
) -> dict[str, np.ndarray]:
    """Per-run modelled powers [W] from stacked-fit coefficients: the acceleration ramp as a
    polynomial in u = t / t_acc (constant acceleration, paper Eq. 5) and the cruise level,
    with the terms of the column causes whose parameter `coef` holds (or of `causes`)."""
    v = column(runs, "speed_mps")
    terms = {
        "ramp0": np.full_like(v, coef["a0"]),
        # P(u) = a0 + 2 a1 v u has the paper's mean a0 + a1 v over u in [0, 1]
        "ramp1": 2 * coef["a1"] * v,
        "ramp2": np.zeros_like(v),
        "cruise": coef["c0"] + coef["c1"] * v,
    }
    names = column_causes(causes if causes is not None else CAUSES)
    for name in names:
        cause = CAUSES[name]
        if cause.parameter not in coef:
            continue
        for key, added in cause.power_terms(runs, coef[cause.parameter]).items():
            terms[key] = terms[key] + added
    return terms


def lumps_J(runs: pd.DataFrame, coef: dict[str, float]) -> np.ndarray:
    """Fixed energies per step of the column causes `coef` holds, summed [J/step]."""
    total = np.zeros(len(runs))
    for name in column_causes(CAUSES):
        cause = CAUSES[name]
        if cause.parameter in coef:
            lump = cause.lump_J_per_step(runs, coef[cause.parameter])
            if lump is not None:
                total = total + lump
    return total


def measured_duration_prediction_J(
    runs: pd.DataFrame, coef: dict[str, float], factor: np.ndarray | None = None, idle_W=0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration + cruise energy the coefficients give for each run's measured phase
    times [J], and those times [s]; with a `factor`, the energy above idle is scaled."""
    terms = phase_power_terms(runs, coef)
    steps = column(runs, "steps_found")
    accel_s = column(runs, "t_acc_s") * steps
    cruise_s = column(runs, "cruise_duration_s")
    energy_J = (
        (terms["ramp0"] + terms["ramp1"] / 2 + terms["ramp2"] / 3) * accel_s
        + terms["cruise"] * cruise_s
        + lumps_J(runs, coef) * steps
    )
    if factor is not None:
        seconds = accel_s + cruise_s
        energy_J = idle_W * seconds + (energy_J - idle_W * seconds) * factor
    return energy_J, accel_s + cruise_s
