"""Convert the public F1/10 (F1TENTH) car log of FrictionMaps into canonical wbpower CSV.

The second robot family of docs/real-logs.md ("A second family: an F1/10 car"): a 1:10
scale Ackermann race car (F1TENTH platform, brushless drive motor behind a VESC motor
controller), teleoperated around a track at 0-3.3 m/s with a few stops and two short
reversals. The log is dataset 5 of AhmadAmine998/FrictionMaps (MIT licence), written by
its `stateLogger.py` ROS 2 node: one CSV per ROS topic, each row stamped with its
message's header time (`s`, `ns`). Dataset 5 is the only one with the VESC's own
measurements (`coreData.csv`, topic /sensors/core, ~18 Hz):

- `cI`: the VESC's average **input** current [A] (battery side), `VI` its input voltage
  [V] (0.1 V steps). Their product is the electrical power the drive train draws from the
  battery: the drive motor and its controller only (the computer and lidar are not behind
  the VESC), so a standing car reads 0 W, as REGBOT does;
- `RPM`: the motor's electrical speed [ERPM], negative when the car drives forward;
- `cM`: the motor (phase) current [A], `DC`: the duty cycle.

`commandData.csv` (topic /ackermann_cmd) holds the commanded speed `V` [m/s] at its own
times.

Each sample of `coreData.csv` becomes one row, with its own time stamp:

- `time_s`: header stamp minus the first core sample's stamp [s] (to the µs);
- `voltage_V`, `current_A`: `VI`, `cI` as logged (power = their product);
- `speed_mps`: -RPM / 7500, the car's speed from its motor's electrical speed. 7500 ERPM
  per m/s (and the sign) is the conversion the car's own odometry used: `odomData.csv`'s
  `vx` is exactly -RPM / 7500 of a core message (vx × 7500 is an integer in every row; the
  RMS difference to -RPM/7500 interpolated at the odometry's stamps is 0.04 m/s, from the
  two topics' different stamps). It is a wheel speed: slip is not seen;
- `motor_current_A`, `duty_cycle`, `erpm`: `cM`, `DC`, `RPM` as logged (not read by
  wbpower);
- `commanded_speed_mps`: the last `V` of `commandData.csv` at or before the row's stamp
  (not read by wbpower; the scoring compares with it).

The logger dropped samples (all topics at once: the logger, not the VESC) in three places
that wbpower's reader refuses ("a gap over 3 sample periods ... cut the log at the gap"):
0.28 s after t = 56.32 s, 1.60 s after t = 56.60 s and 0.25 s after t = 93.22 s (time
from the first core sample). By default the whole log is one file (`ds5`), gaps included,
so that the reader meets them; `--split-at-gaps` cuts it there, as the reader's message
says, into `ds5_a` (0-56.3 s), `ds5_b` (58.2-93.2 s) and `ds5_c` (93.5-116.3 s), each
timed from its own first sample (the one lone sample between the first two gaps is
dropped).

Metadata: `run_id`, `mode: motion`, `steps: 1`, `speed_mps` = the largest commanded speed
magnitude (rounded to 0.01 m/s), and the provenance keys (`source_repo`, `source_commit`,
`source_path`, `source_licence`, `robot`).

Usage (the mirror is a git directory, e.g. from the `fetch` tool; the output goes outside
the tracked tree: data from fetched repositories is never committed):

    python benchmarks/real_logs/convert_f1tenth.py \
        /work/.mirror/AhmadAmine998+FrictionMaps/repo --out DIR/f1tenth_frictionmaps

`locate` finds the converted log for the tests and the scoring script, in this order:
(a) `WBPOWER_REAL_LOGS/f1tenth_frictionmaps/` (when that folder exists); (b)
`../shared/real_logs/f1tenth/` beside the repository; (c) converted on the fly from the
fetched mirror (`FRICTIONMAPS_MIRROR`, default `DEFAULT_MIRROR`) into a cache folder the
caller gives. None: None (`UNAVAILABLE`).
Standard library + numpy only.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from canonical_out import canonical_text, git, write_gzip  # noqa: E402  (a module beside this one)

SET_NAME = "f1tenth_frictionmaps"
REPO = "AhmadAmine998/FrictionMaps"
#: the newest commit of the repository's default branch when fetched (2022-05); dataset 5
#: itself was added in e747eca
COMMIT = "6a1b907d68999067960553bcec18fbf70b30bf4e"
FOLDER = "DataSets/DS5"
LICENCE = "MIT (the repository's LICENSE, Copyright (c) 2022 AhmadAmine998)"
ROBOT = "F1/10 (F1TENTH) 1:10 race car, VESC motor controller"
#: ERPM per m/s of the car's odometry (vx = -RPM / ERPM_PER_MPS, see the docstring)
ERPM_PER_MPS = 7500.0
#: a step between time stamps more than this many median sample spacings longer than the
#: median is a gap the reader refuses (wifibot_power/io/validate.py, MAX_GAP_PERIODS):
#: `--split-at-gaps` cuts the log there, as the reader's message tells a user to
GAP_SPACINGS = 3.0
#: a side of a gap shorter than this is dropped, not written as a run [s] (between the
#: 0.25 s and the 1.6 s gap at t = 56.6 s stands one lone sample)
MIN_PIECE_S = 5.0

#: output columns: (name, printf format: µs, 0.1 V, 10 mA, 0.1 mm/s as logged or finer)
COLUMNS = (
    ("time_s", "%.6f"),
    ("voltage_V", "%.1f"),
    ("current_A", "%.2f"),
    ("speed_mps", "%.5f"),
    ("motor_current_A", "%.2f"),
    ("duty_cycle", "%.3f"),
    ("erpm", "%.0f"),
    ("commanded_speed_mps", "%.4f"),
)


def _table(text: str, source: str, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The named columns of one stateLogger CSV (its first, unnamed column is pandas' index)."""
    header, _, body = text.partition("\n")
    fields = header.strip().split(",")
    missing = [n for n in names if n not in fields]
    if missing:
        raise SystemExit(f"{source}: no column {', '.join(missing)} in the header {fields}")
    data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2)
    if data.shape[1] != len(fields):
        raise SystemExit(f"{source}: {data.shape[1]} fields per row, {len(fields)} named")
    return {n: data[:, fields.index(n)] for n in names}


