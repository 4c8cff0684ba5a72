"""How far below today's `fit` a drive fit of a folder could go: the CPU of the least a
windowed drive fit must do to each sample, beside the bare parse and wbpower's own.

    python benchmarks/drive_floor.py FOLDER [--repeats 3]

In one process, one file at a time, the median over `--repeats` of the CPU time of:

- the bare parse (measure.BARE_PARSE: pyarrow's threaded reader, every column);
- wbpower's parse (pyarrow's serial reader of the columns a fit reads, as io/transport.py;
  the threaded reader can drop a file's last blocks: docs/benchmarks.md);
- the floor of the per-sample work: those columns as numpy arrays, each sample's 0.5 s
  window (time // 0.5 s) and, per window, the sums a least squares of power on the drive
  model's kind of columns needs (1, |v|, v^2, a.v, |yaw rate|, and the power itself at 3
  whole-bin lags: 8 `np.bincount`s with weights), plus the successive differences a noise
  estimate reads; no lag interpolation, no motion detection, no checks of the time stamps;
- `wbpower fit FOLDER --json --jobs 1` (the whole command, in a child process).

It prints each, the ratios to the bare parse, and what the floor leaves to the rest of a
fit under issue 25's bound (1.5x the bare parse, CPU). Quoted in docs/benchmarks.md.

    python benchmarks/drive_floor.py FOLDER --wall [--repeats 3]

The bound read by elapsed time instead ("fit ... runs within 1.5x a bare pyarrow parse"):
each a fresh process, alternating, medians of wall and CPU: the bare parse (threaded, one
process), the floor above with wbpower's parse spread over `--workers` forked processes
(2: as `fit --jobs 0` on 2 cores; files dealt largest first to the least loaded, as the
pipeline does), and `wbpower fit FOLDER --json --jobs 0`. On a machine of few cores the
threaded parse of many small files leaves part of them idle, which a fit's worker processes
need not: the floor by wall can be below the floor by CPU.
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

sys.path.insert(0, str(Path(__file__).resolve().parent))
from measure import BARE_PARSE, load_average, measure  # noqa: E402

from wifibot_power.drive.stats import _median  # noqa: E402

WINDOW_S = 0.5
COLUMNS = ["time_s", "power_W", "speed_mps", "yaw_rate_radps"]


def _logs(folder: Path) -> list[tuple[Path, int]]:
    """Each log of `folder` and the lines before its header (`#` metadata)."""
    logs = []
    for path in sorted(folder.iterdir()):
        if path.suffix != ".csv" or path.name == "runs.csv":
            continue
        with open(path, "rb") as f:
            skip = 0
            while f.readline().startswith(b"#"):
                skip += 1
        logs.append((path, skip))
    return logs


def _serial_parse(path: Path, skip: int) -> pa.Table:
    return pacsv.read_csv(
        path,
        read_options=pacsv.ReadOptions(skip_rows=skip, use_threads=False),
        convert_options=pacsv.ConvertOptions(
            column_types=dict.fromkeys(COLUMNS, pa.float64()), include_columns=COLUMNS
        ),
    )


def _floor(table: pa.Table) -> float:
    """The per-window sums of the floor (module docstring); returns a checksum."""
    t, p, v, w = (table[c].to_numpy() for c in COLUMNS)
    # t - t[0] >= 0, so truncation is the floor; dividing by 0.5 s and multiplying by its
    # inverse are both exact (a power of 2): the windows of `// WINDOW_S`, ~6x cheaper
    window = ((t - t[0]) * (1.0 / WINDOW_S)).astype(np.intp)
    n = int(window[-1]) + 1
    speed = np.abs(v)
    accel = np.diff(v, prepend=v[0]) / np.diff(t, prepend=t[0] - 1.0)
    total = 0.0
    for weights in (None, speed, v * v, np.maximum(accel * v, 0.0), np.abs(w)):
        total += float(np.bincount(window, weights, minlength=n).sum())
    for lag in (0, 1, 2):  # the power a whole bin (here a sample) later
        total += float(np.bincount(window[: p.size - lag], p[lag:], minlength=n).sum())
    # a noise estimate's differences and their median, as drive/stats.py takes it (by counting)
    total += _median(np.abs(np.diff(v)))
    return total


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _child_cpu(argv: list[str]) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(argv, check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _floor_workers(folder: Path, workers: int) -> None:
    """The floor of every log of `folder` over `workers` forked processes (`--wall`)."""
    import multiprocessing

    logs = sorted(_logs(folder), key=lambda log: -log[0].stat().st_size)
    shares: list[list[tuple[Path, int]]] = [[] for _ in range(workers)]
    loads = [0] * workers
    for log in logs:  # largest first to the least loaded
        k = loads.index(min(loads))
        shares[k].append(log)
        loads[k] += log[0].stat().st_size
    with multiprocessing.get_context("fork").Pool(workers) as pool:
        pool.map(_floor_share, shares)


def _floor_share(share: list[tuple[Path, int]]) -> float:
    return sum(_floor(_serial_parse(path, skip)) for path, skip in share)


def _wall(args: argparse.Namespace) -> int:
    """The bound by elapsed time (module docstring)."""
    me = [sys.executable, str(Path(__file__).resolve())]
    argvs = {
        "bare": [sys.executable, "-c", BARE_PARSE, str(args.folder)],
        "floor": [*me, str(args.folder), "--floor-child", str(args.workers)],
        "fit": [args.wbpower, "fit", str(args.folder), "--json", "--jobs", "0"],
    }
    start_load = load_average()
    runs: dict[str, list] = {name: [] for name in argvs}
    for k in range(args.repeats):
        names = list(argvs)
        names = names[k % 3 :] + names[: k % 3]  # the order rotates each repeat
        for name in names:
            # fit exits 1 when a log is skipped; a crash of the others (a traceback: 1) is not
            # a run to time
            ok = (0, 1) if name == "fit" else (0,)
            runs[name].append(measure(argvs[name], ok_codes=ok))
    med = {
        name: (statistics.median(m.wall_s for m in ms), statistics.median(m.cpu_s for m in ms))
        for name, ms in runs.items()
    }
    bare_wall, bare_cpu = med["bare"]
    print(
        f"{args.folder}: {len(_logs(args.folder))} logs, medians of {args.repeats} fresh "
        f"processes; load {start_load} -> {load_average()}"
    )
    print("| what | wall [s] | CPU [s] | / bare parse, wall | / bare parse, CPU |")
    print("|---|---:|---:|---:|---:|")
    rows = [
        ("bare parse (threaded, every column, one process)", "bare"),
        (f"wbpower's parse + the floor, {args.workers} processes", "floor"),
        ("`wbpower fit --json --jobs 0`", "fit"),
    ]
    for label, name in rows:
        wall, cpu = med[name]
        ratios = f"{wall / bare_wall:.2f}x | {cpu / bare_cpu:.2f}x"
        print(f"| {label} | {wall:.2f} | {cpu:.2f} | {ratios} |")
    print(
        f"\nUnder 1.5x the bare parse by wall ({1.5 * bare_wall:.2f} s), the floor leaves "
        f"{1.5 * bare_wall - med['floor'][0]:.2f} s of wall for everything else a fit does; "
        f"today the fit takes {med['fit'][0] - med['floor'][0]:.2f} s more than the floor."
    )
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--wbpower", default=str(Path(sys.executable).parent / "wbpower"))
    parser.add_argument("--wall", action="store_true", help="the bound by elapsed time")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--floor-child", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.floor_child:
        _floor_workers(args.folder, args.floor_child)
        return 0
    if args.wall:
        return _wall(args)
    logs = _logs(args.folder)
    times: dict[str, list[float]] = {"bare": [], "serial": [], "floor": [], "start": [], "fit": []}
    for _ in range(args.repeats):
        times["start"].append(_child_cpu([args.wbpower, "fit", "--help"]))
        times["bare"].append(_child_cpu([sys.executable, "-c", BARE_PARSE, str(args.folder)]))
        start = _cpu()
        for path, skip in logs:
            _serial_parse(path, skip)
        times["serial"].append(_cpu() - start)
        start = _cpu()
        for path, skip in logs:
            _floor(_serial_parse(path, skip))
        times["floor"].append(_cpu() - start)
        fit = [args.wbpower, "fit", str(args.folder), "--json", "--jobs", "1"]
        times["fit"].append(_child_cpu(fit))
    med = {k: statistics.median(v) for k, v in times.items()}
    bare = med["bare"]
    print(f"{args.folder}: {len(logs)} logs, CPU medians of {args.repeats} [s]")
    print("| what | CPU [s] | / bare parse |")
    print("|---|---:|---:|")
    rows = [
        ("bare parse (threaded, every column)", med["bare"]),
        ("wbpower's parse (serial, the fit's columns)", med["serial"]),
        ("that parse + the floor of per-sample work", med["floor"]),
        ("`wbpower fit --help` (start-up: Python and the CLI; numpy, pyarrow later)", med["start"]),
        ("`wbpower fit --json --jobs 1`", med["fit"]),
    ]
    for name, cpu in rows:
        print(f"| {name} | {cpu:.2f} | {cpu / bare:.2f}x |")
    left = 1.5 * bare - med["floor"] - med["start"]
    rest = med["fit"] - med["floor"] - med["start"]
    print(
        f"\nUnder 1.5x the bare parse ({1.5 * bare:.2f} s CPU), the floor and the start-up leave "
        f"{left:.2f} s for everything else a fit does (checks, segmentation, the lag search, "
        f"the fit, the held-out folds, the JSON); today that is {rest:.2f} s."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
