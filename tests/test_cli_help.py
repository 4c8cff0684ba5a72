"""Every command has help, a one-line summary that `wbpower --help` shows whole (it once
cut "energy ... (paper Eq." mid-phrase), and an Examples block whose examples parse."""

from __future__ import annotations

import re
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
        assert f"wbpower {command} {args}".rstrip() in after
        assert f"# {what}" in after
    assert len(EXAMPLES[command]) >= 2


@pytest.mark.parametrize(("command", "args"), [(c, a) for c in COMMANDS for a, _ in EXAMPLES[c]])
def test_every_example_parses(command, args):
    # option names and value types as the command declares them (files need not exist)
    group = typer.main.get_command(app)
    with group.commands[command].make_context(command, shlex.split(args)) as context:
        assert context.params


def _option_blocks(text: str) -> dict[str, str]:
    """Each option's help: its line and the lines folded under it."""
    blocks: dict[str, str] = {}
    name = None
    for line in text.splitlines():
        found = re.match(r"^  (?:-\w, )?(--[\w-]+)", line)
        if found:
            name = found.group(1)
            blocks[name] = line
        elif name and line.startswith("    "):
            blocks[name] += " " + line.strip()
        else:
            name = None
    return blocks


@pytest.mark.parametrize("command", list(COMMANDS))
def test_help_shows_plain_placeholders(command):
    """`--speed NUMBER`, `-o DIR`, `PATH...`: never typer's `<float range>`, `<str>`,
    `<path>` or `{paths}...` (issue 28)."""
    text = _help(command).replace("<plugin>", "")  # export's help names Gazebo's element
    assert not re.search(r"<[a-z][a-z ]*>|\{[a-z_]+\}", text), text
    for option, block in _option_blocks(text).items():
        if option in ("-o", "--out"):
            assert re.match(r"^  -o, --out (DIR|FILE) ", block), block


@pytest.mark.parametrize(
    ("option", "unit"),
    [
        ("--supply-voltage", "V"),
        ("--max-power", "W"),
        ("--sample-period", "S"),
        ("--track-width", "M"),
    ],
)
def test_help_shows_the_bound_that_is_enforced(wbpower, tmp_path, option, unit):
    """0 is refused (it is no voltage, no power limit, no period, no track): the help says
    > 0, never typer's `[x>=0.0]` (shown for --track-width while 0 was refused)."""
    block = _option_blocks(_help("fit"))[option]
    assert block.startswith(f"  {option} {unit} ") and "> 0" in block, block
    assert "x>=0" not in block, block
    log = tmp_path / "a.csv"
    log.write_text("time_s,current_A\n0,1\n0.001,1\n")
    volts = [] if option == "--supply-voltage" else ["--supply-voltage", "12"]
    result = wbpower("inspect", log, option, "0", *volts)
    assert result.exit_code == 2 and option in result.stderr, result.stderr
