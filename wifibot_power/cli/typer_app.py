"""The Typer app every command module registers on."""

from typing import Annotated

import typer

from wifibot_power import __version__

app = typer.Typer(
    name="wbpower",
    help="Energy models of a mobile robot from power-analyser logs, and where they go wrong.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


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
