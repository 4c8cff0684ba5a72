"""How `make bench` times a command: wall, CPU of all its processes, peak memory.

Each command runs in a fresh process under a small wrapper, so `getrusage(RUSAGE_CHILDREN)`
covers it and everything it waited for (the workers of `--jobs 0` included), while a thread
samples the summed PSS of its process tree every 50 ms.
"""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: A bare parse of every log of a folder: pyarrow's multi-threaded `read_csv` of each file
#: (a `.gz` decompressed by pyarrow as it reads), after the lines any reader must skip: the
#: `#` metadata of a canonical log, the preamble of an N6705 export (up to its `Sample,` header).
BARE_PARSE = r"""
import gzip, sys, pyarrow.csv as pacsv
from pathlib import Path
def preamble_lines(path):
    with (gzip.open if path.name.endswith(".gz") else open)(path, "rb") as f:
        first = f.readline()
        if first.startswith(b"N6705"):
            skip = 1
            for line in f:
                if line.startswith(b"Sample"):
                    return skip
                skip += 1
        skip = 0
        line = first
        while line.startswith(b"#"):
            skip += 1
            line = f.readline()
        return skip
largest = rows = 0
for path in sorted(Path(sys.argv[1]).iterdir()):
    if path.name == "runs.csv" or not path.name.endswith((".csv", ".csv.gz")):
        continue
    options = pacsv.ReadOptions(skip_rows=preamble_lines(path))
    table = pacsv.read_csv(path, read_options=options)
    largest = max(largest, table.nbytes)
    rows += table.num_rows
print(largest, rows)
"""


@dataclass
class Measured:
    """One command run: wall time, CPU of all its processes, largest RSS, peak tree PSS."""

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


WRAPPER = (
    "import resource, subprocess, sys\n"
    "p = subprocess.run(sys.argv[1:], stdout=subprocess.PIPE)\n"
    "sys.stdout.buffer.write(p.stdout)\n"
    "use = resource.getrusage(resource.RUSAGE_CHILDREN)\n"
    "cpu = use.ru_utime + use.ru_stime\n"
    "sys.stderr.write('MAXRSS_KB %d CPU_S %.3f\\n' % (use.ru_maxrss, cpu))\n"
    "sys.exit(p.returncode)\n"
)


def measure(argv: list[str], *, ok_codes: tuple[int, ...] = (0,)) -> Measured:
    """Run `argv` through a fresh wrapper so getrusage(RUSAGE_CHILDREN) covers only it."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", WRAPPER, *argv],
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
    if proc.returncode not in ok_codes:
        raise SystemExit(
            f"bench: {' '.join(map(str, argv))} failed (exit {proc.returncode}):\n{text[-2000:]}"
        )
    max_rss_kB = int(text.rsplit("MAXRSS_KB", 1)[1].split()[0])
    cpu_s = float(text.rsplit("CPU_S", 1)[1].split()[0])
    return Measured(wall_s, max_rss_kB / 1024, peak[0] / 1024, cpu_s, out.decode())


def load_average() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def machine() -> dict[str, str]:
    """What the figures were measured on."""
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

    def git(*args: str) -> str:
        return subprocess.run(["git", *args], capture_output=True, text=True, cwd=ROOT).stdout

    head = git("rev-parse", "--short", "HEAD").strip() or "unknown"
    package = git("log", "-1", "--format=%h", "--", "wifibot_power").strip() or "unknown"
    dirty = git("status", "--porcelain", "--untracked-files=no", "--", "wifibot_power").strip()
    code = f"wifibot_power/ as of {package} (HEAD {head})"
    return {
        "code measured": code + (" + uncommitted changes" if dirty else ""),
        "cpu": cpu,
        "cores (nproc)": str(len(os.sched_getaffinity(0))),
        "memory": f"{mem_kB / 1024**2:.1f} GiB",
        "os": f"{platform.system()} {platform.release()}",
        "python": platform.python_version(),
        "pyarrow": pyarrow.__version__,
        "numpy": numpy.__version__,
        "load average at start": load_average(),
    }
