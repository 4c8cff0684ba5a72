"""Identification of the drive model's terms from windows (windows.py): the lag, which terms
the data determine, the coefficients by least squares bounded where physics bounds them, and
intervals from a covariance robust to autocorrelation within a cluster (a run).

- Lag: power lags the speed that causes it (motor controllers, filters, a logger's own
  averaging). Each lag of `LAG_GRID_S` is tried, the response shifted by it, and the lag whose
  unconstrained least squares leaves the smallest sum of squares (on the windows defined at
  every lag) is kept: a grid search of the lag by least squares, refined to a fraction of a
  bin (gram.py `refine_lag`). The least squares is the corrected one, X'X less the speeding-up
  and braking columns' noise (gram.py `corrected_gram`): their noise pulled the lag short.
- Determined terms: a term is kept only when the data hold its regressor (turning needs
  windows that turn in at least `MIN_CLUSTERS` clusters, a surface's rolling term windows
  that move on it) and it is not (nearly) a combination of the terms kept before it (1 - R^2
  of its column on them over `MIN_TOLERANCE`: one speed only makes |v| and v^2 the same
  regressor). The rest go to `not_determined` with the reason; never a number.
- Coefficients: least squares with the bounds of `terms.TERMS` (non-negative where physics
  says so; braking free), by an active-set method (Lawson & Hanson 1974, NNLS) on the normal
  equations; a handful of columns, so exact and fast.
- Intervals: windows of one run are autocorrelated (a slow wander of the battery voltage, a
  mis-set lag), so the sampling covariance is the cluster jackknife (CR3: `_cluster_cov`),
  clusters the runs, and the 95% interval uses Student's t with G - 1 degrees of freedom
  (G clusters; Cameron & Miller 2015, "A practitioner's guide to cluster-robust inference",
  J. Human Resources 50(2), Sec. VI.B-C). statsmodels has it, but `import statsmodels.api`
  took 1.1 s here (numpy: 0.09 s), too much for a command's start; it is numpy here.
- Honest terms (`_honest`): a term the bounded fit holds at its physical bound (0) is not
  measured (no positive value fits better): it leaves the fit, with its reason. A term
  whose interval is far wider than any power the data hold (its half-width times the
  typical size of its regressor where it acts, over how much the power varies there:
  `LOOSE_SHARE`) is not determined either: reported so, with its reason, but kept in the
  prediction (terms the data cannot tell apart still add up to a determined power; leaving
  them out of the fit made held-out energy worse on real logs: `identify`). An interval of
  a term bounded below by 0 is clipped at 0: the truth is not below it, so the clipped
  interval holds it exactly as often as the symmetric one (and never says "maybe
  negative" of a term physics makes non-negative).
- Idle against standing (drive/standing.py, called by `model._model`; the force form's): a
  current proxy's idle is told from its rolling force by a few standing windows against
  thousands moving, and can carry the moving force (BorealTC flooring: 87 W against 17 W
  standing). The logs' standing bins measure idle directly (`standing_power`): a fitted
  idle that differs from their mean by more than t(0.975) standard errors of the
  difference is reported as not determined,
  with both numbers and a warning, and still predicts; so is idle from logs that never stand
  (nothing measures it: BorealTC's moving windows alone gave 4-7 times the standing power).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from wifibot_power.drive.gram import FoldGrams, corrected_gram, refine_lag, window_noise_share
from wifibot_power.drive.moments import (
    WindowMoments,
    _gram_solve,
    cluster_jackknife,
    least_squares,  # noqa: F401  (its home was here: tests import it from identify)
    term_of,
)
from wifibot_power.drive.terms import TERM_BY_NAME, term_unit
from wifibot_power.drive.windows import (
    RunWindows,
    StackedPower,
    Windows,
    assemble,
    between_bins,
)
from wifibot_power.stats import t_quantile

#: Lags tried [s]: 0 to 1 s by one bin.
MAX_LAG_S = 1.0
#: A term's column must keep this share of its variance unexplained by the terms before it.
MIN_TOLERANCE = 1e-2
#: A term must be seen (its regressor non-zero) in windows of at least this many clusters.
MIN_CLUSTERS = 2
#: A term is not determined when its 95% interval's half-width, times its regressor's typical
#: (root mean square) size in the windows where it acts, is more than this share of the
#: standard deviation of the power over those windows (idle: of the mean power): the data
#: leave its share of a window open by more than the power itself varies there.
LOOSE_SHARE = 1.0


@dataclass(frozen=True, eq=False)
class Identified:
    """Fitted coefficients of the determined columns, their covariance and what was left."""

    columns: tuple[str, ...]  # every design column
    kept: np.ndarray  # bool per column: determined
    coef: np.ndarray  # per column (NaN where not determined)
    cov: np.ndarray  # over the kept columns
    dof: int  # G - 1
    clusters: int
    lag_bins: float
    not_determined: tuple[tuple[str, str], ...]  # (column, reason)
    residual_W: np.ndarray | None  # per window (None: fitted from sums, lagsums.py)
    #: bool per column: reported as a term (kept, and its interval not too loose to mean
    #: anything: `_honest`); None: every kept column
    reported: np.ndarray | None = None
    #: the joint sandwich's variance of the lag [s^2] (`_fit_kept`; NaN when the fitted power
    #: does not move with the lag or no covariance was made): the linearised alternative to
    #: laginterval.py's bootstrap, kept for the validation that chose between them
    lag_var_s2: float = np.nan

    @property
    def shown(self) -> np.ndarray:
        """bool per column: the terms reported with a value (the rest: `not_determined`)."""
        return self.kept if self.reported is None else self.reported

    def half_width(self) -> np.ndarray:
        """Each column's 95% half-width, t(0.975, G - 1) x its standard error (NaN where
        not kept or with fewer than 2 clusters)."""
        out = np.full(self.coef.size, np.nan)
        if self.dof >= 1:
            se = np.sqrt(np.clip(np.diag(self.cov), 0, None))
            out[self.kept] = t_quantile(0.975, self.dof) * se
        return out

    def ci95(self) -> np.ndarray:
        """Each column's 95% interval (NaN rows where not determined), clipped at 0 for a term
        physics bounds below by 0 (module docstring: the coverage is unchanged)."""
        half = self.half_width()
        out = np.column_stack((self.coef - half, self.coef + half))
        bounded = np.array([TERM_BY_NAME[_term(c)].non_negative for c in self.columns])
        out[bounded, 0] = np.maximum(out[bounded, 0], 0.0)
        return out

    def predict_W(self, design: np.ndarray) -> np.ndarray:
        return design[:, self.kept] @ self.coef[self.kept]

    def cov_of(self, j: int) -> float:
        """Column j's variance (NaN where not kept)."""
        if not self.kept[j]:
            return np.nan
        k = int(np.count_nonzero(self.kept[:j]))
        return float(self.cov[k, k])


