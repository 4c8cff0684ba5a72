"""Structure left in a model's per-run errors, judged against the runs' own replication.

causes.md, "Unexplained": structure is what the measured runs show beyond their own
run-to-run spread. The yardstick is the spread of repeated runs of one configuration
(speed, distance, steps, payload): *pure error*, which no model can explain. Four tests,
each returning what it found and where, in a plain sentence:

1. **Lack of fit** (e.g. Montgomery & Runger, Applied Statistics, §11-5.1): configurations
   differ from each other more than repeats of one configuration differ. One-way analysis
   of variance of the residuals, `F = (SS_LOF / (g - q)) / (SS_PE / (n - g))`.
2. **Dependence on a covariate** (speed, step count, distance, payload as levels; session
   order as a line within configurations): an F test of adding the covariate, against
   pure error.
3. **An abrupt change in session order**: the largest standardised difference of mean
   residual before and after any run, `max_k |mean(u[:k]) - mean(u[k:])|·sqrt(k(n-k)/n)`
   (a CUSUM / max-t statistic), with a permutation p-value (session order shuffled).
4. **A run far from its repeats** (an intermittent fault): the largest deviation of a run
   from its configuration's mean, over a robust scale of those deviations, with a
   Monte-Carlo p-value for normal errors in the same configurations.

Residuals are relative, `100·(measured - predicted) / measured` [%]: the run-to-run spread
of energy is about proportional to it. A held-out prediction also carries the model's own
estimation error, the same for repeats of one configuration, which the between-configuration
tests read as structure; on field-realistic null data it is small beside the runs' own
spread (the p-values measured there are close to uniform, docs/diagnose.md), so it is not
modelled. The tests are one family: each is judged at `alpha / m` (Bonferroni, m the tests that
could be run), so the chance that a batch with no structure is called unexplained is at
most `alpha` (docs/diagnose.md gives the rate measured on null data).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from wifibot_power.stats import f_sf, ols

if TYPE_CHECKING:  # imported where used: `diagnose_logs` loads pandas beside its workers
    import pandas as pd

#: Overall false-alarm rate of the family of tests (Bonferroni over the tests run).
ALPHA = 0.01
#: Configuration keys: repeated runs share all of them.
CONFIG_KEYS = ("speed_mps", "distance_m", "steps", "payload_kg")
#: Covariates tested as levels: their name, and how runs at one level are called.
LEVEL_COVARIATES = {
    "speed_mps": ("speed", "runs at {:g} m/s"),
    "steps": ("step count", "runs in {:g} step(s)"),
    "distance_m": ("distance", "runs over {:g} m"),
    "payload_kg": ("payload", "runs with {:g} kg payload"),
}
#: Shuffles of session order (change point) and normal draws (outlier): the smallest
#: p-value each can give is 1 / (draws + 1) = 2e-4, below the 1e-3 a test is judged at.
PERMUTATIONS = 4999
#: Fewest runs on each side of a change point.
MIN_SEGMENT_RUNS = 2
_SEED = 11
#: Structure smaller than this [% of run energy] is not reported, however significant: it is
#: below the accuracy of a bench power analyser's reading (of order 0.1 %), so it cannot be
#: told from the instrument, and it is no claim about the robot. On clean simulated runs,
#: whose repeats agree to 0.005 %, the model's own rounding (phase edges on samples) is
#: significant at 0.003 %; on field data repeats differ by ~0.4 % and this never binds.
RESOLUTION_PCT = 0.1


@dataclass(frozen=True)
class ReplicationTest:
    """One test of structure: its p-value and what and where (a plain sentence)."""

    test: str
    testable: bool
    p_value: float
    statistic: float
    where: str
    #: how large the structure is [% of run energy]: the figure `where` quotes
    size_pct: float = float("nan")

    def as_dict(self) -> dict[str, object]:
        return {
            "test": self.test,
            "testable": self.testable,
            "p_value": self.p_value,
            "statistic": self.statistic,
            "where": self.where,
            "size_pct": self.size_pct,
        }


def _untestable(test: str, why: str) -> ReplicationTest:
    return ReplicationTest(test, False, float("nan"), float("nan"), why)


def residual_table(
    run_id: np.ndarray,
    measured_J: np.ndarray,
    predicted_J: np.ndarray,
    keys: pd.DataFrame,
) -> pd.DataFrame:
    """The per-run table the tests read: run_id, the configuration keys, session_order
    (-1 when unknown), measured and predicted energy [J] and the residual in J and %."""
    import pandas as pd

    table = keys.reset_index(drop=True).copy()
    for key in CONFIG_KEYS:
        table[key] = table[key].astype(np.float64).fillna(0.0) if key in table else 0.0
    order = table["session_order"] if "session_order" in table else -1
    table["session_order"] = pd.Series(order, index=table.index).fillna(-1).astype(int)
    table.insert(0, "run_id", np.asarray(run_id))
    table["measured_J"] = np.asarray(measured_J, dtype=np.float64)
    table["predicted_J"] = np.asarray(predicted_J, dtype=np.float64)
    table["residual_J"] = table["measured_J"] - table["predicted_J"]
    table["residual_pct"] = 100.0 * table["residual_J"] / table["measured_J"]
    return table


def _cells(table: pd.DataFrame) -> np.ndarray:
    """Configuration index of each run (keys rounded so float noise cannot split a cell),
    numbered in the sorted order of the configurations (what pandas' `groupby(keys,
    sort=True).ngroup()` gives, in numpy: a tenth of the time, and it runs 5 times a test
    family)."""
    code = np.zeros(len(table), dtype=np.int64)
    for key in CONFIG_KEYS:
        values = table[key].to_numpy(np.float64)
        values = np.round(np.where(np.isnan(values), 0.0, values), 6)
        # each key's sorted level (-0.0 and 0.0 one level), then lexicographic over the
        # keys so far, renumbered 0 .. cells - 1 (no overflow however many keys and runs)
        levels, level = np.unique(values, return_inverse=True)
        code = np.unique(code * levels.size + level.reshape(-1), return_inverse=True)[1]
    return code.reshape(-1)


def _sse_rank(X: np.ndarray, y: np.ndarray) -> tuple[float, int, np.ndarray]:
    """Residual sum of squares, rank and residual of the least-squares fit of y on X
    (the one least-squares path, `stats.ols`)."""
    fit = ols(X, y)
    return fit.sse, fit.rank, fit.residual


def _indicators(codes: np.ndarray) -> np.ndarray:
    return (codes[:, None] == np.unique(codes)[None, :]).astype(np.float64)


def cell_sums(values: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Sums of `values` (last axis: runs; any leading axes, e.g. Monte-Carlo draws) over
    the runs of each configuration `codes` (0 .. g-1, each present), added one run after
    another in run order: the same sums whatever the BLAS. Was `values @ indicators`, a
    matrix product whose last bits depend on the BLAS kernel and the number of rows, and
    which, for the outlier test's 4999 draws, started OpenBLAS threads that spun on the
    second core for as long again as the test took."""
    counts = np.bincount(codes)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    # runs first, grouped by configuration in run order (np.sum would add pairwise)
    by_run = np.moveaxis(np.asarray(values, dtype=np.float64), -1, 0)[
        np.argsort(codes, kind="stable")
    ]
    sums = by_run[starts].copy()
    for j in range(1, int(counts.max())):  # the j-th run of every configuration that has one
        more = counts > j
        sums[more] += by_run[starts[more] + j]
    return np.moveaxis(sums, 0, -1)


def largest_and_median(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`values.max(axis=-1)` and `np.median(values, axis=-1)` (NaN where a row holds NaN),
    from one sort of each row: numpy's median selects per row, 4-5 times slower than
    sorting on the outlier test's 4999 rows of 80-220 runs. The same numbers: the middle
    value, or the mean of the middle two, `(a + b) / 2` as np.mean takes it."""
    ordered = np.sort(values, axis=-1)  # NaN last, as np.max and np.median see it
    largest = ordered[..., -1]
    half = ordered.shape[-1] // 2
    if ordered.shape[-1] % 2:
        median = ordered[..., half]
    else:
        median = (ordered[..., half - 1] + ordered[..., half]) / 2
    return largest, np.where(np.isnan(largest), np.nan, median)


def lack_of_fit(table: pd.DataFrame) -> ReplicationTest:
    """Test 1: configurations differ more than repeats of one configuration (module doc)."""
    r = table["residual_pct"].to_numpy(np.float64)
    cells = _cells(table)
    n, g = r.size, int(cells.max()) + 1 if r.size else 0
    if n - g < 2:
        return _untestable("lack_of_fit", "too few repeated runs to measure their spread")
    Z = np.ones((len(table), 1))
    sse_z, q, u = _sse_rank(Z, r)
    sse_pe, _, _ = _sse_rank(_indicators(cells), r)
    df1, df2 = g - q, n - g
    if df1 < 1 or sse_pe <= 0:
        return _untestable("lack_of_fit", "too few configurations beyond the model's own terms")
    f_stat = ((sse_z - sse_pe) / df1) / (sse_pe / df2)
    p = f_sf(f_stat, df1, df2)
    # where: the configuration whose mean residual stands out most from pure error
    ms_pe = sse_pe / df2
    # pandas' group means (compensated sums); a named .agg() took ten times as long
    import pandas as pd

    per = pd.DataFrame({"u": u, "J": table["residual_J"].to_numpy()}).groupby(cells).mean()
    z = per["u"] / np.sqrt(ms_pe / np.bincount(cells))
    worst = int(z.abs().idxmax())
    row = table[cells == worst].iloc[0]
    where = (
        f"lack of fit: configurations differ more than repeated runs, which agree to "
        f"{np.sqrt(ms_pe):.2g}% (F = {f_stat:.3g}, p = {p:.2g}); most at {_config(row)}, "
        f"whose runs use {_more_less(per.loc[worst, 'J'], per.loc[worst, 'u'])} than the "
        "model predicts"
    )
    size = float(per.loc[worst, "u"])
    return ReplicationTest("lack_of_fit", True, p, float(f_stat), where, abs(size))


def _error_term(
    table: pd.DataFrame, cells: np.ndarray, sse_full: float, rank_full: int
) -> tuple[float, int] | None:
    """Mean square and degrees of freedom of the error: pure error (repeated runs) when
    there are enough repeats, else the residual of the full fit."""
    n, g = len(table), int(cells.max()) + 1
    if n - g >= 2:
        sse_pe, _, _ = _sse_rank(_indicators(cells), table["residual_pct"].to_numpy(np.float64))
        if sse_pe > 0:
            return sse_pe / (n - g), n - g
    if n - rank_full >= 2 and sse_full > 0:
        return sse_full / (n - rank_full), n - rank_full
    return None


def covariate_dependence(table: pd.DataFrame, covariate: str) -> ReplicationTest:
    """Test 2 for a covariate taken as levels (speed, steps, distance, payload): do the
    residuals' means differ between its levels beyond what the model's refit can move?"""
    name = f"depends_on_{covariate}"
    label, runs_at = LEVEL_COVARIATES[covariate]
    levels = table[covariate].astype(np.float64).fillna(0.0).round(6).to_numpy()
    if np.unique(levels).size < 2:
        return _untestable(name, f"one {label} only")
    r = table["residual_pct"].to_numpy(np.float64)
    cells = _cells(table)
    Z = np.ones((len(table), 1))
    sse_z, q, u = _sse_rank(Z, r)
    codes = np.unique(levels, return_inverse=True)[1]
    sse_full, rank_full, _ = _sse_rank(np.column_stack([Z, _indicators(codes)]), r)
    df1 = rank_full - q
    if df1 < 1:
        return _untestable(name, f"{label} is confounded with the model's own terms")
    denominator = _error_term(table, cells, sse_full, rank_full)
    if denominator is None:
        return _untestable(name, "no degrees of freedom left for the error")
    ms_error, df2 = denominator
    f_stat = ((sse_z - sse_full) / df1) / ms_error
    p = f_sf(f_stat, df1, df2)
    # where: the level whose mean (model's refit taken out) differs most from the rest
    best, best_z, best_diff, best_J = None, 0.0, 0.0, 0.0
    for level in np.unique(levels):
        inside = levels == level
        if inside.all():
            continue
        diff = u[inside].mean() - u[~inside].mean()
        zval = diff / np.sqrt(ms_error * (1 / inside.sum() + 1 / (~inside).sum()))
        if abs(zval) > abs(best_z):
            energy_J = table["measured_J"].to_numpy()[inside].mean()
            best, best_z, best_diff, best_J = level, zval, diff, diff / 100 * energy_J
    where = (
        f"the error depends on {label}: {runs_at.format(best)} use "
        f"{_more_less(best_J, best_diff)} than the model predicts, compared with the rest "
        f"(F = {f_stat:.3g}, p = {p:.2g})"
    )
    return ReplicationTest(name, True, p, float(f_stat), where, abs(float(best_diff)))


def session_trend(table: pd.DataFrame) -> ReplicationTest:
    """Test 2 for session order: a linear trend of the residuals with session order within
    configurations (repeats early and late in the session), against pure error."""
    order = table["session_order"].to_numpy(np.float64)
    timed = order >= 0
    if timed.sum() < 6 or np.unique(order[timed]).size < 3:
        return _untestable("depends_on_session_order", "no session order (started_at)")
    sub = table[timed].reset_index(drop=True)
    r = sub["residual_pct"].to_numpy(np.float64)
    cells = _cells(sub)
    x = order[timed]
    replicated = (sub.shape[0] - (cells.max() + 1)) >= 3
    base = _indicators(cells) if replicated else np.ones((len(sub), 1))
    sse_base, rank_base, _ = _sse_rank(base, r)
    sse_full, rank_full, _ = _sse_rank(np.column_stack([base, x]), r)
    df2 = r.size - rank_full
    if rank_full - rank_base < 1 or df2 < 2 or sse_full <= 0:
        return _untestable("depends_on_session_order", "session order is confounded")
    f_stat = (sse_base - sse_full) / (sse_full / df2)
    p = f_sf(f_stat, 1, df2)
    # the slope within configurations
    import pandas as pd

    xc = x - pd.Series(x).groupby(cells).transform("mean").to_numpy()
    rc = r - pd.Series(r).groupby(cells).transform("mean").to_numpy()
    slope = float(xc @ rc / (xc @ xc)) if replicated else float(np.polyfit(x, r, 1)[0])
    where = (
        f"the error drifts with session order: {_signed(10 * slope, '%')} of run energy "
        f"per 10 runs, within configurations (F = {f_stat:.3g}, p = {p:.2g})"
    )
    drift = abs(slope) * (x.max() - x.min())
    return ReplicationTest("depends_on_session_order", True, p, float(f_stat), where, drift)


def change_point(table: pd.DataFrame, permutations: int = PERMUTATIONS) -> ReplicationTest:
    """Test 3: one abrupt change of the residuals' level in session order (module doc)."""
    timed = table["session_order"].to_numpy(np.float64) >= 0
    if timed.sum() < 2 * MIN_SEGMENT_RUNS + 2:
        return _untestable("change_in_session", "no session order (started_at)")
    sub = table[timed].sort_values("session_order").reset_index(drop=True)
    r = sub["residual_pct"].to_numpy(np.float64)
    u = r - r.mean()
    n = u.size
    k = np.arange(MIN_SEGMENT_RUNS, n - MIN_SEGMENT_RUNS + 1)
    weight = np.sqrt(k * (n - k) / n)

    def mean_differences(series: np.ndarray) -> np.ndarray:
        """The difference of means after and before each k, for each row of `series`
        (in place where it can: the null's rows are 4999 shuffles)."""
        head = np.cumsum(series, axis=-1)[..., k[0] - 1 : k[-1]]  # the sums of the first k
        diff = series.sum(axis=-1, keepdims=True) - head
        diff /= n - k
        diff -= np.divide(head, k, out=head)  # the mean of the first k, where their sums were
        return diff

    diff = mean_differences(u)
    observed = np.abs(diff) * weight
    best = int(np.argmax(observed))
    rng = np.random.default_rng(_SEED)
    shuffled = rng.permuted(np.broadcast_to(u, (permutations, n)), axis=1)
    null = mean_differences(shuffled)
    null = np.multiply(np.abs(null, out=null), weight, out=null).max(axis=1)
    p = float((1 + np.sum(null >= observed[best])) / (permutations + 1))
    at = int(k[best])
    energy_J = sub["measured_J"].to_numpy()
    jump_J = diff[best] / 100 * energy_J.mean()
    where = (
        f"an abrupt change in the session: a jump of {_signed(diff[best], '%')} of run "
        f"energy (about {_signed(jump_J, 'J')} a run) between run "
        f"{sub['run_id'].iloc[at - 1]} and run {sub['run_id'].iloc[at]} (session order "
        f"{at - 1} to {at}; p = {p:.2g}, {permutations} shuffles)"
    )
    size = abs(float(diff[best]))
    return ReplicationTest("change_in_session", True, p, float(observed[best]), where, size)


def outlying_run(table: pd.DataFrame, draws: int = PERMUTATIONS) -> ReplicationTest:
    """Test 4: a run far from its repeats (module doc). Statistic: the largest scaled
    deviation from the configuration mean over 1.4826 × their median (a robust sigma, so
    several faulty runs do not hide each other); p from normal errors in the same cells."""
    cells = _cells(table)
    counts = np.bincount(cells)
    replicated = counts[cells] >= 2
    if replicated.sum() < 6:
        return _untestable("outlying_run", "too few repeated runs")
    sub = table[replicated].reset_index(drop=True)
    codes = np.unique(cells[replicated], return_inverse=True)[1]
    counts = np.bincount(codes)
    size = counts[codes]
    scale = np.sqrt(size / (size - 1.0))

    def stat(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        means = cell_sums(r, codes) / counts
        dev = (r - means[..., codes]) * scale
        largest, median = largest_and_median(np.abs(dev))
        return largest / (1.4826 * median), dev

    r = sub["residual_pct"].to_numpy(np.float64)
    observed, dev = stat(r)
    if not np.isfinite(observed):
        return _untestable("outlying_run", "repeated runs are identical")
    rng = np.random.default_rng(_SEED)
    null, _ = stat(rng.standard_normal((draws, r.size)))
    p = float((1 + np.sum(null >= observed)) / (draws + 1))
    i = int(np.argmax(np.abs(dev)))
    mates = sub["run_id"][(codes == codes[i]) & (np.arange(r.size) != i)]
    own_J = sub["residual_J"].iloc[i] - sub["residual_J"][codes == codes[i]].drop(i).mean()
    own_pct = r[i] - r[(codes == codes[i]) & (np.arange(r.size) != i)].mean()
    where = (
        f"an outlying run: {sub['run_id'].iloc[i]} uses {_more_less(own_J, own_pct)} than "
        f"its repeat(s) {', '.join(mates)}, {observed:.3g} times the typical spread of "
        f"repeated runs (p = {p:.2g})"
    )
    size = abs(float(own_pct))
    return ReplicationTest("outlying_run", True, p, float(observed), where, size)


def replication_tests(table: pd.DataFrame) -> list[ReplicationTest]:
    """Every test of the family, in a fixed order (tests that cannot run are listed, not
    testable). `table`: see `residual_table`."""
    tests = [lack_of_fit(table)]
    tests += [covariate_dependence(table, c) for c in LEVEL_COVARIATES]
    tests += [session_trend(table), change_point(table), outlying_run(table)]
    return tests


def judged_alpha(tests: list[ReplicationTest], alpha: float = ALPHA) -> float:
    """The level each test is judged at: alpha over the number of tests run (Bonferroni)."""
    return alpha / max(1, sum(t.testable for t in tests))


def structure_reasons(table: pd.DataFrame, alpha: float = ALPHA) -> list[str]:
    """The `unexplained_reasons` from replication: one sentence per test that is significant
    and whose structure is at least `RESOLUTION_PCT` of run energy, and one more when the
    runs' own spread cannot be measured (`unknown_spread`)."""
    reasons, unknown = structure(table, alpha)
    return reasons + [unknown] if unknown else reasons


def structure(table: pd.DataFrame, alpha: float = ALPHA) -> tuple[list[str], str | None]:
    """`structure_reasons` in two parts: the structure found (a sentence per test), and
    why none can be ruled out when the runs' own spread cannot be measured, or None."""
    return [t.where for t in found(replication_tests(table), alpha)], unknown_spread(table)


#: How the reason starts when the runs' own spread cannot be measured (`unknown_spread`).
UNKNOWN_SPREAD = "the runs' own spread is unknown"


def unknown_spread(table: pd.DataFrame) -> str | None:
    """Why no structure can be ruled out, or None when it can: structure is what the runs
    show beyond their own run-to-run spread (causes.md, "Unexplained"), measured by repeated
    runs of one configuration (pure error, n - g degrees of freedom for n runs in g
    configurations). Lack of fit compares the g configurations' means (g - 1 degrees of
    freedom) against it; with fewer repeats than that (or fewer than 2), the spread is known
    less well than what it is to judge, and "nothing left" would be a claim the data cannot
    back. A balanced design with 2 runs of each configuration has g repeats, just enough.
    Found on real REGBOT logs: 15 runs, each at its own measured speed and distance, held
    out with a MAPE of 27%, read as "the paper's model explains these runs"; and, in review,
    15 single runs plus 2 repeats hiding a 0.3 W effect on 1-step runs (its F test had 2
    degrees of freedom of spread against 14 of configurations)."""
    n = len(table)
    g = int(_cells(table).max()) + 1 if n else 0
    repeats, compared = n - g, g - 1
    if repeats >= max(2, compared):
        return None
    return (
        f"{UNKNOWN_SPREAD}: {n} runs in {g} configurations, {repeats} "
        f"repeated run(s) to measure it against {compared} degrees of freedom between "
        "configurations, so structure beyond it cannot be ruled out (run each configuration "
        "at least twice: the same speed, distance, steps and payload)"
    )


def found(tests: list[ReplicationTest], alpha: float = ALPHA) -> list[ReplicationTest]:
    """The tests that find structure: p below `judged_alpha` and size >= RESOLUTION_PCT."""
    level = judged_alpha(tests, alpha)
    return [t for t in tests if t.testable and t.p_value < level and t.size_pct >= RESOLUTION_PCT]


def _signed(value: float, unit: str) -> str:
    return f"{value:+.2g}{' ' if unit == 'J' else ''}{unit}"


def _more_less(energy_J: float, pct: float) -> str:
    """'4.2 J (1.3%) more' or '... less' (by the sign of pct)."""
    return f"{abs(energy_J):.2g} J ({abs(pct):.2g}%) {'more' if pct >= 0 else 'less'}"


def _config(row: pd.Series) -> str:
    payload = f", {row['payload_kg']:g} kg payload" if row["payload_kg"] else ""
    steps = f" in {int(row['steps'])} steps" if row["steps"] != 1 else " in 1 step"
    return f"{row['speed_mps']:g} m/s, {row['distance_m']:g} m{steps}{payload}"
