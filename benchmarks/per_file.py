"""The per-file part of `fit` (issue 25: "fit of a free-driving corpus within 1.5x a bare pyarrow
parse") timed against the bare parse of the same files, alternating, each in a fresh process
measured as `make bench` measures (`measure.measure`: wall, CPU of all its processes, peak
memory of its process tree).

The per-file part is `pipeline.gather` with fit's plan, `--jobs 0`: every log read, checked,
segmented where its mode asks, reduced to its record (the run row, phases, each model family's
statistics) in forked workers, the records sent back to the parent. What follows it (the fits
in the parent) is not in it.

    .venv/bin/python benchmarks/per_file.py FOLDER [--repeats 3] [--python OTHER/.venv/bin/python]

With `--python`, that interpreter's checkout is timed too (its own `gather`), in the same
alternation: the code before a change against the code after.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from measure import BARE_PARSE, load_average, measure  # noqa: E402

#: `gather` of fit's plan over a folder, all cores (what `fit FOLDER --jobs 0` does first)
GATHER = r"""
import sys
from pathlib import Path
from wifibot_power.io.options import ReadOptions
from wifibot_power.pipeline.gather import gather
from wifibot_power.pipeline.record import FIT_PLAN
gathered = gather([Path(sys.argv[1])], ReadOptions(), FIT_PLAN, jobs=0)
print(len(gathered.records), len(gathered.skipped))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--python", default=None, help="another checkout's interpreter")
    args = parser.parse_args()
    sides = {"bare": [sys.executable, "-c", BARE_PARSE, args.folder]}
    # -P: each interpreter imports its own checkout, not the one in the working directory
    sides["gather"] = [sys.executable, "-P", "-c", GATHER, args.folder]
    if args.python:
        sides["other"] = [args.python, "-P", "-c", GATHER, args.folder]
    print(f"per_file: {args.folder}, load {load_average()}", flush=True)
    times: dict[str, list] = {side: [] for side in sides}
    for k in range(args.repeats):
        order = list(sides) if k % 2 == 0 else list(reversed(sides))
        for side in order:
            times[side].append(measure(sides[side]))
        line = "  ".join(
            f"{side} {t.wall_s:5.2f} s (CPU {t.cpu_s:5.2f}, peak {t.peak_tree_pss_MB:4.0f} MB)"
            for side, t in ((side, times[side][-1]) for side in sides)
        )
        print(f"  {line}", flush=True)
    bare = times["bare"]
    for side in sides:
        if side == "bare":
            continue
        pairs = list(zip(times[side], bare, strict=True))
        wall = statistics.median(t.wall_s / b.wall_s for t, b in pairs)
        cpu = statistics.median(t.cpu_s / b.cpu_s for t, b in pairs)
        print(f"{side} / bare parse: wall {wall:.2f}, CPU {cpu:.2f} (median of paired ratios)")
    print(f"load at end {load_average()}")


if __name__ == "__main__":
    main()
