"""Segmentation speed (ns per sample, before / after) and whether the boundaries moved.

Issue 14's segmentation point: `segment_run` must cost a small share of `fit_logs`, whose
floor is the parse (a bare pyarrow parse of power-only CSV: ~66 ns a sample), without
moving any boundary. This script:

- **records** every answer of `segment_run` (each phase's name, step and sample range, each
  spike, each doubt) on the logs given, with and without the speed column where a log has
  one (`--record FILE`), and **compares** a later run with such a record (`--compare FILE`):
  identical runs are counted, a changed run is listed with how far each boundary moved [ms];
- **times** `segment_run` on the largest runs of the logs given (`--time`), CPU time
  (`time.process_time`), the median of `--repeats` calls, the code of a git revision
  (`--before REV`, loaded as a separate package from `git show`) and the working tree
  interleaved in one process on the same runs in memory, so the load of a shared machine
  hits both alike. Prints ns per sample;
- measures segmentation's **share** of `fit_logs(folder, jobs=1)` (`--share`, with
  `--before REV` the two segmentations alternating), CPU time;
- checks that **every field** of every `Segmentation` (each phase's times, energy, mean
  power and speed, each spike, each doubt; floats by their exact repr) is the one the code
  of `--before REV` gives (`--exact`), with and without the speed column: the record
  above holds boundaries and doubts, this holds every number bit for bit.

Usage:
  python benchmarks/segment_speed.py LOGS... --record base.json
  python benchmarks/segment_speed.py LOGS... --compare base.json
  python benchmarks/segment_speed.py LOGS... --time --before 4e9e4af [--repeats 9]
  python benchmarks/segment_speed.py FOLDER... --share --before 4e9e4af [--repeats 3]
  python benchmarks/segment_speed.py LOGS... --exact --before fcbcdd0

LOGS are files or folders (every *.csv, *.csv.gz, *.csv.zst in them, recursively); the
real N6705C log (../shared/real_logs/n6705c_dlog1.csv) is read at 12.6 V like its test.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

import numpy as np

from wifibot_power.errors import WbpowerError
from wifibot_power.io import ReadOptions, read_log
from wifibot_power.run import Run
from wifibot_power.segment import segment_run

ROOT = Path(__file__).resolve().parent.parent
#: logs read with options other than the defaults (by file name)
OPTIONS = {"n6705c_dlog1.csv": ReadOptions(supply_voltage_V=12.6)}


def log_files(paths: list[str]) -> list[Path]:
    """Every log under the paths given, in name order."""
    found: list[Path] = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            found += [
                p
                for p in sorted(path.rglob("*"))
                if p.name.endswith((".csv", ".csv.gz", ".csv.zst")) and p.name != "runs.csv"
            ]
        else:
            found.append(path)
    return found


def read(path: Path) -> Run:
    return read_log(path, OPTIONS.get(path.name, ReadOptions()))


def answer(run: Run, segment=segment_run) -> dict:
    """What segmentation says of one run, in plain JSON (sample indices, not times)."""
    try:
        seg = segment(run)
    except WbpowerError as exc:
        return {"error": str(exc)}
    return {
        "phases": [[p.phase, p.step, p.i_start, p.i_end] for p in seg.phases],
        "spikes": [
            [round(s.t_start_s, 9), round(s.duration_s, 9), round(s.peak_W, 6)] for s in seg.spikes
        ],
        "doubts": list(seg.doubts),
    }


def answers(files: list[Path]) -> dict[str, dict]:
    """Every answer, keyed by file (and `#no-speed` for the same run without its speed)."""
    out: dict[str, dict] = {}
    for path in files:
        try:
            run = read(path)
        except WbpowerError as exc:
            out[str(path)] = {"error": str(exc)}
            continue
        out[str(path)] = answer(run) | {"period_s": run.sample_period_s}
        if run.speed_mps is not None:
            bare = dataclasses.replace(run, speed_mps=None)
            out[f"{path}#no-speed"] = answer(bare) | {"period_s": run.sample_period_s}
    return out


def compare(old: dict[str, dict], new: dict[str, dict]) -> int:
    """Print how the answers differ; the number of runs whose answer changed."""
    same = changed = 0
    shifts_ms: list[float] = []
    for key in sorted(new.keys() & old.keys()):
        a, b = old[key], new[key]
        if a == b:
            same += 1
            continue
        changed += 1
        print(f"changed: {key}")
        for field in ("error", "doubts", "spikes"):
            if a.get(field) != b.get(field):
                print(f"  {field}: {a.get(field)} -> {b.get(field)}")
        pa, pb = a.get("phases", []), b.get("phases", [])
        if [p[:2] for p in pa] != [p[:2] for p in pb]:
            print(f"  phases: {[p[:2] for p in pa]} -> {[p[:2] for p in pb]}")
        else:
            period_ms = 1e3 * a["period_s"]
            for p, q in zip(pa, pb, strict=True):
                if p[2] != q[2]:
                    shift = (q[2] - p[2]) * period_ms
                    shifts_ms.append(abs(shift))
                    print(f"  {p[0]} {p[1]} starts {shift:+.2f} ms off")
    missing = sorted(new.keys() - old.keys())
    print(f"{same} runs identical, {changed} changed, {len(missing)} not in the record")
    if shifts_ms:
        print(f"boundaries moved: {len(shifts_ms)}, median {np.median(shifts_ms):.2f} ms, ", end="")
        print(f"worst {max(shifts_ms):.2f} ms")
    return changed + len(missing)


def load_before(rev: str, tmp: Path) -> ModuleType:
    """`wifibot_power.segment` at git revision `rev`, as a package of its own (`_before`):
    its segment (a module, or since the split a package), changepoint and phases modules;
    the rest (io, run, errors) shared."""
    package = tmp / "_before"
    package.mkdir()
    (package / "__init__.py").write_text("")
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-tree", "-r", "--name-only", rev, "wifibot_power/"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.split()
    own = ("segment", "changepoint", "phases")
    files = [
        name
        for name in listed
        if name.endswith(".py")
        and (
            name.startswith("wifibot_power/segment/")
            or name in [f"wifibot_power/{o}.py" for o in own]
        )
    ]
    for name in files:
        text = subprocess.run(
            ["git", "-C", str(ROOT), "show", f"{rev}:{name}"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        for module in own:
            text = text.replace(f"wifibot_power.{module} ", f"_before.{module} ")
        text = text.replace("wifibot_power.segment.", "_before.segment.")
        target = package / name.removeprefix("wifibot_power/")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text)
    sys.path.insert(0, str(tmp))
    spec = importlib.util.find_spec("_before.segment")
    assert spec is not None
    return importlib.import_module("_before.segment")


def exact(files: list[Path], rev: str) -> int:
    """Print every run whose `Segmentation` (repr: every float exact) differs from the
    one `rev`'s code gives; the number of such runs."""
    with tempfile.TemporaryDirectory() as tmp:
        before = load_before(rev, Path(tmp))
        same = differ = 0
        for path in files:
            try:
                run = read(path)
            except WbpowerError:
                continue
            variants = [("", run)]
            if run.speed_mps is not None:
                variants.append(("#no-speed", dataclasses.replace(run, speed_mps=None)))
            for tag, each in variants:
                found = []
                for segment in (before.segment_run, segment_run):
                    try:
                        found.append(repr(segment(each)))
                    except WbpowerError as exc:
                        found.append(f"error: {exc}")
                if found[0] == found[1]:
                    same += 1
                else:
                    differ += 1
                    print(f"differs: {path}{tag}")
        print(f"{same} segmentations identical to {rev}'s in every field, {differ} differ")
        return differ


