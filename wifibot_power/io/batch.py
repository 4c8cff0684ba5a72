"""Moved: the batch machinery is `wifibot_power.pipeline` (`pipeline.batch.map_runs`, the
duplicate and run_id rules in `pipeline.duplicates`). These names stay importable from here
for code written against the old place."""

from wifibot_power.pipeline.batch import is_single_input, map_runs
from wifibot_power.pipeline.duplicates import (
    Outcome,
    ProblemHook,
    duplicate_keys,
    run_fingerprint,
    run_identity,
)

_duplicate_keys = duplicate_keys  # the old private name (tests of the duplicate rule)

__all__ = [
    "Outcome",
    "ProblemHook",
    "is_single_input",
    "map_runs",
    "run_fingerprint",
    "run_identity",
]
