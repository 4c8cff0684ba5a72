"""What a user of the CLI gets on the real free-driving logs: `wbpower fit FOLDER --json`'s
held-out accuracy (`drive.heldout`) on each converted set and each of its surface folders, as
they are on disk (each log cut into trips at its stops by the drive model itself).

docs/drive-model.md ("What a user of the CLI gets") quotes the table this prints. Since the
thirteenth session benchmarks/validate_drive_real.py reads and cuts the logs as `fit` does, so
its drive-model rows are these numbers (its MAPE and median leave out trips of net energy
<= 0, which `fit` counts by their |measured|: the unicycles' rows differ so). The sets
are read from `$WBPOWER_REAL_DRIVE` (default /work/real_drive; docs/real-logs.md, "Free
driving", says how to convert them); a set without folders per surface gets one row.

    .venv/bin/python benchmarks/validate_drive_cli.py [SET ...]   # default: borealtc vulpi
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REAL_DRIVE = Path(os.environ.get("WBPOWER_REAL_DRIVE", "/work/real_drive"))


def row(folder: Path) -> str:
    """The table row of `wbpower fit FOLDER --json` (its drive model's held-out accuracy)."""
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", "fit", str(folder), "--json"],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    name = folder.relative_to(REAL_DRIVE)
    try:
        held = json.loads(done.stdout)["drive"]["heldout"]
    except (json.JSONDecodeError, KeyError, TypeError):
        held = None
    if not held:
        return f"| {name} | - | no held-out accuracy |"
    return (
        f"| {name} | {len(held['runs'])} | {held['mape_pct']:.1f} / "
        f"{held['median_ape_pct']:.1f} ({held['coverage_pi90_pct']:.0f}%) |"
    )


def main(argv: list[str]) -> int:
    sets = argv or ["borealtc", "vulpi"]
    print("| folder | held-out trips | drive model |")
    print("|---|---:|---|")
    for name in sets:
        top = REAL_DRIVE / name
        if not top.is_dir():
            print(f"| {name} | - | not converted (docs/real-logs.md) |")
            continue
        print(row(top))
        for folder in sorted(p for p in top.iterdir() if p.is_dir()):
            print(row(folder))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