def cpu_ms(call, run: Run) -> float:
    start = time.process_time()
    call(run)
    return 1e3 * (time.process_time() - start)


def timing(files: list[Path], rev: str, repeats: int, largest: int) -> None:
    """Print CPU time per call and per sample of the `before` and current code."""
    runs = []
    for path in files:
        try:
            runs.append(read(path))
        except WbpowerError:
            continue  # a log the reader refuses (listed by --record) is not timed
    runs = sorted(runs, key=lambda r: -r.samples)[:largest]
    with tempfile.TemporaryDirectory() as tmp:
        before = load_before(rev, Path(tmp))
        calls = {"before": before.segment_run, "after": segment_run}
        print(
            f"| run | samples | before {rev} [ms] | after [ms] | before [ns/sample] "
            "| after [ns/sample] |"
        )
        print("| --- | ---: | ---: | ---: | ---: | ---: |")
        totals = {"before": 0.0, "after": 0.0}
        samples = 0
        for run in runs:
            times: dict[str, list[float]] = {"before": [], "after": []}
            for label in calls:  # warm up (tables, imports)
                calls[label](run)
            for k in range(repeats):
                order = ("before", "after") if k % 2 == 0 else ("after", "before")
                for label in order:
                    times[label].append(cpu_ms(calls[label], run))
            med = {label: float(np.median(t)) for label, t in times.items()}
            for label in med:
                totals[label] += med[label]
            samples += run.samples
            ns = {label: 1e6 * med[label] / run.samples for label in med}
            print(
                f"| {Path(run.file).name} | {run.samples:,} | {med['before']:.1f} | "
                f"{med['after']:.1f} | {ns['before']:.1f} | {ns['after']:.1f} |"
            )
        print(
            f"| all {len(runs)} | {samples:,} | {totals['before']:.1f} | {totals['after']:.1f} "
            f"| {1e6 * totals['before'] / samples:.1f} | {1e6 * totals['after'] / samples:.1f} |"
        )


