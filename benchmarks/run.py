"""`make bench`: `wbpower fit` on >= 1 GB of simulated logs against a bare pyarrow CSV parse.

What it does (docs/benchmarks.md shows the figures and how to read them):

1. Generates two corpora with `wbpower simulate` into bench_corpus/ (git-ignored): the paper's
   grid at 0.1024 ms (9 speeds x trips 2 m, 10 m, 10 m in 10 steps, plus idle/network/video/cpu
   logs), once with 1 repeat ("small") and once with 4 ("full", >= 1 GB of CSV). The longest
   log (10 m at 0.1 m/s, ~1 M samples) is in both. A corpus whose parameters have not changed
   is not generated again.
2. On each corpus, alternating in every repeat: a bare multi-threaded `pyarrow.csv.read_csv` of
   every file (in a fresh interpreter) and `wbpower fit --jobs 0` (cold: no parse cache). Both
   read the same files from the OS page cache; the medians and their ratio are reported.
3. Peak memory of each command: the largest RSS of any of its processes (getrusage of the
   children) and the peak of the summed PSS of its process tree (sampled every 50 ms), beside
   the in-memory columns of the largest file (all its columns as float64, as pyarrow holds
   them) and the fixed overhead (`wbpower fit` on a single tiny log).
4. `wbpower fit --cache DIR`: one run that fills the cache, then warm runs; the speed-up is
   cold (no cache) / warm. The warm result must equal the cold one (checked).
5. Writes docs/benchmarks.md (the machine, the table, how to reproduce).

Usage: `make bench` or `.venv/bin/python benchmarks/run.py [--repeats N] [--corpus small,full]`.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CORPUS_ROOT = ROOT / "bench_corpus"
DOC = ROOT / "docs" / "benchmarks.md"
WBPOWER = [str(Path(sys.executable).parent / "wbpower")]
#: simulate arguments per corpus; the longest log is the same in both
CORPORA = {
    "small": ["--repeats", "1", "--mode-repeats", "1", "--seed", "2026"],
    "full": ["--repeats", "4", "--mode-repeats", "2", "--seed", "2026"],
}
BARE_PARSE = r"""
import sys, pyarrow as pa, pyarrow.csv as pacsv
from pathlib import Path
largest = 0
rows = 0
for path in sorted(p for p in Path(sys.argv[1]).rglob("*.csv") if p.name != "runs.csv"):
    with open(path, "rb") as f:  # skip the '#' metadata lines, as any reader must
        skip = 0
        for line in f:
            if not line.startswith(b"#"):
                break
            skip += 1
    table = pacsv.read_csv(path, read_options=pacsv.ReadOptions(skip_rows=skip))
    largest = max(largest, table.nbytes)
    rows += table.num_rows
