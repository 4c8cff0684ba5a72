"""The corpora `make bench` measures: one folder per shape of log, each several hundred MB.

Usage: `python benchmarks/corpora.py [--shape power,vi,...] [--root DIR] [--list]`; the root is
`--root`, else the environment's `WBPOWER_BENCH_CORPUS`, else `bench_corpus/` in the repository
(git-ignored). Importable: `build(shape, root)` returns the shape's folder.

Every shape is the paper's grid (9 speeds x trips 2 m, 10 m, 10 m in 10 steps, plus the
idle/network/video/cpu logs) simulated by wbpower's own simulator (`iter_simulation`, seeded:
the same parameters give the same bytes), written in one layout:

- `power`: canonical CSV, `time_s,power_W` (~19 bytes a sample), 0.1024 ms;
- `vi`: canonical CSV, `time_s,voltage_V,current_A` (power = V x I, ~26 bytes a sample),
  0.1024 ms;
- `n6705`: Keysight N6705 datalog export, `Sample,"Curr avg 1","Volt avg 1"` (~22 bytes a
  sample), in the layout of the real `n6705c_dlog1.csv`, 0.1024 ms; the run metadata is in
  `runs.csv` (the export has none);
- `gzip`: canonical CSV, all columns, `.csv.gz` (`wbpower simulate --compress gz`), 0.1024 ms;
- `power10k`: canonical CSV, `power_W` only, time from the `sample_period_s` metadata
  (`wbpower simulate --columns power --sample-period 0.0001`, ~8 bytes a sample), 0.1 ms.

One shape is not the grid: `drive`, free driving for the drive model (issue 25), written by
`wbpower simulate --drive free --realism field` itself (a skid-steer robot on random routes
over asphalt and grass: stops, arcs, turns in place, reversing; 20 Hz, noise, lag, quantized
speed, drop-outs): `time_s,power_W,speed_mps,yaw_rate_radps` (~28 bytes a sample), runs of
`duration_s`, `repeats` runs a surface. Its runs are motion of unknown mode: `fit` gives the
drive model from them (the paper's model needs step runs), `diagnose` has nothing to do.

Each folder also holds `runs.csv` (the manifest `wbpower simulate` writes) and `truth.json`
(true phase boundaries, for scoring segmentation), and `.corpus-params.json`: a folder whose
parameters have not changed is not written again. A folder is built under a temporary name
and renamed when complete, so a reader never sees half a corpus. The shapes use different
seeds, so folders mixed into one batch are not taken as copies of each other.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DEFAULT_ROOT = REPO / "bench_corpus"
ENV_ROOT = "WBPOWER_BENCH_CORPUS"
#: bumped when a layout's bytes change for the same parameters (then every folder is rebuilt)
LAYOUT_VERSION = 1


@dataclass(frozen=True)
class Shape:
    """One corpus: a layout of log and the grid simulated into it."""

    layout: str  # a key of LAYOUTS
    sample_period_s: float
    repeats: int  # repeats of each motion run
    mode_repeats: int  # repeats of each idle/network/video/cpu log
    seed: int
    description: str
    #: `drive` only: each free-driving run's duration [s] (None: the paper's grid)
    duration_s: float | None = None

    @property
    def free_driving(self) -> bool:
        return self.layout == "drive_free"


SHAPES: dict[str, Shape] = {
    "power": Shape("time_power", 0.1024e-3, 3, 2, 1401, "power-only canonical, time_s,power_W"),
    "vi": Shape("time_voltage_current", 0.1024e-3, 2, 2, 1402, "canonical, time_s,voltage_V,current_A"),  # noqa: E501
    "n6705": Shape("n6705", 0.1024e-3, 2, 2, 1403, "N6705 export, Curr avg 1 x Volt avg 1"),
    "gzip": Shape("full_gz", 0.1024e-3, 2, 2, 1404, "canonical, all columns, .csv.gz"),
    "power10k": Shape("power", 0.1e-3, 8, 2, 1405, "power-only canonical at 10 kHz, power_W"),
    "drive": Shape("drive_free", 0.05, 100, 0, 1406, "free driving, field realism: time_s,power_W,speed_mps,yaw_rate_radps", duration_s=3600.0),  # noqa: E501
}  # fmt: skip


def root_of(given: str | Path | None = None) -> Path:
    """`given`, else $WBPOWER_BENCH_CORPUS, else bench_corpus/ in the repository."""
    if given:
        return Path(given)
    return Path(os.environ.get(ENV_ROOT) or DEFAULT_ROOT)


# --- the layouts: (meta, power_W, voltage_V) -> (file suffix, bytes) -------------------------


def _meta_lines(meta, *, with_period: bool) -> list[str]:
    """The canonical `#` metadata lines (log-format.md section 1), as `wbpower simulate` writes."""
    lines = ["# wbpower-log: 1", f"# run_id: {meta.run_id}", f"# mode: {meta.mode}"]
    if meta.mode == "motion":
        lines += [
            f"# speed_mps: {meta.speed_mps:g}",
            f"# distance_m: {meta.distance_m:g}",
            f"# steps: {meta.steps}",
        ]
    if meta.started_at is not None:
        lines.append(f"# started_at: {meta.started_at.isoformat().replace('+00:00', 'Z')}")
    if with_period:
        lines.append(f"# sample_period_s: {meta.sample_period_s:g}")
    return lines


def _csv(preamble: list[str], columns: dict[str, np.ndarray]) -> bytes:
    from wifibot_power.io.writer import csv_bytes

    return csv_bytes(preamble, columns)


def _time_s(meta, n: int) -> np.ndarray:
    return np.round(np.arange(n) * meta.sample_period_s, 10)


def time_power(meta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
    columns = {"time_s": _time_s(meta, power_W.size), "power_W": np.round(power_W, 4)}
    return ".csv", _csv([*_meta_lines(meta, with_period=False), "time_s,power_W"], columns)


def time_voltage_current(meta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
    columns = {
        "time_s": _time_s(meta, power_W.size),
        "voltage_V": np.round(voltage_V, 4),
        "current_A": np.round(power_W / voltage_V, 5),
    }
    header = "time_s,voltage_V,current_A"
    return ".csv", _csv([*_meta_lines(meta, with_period=False), header], columns)


def n6705(meta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
    """The export's layout byte for byte as ../shared/real_logs/n6705c_dlog1.csv: a title line,
    a blank line, three quoted lines, a blank line, the header with quoted names, LF ends."""
    started = meta.started_at
    date = started.strftime("%a %b %e %H:%M:%S %Y") if started else "Mon Jun  1 10:00:00 2015"
    preamble = [
        "N6705C exported datalog",
        "",
        f'"Sample interval: {meta.sample_period_s:.10g}"',
        '"Trigger sample: 0"',
        f'"Date: {date}"',
        "",
        'Sample,"Curr avg 1","Volt avg 1"',
    ]
    columns = {
        "Sample": np.arange(power_W.size, dtype=np.int64),
        "current": np.round(power_W / voltage_V, 5),
        "voltage": np.round(voltage_V, 4),
    }
    return ".csv", _csv(preamble, columns)


def full_gz(meta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
    """What `wbpower simulate --compress gz` writes (its own writer)."""
    from wifibot_power.io.writer import format_log

    # the uncompressed bytes: `write_log` gzips a .gz name as `simulate --compress gz` does
    return ".csv.gz", format_log(meta, power_W, voltage_V=voltage_V, time_column=True, decimals=4)


def power(meta, power_W: np.ndarray, voltage_V: np.ndarray) -> tuple[str, bytes]:
    """What `wbpower simulate --columns power` writes (its own writer): `power_W` only."""
    from wifibot_power.io.writer import format_log

    return ".csv", format_log(meta, power_W, voltage_V=None, time_column=False, decimals=4)


LAYOUTS: dict[str, Callable[..., tuple[str, bytes]]] = {
    "time_power": time_power,
    "time_voltage_current": time_voltage_current,
    "n6705": n6705,
    "full_gz": full_gz,
    "power": power,
}


# --- building ------------------------------------------------------------------------------


def _params(shape: Shape) -> dict[str, object]:
    """What the bytes depend on (not the description)."""
    params = asdict(shape)
    del params["description"]
    if params["duration_s"] is None:  # the grid shapes' parameters as before the field existed
        del params["duration_s"]
    return {"shape": params, "layout_version": LAYOUT_VERSION}


def is_built(name: str, root: Path) -> bool:
    stamp = root / name / ".corpus-params.json"
    return stamp.is_file() and json.loads(stamp.read_text()) == _params(SHAPES[name])


def build(name: str, root: Path | None = None, *, quiet: bool = False) -> Path:
    """The folder of shape `name` under `root`, written unless present with the same parameters."""
    root = root_of(root)
    shape = SHAPES[name]
    folder = root / name
    if is_built(name, root):
        if not quiet:
            print(f"corpora: {folder} present with the same parameters: not written again")
        return folder
    partial = root / f".{name}.partial"
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir(parents=True)
    print(f"corpora: writing {folder} ({shape.description}) ...", flush=True)
    start = time.perf_counter()
    if shape.free_driving:
        written = _free_driving(shape, partial)
    else:
        written = _grid(name, shape, partial)
    (partial / ".corpus-params.json").write_text(json.dumps(_params(shape)))
    shutil.rmtree(folder, ignore_errors=True)
    partial.rename(folder)
    print(
        f"corpora: {name}: {written['runs']} logs, {written['csv_bytes'] / 1e6:.0f} MB of CSV "
        f"in {time.perf_counter() - start:.0f} s",
        flush=True,
    )
    return folder


def _grid(name: str, shape: Shape, partial: Path) -> dict:
    """The paper's grid simulated into `partial` in the shape's layout."""
    from wifibot_power.simulate import SimConfig, realism, write_simulation

    config = SimConfig(
        repeats=shape.repeats,
        mode_repeats=shape.mode_repeats,
        sample_period_s=shape.sample_period_s,
        seed=shape.seed,
        **realism("lab"),
    )
    return write_simulation(
        config,
        partial,
        render=LAYOUTS[shape.layout],
        generator=f"benchmarks/corpora.py shape {name}",
    )


def _free_driving(shape: Shape, partial: Path) -> dict:
    """`wbpower simulate --drive free --realism field` into `partial`, as a user would run it
    (the installed command beside this interpreter, else `python -m wifibot_power`)."""
    wbpower = Path(sys.executable).parent / "wbpower"
    command = [str(wbpower)] if wbpower.is_file() else [sys.executable, "-m", "wifibot_power"]
    argv = [
        *command, "simulate", "-o", str(partial), "--drive", "free", "--realism", "field",
        "--repeats", str(shape.repeats), "--duration", f"{shape.duration_s:g}",
        "--seed", str(shape.seed), "--json",
    ]  # fmt: skip
    done = subprocess.run(argv, capture_output=True, text=True, cwd=REPO, check=False)
    if done.returncode != 0:
        raise SystemExit(f"corpora: {' '.join(argv)} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout)


def log_files(folder: Path) -> list[Path]:
    """The logs of a corpus folder (not its manifest)."""
    return sorted(
        p
        for p in folder.iterdir()
        if p.name != "runs.csv" and (p.name.endswith(".csv") or p.name.endswith(".csv.gz"))
    )


def quick_subset(folder: Path, into: Path) -> Path:
    """A small corpus for iterating on the bench: the first repeat of every run (`*_r1.*`;
    free driving: its first eighth of runs), as symlinks, with the manifest rows that name
    them."""
    shutil.rmtree(into, ignore_errors=True)
    into.mkdir(parents=True)
    logs = log_files(folder)
    keep = {p.name for p in logs if "_r1." in p.name} or {
        p.name for p in logs[: -(-len(logs) // 8)]
    }
    for name in sorted(keep):
        (into / name).symlink_to(folder / name)
    lines = (folder / "runs.csv").read_text().splitlines()
    rows = [lines[0], *(line for line in lines[1:] if line.split(",", 1)[0] in keep)]
    (into / "runs.csv").write_text("\n".join(rows) + "\n")
    return into


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shape", default=",".join(SHAPES), help="comma-separated shapes")
    parser.add_argument("--root", default=None, help=f"default: ${ENV_ROOT} or bench_corpus/")
    parser.add_argument("--list", action="store_true", help="list the shapes and stop")
    args = parser.parse_args(argv)
    if args.list:
        for name, shape in SHAPES.items():
            print(f"{name:9s} {shape.description} ({shape.sample_period_s * 1e3:g} ms)")
        return
    names = [n.strip() for n in args.shape.split(",") if n.strip()]
    unknown = [n for n in names if n not in SHAPES]
    if unknown:
        raise SystemExit(f"corpora: unknown shape {unknown}: give some of {', '.join(SHAPES)}")
    root = root_of(args.root)
    root.mkdir(parents=True, exist_ok=True)
    need_GB = 0.7 * sum(not is_built(n, root) for n in names)
    free_GB = shutil.disk_usage(root).free / 1e9
    if free_GB < need_GB:
        raise SystemExit(f"corpora: {free_GB:.1f} GB free in {root}, about {need_GB:.1f} needed")
    for name in names:
        build(name, root)


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))  # runnable as a script from anywhere
    main()
