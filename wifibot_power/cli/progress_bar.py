"""The progress bar over files of a batch (`cli.common.progress`), on stderr with rich:
loaded only when a bar is drawn (a terminal, two files or more), so a `--json` run or a run
in a pipe never imports rich's progress machinery."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import TypeVar

from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    Task,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)
from rich.text import Text

from wifibot_power.cli import consoles

T = TypeVar("T")


#: No rate is shown before this much time since the work started: the first files finish
#: together, a few ms apart, which would show rates of hundreds of GB/s.
RATE_AFTER_S = 1.0


def rate_text(bytes_done: float, elapsed_s: float) -> str:
    """The rate shown on the bar: bytes done over the time since the work started (not
    rich's rate between two updates), blank until `RATE_AFTER_S` has passed."""
    if elapsed_s < RATE_AFTER_S or bytes_done <= 0:
        return ""
    rate = bytes_done / elapsed_s
    for unit in ("B", "kB", "MB", "GB"):
        if rate < 1000 or unit == "GB":
            return f"{rate:.1f} {unit}/s"
        rate /= 1000
    return ""  # not reached


class _RateColumn(ProgressColumn):
    """Bytes per second since `started` (a `time.monotonic()`), or nothing yet."""

    def __init__(self, started: float, in_bytes: bool = True) -> None:
        super().__init__()
        self.started = started
        self.in_bytes = in_bytes  # False: the bar counts files (sizes unknown), no rate

    def render(self, task: Task) -> Text:
        if not self.in_bytes:
            return Text("")
        return Text(rate_text(task.completed, time.monotonic() - self.started))


class FileProgress:
    """A rich progress bar on stderr: files done, MB/s, elapsed time.

    Files finish in any order when they run in parallel, so `done(item)` advances the bar by
    that file (its bytes on disk); iterating over it instead advances as the loop goes on.
    """

    def __init__(self, items: list[T], label: str) -> None:
        self.items = items
        self.sizes = {id(item): _size_bytes(item) for item in items}
        self.total_bytes = sum(self.sizes.values())
        self.label = label
        self.files_done = 0
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self.started = time.monotonic()  # the work starts now, the bar at the first file done

    def _start(self) -> None:
        self._bar = Progress(
            TextColumn(f"[bold]{self.label}"),
            BarColumn(),
            TextColumn("{task.fields[files]}/" + f"{len(self.items)} files"),
            _RateColumn(self.started, in_bytes=self.total_bytes > 0),
            TimeElapsedColumn(),
            console=consoles.stderr,
            transient=True,
        )
        self._bar.start()
        self._task = self._bar.add_task(
            self.label, total=self.total_bytes or len(self.items), files=0
        )

    def done(self, item: T) -> None:
        """One more file finished."""
        if self._bar is None:
            self._start()
        self.files_done += 1
        advance = self.sizes.get(id(item), 0) if self.total_bytes else 1
        self._bar.update(self._task, advance=advance, files=self.files_done)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def __iter__(self) -> Iterator[T]:
        try:
            for item in self.items:
                yield item
                self.done(item)
        finally:
            self.close()


def _size_bytes(item: object) -> int:
    path = getattr(item, "path", item)
    try:
        return Path(path).stat().st_size if isinstance(path, str | Path) else 0
    except OSError:
        return 0
