"""Whether and how a command shows its progress on stderr (docs/cli-output.md, "Progress"):
the light entry points `progress`, `stage` and `progress_done` (re-exported by `cli.common`);
rich's bar and spinner (`cli/progress_bar.py`) load only when something is drawn."""

from __future__ import annotations

import sys
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TypeVar

from wifibot_power.cli.json_document import DOCUMENT

T = TypeVar("T")


def progress_on() -> bool:
    """Whether progress is drawn: stderr is a terminal and the command prints no `--json`
    document (docs/cli-output.md, "Progress")."""
    return sys.stderr.isatty() and DOCUMENT.get() is None


def progress(items: list[T], label: str, then: str | None = None) -> Iterable[T]:
    """A progress bar over files (files done, MB/s) on stderr, for `map_runs(wrap=...)`,
    and once the files are done, the spinner of the step that follows (`then`, e.g.
    "fitting the models"); a single file shows the spinner `label` alone. Silent (a plain
    list) unless `progress_on()`. rich loads only when something is drawn
    (`cli/progress_bar.py`)."""
    if not progress_on():
        return items
    from wifibot_power.cli import progress_bar

    if len(items) < 2:
        progress_bar.stage(label)
        return _Then(items, then)
    return progress_bar.FileProgress(items, label, then)


@dataclass
class _Then:
    """One file: the spinner says `label` while it is read, `then` once it is done."""

    items: list
    then: str | None

    def __iter__(self) -> Iterable:
        return iter(self.items)

    def done(self, item: object) -> None:
        return None

    def close(self) -> None:
        if self.then:
            stage(self.then)
        else:
            progress_done()


def stage(label: str) -> None:
    """Say on stderr, on a spinner line with its time, the step under way (`drawing the
    figures`); silent unless `progress_on()`. `progress_done()` ends it."""
    if progress_on():
        from wifibot_power.cli import progress_bar

        progress_bar.stage(label)


def progress_done() -> None:
    """End the progress line, if any: called before the command prints its result, and by
    `handles_errors` when the command ends, however it ends."""
    bar = sys.modules.get("wifibot_power.cli.progress_bar")  # loaded only if one was drawn
    if bar is not None:
        bar.stop()