def lag_grid(runs: list[RunWindows]) -> np.ndarray:
    """The whole lags [bins] the lag search tries: 0 to `MAX_LAG_S`."""
    return np.arange(int(round(MAX_LAG_S / runs[0].stats.bin_s)) + 1)


def lag_search(
    runs: list[RunWindows],
    surfaces: tuple[str, ...],
    only: list[np.ndarray] | None = None,
    gram: bool = True,
) -> tuple[float, np.ndarray]:
    """The lag [bins] whose least squares fits best (on the windows `only` keeps; to a
    fraction of a bin), and each whole lag's sum of squares. `gram`: from the sums X'X, X'Y,
    Y'Y of one pass (gram.py), else by least squares over the windows at each lag tried (the
    same numbers up to the order of summation)."""
    lags = lag_grid(runs)
    if gram:
        keep = StackedPower(runs).ok if only is None else np.concatenate(only).astype(bool)
        found = FoldGrams.from_windows(runs, surfaces, np.where(keep, 0, -1), 1, lags).search(-1)
        if found is not None:
            return found
    return WindowSearch(runs, surfaces).search(None if only is None else np.concatenate(only))


class WindowSearch:
    """`lag_search` by least squares over the windows (`gram=False`), for any subset of the
    same runs' windows: what does not depend on the subset (the stacked power at each whole
    lag, the windows defined at every lag, their design and noise shares) is made once, so a
    held-out check's ten folds cost one assembly, not ten (step runs: their least squares
    fits too closely for the sums, gram.py `CANCELLATION`). Each search keeps the rows of
    the same arrays a search from scratch makes: the same numbers."""

    def __init__(self, runs: list[RunWindows], surfaces: tuple[str, ...]) -> None:
        self.runs, self.surfaces = runs, surfaces
        self.lags = lag_grid(runs)
        self.stacked = stacked = StackedPower(runs)
        # each whole lag's power once (a fraction of a bin is between two of them)
        self.whole = {int(lag): stacked.power_at(int(lag)) for lag in self.lags}
        # the windows defined at every lag, so that each lag is judged on the same windows
        defined = stacked.ok
        for _, at_lag in self.whole.values():
            defined = defined & at_lag
        self.defined = defined
        # lag 0 is on the grid: the windows `assemble` keeps at lag 0 are the defined ones
        every = stacked.split(defined)
        self.design = assemble(runs, 0, surfaces, only=every, stacked=stacked).design
        self.share = window_noise_share(runs, every, self.design.shape[1], surfaces)
        self._trip: np.ndarray | None = None

    def search_trips(
        self, train: np.ndarray | None, trip_base: np.ndarray
    ) -> tuple[float, np.ndarray]:
        """`search` on the windows of the `train` trips (a bool per trip of every run, run
        r's first at `trip_base[r]`; None: every trip)."""
        if train is None:
            return self.search(None)
        if self._trip is None:
            bases = zip(self.runs, trip_base, strict=False)
            self._trip = np.concatenate([rw.trip + base for rw, base in bases])
        return self.search(train[self._trip])

    def search(self, only: np.ndarray | None) -> tuple[float, np.ndarray]:
        """`lag_search` on the stacked windows `only` keeps (None: every one)."""
        stacked, whole = self.stacked, self.whole
        common = self.defined if only is None else self.defined & np.asarray(only, dtype=bool)
        rows = common[self.defined]
        # every lag tried keeps the same windows (`common`; a fraction of a bin between two
        # whole lags tried): the design is made and factorised once, only the response moves
        X = self.design[rows]
        # the corrected least squares (gram.py `corrected_gram`): X'X less the noisy columns'
        noise = np.sum(self.share[rows] * np.square(X), axis=0)
        usable = np.any(X != 0, axis=0)
        X, noise = X[:, usable], noise[usable]
        plain = X.T @ X
        xx = corrected_gram(plain, noise)
        scale = np.sqrt(np.diag(xx)).copy()
        scale[scale == 0] = 1.0
        inverse = np.linalg.pinv(xx / np.outer(scale, scale))  # factorised once: only y moves

        def sse_at(lag: float) -> float:
            power_at = lambda w: whole[w] if w in whole else stacked.power_at(w)  # noqa: E731
            y = between_bins(power_at, lag)[0][common]
            if y.size <= X.shape[1]:
                return np.inf
            coef = (inverse @ ((X.T @ y) / scale)) / scale
            # the residual's sum of squares less the noise's share of b'X'Xb (`corrected_gram`)
            return float(np.sum(np.square(y - X @ coef)) - coef @ (plain - xx) @ coef)

        return refine_lag(self.lags, sse_at)


