"""Read compressed logs again and again, in fresh interpreters with forked workers and busy
threads (as an xdist worker that has run hundreds of tests does), and count native crashes.

Why (issue 29): an xdist worker died twice with a segmentation fault while a test read a
`.gz` through `pa.PythonFile` (a Python file object pyarrow's readahead thread called back
into), then four clean runs; unexplained. The reader has since stopped handing pyarrow any
Python file object (`io/transport.py`, `_Pieces`: compressed logs are read in 1 MiB pieces
of whole lines that pyarrow parses from buffers; `tests/test_no_python_file.py` keeps it
so). This harness is the stress test that would catch a crash on that path: every round is
a fresh `python` that reads every `.gz`/`.zst` log of a folder with `read_log` in forked
workers (`parallel.map_ordered`), while a thread of the parent keeps allocating (garbage
collection and the allocator busy, as in a long test session), and checks each run's sample
count and power digest against a reference made once in a process that never forks. A
round that ends with a signal (segfault: -11, abort: -6) or a differing run is counted.

`--path python-file` reads through the suspect path instead (`pa.PythonFile(gzip.open(..))`
given to pyarrow's threaded CSV reader), to see whether that path crashes under the same
load: it is what the harness compares against, not what wbpower does.

Usage: `.venv/bin/python benchmarks/stress_gz.py FOLDER [--rounds N] [--jobs J]
[--path reader|python-file]` (FOLDER: e.g. `sample_logs`, whose logs are .csv.gz).
Not part of `make test`.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

ROUND = r"""
import gc, gzip, hashlib, json, sys, threading
from pathlib import Path
import numpy as np
import pyarrow as pa, pyarrow.csv as pacsv
from wifibot_power.io import read_log
from wifibot_power.parallel import map_ordered

files, reference, jobs, path_kind = json.loads(sys.argv[1])

def digest(power_W):
    return hashlib.sha256(np.ascontiguousarray(power_W).tobytes()).hexdigest()

def read(file):
    if path_kind == "python-file":  # the suspect path: pyarrow's threads call into Python
        with gzip.open(file, "rb") as handle:
            table = pacsv.read_csv(
                pa.PythonFile(handle, mode="r"),
                read_options=pacsv.ReadOptions(use_threads=True, block_size=1 << 16),
                parse_options=pacsv.ParseOptions(),
            )
        return table.num_rows, None
    run = read_log(file)
    return int(run.power_W.size), digest(run.power_W)

stop = threading.Event()
def churn():  # the parent busy allocating and collecting while the workers run
    while not stop.is_set():
        junk = [np.ones(1000) for _ in range(200)]
        del junk
        gc.collect()
threading.Thread(target=churn, daemon=True).start()
results = map_ordered(files, read, jobs=jobs) + [read(f) for f in files[:3]]  # + in-process
stop.set()
bad = []
for file, (count, power) in zip(files + files[:3], results):
    want_count, want_power = reference[file]
    if path_kind == "reader" and (count, power) != (want_count, want_power):
        bad.append(file)
print(json.dumps(bad))
"""


def reference(files: list[str]) -> dict[str, tuple[int, str]]:
    """Each log's sample count and power digest, read in this process (never forked)."""
    import numpy as np

    from wifibot_power.io import read_log

    out = {}
    for file in files:
        run = read_log(file)
        digest = hashlib.sha256(np.ascontiguousarray(run.power_W).tobytes()).hexdigest()
        out[file] = (int(run.power_W.size), digest)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--rounds", type=int, default=50)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--path", choices=("reader", "python-file"), default="reader")
    args = parser.parse_args()
    files = sorted(
        str(p) for p in args.folder.rglob("*") if p.name.endswith((".csv.gz", ".csv.zst"))
    )
    if not files:
        raise SystemExit(f"no .csv.gz/.csv.zst logs under {args.folder}")
    ref = reference(files)
    crashes: list[int] = []
    wrong = 0
    started = time.monotonic()
    for k in range(args.rounds):
        done = subprocess.run(
            [sys.executable, "-c", ROUND, json.dumps([files, ref, args.jobs, args.path])],
            capture_output=True,
            text=True,
            cwd=ROOT,
        )
        if done.returncode != 0:
            crashes.append(done.returncode)
            print(f"round {k}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
        elif json.loads(done.stdout.strip().splitlines()[-1]):
            wrong += 1
            print(f"round {k}: differing runs: {done.stdout.strip()}")
    took = time.monotonic() - started
    print(
        json.dumps(
            {
                "path": args.path,
                "rounds": args.rounds,
                "logs_per_round": len(files) + 3,
                "jobs": args.jobs,
                "crashed_rounds": len(crashes),
                "exit_codes": sorted(set(crashes)),
                "rounds_with_differing_runs": wrong,
                "seconds": round(took, 1),
            }
        )
    )
    raise SystemExit(1 if crashes or wrong else 0)


if __name__ == "__main__":
    main()
