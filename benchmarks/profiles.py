"""Where the time goes: cProfile of `fit_logs` / `diagnose_logs` with 1 job (all the work in
one process, so the profiler sees it), and `fit_logs` timed from Python with and without the
parse cache. Each runs in a fresh interpreter; the numbers come back as JSON.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: stage label -> (file the function lives in, function name); the cumulative time of each.
#: A function renamed or moved shows as "not found", never as a stage that takes no time.
FIT_STAGES = {
    "fit_logs (whole, 1 job)": ("fit.py", "fit_logs"),
    "read_log": ("reader.py", "read_log"),
    "  CSV parse to numpy (read_columns)": ("transport.py", "read_columns"),
    "  sample checks (check_log_samples)": ("validate.py", "check_log_samples"),
    "segmentation (segment_run)": ("segment/__init__.py", "segment_run"),
    "run_row": ("runtable.py", "run_row"),
    "drive model's per-run statistics (drive_stats)": ("drive/stats.py", "drive_stats"),
    "fit of the run records (fit_records)": ("fit.py", "fit_records"),
    "  drive model (fit_drive_stats)": ("drive/model.py", "fit_drive_stats"),
}
#: the drive model's stages (the free-driving shape: `profile("fit", folder, drive=True)`)
DRIVE_STAGES = {
    # free driving is not segmented into the paper's phases (no step runs): not a stage there
    **{k: v for k, v in FIT_STAGES.items() if v[1] != "segment_run"},
    # the fit from the workers' per-trip sums (drive/lagsums.py; until the thirteenth session
    # lag_search, identify and heldout_accuracy over the windows: those are now the reference
    # path only, `fit_drive_stats(direct=True)`). The indented rows overlap (cumulative times:
    # the searches and identifications run inside the held-out folds, and lagsums.py's
    # `__init__`s are SumsTable's, LagSums' and SumMoments'), so they add up to more than
    # their parent row
    "  drive model's per-run windows (run_windows)": ("drive/windows.py", "run_windows"),
    "  drive model's per-trip sums (run_sums)": ("drive/sums.py", "run_sums"),
    "    sums laid out (lagsums.py __init__s; overlapping)": ("drive/lagsums.py", "__init__"),
    "    lag searches (FoldGrams.search; overlapping)": ("drive/gram.py", "search"),
    "    identifications (identify_moments; overlapping)": (
        "drive/identify.py",
        "identify_moments",
    ),
    "    held-out K-fold (heldout_from_sums)": ("drive/heldout.py", "heldout_from_sums"),
    "    the lag's interval (lag_interval)": ("drive/laginterval.py", "lag_interval"),
}
DIAGNOSE_STAGES = {
    "diagnose_logs (whole, 1 job)": ("diagnose/batch.py", "diagnose_logs"),
    "read_log": ("reader.py", "read_log"),
    "  CSV parse to numpy (read_columns)": ("transport.py", "read_columns"),
    "  sample checks (check_log_samples)": ("validate.py", "check_log_samples"),
    "per run (run_record)": ("record.py", "run_record"),
    "  segmentation (segment_run)": ("segment/__init__.py", "segment_run"),
    # until issue 24, "trace statistics (trace_stats)" and "causes' run statistics
    # (run_columns)": now every cause's, windows, spectrum and creep alike
    "  causes' run statistics (run_statistics)": ("causes/registry.py", "run_statistics"),
    "  run_row": ("runtable.py", "run_row"),
    "statistics over runs (diagnose_summaries)": ("diagnose/diagnosis.py", "diagnose_summaries"),
}

PROFILE = r"""
import cProfile, json, pstats, sys, time
from pathlib import Path
what, folder, stages = sys.argv[1], Path(sys.argv[2]), json.loads(sys.argv[3])
start = time.perf_counter()
if what == "fit":
    from wifibot_power.fit import fit_logs as call
else:
    from wifibot_power.diagnose import diagnose_logs as call
import_s = time.perf_counter() - start
profile = cProfile.Profile()
start = time.perf_counter()
profile.runcall(call, [folder], jobs=1)
wall_s = time.perf_counter() - start
stats = pstats.Stats(profile).stats
def cumulative(file_end, name):
    found = [v[3] for (f, _, n), v in stats.items() if f.endswith(file_end) and n == name]
    return sum(found) if found else None
own = {}
for (f, line, n), v in stats.items():
    if "wifibot_power" in f:
        key = f"{f.split('wifibot_power/', 1)[1]}:{n}"
        own[key] = own.get(key, 0.0) + v[2]
