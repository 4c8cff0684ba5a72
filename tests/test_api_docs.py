"""docs/api.md's examples run as a notebook user would run them: every `python` block, in
order, in one namespace, from the repository's root (issue 24)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def blocks() -> list[str]:
    return BLOCK.findall((ROOT / "docs" / "api.md").read_text(encoding="utf-8"))


def test_the_page_has_examples_of_every_step() -> None:
    text = "\n".join(blocks())
    calls = ("read_log(", "segment_run(", "fit_logs(", "trip_energy(", "diagnose_logs(")
    calls += ("fit_drive(", "route_energy(", "export_model(")  # the drive model (issue 25)
    for call in calls:
        assert call in text, call
    assert "FIGURES[" in text


def test_every_example_runs_in_order(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    namespace: dict[str, object] = {"__name__": "__main__"}
    for k, code in enumerate(blocks()):
        try:
            exec(compile(code, f"docs/api.md block {k + 1}", "exec"), namespace)  # noqa: S102
        except Exception as exc:  # which block, and its code, in the failure
            raise AssertionError(f"docs/api.md block {k + 1} failed:\n{code}") from exc


def test_dir_lists_the_public_api() -> None:
    import wifibot_power as wb

    public = [name for name in dir(wb) if not name.startswith("_")]
    assert public == sorted(wb.__all__)
    for name in ("fit_logs", "fit_runs", "diagnose_logs", "diagnose_runs", "build_report"):
        assert name in public
    assert all(getattr(wb, name) is not None for name in public)
