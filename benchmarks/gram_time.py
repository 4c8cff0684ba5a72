"""Wall and CPU time of `fit --json --jobs 0` at two revisions against a bare pyarrow parse,
alternating.

    python benchmarks/gram_time.py OLD_REV NEW_REV FOLDER [FOLDER ...] [--repeats 3]

Each revision's source comes from `git archive` (as benchmarks/gram_equal.py), run with this
interpreter; each round runs the bare parse (measure.BARE_PARSE), the old fit and the new fit
of a folder one after the other (the machine's load falls on all three alike), and the medians
of the wall time and of the CPU time of all their processes (measure.measure) are printed with
the ratios fit / bare parse, the figure issue 25 bounds at 1.5.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gram_equal import source  # noqa: E402
from measure import BARE_PARSE, load_average, measure  # noqa: E402

LAUNCH = (
    "import sys; sys.path.insert(0, sys.argv.pop(1)); "
    "from wifibot_power.cli import app; sys.argv[0] = 'wbpower'; app()"
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--work", type=Path, default=None)
    args = parser.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="gram_time_"))
    srcs = {"old": source(args.old, work), "new": source(args.new, work)}
    start_load = load_average()
    print(f"load average at the start: {start_load}")
    table = [
        "| set | rounds | bare parse, wall / CPU [s] | fit old, wall / CPU [s] | "
        "fit new, wall / CPU [s] | new / old, wall / CPU | fit / bare parse, wall: old -> new "
        "| the same, CPU |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for folder in args.folders:
        runs: dict[str, list] = {"bare": [], "old": [], "new": []}
        for _ in range(args.repeats):
            runs["bare"].append(measure([sys.executable, "-c", BARE_PARSE, str(folder)]))
            for name, src in srcs.items():
                argv = [sys.executable, "-c", LAUNCH, str(src), "fit", str(folder)]
                runs[name].append(measure([*argv, "--json", "--jobs", "0"], ok_codes=(0, 1)))
        for what in ("wall_s", "cpu_s"):
            med = {n: statistics.median(getattr(m, what) for m in ms) for n, ms in runs.items()}
            print(
                f"{folder}: {what} medians of {args.repeats}: bare parse {med['bare']:.2f}, "
                f"fit {args.old} {med['old']:.2f} ({med['old'] / med['bare']:.2f}x), "
                f"fit {args.new} {med['new']:.2f} ({med['new'] / med['bare']:.2f}x); "
                f"new / old {med['new'] / med['old']:.2f}"
            )
            every = {n: [round(getattr(m, what), 2) for m in ms] for n, ms in runs.items()}
            print(f"  all runs: {every}")
        table.append(_row(folder.name, args.repeats, runs))
    end_load = load_average()
    print(f"load average at the end: {end_load}")
    print(f"\n{args.old} (old) against {args.new} (new), medians; load {start_load} -> {end_load}:")
    print("\n".join(table))
    return 0


def _row(name: str, repeats: int, runs: dict[str, list]) -> str:
    """A Markdown row: the medians of wall and CPU time, and their ratios."""
    med = {
        (n, what): statistics.median(getattr(m, what) for m in ms)
        for n, ms in runs.items()
        for what in ("wall_s", "cpu_s")
    }

    def pair(n: str) -> str:
        return f"{med[n, 'wall_s']:.2f} / {med[n, 'cpu_s']:.2f}"

    def ratio(a: str, b: str, what: str) -> float:
        return med[a, what] / med[b, what]

    return (
        f"| {name} | {repeats} | {pair('bare')} | {pair('old')} | {pair('new')} | "
        f"{ratio('new', 'old', 'wall_s'):.2f} / {ratio('new', 'old', 'cpu_s'):.2f} | "
        f"{ratio('old', 'bare', 'wall_s'):.2f} -> **{ratio('new', 'bare', 'wall_s'):.2f}** | "
        f"{ratio('old', 'bare', 'cpu_s'):.2f} -> **{ratio('new', 'bare', 'cpu_s'):.2f}** |"
    )


if __name__ == "__main__":
    sys.exit(main())
