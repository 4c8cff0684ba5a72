"""Stops at low speed under a cruise ripple: how many `segment_run` misses, and how many of
those it misses silently (no doubt), against the simulator's truth (docs/segmentation.md,
"A stop hidden by the ripple").

Grid (`wbpower simulate`'s model, 1.024 ms samples): ripple 0.5, 1, 2 W x stop phase 0.3,
0.5, 1 s x speeds 0.1, 0.2, 0.3 m/s x trips of 1 m and 10 m in one step (and 10 m in ten
1 m steps with `--ten-steps`), lab and field realism, seeds given. A stop counts as
**missed** when the step's found phases have no `decel` or its start or end is more than
50 ms (the tolerance of issue 12) from the truth's; a run with a missed stop is **silent**
when `Segmentation.doubts` is empty. The same grid without `decel_phase` (`--no-stop`)
counts **false doubts**: doubts on runs whose phases are all within 50 ms of the truth.

    .venv/bin/python benchmarks/stops_under_ripple.py [--seeds 1-4] [--no-stop] [--ten-steps]
        [--stops 0.3,0.5,1] [--before REV] [--list]
"""

from __future__ import annotations

import argparse
import itertools
import multiprocessing
import sys
import tempfile
from pathlib import Path

from wifibot_power.segment import segment_run
from wifibot_power.simulate import SimConfig, realism, simulate_runs

RIPPLES_W = (0.5, 1.0, 2.0)
STOPS_S = (0.3, 0.5, 1.0)
SPEEDS_MPS = (0.1, 0.2, 0.3)
#: the segmenter measured (`--before REV` swaps in that revision's, as segment_speed.py does)
SEGMENT = segment_run
#: a boundary further than this from the truth is wrong (issue 12's tolerance) [s]
TOLERANCE_S = 0.05


def _bounds(phases: list[dict]) -> dict[tuple[int, str], tuple[float, float]]:
    return {(int(p["step"]), p["phase"]): (p["t_start_s"], p["t_end_s"]) for p in phases}


def _where(truth: dict, found: dict, k: int) -> str:
    """Where a missed stop of step `k` went: into the cruise (the cruise ends at the stop's
    end), into the idle after it (the motion ends at the stop's start), or elsewhere."""
    t_dec = truth[(k, "decel")]
    cruise = found.get((k, "cruise"))
    if cruise is None or (k, "decel") in found:
        return "other"
    if abs(cruise[1] - t_dec[1]) <= TOLERANCE_S:
        return "cruise"
    if abs(cruise[1] - t_dec[0]) <= TOLERANCE_S:
        return "idle"
    return "other"


def case(args: tuple[str, float, float | None, int, bool]) -> list[dict]:
    """Every run of one cell: what the truth has, what was found, the doubts."""
    level, ripple_W, stop_s, seed, ten_steps = args
    effects = {"cruise_ripple": ripple_W}
    if stop_s is not None:
        effects["decel_phase"] = stop_s
    trips = ((1.0, 1), (10.0, 1)) + (((10.0, 10),) if ten_steps else ())
    config = SimConfig(
        speeds_mps=SPEEDS_MPS,
        trips=trips,
        repeats=1,
        modes=(),
        sample_period_s=1.024e-3,
        seed=seed,
        effects=effects,
        **realism(level),
    )
    out = []
    for sim in simulate_runs(config):
        seg = SEGMENT(sim.run)
        truth = _bounds(sim.truth["phases"])
        found = _bounds([p.as_dict() for p in seg.phases])
        steps = sorted({k for k, name in truth if name == "accel"})
        missed = []  # steps whose stop is not found within the tolerance
        kinds = []  # where a missed stop went: "cruise", "idle" or "other"
        wrong = []  # steps with any boundary off (or a phase missing / extra)
        for k in steps:
            names = ("accel", "cruise", "decel")
            for name in names:
                t, f = truth.get((k, name)), found.get((k, name))
                off = (t is None) != (f is None) or (
                    t is not None
                    and f is not None
                    and max(abs(t[0] - f[0]), abs(t[1] - f[1])) > TOLERANCE_S
                )
                if off:
                    wrong.append(k)
                    if name == "decel" and t is not None:
                        missed.append(k)
                        kinds.append(_where(truth, found, k))
        out.append(
            {
                "run_id": sim.truth["run_id"],
                "level": level,
                "ripple_W": ripple_W,
                "stop_s": stop_s,
                "speed_mps": sim.run.meta.speed_mps,
                "distance_m": sim.run.meta.distance_m,
                "seed": seed,
                "steps": len(steps),
                "missed": sorted(set(missed)),
                "kinds": kinds,
                "wrong": sorted(set(wrong)),
                "doubts": list(seg.doubts),
            }
        )
    return out


