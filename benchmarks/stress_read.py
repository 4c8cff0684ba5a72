"""Read (and segment) every log of a folder again and again in forked workers, as `fit` does,
and catch any read or segmentation that differs from the file's reference.

Why: `wbpower fit bench_corpus/power10k --jobs 0` exited 1 twice in ~330 runs, each time
skipping a log as "the run ends moving" that is never doubted when read again
(docs/benchmarks.md, "An intermittent truncated run?"). `stress_fit.py` compared sample
counts only; this compares every sample: the reference of each log (sample count, a digest
of its power bytes and of each 2^17-sample piece, the segmentation's phases and doubts) is
made once in a process that never forks, and each round runs in a fresh interpreter (as the
CLI does) whose forked workers check every run they read against it. A run that differs is
written down (which pieces differ, its last samples, its doubts) and its samples saved.
(The cause, found by fault injection, not by this harness: pyarrow's threaded CSV reader
dropping a table's last block, docs/benchmarks.md. With `LD_PRELOAD` of a shim such as
tests/test_io_serial_parse.py's in the environment, the shim reaches every round.)

Usage: `.venv/bin/python benchmarks/stress_read.py FOLDER [--minutes M] [--what fit|read]
[--jobs N] [--fits-per-process K] [--no-threads] [--out DIR]`. With `taskset -c 0` the two
workers share one core (CPU contention, as on the busy machine the failures came on); jobs
are then given explicitly, since `--jobs 0` counts the cores the process may use.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: Samples per piece whose digest is kept: where in a run a difference starts.
PIECE = 1 << 17


def fingerprint(power_W) -> dict[str, object]:
    """Sample count, digest of the bytes, digest of each piece of `PIECE` samples."""
    import hashlib
    import zlib

    data = memoryview(power_W).cast("B")
    step = PIECE * 8
    return {
        "samples": int(power_W.size),
        "sha1": hashlib.sha1(data).hexdigest(),
        "pieces": [zlib.crc32(data[k : k + step]) for k in range(0, len(data), step)],
    }


def segmentation_of(found) -> dict[str, object]:
    return {
        "phases": [[p.phase, p.i_start, p.i_end] for p in found.phases],
        "doubts": list(found.doubts),
    }


def reference(folder: Path, path: Path) -> dict[str, dict[str, object]]:
    """Each log's fingerprint and segmentation, read in this process (one job, no fork);
    kept in `path` and read from there when present."""
    if path.exists():
        return json.loads(path.read_text())
    from wifibot_power.errors import WbpowerError
    from wifibot_power.io import read_log
    from wifibot_power.io.discover import find_logs
    from wifibot_power.segment import segment_run

    found = {}
    for source in find_logs([folder])[0]:
        try:
            run = read_log(source.path, overrides=source.overrides, origin=source.origin)
        except WbpowerError:
            continue
        entry = fingerprint(run.power_W)
        try:
            entry.update(segmentation_of(segment_run(run)))
        except WbpowerError as exc:
            entry["error"] = exc.one_line()
        found[source.path.name] = entry
    path.write_text(json.dumps(found))
    return found


#: One round, in a fresh interpreter: argv = reference, report, folder, what, jobs, fits, threads.
CHILD = r"""
import json, os, sys, time
import numpy as np
sys.path.insert(0, os.path.join(os.environ["STRESS_ROOT"], "benchmarks"))
from stress_read import fingerprint, segmentation_of

ref_path, report, folder, what, jobs, fits, threads, saves = sys.argv[1:9]
expected = json.load(open(ref_path))
jobs, fits, saves = int(jobs), int(fits), int(saves)
if threads == "0":
    import wifibot_power.io.transport as transport
    original_options = transport._csv_options

    def _csv_options(*args, **kwargs):
        options = original_options(*args, **kwargs)
        options["read_options"].use_threads = False
        return options

    transport._csv_options = _csv_options


