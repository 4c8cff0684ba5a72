"""Helpers several causes share (no cause is named here)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import Evidence, RunTable
from wifibot_power.causes.design import stacked_fit

if TYPE_CHECKING:
    from wifibot_power.causes.base import Cause


def coefficient_evidence(
    cause: Cause,
    table: RunTable,
    rises: str,
    falls: str | None = None,
    flat: str | None = None,
) -> Evidence:
    """The cause's column in the stacked fit, on top of the causes already found: its
    one-sided t-test (the term adds power) and 95% interval. Its summary is worded from the
    estimate's sign and size: `rises` when the interval is above zero, `falls` when below,
    `flat` when it holds zero (so a negative coefficient is never said to rise)."""
    _, fit, names = stacked_fit(table.runs, [*table.given, cause.name], table.model)
    j = names.index(cause.parameter)
    estimate = float(fit.coef[j])
    ci95 = fit.ci95(j)
    if ci95[0] > 0:
        what = rises
    elif ci95[1] < 0:
        what = falls or f"the opposite of '{rises}'"
    else:
        what = flat or f"not distinguishable from zero ('{rises}' not shown)"
    return Evidence(
        cause.name,
        True,
        fit.p_greater(j),
        estimate,
        ci95,
        {cause.parameter: estimate},
        f"{what}: {cause.parameter} = {estimate:.3g} {cause.unit}",
    )


def distinct(values: np.ndarray) -> int:
    values = np.asarray(values, dtype=np.float64)
    return int(np.unique(values[np.isfinite(values)]).size)