def identify(windows: Windows, lag_bins: float, clusters: np.ndarray) -> Identified:
    """Fit the determined columns of `windows` (module docstring). A term that passes the
    screens stays in the fit however wide its interval: leaving out the terms whose interval
    spans over half the mean power was tried and made held-out energy worse on real logs
    (BorealTC 29.7% -> 38.2% MAPE, the unicycles' wAPE 11.9% -> 21.6%). One too loose to
    mean anything is reported as not determined (`_honest`), not given a number."""
    return identify_moments(WindowMoments(windows, clusters), lag_bins)


def identify_moments(moments, lag_bins: float, coefficients_only: bool = False) -> Identified:
    """`identify` from `moments` (moments.py: the windows' sums, made from the rows or from
    per-trip sums). `coefficients_only`: the coefficients and what is kept, without the
    covariance and the loose-interval check (a held-out fold predicts with the coefficients
    alone: the same predictions)."""
    kept, reasons = _determined(moments)
    fitted = _fit_kept(moments, lag_bins, kept, reasons, coefficients_only)
    return _honest(moments, fitted, coefficients_only)


def _honest(moments, fitted: Identified, coefficients_only: bool = False) -> Identified:
    """The terms the fit can honestly report (module docstring): a term held at its bound
    leaves the fit (its coefficient is 0 either way: the others' are unchanged, their
    covariance is the one without it), and a term whose interval is looser than any power
    the data hold is reported as not determined, with its reason, but still predicts."""
    columns = fitted.columns
    bounds = np.array([TERM_BY_NAME[_term(c)].non_negative for c in columns])
    pinned = fitted.kept & bounds & (fitted.coef == 0)
    reasons = list(fitted.not_determined)
    if pinned.any():
        free = moments.unbounded(fitted.kept)
        unbounded = dict(zip(np.flatnonzero(fitted.kept), free, strict=True))
        for j in np.flatnonzero(pinned):
            unit = term_unit(_term(columns[j]), moments.proxy_all)
            # why no positive value fits better: the data push it below 0, or (its own
            # least squares positive) the other terms' bounds leave it nothing to explain
            why = (
                "these logs would make it negative"
                if unbounded[j] < 0
                else "the other terms' bounds leave it nothing to explain"
            )
            reasons.append(
                (
                    columns[j],
                    f"{columns[j]}: held at its physical bound 0 by the fit ({why}; least "
                    f"squares without the bounds: {unbounded[j]:.3g} {unit}): no value given",
                )
            )
        fitted = _fit_kept(
            moments, fitted.lag_bins, fitted.kept & ~pinned, reasons, coefficients_only
        )
        reasons = list(fitted.not_determined)
    if coefficients_only:
        return replace(fitted, not_determined=tuple(reasons))
    half = fitted.half_width()
    reported = fitted.kept.copy()
    for j in np.flatnonzero(fitted.kept):
        idle = _term(columns[j]) == "idle_W"
        count, typical, spread_W = moments.seen_spread(j, idle)
        if count < 2 or not np.isfinite(half[j]):
            continue
        # the term's share of a window where it acts: what its interval leaves open, against
        # how much the power itself varies over those windows (idle, a constant share, against
        # the power's level: a robot whose power hardly varies still has a measured idle)
        open_W = half[j] * typical
        if open_W > LOOSE_SHARE * spread_W:
            unit = term_unit(_term(columns[j]), moments.proxy_all)
            reported[j] = False
            reasons.append(
                (
                    columns[j],
                    f"{columns[j]}: not determined, {fitted.coef[j]:.3g} ± {half[j]:.3g} {unit} "
                    f"(95%) leaves ± {open_W:.3g} W open where it acts, more than the power "
                    + (
                        f"it is part of ({spread_W:.3g} W mean)"
                        if idle
                        else f"varies there (sd {spread_W:.3g} W)"
                    )
                    + ": these logs do not tell it apart from the other terms (it stays in "
                    "the predictions)",
                )
            )
    return replace(fitted, not_determined=tuple(reasons), reported=reported)


