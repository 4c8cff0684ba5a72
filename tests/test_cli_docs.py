"""References a user can open (issue 28): the project's docs ship inside the package and
`wbpower docs NAME` prints them; no help text, table title or error message names a path the
user does not have (`docs/log-format.md`, `shared/spec/causes.md`: not installed by pip)."""

from __future__ import annotations

import ast
import json
import re
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

from wifibot_power.cli import COMMANDS, app

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PACKAGE = ROOT / "wifibot_power"
SPEC_CAUSES = ROOT.parent / "shared" / "spec" / "causes.md"

#: a file path a message might cite: `docs/log-format.md`, `causes.md`, `shared/spec/...`
PATH_CITED = re.compile(r"[\w./-]+\.md\b|shared/spec")
#: a page cited the way a user can open it
PAGE_CITED = re.compile(r"wbpower docs ([a-z][a-z-]*)")


def _help(*args: str) -> str:
    result = CliRunner().invoke(app, [*args, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    return result.stdout


def test_every_page_of_docs_is_shipped_and_listed(wbpower):
    doc = json.loads(wbpower("docs", "--json").stdout)
    listed = {page["name"] for page in doc["pages"]}
    assert listed == {p.stem for p in DOCS.glob("*.md")}
    assert {"causes", "log-format", "cli-output"} <= listed
    assert all(page["title"] for page in doc["pages"])
    # the package's own copy (package data) is the repository's docs/ (a symbolic link)
    assert (PACKAGE / "docs").resolve() == DOCS.resolve()
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "docs/*.md" in data["package-data"]["wifibot_power"]


def test_a_page_prints_whole(wbpower):
    result = wbpower("docs", "causes")
    assert result.exit_code == 0
    assert result.stdout == (DOCS / "causes.md").read_text()
    assert wbpower("docs", "log-format.md").stdout == (DOCS / "log-format.md").read_text()


def test_an_unknown_page_is_one_line_naming_the_pages(wbpower):
    result = wbpower("docs", "nowhere")
    assert result.exit_code == 2 and result.stdout == ""
    line = result.stderr.strip()
    assert "\n" not in line and "nowhere" in line and "causes" in line and "log-format" in line


def test_docs_causes_is_the_contracts_text():
    """docs/causes.md is the contract's page, copied so that it ships: the same text."""
    if not SPEC_CAUSES.is_file():
        pytest.skip(f"{SPEC_CAUSES} is not there")
    assert (DOCS / "causes.md").read_text() == SPEC_CAUSES.read_text()


def _cited_pages(text: str) -> set[str]:
    return set(PAGE_CITED.findall(text))


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_no_help_text_cites_a_path(command):
    text = _help(*([command] if command else []))
    assert not PATH_CITED.search(text), PATH_CITED.search(text).group(0)
    pages = {p.stem for p in DOCS.glob("*.md")}
    assert _cited_pages(text) <= pages, _cited_pages(text) - pages


def _message_strings() -> list[tuple[str, int, str]]:
    """Every string literal of the package that is not a docstring or a comment: the text
    of its messages, table titles and option help, as (file, line, text)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docstrings = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Module | ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                first = node.body[0] if node.body else None
                if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                    docstrings.add(id(first.value))
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and id(node) not in docstrings
            ):
                found.append((str(path.relative_to(ROOT)), node.lineno, node.value))
    return found


def test_no_message_cites_a_path():
    """Errors, warnings and titles cite `wbpower docs NAME`, never a file of the repository."""
    strings = _message_strings()
    assert len(strings) > 1000  # the scan reads the package
    cited = [f"{f}:{n}: {t!r}" for f, n, t in strings if PATH_CITED.search(t)]
    assert not cited, "\n".join(cited)
    pages = {p.stem for p in DOCS.glob("*.md")}
    named = set().union(*(_cited_pages(t) for _, _, t in strings))
    assert named and named <= pages, named - pages


def test_a_reader_error_names_a_page_the_user_can_open(wbpower, tmp_path):
    log = tmp_path / "log.csv"
    log.write_text("when,amps\n0,1\n1,1\n")
    result = wbpower("inspect", log)
    line = result.stderr.strip().splitlines()[-1]
    assert "'wbpower docs log-format'" in line and ".md" not in line, line
    page = PAGE_CITED.search(line).group(1)
    assert wbpower("docs", page).exit_code == 0


def test_the_diagnose_findings_title_names_the_causes_page():
    from wifibot_power.cli import diagnose_cmd

    source = Path(diagnose_cmd.__file__).read_text()
    assert "Findings: named causes ('wbpower docs causes')" in source


def test_the_license_is_an_spdx_string():
    """setuptools >= 77 warns three times per install ("`project.license` as a TOML table is
    deprecated", seen in `make demo`) for `license = { text = ... }`: an SPDX string, which
    needs setuptools >= 77 to build."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["project"]["license"] == "MIT"
    assert "setuptools>=77" in project["build-system"]["requires"]
