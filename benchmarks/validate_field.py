"""Validation of `wbpower diagnose` at field realism, on data from the independent generator
(`tests/fieldgen.py`), for docs/diagnose.md ("Validation at field realism").

Suites (seeds stated; diagnose sees only the runs):
- off-catalogue: each of fieldgen's seven effects no cause of causes.md names, seeds 1-5:
  how often a catalogue name is forced onto it (goal: none in >= 95% of batches), how often
  `unexplained: true` (goal >= 90%), and how often the replication tests alone flag the
  paper-form model's held-out errors (what `residuals.py` sees when no name is forced);
- catalogue: the null and each cause in fieldgen's other physical forms, seeds 1-8, and
  every pair at seed 1: named exactly, unexplained, own and overall held-out gain;
- false alarms: the null robot, fieldgen seeds 101-124 and `simulate --realism field` on
  the test grid, seeds 201-240: how often anything is named, how often `unexplained`;
- jerk-limited ramps (50 ms), null, seeds 1-3: what segmentation does with them.

fieldgen's grid: speeds 0.1, 0.3, 0.5, 0.7, 0.9 m/s x (2 m, 10 m, 10 m in 10 steps) x 2
repeats + 2 idle runs (30 motion runs; 60 with payloads 0 and 3 kg), at 1 kHz (the
analyser's 0.1024 ms samples averaged: the tests' statistics are run energies and phase
means, which do not depend on the rate; the PWM tone then folds to 0-10 Hz, as it would).
About 15 minutes on 2 idle cores; `--quick` (3 seeds per effect, 4 per cause, 8 null
seeds, no pairs) about a third of that.

    .venv/bin/python benchmarks/validate_field.py [--quick] [--off-seeds=N]
"""

from __future__ import annotations

import itertools
import multiprocessing
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

import fieldgen  # noqa: E402
from test_diagnose import GRID  # noqa: E402

from wifibot_power import diagnose, residuals  # noqa: E402
from wifibot_power.simulate import SimConfig, realism, simulate_runs  # noqa: E402

ENERGY_CAUSES = [c for c in fieldgen.CATALOGUE if c != "cruise_ripple"]


def _baseline_flags(result) -> list[str]:
    """The replication tests on the paper-form model's held-out errors (no cause named)."""
    table = diagnose.replication_table(result.runs, "baseline_energy_J")
    return [r.test for r in residuals.found(residuals.replication_tests(table))]


def case(args: tuple[str, str, tuple[str, ...], int, float]) -> dict:
    suite, label, hidden, seed, jerk_s = args
    started = time.perf_counter()
    if suite == "simulate":
        config = SimConfig(**GRID, seed=seed, **realism("field"))
        runs = [s.run for s in simulate_runs(config)]
        effects: dict[str, float] = {}
    else:
        effects = {k: fieldgen.sizes(k, seed) for k in hidden}
        batch = fieldgen.Batch(effects=effects, seed=seed, jerk_s=jerk_s)
        runs = fieldgen.to_runs(fieldgen.generate(batch))
    try:
        result = diagnose.diagnose_runs(runs)
    except Exception as exc:  # a batch diagnose cannot take is a result too
        return {"suite": suite, "label": label, "seed": seed, "error": str(exc)[:120]}
    named = [f.cause for f in result.findings]
    ratios = {
        f.cause: f.estimate["value"] / effects[f.cause]
        for f in result.findings
        if f.cause in effects
    }
    return {
        "suite": suite,
        "label": label,
        "seed": seed,
        "error": None,
        "named": named,
        "exact": sorted(named) == sorted(hidden),
        "unexplained": result.unexplained,
        "reasons": list(result.unexplained_reasons),
        "baseline_flags": _baseline_flags(result),
        "own_gains": {f.cause: f.gain_pct for f in result.findings},
        "gain_pct": result.gain_pct,
        "ratios": ratios,
        "seconds": time.perf_counter() - started,
    }


def cases(
    off_seeds: int = 5, seeds: int = 8, null_seeds: int = 24, pairs: bool = True
) -> list[tuple[str, str, tuple[str, ...], int, float]]:
    out = []
    for kind in fieldgen.OFF_CATALOGUE:
        out += [("off", kind, (kind,), seed, 0.0) for seed in range(1, off_seeds + 1)]
    out += [("catalogue", "nothing", (), seed, 0.0) for seed in range(1, seeds + 1)]
    for cause in fieldgen.CATALOGUE:
        out += [("catalogue", cause, (cause,), seed, 0.0) for seed in range(1, seeds + 1)]
    if pairs:
        for a, b in itertools.combinations(fieldgen.CATALOGUE, 2):
            out.append(("catalogue", "pairs (15, seed 1)", (a, b), 1, 0.0))
    out += [("null", "fieldgen null", (), s, 0.0) for s in range(101, 101 + null_seeds)]
    out += [("simulate", "simulate --realism field", (), seed, 0.0) for seed in range(201, 241)]
    out += [("jerk", "null, jerk-limited ramps (50 ms)", (), 1, 0.05)]
    return out


def _span(values: list[float]) -> str:
    if not values:
        return "-"
    low, high = (round(v, 1) + 0.0 for v in (min(values), max(values)))
    return f"{low:.1f}%" if low == high else f"{low:.1f}-{high:.1f}%"


