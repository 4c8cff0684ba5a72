"""docs/errors.md lists every error the reading code can raise: checked against the code itself.

Each `LogError(...)` in wifibot_power/io/ is found with `ast`; the longest literal piece of
its message must appear in docs/errors.md, so a new message cannot go undocumented.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "errors.md"
RAISERS = {"LogError", "not_a_log"}


def _messages() -> list[tuple[str, str]]:
    found = []
    for path in sorted((ROOT / "wifibot_power" / "io").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Call) or not node.args:
                continue
            name = getattr(node.func, "id", getattr(node.func, "attr", ""))
            if name not in RAISERS:
                continue
            first = node.args[1] if name == "not_a_log" else node.args[0]
            if isinstance(first, ast.Constant) and isinstance(first.value, str):
                pieces = [first.value]
            elif isinstance(first, ast.JoinedStr):
                pieces = [v.value for v in first.values if isinstance(v, ast.Constant)]
            else:
                continue  # a message built elsewhere (checked where it is built)
            longest = max((p.strip(" ('):,;") for p in pieces), key=len, default="")
            if len(longest) >= 6:
                found.append((f"{path.name}:{node.lineno}", longest))
    return found


MESSAGES = _messages()


def test_the_scan_finds_the_reading_errors():
    assert len(MESSAGES) >= 40  # a scan that silently finds nothing would prove nothing


@pytest.mark.parametrize(("where", "piece"), MESSAGES, ids=[m[0] for m in MESSAGES])
def test_every_reading_error_is_in_docs_errors_md(where, piece):
    assert piece in DOC.read_text(), f"{where}: '{piece}' is not described in docs/errors.md"
