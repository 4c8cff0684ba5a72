"""The `wbpower` command line: each command parses options, calls the library, renders.

One module per command registers on the shared Typer app; nothing here does math or
parsing. `wbpower COMMAND` loads only that command's module (start-up is most of a warm
`fit --cache` run); `wbpower --help`, and `from wifibot_power.cli import app`, load all.
"""

from __future__ import annotations

import importlib
import sys
from typing import Annotated

import typer

from wifibot_power import __version__
from wifibot_power.cli.typer_app import app as _app

#: command name -> the module that registers it
COMMANDS = {
    "inspect": "inspect_cmd",
    "segment": "segment_cmd",
    "fit": "fit_cmd",
    "energy": "energy_cmd",
    "lifetime": "lifetime_cmd",
    "diagnose": "diagnose_cmd",
    "simulate": "simulate_cmd",
    "report": "report_cmd",
}


def load_commands(names: list[str] | None = None) -> typer.Typer:
    """Register the named commands (all by default) on the app and return it."""
    for name in names or list(COMMANDS):
        importlib.import_module(f"wifibot_power.cli.{COMMANDS[name]}")
    return _app


def __getattr__(name: str) -> object:
    if name == "app":  # the whole command line, e.g. for typer.testing.CliRunner
        return load_commands()
    raise AttributeError(f"module 'wifibot_power.cli' has no attribute {name!r}")


def _version(value: bool) -> None:
    if value:
        print(f"wbpower {__version__}")
        raise typer.Exit(0)


@_app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
) -> None:
    """Energy models of a mobile robot from power-analyser logs, and where they go wrong."""


def main() -> None:
    wanted = [arg for arg in sys.argv[1:2] if arg in COMMANDS]
    load_commands(wanted or None)()
