"""The one pipeline (issue 24): what each command asks of a run (`RunPlan`), the run of
unknown mode said once, the cache's copy of a record, and `--cache` on diagnose and report."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest

from wifibot_power.io import read_log
from wifibot_power.pipeline import (
    DIAGNOSE_PLAN,
    FIT_PLAN,
    REPORT_PLAN,
    gather,
    record,
    run_record,
)
from wifibot_power.pipeline.record import record_from_json, record_to_json

SAMPLE_LOGS = Path(__file__).resolve().parents[1] / "sample_logs"
#: 8 motion runs at 2 speeds (enough to diagnose) and an idle run
DIAGNOSABLE = [
    f"v{v}_d10_s{s}_r{r}.csv.gz" for v in ("0.30", "0.90") for s in (1, 10) for r in (1, 2)
] + ["idle_r1.csv.gz"]


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("pipeline")
    for name in DIAGNOSABLE:
        shutil.copy(SAMPLE_LOGS / name, folder / name)
    return folder


@pytest.fixture(scope="module")
def unknown_log(tmp_path_factory) -> Path:
    """The idle log with its mode line removed: mode unknown."""
    import gzip

    text = gzip.decompress((SAMPLE_LOGS / "idle_r1.csv.gz").read_bytes()).decode()
    path = tmp_path_factory.mktemp("unknown") / "nomode.csv"
    path.write_text("\n".join(line for line in text.split("\n") if line != "# mode: idle"))
    return path


def test_a_run_of_unknown_mode_is_not_segmented_for_fit_and_has_no_phases(
    unknown_log, monkeypatch
) -> None:
    run = read_log(unknown_log)
    assert run.meta.mode == "unknown"
    segmented = []
    real = record.segment_checked
    monkeypatch.setattr(record, "segment_checked", lambda r, s=None: segmented.append(1) or real(r))
    fitted = run_record(run, FIT_PLAN)
    assert segmented == [] and fitted.phases == () and fitted.row["steps_found"] == 0
    assert not fitted.row["usable"] and "no mode or speed" in fitted.row["skip_reason"]
    # the report segments it (its trace is drawn) but its row is the same: made from no phases
    drawn = run_record(run, REPORT_PLAN)
    assert segmented == [1] and drawn.view is not None and len(drawn.view.phases) > 0
    assert drawn.phases == () and json.dumps(drawn.row, default=str) == json.dumps(
        fitted.row, default=str
    )


def test_each_plan_computes_what_its_command_needs(logs) -> None:
    run = read_log(logs / "v0.30_d10_s1_r1.csv.gz")
    idle = read_log(logs / "idle_r1.csv.gz")
    fit, diagnose, report = (run_record(run, p) for p in (FIT_PLAN, DIAGNOSE_PLAN, REPORT_PLAN))
    assert fit.phases and fit.models and not fit.causes and not fit.traces and fit.view is None
    assert not diagnose.phases and diagnose.causes and diagnose.traces
    assert report.phases and report.causes and report.traces and report.view
    # one row whatever the plan (the numbers the fit and the diagnosis read are the same)
    for other in (diagnose, report):
        assert all(
            (math.isnan(v) and math.isnan(other.row[k]))
            if isinstance(v, float) and math.isnan(v)
            else other.row[k] == v
            for k, v in fit.row.items()
        )
    # diagnose does not segment a run that is not motion; its causes are motion runs' only
    assert run_record(idle, DIAGNOSE_PLAN).row["steps_found"] == 0
    assert not run_record(idle, REPORT_PLAN).causes


def test_a_record_round_trips_through_the_cache_exactly(logs) -> None:
    for name in ("v0.90_d10_s10_r1.csv.gz", "idle_r1.csv.gz"):
        kept = run_record(read_log(logs / name), FIT_PLAN.kept)
        back = record_from_json(json.loads(json.dumps(record_to_json(kept))))
        assert json.dumps(record_to_json(back)) == json.dumps(record_to_json(kept))
        assert back.row["started_at"] == kept.row["started_at"] and back.phases == kept.phases


def test_gather_keeps_one_record_per_log_in_order(logs) -> None:
    gathered = gather([logs], jobs=2)
    assert [r.row["file"] for r in gathered.records] == sorted(
        str(p) for p in logs.glob("*.csv.gz")
    )
    assert gathered.skipped == []


@pytest.mark.parametrize("command", ["diagnose", "report"])
def test_diagnose_and_report_take_cache(logs, wbpower, tmp_path, monkeypatch, command) -> None:
    """`--cache` on diagnose and report (as on fit): the same answer cold and warm, and a
    warm run parses nothing."""

    def answer(*extra: object) -> dict:
        out = ("-o", tmp_path / f"out{len(extra)}") if command == "report" else ()
        result = wbpower(command, logs, "--json", "--jobs", "1", *out, *extra)
        assert result.exit_code == 0, result.stderr
        document = json.loads(result.stdout)
        if command == "report":  # where it was written differs
            document = {
                k: v for k, v in document.items() if k not in ("report", "figures", "written")
            }
        return document

    plain = answer()
    cache = tmp_path / "cache"
    assert answer("--cache", cache) == plain
    from wifibot_power.io import reader

    monkeypatch.setattr(reader, "read_log", lambda *a, **k: pytest.fail("parsed"))
    assert answer("--cache", cache) == plain


def test_no_module_imports_another_modules_private_name() -> None:
    """What one module needs of another is public (issue 24: `fit._import_work_modules` was
    imported by diagnose and report); checked over every import, function-level included.
    A subpackage's modules may share its underscore names among themselves (package-private:
    `segment/` split one module into several), never with the rest of the package."""
    import ast

    package = Path(__file__).resolve().parents[1] / "wifibot_power"
    found = []
    for source in sorted(package.rglob("*.py")):
        for node in ast.walk(ast.parse(source.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("wifibot_"):
                names = [a.name for a in node.names]
                private = [n for n in names if n.startswith("_") and not n.endswith("__")]
                here = source.relative_to(package).parent.parts
                if here and node.module.split(".")[1 : 1 + len(here)] == list(here):
                    continue  # within its own subpackage
                found += [f"{source.relative_to(package)}: {node.module}.{n}" for n in private]
    assert found == []


def test_preload_imports_the_drive_package_only_for_a_plan_with_model_statistics() -> None:
    """`preload_work` loads what the plan's workers import before they fork: the drive model's
    package for `fit` (its family's statistics), not for `diagnose` (no family statistics:
    ~20 ms of CPU it does without)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from wifibot_power.pipeline import preload, record\n"
        "preload.preload_work(record.{plan})\n"
        "print('wifibot_power.drive' in sys.modules, 'wifibot_power.segment' in sys.modules)\n"
    )
    for plan, loaded in (("DIAGNOSE_PLAN", "False True"), ("FIT_PLAN", "True True")):
        out = subprocess.run(
            [sys.executable, "-c", code.format(plan=plan)], capture_output=True, text=True
        )
        assert out.stdout.split() == loaded.split(), out.stderr


def test_the_benchmarks_switch_for_new_work_switches_it_off() -> None:
    """benchmarks/new_work_off.py (issue 24's timing of the code without the work c6b8187 did
    not do): with `drive` off, `fit` of step runs has no drive model; with nothing off, the
    same command has one; an unknown switch is refused."""
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    script = [sys.executable, str(root / "benchmarks" / "new_work_off.py")]
    command = ["fit", str(root / "sample_logs"), "--json", "--jobs", "1"]

    def drive(off: str) -> object:
        done = subprocess.run(
            script + command,
            capture_output=True,
            text=True,
            env={**os.environ, "WBPOWER_OFF": off},
        )
        return json.loads(done.stdout).get("drive")

    assert drive("") is not None
    assert drive("check,drive,pieces") is None
    refused = subprocess.run(
        script + command, capture_output=True, text=True, env={**os.environ, "WBPOWER_OFF": "x"}
    )
    assert refused.returncode != 0 and "unknown" in refused.stderr
