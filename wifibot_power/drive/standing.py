"""The logs' own standing power, and the reported idle checked against it (docs/drive-model.md,
"Current-only logs"): a current proxy's few standing windows against thousands moving let
the constant take a share of the moving force (BorealTC flooring: idle 87 W against 17 W
standing), so an idle the standing bins contradict is reported as not determined.

`standing_stops` is a run's (in the worker, from its bins), `standing_power` the batch's,
`idle_against_standing` the check on a fit (`identify.Identified`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.drive.identify import MAX_LAG_S, Identified
from wifibot_power.drive.windows import STANDING_MPS, STANDING_RADPS
from wifibot_power.stats import t_quantile

if TYPE_CHECKING:
    from wifibot_power.drive.stats import DriveStats


@dataclass(frozen=True)
class Standing:
    """The logs' own standing power (`standing_power`): the mean power [W] of the bins that
    stand, its standard error [W] with the stops as clusters, and how many bins and stops."""

    mean_W: float
    se_W: float
    bins: int
    stops: int

    def half_width_W(self) -> float:
        """Its 95% half-width: t(0.975, stops - 1) x its standard error."""
        return t_quantile(0.975, self.stops - 1) * self.se_W


def standing_stops(stats: DriveStats) -> StandingStops:
    """A run's stops (`standing_power`): each stretch of bins where the robot stands (speed
    under `STANDING_MPS` and rate of turn under `STANDING_RADPS`, windows.py, on every bin
    within `MAX_LAG_S` either side, so that no lagged power of motion is in it; before a
    run's first bin and after its last, no motion), its bins and their summed power [J/bin].
    Made in the worker from the bins (a current proxy's: `models.drive.WorkerStats`), so
    that the fit reads no run's bins again for it."""
    reach = int(round(MAX_LAG_S / stats.bin_s))
    with np.errstate(invalid="ignore"):  # a drop-out of the speed: not known still
        still = (np.abs(stats.speed_mps) < STANDING_MPS) & (
            np.abs(stats.yaw_rate_radps) < STANDING_RADPS
        )
    # a bin stands when no bin within `reach` of it moves: the moving bins counted over each
    # bin's 2 reach + 1 neighbours by a running count (whole numbers: exact)
    moving = np.concatenate((np.zeros(reach + 1, np.intp), np.cumsum(~still, dtype=np.intp)))
    moving = np.concatenate((moving, np.full(reach, moving[-1])))
    centre = np.arange(still.size)
    near = moving[centre + 2 * reach + 1] - moving[np.maximum(centre, 0)] > 0
    stands = ~near
    if not stands.any():
        return StandingStops(np.zeros(0, np.intp), np.zeros(0))
    # each stop's bins whose power was logged: a drop-out of the power alone leaves its stop
    # (and its neighbours) standing, not moving (counted as motion, drop-outs a second or two
    # apart left a log "never standing")
    label = np.cumsum(np.r_[stands[0], stands[1:] & ~stands[:-1]])[stands] - 1
    power = stats.power_W[stands]
    logged = np.isfinite(power)
    bins = np.bincount(label, weights=logged).astype(np.intp)
    sums = np.bincount(label, weights=np.where(logged, power, 0.0))
    return StandingStops(bins[bins > 0], sums[bins > 0])


def run_stops(stats: object) -> StandingStops:
    """A run's stops as its worker made them (`models.drive.WorkerStats.standing`), or made
    now from its bins (a `DriveStats` in memory, or as the cache kept it)."""
    made = getattr(stats, "standing", None)
    return made if made is not None else standing_stops(stats)


@dataclass(frozen=True)
class StandingStops:
    """One run's stops (`standing_stops`): each stop's bins and summed power [W x bins]."""

    bins: np.ndarray
    power_sum_W: np.ndarray


def standing_power(stops: list[StandingStops]) -> Standing:
    """The mean power of the bins where the robot stands (`standing_stops`) over every run,
    with a cluster-robust standard error, each stop a cluster (CR1 of a mean: Cameron &
    Miller 2015, Sec. II.C; a stop's draw drifts with the battery, its bins do not). Its
    mean and standard error are NaN without a stop, its standard error with one."""
    if not any(s.bins.size for s in stops):
        return Standing(np.nan, np.nan, 0, 0)
    count = np.concatenate([s.bins for s in stops])
    total = np.concatenate([s.power_sum_W for s in stops])
    G, n = count.size, int(count.sum())
    if G < 2:
        return Standing(float(total.sum() / n), np.nan, n, G)
    mean = float(total.sum() / n)
    se = float(np.sqrt(G / (G - 1) * np.sum(np.square(total - count * mean))) / n)
    return Standing(mean, se, n, G)


def idle_against_standing(
    fitted: Identified, standing: Standing | None, force_form: bool
) -> tuple[Identified, str | None]:
    """The reported idle checked against the logs' standing power (docs/drive-model.md,
    "Current-only logs"): idle is the power of standing still, so a fitted idle that differs
    from the standing bins' mean by more than t(0.975) standard errors of the difference
    (sqrt(se_idle^2 + se_standing^2), t with Welch-Satterthwaite's degrees of freedom) is not
    what the logs measure standing: it carries a share of the moving power (a current proxy's
    few standing windows against thousands moving: BorealTC flooring's idle 87 W against 17 W
    standing). Such an idle is reported as not determined, with both numbers, and it stays in
    the predictions (as a loose term does: `_honest`); the second value is the warning.

    The force form's only (`force_form`: every log a current proxy): it has no step on
    moving, so idle and the rolling force (halved on an arc) are told apart by the standing
    windows against every moving one. A power log's step (`drive_on_W`) is 0 exactly where a
    window stands, so its idle is the standing windows' own fit; checked anyway, the two
    readings of one number differed by 0.01-0.9 W, "significantly" where the standing power
    came from 2 or 3 stops whose spread gives no standard error worth the name (the
    simulator at field realism: 2 of 20 seeds, idle 12.0 W against 11.2 and 12.6 W
    standing, truth 12; sample_logs: 23.292 against 23.300 W; docs/drive-model.md)."""
    j = fitted.columns.index("idle_W") if "idle_W" in fitted.columns else -1
    if not force_form or standing is None or j < 0 or not fitted.shown[j]:
        return fitted, None
    if standing.stops == 0:
        # never standing, the constant is found from the moving windows alone (an arc's
        # halved rolling force against it): where BorealTC's logs did stand, that gave 4-7
        # times their standing power
        return _idle_not_determined(
            fitted,
            j,
            "no bin of these logs stands (still, with a second either side): the standstill "
            "current is not measured, and a constant found from moving windows alone carried "
            "the moving force where the logs did stand",
            measured=False,
        )
    if fitted.dof < 1:
        return fitted, None
    se_idle = float(np.sqrt(max(fitted.cov_of(j), 0.0)))
    difference = float(fitted.coef[j]) - standing.mean_W
    # one stop: the standing power's spread from stop to stop is not measured, so the test
    # rests on the fit's own error (a stop's mean is a direct reading; left unchecked, a
    # set that stood once reported the moving windows' constant: 54.9 W against 9.9 W)
    se_standing = standing.se_W if standing.stops >= 2 else 0.0
    se = float(np.hypot(se_idle, se_standing))
    if not se > 0:  # exact on both sides (noise-free logs): no error to judge a difference by
        return fitted, None
    # Welch-Satterthwaite's degrees of freedom of a difference of two means (Welch 1947,
    # Biometrika 34, Eq. 9): the fewer of the two alone would take a 2-stop standing power's
    # t(0.975, 1) = 12.7 however small its standard error
    standing_term = se_standing**4 / (standing.stops - 1) if standing.stops >= 2 else 0.0
    dof = se**4 / (se_idle**4 / fitted.dof + standing_term)
    t = t_quantile(0.975, dof)
    if not np.isfinite(se) or abs(difference) <= t * se:
        return fitted, None
    spread = (
        f"± {standing.half_width_W():.3g} W (95%; {standing.bins} bins in {standing.stops} stops)"
        if standing.stops >= 2
        else f"W ({standing.bins} bins in one stop: its spread not measured)"
    )
    measured = f"the logs' standing power, {standing.mean_W:.3g} {spread}"
    return _idle_not_determined(
        fitted,
        j,
        f"it is not {measured}: {abs(difference) / se:.1f} standard errors apart; the fit "
        "gives the constant a share of the moving power",
    )


def _idle_not_determined(
    fitted: Identified, j: int, why: str, measured: bool = True
) -> tuple[Identified, str]:
    """`fitted` with idle (column j) reported as not determined because `why`, and the
    warning (`idle_against_standing`); `measured` False: no standing bin to compare with (the
    warning then says it is not measured, not that it differs)."""
    half = fitted.half_width()[j]
    value = (
        f"{fitted.coef[j]:.3g} ± {half:.3g} W (95%)"
        if np.isfinite(half)
        else (f"{fitted.coef[j]:.3g} W")
    )
    reason = f"idle_W: not determined, {value}: {why} (it stays in the predictions)"
    warning = (
        f"idle_W ({fitted.coef[j]:.3g} W) is "
        + ("not the power these logs draw standing still" if measured else "not measured")
        + f": {why}; it is reported as not determined ('wbpower docs drive-model', "
        "'Current-only logs')"
    )
    reported = fitted.shown.copy()
    reported[j] = False
    return (
        replace(
            fitted, reported=reported, not_determined=(*fitted.not_determined, ("idle_W", reason))
        ),
        warning,
    )
