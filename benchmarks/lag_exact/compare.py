"""Stage 2: today's lag search (quartic/parabola refinement) against the exact minimum of the
fractional-lag sum of squares, for the point estimate and for each of the 1000 cluster-bootstrap
replicates (laginterval.py's weights, seed 0, and its widening). Reads stage 1's cache.
Usage: compare.py [realism ...]"""

import os
import sys
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parents[2]), str(Path(__file__).resolve().parent)]
import numpy as np  # noqa: E402
from common import exact_replicates  # noqa: E402

import wifibot_power.drive.gram as gram  # noqa: E402
from wifibot_power.drive.gram import FoldGrams  # noqa: E402
from wifibot_power.drive.laginterval import (  # noqa: E402
    REPLICATES,
    _Replicates,
    few_clusters_factor,
    lag_interval,
)

#: the per-seed sums simulate_grams.py wrote
CACHE = Path(os.environ.get("LAG_EXACT_CACHE", "/tmp/lag_exact_cache"))


def load(path):
    z = np.load(path)
    g = FoldGrams(z["count"], z["xx"], z["xy"], z["yy"], z["lags"], z["noise"])
    return g, float(z["lag_bins"]), float(z["bin_s"]), float(z["true_s"])


def golden_replicates(reps: _Replicates, tol=1e-7) -> np.ndarray:
    """the same minimum by golden section over [best-1, best+1] (clipped to the grid), all
    replicates at once through `_Replicates.at` (a check of the exact one, and its cost)"""
    sse = reps.whole()
    L = reps.lags.size
    best = np.argmin(np.where(np.isfinite(sse), sse, np.inf), axis=1)
    rows = np.arange(reps.B)
    a = np.maximum(best - 1.0, 0.0)
    b = np.minimum(best + 1.0, L - 1.0)
    r = (np.sqrt(5) - 1) / 2
    c = b - r * (b - a)
    d = a + r * (b - a)
    fc, fd = reps.at(c, rows), reps.at(d, rows)
    while (b - a).max() > tol:
        left = fc < fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        nc = np.where(left, b - r * (b - a), d)
        nd = np.where(left, c, a + r * (b - a))
        new = np.where(left, nc, nd)
        fnew = reps.at(new, rows)
        fd, fc = np.where(left, fc, fnew), np.where(left, fnew, fd)
        c, d = nc, nd
    return (a + b) / 2


def search_with(grams, refine):
    saved = gram.refine_lag
    gram.refine_lag = refine
    try:
        return grams.search(-1)
    finally:
        gram.refine_lag = saved


def widened(found, centre, grams, G):
    """lag_interval's interval from replicate lags `found` [bins] about `centre` [bins]"""
    found = found[np.isfinite(found)]
    low, high = np.quantile(found, [0.025, 0.975])
    pct = (low, high)
    high = max(high, float(grams.lags[0]) + 0.5)
    c = min(max(centre, low), high)
    w = few_clusters_factor(G)
    low = max(c - w * (c - low), float(grams.lags[0]))
    high = min(c + w * (high - c), float(grams.lags[-1]))
    return (low, high), pct


