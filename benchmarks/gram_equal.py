"""Are `fit --json`'s answers of two commits the same up to the order of floating-point summation?

    python benchmarks/gram_equal.py OLD_REV NEW_REV [--rtol 1e-9] [--work DIR]

Writes each revision's source (`git archive`) under --work, simulates two free-driving sets
(`simulate --drive free --realism field`, seeds 1 and 2) with the new revision, runs
`fit --json` of each revision on sample_logs, the two free-driving sets,
/work/real_drive/borealtc/flooring and ../shared/real_logs/f1tenth (with this interpreter,
the revision's source first on sys.path), and compares the two JSON documents: every string
and every other non-number exactly, every number with `--rtol` (or within an absolute 1e-12:
numbers that should be 0). Prints the largest relative difference per set and where it is,
and exits 1 when a set differs beyond the tolerance (gram.py: the lag searches from sufficient
statistics; main: by least squares over the windows). --extra FOLDER adds a set.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SETS = {
    "sample_logs": ROOT / "sample_logs",
    "borealtc_flooring": Path("/work/real_drive/borealtc/flooring"),
    "f1tenth": (ROOT / ".." / "shared" / "real_logs" / "f1tenth").resolve(),
}
ABS_ZERO = 1e-12


def source(rev: str, work: Path) -> Path:
    out = work / f"src_{rev.replace('/', '_')}"
    if not out.exists():
        out.mkdir(parents=True)
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", rev, "wifibot_power"],
            check=True,
            capture_output=True,
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(out)], input=archive, check=True)
    return out


def wbpower(src: Path, *args: str) -> subprocess.CompletedProcess:
    code = (
        "import sys; sys.path.insert(0, sys.argv.pop(1)); import wifibot_power; "
        "assert wifibot_power.__file__.startswith(sys.path[0]), wifibot_power.__file__; "
        "from wifibot_power.cli import app; sys.argv[0] = 'wbpower'; app()"
    )
    return subprocess.run(
        [sys.executable, "-c", code, str(src), *args], capture_output=True, text=True
    )


def compare(old, new, where: str, worst: list, errors: list, rtol: float) -> None:
    if isinstance(old, bool) or isinstance(new, bool) or old is None or new is None:
        if old != new:
            errors.append(f"{where}: {old!r} != {new!r}")
        return
    if isinstance(old, int | float) and isinstance(new, int | float):
        if math.isnan(old) or math.isnan(new):
            if not (math.isnan(old) and math.isnan(new)):
                errors.append(f"{where}: {old!r} != {new!r}")
            return
        diff = abs(old - new)
        scale = max(abs(old), abs(new))
        relative = diff / scale if scale > 0 else 0.0
        if relative > worst[0][0]:
            worst[0] = (relative, where, old, new)
        if diff > ABS_ZERO and relative > rtol:
            errors.append(f"{where}: {old!r} != {new!r} (relative {relative:.3g})")
        return
    if type(old) is not type(new):
        errors.append(f"{where}: {type(old).__name__} != {type(new).__name__}")
        return
    if isinstance(old, dict):
        if list(old) != list(new):
            errors.append(f"{where}: keys {sorted(set(old) ^ set(new))}")
        for key in old.keys() & new.keys():
            compare(old[key], new[key], f"{where}.{key}", worst, errors, rtol)
    elif isinstance(old, list):
        if len(old) != len(new):
            errors.append(f"{where}: {len(old)} items != {len(new)}")
        for i, (a, b) in enumerate(zip(old, new, strict=False)):
            compare(a, b, f"{where}[{i}]", worst, errors, rtol)
    elif old != new:
        errors.append(f"{where}: {old!r} != {new!r}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--rtol", type=float, default=1e-9)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--extra", type=Path, action="append", default=[], help="another folder")
    args = parser.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="gram_equal_"))
    old_src, new_src = source(args.old, work), source(args.new, work)
    sets = dict(SETS) | {folder.name: folder for folder in args.extra}
    for seed in (1, 2):
        logs = work / f"free_seed{seed}"
        if not logs.exists():
            made = wbpower(
                new_src, "simulate", "-o", str(logs), "--drive", "free", "--realism", "field",
                "--seed", str(seed),
            )  # fmt: skip
            if made.returncode != 0:
                print(made.stderr, file=sys.stderr)
                return 2
        sets[f"free_seed{seed}"] = logs
    failed = False
    for name, logs in sets.items():
        answers = []
        for src in (old_src, new_src):
            done = wbpower(src, "fit", str(logs), "--json", "-j", "1")
            try:
                answers.append(json.loads(done.stdout))
            except json.JSONDecodeError:
                print(f"{name}: no JSON from {src} ({done.stderr.strip()[-300:]})")
                return 2
        worst, errors = [(0.0, "-", None, None)], []
        compare(answers[0], answers[1], name, worst, errors, args.rtol)
        relative, where, old, new = worst[0]
        print(f"{name}: largest relative difference {relative:.3g} at {where} ({old!r} -> {new!r})")
        for line in errors[:20]:
            print(f"  DIFFERS {line}")
        failed |= bool(errors)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