print(largest, rows)
"""


@dataclass
class Measured:
    """One command run: wall time, largest process RSS, peak summed PSS of its tree."""

    wall_s: float
    max_rss_MB: float
    peak_tree_pss_MB: float
    #: user + system CPU of all its processes: what it costs, whatever else the machine runs
    cpu_s: float
    stdout: str = field(repr=False, default="")


def _tree_pss_kB(root_pid: int) -> int:
    """Summed PSS of `root_pid` and its descendants (Linux /proc)."""
    parents: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                parents[int(entry)] = int(fields[1])
            except (OSError, IndexError, ValueError):
                continue
    tree, frontier = {root_pid}, [root_pid]
    while frontier:
        pid = frontier.pop()
        for child, parent in parents.items():
            if parent == pid and child not in tree:
                tree.add(child)
                frontier.append(child)
    total = 0
    for pid in tree:
        try:
            with open(f"/proc/{pid}/smaps_rollup") as f:
                for line in f:
                    if line.startswith("Pss:"):
                        total += int(line.split()[1])
                        break
        except OSError:
            continue
    return total


def measure(argv: list[str]) -> Measured:
    """Run `argv` through a fresh wrapper so getrusage(RUSAGE_CHILDREN) covers only it."""
    wrapper = (
        "import resource, subprocess, sys\n"
        "p = subprocess.run(sys.argv[1:], stdout=subprocess.PIPE)\n"
        "sys.stdout.buffer.write(p.stdout)\n"
        "use = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
        "cpu = use.ru_utime + use.ru_stime\n"
        "sys.stderr.write('MAXRSS_KB %d CPU_S %.3f\\n' % (use.ru_maxrss, cpu))\n"
        "sys.exit(p.returncode)\n"
    )
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", wrapper, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    peak = [0]
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            peak[0] = max(peak[0], _tree_pss_kB(proc.pid))
            stop.wait(0.05)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    out, err = proc.communicate()
    wall_s = time.perf_counter() - start
    stop.set()
    sampler.join()
    text = err.decode()
    if proc.returncode not in (0, 1):
        raise SystemExit(f"bench: {' '.join(map(str, argv))} failed:\n{text[-2000:]}")
    max_rss_kB = int(text.rsplit("MAXRSS_KB", 1)[1].split()[0])
    cpu_s = float(text.rsplit("CPU_S", 1)[1].split()[0])
    return Measured(wall_s, max_rss_kB / 1024, peak[0] / 1024, cpu_s, out.decode())


def generate(name: str) -> Path:
    """The corpus `name`, generated unless present with the same parameters."""
    folder = CORPUS_ROOT / name
    stamp = folder / ".bench-params.json"
    wanted = {"simulate": CORPORA[name], "version": 1}
    if stamp.is_file() and json.loads(stamp.read_text()) == wanted:
        print(f"bench: {folder} present with the same parameters: not generated again")
        return folder
    shutil.rmtree(folder, ignore_errors=True)
    print(f"bench: generating {folder} ...", flush=True)
    start = time.perf_counter()
    subprocess.run([*WBPOWER, "simulate", "-o", str(folder), *CORPORA[name]], check=True, cwd=ROOT)
    stamp.write_text(json.dumps(wanted))
    print(f"bench: generated in {time.perf_counter() - start:.0f} s")
    return folder


def corpus_bytes(folder: Path) -> tuple[int, int]:
    files = [p for p in folder.rglob("*.csv") if p.name != "runs.csv"]
    return len(files), sum(p.stat().st_size for p in files)


def machine() -> dict[str, str]:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem_kB = 0
    try:
        mem_kB = int(Path("/proc/meminfo").read_text().split()[1])
    except (OSError, ValueError, IndexError):
        pass
    import numpy
    import pyarrow

    return {
        "cpu": cpu,
        "cores (nproc)": str(len(os.sched_getaffinity(0))),
        "memory": f"{mem_kB / 1024**2:.1f} GiB",
        "os": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "pyarrow": pyarrow.__version__,
        "numpy": numpy.__version__,
        "load average at start": " ".join(f"{x:.2f}" for x in os.getloadavg()),
    }


def bench_corpus(folder: Path, repeats: int) -> dict[str, object]:
    files, size = corpus_bytes(folder)
    print(f"bench: {folder.name}: {files} files, {size / 1e6:.0f} MB", flush=True)
    bare_argv = [sys.executable, "-c", BARE_PARSE, str(folder)]
    fit_argv = [*WBPOWER, "fit", str(folder), "--json", "--jobs", "0"]
    bare, fit = [], []
    for k in range(repeats):
        order = [("bare", bare_argv, bare), ("fit", fit_argv, fit)]
        for name, argv, into in order if k % 2 == 0 else order[::-1]:
            result = measure(argv)
            into.append(result)
            print(
                f"  {name:4s} {result.wall_s:6.2f} s  CPU {result.cpu_s:6.2f} s  "
                f"max RSS {result.max_rss_MB:6.0f} MB  "
                f"tree PSS {result.peak_tree_pss_MB:6.0f} MB",
                flush=True,
            )
    largest_bytes, rows = map(int, bare[0].stdout.split())
    fit_json = json.loads(fit[0].stdout)
    cache_dir = Path(tempfile.mkdtemp(prefix="wbpower-bench-cache-", dir=CORPUS_ROOT))
    try:
        cache_argv = [*fit_argv, "--cache", str(cache_dir)]
        fill = measure(cache_argv)
        print(f"  fill cache {fill.wall_s:6.2f} s", flush=True)
        warm = []
        for _ in range(max(repeats, 3)):
            warm.append(measure(cache_argv))
            print(f"  warm {warm[-1].wall_s:6.2f} s", flush=True)
        cache_MB = sum(p.stat().st_size for p in cache_dir.iterdir()) / 1e6
        same = json.loads(warm[-1].stdout) == fit_json and json.loads(fill.stdout) == fit_json
    finally:
        shutil.rmtree(cache_dir, ignore_errors=True)
    library = library_times(folder)
    print(f"  library: {library}", flush=True)
    med = lambda runs, attr="wall_s": statistics.median(getattr(r, attr) for r in runs)  # noqa: E731
    return {
        "corpus": folder.name,
        "files": files,
        "csv_MB": size / 1e6,
        "samples": rows,
        "largest_file_columns_MB": largest_bytes / 1e6,
        "bare_s": med(bare),
        "fit_s": med(fit),
        "bare_runs_s": [r.wall_s for r in bare],
        "fit_runs_s": [r.wall_s for r in fit],
        "ratio": med(fit) / med(bare),
        "bare_cpu_s": med(bare, "cpu_s"),
        "fit_cpu_s": med(fit, "cpu_s"),
        "cpu_ratio": med(fit, "cpu_s") / med(bare, "cpu_s"),
        "warm_cpu_s": med(warm, "cpu_s"),
        "bare_MBps": size / 1e6 / med(bare),
        "fit_MBps": size / 1e6 / med(fit),
        "bare_max_rss_MB": max(r.max_rss_MB for r in bare),
        "fit_max_rss_MB": max(r.max_rss_MB for r in fit),
        "bare_tree_pss_MB": max(r.peak_tree_pss_MB for r in bare),
        "fit_tree_pss_MB": max(r.peak_tree_pss_MB for r in fit),
        "fill_cache_s": fill.wall_s,
        "warm_s": med(warm),
        "warm_runs_s": [r.wall_s for r in warm],
        "cache_speedup": med(fit) / med(warm),
        "cache_MB": cache_MB,
        "lib_cold_s": library["cold_s"],
        "lib_fill_s": library["fill_s"],
        "lib_warm_s": library["warm_s"],
        "lib_speedup": library["cold_s"] / library["warm_s"],
        "warm_max_rss_MB": max(r.max_rss_MB for r in warm),
        "cached_result_identical": same,
        "fit_n_runs": fit_json["n_runs"],
    }


PROFILE = r"""
import cProfile, json, pstats, sys, time
from pathlib import Path
start = time.perf_counter()
import wifibot_power.cli  # what every wbpower command imports
import_s = time.perf_counter() - start
from wifibot_power.fit import fit_logs
profile = cProfile.Profile()
profile.runcall(fit_logs, [Path(sys.argv[1])], jobs=1)
stats = pstats.Stats(profile).stats
def cumulative(file_end, name):
    return sum(v[3] for (f, _, n), v in stats.items() if f.endswith(file_end) and n == name)
