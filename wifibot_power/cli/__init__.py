"""The `wbpower` command line: each command parses options, calls the library, renders.

One module per command registers on the shared app; nothing here does math or parsing.
"""

from __future__ import annotations

from typing import Annotated

import typer

from wifibot_power import __version__
from wifibot_power.cli import (  # noqa: F401 - importing registers the commands
    diagnose_cmd,
    energy_cmd,
    fit_cmd,
    inspect_cmd,
    lifetime_cmd,
    segment_cmd,
    simulate_cmd,
)
from wifibot_power.cli.app import app


def _version(value: bool) -> None:
    if value:
        print(f"wbpower {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
) -> None:
    """Energy models of a mobile robot from power-analyser logs, and where they go wrong."""


def main() -> None:
    app()
