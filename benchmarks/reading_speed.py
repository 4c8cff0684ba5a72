"""Reading speed: `read_log` (what `wbpower fit` does per file, bar segmentation) against a bare
`pyarrow.csv.read_csv` of the same files, on one or more corpus folders.

Both run in this process, alternating in every repeat, over files already in the OS page
cache; wall time and CPU time (`time.process_time`: every thread of the process) are
reported as medians, and their ratio. `read_log` here includes the run's fingerprint
(`run_fingerprint`), which a batch computes for every file. The bare parse is the bench's
(benchmarks/run.py): type inference, every column, the '#' lines skipped; a .gz is read by
pyarrow's own decompression, as `read_csv` of its path does. docs/reading-speed.md shows the
figures.

With `--fit`, the second column is `fit_logs(DIR, jobs=1)` (the whole of `wbpower fit` on
one core, bar writing its outputs) less the CPU time spent segmenting (`segment_checked`,
timed around each call): what the reader and the per-run work cost beside the parse.

Usage: `.venv/bin/python benchmarks/reading_speed.py DIR [DIR ...] [--repeats N] [--profile]
[--fit]`
"""

from __future__ import annotations

import argparse
import cProfile
import gzip
import pstats
import statistics
import time
from pathlib import Path

import pyarrow.csv as pacsv

from wifibot_power.io.batch import run_fingerprint
from wifibot_power.io.manifest import read_manifest
from wifibot_power.io.reader import read_log


def _files(folder: Path) -> list[Path]:
    return sorted(
        p for p in folder.iterdir() if p.name != "runs.csv" and p.name.endswith((".csv", ".gz"))
    )


def _skip(path: Path) -> int:
    """Lines before the header: the '#' lines (as benchmarks/run.py skips them), or an N6705
    export's preamble (up to its 'Sample,...' line)."""
    opener = gzip.open if path.name.endswith(".gz") else open
    with opener(path, "rb") as f:
        first = f.readline()
        if first.startswith(b"N6705"):
            for index, line in enumerate(f, start=1):
                if line.startswith(b"Sample"):
                    return index
        skip = 1 if first.startswith(b"#") else 0
        if skip:
            for line in f:
                if not line.startswith(b"#"):
                    break
                skip += 1
    return skip


def bare(files: list[Path], skips: dict[Path, int]) -> int:
    rows = 0
    for path in files:
        table = pacsv.read_csv(path, read_options=pacsv.ReadOptions(skip_rows=skips[path]))
        rows += table.num_rows
    return rows


def ours(files: list[Path], overrides: dict[str, dict[str, str]]) -> int:
    rows = 0
    for path in files:
        run = read_log(path, overrides=overrides.get(path.name))
        run_fingerprint(run)
        rows += run.power_W.size
    return rows


SEGMENT_CPU_S = [0.0]


def fit_less_segmentation(folder: Path) -> int:
    """`fit_logs(folder, jobs=1)`; the CPU time of segmenting is added to SEGMENT_CPU_S."""
    import wifibot_power.fit as fit

    segment = fit.segment_checked

    def timed(*args, **kwargs):
        start = time.process_time()
        try:
            return segment(*args, **kwargs)
        finally:
            SEGMENT_CPU_S[0] += time.process_time() - start

    fit.segment_checked = timed
    try:
        fit.fit_logs(folder, jobs=1)
    finally:
        fit.segment_checked = segment
    return 0


def _timed(work, *args) -> tuple[float, float]:
    wall, cpu = time.perf_counter(), time.process_time()
    work(*args)
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--profile", action="store_true")
    parser.add_argument("--fit", action="store_true", help="fit_logs less segmentation")
    args = parser.parse_args()
    print("| corpus | MB | bare wall s | read wall s | x | bare CPU s | read CPU s | x |")
    print("|---|---|---|---|---|---|---|---|")
    for folder in args.folders:
        files = _files(folder)
        manifest = folder / "runs.csv"
        overrides: dict[str, dict[str, str]] = {}
        if manifest.exists() and any(f.name.endswith(".csv") for f in files):
            for row in read_manifest(manifest):
                overrides[row.file.name] = dict(row.values)
        skips = {p: _skip(p) for p in files}
        size_MB = sum(p.stat().st_size for p in files) / 1e6
        if args.profile:
            profile = cProfile.Profile()
            profile.runcall(ours, files, overrides)
            pstats.Stats(profile).sort_stats("tottime").print_stats(25)
            continue
        work, work_args = (
            (fit_less_segmentation, (folder,)) if args.fit else (ours, (files, overrides))
        )
        bare(files, skips), work(*work_args)  # warm the page cache and the imports
        timings: dict[str, list[tuple[float, float]]] = {"bare": [], "ours": []}
        for _ in range(args.repeats):
            timings["bare"].append(_timed(bare, files, skips))
            SEGMENT_CPU_S[0] = 0.0
            wall_s, cpu_s = _timed(work, *work_args)
            # segmentation ran on this one thread: its CPU time is wall time too
            timings["ours"].append((wall_s - SEGMENT_CPU_S[0], cpu_s - SEGMENT_CPU_S[0]))
        med = {
            k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
            for k, v in timings.items()
        }
        print(
            f"| {folder.name} | {size_MB:.0f} | {med['bare'][0]:.2f} | {med['ours'][0]:.2f} | "
            f"{med['ours'][0] / med['bare'][0]:.2f} | {med['bare'][1]:.2f} | "
            f"{med['ours'][1]:.2f} | {med['ours'][1] / med['bare'][1]:.2f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