top = sorted(own.items(), key=lambda kv: -kv[1])[:10]
print(json.dumps({
    "import_s": import_s,
    "wall_s": wall_s,
    "stages": {label: cumulative(*where) for label, where in stages.items()},
    "top_own_s": top,
}))
"""

#: the modules of the files `FIT_STAGES` names, for `timed_shares`
_MODULES = {
    "reader.py": "wifibot_power.io.reader",
    "transport.py": "wifibot_power.io.transport",
    "validate.py": "wifibot_power.io.validate",
    "segment/__init__.py": "wifibot_power.segment",
    "runtable.py": "wifibot_power.runtable",
}
#: stage label -> (module, function) timed by `timed_shares`, CPU time, no profiler: the
#: per-file stages of `FIT_STAGES`, under the same labels
TIMED_STAGES = {
    label: (_MODULES[file], name) for label, (file, name) in FIT_STAGES.items() if file in _MODULES
}

TIMED = r"""
import importlib, json, sys, time
from pathlib import Path
folder, stages = Path(sys.argv[1]), json.loads(sys.argv[2])
from wifibot_power.fit import fit_logs
spent = dict.fromkeys(stages, 0.0)
swaps = []
for label, (module, name) in stages.items():
    original = getattr(importlib.import_module(module), name)
    def timed(*args, _original=original, _label=label, **kwargs):
        start = time.process_time()
        try:
            return _original(*args, **kwargs)
        finally:
            spent[_label] += time.process_time() - start
    swaps.append((original, timed))
# every name bound to a stage's function in wifibot_power's modules, the defining one too
for module in [m for n, m in sys.modules.items() if n.startswith("wifibot_power")]:
    for attr, value in list(vars(module).items()):
        for original, timed in swaps:
            if value is original:
                setattr(module, attr, timed)
fit_logs([folder], jobs=1)  # the page cache and lazy imports warmed
spent = dict.fromkeys(stages, 0.0)
start = time.process_time()
fit_logs([folder], jobs=1)
whole = time.process_time() - start
print(json.dumps({"whole_cpu_s": whole, "stages": spent}))
"""

LIBRARY = r"""
import json, shutil, statistics, sys, tempfile, time
from pathlib import Path
from wifibot_power.cache import ParseCache
from wifibot_power.fit import fit_logs
folder, scratch = Path(sys.argv[1]), Path(sys.argv[2])
def timed(**kw):
    start = time.perf_counter()
    fit_logs([folder], jobs=0, **kw)
    return time.perf_counter() - start
cold = [timed() for _ in range(2)]
cache = ParseCache(Path(tempfile.mkdtemp(dir=scratch)))
fill = timed(cache=cache)
warm = [timed(cache=cache) for _ in range(3)]
shutil.rmtree(cache.directory)
print(json.dumps({"cold_s": statistics.median(cold), "fill_s": fill,
                  "warm_s": statistics.median(warm)}))
"""


def _run(script: str, *args: str) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", script, *args], capture_output=True, text=True, cwd=ROOT
    )
    if out.returncode != 0:
        raise SystemExit(f"bench: profiling failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout)


def profile(what: str, folder: Path, *, drive: bool = False) -> dict:
    """cProfile of `fit_logs` (`what` "fit") or `diagnose_logs` ("diagnose") over `folder`,
    1 job: {"import_s", "wall_s", "stages": {label: cumulative s or None}, "top_own_s"}.
    `drive`: the drive model's stages too (a free-driving corpus)."""
    stages = (DRIVE_STAGES if drive else FIT_STAGES) if what == "fit" else DIAGNOSE_STAGES
    result = _run(PROFILE, what, str(folder), json.dumps(stages))
    missing = [label.strip() for label, s in result["stages"].items() if s is None]
    if missing:
        print(f"bench: WARNING: no time found for {missing}: renamed? (benchmarks/profiles.py)")
    return result


def timed_shares(folder: Path) -> dict:
    """`fit_logs` over `folder` with 1 job, its stages timed by CPU time around each call
    (`TIMED_STAGES`), no profiler: cProfile charges every call, so it inflates the share of
    code made of many small calls (segmentation) against one long call (the parse).
    {"whole_cpu_s", "stages": {label: CPU s}}."""
    return _run(TIMED, str(folder), json.dumps(TIMED_STAGES))


def library_times(folder: Path, scratch: Path) -> dict[str, float]:
    """`fit_logs` called from Python, timed after the imports (what a notebook or a CI job
    that fits several corpora in one process sees): cold, filling the cache, warm."""
    return _run(LIBRARY, str(folder), str(scratch))
