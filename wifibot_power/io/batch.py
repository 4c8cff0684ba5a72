"""Reading many logs: every good file is processed, each bad one is listed with its reason."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TypeVar

from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.io.discover import LogSource, Skipped, find_logs
from wifibot_power.io.manifest import is_manifest
from wifibot_power.io.reader import ReadOptions, read_log
from wifibot_power.run import Run

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
) -> tuple[list[T], list[Skipped]]:
    """Read each log under `paths` and apply `work` to it, one file in memory at a time.

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
    results: list[T] = []
    for source in wrap(sources) if wrap else sources:
        try:
            run = read_log(source.path, options, source.overrides, origin=source.origin)
            results.append(work(run))
        except WbpowerError as exc:
            exc.with_file(source.path)
            if single:
                raise
            skipped.append(Skipped(str(source.path), exc.one_line()))
        except Exception as exc:
            # a bug must not stop a CI batch: the file is listed as skipped, with the bug named
            if single:
                raise
            reason = (
                f"{source.path}: internal error: {exc.__class__.__name__}: {exc} (please report it)"
            )
            skipped.append(Skipped(str(source.path), " ".join(reason.split())))
    return results, skipped