print(json.dumps({
    "import wifibot_power.cli": import_s,
    "fit_logs (whole, 1 job)": cumulative("fit.py", "fit_logs"),
    "read_log": cumulative("reader.py", "read_log"),
    "  CSV parse to numpy (read_columns)": cumulative("transport.py", "read_columns"),
    "  sample checks (check_samples)": cumulative("validate.py", "check_samples"),
    "segment_run": cumulative("segment.py", "segment_run"),
    "run_row": cumulative("runtable.py", "run_row"),
}))
"""


LIBRARY = r"""
import json, shutil, statistics, sys, tempfile, time
from pathlib import Path
from wifibot_power.cache import ParseCache
from wifibot_power.fit import fit_logs
folder, scratch = Path(sys.argv[1]), Path(sys.argv[2])
def timed(**kw):
    start = time.perf_counter()
    fit_logs([folder], jobs=0, **kw)
    return time.perf_counter() - start
cold = [timed() for _ in range(2)]
cache = ParseCache(Path(tempfile.mkdtemp(dir=scratch)))
fill = timed(cache=cache)
warm = [timed(cache=cache) for _ in range(3)]
shutil.rmtree(cache.directory)
print(json.dumps({"cold_s": statistics.median(cold), "fill_s": fill,
                  "warm_s": statistics.median(warm)}))