def _stamp(cols: dict[str, np.ndarray], s0: float) -> np.ndarray:
    # seconds and nanoseconds apart: float64 of the epoch seconds alone keeps the ns
    return (cols["s"] - s0) + cols["ns"] * 1e-9


def parse(core_text: str, command_text: str, source: str) -> dict[str, np.ndarray]:
    """The canonical columns of dataset 5 (core samples, with the command held)."""
    core = _table(core_text, source + "/coreData.csv", ("s", "ns", "cM", "cI", "DC", "RPM", "VI"))
    cmd = _table(command_text, source + "/commandData.csv", ("s", "ns", "V"))
    s0 = core["s"][0]
    t_core = _stamp(core, s0)
    t_cmd = _stamp(cmd, s0)
    if np.any(np.diff(t_core) <= 0) or np.any(np.diff(t_cmd) < 0):
        raise SystemExit(f"{source}: time stamps not increasing")
    t0 = t_core[0]
    last = np.searchsorted(t_cmd, t_core, side="right") - 1  # the command in force
    commanded = np.where(last >= 0, cmd["V"][np.maximum(last, 0)], np.nan)
    return {
        "time_s": t_core - t0,
        "voltage_V": core["VI"],
        "current_A": core["cI"],
        "speed_mps": -core["RPM"] / ERPM_PER_MPS + 0.0,  # + 0.0: no "-0"
        "motor_current_A": core["cM"],
        "duty_cycle": core["DC"],
        "erpm": core["RPM"],
        "commanded_speed_mps": commanded,
    }


def gaps(time_s: np.ndarray) -> np.ndarray:
    """Indices i where the step time_s[i+1] - time_s[i] exceeds the median by GAP_SPACINGS
    medians (the samples missing there span more than GAP_SPACINGS sample periods)."""
    step = np.diff(time_s)
    period = np.median(step)
    return np.flatnonzero(step - period > GAP_SPACINGS * period)


def to_canonical(cols: dict[str, np.ndarray], meta: dict[str, str]) -> str:
    """The canonical wbpower CSV text of (a slice of) the log."""
    top = np.nanmax(np.abs(cols["commanded_speed_mps"]))
    meta = {**meta, "speed_mps": f"{top:.2f}"}
    table = np.column_stack([cols[name] for name, _ in COLUMNS])
    return canonical_text(meta, [n for n, _ in COLUMNS], [f for _, f in COLUMNS], table)