def main(argv: list[str] | None = None) -> None:
    """argv: `--quick` runs 3 seeds per off-catalogue kind, 4 per cause, 8 null seeds and
    no pairs (for a loaded machine; the tables then say so by their counts)."""
    argv = argv if argv is not None else sys.argv[1:]
    quick = "--quick" in argv
    todo = cases(3, 4, 8, False) if quick else cases()
    # --off-seeds N: the off-catalogue suite alone, seeds 1..N per effect (its false-name
    # rate measured on more batches than the 5 a full run spends)
    off = [a for a in argv if a.startswith("--off-seeds")]
    if off:
        value = off[-1].partition("=")[2]
        if not value.isdigit() or int(value) < 1:
            raise SystemExit(f"validate_field.py: give --off-seeds=N (N >= 1), not {off[-1]!r}")
        todo = [c for c in cases(int(value), 0, 0, False) if c[0] == "off"]
    started = time.perf_counter()
    results = []
    with multiprocessing.Pool(2) as pool:
        for r in pool.imap(case, todo, chunksize=1):
            results.append(r)
            _print_case(r)
    print(f"\n{len(results)} batches in {time.perf_counter() - started:.0f} s\n")

    groups: dict[tuple[str, str], list[dict]] = {}
    for r in results:
        groups.setdefault((r["suite"], r["label"]), []).append(r)

    print(f"Off-catalogue effects (fieldgen, seeds {_seeds(results, 'off')}):\n")
    print(
        "| effect | no name forced | unexplained | replication tests flag the paper-form "
        "errors | names forced |"
    )
    print("| --- | --- | --- | --- | --- |")
    for (suite, label), rs in groups.items():
        if suite != "off":
            continue
        ok = [r for r in rs if not r["error"]]
        forced = sorted({c for r in ok for c in r["named"]})
        print(
            f"| {label} | {sum(not r['named'] for r in ok)}/{len(rs)} "
            f"| {sum(r['unexplained'] for r in ok)}/{len(rs)} "
            f"| {sum(bool(r['baseline_flags']) for r in ok)}/{len(rs)} "
            f"| {', '.join(forced) or '-'} |"
        )
    off = [r for r in results if r["suite"] == "off"]
    if off:
        ok = [r for r in off if not r["error"]]
        print(
            f"| all | {sum(not r['named'] for r in ok)}/{len(off)} "
            f"| {sum(r['unexplained'] for r in ok)}/{len(off)} "
            f"| {sum(bool(r['baseline_flags']) for r in ok)}/{len(off)} | |"
        )

    if not any(r["suite"] in ("catalogue", "null", "simulate") for r in results):
        return  # --off-seeds: the off-catalogue table alone
    print(
        "\nCatalogue causes in other physical forms (fieldgen, seeds "
        f"{_seeds(results, 'catalogue')}; pairs, when run, seed 1; jerk-limited seed 1):\n"
    )
    print(
        "| hidden | named exactly | unexplained | smallest own gain | overall gain, nested "
        "| estimate / size | other names |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for (suite, label), rs in groups.items():
        if suite not in ("catalogue", "jerk"):
            continue
        ok = [r for r in rs if not r["error"]]
        own = [g for r in ok for g in r["own_gains"].values()]
        ratios = [v for r in ok for v in r["ratios"].values()]
        hidden = set() if label.startswith(("nothing", "null", "pairs")) else {label}
        extra = sorted({c for r in ok for c in r["named"]} - hidden)
        if label.startswith("pairs"):
            extra = ["-"]
        errors = len(rs) - len(ok)
        print(
            f"| {label} | {sum(r['exact'] for r in ok)}/{len(rs)} "
            f"| {sum(r['unexplained'] for r in ok)}/{len(rs)} "
            f"| {_span(own)} | {_span([r['gain_pct'] for r in ok])} "
            f"| {f'{min(ratios):.2f}-{max(ratios):.2f}' if ratios else '-'} "
            f"| {', '.join(extra) or '-'}{f' ({errors} failed)' if errors else ''} |"
        )

    print("\nFalse alarms on the null robot at field realism:\n")
    print("| data | batches | anything named | unexplained | which test |")
    print("| --- | --- | --- | --- | --- |")
    for (suite, label), rs in groups.items():
        if suite not in ("null", "simulate"):
            continue
        ok = [r for r in rs if not r["error"]]
        tests = sorted({x.split(":")[0] for r in ok for x in r["reasons"]})
        print(
            f"| {label} | {len(rs)} | {sum(bool(r['named']) for r in ok)} "
            f"| {sum(r['unexplained'] for r in ok)} | {'; '.join(tests) or '-'} |"
        )


def _seeds(results: list[dict], suite: str) -> str:
    seeds = sorted({r["seed"] for r in results if r["suite"] == suite})
    return f"{seeds[0]}-{seeds[-1]}" if seeds else "-"


def _print_case(r: dict) -> None:
    if r["error"]:
        print(f"{r['label']:34s} seed {r['seed']:3d}: ERROR {r['error']}", flush=True)
        return
    print(
        f"{r['label']:34s} seed {r['seed']:3d}: named {r['named']} "
        f"unexplained {r['unexplained']} baseline flags {r['baseline_flags']} "
        f"gain {r['gain_pct']:.1f}% est/size {_fmt(r['ratios'])} ({r['seconds']:.0f} s)"
    )
    for reason in r["reasons"]:
        print(f"      {reason}")
    sys.stdout.flush()


def _fmt(ratios: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:.2f}" for k, v in ratios.items()) or "-"


if __name__ == "__main__":
    main()
