"""The rich consoles human output is drawn on (`stdout`, `stderr`), made (and rich imported,
~40 ms) on first use: `--json` output and one-line messages need neither. Its own module so
that the progress bar (`cli/progress_bar.py`) reads the console without importing
`cli.common`, which loads the bar."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rich.console import Console


def _console(name: str) -> Console:
    from rich.console import Console

    if name == "stdout":
        return Console(soft_wrap=False, width=stdout_width())
    return Console(stderr=True, soft_wrap=True)


#: the width of output that is not a terminal (a pipe, a file), when COLUMNS does not say
PIPE_WIDTH = 80


def stdout_width() -> int | None:
    """The width tables are laid out for (docs/cli-output.md): `COLUMNS` when set, else the
    terminal's (None: rich asks it), else `PIPE_WIDTH` (`| less`, `| head`, a CI log);
    `--wide` draws one table however wide."""
    columns = os.environ.get("COLUMNS", "").strip()
    if columns.isdigit() and int(columns) > 0:
        return int(columns)
    return None if sys.stdout.isatty() else PIPE_WIDTH


stdout: Console
stderr: Console


def __getattr__(name: str) -> object:
    if name in ("stdout", "stderr"):
        console = globals()[name] = _console(name)
        return console
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
