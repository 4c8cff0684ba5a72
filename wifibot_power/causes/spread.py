"""Where what a cause explains sits: spread over the runs as its physics says, or at one
pattern no cause has (causes.md, the paragraph after "How a cause earns its name").

A "column" cause explains the phase means through its column of the stacked fit
(`design.stacked_design`): a start transient through ``E / t_acc`` in every acceleration, a
v² loss through ``v²`` at every speed. Structure that no cause has is often confined to one
*pattern* of the batch: one speed level, one distance, one step count, one payload, one
stretch of the session. Such a pattern is itself a column: a power ``P_L`` added to the
phase means of the runs at level ``L`` only, in both phases or in one.

The check is an encompassing test (Davidson & MacKinnon, *Econometric Theory and Methods*,
2004, §15.3: non-nested regressions judged by the artificial regression that holds both):
the stacked fit holds the cause's column and one pattern's column at a time. The cause's
share is *not* spread as its physics says when, for some pattern,

- the pattern is seen beside the cause (its column's two-sided p < `CHECK_ALPHA`): the
  runs at ``L`` still differ from what the cause's form gives them; **and**
- the cause is no longer seen beside the pattern (its column's one-sided p >= `CHECK_ALPHA`,
  a consequence that "must be there", causes.md): outside ``L`` there is nothing of it.

Then the residual the cause took up is better described by the pattern, and the cause is
not named: `unexplained`, with the pattern in the check's detail. A true cause keeps its
column significant beside any one pattern (its share is in every level), and a pattern is
seen beside it only as often as its p-value falls under CHECK_ALPHA by chance; both have
to hold. A cause's own pattern (`Cause.own_patterns`: accel_inertial's payload, which its
physics puts at payload > 0 only) is not tested against it.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.causes.base import CHECK_ALPHA, Check
from wifibot_power.causes.design import column, mixed_rows, stacked_design
from wifibot_power.causes.design import power_factor as factor_of
from wifibot_power.stats import ols

if TYPE_CHECKING:
    from wifibot_power.causes.base import Cause, RunTable

#: The check's name in `checks` (cli.md).
SPREAD_CHECK = "spread as its physics says, not at one pattern"
#: Covariates whose levels are patterns, and how runs at one level are called.
LEVELS = {
    "speed_mps": "runs at {:g} m/s",
    "distance_m": "runs over {:g} m",
    "steps": "runs in {:g} step(s)",
    "payload_kg": "runs with {:g} kg payload",
}
#: Session stretches: the runs from these fractions of the session order on.
STRETCHES = (1 / 3, 1 / 2, 2 / 3)
#: Fewest runs inside a pattern and outside it.
MIN_RUNS = 2
#: The phases a pattern's power may sit in.
PHASES = ("while moving", "in acceleration", "in cruise")


def patterns(runs, own: tuple[str, ...]) -> Iterator[tuple[str, np.ndarray]]:
    """(what, mask over runs) of every pattern the batch can show: each level of speed,
    distance, steps and payload, and the late stretches of the session, each with at least
    `MIN_RUNS` runs inside and outside; none along the covariates in `own`."""
    n = len(runs)
    for key, label in LEVELS.items():
        if key in own or key not in runs:
            continue
        values = np.round(np.nan_to_num(column(runs, key)), 6)
        levels = np.unique(values)
        if levels.size < 2:
            continue
        for level in levels:
            inside = values == level
            if MIN_RUNS <= inside.sum() <= n - MIN_RUNS:
                yield label.format(level), inside
    if "session_order" in own or "session_order" not in runs:
        return
    order = column(runs, "session_order")
    timed = order >= 0
    if timed.sum() < 2 * MIN_RUNS + 2:
        return
    ranks = np.argsort(np.argsort(np.where(timed, order, np.inf)))
    count = int(timed.sum())
    for fraction in STRETCHES:
        k = int(round(fraction * count))
        late = timed & (ranks >= k)
        if MIN_RUNS <= late.sum() <= n - MIN_RUNS:
            yield f"the runs from session position {k + 1} of {count} on", late


def spread_check(cause: Cause, table: RunTable) -> Check:
    """The check of the module docstring for a "column" cause on `table` (its column
    beside the causes already found, `table.given`)."""
    runs = table.runs
    given = [c for c in table.given if c != cause.name]
    causes = [*given, cause.name]
    X, y, names = stacked_design(
        runs, causes, table.model.idle_W, factor_of(runs, table.model.extensions)
    )
    j = names.index(cause.parameter)
    n = len(runs)
    mixed, w_acc = mixed_rows(runs, causes)
    w_acc = np.where(mixed, w_acc, 1.0)
    worst: tuple[float, float, str] | None = None  # (p of the cause, p of the pattern, what)
    tried = 0
    for what, inside in patterns(runs, cause.own_patterns):
        at = inside.astype(np.float64)
        for phase in PHASES:
            acc = at if phase != "in cruise" else np.zeros(n)
            cr = at if phase != "in acceleration" else np.zeros(n)
            # a row of acceleration and cruise together holds both phases' shares
            acc = np.where(mixed, w_acc * acc + (1.0 - w_acc) * cr, acc)
            fit = ols(np.column_stack([X, np.concatenate([acc, cr])]), y)
            p_pattern = fit.p_two_sided(X.shape[1])
            p_cause = fit.p_greater(j)
            if not (np.isfinite(p_pattern) and np.isfinite(p_cause)):
                continue
            tried += 1
            if p_pattern < CHECK_ALPHA and (worst is None or p_cause > worst[0]):
                worst = (p_cause, p_pattern, f"{what}, {phase}")
    if not tried:
        return Check(SPREAD_CHECK, True, "no pattern of these runs can be told from its form")
    if worst is None:
        return Check(
            SPREAD_CHECK,
            True,
            f"no single pattern (speed level, distance, steps, payload, session stretch; "
            f"{tried} tried) is seen beside it at p < {CHECK_ALPHA:g}",
        )
    p_cause, p_pattern, what = worst
    ok = p_cause < CHECK_ALPHA
    if ok:
        detail = (
            f"a power at {what} is seen beside it (p = {p_pattern:.2g}), and it is still "
            f"seen beside that (p = {p_cause:.2g}): spread beyond the pattern"
        )
    else:
        detail = (
            f"what it explains sits at {what}: a power there is seen beside it "
            f"(p = {p_pattern:.2g}), and beside that power it is not (p = {p_cause:.2g})"
        )
    return Check(SPREAD_CHECK, bool(ok), detail)


__all__ = ["SPREAD_CHECK", "patterns", "spread_check"]
