"""docs/benchmarks.md from the figures of `benchmarks/run.py`, and its summary for the terminal.

The measured part is written again at every run; the text below MARKER is kept.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "benchmarks.md"
MARKER = "<!-- hand-written below: kept by make bench -->"
#: issue 14's targets: on every shape, fit <= 1.2x and diagnose <= 2x the bare parse
TARGET = {"fit": 1.2, "diagnose": 2.0}
#: issue 14: segmentation <= 10% of fit_logs in the profile of the power-only corpus
SEGMENTATION_SHARE = 0.10


#: issue 25: `fit` of a free-driving corpus within 1.5x the bare parse (the `drive` shape)
DRIVE_TARGET = 1.5


def worst(rows: list[dict], what: str, key: str = "ratio") -> dict:
    """The row of the largest ratio among the shapes that time `what` (the free-driving shape
    has no diagnose)."""
    return max(
        (r for r in rows if r.get(f"{what}_{key}") is not None),
        key=lambda r: r[f"{what}_{key}"],
    )


def _grid_rows(rows: list[dict]) -> list[dict]:
    """The paper's grid shapes (issue 14's targets), not free driving (issue 25's)."""
    return [r for r in rows if r["shape"] != "drive"] or rows


def _met(value: float, target: float) -> str:
    return "met" if value <= target else "not met"


def headline(rows: list[dict], extras: dict) -> list[str]:
    """The worst shape's ratios, against issue 14's targets."""
    lines = []
    drive = [r for r in rows if r["shape"] == "drive"]
    grid = _grid_rows(rows)
    for what in ("fit", "diagnose"):
        if not any(r.get(f"{what}_ratio") is not None for r in grid):
            continue
        w = worst(grid, what)
        c = worst(grid, what, "cpu_ratio")
        lines.append(
            f"- **`wbpower {what}`: {w[f'{what}_ratio']:.2f}x the bare parse** (wall, worst shape: "
            f"{w['shape']}); CPU: {c[f'{what}_cpu_ratio']:.2f}x (worst: {c['shape']}). "
            f"Target <= {TARGET[what]:g}x on every shape: {_met(w[f'{what}_ratio'], TARGET[what])} "
            f"(wall), {_met(c[f'{what}_cpu_ratio'], TARGET[what])} (CPU)."
        )
    for r in drive:
        lines.append(
            f"- **`wbpower fit` of free driving (drive model): {r['fit_ratio']:.2f}x the bare "
            f"parse** (wall); CPU: {r['fit_cpu_ratio']:.2f}x. Target <= {DRIVE_TARGET:g}x "
            f"(issue 25): {_met(r['fit_ratio'], DRIVE_TARGET)} (wall), "
            f"{_met(r['fit_cpu_ratio'], DRIVE_TARGET)} (CPU)."
        )
    share = segmentation_share(extras)
    if share is not None:
        timed = timed_segmentation_share(extras)
        unprofiled = (
            f"; {100 * timed:.0f}% timed without a profiler ({_met(timed, SEGMENTATION_SHARE)})"
            if timed is not None
            else ""
        )
        lines.append(
            f"- **Segmentation: {100 * share:.0f}% of `fit_logs`** (cProfile, 1 job, "
            f"{extras['profile_shape']} corpus). Target <= {100 * SEGMENTATION_SHARE:.0f}%: "
            f"{_met(share, SEGMENTATION_SHARE)}{unprofiled}."
        )
    if "copies" in extras:
        shape = extras["shape"]
        row = next(r for r in rows if r["shape"] == shape)
        rss = [c["max_rss_MB"] for c in extras["copies"]] + [row["fit_max_rss_MB"]]
        budget = extras["fixed"]["max_rss_MB"] + 2 * row["largest_file_columns_MB"]
        lines.append(
            f"- Memory ({shape}): the largest `fit` process peaks at {min(rss):.0f}-"
            f"{max(rss):.0f} MB from {extras['copies'][0]['logs']} logs to {row['files']}; "
            f"budget (fixed overhead + 2 x the largest log's columns) {budget:.0f} MB: "
            f"{_met(max(rss), budget)}."
        )
    if "warm" in extras:
        lines.append(
            f"- Warm parse cache: {extras['warm']['speedup']:.1f}x faster than cold "
            f"({extras['shape']}; target >= 10x: "
            f"{'met' if extras['warm']['speedup'] >= 10 else 'not met'}); the warm result is "
            f"{'identical to' if extras['warm']['identical'] else 'NOT the same as'} the cold one."
        )
    return lines


def segmentation_share(extras: dict) -> float | None:
    profile = extras.get("profile_fit")
    if not profile:
        return None
    stages = profile["stages"]
    whole, seg = stages["fit_logs (whole, 1 job)"], stages["segmentation (segment_run)"]
    return seg / whole if whole and seg is not None else None


def timed_segmentation_share(extras: dict) -> float | None:
    timed = extras.get("timed_fit")
    if not timed or not timed["whole_cpu_s"]:
        return None
    return timed["stages"]["segmentation (segment_run)"] / timed["whole_cpu_s"]


def summary(rows: list[dict], extras: dict) -> str:
    """The per-shape ratios and the headline, for the terminal (80 columns)."""
    out = ["", f"{'shape':9s} {'MB':>5s} {'bare s':>7s} {'fit s':>6s} {'diag s':>7s} "
           f"{'fit/bare':>9s} {'diag/bare':>10s} {'(CPU)':>11s}"]  # fmt: skip
    for r in rows:
        out.append(
            f"{r['shape']:9s} {r['csv_MB']:5.0f} {r['bare_s']:7.2f} {r['fit_s']:6.2f} "
            f"{_num(r['diagnose_s']):>7s} {r['fit_ratio']:9.2f} {_num(r['diagnose_ratio']):>10s} "
            f"{r['fit_cpu_ratio']:5.2f} {_num(r['diagnose_cpu_ratio']):>5s}"
        )
    out.append("")
    for line in headline(rows, extras):
        plain = line.replace("**", "").replace("`", "")
        out += textwrap.wrap(plain, 80, subsequent_indent="  ")
    return "\n".join(out)


def _num(x: float | None, d: int = 2) -> str:
    return "—" if x is None else f"{x:.{d}f}"


def write(record: dict) -> None:
    """docs/benchmarks.md from a run's record (what `run.py` writes to last-bench.json)."""
    info, rows, extras, quick = record["machine"], record["rows"], record["extras"], record["quick"]
    lines = [
        "# Benchmarks: `wbpower fit` and `diagnose` beside a bare CSV parse",
        "",
        *textwrap.wrap(
            "Written by `make bench` (benchmarks/run.py) on "
            f"{record['measured_at']}"
            + (" with `--quick` (a subset: not the figures that count)" if quick else "")
            + ". Re-run it to refresh this page.",
            96,
        ),
        "",
        "## Headline",
        "",
        *[
            wrapped
            for line in headline(rows, extras)
            for wrapped in textwrap.wrap(line, 96, subsequent_indent="  ", break_on_hyphens=False)
        ],
        "",
        "The worst shape counts (issue 14). Times are medians of alternating runs in one session",
        "(bare, fit, diagnose; the order rotates each repeat); each run is a fresh process",
        "(interpreter start and imports included) reading the files from the OS page cache,",
        "with wbpower's bytecode compiled first, as a pip install leaves it.",
        "CPU is the user + system time of all the command's processes (workers included): it",
        "moves less than wall time when other work shares the machine (see the load averages).",
        "",
        "## Machine",
        "",
        "| | |",
        "| --- | --- |",
        *[f"| {k} | {v} |" for k, v in info.items()],
        "",
        "## fit and diagnose against the bare parse, per shape",
        "",
        "Corpora: `benchmarks/corpora.py` (the paper's grid simulated by wbpower, one layout per",
        "shape, and `drive`: free driving by `wbpower simulate --drive free --realism field`,",
        "timed for `fit` only; its docstring has the details). Bare parse:",
        "`pyarrow.csv.read_csv` of every log, multi-threaded, after its `#` metadata or N6705",
        "preamble lines; a `.gz` is decompressed by pyarrow as it reads.",
        "",
        "| | " + " | ".join(str(r["shape"]) for r in rows) + " |",
        "| --- | " + " | ".join("---:" for _ in rows) + " |",
    ]

    def row(label: str, key: str, fmt=_num) -> None:
        cells = ("—" if r.get(key) is None else fmt(r[key]) for r in rows)
        lines.append(f"| {label} | " + " | ".join(cells) + " |")

    def runs(xs: list[float]) -> str:
        return ", ".join(f"{x:.1f}" for x in xs)

    row("layout", "description", str)
    row("sample period [ms]", "sample_period_ms", lambda x: f"{x:g}")
    row("logs", "files", str)
    row("CSV [MB]", "csv_MB", lambda x: f"{x:.0f}")
    row("on disk [MB]", "disk_MB", lambda x: f"{x:.0f}")
    row("samples", "samples", lambda x: f"{x:,}")
    row("CSV bytes a sample", "bytes_per_sample", lambda x: f"{x:.1f}")
    row("bare `pyarrow.csv.read_csv` [s]", "bare_s")
    row("`wbpower fit --jobs 0`, cold [s]", "fit_s")
    row("`wbpower diagnose --jobs 0` [s]", "diagnose_s")
    row("**fit / bare parse**", "fit_ratio", lambda x: f"**{x:.2f}**")
    row("**diagnose / bare parse**", "diagnose_ratio", lambda x: f"**{x:.2f}**")
    row("bare parse, CPU [s]", "bare_cpu_s")
    row("fit, CPU of all its processes [s]", "fit_cpu_s")
    row("diagnose, CPU of all its processes [s]", "diagnose_cpu_s")
    row("fit / bare parse, CPU", "fit_cpu_ratio")
    row("diagnose / bare parse, CPU", "diagnose_cpu_ratio")
    row("bare parse [MB/s of CSV]", "bare_MBps", lambda x: f"{x:.0f}")
    row("fit [MB/s]", "fit_MBps", lambda x: f"{x:.0f}")
    row("diagnose [MB/s]", "diagnose_MBps", lambda x: f"{x:.0f}")
    row("bare runs [s]", "bare_runs_s", runs)
    row("fit runs [s]", "fit_runs_s", runs)
    row("diagnose runs [s]", "diagnose_runs_s", runs)
    row("runs fitted", "fit_n_runs", str)
    row("runs skipped by fit", "fit_skipped", str)
    row("runs diagnosed", "diagnose_n_runs", str)
    row("findings (the corpora have no effect)", "diagnose_findings", str)
    row("largest log's columns in memory [MB]", "largest_file_columns_MB", lambda x: f"{x:.0f}")
    row("bare: peak RSS [MB]", "bare_max_rss_MB", lambda x: f"{x:.0f}")
    row("fit: largest process RSS [MB]", "fit_max_rss_MB", lambda x: f"{x:.0f}")
    row("fit: peak PSS of all its processes [MB]", "fit_tree_pss_MB", lambda x: f"{x:.0f}")
    row("diagnose: largest process RSS [MB]", "diagnose_max_rss_MB", lambda x: f"{x:.0f}")
    row("diagnose: peak PSS, all processes [MB]", "diagnose_tree_pss_MB", lambda x: f"{x:.0f}")
    lines.append("")
    lines += _extras(rows, extras)
    lines += [
        "## How to reproduce",
        "",
        "```",
        "make bench                   # everything: ~4 min on 2 idle cores (corpora built once)",
        ".venv/bin/python benchmarks/run.py --quick   # a subset, 1 repeat, for iterating",
        ".venv/bin/python benchmarks/run.py --shapes power,n6705 --repeats 5",
        ".venv/bin/python benchmarks/corpora.py --list   # the shapes; --root DIR to build them",
        "```",
        "",
        "The corpora go to `$WBPOWER_BENCH_CORPUS` (else `bench_corpus/`); each is built once and",
        "again only when its parameters change. The figures are also written to",
        "`last-bench.json` there.",
        "",
    ]
    DOC.write_text(_with_notes("\n".join(lines)))
    print(f"bench: wrote {DOC}")


def _extras(rows: list[dict], extras: dict) -> list[str]:
    lines: list[str] = []
    if "fixed" in extras:
        shape = extras["shape"]
        row = next(r for r in rows if r["shape"] == shape)
        fixed = extras["fixed"]
        columns = row["largest_file_columns_MB"]
        lines += [
            f"## Memory ({shape})",
            "",
            f"Fixed overhead: `wbpower fit --jobs 1` on one tiny log peaks at "
            f"{fixed['max_rss_MB']:.0f} MB RSS",
            f"({fixed['wall_s']:.2f} s: the interpreter, numpy, pandas, pyarrow, typer, rich).",
            "Budget per process: fixed overhead + 2 x the largest log's columns = "
            f"{fixed['max_rss_MB']:.0f} + 2 x {columns:.0f} = "
            f"{fixed['max_rss_MB'] + 2 * columns:.0f} MB.",
            "",
            "`fit --jobs 0` over the N largest logs of the corpus (the largest log is in every",
            "set, so memory that grows with N would be memory held per file):",
            "",
            "| logs | CSV [MB] | wall [s] | CPU [s] | largest process RSS [MB] | "
            "peak PSS, all processes [MB] |",
            "| ---: | ---: | ---: | ---: | ---: | ---: |",
            *[
                f"| {c['logs']} | {c['MB']:.0f} | {c['wall_s']:.1f} | {c['cpu_s']:.1f} | "
                f"{c['max_rss_MB']:.0f} | {c['tree_pss_MB']:.0f} |"
                for c in extras["copies"]
            ],
            f"| {row['files']} (all) | {row['csv_MB']:.0f} | {row['fit_s']:.1f} | "
            f"{row['fit_cpu_s']:.1f} | {row['fit_max_rss_MB']:.0f} | "
            f"{row['fit_tree_pss_MB']:.0f} |",
            "",
        ]
    if "warm" in extras:
        warm, lib = extras["warm"], extras["library"]
        lines += [
            f"## Parse cache ({extras['shape']})",
            "",
            "| | |",
            "| --- | ---: |",
            f"| `fit --jobs 0`, cold (median above) [s] | {warm['cold_s']:.2f} |",
            f"| `fit --cache DIR`, first run (fills it) [s] | {warm['fill_s']:.2f} |",
            f"| `fit --cache DIR`, warm [s] | {warm['warm_s']:.2f} |",
            f"| `fit --cache DIR`, warm, CPU [s] | {warm['warm_cpu_s']:.2f} |",
            f"| warm runs [s] | {', '.join(f'{x:.2f}' for x in warm['warm_runs_s'])} |",
            f"| **cold / warm** | **{warm['speedup']:.1f}x** |",
            f"| cache size [MB] | {warm['cache_MB']:.0f} |",
            f"| warm result identical to cold | {warm['identical']} |",
            f"| `fit_logs()` after imports, cold [s] | {lib['cold_s']:.2f} |",
            f"| `fit_logs(cache=...)`, filling [s] | {lib['fill_s']:.2f} |",
            f"| `fit_logs(cache=...)`, warm [s] | {lib['warm_s']:.3f} |",
            f"| **cold / warm, after imports** | **{lib['speedup']:.0f}x** |",
            "",
        ]
    for what in ("fit", "diagnose", "fit_drive"):
        profile = extras.get(f"profile_{what}")
        if not profile:
            continue
        stages = profile["stages"]
        whole = next(iter(stages.values()))
        shape = "drive" if what == "fit_drive" else extras["profile_shape"]
        what = what.removesuffix("_drive")
        lines += [
            f"## Where the time goes: `{what}` ({shape}, cProfile, 1 job)",
            "",
            "Cumulative seconds (profiling adds overhead, most to code with many small calls).",
            f"Importing `wifibot_power.{what}` took {profile['import_s']:.2f} s before.",
            "",
            f"| stage | s | share of {'fit_logs' if what == 'fit' else 'diagnose_logs'} |",
            "| --- | ---: | ---: |",
            *[
                f"| {label.strip()} | {_num(s)} | "
                + ("not found |" if s is None else f"{100 * s / whole:.0f}% |")
                for label, s in stages.items()
            ],
            "",
            *textwrap.wrap(
                "Most own time (tottime, wifibot_power functions): "
                + "; ".join(f"`{name}` {s:.2f} s" for name, s in profile["top_own_s"][:6])
                + ".",
                96,
                break_on_hyphens=False,
            ),
            "",
        ]
        timed = extras.get("timed_fit") if what == "fit" and shape != "drive" else None
        if timed:
            cpu = timed["whole_cpu_s"]
            lines += [
                f"The same stages of `fit_logs` timed by CPU time around each call, without a "
                f"profiler ({extras['profile_shape']}, 1 job, the second of two runs):",
                "",
                "| stage | CPU s | share of fit_logs |",
                "| --- | ---: | ---: |",
                f"| fit_logs (whole, 1 job) | {cpu:.2f} | 100% |",
                *[
                    f"| {label.strip()} | {s:.2f} | {100 * s / cpu:.0f}% |"
                    for label, s in timed["stages"].items()
                ],
                "",
            ]
    return lines


def _with_notes(table: str) -> str:
    """The measured part, then the hand-written part of the page kept from the existing file."""
    notes = ""
    if DOC.is_file() and MARKER in DOC.read_text():
        notes = DOC.read_text().split(MARKER, 1)[1]
    return f"{table}\n{MARKER}{notes}"
