#!/usr/bin/env python3
"""Convert the VESC Tool ride log shipped with lachlanhurst/esc-log-video to wbpower CSV.

Source: https://github.com/lachlanhurst/esc-log-video (MIT), file public/2023-01-08_17-32-11.csv,
last changed in commit ce98cdd4be8c9258a0723339a73387b7fcd64659 (identical at HEAD b8f1b78).
A VESC Tool mobile-app CSV log (';'-separated, one row per ~82 ms) of one ride of a
single-VESC personal electric vehicle (the repository does not say which; 12S pack, ~49 V).

Columns used (VESC Tool log format, units per VESC Tool's Log Analysis page):
  ms_today              ms since local midnight      -> time_s = (ms_today - first) / 1000
  input_voltage         V, battery side              -> voltage_V
  current_in            A, battery side (< 0 regen)  -> current_A (power = V x I by wbpower)
  speed_meters_per_sec  m/s, from ERPM and the configured wheel size -> speed_mps
  gyroZ                 deg/s, VESC IMU, z vertical (accZ ~ 0.93 g at rest)
                        -> yaw_rate_radps (radians)
Not documented by the source, so not given: mass_kg, payload_kg, track_m, surface.

Usage: convert.py [SOURCE_CSV]   (default: read it from the fetched git mirror)
"""

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

MIRROR = "/work/.mirror/lachlanhurst+esc-log-video/repo"
COMMIT = "ce98cdd4be8c9258a0723339a73387b7fcd64659"
PATH = "public/2023-01-08_17-32-11.csv"
OUT = (
    Path(os.environ.get("WBPOWER_REAL_DRIVE", "/work/real_drive"))
    / "vesc_esclogvideo"
    / "2023-01-08_17-32-11.csv"
)


def source_text(argv):
    if len(argv) > 1:
        return Path(argv[1]).read_text()
    return subprocess.run(
        ["git", "-C", MIRROR, "show", f"{COMMIT}:{PATH}"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout


def main(argv):
    rows = list(csv.DictReader(source_text(argv).splitlines(), delimiter=";"))
    t0 = float(rows[0]["ms_today"])
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with OUT.open("w", newline="") as f:
        f.write("# wbpower-log: 1\n")
        f.write("# run_id: vesc_2023-01-08_17-32-11\n")
        # no "# mode: motion" line: a speed column alone makes it a motion log (log-format.md)
        f.write("# source_repo: https://github.com/lachlanhurst/esc-log-video\n")
        f.write(f"# source_commit: {COMMIT}\n")
        f.write(f"# source_path: {PATH}\n")
        f.write("# source_licence: MIT (LICENSE of the repository, (c) 2023 Lachlan Hurst)\n")
        f.write(
            "# vehicle: single-VESC personal EV (type, mass, rider not documented by the source)\n"
        )
        f.write("# started_at: 2023-01-08T17:32:11\n")
        w = csv.writer(f)
        w.writerow(["time_s", "voltage_V", "current_A", "speed_mps", "yaw_rate_radps"])
        for r in rows:
            w.writerow(
                [
                    f"{(float(r['ms_today']) - t0) / 1000:.3f}",
                    r["input_voltage"],
                    r["current_in"],
                    r["speed_meters_per_sec"],
                    f"{math.radians(float(r['gyroZ'])):.5f}",
                ]
            )
    print(f"wrote {OUT} ({len(rows)} rows)")


if __name__ == "__main__":
    main(sys.argv)
