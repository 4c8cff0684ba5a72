"""Errors a user can meet. Each renders as one line: where, what, what to do.

The CLI turns these into a one-line message on stderr and an exit code; nothing
below the CLI prints. See docs/errors.md for the catalogue.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from wifibot_power.io.discover import Skipped


class WbpowerError(Exception):
    """Base of every error wbpower reports to a user (never a traceback)."""

    def __init__(
        self,
        problem: str,
        *,
        file: str | Path | None = None,
        where: str | None = None,
        fix: str | None = None,
        skipped: Sequence[Skipped] = (),
    ) -> None:
        self.problem = problem
        #: a batch that failed as a whole: every input it left out, each with its own
        #: reason (the CLI lists them, on stderr and in `--json`'s `skipped`)
        self.skipped: tuple[Skipped, ...] = tuple(skipped)
        self.file = str(file) if file is not None else None
        self.where = where
        self.fix = fix
        super().__init__(self.one_line())

    def one_line(self) -> str:
        parts = [p for p in (self.file, self.where) if p]
        head = ": ".join(parts)
        text = f"{head}: {self.problem}" if head else self.problem
        if self.fix:
            text = f"{text} ({self.fix})"
        return " ".join(text.split())  # one line, whatever the pieces held

    def with_file(self, file: str | Path) -> WbpowerError:
        """The same error, naming `file` when it did not name one yet."""
        if self.file is None:
            self.file = str(file)
            self.args = (self.one_line(),)
        return self


class LogError(WbpowerError):
    """An input log (or manifest) that cannot be read as it is."""


class UsageError(WbpowerError):
    """Options that do not make sense together; nothing was computed."""
