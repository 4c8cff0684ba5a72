"""Convert public REGBOT motor logs into canonical wbpower CSV (log-format.md §1).

REGBOT is DTU's small two-wheeled teaching robot (DC motors with encoders, a Teensy
controller that logs at 1 ms). Its log files are plain text: `%` comment lines that name
each column (`%  5  6 Motor voltage [V] left, right: ...`), then one row of space separated
numbers per sample. Two public sets are converted (docs/real-logs.md):

- `regbot_initial_current`: zachasme/regbot, `qtgui/initial_current_*.txt` (2016-17): one
  start-up test per robot of a whole class fleet: commanded motor voltage 2 (or 1.2-1.6) V
  for 0.2 s, then 4 V, then for most -4 V (the wheels reverse) and 0 V (the motors shorted:
  power 0 while the wheels coast to a stop); some hold 1.2 V then 4 V and never stop.
- `regbot_rev2b_vel_step`: tarasz98/Robot_cup_Saga, `Pi/regbot/matlab/rev2b/vel_step*.txt`
  (2015, hardware rev. 2b): a voltage step 2.1 -> 4.1 V (two speed levels), never stopping.

Each log becomes one `.csv.gz` with every row kept and its own time stamps:

- `time_s`: the log's time column [s] (1 ms steps);
- `voltage_left_V`, `current_left_A`, `voltage_right_V`, `current_right_A`: the two motors
  as two channels (log-format.md, "Several channels": wbpower sums their voltage x current
  into the robot's power). The logs record the motors only, so a standing robot reads 0 W;
  the voltage is the one the controller commands (the log's "Motor voltage" column), the
  current the one it measures;
- `speed_mps`: (left + right wheel velocity) / 2, signed (negative = backwards). The logs'
  "Wheel velocity [m/s]" is already a speed: the robot's firmware converts encoder ticks
  with its configured wheel radius (0.03 m on REGBOT), so no radius is applied here;
- `speed_left_mps`, `speed_right_mps`: the two wheel velocities as logged.

Metadata: `run_id` (set + file stem), `mode: motion`, `speed_mps` = the largest |speed|
of the log (the tests command voltages, not speeds), `steps: 1`, and provenance keys
(`source_repo`, `source_commit`, `source_path`, `source_licence`, `robot`).

Usage (the mirror is a git directory, e.g. from the `fetch` tool, /work/.mirror/...; the
output goes outside the tracked tree: data from fetched repositories is never committed):

    python benchmarks/real_logs/convert_regbot.py regbot_initial_current \
        /work/.mirror/zachasme+regbot/repo/.git --out DIR/regbot_initial_current
    python benchmarks/real_logs/convert_regbot.py regbot_rev2b_vel_step \
        /work/.mirror/tarasz98+Robot_cup_Saga/repo --out DIR/regbot_rev2b_vel_step

By default only the set's excerpt (`fixture` below) is written; `--all` converts every log
of the set. Standard library + numpy only.

`locate` is the one place that finds the converted logs, for the tests and for
benchmarks/score_segmentation_real.py, in this order: (a) the folder named by the
environment variable `WBPOWER_REAL_LOGS` (holding one `<set>/` folder per set);
(b) `../shared/real_logs/regbot/` beside the repository; (c) converted on the fly from the
fetched mirrors (`REGBOT_MIRROR`, `SAGA_MIRROR`; defaults in `DEFAULT_MIRRORS`) into a
cache folder the caller gives. None of these: `locate` returns None and the caller says
`UNAVAILABLE`.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from canonical_out import canonical_text, git, write_gzip  # noqa: E402  (a module beside this one)


@dataclass(frozen=True)
class LogSet:
    repo: str
    commit: str
    pattern: str
    licence: str
    #: file names kept as the test fixture (an excerpt: the sets state no licence)
    fixture: tuple[str, ...]


NO_LICENCE = (
    "no licence stated for the log files (the repository has no LICENSE file; "
    "only an excerpt is kept)"
)

SETS = {
    "regbot_initial_current": LogSet(
        repo="zachasme/regbot",
        commit="d34f38ec0ad36e95a5db6ed00413220ab575b11b",
        pattern="qtgui/initial_current_*.txt",
        licence=NO_LICENCE
        + "; the repository's program sources carry GPL-2.0-or-later headers (DTU)",
        fixture=(
            "initial_current_01_emma.txt",
            "initial_current_08_ella.txt",
            "initial_current_12_josefine.txt",
            "initial_current_13_olivia.txt",
            "initial_current_16_sofie.txt",
            "initial_current_19_lily.txt",
            "initial_current_58_sigrid.txt",
            "initial_current_62_tania.txt",
            "initial_current_78_melina.txt",
            "initial_current_85_haiyan_b.txt",
            "initial_current_87_mia_c.txt",
            "initial_current_88_vera.txt",
        ),
    ),
    "regbot_rev2b_vel_step": LogSet(
        repo="tarasz98/Robot_cup_Saga",
        commit="1dfc83577c08d18df75e95d78ce9d5e792c7986b",
        pattern="Pi/regbot/matlab/rev2b/vel_step*.txt",
        licence=NO_LICENCE,
        fixture=(
            "vel_step.txt",
            "vel_step_-2.txt",
            "vel_step_2.txt",
            "vel_step_18.txt",
            "vel_step_19.txt",
            "vel_step_24.txt",
            "vel_step_30.txt",
            "vel_step_35.txt",
        ),
    ),
}

#: a REGBOT header line: `%  5  6 Motor voltage [V] left, right: 2.0 2.0` (first column, 1-based)
_HEADER = re.compile(r"^%\s+(\d+)\s+(?:\d+\s+)*(Motor voltage|Motor current|Wheel velocity)")
_ROBOT = re.compile(r"^%%? ?logfile from robot\s+(.*?)\s*$")


def parse_regbot(text: str, source: str) -> dict[str, np.ndarray | str]:
    """Columns of one REGBOT log: time, per-motor voltage/current/wheel velocity, robot name."""
    first: dict[str, int] = {}
    robot = ""
    rows = []
    for line in text.splitlines():
        if line.startswith("%"):
            match = _HEADER.match(line)
            if match:
                first.setdefault(match.group(2), int(match.group(1)) - 1)
            name = _ROBOT.match(line)
            if name:
                robot = name.group(1)
            continue
        if line.strip():
            rows.append(line.split())
    missing = {"Motor voltage", "Motor current", "Wheel velocity"} - set(first)
    if missing:
        raise SystemExit(f"{source}: no {', '.join(sorted(missing))} column in the header")
    widths = {len(row) for row in rows}
    if len(widths) != 1:
        raise SystemExit(f"{source}: rows of different lengths {sorted(widths)}")
    data = np.array(rows, dtype=np.float64)
    u, i, v = (first[k] for k in ("Motor voltage", "Motor current", "Wheel velocity"))
    return {
        "time_s": data[:, 0],
        "u_left_V": data[:, u],
        "u_right_V": data[:, u + 1],
        "i_left_A": data[:, i],
        "i_right_A": data[:, i + 1],
        "v_left_mps": data[:, v],
        "v_right_mps": data[:, v + 1],
        "robot": robot,
    }


#: output columns: (name, source key, printf format as logged: 3 decimals of time, 0.1 V,
#: mA, 0.1 mm/s)
COLUMNS = (
    ("time_s", "time_s", "%.3f"),
    ("speed_mps", None, "%.5f"),
    ("voltage_left_V", "u_left_V", "%.2f"),
    ("current_left_A", "i_left_A", "%.3f"),
    ("voltage_right_V", "u_right_V", "%.2f"),
    ("current_right_A", "i_right_A", "%.3f"),
    ("speed_left_mps", "v_left_mps", "%.4f"),
    ("speed_right_mps", "v_right_mps", "%.4f"),
)


def to_canonical(cols: dict[str, np.ndarray | str], meta: dict[str, str]) -> str:
    """The canonical wbpower CSV text of one parsed log."""
    speed_mps = (cols["v_left_mps"] + cols["v_right_mps"]) / 2 + 0.0  # + 0.0: no "-0"
    meta = {**meta, "speed_mps": f"{np.max(np.abs(speed_mps)):.2f}"}
    table = np.column_stack([speed_mps if k is None else cols[k] for _, k, _ in COLUMNS])
    return canonical_text(meta, [n for n, _, _ in COLUMNS], [f for _, _, f in COLUMNS], table)


def convert(set_name: str, mirror: Path, out: Path, everything: bool) -> list[Path]:
    spec = SETS[set_name]
    paths = [
        p
        for p in git(mirror, "ls-tree", "-r", "--name-only", spec.commit).decode().split("\n")
        if fnmatch.fnmatch(p, spec.pattern)
    ]
    if not everything:
        paths = [p for p in paths if Path(p).name in spec.fixture]
        absent = set(spec.fixture) - {Path(p).name for p in paths}
        if absent:
            raise SystemExit(f"{mirror}: fixture logs not found: {sorted(absent)}")
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for path in sorted(paths):
        source = f"{spec.repo}@{spec.commit[:12]}:{path}"
        cols = parse_regbot(git(mirror, "show", f"{spec.commit}:{path}").decode(), source)
        stem = Path(path).stem
        meta = {
            "run_id": f"{set_name}/{stem}",
            "mode": "motion",
            "steps": "1",
            "source_repo": f"https://github.com/{spec.repo}",
            "source_commit": spec.commit,
            "source_path": path,
            "source_licence": spec.licence,
            "robot": f"REGBOT {cols['robot']}".strip(),
        }
        target = out / f"{stem}.csv.gz"
        write_gzip(target, to_canonical(cols, meta))
        written.append(target)
    return written


#: the repository this file belongs to, and the shared folder beside it (steering team's)
ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "real_logs" / "regbot"
#: a folder holding one `<set>/` folder of converted logs per set: looked at first
ENV_VAR = "WBPOWER_REAL_LOGS"
#: where the `fetch` tool puts the two repositories (git directories), and the environment
#: variables that override them
DEFAULT_MIRRORS = {
    "regbot_initial_current": ("REGBOT_MIRROR", "/work/.mirror/zachasme+regbot/repo/.git"),
    "regbot_rev2b_vel_step": ("SAGA_MIRROR", "/work/.mirror/tarasz98+Robot_cup_Saga/repo"),
}
UNAVAILABLE = (
    f"real REGBOT logs not available: set {ENV_VAR}, or put them under "
    "../shared/real_logs/regbot/, or fetch the mirrors (docs/real-logs.md)"
)


@dataclass(frozen=True)
class Located:
    """Where the converted logs were found: `root` holds one `<set>/` folder per set."""

    root: Path
    #: "env" (WBPOWER_REAL_LOGS), "shared" (../shared/real_logs/regbot/) or "mirrors"
    #: (converted from the fetched repositories into the cache)
    source: str

    def folder(self, set_name: str) -> Path:
        return self.root / set_name

    def excerpt(self, set_name: str) -> list[Path]:
        """The set's excerpt files (`fixture`), in name order: a folder may hold more."""
        return sorted(
            self.folder(set_name) / f"{Path(n).stem}.csv.gz" for n in SETS[set_name].fixture
        )