#: The terms in the order they are kept when the data cannot tell them apart (roughly how
#: much power they carry on the robots seen): collinearity and loose intervals drop the last.
PREFERENCE = (
    "idle_W",
    "rolling_W_per_mps",
    "turning_Nm",
    "effective_mass_kg",
    "braking_mass_kg",
    "turning_coulomb_W",
    "drive_on_W",
    "quadratic_W_per_mps2",
)
#: The same for a current proxy's force form (moving.py `force_form_regressors`): its idle is the
#: motors' standstill current (the Husky's 0.6 A a motor: 29 W of proxy) and the force
#: always there while moving is the rolling force, so where the two are one column (trips
#: that never stand) the rolling term is kept and idle left out. Held out per surface on
#: BorealTC, sandy loam 8.7% -> 5.8% MAPE (median 4.1 -> 4.2%): its only arc, whose rolling
#: force counts half, was predicted from an idle that counts in full (+63%; now +23%); no other
#: BorealTC surface moves by 0.1 point; Vulpi's ploughed (its arcs alike) 7.0% -> 5.6%.
PREFERENCE_FORCE_FORM = ("rolling_W_per_mps", "idle_W", *PREFERENCE[2:])


def _fit_kept(
    moments,
    lag_bins: float,
    kept: np.ndarray,
    reasons: list[tuple[str, str]],
    coefficients_only: bool = False,
) -> Identified:
    """The bounded least squares of the `kept` columns and (unless `coefficients_only`) their
    cluster jackknife covariance, the lag's uncertainty carried in (below)."""
    columns = moments.columns
    bounds = np.array([TERM_BY_NAME[_term(c)].non_negative for c in columns])
    coef = np.full(len(columns), np.nan)
    xx, xy = moments.gram_xy(kept)
    coef_k = bounded_from_gram(xx, xy, bounds[kept])
    coef[kept] = coef_k
    p = int(kept.sum())
    cov, dof, groups = np.full((p, p), np.nan), 0, 0
    lag_var_s2 = np.nan
    if not coefficients_only:
        # the lag was estimated from these same windows: its uncertainty is carried into the
        # coefficients' by the joint sandwich of (coefficients, lag), the lag's column being
        # how the fitted power moves with it (the regressors' rate of change times the
        # coefficients: a Gauss-Newton linearisation)
        sums, joint_p, groups = moments.jackknife_sums(kept, coef_k)
        dof = max(groups - 1, 0)
        if sums is not None:
            cov, dof, groups = cluster_jackknife(*sums)
        else:
            cov = np.full((joint_p, joint_p), np.nan)
        if joint_p > p:  # the lag's column is in [1/s]: its coefficient a lag in s
            lag_var_s2 = float(cov[p, p])
        cov = cov[:p, :p]
    return Identified(
        columns=columns,
        kept=kept,
        coef=coef,
        cov=cov,
        dof=dof,
        clusters=groups,
        lag_bins=lag_bins,
        not_determined=tuple(reasons),
        residual_W=moments.residual_W,
        lag_var_s2=lag_var_s2,
    )


