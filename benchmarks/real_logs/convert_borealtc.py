"""Convert BorealTC's Husky logs (free driving over five surfaces) into canonical wbpower CSV.

The skid-steer field robot of docs/real-logs.md ("Free driving"): a Clearpath Husky A200
(four wheels, two sides, skid-steer) driven by hand on asphalt, flooring, ice, sandy
loam and snow, in norlab-ulaval/BorealTC (LaRocque et al., IROS 2024; the data is CC0
1.0, the code MIT). Each experiment's "wheel service" file `data/borealtc/<SURFACE>/
pro_NN.csv` holds, at 6.5 Hz (a 1/6.5 s step, evenly spaced):

- `time` [s] from the file's first row;
- `curL`, `curR`: the left and right **motor** currents [A] as the Husky's controller
  reports them: never negative, the torque-producing current (the dataset's own
  `utils/transforms.py` turns them into torque with the motor constant), and ~0 on a side
  that brakes (an arc's inner side reads at most the 0.6 A standstill current in 51-98% of
  its samples: benchmarks/validate_drive_real.py, "The sides of an arc");
- `velL`, `velR`: the left and right wheel speeds [m/s] (wheel odometry, signed);
- `MIXED/pro_00.csv` only: a `terrain` column naming the surface under the robot, empty
  where unlabelled.

The logs carry no voltage. Power is therefore `NOMINAL_V` (the Husky's 24 V battery) times
each motor's current: each side is a channel (`voltage_left_V` = 24, `current_left_A`;
`..._right_...`; log-format.md "Several channels"). This is what the motors would draw
from the battery if the drivers passed motor current through 1:1: at part duty the real
battery current is lower, and a braking side shows nothing (its current reads ~0). It
is a proxy proportional to the driving motors' torque; a constant factor does not change any
relative energy error, but the watts are not the battery's.

Each file becomes one `.csv.gz`, every row kept: `time_s`, the two channels,
`speed_mps` = (velL + velR) / 2, `speed_left_mps`, `speed_right_mps` (log-format.md
"Turning": with `track_m` the yaw rate is their difference over the track), and for
MIXED a per-sample `surface` column (lower case; empty where unlabelled). Metadata:
`run_id` (`borealtc/<surface>/pro_NN`), `mode: motion` and `speed_mps` = the largest
|speed_mps| of the log (free driving has no commanded speed, but the reader refuses a
motion run without one: docs/real-logs.md); neither for the 20 runs that only spin in
place (their linear speed is 0 throughout, and `speed_mps: 0` in a motion run is metadata
that contradicts itself, log-format.md "Bad input"), `surface` (lower case folder name;
not for MIXED), `track_m` = 0.5708 (husky_description's `track`), `mass_kg` = 50 (the
A200's own mass, Clearpath's data sheet; the sensors it carried are not stated),
`voltage_assumed_V` = 24, for `vulpi` `speed_dealiased` (its wheel speeds' aliased
samples replaced: `dealias`), and the provenance keys (`source_repo`, `source_commit`,
`source_path`, `source_licence`, `robot`). No `max_power_W`: the Husky's limit is not
documented in the source.

Usage (the mirror is a git directory from the `fetch` tool; the output goes outside the
repository, by default `$WBPOWER_REAL_DRIVE/borealtc` or /work/real_drive/borealtc):

    python benchmarks/real_logs/convert_borealtc.py /work/.mirror/norlab-ulaval+BorealTC/repo

Standard library + numpy only.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import canonical_out as co  # noqa: E402  (a module beside this one)
from canonical_out import canonical_text, git, write_gzip  # noqa: E402

REPO = "norlab-ulaval/BorealTC"
#: the newest commit of the default branch when fetched (2025-01-01); the data files were
#: last changed in 2e64df4 (2024-03-22, "Move all datasets in a common dir")
COMMIT = "fe64e386694528899db299e78a859dcab82f6b01"
#: each set: its folder in the repository, its licence, its robot
SETS = {
    "borealtc": (
        "data/borealtc",
        "CC0 1.0 (data/borealtc/README.md, 'This dataset is licensed under a CC0 1.0 Universal "
        "license'); the repository's code is MIT (LICENSE, Copyright (c) 2024 the BorealTC "
        "authors)",
        "Clearpath Husky A200, skid-steer, 4 wheels (BorealTC, LaRocque et al. 2024)",
    ),
    "vulpi": (
        "data/vulpi",
        "no licence stated for the data: converted to CSV by BorealTC (whose code is MIT and "
        "whose CC0 covers its own data) from Ph0bi0/T_DEEP's .mat files (README.md)",
        "skid-steer UGV of Vulpi et al. 2021 (Politecnico di Bari), taken to be a Clearpath "
        "Husky as BorealTC's code does (HuskyConstants, Reina 2016; its standstill current, "
        "0.6 A a motor, is the A200's)",
    ),
}
#: the Husky A200's battery voltage [V] (24 V sealed lead-acid, Clearpath): not in the logs
NOMINAL_V = 24.0
#: husky_description's `track` [m]: the left and right wheels' contact lines
TRACK_M = 0.5708
#: Clearpath's data sheet mass of the A200 [kg]
MASS_KG = 50.0
HEADER = ("time", "curL", "curR", "velL", "velR")  # by name: vulpi orders them otherwise
#: the sets whose wheel speeds hold aliased samples (`dealias`)
ALIASED = ("vulpi",)
#: an aliased sample reads this share of its neighbours' mean speed (Vulpi's: 0.40-0.70, most
#: 0.50-0.55), its neighbours agreeing within `ALIAS_AGREE` and faster than `ALIAS_MIN_MPS`
ALIAS_SHARE = (0.35, 0.70)
ALIAS_AGREE = 0.15
ALIAS_MIN_MPS = 0.1

COLUMNS = (
    ("time_s", "%.6f"),
    ("voltage_left_V", "%.1f"),
    ("current_left_A", "%.2f"),
    ("voltage_right_V", "%.1f"),
    ("current_right_A", "%.2f"),
    ("speed_mps", "%.6f"),
    ("speed_left_mps", "%.6f"),
    ("speed_right_mps", "%.6f"),
)


def parse(text: str, source: str) -> dict[str, np.ndarray]:
    """The columns of one `pro_NN.csv` (and `terrain` as strings where the file has it)."""
    header, _, body = text.partition("\n")
    fields = header.strip().split(",")
    missing = [n for n in HEADER if n not in fields]
    if missing:
        raise SystemExit(f"{source}: no column {', '.join(missing)} in the header {fields}")
    at = [fields.index(n) for n in HEADER]
    rows = [line.split(",") for line in body.splitlines() if line.strip()]
    text = "\n".join(",".join(r[k] for k in at) for r in rows)
    numbers = np.loadtxt(io.StringIO(text), delimiter=",", ndmin=2)
    cols = {name: numbers[:, k] for k, name in enumerate(HEADER)}
    if "terrain" in fields:
        k = fields.index("terrain")
        cols["terrain"] = np.array([r[k].strip().lower() if len(r) > k else "" for r in rows])
    if np.any(np.diff(cols["time"]) <= 0):
        raise SystemExit(f"{source}: time not increasing")
    return cols


def dealias(speed_mps: np.ndarray) -> tuple[np.ndarray, int]:
    """A wheel speed with its aliased samples replaced by their neighbours' mean, and how many.

    Vulpi's wheel speeds (15 Hz) read about half the speed on every third or fourth sample
    (0.56, 0.57, 0.29, 0.59 m/s): of the samples whose two neighbours agree within 15% above
    0.1 m/s, 54% read 0.40-0.70 of their neighbours' mean, 0.50-0.55 most often: 6,312 of its
    24,640 wheel speed samples (BorealTC's own logs, 6.5 Hz: 8 of 108,302). A 50 kg Husky
    cannot lose and regain half of 0.56 m/s within 2/15 s (+-4 m/s^2, 0.4 g), and its motor
    currents show no braking nor pulse there (concrete/pro_1 at 0.4 s, 0.29 m/s between 0.56
    and 0.57: 2.3 / 3.6 A before, 3.6 / 3.9 A at it, 3.5 / 4.0 A after): an encoder count
    taken over part of its period, not a speed. Left in, they put a quarter of the samples at
    half speed and the noise estimate of the drive model (successive differences) at 0.25 m/s,
    so that a 0.56 m/s run counts as standing (docs/drive-model.md, "Real logs")."""
    prev, cur, nxt = speed_mps[:-2], speed_mps[1:-1], speed_mps[2:]
    around = (prev + nxt) / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        share = cur / around
    agree = np.abs(prev - nxt) <= ALIAS_AGREE * np.abs(prev)
    fast = (np.abs(prev) > ALIAS_MIN_MPS) & (np.abs(nxt) > ALIAS_MIN_MPS)
    aliased = agree & fast & (share >= ALIAS_SHARE[0]) & (share <= ALIAS_SHARE[1])
    out = speed_mps.copy()
    out[1:-1][aliased] = around[aliased]
    return out, int(np.count_nonzero(aliased))


def to_canonical(cols: dict[str, np.ndarray], meta: dict[str, str]) -> str:
    """The canonical wbpower CSV text of one experiment."""
    n = cols["time"].size
    out = {
        "time_s": cols["time"] - cols["time"][0],
        "voltage_left_V": np.full(n, NOMINAL_V),
        "current_left_A": cols["curL"],
        "voltage_right_V": np.full(n, NOMINAL_V),
        "current_right_A": cols["curR"],
        "speed_mps": (cols["velL"] + cols["velR"]) / 2 + 0.0,  # + 0.0: no "-0"
        "speed_left_mps": cols["velL"] + 0.0,
        "speed_right_mps": cols["velR"] + 0.0,
    }
    names = [c for c, _ in COLUMNS]
    formats = [f for _, f in COLUMNS]
    table = np.empty((n, len(names) + ("terrain" in cols)), dtype=object)
    for k, name in enumerate(names):
        table[:, k] = out[name]
    if "terrain" in cols:
        names.append("surface")
        formats.append("%s")
        table[:, -1] = cols["terrain"]
    return canonical_text(meta, names, formats, table)


def experiments(mirror: Path, folder: str) -> list[str]:
    """Paths of every `pro_NN.csv` under `folder` at COMMIT, sorted."""
    listing = git(mirror, "ls-tree", "-r", "--name-only", COMMIT, folder).decode().split()
    return sorted(p for p in listing if Path(p).name.startswith("pro_") and p.endswith(".csv"))


def convert(mirror: Path, out: Path, set_name: str = "borealtc") -> list[Path]:
    folder, licence, robot = SETS[set_name]
    written = []
    for path in experiments(mirror, folder):
        surface_dir, stem = Path(path).parent.name, Path(path).stem
        cols = parse(git(mirror, "show", f"{COMMIT}:{path}").decode(), f"{REPO}:{path}")
        replaced = 0
        if set_name in ALIASED:
            cols["velL"], left = dealias(cols["velL"])
            cols["velR"], right = dealias(cols["velR"])
            replaced = left + right
        top = np.max(np.abs(cols["velL"] + cols["velR"]) / 2)
        meta = {"run_id": f"{set_name}/{surface_dir.lower()}/{stem}"}
        if top >= 0.005:  # a run that only spins has no speed to give (see the docstring)
            # today's reader refuses `mode: motion` without a speed (docs/real-logs.md)
            meta |= {"mode": "motion", "speed_mps": f"{top:.2f}"}
        if "terrain" not in cols:
            meta["surface"] = surface_dir.lower()
        meta |= {
            "track_m": f"{TRACK_M}",
            "mass_kg": f"{MASS_KG:g}",
            "voltage_assumed_V": f"{NOMINAL_V:g} (the battery's nominal voltage: the log "
            "holds motor currents only)",
            "source_repo": f"https://github.com/{REPO}",
            "source_commit": COMMIT,
            "source_path": path,
            "source_licence": licence,
            "robot": robot,
        }
        if set_name in ALIASED:
            meta["speed_dealiased"] = (
                f"{replaced} wheel speed sample(s) of {2 * cols['time'].size} read at about "
                "half their neighbours' speed, replaced by the neighbours' mean (dealias)"
            )
        target = out / surface_dir.lower() / f"{stem}.csv.gz"
        target.parent.mkdir(parents=True, exist_ok=True)
        write_gzip(target, to_canonical(cols, meta))
        written.append(target)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mirror", type=Path, help="git directory of the fetched repository")
    parser.add_argument("--set", choices=sorted(SETS), default="borealtc", dest="set_name")
    co.add_out_argument(parser, "SET")
    args = parser.parse_args(argv)
    folder = args.out or co.real_drive_root() / args.set_name
    written = convert(args.mirror, folder, args.set_name)
    print(f"{len(written)} log(s) written to {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