def mirrors() -> dict[str, Path]:
    """The git directory of each set's fetched repository (environment, else default)."""
    return {
        name: Path(os.environ.get(var) or path) for name, (var, path) in DEFAULT_MIRRORS.items()
    }


def _holds_every_set(root: Path) -> bool:
    return all(p.is_file() for name in SETS for p in Located(root, "").excerpt(name))


def locate(cache: Path) -> Located | None:
    """Find the converted logs of every set: (a) WBPOWER_REAL_LOGS, (b) ../shared, (c) mirrors.

    A `WBPOWER_REAL_LOGS` that is set but lacks a set's excerpt is an error (SystemExit
    naming the folder), not a reason to look elsewhere. For (c) both mirrors must hold their
    commit; the excerpts are converted into `cache/<set>/` (written afresh each time).
    """
    named = os.environ.get(ENV_VAR)
    if named:
        root = Path(named)
        if not _holds_every_set(root):
            raise SystemExit(
                f"{ENV_VAR}={root}: no converted excerpt of every set there (it needs "
                f"{', '.join(f'{n}/' for n in SETS)} with the files of docs/real-logs.md; "
                f"convert them with {Path(__file__).name}, or unset {ENV_VAR})"
            )
        return Located(root, "env")
    if _holds_every_set(SHARED):
        return Located(SHARED, "shared")
    sources = mirrors()
    if not all((git_dir / "HEAD").is_file() for git_dir in sources.values()):
        return None
    try:
        for name, git_dir in sources.items():
            convert(name, git_dir, cache / name, everything=False)
    except subprocess.CalledProcessError:  # a mirror without the commit or a path
        return None
    return Located(cache, "mirrors")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("set", choices=sorted(SETS))
    parser.add_argument("mirror", type=Path, help="git directory of the fetched repository")
    parser.add_argument("--out", type=Path, required=True, help="folder for the .csv.gz files")
    parser.add_argument("--all", action="store_true", help="every log of the set, not the excerpt")
    args = parser.parse_args(argv)
    written = convert(args.set, args.mirror, args.out, args.all)
    print(f"{len(written)} logs written to {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
