#!/usr/bin/env python3
"""`wbpower` with work that c6b8187 did not do switched off, to time the rest against it
(issue 24, docs/benchmarks.md "Issue 24 in the thirteenth session"). For benchmarks only:
the answers differ (no drive model of step runs, no piece or power-twice problems).

`WBPOWER_OFF`, a comma list of:
- `check`: issue 29's power-twice check (`PowerSource.twice` None: the voltage and current
  columns beside a power column are not read);
- `drive`: issue 25's drive statistics of a run without a speed column (the step runs'
  drive model);
- `pieces`: issue 29's piece signatures (a worker's fingerprint without them).

    PATH=$PWD/.venv/bin:$PATH WBPOWER_OFF=check,drive,pieces .venv/bin/python \\
        benchmarks/versus.py --before OLD/.venv/bin/wbpower --after benchmarks/new_work_off.py
"""

import os
import sys

off = set(filter(None, os.environ.get("WBPOWER_OFF", "").split(",")))
if off - {"check", "drive", "pieces"}:
    sys.exit(f"new_work_off: unknown WBPOWER_OFF {sorted(off - {'check', 'drive', 'pieces'})}")


def _patched(module, name: str, value) -> None:
    """`module.name` set to `value`; a name gone (moved by a later change) is an error, not a
    patch that silently does nothing."""
    if not hasattr(module, name):
        sys.exit(f"new_work_off: {module.__name__} has no {name} any more: update this script")
    setattr(module, name, value)


if "check" in off:
    import wifibot_power.io.columns as columns

    _patched(columns.PowerSource, "twice", property(lambda self: None))
if "drive" in off:
    import wifibot_power.models.drive as drive_family

    run_stats = drive_family.DriveFamily.run_stats
    _patched(
        drive_family.DriveFamily,
        "run_stats",
        lambda self, run, segmentation: (
            None if run.speed_mps is None else run_stats(self, run, segmentation)
        ),
    )
if "pieces" in off:
    import wifibot_power.pipeline.batch as batch
    from wifibot_power.pipeline.duplicates import run_fingerprint

    _patched(batch, "batch_fingerprint", run_fingerprint)

from wifibot_power.cli import main  # noqa: E402

sys.exit(main())
