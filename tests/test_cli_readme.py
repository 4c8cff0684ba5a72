"""What the README quotes is what the tool prints (issue 28: it quoted `cruise_ripple
0.9999 W [0.9995, 1]` where the tool printed 0.9998 [0.9994, 1]): every output block marked
`<!-- quoted: [ENV=...] wbpower ARGS -->` is run and found, line for line, in the command's
output; the numbers the prose quotes from `fit` and `diagnose` on sample_logs/ are those of
their JSON, to the digits quoted. A change that moves a quoted number fails here until the
README is brought in step (a slow test: fit and diagnose of the 89 sample logs)."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
QUOTED = re.compile(
    r"<!-- quoted: (.+?) \(tests/test_cli_readme\.py checks it\) -->\n```\n(.*?)```", re.S
)

pytestmark = pytest.mark.skipif(
    not (ROOT / "sample_logs").is_dir(), reason="sample_logs/ is not there"
)


def _wbpower(command: str, tmp: Path | None = None) -> str:
    """Run a quoted command line (`ENV=VALUE ... wbpower ARGS`) in the repository, its
    stdout piped, as a reader who types it would."""
    words = shlex.split(command)
    env = dict(os.environ)
    while "=" in words[0]:
        key, _, value = words.pop(0).partition("=")
        env[key] = value
    assert words[0] == "wbpower", command
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", *words[1:]],
        capture_output=True, text=True, cwd=ROOT, env=env, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_every_quoted_block_is_the_tools_output():
    blocks = QUOTED.findall(README.read_text())
    assert blocks, "README.md marks no quoted output"
    for command, block in blocks:
        shown = [line.rstrip() for line in _wbpower(command).splitlines()]
        quoted = block.rstrip("\n").splitlines()
        starts = [i for i, line in enumerate(shown) if line == quoted[0]]
        assert any(shown[i : i + len(quoted)] == quoted for i in starts), (
            f"README.md quotes of '{command}' differ from its output:\n" + "\n".join(shown)
        )


@pytest.fixture(scope="module")
def fitted() -> dict:
    return json.loads(_wbpower("wbpower fit sample_logs/ --json"))


def _prose() -> str:
    return " ".join(README.read_text().split())


def test_the_fit_numbers_the_prose_quotes(fitted):
    prose = _prose()
    accel, cruise = fitted["accel"], fitted["cruise"]
    line = (
        f"P_acc = {accel['intercept_W']:.3f} + {accel['slope_W_per_mps']:.3f} v, "
        f"P_v = {cruise['intercept_W']:.3f} + {cruise['slope_W_per_mps']:.3f} v, "
        f"idle {fitted['idle_W']:.3f} W"
    )
    assert line in prose, line
    low, high = cruise["intercept_ci95"]
    assert f"[{low:.5f}, {high:.5f}] W, ends {(23.9 - high) * 1e3:.2f} mW short of 23.9" in prose
    (row,) = [
        r
        for r in fitted["stop_and_go"]
        if (r["speed_mps"], r["distance_m"], r["steps"]) == (0.5, 10.0, 10)
    ]
    low, high = row["overhead_ci95"]
    quoted = (
        f"10 m in 10 steps costs {row['overhead_pct']:.1f}% [{low:.1f}, {high:.1f}] more motion "
        f"energy than in one step at 0.5 m/s, where the fitted Eq. 5/6 says "
        f"{row['model_overhead_pct']:.1f}%"
    )
    assert quoted in prose, quoted
