"""`make bench`: `wbpower fit` and `diagnose` beside a bare CSV parse, on every shape of log.

The shapes are those of issue 14.

What it does (docs/benchmarks.md shows the figures and how to read them):

1. Builds the corpora of `benchmarks/corpora.py` unless present with the same parameters
   (root: `--root`, else $WBPOWER_BENCH_CORPUS, else bench_corpus/, git-ignored): the paper's
   grid as power-only canonical CSV (`time_s,power_W`), voltage+current canonical CSV, Keysight
   N6705 exports, gzip-compressed canonical CSV, all at 0.1024 ms, and power-only (`power_W`)
   at 10 kHz; each several hundred MB.
   wbpower's bytecode is compiled first, as a regular pip install does (this matters where
   PYTHONDONTWRITEBYTECODE is set: an editable install would compile every module at
   every start).
2. On each shape, alternating in every repeat (the order rotates): a bare multi-threaded
   `pyarrow.csv.read_csv` of every log in a fresh interpreter (`measure.BARE_PARSE`),
   `wbpower fit --jobs 0` (cold: no parse cache) and `wbpower diagnose --jobs 0`. All read the
   same files from the OS page cache. Medians of wall time and of the CPU time of all the
   command's processes, their ratios to the bare parse; the worst shape is the headline.
3. On one shape (`--extras-shape`, default power): peak memory over the N largest logs for
   growing N (flat in the number of files?), the warm parse cache (`fit --cache`, checked equal
   to the cold result), `fit_logs()` timed after its imports, and the fixed overhead (`fit` of
   one tiny log).
4. cProfile of `fit_logs` and of `diagnose_logs` with 1 job on the `--profile-shape` corpus
   (default power): the share of segmentation, the parse, the sample checks, run_row, ...;
   and the same stages of `fit_logs` timed by CPU time around each call, without a
   profiler (which inflates code made of many small calls).
5. Writes docs/benchmarks.md (text below its hand-written marker is kept) and
   ROOT/last-bench.json (every figure; `--render FILE` writes the page again from it).

Usage: `make bench` or `.venv/bin/python benchmarks/run.py [--shapes power,vi,...]
[--repeats N] [--quick] [--root DIR]`. `--quick` runs the first repeat of every run of each
shape (a third of it or less), one repeat, and writes the page only with `--write-doc`.
The machine is assumed shared: read the CPU columns beside the wall ones.
"""

from __future__ import annotations

import argparse
import compileall
import json
import shutil
import statistics
import struct
import sys
import tempfile
import time
from pathlib import Path

import benchdoc
import corpora
import profiles
from measure import BARE_PARSE, Measured, load_average, machine, measure

ROOT = Path(__file__).resolve().parent.parent
WBPOWER = str(Path(sys.executable).parent / "wbpower")
#: N largest logs of the extras shape fitted for the memory rows (plus the whole shape)
MEMORY_COUNTS = (2, 8, 32)


def csv_bytes(path: Path) -> int:
    """Bytes of CSV in a log: a .gz's uncompressed size (its trailer, mod 4 GiB)."""
    if path.name.endswith(".gz"):
        with open(path, "rb") as f:
            f.seek(-4, 2)
            return struct.unpack("<I", f.read(4))[0]
    return path.stat().st_size


def _line(name: str, m: Measured) -> str:
    return (
        f"  {name:8s} {m.wall_s:6.2f} s  CPU {m.cpu_s:6.2f} s  "
        f"max RSS {m.max_rss_MB:5.0f} MB  tree PSS {m.peak_tree_pss_MB:5.0f} MB"
    )


