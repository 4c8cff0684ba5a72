"""`python -m wifibot_power` is the `wbpower` command (where the script is not on PATH)."""

from __future__ import annotations

import subprocess
import sys

from wifibot_power import __version__


def test_python_dash_m_runs_the_command():
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", "--version"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"wbpower {__version__}"


def test_python_dash_m_runs_a_command_with_its_options():
    done = subprocess.run(
        [sys.executable, "-m", "wifibot_power", "energy", "--speed", "0.5", "--dist", "2"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert "stop-and-go overhead" in done.stdout