_term = term_of


def _determined(moments) -> tuple[np.ndarray, list]:
    """Which columns the data determine, and why each other one is not (module docstring).
    Columns are tried in order of how much power they usually carry: idle, rolling, turning,
    speeding up, braking, then the step on moving and v^2, so collinearity drops the weaker
    term (one speed only: |v|, the step and v^2 are one regressor, and |v| is kept)."""
    columns = moments.columns
    preference = PREFERENCE_FORCE_FORM if moments.force_form else PREFERENCE
    order = sorted(range(len(columns)), key=lambda j: preference.index(_term(columns[j])))
    kept = np.zeros(len(columns), dtype=bool)
    reasons: list[tuple[str, str]] = []
    seen_clusters = moments.seen_clusters()
    # every screen below is least squares of one column on the kept ones: from X'X, made once
    gram = moments.gram
    for j in order:
        column = columns[j]
        term = _term(column)
        if term == "turning_coulomb_W" and not moments.proxy_any:
            continue  # a term of the force form only: not one of a power log's model
        if term == "drive_on_W" and moments.proxy_all:
            reasons.append(
                (
                    column,
                    "drive_on_W: a motor current holds no drivers' step (current-proxy logs: "
                    "the force form; the constant moment of turning is turning_coulomb_W)",
                )
            )
            continue
        n_clusters = int(seen_clusters[j])
        if n_clusters < MIN_CLUSTERS:
            reasons.append((column, _unseen_reason(column, n_clusters)))
            continue
        if kept.any():
            base = gram[np.ix_(kept, kept)]
            coef = _gram_solve(base, gram[kept, j])
            # the residual's sum of squares x'x - 2 b'X'x + b'X'X b (>= 0 but for rounding)
            rest_ss = max(float(gram[j, j] - 2.0 * coef @ gram[kept, j] + coef @ base @ coef), 0)
            total = float(gram[j, j]) if term == "idle_W" else moments.centred_ss(j)
            tolerance = rest_ss / total if total > 0 else 0.0
            if tolerance < MIN_TOLERANCE:
                names = ", ".join(columns[k] for k in np.flatnonzero(kept))
                reasons.append(
                    (
                        column,
                        f"{column} cannot be told apart from {names} in these logs "
                        f"({100 * (1 - tolerance):.1f}% of its variation is theirs: e.g. "
                        "one speed only)",
                    )
                )
                continue
        kept[j] = True
    return kept, reasons


