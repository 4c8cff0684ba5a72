"""Every answer of `fit`, `diagnose` and `segment --json`, written to a folder, so that a
restructure can be proven to change none of them (issue "One pipeline": byte for byte).

Sets: sample_logs/; a field-realism simulated set with every catalogue effect (seed 7, a small
grid at 1 kHz); the real logs in ../shared/real_logs (the N6705C export, REGBOT, F1/10) where
present. Each command's stdout, stderr and exit code go to one file per call.

    .venv/bin/python benchmarks/golden.py OUT_DIR          # then: diff -r OLD_DIR NEW_DIR

Run it on the code before and after a change (a git worktree of the old commit with its own
venv, or the same venv: it calls `python -m wifibot_power` from the checkout it lives in).
About 2-3 minutes on 2 idle cores.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from wifibot_power.simulate import EFFECTS as _SIM_EFFECTS  # noqa: E402

SHARED = Path(os.environ.get("WBPOWER_REAL_LOGS", ROOT.parent / "shared" / "real_logs")).resolve()
#: every catalogue effect, as the simulator lists them (the order makes the field set)
EFFECTS = tuple(_SIM_EFFECTS)


def wbpower(out: Path, name: str, *args: str) -> None:
    """Run `python -m wifibot_power ARGS` from ROOT, its output to OUT/NAME.txt."""
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=str(ROOT))
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", *args],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    text = (
        f"$ wbpower {' '.join(args)}\nexit {done.returncode}\n"
        f"--- stdout\n{done.stdout}--- stderr\n{done.stderr}"
    )
    # the checkout's and the output folder's paths differ between the two trees compared
    for path, label in ((out, "<OUT>"), (SHARED, "<SHARED>"), (ROOT, "<ROOT>")):
        text = text.replace(str(path), label)
    (out / f"{name}.txt").write_text(text)


def field_set(work: Path) -> Path:
    """The simulated field-realism set with every catalogue effect (made once per OUT)."""
    logs = work / "field_logs"
    if not logs.exists():
        effects = [arg for e in EFFECTS for arg in ("--effect", e)]
        subprocess.run(
            [
                sys.executable,
                "-m",
                "wifibot_power",
                "simulate",
                "-o",
                str(logs),
                "--seed",
                "7",
                "--realism",
                "field",
                "--sample-period",
                "0.001",
                "--speeds",
                "0.2,0.5,0.8",
                "--repeats",
                "2",
                "--compress",
                "gz",
                *effects,
            ],
            cwd=ROOT,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
            check=True,
            capture_output=True,
        )
    return logs


def main(out: Path) -> None:
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    work = out / "_work"
    work.mkdir(exist_ok=True)
    sets: dict[str, list[Path]] = {
        "sample": [ROOT / "sample_logs"],
        "field": [field_set(work)],
    }
    if SHARED.is_dir():
        sets["regbot_ic"] = [SHARED / "regbot" / "regbot_initial_current"]
        sets["regbot_vs"] = [SHARED / "regbot" / "regbot_rev2b_vel_step"]
        sets["f1tenth"] = [SHARED / "f1tenth"]
    for name, paths in sets.items():
        folders = [str(p) for p in paths]
        wbpower(out, f"{name}.fit", "fit", *folders, "--json", "--jobs", "2")
        keep = ("--json", "--jobs", "2", "--keep-doubtful")
        wbpower(out, f"{name}.fit_keep", "fit", *folders, *keep)
        wbpower(out, f"{name}.diagnose", "diagnose", *folders, "--json", "--jobs", "2")
        files = sorted(f for p in paths for f in p.rglob("*.csv*"))
        for f in files:
            wbpower(out, f"{name}.segment.{f.name}", "segment", str(f), "--json")
    if SHARED.is_dir():
        n6705 = str(SHARED / "n6705c_dlog1.csv")
        wbpower(out, "n6705.segment", "segment", n6705, "--json", "--supply-voltage", "12.6")
        wbpower(out, "n6705.fit", "fit", n6705, "--json", "--supply-voltage", "12.6")
        wbpower(out, "n6705.inspect", "inspect", n6705, "--json", "--supply-voltage", "12.6")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: golden.py OUT_DIR")
    main(Path(sys.argv[1]))
