"""The warm parse cache by hand: cold and warm `wbpower fit DIR --json --jobs 0`, alternating,
for one or more copies of the code (e.g. before and after a change), in one session.

Each copy runs as `python -m wifibot_power` with its folder first on PYTHONPATH (a tree
exported with `git archive COMMIT wifibot_power | tar -x -C DIR`, or the worktree itself);
its warm cache (under --scratch) is filled first. Every repeat runs, for each copy, a cold run
(no cache) then a warm one (`--cache`). Medians of wall time and of CPU time (user + system of
all the command's processes: `getrusage` of the children), and the cold / warm ratios; every
run's JSON must be the same (a different one is reported, and the exit code is 1).

Usage: `.venv/bin/python benchmarks/warm_cache.py CORPUS [--repeats 9]
[--scratch /tmp/wbpower-warm] NAME=TREE [NAME=TREE ...]`, e.g.
`... /work/bench_corpus/power before=/tmp/base after=.` (docs/benchmarks.md, "Warm cache").
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path


def timed(tree: Path, corpus: Path, cache: Path | None) -> tuple[float, float, str]:
    """(wall [s], CPU of all processes [s], stdout) of one `fit --json` of the tree's code."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    args = [sys.executable, "-m", "wifibot_power", "fit", str(corpus), "--json", "--jobs", "0"]
    if cache is not None:
        args += ["--cache", str(cache)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True, env=env, cwd=Path("/"))
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    try:
        json.loads(done.stdout)
    except ValueError:  # an error timed is no measurement
        raise SystemExit(f"{tree}: no JSON from {' '.join(args)}: {done.stderr.strip()}") from None
    return wall, cpu, done.stdout


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("corpus", type=Path)
    parser.add_argument("trees", nargs="+", help="NAME=FOLDER holding wifibot_power/")
    parser.add_argument("--repeats", type=int, default=9)
    parser.add_argument("--scratch", type=Path, default=Path("/tmp/wbpower-warm"))
    args = parser.parse_args()
    trees = {name: Path(path).resolve() for name, path in (t.split("=", 1) for t in args.trees)}
    corpus = args.corpus.resolve()  # the runs start in / (no package of the current folder)
    caches = {name: args.scratch / f"cache-{name}" for name in trees}
    for name, tree in trees.items():
        shutil.rmtree(caches[name], ignore_errors=True)
        timed(tree, corpus, caches[name])  # fills the cache
    times: dict[tuple[str, str], list[tuple[float, float]]] = {}
    outputs: set[str] = set()
    for _ in range(args.repeats):
        for name, tree in trees.items():
            for kind in ("cold", "warm"):
                wall, cpu, out = timed(tree, corpus, caches[name] if kind == "warm" else None)
                times.setdefault((name, kind), []).append((wall, cpu))
                outputs.add(out)
    for (name, kind), runs in times.items():
        walls = [w for w, _ in runs]
        print(
            f"{name} {kind}: wall median {statistics.median(walls):.3f} s "
            f"[{min(walls):.3f}-{max(walls):.3f}], CPU median "
            f"{statistics.median(c for _, c in runs):.3f} s, n={len(runs)}"
        )
    for name in trees:
        cold, warm = times[(name, "cold")], times[(name, "warm")]
        for label, k in (("wall", 0), ("CPU", 1)):
            ratio = statistics.median(r[k] for r in cold) / statistics.median(r[k] for r in warm)
            print(f"{name}: cold / warm {ratio:.1f}x ({label})")
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    bytecode = os.environ.get("PYTHONDONTWRITEBYTECODE")
    print(f"load average {load}; PYTHONDONTWRITEBYTECODE={bytecode}")
    if len(outputs) != 1:
        print(f"the runs printed {len(outputs)} different JSON documents", file=sys.stderr)
        return 1
    print("every run printed the same JSON")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
