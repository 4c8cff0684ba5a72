"""Shared test fixtures: the real analyser logs, and running the CLI as a user does."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner, Result

from wifibot_power.cli import app

#: ../shared/real_logs beside the repository (not copied into it: see its README).
REAL_LOGS = Path(__file__).resolve().parents[1].parent / "shared" / "real_logs"
REAL_N6705 = REAL_LOGS / "n6705c_dlog1.csv"


@pytest.fixture
def real_n6705() -> Path:
    """The real Keysight N6705C datalog; the test is skipped where it is absent."""
    if not REAL_N6705.is_file():
        pytest.skip(f"real analyser log not found at {REAL_N6705} (../shared/real_logs is absent)")
    return REAL_N6705


@pytest.fixture
def wbpower() -> Callable[..., Result]:
    """Run `wbpower ARGS...` in-process; fail the test if anything escaped as a traceback."""
    runner = CliRunner()

    def run(*args: object) -> Result:
        result = runner.invoke(app, [str(a) for a in args])
        if result.exception is not None and not isinstance(result.exception, SystemExit):
            raise AssertionError(f"wbpower raised {result.exception!r}") from result.exception
        assert "Traceback" not in result.stderr
        return result

    return run
