"""Shared: the exact minimum of the fractional-lag sum of squares."""

from __future__ import annotations

import numpy as np


# ---- exact minimum: within a bin the sum of squares is a quadratic in the lag (X'X does not
# move with the lag; X'y is linear and y'y quadratic in the fraction), so three values a bin
# (its ends, its middle) give it exactly; the least over [best-1, best+1]
def quad_min(s0, sm, s1):
    """offset in [0,1] and value of the least of the quadratic through (0,s0),(.5,sm),(1,s1)"""
    a = 2 * (s0 - 2 * sm + s1)
    b = s1 - s0 - a
    with np.errstate(all="ignore"):
        t = np.where(a > 0, np.clip(-b / (2 * np.where(a > 0, a, 1)), 0, 1), 0.0)
    v = s0 + b * t + a * t * t
    t = np.where(s1 < np.minimum(v, s0), 1.0, np.where(s0 <= v, 0.0, t))
    v = np.minimum(np.minimum(v, s0), s1)
    return t, v


def exact_replicates(reps) -> np.ndarray:
    """The exact minimum for every replicate of `reps` (laginterval.py `_Replicates`)."""
    sse = reps.whole()
    L = reps.lags.size
    finite = np.isfinite(sse)
    some = finite.any(axis=1)
    best = np.argmin(np.where(finite, sse, np.inf), axis=1)
    out = np.full(reps.B, np.nan)
    out[some] = reps.lags[best[some]]
    rows = np.flatnonzero(some)
    b = best[rows]
    bestval = sse[rows, b]
    lag = b.astype(float)
    for side in (-1, 1):
        lo = b + min(side, 0)  # the bin [lo, lo+1]
        ok = (lo >= 0) & (lo + 1 <= L - 1)
        lo_c = np.clip(lo, 0, L - 2)
        s0, s1 = sse[rows, lo_c], sse[rows, lo_c + 1]
        ok &= np.isfinite(s0) & np.isfinite(s1)
        sm = reps.at(lo_c + 0.5, rows)
        t, v = quad_min(s0, sm, s1)
        better = ok & (v < bestval)
        lag = np.where(better, lo_c + t, lag)
        bestval = np.where(better, v, bestval)
    out[rows] = lag
    return out


def exact_refine(lags, sse_at):
    """refine_lag's signature (gram.py), the exact minimum: for FoldGrams.search"""
    sse = np.array([sse_at(int(lag)) for lag in lags])
    if not np.isfinite(sse).any():
        return 0.0, sse
    best = int(np.argmin(sse))
    L = lags.size
    lag, val = float(best), sse[best]
    for lo in (best - 1, best):
        if 0 <= lo and lo + 1 <= L - 1 and np.isfinite(sse[lo]) and np.isfinite(sse[lo + 1]):
            t, v = quad_min(np.array(sse[lo]), np.array(sse_at(lo + 0.5)), np.array(sse[lo + 1]))
            if v < val:
                lag, val = lo + float(t), float(v)
    return lag, sse