def share(folder: Path, rounds: int, rev: str | None) -> None:
    """Print segmentation's share of `fit_logs(folder, jobs=1)`: CPU time of the whole call
    and of the `segment_run` calls inside it (the segmenter wrapped by a timer), median of
    `rounds` calls per code (after a first call that warms imports and the page cache);
    with `rev`, that revision's segmentation and the working tree's alternate."""
    from wifibot_power.fit import fit_logs

    with tempfile.TemporaryDirectory() as tmp:
        codes = {"after": segment_run}
        if rev:
            codes = {"before": load_before(rev, Path(tmp)).segment_run, **codes}
        spent = [0.0]

        def timed(segment):
            def call(run: Run):
                start = time.process_time()
                try:
                    return segment(run)
                finally:
                    spent[0] += time.process_time() - start

            return call

        totals: dict[str, list[float]] = {label: [] for label in codes}
        segs: dict[str, list[float]] = {label: [] for label in codes}
        fit_logs(folder, jobs=1, keep_doubtful=True)  # warm up
        for _ in range(rounds):
            for label, segment in codes.items():
                spent[0] = 0.0
                start = time.process_time()
                fit_logs(folder, segmenter=timed(segment), jobs=1, keep_doubtful=True)
                totals[label].append(time.process_time() - start)
                segs[label].append(spent[0])
        for label in codes:
            total, seg = float(np.median(totals[label])), float(np.median(segs[label]))
            name = f"{label} ({rev})" if label == "before" else label
            print(
                f"{name}: fit_logs({folder}, jobs=1) {total:.2f} s CPU, segmentation "
                f"{seg:.2f} s ({100 * seg / total:.0f}%), median of {rounds}"
            )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("logs", nargs="+", help="log files or folders")
    parser.add_argument("--record", type=Path, help="write every answer to this JSON file")
    parser.add_argument("--compare", type=Path, help="compare the answers with this record")
    parser.add_argument("--time", action="store_true", help="time before / after")
    parser.add_argument("--before", default="HEAD", help="git revision of the 'before' code")
    parser.add_argument("--repeats", type=int, default=9, help="calls per run and code")
    parser.add_argument("--share", action="store_true", help="share of fit_logs (a folder)")
    parser.add_argument(
        "--exact", action="store_true", help="every field equal to --before's, bit for bit"
    )
    parser.add_argument("--largest", type=int, default=6, help="time the N largest runs")
    args = parser.parse_args(argv)
    files = log_files(args.logs)
    status = 0
    if args.record or args.compare:
        found = answers(files)
        if args.record:
            args.record.write_text(json.dumps(found, indent=0, sort_keys=True))
            print(f"{len(found)} answers written to {args.record}")
        if args.compare:
            status = 1 if compare(json.loads(args.compare.read_text()), found) else 0
    if args.exact:
        status = 1 if exact(files, args.before) else status
    if args.share:
        for folder in args.logs:
            share(Path(folder), args.repeats, args.before if args.before != "HEAD" else None)
    if args.time:
        timing(files, args.before, args.repeats, args.largest)
    return status


if __name__ == "__main__":
    raise SystemExit(main())