def bench_shape(name: str, folder: Path, repeats: int) -> dict[str, object]:
    """Bare parse, fit and diagnose of one corpus, alternating, `repeats` times each."""
    logs = corpora.log_files(folder)
    disk = sum(p.stat().st_size for p in logs)
    size = sum(csv_bytes(p) for p in logs)
    print(
        f"bench: {name}: {len(logs)} logs, {size / 1e6:.0f} MB of CSV"
        + (f" ({disk / 1e6:.0f} MB on disk)" if disk != size else ""),
        flush=True,
    )
    free = name in corpora.SHAPES and corpora.SHAPES[name].free_driving
    commands = {
        "bare": [sys.executable, "-c", BARE_PARSE, str(folder)],
        "fit": [WBPOWER, "fit", str(folder), "--json", "--jobs", "0"],
        # diagnose exits 1 only with --fail-on-discrepancy (not given); allowed all the same
        "diagnose": [WBPOWER, "diagnose", str(folder), "--json", "--jobs", "0"],
    }
    if free:  # free driving: diagnose needs the paper's step runs (nothing to time)
        del commands["diagnose"]
    # fit exits 1 when it skipped a log: the simulator's field drop-outs now and then fall
    # side by side into a gap the reader refuses (counted in the row, `fit_skipped`)
    ok_codes = {"bare": (0,), "fit": (0, 1) if free else (0,), "diagnose": (0, 1)}
    runs: dict[str, list[Measured]] = {k: [] for k in commands}
    order = list(commands)
    for k in range(repeats):
        for what in order[k % len(order) :] + order[: k % len(order)]:
            result = measure(commands[what], ok_codes=ok_codes[what])
            runs[what].append(result)
            print(_line(what, result), flush=True)
    largest_bytes, rows = map(int, runs["bare"][0].stdout.split())
    fit_json = json.loads(runs["fit"][0].stdout)
    diag_json = json.loads(runs["diagnose"][0].stdout) if "diagnose" in runs else {}

    def med(what: str, attr: str = "wall_s") -> float:
        return statistics.median(getattr(r, attr) for r in runs[what])

    row: dict[str, object] = {
        "shape": name,
        "description": corpora.SHAPES[name].description if name in corpora.SHAPES else name,
        "sample_period_ms": _period_ms(name),
        "files": len(logs),
        "disk_MB": disk / 1e6,
        "csv_MB": size / 1e6,
        "samples": rows,
        "bytes_per_sample": size / rows,
        "largest_file_columns_MB": largest_bytes / 1e6,
        # free driving: the runs the drive model was fitted from (the paper's model has none)
        "fit_n_runs": (fit_json.get("drive") or {}).get("n_runs") if free else fit_json["n_runs"],
        "fit_skipped": len(fit_json.get("skipped", [])),
        "diagnose_n_runs": diag_json.get("n_runs"),
        "diagnose_findings": len(diag_json["findings"]) if "findings" in diag_json else None,
    }
    for what in ("diagnose",) if free else ():
        for key in ("s", "cpu_s", "runs_s", "cpu_runs_s", "max_rss_MB", "tree_pss_MB", "MBps"):
            row[f"{what}_{key}"] = [] if key.endswith("runs_s") else None
        row[f"{what}_ratio"] = row[f"{what}_cpu_ratio"] = None
    for what in commands:
        row[f"{what}_s"] = med(what)
        row[f"{what}_cpu_s"] = med(what, "cpu_s")
        row[f"{what}_runs_s"] = [r.wall_s for r in runs[what]]
        row[f"{what}_cpu_runs_s"] = [r.cpu_s for r in runs[what]]
        row[f"{what}_max_rss_MB"] = max(r.max_rss_MB for r in runs[what])
        row[f"{what}_tree_pss_MB"] = max(r.peak_tree_pss_MB for r in runs[what])
        row[f"{what}_MBps"] = size / 1e6 / med(what)
    for what in ("fit", "diagnose") if not free else ("fit",):
        row[f"{what}_ratio"] = med(what) / med("bare")
        row[f"{what}_cpu_ratio"] = med(what, "cpu_s") / med("bare", "cpu_s")
    row["_fit_json"] = fit_json
    return row


def _period_ms(name: str) -> float | None:
    shape = corpora.SHAPES.get(name)
    return shape.sample_period_s * 1e3 if shape else None


