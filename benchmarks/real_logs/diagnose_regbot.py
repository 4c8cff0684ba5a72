"""`wbpower diagnose` on converted REGBOT logs (docs/real-logs.md, "diagnose on them").

The logs carry a speed column but no distance, which wbpower then takes from the speed
column (the path of the motion phases, `runtable.run_row`). This script runs
`wbpower diagnose --json` on a set as converted, with and without `--keep-doubtful`, and,
as a cross-check of that distance, on a copy whose `runs.csv` gives each run the path its
whole log's speed column integrates to (sum of |v| dt); it prints what each says: the error
line, or the runs used, the baseline's held-out MAPE, the names and `unexplained` with its
reasons.

    .venv/bin/python benchmarks/real_logs/diagnose_regbot.py DIR_OF_A_SET [...]

DIR_OF_A_SET: a folder of converted `.csv.gz` logs (`convert_regbot.py --all --out DIR`).
"""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

WBPOWER = Path(sys.executable).with_name("wbpower")


def with_distances(logs: Path, scratch: Path) -> Path:
    """A copy of the set's logs with a runs.csv of each run's integrated distance [m]."""
    out = scratch / logs.name
    out.mkdir()
    rows = []
    for log in sorted(logs.glob("*.csv.gz")):
        shutil.copy(log, out / log.name)
        frame = pd.read_csv(log, comment="#", usecols=["time_s", "speed_mps"])
        t_s, v_mps = frame["time_s"].to_numpy(), frame["speed_mps"].to_numpy()
        rows.append((log.name, float(np.sum(np.abs(v_mps[1:]) * np.diff(t_s)))))
    with (out / "runs.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["file", "distance_m"])
        writer.writerows((name, f"{d_m:.3f}") for name, d_m in rows)
    return out


def diagnose(folder: Path, *extra: str) -> str:
    done = subprocess.run(
        [str(WBPOWER), "diagnose", str(folder), "--json", *extra],
        capture_output=True,
        text=True,
    )
    if done.returncode == 2:
        return "error: " + done.stderr.strip().splitlines()[-1].split("error: ", 1)[-1]
    result = json.loads(done.stdout)
    mape = result["baseline"]["heldout_mape_pct"]  # null (NaN) where nothing is predicted
    lines = [
        f"{result['n_runs']} runs; baseline held-out MAPE "
        f"{'-' if mape is None else f'{mape:.0f}%'}; named "
        f"{[f['cause'] for f in result['findings']] or 'nothing'}; "
        f"unexplained {result['unexplained']}"
    ]
    lines += [f"  - {reason}" for reason in result["unexplained_reasons"]]
    return "\n".join(lines)


def main(argv: list[str]) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        for logs in map(Path, argv):
            folder = with_distances(logs, Path(scratch))
            print(f"## {logs.name} ({len(list(logs.glob('*.csv.gz')))} logs)")
            print("as converted:", diagnose(logs))
            print("as converted, --keep-doubtful:", diagnose(logs, "--keep-doubtful"))
            print("runs.csv distances, --keep-doubtful:", diagnose(folder, "--keep-doubtful"))
            print()


if __name__ == "__main__":
    main(sys.argv[1:])
