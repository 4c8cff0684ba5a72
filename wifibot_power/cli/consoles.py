"""The rich consoles human output is drawn on (`stdout`, `stderr`), made (and rich imported,
~40 ms) on first use: `--json` output and one-line messages need neither. Its own module so
that the progress bar (`cli/progress_bar.py`) reads the console without importing
`cli.common`, which loads the bar."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console


def _console(name: str) -> Console:
    from rich.console import Console

    if name == "stdout":
        # a pipe gets wide tables (not rich's 80 columns), whatever COLUMNS the environment has
        return Console(soft_wrap=False, width=None if sys.stdout.isatty() else 200)
    return Console(stderr=True, soft_wrap=True)


stdout: Console
stderr: Console


def __getattr__(name: str) -> object:
    if name in ("stdout", "stderr"):
        console = globals()[name] = _console(name)
        return console
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
