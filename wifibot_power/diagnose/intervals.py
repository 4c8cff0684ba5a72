"""95% intervals of held-out gains (cli.md `gain_ci95`; causes.md, "How a cause earns its
name": a finding whose gain interval reaches zero is not named).

A held-out gain moves with two draws: how the runs fall into folds (on eleven runs, a
finding's gain was 93.0% or 17.2% by run_id names alone: docs/diagnose.md) and which runs
were logged at all. Both are resampled, without refitting anything per resample:

1. The gain is measured on `DEALS` fold deals (`gain_deals`): the diagnosis's own and
   seeded others (`heldout_folds(seed=...)`); each deal gives every run's held-out squared
   error without and with the term (a model fitted without the run's fold predicts it).
2. `RESAMPLES` bootstrap samples of the runs (with replacement), each taken from one deal
   in turn, give the gain ``100 (1 - sqrt(sum with / sum without))`` of each sample
   (`folds.gain_pct` of the two RMSEs); the interval is their 2.5 and 97.5 percentiles
   (Efron & Tibshirani 1993, "An Introduction to the Bootstrap", ch. 13, percentile
   interval; the per-run held-out errors as the units resampled).

Refits per resample (a bootstrap of the whole cross-validation) would be wider on tiny
batches; this interval is the cheap one and is said to be (docs/diagnose.md, "Limits").
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.diagnose.folds import Batch, heldout_folds

if TYPE_CHECKING:
    from collections.abc import Callable

#: Fold deals each gain is measured on: the diagnosis's own, and DEALS - 1 seeded others.
DEALS = 4
#: Bootstrap samples of the runs, dealt in turn over the deals.
RESAMPLES = 2000
#: A gain interval is `CI_PERCENTILES` of the resampled gains [%].
CI_PERCENTILES = (2.5, 97.5)


def gain_deals(batch: Batch, deals: int = DEALS) -> list[Batch]:
    """The batch on `deals` fold deals: its own first, then seeds 1, 2, ... (a seed whose
    deal cannot predict every run held out, or repeats one already taken, is passed over;
    at most 3 × `deals` seeds are tried)."""
    out, seen = [batch], {batch.folds.tobytes()}
    for seed in range(1, 3 * deals):
        if len(out) == deals:
            break
        folds = heldout_folds(batch.motion, seed=seed)
        if isinstance(folds, str) or folds.tobytes() in seen:
            continue
        seen.add(folds.tobytes())
        out.append(replace(batch, folds=folds))
    return out


def gain_ci95(without: np.ndarray, with_: np.ndarray, seed: int = 0) -> tuple[float, float]:
    """The 95% interval of the held-out gain [%] (module docstring): `without`, `with_`:
    each run's held-out squared error without and with the term, a row per fold deal
    (deals x runs). A deal with a non-finite error is left out; none left: (nan, nan)."""
    without, with_ = np.atleast_2d(without), np.atleast_2d(with_)
    finite = np.isfinite(without).all(axis=1) & np.isfinite(with_).all(axis=1)
    without, with_ = without[finite], with_[finite]
    if without.shape[0] == 0 or without.shape[1] == 0:
        return (float("nan"), float("nan"))
    n_deals, n_runs = without.shape
    rng = np.random.default_rng(seed)
    runs = rng.integers(0, n_runs, size=(RESAMPLES, n_runs))
    deal = (np.arange(RESAMPLES) % n_deals)[:, None]
    sum_without = without[deal, runs].sum(axis=1)
    sum_with = with_[deal, runs].sum(axis=1)
    ratio = np.divide(sum_with, sum_without, out=np.ones(RESAMPLES), where=sum_without > 0)
    gains = 100.0 * (1.0 - np.sqrt(ratio))
    low, high = np.percentile(gains, CI_PERCENTILES)
    return (float(low), float(high))


def energy_errors(deals: list[Batch], causes: list[str] | frozenset) -> np.ndarray:
    """Each run's held-out squared error of motion energy [J²] with `causes` fitted without
    its fold, a row per deal (NaN: a deal whose fits cannot identify the model)."""
    from wifibot_power.diagnose.extended import NotEstimable

    rows = []
    for deal in deals:
        try:
            predicted = deal.heldout_energy_J(sorted(causes), strict=bool(causes))
        except NotEstimable:
            predicted = np.full(len(deal.motion), np.nan)
        rows.append((predicted - deal.measured) ** 2)
    return np.array(rows)


def trace_ci95(
    deals: list[Batch], name: str, per_deal_gain: Callable[[Batch], float]
) -> tuple[float, float]:
    """The interval of a trace cause's held-out gain: from its per-run trace errors
    (`Cause.heldout_trace_errors`) when it gives them; else the range of its gain over the
    fold deals alone (`per_deal_gain`)."""
    from wifibot_power.causes import CAUSES

    cause = CAUSES[name]
    rows = [cause.heldout_trace_errors(d.motion, d.folds, d.traces.get(name, {})) for d in deals]
    if any(r is None for r in rows):
        gains = [per_deal_gain(d) for d in deals]
        return (float(min(gains)), float(max(gains)))
    return gain_ci95(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))


def reaches_zero(ci95: tuple[float, float]) -> bool:
    """Whether a gain interval reaches zero (or is not known: not estimable)."""
    return not (np.isfinite(ci95[0]) and ci95[0] > 0)


__all__ = [
    "CI_PERCENTILES",
    "DEALS",
    "RESAMPLES",
    "energy_errors",
    "gain_ci95",
    "gain_deals",
    "reaches_zero",
    "trace_ci95",
]
