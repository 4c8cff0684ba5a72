"""Many logs, one file in memory at a time per worker: every good file is processed, each bad
one is listed with its reason.

`map_runs` is four steps, each its own function:

1. `find_sources`: the logs under the paths given (folders, manifests, files).
2. `kept_outcomes`: with a cache and a memo, the results kept for unchanged content, looked
   up in this process, so a warm batch starts no worker.
3. `dispatch`: the rest, read (through the cache when there is one) and worked on in forked
   workers (`parallel.map_ordered`).
4. `duplicates.settle`: one result per recording and per run_id.

What a log's reading found odd but did not stop (a short gap of dropped samples:
`Run.problems`) comes back from the workers with each result, so the calling process can say
it (`on_problems`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.io.discover import LogSource, Skipped, find_logs
from wifibot_power.io.manifest import is_manifest
from wifibot_power.io.options import ReadOptions
from wifibot_power.pipeline.duplicates import (
    Outcome,
    ProblemHook,
    batch_fingerprint,
    duplicate_keys,
    settle,
)
from wifibot_power.run import Problem, Run

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache, ResultMemo

T = TypeVar("T")

#: A progress hook: an iterator over the sources, advanced as each file is done; if it has a
#: `done(source)` method, that is called instead with the file done.
Wrap = Callable[[list[LogSource]], Iterator[LogSource]]


def is_single_input(paths: list[Path]) -> bool:
    """One log file named (not a folder, not a manifest): an unreadable input is then a usage
    error (exit 2)."""
    return len(paths) == 1 and not Path(paths[0]).is_dir() and not is_manifest(Path(paths[0]))


def find_sources(paths: list[Path]) -> tuple[list[LogSource], list[Skipped]]:
    """The logs under `paths`, and the inputs that are not logs (`io.find_logs`); raises when
    there is nothing at all."""
    sources, skipped = find_logs([Path(p) for p in paths])
    if not sources and not skipped:
        raise LogError(
            "no logs found (.csv, .csv.gz, .csv.zst)",
            file=", ".join(map(str, paths)),
            fix="give log files or a folder that holds them",
        )
    return sources, skipped


def map_runs(
    paths: list[Path],
    options: ReadOptions,
    work: Callable[[Run], T],
    *,
    wrap: Wrap | None = None,
    jobs: int | None = 1,
    cache: ParseCache | None = None,
    memo: ResultMemo[T] | None = None,
    on_problems: ProblemHook | None = None,
    prepare: Callable[[], object] | None = None,
    beside: Callable[[], object] | None = None,
    only: set[str] | None = None,
) -> tuple[list[T], list[Skipped]]:
    """Read each log under `paths` and apply `work` to it, one file in memory at a time per
    worker; results in the order of the logs, one per recording and per run_id
    (`duplicates.settle`), and every input left out with its reason.

    `jobs` worker processes (None or 0: all cores) each take a file at a time; what `work`
    returns goes back to this process, so it should be small (a row, not the samples).
    `cache` skips parsing files parsed before; with `memo` (how to keep what `work`
    returns) it skips the work too on content it has seen. `wrap(sources)`: a progress hook
    (`Wrap`). `prepare()` is called once before the first file is worked on (not at all
    when every result is kept), e.g. `pipeline.preload.preload_work`; `beside()` runs in a
    thread of this process while forked workers work (`parallel.map_ordered`).
    `on_problems(file, problems)` is called in the order of the logs, after all are done.
    `only`: the logs (their paths as text) to read among those under `paths` (each with its
    manifest values, as in the whole batch).

    A single named file that fails raises (exit 2); in a batch the failure is recorded in
    the returned `Skipped` list and the rest goes on (exit 1).
    """
    paths = [Path(p) for p in paths]
    sources, skipped = find_sources(paths)
    if only is not None:
        sources = [source for source in sources if str(source.path) in only]
    on_done, close = _progress(wrap, sources)
    try:
        outcomes = kept_outcomes(sources, cache, memo, options, on_done)
        one = _one_log(
            options, work, cache, memo, single=is_single_input(paths), batch=len(sources) > 1
        )
        dispatch(sources, outcomes, one, jobs=jobs, on_done=on_done, prepare=prepare, beside=beside)
    finally:
        close()
    keys = duplicate_keys(sources, outcomes, options, jobs, cache)  # type: ignore[arg-type]
    return settle(sources, outcomes, keys, skipped, on_problems), skipped  # type: ignore[arg-type]


def dispatch(
    sources: list[LogSource],
    outcomes: list[tuple[bool, object] | None],
    one: Callable[[LogSource], tuple[bool, object]],
    *,
    jobs: int | None,
    on_done: Callable[[LogSource], None] | None,
    prepare: Callable[[], object] | None,
    beside: Callable[[], object] | None,
) -> None:
    """Fill in each outcome not kept (None) by `one(source)` in forked workers; only what is
    not kept goes to workers, so a warm batch starts none."""
    todo = [k for k, outcome in enumerate(outcomes) if outcome is None]
    if not todo:
        return
    # the parser (and pyarrow), and the workers' multiprocessing, load only when something is
    # parsed: a warm batch skips them
    import wifibot_power.io.reader  # noqa: F401
    from wifibot_power.parallel import map_ordered

    if prepare is not None:
        prepare()
    computed = map_ordered(
        [sources[k] for k in todo], one, jobs=jobs, on_done=on_done, cost=_size_bytes, beside=beside
    )
    for k, outcome in zip(todo, computed, strict=True):
        outcomes[k] = outcome


def _one_log(
    options: ReadOptions,
    work: Callable[[Run], T],
    cache: ParseCache | None,
    memo: ResultMemo[T] | None,
    *,
    single: bool,
    batch: bool,
) -> Callable[[LogSource], tuple[bool, Outcome[T] | Skipped]]:
    """What a worker does with one log: read it (through the cache), work on it, and return
    `(True, outcome)`, or `(False, Skipped)` with why (a single named file raises)."""

    def with_problems(run: Run) -> Outcome[T]:
        # a kept result may serve a later batch: it keeps its fingerprint too
        identify = batch or memo is not None
        fingerprint = batch_fingerprint(run) if identify else None
        return run.problems, fingerprint, run.meta.run_id, work(run)

    def one(source: LogSource) -> tuple[bool, Outcome[T] | Skipped]:
        from wifibot_power.io.reader import read_log  # loaded before workers fork (`dispatch`)

        try:
            if cache is not None:
                return True, cache.process(
                    source.path,
                    options,
                    source.read_overrides,
                    origin=source.origin,
                    work=with_problems,
                    memo=keeping_problems(memo) if memo is not None else None,
                )
            run = read_log(source.path, options, source.read_overrides, origin=source.origin)
            return True, with_problems(run)
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

    return one


def _progress(
    wrap: Wrap | None, sources: list[LogSource]
) -> tuple[Callable[[LogSource], None] | None, Callable[[], None]]:
    """The progress hook as `(on_done(source), close())`."""
    tracker = wrap(sources) if wrap else None
    on_done = getattr(tracker, "done", None)
    if tracker is not None and on_done is None:
        iterator = iter(tracker)
        next(iterator, None)  # a generator hook yields the first source before any is done

        def on_done(source: LogSource) -> None:
            next(iterator, None)

    close = getattr(tracker, "close", None)
    return on_done, (close if close is not None else _nothing)


def _nothing() -> None:
    return None


def keeping_problems(memo: ResultMemo[T]) -> ResultMemo[Outcome[T]]:
    """`memo`, keeping the run's problems, fingerprint and run_id beside its result, so a
    result taken from the cache still says what reading the log found, and is still known as
    a duplicate or as a run_id another log has."""
    from wifibot_power.cache import ResultMemo

    def to_json(kept: Outcome[T]) -> object:
        problems, identity, run_id, result = kept
        return {
            "problems": [dataclasses.asdict(p) for p in problems],
            "identity": identity,
            "run_id": run_id,
            "result": memo.to_json(result),
        }

    def from_json(kept: object) -> Outcome[T]:
        listed = kept["problems"]  # type: ignore[index]  # KeyError / TypeError: a miss
        identity = kept["identity"]  # type: ignore[index]
        run_id = kept["run_id"]  # type: ignore[index]
        problems = tuple(Problem(**p) for p in listed)
        return problems, identity, run_id, memo.from_json(kept["result"])  # type: ignore[index]

    # the kept key is the run's fingerprint (a kept SHA-256 identity, as before, is a miss),
    # and a result kept without its run_id is a miss
    return ResultMemo(
        key=f"{memo.key} +problems +fingerprint +pieces +run_id",
        to_json=to_json,
        from_json=from_json,
    )


def kept_outcomes(
    sources: list[LogSource],
    cache: ParseCache | None,
    memo: ResultMemo[T] | None,
    options: ReadOptions,
    on_done: Callable[[LogSource], None] | None,
) -> list[tuple[bool, object] | None]:
    """Each source's kept result (as a worker returns it), looked up in this process; None
    for a source whose content has no kept result (or when there is no cache or memo)."""
    if cache is None or memo is None:
        return [None] * len(sources)
    from wifibot_power.cache import MISSING

    keeping = keeping_problems(memo)
    outcomes: list[tuple[bool, object] | None] = []
    for source in sources:
        try:
            kept = cache.kept_result(
                source.path, options, source.read_overrides, origin=source.origin, memo=keeping
            )
        except Exception:  # noqa: BLE001 - a lookup that fails is a miss: the worker will say why
            kept = MISSING
        if kept is MISSING:
            outcomes.append(None)
            continue
        outcomes.append((True, kept))
        if on_done is not None:
            on_done(source)
    return outcomes


def _size_bytes(source: LogSource) -> int:
    try:
        return source.path.stat().st_size
    except OSError:
        return 0
