"""What a command shows on stderr while it works (`cli.common.progress` and `cli.common.stage`),
with rich: a bar over the files of a batch (files done, MB/s, time), and a spinner line naming
the step under way (`fitting the models`, `drawing the figures`, `simulating: 12 of 89 runs
done`) with its time, for the steps that are not per file. Loaded only when something is drawn
(stderr a terminal, no `--json`: `common.progress_on`), so a `--json` run or a run in a pipe
never imports rich's progress machinery. One live line at a time: the bar ends the spinner and
the spinner the bar; `stop()` ends either (the command calls it before it prints its result,
and `common.handles_errors` when the command ends)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import TypeVar

from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    SpinnerColumn,
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


#: the live line on stderr now (a `FileProgress`'s bar or the `stage` spinner), if any
_live: Progress | None = None
#: the spinner's one task
_stage_task: TaskID | None = None


def _show(bar: Progress) -> None:
    """Make `bar` the one live line on stderr (rich draws one at a time)."""
    global _live
    stop()
    _live = bar
    bar.start()


def stop() -> None:
    """End the live line (bar or spinner), leaving stderr as it was (transient)."""
    global _live, _stage_task
    if _live is not None:
        _live.stop()
    _live = _stage_task = None


def stage(label: str) -> None:
    """Show `label` on a spinner line with the time since the step began; a new label
    replaces the step shown (and its time)."""
    global _stage_task
    if _live is not None and _stage_task is not None:
        _live.reset(_stage_task, description=label)
        return
    spinner = Progress(
        SpinnerColumn(),
        TextColumn("[bold]{task.description}"),
        TimeElapsedColumn(),
        console=consoles.stderr,
        transient=True,
        # stdout is the command's result: never drawn through the stderr console
        redirect_stdout=False,
    )
    _show(spinner)
    _stage_task = spinner.add_task(label, total=None)


class FileProgress:
    """A rich progress bar on stderr: files done, MB/s, elapsed time; with `then`, the
    spinner of the step that follows the files (`stage(then)`) once the bar closes.

    Files finish in any order when they run in parallel, so `done(item)` advances the bar by
    that file (its bytes on disk); iterating over it instead advances as the loop goes on.
    The bar is drawn from the start (0 files done), so the first file, however long, is
    never a blank screen.
    """

    def __init__(self, items: list[T], label: str, then: str | None = None) -> None:
        self.items = items
        self.sizes = {id(item): _size_bytes(item) for item in items}
        self.total_bytes = sum(self.sizes.values())
        self.label = label
        self.then = then
        self.files_done = 0
        self._bar: Progress | None = None
        self._task: TaskID | None = None
        self.started = time.monotonic()  # the work starts now
        self._start()

    def _start(self) -> None:
        bar = Progress(
            TextColumn(f"[bold]{self.label}"),
            BarColumn(),
            TextColumn("{task.fields[files]}/" + f"{len(self.items)} files"),
            _RateColumn(self.started, in_bytes=self.total_bytes > 0),
            TimeElapsedColumn(),
            console=consoles.stderr,
            transient=True,
            redirect_stdout=False,
        )
        _show(bar)
        self._bar = bar
        self._task = bar.add_task(self.label, total=self.total_bytes or len(self.items), files=0)

    def done(self, item: T) -> None:
        """One more file finished."""
        if self._bar is None:
            return  # closed (the batch ended): nothing to advance
        self.files_done += 1
        advance = self.sizes.get(id(item), 0) if self.total_bytes else 1
        self._bar.update(self._task, advance=advance, files=self.files_done)

    def close(self) -> None:
        if self._bar is not None:
            if _live is self._bar:
                stop()
            self._bar = None
            if self.then:
                stage(self.then)

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
