"""wbpower on the F1/10 car's log (docs/real-logs.md, "A second family: an F1/10 car").

Reads the converted log (`convert_f1tenth.py`: the whole log `ds5` and its three sides of
the logger's gaps `ds5_a`, `ds5_b`, `ds5_c`) as a user would and scores what wbpower does
against the truth the log holds:

1. **Reading**: refused (the message), or samples, the period wbpower reads, the energy
   the time stamps give (sum of P_i (t_{i+1} - t_i)) beside wbpower's (its samples at its
   period), the negative samples (regeneration) and the time-stamp gaps the reader reports.
2. **Truth**: the car's motions, from the speed column (-ERPM / 7500, the car's own
   odometry): moving where |speed| exceeds `TRUTH_FLOOR_MPS` (0.1 m/s, 750 ERPM). The
   noise floor of benchmarks/score_segmentation_real.py (5 sd of the standing readings'
   steps, at least 0.02 m/s) does not carry over: REGBOT's encoders read 0 standing, this
   car's sensorless motor controller reads 0.02-0.08 m/s when the car stands or stalls
   (its estimate of a motor that barely turns; 61% of the samples under 0.1 m/s are
   commanded to move: the car pushes, at its 60 A current limit, without moving). The
   log's speed readings cluster at 0-0.08 m/s and thin out at 0.08-0.10 m/s before the
   driving speeds: the floor sits at the top of that trough. A **stop** is at least
   `MIN_STOP_SAMPLES` consecutive samples at or below it (two samples, ~0.1 s at this
   log's ~18 Hz: one reading amid a slow crawl is not a stop); a motion runs from the
   first moving sample after a stop to the first sample of the next stop. As a cross-check
   independent of the motor, how many of the stops see a commanded speed of 0.
3. **Segmentation twice**, with the speed column and without it (`Run.speed_mps = None`,
   power alone): the found motions are the stretches of consecutive non-idle phases. Each
   true motion is matched to the found motion it overlaps most; it is **right** when both
   ends are within `tolerance` = max(50 ms (issue 12's), 2 median sample periods: at
   ~18 Hz a boundary cannot be placed finer than a sample on either side). The outcome of
   a segmentation: `right` (as many motions found as true, every one right, phases in time
   order), else `doubted` (it carries doubts, or stopped with an error), else
   `silently wrong`.
4. **fit** and **diagnose** (the CLI, as a user runs them) on the three sides together:
   their error line, or what they found.

    .venv/bin/python benchmarks/real_logs/study_f1tenth.py              # text, 80 columns
    .venv/bin/python benchmarks/real_logs/study_f1tenth.py --write-docs # docs/real-logs.md

The log is found by `convert_f1tenth.locate` (`--data DIR`: a folder holding the converted
files instead): WBPOWER_REAL_LOGS/f1tenth_frictionmaps/, ../shared/real_logs/f1tenth/, or
converted from the fetched mirror into `.cache/real_logs/f1tenth_frictionmaps/`.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))
import convert_f1tenth as f1tenth  # noqa: E402  (scripts beside this one, not a package)
import score_segmentation_real as scoring  # noqa: E402

from wifibot_power.errors import WbpowerError  # noqa: E402
from wifibot_power.io import ReadOptions, read_log  # noqa: E402
from wifibot_power.phases import Segmentation  # noqa: E402
from wifibot_power.segment import segment_run  # noqa: E402

ROOT = HERE.parents[1]
CACHE = ROOT / ".cache" / "real_logs" / f1tenth.SET_NAME
DOCS = ROOT / "docs" / "real-logs.md"
BEGIN, END = "<!-- f1tenth study: begin -->", "<!-- f1tenth study: end -->"
WBPOWER = Path(sys.executable).with_name("wbpower")

#: the car moves where |speed| exceeds this [m/s] (docstring, 2)
TRUTH_FLOOR_MPS = 0.1
#: a stop is at least this many consecutive samples at or below it
MIN_STOP_SAMPLES = 2
#: a commanded speed this close to 0 is a commanded stop [m/s]
COMMAND_STOP_MPS = 0.01


@dataclass(frozen=True)
class Attempt:
    """One segmentation of a log (with or without the speed column)."""

    motions: list[tuple[float, float]]
    right: int
    start_errors_s: list[float]
    end_errors_s: list[float]
    in_order: bool
    doubts: tuple[str, ...]
    error: str | None
    outcome: str


@dataclass(frozen=True)
class Study:
    log: str
    refused: str | None
    samples: int = 0
    period_s: float = float("nan")
    duration_s: float = float("nan")
    energy_J: float = float("nan")
    wbpower_energy_J: float = float("nan")
    negative_samples: int = 0
    gaps: int = 0
    truth: list[tuple[float, float]] = dataclasses.field(default_factory=list)
    stops: int = 0
    commanded_stops: int = 0
    tolerance_s: float = float("nan")
    with_speed: Attempt | None = None
    without_speed: Attempt | None = None


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[a, b) stretches where `mask` holds."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def true_motions(time_s: np.ndarray, speed_mps: np.ndarray) -> list[tuple[int, int]]:
    """The motions [first moving sample, first sample of the next stop) (docstring, 2)."""
    still = np.abs(speed_mps) <= TRUTH_FLOOR_MPS
    stops = [(a, b) for a, b in _runs(still) if b - a >= MIN_STOP_SAMPLES]
    bounds = [0, *(x for stop in stops for x in stop), time_s.size]
    motions = list(zip(bounds[::2], bounds[1::2], strict=True))
    return [(a, b) for a, b in motions if b > a]


def found_motions(seg: Segmentation) -> list[tuple[float, float]]:
    """Stretches of consecutive non-idle phases [s]."""
    motions: list[tuple[float, float]] = []
    previous = "idle"
    for phase in seg.phases:
        if phase.phase != "idle":
            if previous == "idle":
                motions.append((phase.t_start_s, phase.t_end_s))
            else:
                motions[-1] = (motions[-1][0], max(motions[-1][1], phase.t_end_s))
        previous = phase.phase
    return motions


def _attempt(run, truth: list[tuple[float, float]], tolerance_s: float) -> Attempt:
    try:
        seg = segment_run(run)
    except WbpowerError as exc:
        return Attempt([], 0, [], [], True, (), exc.one_line(), "doubted")
    found = found_motions(seg)
    in_order = all(b.t_start_s >= a.t_end_s - 1e-9 for a, b in itertools.pairwise(seg.phases))
    starts, ends, right = [], [], 0
    for t0, t1 in truth:
        overlap = [max(0.0, min(t1, f1) - max(t0, f0)) for f0, f1 in found]
        if not overlap or max(overlap) <= 0:
            continue
        f0, f1 = found[int(np.argmax(overlap))]
        starts.append(f0 - t0)
        ends.append(f1 - t1)
        right += max(abs(f0 - t0), abs(f1 - t1)) <= tolerance_s + 1e-9
    if right == len(truth) == len(found) and in_order:
        outcome = "right"
    else:
        outcome = "doubted" if seg.doubts else "silently wrong"
    return Attempt(found, right, starts, ends, in_order, tuple(seg.doubts), None, outcome)


def study_log(path: Path) -> Study:
    log = path.name.removesuffix(".gz").removesuffix(".csv")
    try:
        run = read_log(path, ReadOptions())
    except WbpowerError as exc:
        return Study(log, exc.one_line())
    frame = pd.read_csv(path, comment="#", usecols=["time_s", "commanded_speed_mps"])
    time_s, speed = run.time_s, run.speed_mps
    if speed is None:
        raise SystemExit(f"{path}: the reader found no speed column (speed_mps)")
    motions = true_motions(time_s, speed)
    period_s = float(np.median(np.diff(time_s)))
    end_of = np.append(time_s, time_s[-1] + period_s)
    truth = [(float(time_s[a]), float(end_of[b])) for a, b in motions]
    command = frame["commanded_speed_mps"].to_numpy()
    stops = list(
        zip([0] + [b for _, b in motions], [a for a, _ in motions] + [time_s.size], strict=True)
    )
    stops = [(a, b) for a, b in stops if b > a]
    commanded = sum(bool(np.any(np.abs(command[a:b]) <= COMMAND_STOP_MPS)) for a, b in stops)
    tolerance_s = max(scoring.TOLERANCE_S, 2 * period_s)
    power = run.power_W
    return Study(
        log,
        None,
        samples=run.samples,
        period_s=run.sample_period_s,
        duration_s=float(time_s[-1] - time_s[0]),
        energy_J=float(np.sum(power[:-1] * np.diff(time_s)) + power[-1] * period_s),
        wbpower_energy_J=run.energy_J,
        negative_samples=int(np.sum(power < -1.0)),
        gaps=sum(p.kind == "gap" for p in run.problems),
        truth=truth,
        stops=len(stops),
        commanded_stops=commanded,
        tolerance_s=tolerance_s,
        with_speed=_attempt(run, truth, tolerance_s),
        without_speed=_attempt(dataclasses.replace(run, speed_mps=None), truth, tolerance_s),
    )


def _cli(command: str, folder: Path) -> str:
    """The last line a user sees of `wbpower COMMAND folder` (stderr's error, else stdout)."""
    done = subprocess.run(
        [str(WBPOWER), command, str(folder)], capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        lines = [line for line in done.stderr.splitlines() if "error:" in line]
        return f"exit {done.returncode}: " + (lines[-1] if lines else done.stderr.strip())
    return done.stdout.strip().splitlines()[0] if done.stdout.strip() else "(no output)"


def batch(folder: Path) -> dict[str, str]:
    """fit and diagnose on the three sides of the gaps together (a folder of their own)."""
    with tempfile.TemporaryDirectory() as scratch:
        sides = Path(scratch) / f1tenth.SET_NAME
        sides.mkdir()
        for name in f1tenth.FILES[1:]:
            (sides / name).write_bytes((folder / name).read_bytes())
        return {command: _cli(command, sides) for command in ("fit", "diagnose")}


def _ms(values: list[float]) -> str:
    if not values:
        return "-"
    worst = values[int(np.argmax(np.abs(values)))]
    return f"{1000 * np.median(np.abs(values)):.0f} / {1000 * worst:+.0f}"


def _cells(a: Attempt | None, truth: int) -> list[str]:
    if a is None:
        return ["-"] * 5
    if a.error:
        return ["error", "-", "-", "-", "doubted"]
    order = "" if a.in_order else " (overlap)"
    return [
        f"{len(a.motions)}{order}",
        f"{a.right}/{truth}",
        _ms(a.start_errors_s),
        _ms(a.end_errors_s),
        f"{a.outcome} ({len(a.doubts)} doubts)" if a.doubts else a.outcome,
    ]


def rows(studies: list[Study]) -> list[list[str]]:
    out = []
    for s in studies:
        if s.refused:
            out.append([s.log, "refused", *["-"] * 13])
            continue
        out.append(
            [
                s.log,
                f"{s.duration_s:.1f} s, {s.samples} @ {1000 * s.period_s:.1f} ms",
                f"{s.energy_J:.0f} / {s.wbpower_energy_J:.0f}",
                str(s.negative_samples),
                str(s.gaps),
                str(len(s.truth)),
                f"{s.commanded_stops}/{s.stops}",
                f"{1000 * s.tolerance_s:.0f}",
                *_cells(s.with_speed, len(s.truth)),
                *_cells(s.without_speed, len(s.truth))[:2],
                _cells(s.without_speed, len(s.truth))[4],
            ]
        )
    return out


HEADER = [
    "log",
    "read",
    "energy J: stamps / wbpower",
    "samples < -1 W",
    "short gaps",
    "true motions",
    "stops with a command of 0",
    "tol. ms",
    "with speed: motions",
    "right",
    "|Δstart| median / worst ms",
    "|Δend| median / worst ms",
    "outcome",
    "without speed: motions",
    "right",
    "outcome",
]


def _plain(message: str) -> str:
    """A message without the folders it was run in (temporary, or this machine's)."""
    message = re.sub(r"\S*/(ds5\w*\.csv\.gz)", r"\1", message)
    return re.sub(r"\S*/(" + f1tenth.SET_NAME + ")", r"\1", message)


def render_markdown(studies: list[Study], cli: dict[str, str]) -> str:
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    for row in rows(studies):
        if row[1] == "refused":
            row = [row[0], "refused", *row[2:]][: len(HEADER)]
            row += ["-"] * (len(HEADER) - len(row))
        lines.append("| " + " | ".join(row) + " |")
    lines.append("")
    for s in studies:
        if s.refused:
            lines.append(f"- {s.log}: refused by the reader: {_plain(s.refused)}")
    for command, said in cli.items():
        lines.append(f"- `wbpower {command}` on ds5_a, ds5_b, ds5_c: {_plain(said)}")
    return "\n".join(lines)


def render_text(studies: list[Study], cli: dict[str, str]) -> str:
    out = []
    for s in studies:
        if s.refused:
            out.append(f"{s.log}: refused: {s.refused}")
            continue
        out.append(
            f"{s.log}: {s.duration_s:.1f} s, {s.samples} samples at "
            f"{1000 * s.period_s:.1f} ms, {s.energy_J:.0f} J ({s.wbpower_energy_J:.0f} J by "
            f"wbpower), {s.negative_samples} samples "
            f"< -1 W, {s.gaps} short gaps; {len(s.truth)} true motions, tolerance "
            f"{1000 * s.tolerance_s:.0f} ms"
        )
        for label, a in (("with speed", s.with_speed), ("without", s.without_speed)):
            c = _cells(a, len(s.truth))
            out.append(
                f"  {label}: {c[0]} motions, {c[1]} right, |dstart| {c[2]} ms, "
                f"|dend| {c[3]} ms: {c[4]}"
            )
    for command, said in cli.items():
        out.append(f"wbpower {command} (ds5_a-c): {said}")
    return "\n".join(out)


def write_docs(path: Path, text: str) -> None:
    doc = path.read_text()
    if BEGIN not in doc or END not in doc:
        raise SystemExit(f"{path}: no {BEGIN} ... {END} lines to write between")
    head, rest = doc.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    path.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, help="a folder holding the converted files")
    parser.add_argument("--write-docs", action="store_true", help="update docs/real-logs.md")
    args = parser.parse_args(argv)
    folder = args.data or f1tenth.locate(CACHE)
    if folder is None:
        raise SystemExit(f1tenth.UNAVAILABLE)
    studies = [study_log(folder / name) for name in f1tenth.FILES]
    cli = batch(folder)
    if args.write_docs:
        write_docs(DOCS, render_markdown(studies, cli))
    else:
        print(render_text(studies, cli))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
