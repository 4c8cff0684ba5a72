"""Run `wbpower fit FOLDER --json --jobs 0` again and again and catch a run read short.

Why: in the seventh session `fit` of the power10k bench corpus exited 1 twice in ~225 runs,
each time skipping one log as "the run ends moving" that is never doubted when read again
(docs/benchmarks.md, "An intermittent truncated run?"). This script is the check for it: each
command runs in a fresh process as the CLI does, with the segmenter wrapped in every forked
worker so that a run whose sample count differs from the file's (read once here, first), or
that is doubted as ending moving, is written down with its pid, sample count and last
samples; the command's exit code and stderr are kept for any run that does not exit 0.

Usage: `.venv/bin/python benchmarks/stress_fit.py FOLDER [--runs N] [--out FILE]`
(default 50 runs; the findings go to stdout and, line by line, to FILE).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: The CLI's `fit`, with each worker's run checked (run in a fresh interpreter per command).
CHILD = r"""
import json, os, sys
expected = json.load(open(sys.argv[1]))
report = sys.argv[2]
import wifibot_power.segment as segment

original = segment.segment_run


def segment_run(run, *args, **kwargs):
    name = os.path.basename(str(run.file))
    want = expected.get(name)
    found = original(run, *args, **kwargs)
    ends_moving = [d for d in found.doubts if "ends moving" in d]
    if (want is not None and run.samples != want) or ends_moving:
        with open(report, "a") as f:
            f.write(json.dumps({
                "pid": os.getpid(), "file": name, "samples": run.samples, "expected": want,
                "last_W": run.power_W[-5:].tolist(), "doubts": ends_moving,
            }) + "\n")
    return found


segment.segment_run = segment_run  # the fit's default segmenter is looked up at call time
sys.argv = ["wbpower", "fit", sys.argv[3], "--json", "--jobs", "0"]
from wifibot_power.cli import main

main()
"""


def expected_samples(folder: Path) -> dict[str, int]:
    """Each readable log's sample count, read once in this process (one job, no fork)."""
    from wifibot_power.errors import WbpowerError
    from wifibot_power.io import read_log
    from wifibot_power.io.discover import find_logs

    counts = {}
    for source in find_logs([folder])[0]:
        try:
            counts[source.path.name] = read_log(source.path).samples
        except WbpowerError:
            pass  # the fit skips it too
    return counts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--runs", type=int, default=50)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        counts = Path(tmp) / "expected.json"
        counts.write_text(json.dumps(expected_samples(args.folder)))
        report = Path(tmp) / "report.jsonl"
        failed = 0
        for k in range(args.runs):
            done = subprocess.run(
                [sys.executable, "-c", CHILD, str(counts), str(report), str(args.folder)],
                capture_output=True,
                text=True,
                cwd=ROOT,
            )
            findings = report.read_text().splitlines() if report.exists() else []
            report.unlink(missing_ok=True)
            if done.returncode != 0 or findings:
                failed += 1
                lines = [f"run {k + 1}: exit {done.returncode}", *findings]
                lines += [f"  stderr: {line}" for line in done.stderr.splitlines()[:5]]
                for line in lines:
                    print(line, flush=True)
                if args.out is not None:
                    with args.out.open("a") as f:
                        f.write("\n".join(lines) + "\n")
        print(f"{failed} of {args.runs} runs with a finding or a non-zero exit")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
