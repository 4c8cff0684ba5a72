"""`make install` (which `make demo` and `make test` run first) recovers from a venv left
broken: after `make demo PYTHON=<too old>` failed, a plain `make demo` used to keep failing
on the stale `.venv`. Here the venv is built in a temporary folder, without pip, and the
installs are no-ops (PIP_INSTALL=true), so nothing is downloaded; a too-old interpreter is
played by asking for Python >= 99.0 (MIN_PYTHON)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")


def _make(venv: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            "make",
            "-C",
            str(ROOT),
            "install",
            f"VENV={venv}",
            f"PYTHON={sys.executable}",
            "PIP_INSTALL=true",
            "VENV_FLAGS=--without-pip",
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_a_failed_install_does_not_stick(tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    # what a failed first `make demo` leaves: a venv whose install never completed
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    (venv / "stale").write_text("left by the failed install")

    too_old = _make(venv, "MIN_PYTHON=99.0")
    assert too_old.returncode != 0
    assert "wbpower needs Python >= 99.0" in too_old.stderr
    assert "give PYTHON=python3.11 or newer" in too_old.stderr

    again = _make(venv)
    assert again.returncode == 0, again.stderr
    assert (venv / ".installed").is_file()
    # the install compiles wifibot_power's bytecode (an editable install does not, and with
    # PYTHONDONTWRITEBYTECODE set every command would compile it again), and it succeeded
    assert f"{venv}/bin/python -m compileall -q wifibot_power" in again.stdout
    assert not (venv / "stale").exists(), "the stale venv was reused, not rebuilt"
    assert "Nothing to be done" in _make(venv).stdout  # a good venv is left alone


def test_a_venv_whose_python_broke_is_rebuilt(tmp_path: Path) -> None:
    venv = tmp_path / "venv"
    assert _make(venv).returncode == 0
    python = venv / "bin" / "python"
    python.unlink()
    python.write_text("#!/bin/sh\nexit 1\n")  # e.g. the interpreter it linked to is gone
    python.chmod(0o755)
    rebuilt = _make(venv)
    assert rebuilt.returncode == 0, rebuilt.stderr
    done = subprocess.run([str(python), "-c", "print(1)"], capture_output=True, text=True)
    assert done.stdout == "1\n"