def note(run, what_differs, got):
    name = os.path.basename(str(run.file))
    want = expected[name]
    entry = {"time": time.strftime("%H:%M:%S"), "pid": os.getpid(), "file": name,
             "differs": what_differs, "samples": run.samples, "expected": want["samples"],
             "last_W": run.power_W[-5:].tolist(), **got}
    if "pieces" in got:
        entry["pieces_differing"] = [
            k for k in range(max(len(got["pieces"]), len(want["pieces"])))
            if k >= len(got["pieces"]) or k >= len(want["pieces"])
            or got["pieces"][k] != want["pieces"][k]
        ]
        del entry["pieces"]
    with open(report, "a") as f:
        f.write(json.dumps(entry) + "\n")
    if saves > 0:
        np.save(f"{report}.{os.getpid()}.{name}.npy", run.power_W)


def check_read(run):
    got = fingerprint(run.power_W)
    want = expected.get(os.path.basename(str(run.file)))
    if want is not None and (got["samples"], got["sha1"]) != (want["samples"], want["sha1"]):
        note(run, "samples", got)


import wifibot_power.segment as segment
original_segment = segment.segment_run


def checking_segmenter(run):
    check_read(run)
    found = original_segment(run)
    got = segmentation_of(found)
    want = expected.get(os.path.basename(str(run.file)))
    wanted = [want.get(k) for k in ("phases", "doubts")] if want is not None else None
    if wanted is not None and [got["phases"], got["doubts"]] != wanted:
        note(run, "segmentation", got)
    return found


from wifibot_power.fit import fit_logs

for _ in range(fits):
    if what == "fit":
        fit_logs([folder], jobs=jobs, segmenter=checking_segmenter)
    else:  # read only: the same reading as fit's workers, no segmentation
        from wifibot_power.io.batch import map_runs
        from wifibot_power.io.options import ReadOptions
        map_runs([folder], ReadOptions(), check_read, jobs=jobs)
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--what", choices=("fit", "read"), default="fit")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--fits-per-process", type=int, default=1)
    parser.add_argument("--no-threads", action="store_true", help="pyarrow use_threads=False")
    parser.add_argument("--out", type=Path, default=Path("/tmp/stress_read"))
    parser.add_argument("--saves", type=int, default=1, help="save samples of differing runs")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    ref = reference(args.folder, args.out / "reference.json")
    report = args.out / f"report-{os.getpid()}.jsonl"
    env = {**os.environ, "STRESS_ROOT": str(ROOT)}
    deadline = time.monotonic() + 60 * args.minutes
    rounds = failed_rounds = 0
    reads = 0
    while time.monotonic() < deadline:
        before = len(report.read_text().splitlines()) if report.exists() else 0
        done = subprocess.run(
            [
                sys.executable, "-c", CHILD, str(args.out / "reference.json"), str(report),
                str(args.folder), args.what, str(args.jobs), str(args.fits_per_process),
                "0" if args.no_threads else "1", str(args.saves),
            ],
            capture_output=True, text=True, cwd=ROOT, env=env,
        )  # fmt: skip
        rounds += 1
        reads += len(ref) * args.fits_per_process
        after = len(report.read_text().splitlines()) if report.exists() else 0
        if done.returncode != 0 or after > before:
            failed_rounds += 1
            print(
                f"round {rounds}: exit {done.returncode}, {after - before} finding(s)", flush=True
            )
            for line in done.stderr.splitlines()[-5:]:
                print(f"  stderr: {line}", flush=True)
    findings = len(report.read_text().splitlines()) if report.exists() else 0
    summary = {
        "what": args.what, "jobs": args.jobs, "threads": not args.no_threads,
        "pool": os.environ.get("ARROW_DEFAULT_MEMORY_POOL", "jemalloc"),
        "affinity": sorted(os.sched_getaffinity(0)), "rounds": rounds,
        "fits_per_process": args.fits_per_process, "file_reads": reads,
        "findings": findings, "rounds_failed": failed_rounds, "report": str(report),
    }  # fmt: skip
    print(json.dumps(summary), flush=True)
    return 1 if failed_rounds else 0


if __name__ == "__main__":
    raise SystemExit(main())