"""


def library_times(folder: Path) -> dict[str, float]:
    """`fit_logs` called from Python, timed after the imports (what a notebook or a CI job
    that fits several corpora in one process sees): cold, filling the cache, warm."""
    out = subprocess.run(
        [sys.executable, "-c", LIBRARY, str(folder), str(CORPUS_ROOT)],
        check=True,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    stages = json.loads(out.stdout)
    # a function renamed in the package would otherwise show as a stage that takes no time
    missing = [name.strip() for name, seconds in stages.items() if seconds <= 0]
    if missing:
        raise SystemExit(f"bench: no time found for {missing}: rename them in PROFILE")
    return stages


def profile_stages(folder: Path) -> dict[str, float]:
    """Where `fit` spends its time: cProfile of one job over `folder` (cumulative seconds)."""
    out = subprocess.run(
        [sys.executable, "-c", PROFILE, str(folder)],
        check=True,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    return json.loads(out.stdout)


def memory_vs_files(corpus: Path, counts: tuple[int, ...] = (2, 8, 32)) -> list[dict]:
    """Peak memory of `fit` over N copies (symlinks) of the corpus's largest log: the largest
    file is the same whatever N, so any growth with N would be memory held per file."""
    largest = max(
        (p for p in corpus.glob("*.csv") if p.name != "runs.csv"), key=lambda p: p.stat().st_size
    )
    out = []
    for count in counts:
        folder = CORPUS_ROOT / f"copies_{count}"
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir()
        for k in range(count):
            (folder / f"copy_{k:03d}.csv").symlink_to(largest)
        result = measure([*WBPOWER, "fit", str(folder), "--json", "--jobs", "0"])
        shutil.rmtree(folder)
        print(f"  {count} copies: {result.wall_s:.1f} s, max RSS {result.max_rss_MB:.0f} MB, "
              f"tree PSS {result.peak_tree_pss_MB:.0f} MB", flush=True)  # fmt: skip
        out.append(
            {
                "copies": count,
                "file": largest.name,
                "file_MB": largest.stat().st_size / 1e6,
                "wall_s": result.wall_s,
                "max_rss_MB": result.max_rss_MB,
                "tree_pss_MB": result.peak_tree_pss_MB,
            }
        )
    return out


def fixed_overhead() -> Measured:
    """`wbpower fit` on one tiny log: what the interpreter and libraries cost on their own."""
    tiny = CORPUS_ROOT / "tiny"
    if not (tiny / "runs.csv").is_file():
        subprocess.run(
            [*WBPOWER, "simulate", "-o", str(tiny), "--speeds", "0.5", "--trips", "2x1",
             "--repeats", "1", "--modes", "", "--sample-period", "0.001024"],
            check=True, cwd=ROOT, stdout=subprocess.DEVNULL,
        )  # fmt: skip
    return measure([*WBPOWER, "fit", str(tiny), "--json", "--jobs", "1"])


def write_doc(
    info: dict[str, str],
    rows: list[dict[str, object]],
    fixed: Measured,
    stages: dict[str, float],
    profiled: str,
    copies: list[dict],
) -> None:
    def num(x: float, d: int = 2) -> str:
        return f"{x:.{d}f}"

    lines = [
        "# Benchmarks: `wbpower fit` beside a bare CSV parse",
        "",
        "Written by `make bench` (benchmarks/run.py) on "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}. Re-run it to refresh this page.",
        "",
        "## Machine",
        "",
        "| | |",
        "| --- | --- |",
        *[f"| {k} | {v} |" for k, v in info.items()],
        "",
        "## Results",
        "",
        "Times are medians of alternating runs (bare, fit, bare, ...) in one session; each is a",
        "fresh process (interpreter start and imports included). Both read the files from the",
        "OS page cache: what is compared is the CPU cost of parsing and of the rest.",
        "",
        "| | " + " | ".join(str(r["corpus"]) for r in rows) + " |",
        "| --- | " + " | ".join("---:" for _ in rows) + " |",
    ]

    def row(label: str, key: str, fmt=num) -> None:
        lines.append(f"| {label} | " + " | ".join(fmt(r[key]) for r in rows) + " |")

    row("files", "files", str)
    row("CSV [MB]", "csv_MB", lambda x: f"{x:.0f}")
    row("samples", "samples", lambda x: f"{x:,}")
    row("runs fitted", "fit_n_runs", str)
    row("bare `pyarrow.csv.read_csv` [s]", "bare_s")
    row("`wbpower fit --jobs 0`, cold [s]", "fit_s")
    row("**fit / bare parse**", "ratio", lambda x: f"**{x:.2f}**")
    row("bare parse, CPU (user + system) [s]", "bare_cpu_s")
    row("fit, CPU of all its processes [s]", "fit_cpu_s")
    row("fit / bare parse, CPU", "cpu_ratio")
    row("bare parse [MB/s]", "bare_MBps", lambda x: f"{x:.0f}")
    row("fit [MB/s]", "fit_MBps", lambda x: f"{x:.0f}")
    row("fit runs [s]", "fit_runs_s", lambda xs: ", ".join(f"{x:.1f}" for x in xs))
    row("bare runs [s]", "bare_runs_s", lambda xs: ", ".join(f"{x:.1f}" for x in xs))
    row("largest file's columns in memory [MB]", "largest_file_columns_MB", lambda x: f"{x:.0f}")
    row("fit: largest process RSS [MB]", "fit_max_rss_MB", lambda x: f"{x:.0f}")
    row("fit: peak PSS of all its processes [MB]", "fit_tree_pss_MB", lambda x: f"{x:.0f}")
    row("bare: peak RSS [MB]", "bare_max_rss_MB", lambda x: f"{x:.0f}")
    row("fit --cache, first run (fills it) [s]", "fill_cache_s")
    row("fit --cache, warm [s]", "warm_s")
    row("fit --cache, warm, CPU [s]", "warm_cpu_s")
    row("**cold / warm**", "cache_speedup", lambda x: f"**{x:.1f}x**")
    row("cache size [MB]", "cache_MB", lambda x: f"{x:.0f}")
    row("`fit_logs()` after imports, cold [s]", "lib_cold_s")
    row("`fit_logs(cache=...)`, filling [s]", "lib_fill_s")
    row("`fit_logs(cache=...)`, warm [s]", "lib_warm_s")
    row("**cold / warm, after imports**", "lib_speedup", lambda x: f"**{x:.0f}x**")
    row("warm result identical to cold", "cached_result_identical", str)
    columns = max(r["largest_file_columns_MB"] for r in rows)
    measured = ", ".join(f"{r['corpus']} {r['fit_max_rss_MB']:.0f} MB" for r in rows)
    lines += [
        "",
        f"Fixed overhead: `wbpower fit --jobs 1` on one tiny log peaks at {fixed.max_rss_MB:.0f}",
        f"MB RSS ({fixed.wall_s:.2f} s: the interpreter, numpy, pandas, scipy, pyarrow, typer,",
        "rich). Budget per process: fixed overhead + 2 x the largest file's columns = "
        f"{fixed.max_rss_MB:.0f} + 2 x {columns:.0f} = {fixed.max_rss_MB + 2 * columns:.0f} MB;",
        f"measured largest process RSS: {measured}.",
        "",
    ]
    if copies:
        lines += [
            "Memory against the number of files: `fit --jobs 0` over N copies of the largest log",
            f"({copies[0]['file']}, {copies[0]['file_MB']:.0f} MB of CSV):",
            "",
            "| copies | wall [s] | largest process RSS [MB] | peak PSS, all processes [MB] |",
            "| ---: | ---: | ---: | ---: |",
            *[
                f"| {c['copies']} | {c['wall_s']:.1f} | {c['max_rss_MB']:.0f} | "
                f"{c['tree_pss_MB']:.0f} |"
                for c in copies
            ],
            "",
        ]
    whole = stages["fit_logs (whole, 1 job)"]
    lines += [
        f"Where the time goes: cProfile of `fit_logs` with 1 job over the {profiled} corpus",
        "(cumulative seconds; profiling adds some overhead):",
        "",
        "| stage | s | share of fit_logs |",
        "| --- | ---: | ---: |",
        *[
            f"| {name.strip()} | {value:.2f} | "
            + (f"{100 * value / whole:.0f}% |" if "import" not in name else "(before) |")
            for name, value in stages.items()
        ],
        "",
    ]
    DOC.write_text(_with_notes("\n".join(lines)))
    (CORPUS_ROOT / "last-bench.json").write_text(
        json.dumps(
            {
                "machine": info,
                "rows": rows,
                "fixed_MB": fixed.max_rss_MB,
                "stages": stages,
                "copies": copies,
            },
            indent=2,
        )
    )
    print(f"bench: wrote {DOC}")


def _with_notes(table: str) -> str:
    """The measured part, then the hand-written part of the page kept from the existing file."""
    marker = "<!-- hand-written below: kept by make bench -->"
    notes = ""
    if DOC.is_file() and marker in DOC.read_text():
        notes = DOC.read_text().split(marker, 1)[1]
    return f"{table}\n{marker}{notes}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="alternating repeats (median)")
    parser.add_argument("--corpus", default="small,full", help="corpora to run: small,full")
    parser.add_argument("--generate-only", action="store_true")
    args = parser.parse_args()
    CORPUS_ROOT.mkdir(exist_ok=True)
    names = [n.strip() for n in args.corpus.split(",") if n.strip()]
    need_GB = 1.6 * sum(1 if n == "full" else 0.4 for n in names)
    free_GB = shutil.disk_usage(CORPUS_ROOT).free / 1e9
    if free_GB < need_GB:
        raise SystemExit(f"bench: {free_GB:.1f} GB free, about {need_GB:.1f} GB needed")
    folders = [generate(name) for name in names]
    if args.generate_only:
        return
    info = machine()
    fixed = fixed_overhead()
    rows = [bench_corpus(folder, args.repeats) for folder in folders]
    stages = profile_stages(folders[0])
    copies = memory_vs_files(folders[-1])
    info["load average at end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    write_doc(info, rows, fixed, stages, folders[0].name, copies)


if __name__ == "__main__":
    main()
