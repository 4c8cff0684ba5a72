"""Reading many logs: every good file is processed, each bad one is listed with its reason."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.io.discover import LogSource, Skipped, find_logs
from wifibot_power.io.manifest import is_manifest
from wifibot_power.io.reader import ReadOptions, read_log
from wifibot_power.parallel import map_ordered
from wifibot_power.run import Run

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache, ResultMemo

T = TypeVar("T")


def is_single_input(paths: list[Path]) -> bool:
    """One log file named (not a folder, not a manifest): an unreadable input is then a usage
    error (exit 2)."""
    return len(paths) == 1 and not Path(paths[0]).is_dir() and not is_manifest(Path(paths[0]))


def map_runs(
    paths: list[Path],
    options: ReadOptions,
    work: Callable[[Run], T],
    *,
    wrap: Callable[[list[LogSource]], Iterator[LogSource]] | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    memo: ResultMemo[T] | None = None,
) -> tuple[list[T], list[Skipped]]:
    """Read each log under `paths` and apply `work` to it, one file in memory at a time per
    worker; results in the order of the logs.

    `jobs` worker processes (None or 0: all cores) each take a file at a time; what `work`
    returns goes back to this process, so it should be small (a row, not the samples).
    `cache` (`wifibot_power.cache.ParseCache`) skips parsing files parsed before; with `memo`
    (how to keep what `work` returns) it skips the work too on content it has seen.
    `wrap(sources)` is a progress hook: an iterator over the sources, advanced as each file
    is done; if it has a `done(source)` method, that is called instead with the file done.

    A single named file that fails raises (exit 2); in a batch the failure is recorded in
    the returned `Skipped` list and the rest goes on (exit 1).
    """
    sources, skipped = find_logs([Path(p) for p in paths])
    if not sources and not skipped:
        raise LogError(
            "no logs found (.csv, .csv.gz, .csv.zst)",
            file=", ".join(map(str, paths)),
            fix="give log files or a folder that holds them",
        )
    single = is_single_input([Path(p) for p in paths])

    def one(source: LogSource) -> tuple[bool, T | Skipped]:
        try:
            if cache is not None:
                return True, cache.process(
                    source.path,
                    options,
                    source.overrides,
                    origin=source.origin,
                    work=work,
                    memo=memo,
                )
            run = read_log(source.path, options, source.overrides, origin=source.origin)
            return True, work(run)
        except WbpowerError as exc:
            exc.with_file(source.path)
            if single:
                raise
            return False, Skipped(str(source.path), exc.one_line())
        except Exception as exc:
            # a bug must not stop a CI batch: the file is listed as skipped, with the bug named
            if single:
                raise
            reason = (
                f"{source.path}: internal error: {exc.__class__.__name__}: {exc} (please report it)"
            )
            return False, Skipped(str(source.path), " ".join(reason.split()))

    tracker = wrap(sources) if wrap else None
    on_done = getattr(tracker, "done", None)
    if tracker is not None and on_done is None:
        iterator = iter(tracker)
        next(iterator, None)  # a generator hook yields the first source before any is done

        def on_done(source: LogSource) -> None:
            next(iterator, None)

    try:
        outcomes = map_ordered(sources, one, jobs=jobs, on_done=on_done, cost=_size_bytes)
    finally:
        close = getattr(tracker, "close", None)
        if close is not None:
            close()
    results: list[T] = []
    for ok, value in outcomes:
        if ok:
            results.append(value)  # type: ignore[arg-type]
        else:
            skipped.append(value)  # type: ignore[arg-type]
    return results, skipped


def _size_bytes(source: LogSource) -> int:
    try:
        return source.path.stat().st_size
    except OSError:
        return 0
