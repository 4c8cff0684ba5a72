"""Every command has help, a one-line summary that `wbpower --help` shows whole (it once
cut "energy ... (paper Eq." mid-phrase), and an Examples block whose examples parse."""

from __future__ import annotations

import shlex

import pytest
import typer
from typer.testing import CliRunner

from wifibot_power.cli import COMMANDS, app
from wifibot_power.cli.help import EXAMPLES, SHORT_HELP

WIDTH = 80


def _help(*args: str) -> str:
    result = CliRunner().invoke(app, [*args, "--help"], env={"COLUMNS": str(WIDTH)})
    assert result.exit_code == 0, result.output
    return result.stdout


def test_every_command_is_documented():
    assert set(SHORT_HELP) == set(EXAMPLES)
    assert set(COMMANDS) <= set(SHORT_HELP)


def test_the_command_list_shows_each_summary_whole():
    text = _help()
    flat = " ".join(text.split())
    for command in COMMANDS:
        summary = SHORT_HELP[command]
        assert f"{command} {summary}" in flat, f"{command}: summary cut or missing:\n{text}"
    commands = text.split("Commands:")[1]
    assert "..." not in commands
    assert max(len(line) for line in text.splitlines()) <= WIDTH


@pytest.mark.parametrize("command", list(COMMANDS))
def test_each_command_has_help_and_examples(command):
    text = _help(command)
    lines = text.splitlines()
    assert max(len(line) for line in lines) <= WIDTH, text
    description = text.split("Options:")[0].split("\n", 2)[-1].strip()
    assert len(description) > 20, f"{command} has no description"
    assert "Examples:" in text
    after = text.split("Examples:")[1]
    for args, what in EXAMPLES[command]:
        assert f"wbpower {command} {args}" in after
        assert f"# {what}" in after
    assert len(EXAMPLES[command]) >= 2


@pytest.mark.parametrize(("command", "args"), [(c, a) for c in COMMANDS for a, _ in EXAMPLES[c]])
def test_every_example_parses(command, args):
    # option names and value types as the command declares them (files need not exist)
    group = typer.main.get_command(app)
    with group.commands[command].make_context(command, shlex.split(args)) as context:
        assert context.params