def warm_cache(folder: Path, scratch: Path, repeats: int, cold_json: dict) -> dict[str, object]:
    """`fit --cache`: one run that fills the cache, then warm runs; the result must not change."""
    cache_dir = Path(tempfile.mkdtemp(prefix="wbpower-bench-cache-", dir=scratch))
    argv = [WBPOWER, "fit", str(folder), "--json", "--jobs", "0", "--cache", str(cache_dir)]
    try:
        fill = measure(argv)
        print(_line("fill", fill), flush=True)
        warm = []
        for _ in range(max(repeats, 3)):
            warm.append(measure(argv))
            print(_line("warm", warm[-1]), flush=True)
        cache_MB = sum(p.stat().st_size for p in cache_dir.rglob("*") if p.is_file()) / 1e6
        same = json.loads(warm[-1].stdout) == cold_json and json.loads(fill.stdout) == cold_json
    finally:
        shutil.rmtree(cache_dir, ignore_errors=True)
    return {
        "fill_s": fill.wall_s,
        "warm_s": statistics.median(r.wall_s for r in warm),
        "warm_cpu_s": statistics.median(r.cpu_s for r in warm),
        "warm_runs_s": [r.wall_s for r in warm],
        "warm_max_rss_MB": max(r.max_rss_MB for r in warm),
        "cache_MB": cache_MB,
        "identical": same,
    }


def memory_vs_files(folder: Path, scratch: Path, counts: tuple[int, ...]) -> list[dict]:
    """Peak memory of `fit` over the N largest logs of `folder` (symlinks): the largest file is
    the same whatever N, so growth with N would be memory held per file. (Copies of one log
    would not do: a batch analyses a copy once, log-format.md.)"""
    logs = sorted(corpora.log_files(folder), key=lambda p: -p.stat().st_size)
    manifest = (folder / "runs.csv").read_text().splitlines()
    out = []
    for count in counts:
        chosen = logs[:count]
        sub = scratch / f"bench-largest-{count}"
        shutil.rmtree(sub, ignore_errors=True)
        sub.mkdir(parents=True)
        for path in chosen:
            (sub / path.name).symlink_to(path)
        names = {p.name for p in chosen}
        rows = [manifest[0], *(r for r in manifest[1:] if r.split(",", 1)[0] in names)]
        (sub / "runs.csv").write_text("\n".join(rows) + "\n")
        # the largest logs are all at one speed: an incomplete model, which fit says in its
        # warnings (exit 0; it exited 1 before, and still does if a log is skipped)
        result = measure([WBPOWER, "fit", str(sub), "--json", "--jobs", "0"], ok_codes=(0, 1))
        shutil.rmtree(sub)
        print(_line(f"{count} logs", result), flush=True)
        out.append(
            {
                "logs": count,
                "MB": sum(p.stat().st_size for p in chosen) / 1e6,
                "largest_MB": chosen[0].stat().st_size / 1e6,
                "wall_s": result.wall_s,
                "cpu_s": result.cpu_s,
                "max_rss_MB": result.max_rss_MB,
                "tree_pss_MB": result.peak_tree_pss_MB,
            }
        )
    return out


