"""How wbpower stops on a signal: SIGTERM (what `timeout`, `kill` and a CI cancel send) as
Ctrl-C (SIGINT), so that the same clean-up runs (workers stopped, temporary files removed,
nothing partial written), with the exit code that names the signal (docs/errors.md,
"Signals and exit codes").

`Terminated` is a `KeyboardInterrupt`: every `except KeyboardInterrupt` / `except
BaseException` clean-up that handles Ctrl-C handles SIGTERM too. `held` holds both back for
a few renames that must happen all or not at all.
"""

from __future__ import annotations

import _thread
import contextlib
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType

#: the signals that stop a command cleanly
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as Ctrl-C raises KeyboardInterrupt."""


def exit_code(exc: BaseException) -> int:
    """128 + the signal's number, as shells report a command a signal stopped: 143 for
    SIGTERM, 130 for Ctrl-C (SIGINT)."""
    return 128 + (signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT)


#: stopped by Ctrl-C or SIGTERM after its outputs were written in full (docs/errors.md)
EXIT_INTERRUPTED_WRITTEN = 3


def interrupted(exc: BaseException) -> tuple[str, int]:
    """The message and exit code of a command stopped by Ctrl-C or SIGTERM: 130 or 143 when
    it wrote nothing, `EXIT_INTERRUPTED_WRITTEN` when its outputs were written in full
    first (`outputs.written`), so that a script can tell the two (docs/errors.md). Imports
    nothing: the signal may have come while modules were loading."""
    what = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
    outputs = sys.modules.get("wifibot_power.outputs")
    written = list(getattr(outputs, "written", ()))
    if written:
        paths = ", ".join(map(str, written))
        return f"{what} after writing {paths} in full", EXIT_INTERRUPTED_WRITTEN
    return what, exit_code(exc)


#: the code of Python's import machinery, as frames name it
_IMPORT_MACHINERY = ("<frozen importlib._bootstrap>", "<frozen importlib._bootstrap_external>")
#: seconds before a signal that came during an import is delivered again (`_stop`)
_RETRY_S = 0.02


def _importing(frame: FrameType | None) -> bool:
    """Whether `frame` runs inside an import (a module's top level, or the import
    machinery's own callbacks)."""
    while frame is not None:
        if frame.f_code.co_filename in _IMPORT_MACHINERY:
            return True
        frame = frame.f_back
    return False


def _stop(signum: int, frame: FrameType | None) -> None:
    """Ctrl-C or SIGTERM in the main thread: `KeyboardInterrupt` or `Terminated`, as
    Python's own handler raises KeyboardInterrupt; but not inside an import. There the
    exception may be raised in a weakref callback of the import machinery, where Python
    prints it ("Exception ignored in") and swallows it, and the command goes on as if no
    signal came (benchmarks/soak_fit.py saw `fit -o` write its set after a Ctrl-C that
    way). The signal is delivered again a moment later (`_thread.interrupt_main`), until
    it comes outside an import: the imports of a command take well under a second.

    Likewise while the main thread blocks these signals (`blocked`: workers being forked,
    which must not be left half-made): such a delivery comes through another thread, or
    through `_thread.interrupt_main`, not through the main thread's own signal mask."""
    if _importing(frame) or signum in signal.pthread_sigmask(signal.SIG_BLOCK, []):
        retry = threading.Timer(_RETRY_S, _thread.interrupt_main, args=(signum,))
        retry.daemon = True
        retry.start()
        return
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def install() -> None:
    """Ctrl-C and SIGTERM raise `KeyboardInterrupt` and `Terminated` in the main thread,
    never swallowed inside an import (`_stop`). Called first thing by the command line; a
    library user keeps the handlers it has."""
    if threading.current_thread() is threading.main_thread():
        for signum in STOP_SIGNALS:
            signal.signal(signum, _stop)


def ignore() -> None:
    """Ignore SIGINT and SIGTERM from now on (a command that has finished; `cli.main`).
    Python's shutdown leaves an ignored signal ignored, where it puts a handler back to
    the default."""
    if threading.current_thread() is threading.main_thread():
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)


@contextlib.contextmanager
def held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back until the block ends, then act on them (the usual
    handlers: KeyboardInterrupt, `Terminated`): for a few renames that must happen all or
    not at all. Outside the main thread (where Python cannot set a handler) the block just
    runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {
        signum: signal.signal(signum, lambda number, frame: caught.append(number))
        for signum in STOP_SIGNALS
    }
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(caught):  # delivered again, now to the usual handler
            signal.raise_signal(signum)


@contextlib.contextmanager
def blocked() -> Iterator[None]:
    """SIGINT and SIGTERM held pending by the kernel (delivered on leaving) while workers
    are forked: each is forked with them blocked and installs its own handling before
    unblocking them."""
    signal.pthread_sigmask(signal.SIG_BLOCK, set(STOP_SIGNALS))
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, set(STOP_SIGNALS))