def _is_hidden_stop(doubt: str) -> bool:
    """Whether a doubt is one of `_hidden_stop_doubts`' (its wording)."""
    return "the ripple hid" in doubt or "a stop labelled idle" in doubt


def seeds_of(text: str) -> list[int]:
    first, _, last = text.partition("-")
    return list(range(int(first), int(last or first) + 1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="1-4")
    parser.add_argument("--no-stop", action="store_true", help="the grid without decel_phase")
    parser.add_argument("--ten-steps", action="store_true", help="also 10 m in ten 1 m steps")
    parser.add_argument("--list", action="store_true", help="list every missed or doubted run")
    parser.add_argument("--stops", help="stop lengths [s], comma-separated (0.3,0.5,1)")
    parser.add_argument("--before", help="measure the segmenter of this git revision")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    stops = tuple(float(x) for x in args.stops.split(",")) if args.stops else STOPS_S
    stops = (None,) if args.no_stop else stops
    cells = list(
        itertools.product(
            ("lab", "field"), RIPPLES_W, stops, seeds_of(args.seeds), (args.ten_steps,)
        )
    )
    global SEGMENT
    with tempfile.TemporaryDirectory() as tmp:
        if args.before:
            sys.path.insert(0, str(Path(__file__).resolve().parent))
            from segment_speed import load_before

            SEGMENT = load_before(args.before, Path(tmp)).segment_run
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            rows = [r for cell in pool.map(case, cells) for r in cell]
    runs = len(rows)
    stops_total = sum(r["steps"] for r in rows) if not args.no_stop else 0
    missed = [r for r in rows if r["missed"]]
    silent = [r for r in missed if not r["doubts"]]
    wrong = [r for r in rows if r["wrong"]]
    wrong_silent = [r for r in wrong if not r["doubts"]]
    right_doubted = [r for r in rows if not r["wrong"] and r["doubts"]]
    print(f"runs {runs}, stops {stops_total}")
    if not args.no_stop:
        print(
            f"runs with a stop missed: {len(missed)}, of them with no doubt: {len(silent)} "
            f"(stops missed: {sum(len(r['missed']) for r in missed)})"
        )
    print(f"runs with any phase wrong: {len(wrong)}, of them with no doubt: {len(wrong_silent)}")
    print(f"runs right but doubted (false doubts): {len(right_doubted)}")
    hidden = [r for r in rows if any(_is_hidden_stop(d) for d in r["doubts"])]
    print(
        f"runs with a hidden-stop doubt: {len(hidden)}: on a run with a stop missed "
        f"{sum(bool(r['missed']) for r in hidden)}, with any phase wrong "
        f"{sum(bool(r['wrong']) for r in hidden)}, on a right run "
        f"{sum(not r['wrong'] for r in hidden)}"
    )
    if not args.no_stop:
        print(
            "runs with a stop missed and no hidden-stop doubt: "
            f"{sum(not any(_is_hidden_stop(d) for d in r['doubts']) for r in missed)}"
        )
    by = {}
    for r in missed:
        key = (r["speed_mps"], r["ripple_W"], r["stop_s"])
        by.setdefault(key, [0, 0])
        by[key][0] += 1
        by[key][1] += not r["doubts"]
    kinds = {}
    for r in missed:
        for kind in r["kinds"]:
            kinds.setdefault(kind, [0, 0])
            kinds[kind][0] += 1
            kinds[kind][1] += not r["doubts"]
    for kind, (n, quiet) in sorted(kinds.items()):
        print(f"stops missed into {kind}: {n}, in runs with no doubt: {quiet}")
    for key in sorted(by):
        print(
            f"  v {key[0]} m/s, ripple {key[1]} W, stop {key[2]} s: missed {by[key][0]}, "
            f"silent {by[key][1]}"
        )
    if args.list:
        for r in rows:
            if r["wrong"] or r["doubts"]:
                print(
                    f"{r['level']:5} seed {r['seed']} {r['run_id']:28} v {r['speed_mps']} "
                    f"d {r['distance_m']} ripple {r['ripple_W']} stop {r['stop_s']} "
                    f"missed {r['missed']} wrong {r['wrong']} doubts {len(r['doubts'])}: "
                    + " | ".join(d[:70] for d in r["doubts"] if _is_hidden_stop(d))
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