def _unseen_reason(column: str, n_clusters: int) -> str:
    term = _term(column)
    what = {
        "idle_W": "no window",
        "drive_on_W": "no motion",
        "rolling_W_per_mps": "no motion",
        "quadratic_W_per_mps2": "no motion",
        "effective_mass_kg": "no speeding up",
        "braking_mass_kg": "no braking",
        "turning_Nm": "no turning",
        "turning_coulomb_W": "no turning",
    }[term]
    where = f" on surface '{column[len(term) + 1 : -1]}'" if "[" in column else ""
    if n_clusters == 0:
        return f"{column}: {what}{where} in the data"
    return (
        f"{column}: seen in only {n_clusters} run(s) or trip(s){where} (at least "
        f"{MIN_CLUSTERS} are needed for an interval)"
    )


def bounded_from_gram(xx: np.ndarray, xy: np.ndarray, non_negative: np.ndarray) -> np.ndarray:
    """Least squares with coef[j] >= 0 where `non_negative[j]`, from X'X and X'y only:
    Lawson & Hanson's active set on the normal equations (few columns; the sum of squares is
    y'y - 2 b'X'y + b'X'X b; Lawson & Hanson 1974, Ch. 23), columns scaled to unit norm for
    conditioning. A fit on some groups' windows is a sum of their sums."""
    p = xx.shape[0]
    if p == 0:
        return np.zeros(0)
    scale = np.sqrt(np.diag(xx)).copy()
    scale[scale == 0] = 1.0
    gram, rhs = xx / np.outer(scale, scale), xy / scale
    fixed = np.zeros(p, dtype=bool)  # held at 0
    coef = np.zeros(p)
    for _ in range(4 * p + 10):
        free = ~fixed
        coef = np.zeros(p)
        coef[free] = np.linalg.solve(gram[np.ix_(free, free)], rhs[free])
        wrong = free & non_negative & (coef < 0)
        if wrong.any():
            fixed[np.flatnonzero(wrong)[np.argmin(coef[wrong])]] = True
            continue
        gradient = rhs - gram @ coef  # > 0: raising that coefficient lowers the SSE
        release = fixed & (gradient > 1e-10 * max(1.0, float(np.abs(rhs).max())))
        if not release.any():
            break
        fixed[np.flatnonzero(release)[np.argmax(gradient[release])]] = False
    return coef / scale
