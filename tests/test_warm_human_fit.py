"""A warm human `fit --cache` of free driving loads no pandas: the held-out table's caption
tells trips from runs by the batch's run ids (`FitResult.run_ids`), which the kept records
give, not the runs table (which would load pandas, ~0.45 s: docs/benchmarks.md, "Warm
cache")."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

from wifibot_power.drive.simulate import FreeDriveConfig, write_free

WARM_HUMAN = r"""
import sys
corpus, cache = sys.argv[1:3]
from wifibot_power.cli import main
sys.argv = ["wbpower", "fit", corpus, "--jobs", "1", "--cache", cache]
try:
    main()
except SystemExit:
    pass
print("pandas loaded" if "pandas" in sys.modules else "pandas not loaded", file=sys.stderr)
"""


def test_a_warm_human_fit_of_free_driving_loads_no_pandas(tmp_path):
    config = dataclasses.replace(FreeDriveConfig(), runs_per_surface=3, run_s=60.0, seed=4)
    write_free(config, tmp_path / "logs")

    def run() -> subprocess.CompletedProcess:
        argv = [sys.executable, "-c", WARM_HUMAN, str(tmp_path / "logs"), str(tmp_path / "c")]
        return subprocess.run(argv, capture_output=True, text=True, check=True)

    cold, warm = run(), run()
    assert "trips of" in cold.stdout  # the caption counted trips, as it does warm
    assert warm.stdout == cold.stdout
    assert warm.stderr.strip().splitlines()[-1] == "pandas not loaded"