def fixed_overhead(scratch: Path) -> dict[str, float]:
    """`wbpower fit` on one tiny log: what the interpreter and libraries cost on their own."""
    tiny = scratch / "bench-tiny"
    if not (tiny / "runs.csv").is_file():
        shutil.rmtree(tiny, ignore_errors=True)
        measure(
            [WBPOWER, "simulate", "-o", str(tiny), "--speeds", "0.5", "--trips", "2x1",
             "--repeats", "1", "--modes", "", "--sample-period", "0.001024"]
        )  # fmt: skip
    # one speed is not a complete model, and fit says so (exit 0; it exited 1 before);
    # the cost is what is measured
    result = measure([WBPOWER, "fit", str(tiny), "--json", "--jobs", "1"], ok_codes=(0, 1))
    return {"max_rss_MB": result.max_rss_MB, "wall_s": result.wall_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", default=",".join(corpora.SHAPES), help="comma-separated")
    parser.add_argument("--repeats", type=int, default=5, help="alternating repeats (median)")
    parser.add_argument("--quick", action="store_true", help="small subset, 1 repeat")
    parser.add_argument("--root", default=None, help="corpus root (default: see corpora.py)")
    parser.add_argument("--extras-shape", default="power", help="shape of the memory/cache rows")
    parser.add_argument("--profile-shape", default="power", help="shape profiled")
    parser.add_argument("--no-extras", action="store_true", help="skip memory, cache, profiles")
    parser.add_argument("--write-doc", action="store_true", help="write the page after --quick")
    parser.add_argument("--generate-only", action="store_true", help="build the corpora, stop")
    parser.add_argument("--render", metavar="JSON", help="write the page from a last-bench.json")
    args = parser.parse_args()
    if args.render:
        benchdoc.write(json.loads(Path(args.render).read_text()))
        return
    root = corpora.root_of(args.root)
    root.mkdir(parents=True, exist_ok=True)
    names = [n.strip() for n in args.shapes.split(",") if n.strip()]
    unknown = [n for n in names if n not in corpora.SHAPES]
    if unknown:
        known = ", ".join(corpora.SHAPES)
        raise SystemExit(f"bench: unknown shape {unknown}: give some of {known}")
    corpora.main(["--shape", ",".join(names), "--root", str(root)])
    if args.generate_only:
        return
    # wbpower as installed: its bytecode compiled (pip compiles it at a regular install;
    # an editable one compiles nothing, and with PYTHONDONTWRITEBYTECODE set, as here, every
    # start would compile wifibot_power's source again, ~80 ms a command)
    compileall.compile_dir(ROOT / "wifibot_power", quiet=1)
    started = time.perf_counter()
    folders = {n: root / n for n in names}
    repeats = args.repeats
    counts = MEMORY_COUNTS
    if args.quick:
        folders = {n: corpora.quick_subset(f, root / "bench-quick" / n) for n, f in folders.items()}
        repeats = 1 if args.repeats == parser.get_default("repeats") else args.repeats
        counts = (2, 4)
    info = machine()
    rows = [bench_shape(n, f, repeats) for n, f in folders.items()]
    extras: dict[str, object] = {}
    if not args.no_extras:
        extras_name = args.extras_shape if args.extras_shape in folders else names[0]
        extras_row = next(r for r in rows if r["shape"] == extras_name)
        print(f"bench: memory, parse cache and fixed overhead on {extras_name}", flush=True)
        extras["shape"] = extras_name
        extras["fixed"] = fixed_overhead(root)
        extras["copies"] = memory_vs_files(folders[extras_name], root, counts)
        extras["warm"] = warm_cache(folders[extras_name], root, repeats, extras_row["_fit_json"])
        extras["warm"]["cold_s"] = extras_row["fit_s"]
        extras["warm"]["speedup"] = extras_row["fit_s"] / extras["warm"]["warm_s"]
        library = profiles.library_times(folders[extras_name], root)
        library["speedup"] = library["cold_s"] / library["warm_s"]
        extras["library"] = library
        print(
            f"  fit_logs() after imports: cold {library['cold_s']:.2f} s, filling the cache "
            f"{library['fill_s']:.2f} s, warm {library['warm_s']:.3f} s",
            flush=True,
        )
        profile_name = args.profile_shape if args.profile_shape in folders else names[0]
        print(f"bench: cProfile of fit_logs and diagnose_logs on {profile_name}", flush=True)
        extras["profile_shape"] = profile_name
        extras["profile_fit"] = profiles.profile("fit", folders[profile_name])
        extras["timed_fit"] = profiles.timed_shares(folders[profile_name])
        extras["profile_diagnose"] = profiles.profile("diagnose", folders[profile_name])
        if "drive" in folders:
            print("bench: cProfile of fit_logs on drive (the drive model)", flush=True)
            extras["profile_fit_drive"] = profiles.profile("fit", folders["drive"], drive=True)
    info["load average at end"] = load_average()
    info["bench took"] = f"{(time.perf_counter() - started) / 60:.1f} min"
    for row in rows:
        row.pop("_fit_json")
    print(benchdoc.summary(rows, extras))
    record = {
        "measured_at": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "quick": args.quick,
        "machine": info,
        "rows": rows,
        "extras": extras,
    }
    name = "last-bench-quick.json" if args.quick else "last-bench.json"
    (root / name).write_text(json.dumps(record, indent=2))
    print(f"bench: wrote {root / name}")
    if not args.quick or args.write_doc:
        benchdoc.write(record)


if __name__ == "__main__":
    main()