def main(names):
    for name in names:
        files = sorted(CACHE.glob(f"{name}_*.npz"), key=lambda p: int(p.stem.rsplit("_", 1)[1]))
        rows = {"today": [], "exact": []}
        cost = {
            "today_fit": [],
            "exact_fit": [],
            "today_boot": [],
            "exact_boot": [],
            "golden_boot": [],
            "build": [],
        }
        check, bysums, share = [], [], []
        for i, path in enumerate(files):
            g, lag_bins, bin_s, true_s = load(path)
            G = g.folds
            z = np.load(path)
            exact_bins = float(z["exact_bins"])
            cost["today_fit"].append(float(z["cost_today"]))
            cost["exact_fit"].append(float(z["cost_exact"]))
            ones = _Replicates(g, np.ones((1, G)))
            whole_sums = ones.whole()[0]
            check.append(np.max(np.abs(whole_sums - z["sse_window"]) / z["sse_window"]))
            bysums.append(bool(z["by_sums"]))
            share.append(np.min(whole_sums / g.yy[:, 0].sum(0)))
            # bootstrap: laginterval.py's draws
            rng = np.random.default_rng(0)
            weights = rng.multinomial(G, np.full(G, 1.0 / G), size=REPLICATES).astype(float)
            t0 = time.perf_counter()
            reps = _Replicates(g, weights)
            t1 = time.perf_counter()
            today_reps = reps.refined()
            t2 = time.perf_counter()
            exact_reps = exact_replicates(reps)
            t3 = time.perf_counter()
            cost["build"].append(t1 - t0)
            cost["today_boot"].append(t2 - t1)
            cost["exact_boot"].append(t3 - t2)
            if i < 5:
                t3 = time.perf_counter()
                gold = golden_replicates(reps)
                t4 = time.perf_counter()
                cost["golden_boot"].append(t4 - t3)
                diff = np.abs(gold - exact_reps)
                apart = np.flatnonzero(diff > 1e-3)
                rows_ = np.arange(reps.B)[apart]
                lower = int(
                    np.sum(reps.at(exact_reps[apart], rows_) <= reps.at(gold[apart], rows_))
                )
                # golden section settles in one bin's local minimum where the curve dips on
                # both sides of the whole lag: the exact one is then the lower
                print(
                    f"  {name} {path.name}: golden section vs exact, max |diff| "
                    f"{np.nanmax(diff):.2e} bins; {apart.size} replicates over 1e-3 bins apart, "
                    f"the exact one's sum of squares the lower in {lower}"
                )
            ref = lag_interval(g, lag_bins, bin_s)
            for method, pt, rl in (
                ("today", lag_bins, today_reps),
                ("exact", exact_bins, exact_reps),
            ):
                ci, pct = widened(rl, pt, g, G)
                if method == "today":  # the reproduction of lag_interval
                    assert np.allclose(np.array(ci) * bin_s, ref.ci95_s, atol=1e-12), (
                        ci,
                        ref.ci95_s,
                    )
                rows[method].append(
                    (
                        pt * bin_s,
                        ci[0] * bin_s,
                        ci[1] * bin_s,
                        pct[0] * bin_s,
                        pct[1] * bin_s,
                        np.nanstd(rl, ddof=1) * bin_s,
                        np.nanmean(rl) * bin_s,
                        true_s,
                        G,
                    )
                )
        print(
            f"\n## {name}: {len(files)} seeds, bin {bin_s * 1000:.0f} ms, G={G}; today's point "
            f"searched from sums (not over windows) in {sum(bysums)}; whole-lag SSE, sums vs "
            f"windows: median rel diff {np.median(check):.1e}, max {max(check):.1e}; "
            f"min SSE/y'y median {np.median(share):.1e}"
        )
        print(
            "| method | seeds | mean lag [s] | sd over seeds [s] | median boot sd [s] | "
            "median width [s] | coverage (widened) | coverage (percentile) | "
            "mean(rep mean - point) [s] |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for method, r in rows.items():
            a = np.array(r)
            pt, lo, hi, plo, phi, bsd, bmean, true = a[:, :8].T
            held = (lo <= true) & (true <= hi)
            hp = (plo <= true) & (true <= phi)
            print(
                f"| {method} | {len(a)} | {pt.mean():.5f} | {pt.std(ddof=1):.5f} | "
                f"{np.median(bsd):.5f} | {np.median(hi - lo):.5f} | {held.sum()}/{len(a)} | "
                f"{hp.sum()}/{len(a)} | {np.mean(bmean - pt):+.6f} |"
            )
            np.save(f"{CACHE}/rows_{name}_{method}.npy", a)
        d = np.array(rows["exact"])[:, 0] - np.array(rows["today"])[:, 0]
        print(
            f"exact - today point: mean {d.mean():+.6f} s, sd {d.std(ddof=1):.6f} s, "
            "corr(today err, exact err) "
            f"{np.corrcoef(np.array(rows['today'])[:, 0], np.array(rows['exact'])[:, 0])[0, 1]:.3f}"
        )
        ms = {k: 1000 * np.median(v) for k, v in cost.items() if v}
        print("cost (median ms): " + ", ".join(f"{k} {v:.2f}" for k, v in ms.items()))


if __name__ == "__main__":
    main(sys.argv[1:] or ["lab", "field", "slow"])