def convert(mirror: Path, out: Path, split_at_gaps: bool = False) -> list[Path]:
    source = f"{REPO}@{COMMIT[:12]}:{FOLDER}"

    def show(name: str) -> str:
        return git(mirror, "show", f"{COMMIT}:{FOLDER}/{name}").decode()

    cols = parse(show("coreData.csv"), show("commandData.csv"), source)
    pieces = {"ds5": slice(None)}
    if split_at_gaps:
        cuts = [0, *(int(i) + 1 for i in gaps(cols["time_s"])), cols["time_s"].size]
        sides = [
            slice(a, b)
            for a, b in zip(cuts[:-1], cuts[1:], strict=True)
            if cols["time_s"][b - 1] - cols["time_s"][a] >= MIN_PIECE_S
        ]
        pieces = {f"ds5_{chr(ord('a') + k)}": rows for k, rows in enumerate(sides)}
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for stem, rows in pieces.items():
        part = {k: v[rows] for k, v in cols.items()}
        part["time_s"] = part["time_s"] - part["time_s"][0]
        meta = {
            "run_id": f"{SET_NAME}/{stem}",
            "mode": "motion",
            "steps": "1",
            "source_repo": f"https://github.com/{REPO}",
            "source_commit": COMMIT,
            "source_path": f"{FOLDER}/coreData.csv, {FOLDER}/commandData.csv",
            "source_licence": LICENCE,
            "robot": ROBOT,
        }
        target = out / f"{stem}.csv.gz"
        write_gzip(target, to_canonical(part, meta))
        written.append(target)
    return written


#: the repository this file belongs to, and the shared folder beside it (steering team's)
ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "real_logs" / "f1tenth"
ENV_VAR = "WBPOWER_REAL_LOGS"
MIRROR_VAR = "FRICTIONMAPS_MIRROR"
DEFAULT_MIRROR = "/work/.mirror/AhmadAmine998+FrictionMaps/repo"
#: the converted files: the whole log, and its two sides of the logger's gap
FILES = ("ds5.csv.gz", "ds5_a.csv.gz", "ds5_b.csv.gz", "ds5_c.csv.gz")
UNAVAILABLE = (
    f"real F1/10 log not available: set {ENV_VAR} (with {SET_NAME}/), or put it under "
    f"../shared/real_logs/f1tenth/, or fetch {REPO} (docs/real-logs.md)"
)


def _holds(folder: Path) -> bool:
    return all((folder / name).is_file() for name in FILES)


def locate(cache: Path) -> Path | None:
    """The folder holding FILES: (a) WBPOWER_REAL_LOGS/<set>, (b) ../shared, (c) the mirror.

    A `WBPOWER_REAL_LOGS/f1tenth_frictionmaps/` that lacks the files is an error
    (SystemExit naming it); a `WBPOWER_REAL_LOGS` without that folder (the REGBOT sets
    alone) is passed over. For (c) the files are converted into `cache` afresh.
    """
    named = os.environ.get(ENV_VAR)
    # WBPOWER_REAL_LOGS may hold the REGBOT sets alone (it came first): only a
    # f1tenth_frictionmaps/ folder there is this log's place
    if named and (Path(named) / SET_NAME).is_dir():
        folder = Path(named) / SET_NAME
        if not _holds(folder):
            raise SystemExit(
                f"{ENV_VAR}={named}: no converted F1/10 log in {folder} (it needs "
                f"{', '.join(FILES)}; convert them with {Path(__file__).name} "
                "(once without and once with --split-at-gaps), or unset it)"
            )
        return folder
    if _holds(SHARED):
        return SHARED
    mirror = Path(os.environ.get(MIRROR_VAR) or DEFAULT_MIRROR)
    if not (mirror / "HEAD").is_file():
        return None
    try:
        convert(mirror, cache)
        convert(mirror, cache, split_at_gaps=True)
    except subprocess.CalledProcessError:  # a mirror without the commit or the files
        return None
    return cache


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mirror", type=Path, help="git directory of the fetched repository")
    parser.add_argument("--out", type=Path, required=True, help="folder for the .csv.gz files")
    parser.add_argument(
        "--split-at-gaps", action="store_true", help="one file per side of the logger's gap"
    )
    args = parser.parse_args(argv)
    written = convert(args.mirror, args.out, args.split_at_gaps)
    print(f"{len(written)} log(s) written to {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
