"""Stage 1: per seed, simulate as benchmarks/validate_drive.py `_identified` does, and cache the
per-cluster lag-search sums (cluster_grams_of_windows, clusters = runs), today's lag found
(lag_search: from the sums, or over the windows where the sums lose digits, as at lab), the
exact minimum of the same search (`refine_lag` replaced by common.exact_refine, in this
process only) and the cost of each. Usage: simulate_grams.py REALISM FIRST COUNT"""

import os
import sys
import time
from pathlib import Path

sys.path[:0] = [str(Path(__file__).resolve().parents[2]), str(Path(__file__).resolve().parent)]
import numpy as np  # noqa: E402
from common import exact_refine  # noqa: E402

import wifibot_power.drive.gram as gram  # noqa: E402
import wifibot_power.drive.identify as ident  # noqa: E402
from wifibot_power.drive.identify import lag_grid, lag_search  # noqa: E402
from wifibot_power.drive.laginterval import cluster_grams_of_windows  # noqa: E402
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free  # noqa: E402
from wifibot_power.drive.stats import drive_stats  # noqa: E402
from wifibot_power.drive.windows import StackedPower, run_windows  # noqa: E402

#: where the per-seed sums go (compare.py reads them)
CACHE = Path(os.environ.get("LAG_EXACT_CACHE", "/tmp/lag_exact_cache"))
CACHE.mkdir(parents=True, exist_ok=True)

ORIGINAL = gram.refine_lag


def patched(refine):
    gram.refine_lag = ident.refine_lag = refine


SLOW = {"sample_period_s": 1 / 6.5, "yaw_noise_radps": 0.03}
name, first, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
args = {
    "lab": dict(realism="lab"),
    "field": dict(realism="field"),
    "slow": dict(realism="field", realism_overrides=SLOW),
}[name]
for seed in range(first, first + count):
    config = FreeDriveConfig(seed=seed, runs_per_surface=6, run_s=90.0, **args)
    stats = [drive_stats(as_run(r)) for r in simulate_free(config)]
    runs = [run_windows(s) for s in stats]
    surfaces = tuple(sorted({s for rw in runs for s in rw.stats.surfaces}))
    cost = {}
    for label, refine in (("today", ORIGINAL), ("exact", exact_refine)):
        patched(refine)
        t0 = time.perf_counter()
        found = lag_search(runs, surfaces)
        cost[label] = time.perf_counter() - t0
        if label == "today":
            lag_bins, sse_window = found
        else:
            exact_bins = found[0]
    patched(ORIGINAL)
    # which path lag_search took: the sums' search, or the windows' (cancellation)
    g1 = gram.FoldGrams.from_windows(
        runs, surfaces, np.where(StackedPower(runs).ok, 0, -1), 1, lag_grid(runs)
    )
    by_sums = g1.search(-1) is not None
    g = cluster_grams_of_windows(runs, surfaces, True, lag_grid(runs))
    np.savez(
        f"{CACHE}/{name}_{seed}.npz",
        count=g.count,
        xx=g.xx,
        xy=g.xy,
        yy=g.yy,
        lags=g.lags,
        noise=g.noise,
        lag_bins=lag_bins,
        exact_bins=exact_bins,
        sse_window=sse_window,
        bin_s=runs[0].stats.bin_s,
        true_s=config.lag_s,
        cost_today=cost["today"],
        cost_exact=cost["exact"],
        by_sums=by_sums,
    )
    print(
        name,
        seed,
        f"today {lag_bins * runs[0].stats.bin_s:.5f}s "
        f"exact {exact_bins * runs[0].stats.bin_s:.5f}s sums {by_sums} "
        f"cost {1000 * cost['today']:.1f}/{1000 * cost['exact']:.1f} ms",
        flush=True,
    )
