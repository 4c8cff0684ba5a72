"""The Typer app every command module registers on."""

import typer

app = typer.Typer(
    name="wbpower",
    help="Energy models of a mobile robot from power-analyser logs, and where they go wrong.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)
