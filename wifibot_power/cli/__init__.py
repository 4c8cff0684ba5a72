"""The `wbpower` command line: each command parses options, calls the library, renders.

One module per command registers on the shared Typer app; nothing here does math or
parsing. `wbpower COMMAND` loads only that command's module (start-up is most of a warm
`fit --cache` run); `wbpower --help`, and `from wifibot_power.cli import app`, load all.
This module itself imports nothing heavy, so that `main` covers the whole start-up: a
Ctrl-C while typer, rich or numpy load is the same quiet exit 130 as one during the work.
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import typer

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
    "export": "export_cmd",
    "docs": "docs_cmd",
}


def load_commands(names: list[str] | None = None) -> typer.Typer:
    """Register the named commands (all by default) on the app and return it."""
    from wifibot_power.cli.typer_app import app

    for name in names or list(COMMANDS):
        importlib.import_module(f"wifibot_power.cli.{COMMANDS[name]}")
    return app


def __getattr__(name: str) -> object:
    if name == "app":  # the whole command line, e.g. for typer.testing.CliRunner
        return load_commands()
    raise AttributeError(f"module 'wifibot_power.cli' has no attribute {name!r}")


def main() -> None:
    from wifibot_power import signals

    try:
        signals.install()  # SIGTERM stops a command as Ctrl-C does (exit 143)
        wanted = [arg for arg in sys.argv[1:2] if arg in COMMANDS]
        # held while modules load: a KeyboardInterrupt raised inside an import's weakref
        # callback is printed and swallowed by Python ("Exception ignored in"), and the
        # command would go on as if no Ctrl-C came; here it comes once they are loaded
        with signals.held():
            app = load_commands(wanted or None)
        app()
    except KeyboardInterrupt as exc:
        # Ctrl-C or SIGTERM outside a command's own handling (loading, parsing options)
        message, code = signals.interrupted(exc)
        print(f"wbpower: error: {message}", file=sys.stderr)
        raise SystemExit(code) from None
    finally:
        # the command is done and its exit code decided: a signal now, while Python shuts
        # down (which puts the default handlers back), would end the process as "killed by
        # SIGTERM" (143) or SIGINT (130), which says "nothing written", after its outputs
        # were written. Ignored: the process exits with the code it has.
        signals.ignore()
