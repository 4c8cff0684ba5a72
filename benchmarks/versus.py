"""Two checkouts of wbpower timed against each other on the bench corpora (issue 24: "`make bench`
not slower than before on any shape").

For each shape and command (`fit`, `diagnose`), the `before` and `after` commands run one after
the other, in an order that alternates from repeat to repeat, on the same corpus folder (the
OS page cache warm for both), each in a fresh process measured as `make bench` measures
(`measure.measure`: wall time, CPU of all its processes). A pair's ratio after/before is taken
within the repeat, so a load that changes slowly (other work on the machine) cancels; the
median of the paired ratios is the figure, their range the spread. Whether both sides printed
the same `--json` document is said beside it (across the restructure it differs where later
work added to the document, e.g. fit's `drive` key: then compare the numbers both have).

    .venv/bin/python benchmarks/versus.py --before /tmp/old/.venv/bin/wbpower \\
        [--after .venv/bin/wbpower] [--shapes power,vi] [--repeats 5] [--out FILE.json]

The corpora are those of `make bench` (corpora.py; built if missing). The free-driving shape
compares `fit` only (diagnose has no step runs there).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import corpora
from measure import load_average, measure

HERE = Path(__file__).resolve().parent


def _argv(wbpower: str, what: str, folder: Path) -> list[str]:
    return [wbpower, what, str(folder), "--json", "--jobs", "0"]


def compare(before: str, after: str, folder: Path, what: str, repeats: int) -> dict[str, object]:
    """`what` by each side on `folder`, alternating, `repeats` pairs."""
    ok = (0, 1)  # diagnose: 1 with --fail-on-discrepancy only; fit: 1 when a log is skipped
    sides = {"before": before, "after": after}
    runs: dict[str, list] = {"before": [], "after": []}
    for k in range(repeats):
        for side in ("before", "after") if k % 2 == 0 else ("after", "before"):
            runs[side].append(measure(_argv(sides[side], what, folder), ok_codes=ok))
        b, a = runs["before"][-1], runs["after"][-1]
        print(
            f"  {what:8s} before {b.wall_s:6.2f} s (CPU {b.cpu_s:6.2f})  after {a.wall_s:6.2f} s "
            f"(CPU {a.cpu_s:6.2f})  after/before {a.wall_s / b.wall_s:5.2f} "
            f"(CPU {a.cpu_s / b.cpu_s:5.2f})",
            flush=True,
        )
    same = runs["before"][0].stdout == runs["after"][0].stdout
    if not same:
        print(f"versus: {what} on {folder}: the two sides print different --json documents")
    wall = [a.wall_s / b.wall_s for a, b in zip(runs["after"], runs["before"], strict=True)]
    cpu = [a.cpu_s / b.cpu_s for a, b in zip(runs["after"], runs["before"], strict=True)]
    return {
        "what": what,
        "same_json": same,
        "before_wall_s": [r.wall_s for r in runs["before"]],
        "after_wall_s": [r.wall_s for r in runs["after"]],
        "before_cpu_s": [r.cpu_s for r in runs["before"]],
        "after_cpu_s": [r.cpu_s for r in runs["after"]],
        "wall_ratio": statistics.median(wall),
        "wall_ratio_range": [min(wall), max(wall)],
        "cpu_ratio": statistics.median(cpu),
        "cpu_ratio_range": [min(cpu), max(cpu)],
    }


def table(results: list[dict]) -> str:
    """The per-shape ratios (after / before; < 1: faster after), 80 columns."""
    out = [
        f"{'shape':9s} {'command':8s} {'wall a/b':>9s} {'range':>12s} {'CPU a/b':>8s} "
        f"{'range':>12s} {'same':>5s}"
    ]
    for r in results:
        wl, wh = r["wall_ratio_range"]
        cl, ch = r["cpu_ratio_range"]
        out.append(
            f"{r['shape']:9s} {r['what']:8s} {r['wall_ratio']:9.2f} {wl:5.2f}-{wh:<6.2f} "
            f"{r['cpu_ratio']:8.2f} {cl:5.2f}-{ch:<6.2f} {'yes' if r['same_json'] else 'NO':>5s}"
        )
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the old checkout's wbpower")
    parser.add_argument("--after", default=str(Path(sys.executable).parent / "wbpower"))
    parser.add_argument("--shapes", default=",".join(corpora.SHAPES), help="comma-separated")
    parser.add_argument("--commands", default="fit,diagnose", help="comma-separated")
    parser.add_argument("--repeats", type=int, default=5, help="alternating pairs")
    parser.add_argument("--root", default=None, help="corpus root (default: see corpora.py)")
    parser.add_argument("--out", default=None, help="write every figure to this JSON file")
    args = parser.parse_args()
    root = corpora.root_of(args.root)
    names = [n.strip() for n in args.shapes.split(",") if n.strip()]
    corpora.main(["--shape", ",".join(names), "--root", str(root)])
    results = []
    start_load = load_average()
    for name in names:
        print(f"versus: {name}", flush=True)
        for what in args.commands.split(","):
            if what == "diagnose" and corpora.SHAPES[name].free_driving:
                continue
            result = compare(args.before, args.after, root / name, what, args.repeats)
            results.append({"shape": name, **result})
    print(table(results))
    print(f"load average {start_load} at start, {load_average()} at end")
    if args.out:
        record = {"before": args.before, "after": args.after, "repeats": args.repeats}
        record["load"] = [start_load, load_average()]
        Path(args.out).write_text(json.dumps({**record, "results": results}, indent=2))


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    main()
