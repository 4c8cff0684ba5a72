"""Reading many logs: every good file is processed, each bad one is listed with its reason.

What a log's reading found odd but did not stop (a short gap of dropped samples:
`Run.problems`) comes back from the workers with each result, so the calling process can say
it (`on_problems`).

The same log given twice in one batch (a copy, a renamed copy, the .csv and its .csv.gz) is
analysed once, with a warning naming both files (log-format.md): each worker returns the
run's `run_fingerprint`, a cheap key that the same samples always share, and the calling
process keeps the first of each. Only logs whose fingerprints are equal are read again, for
their `run_identity` (a SHA-256 of the samples): two logs are duplicates when those are
equal, never on the fingerprint alone.

A run_id names one run of the batch (log-format.md): logs whose run_ids would be the same
file name get run_ids from their paths before any is read (`find_logs`), and of two different
logs that give one run_id in their metadata or the manifest, the later is left out, listed in
`skipped` with both files named: never merged into one run. Copies are found first, so a copy
(which has its original's run_id) stays a duplicate, not a contradiction.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from wifibot_power.errors import LogError, WbpowerError
from wifibot_power.io.discover import LogSource, Skipped, find_logs
from wifibot_power.io.manifest import is_manifest
from wifibot_power.io.options import ReadOptions
from wifibot_power.run import Problem, Run

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache, ResultMemo

T = TypeVar("T")

#: `hook(file, problems)`: called in the calling process for each log read with problems.
ProblemHook = Callable[[str, tuple[Problem, ...]], None]

#: What a worker returns for a log: its problems, its fingerprint (None: not asked for), its
#: run_id and what `work` made of it.
Outcome = tuple[tuple[Problem, ...], str | None, str, T]


def run_identity(run: Run) -> str:
    """A digest of a run's samples: equal for the same recording, whatever its file name,
    compression or metadata. SHA-256 of the power samples (bit for bit) and of the speed
    samples when there are some, with the time axis's start, end and length: two different
    recordings never share 1000s of noisy power readings bit for bit. Measured: 10 ms on the
    1.2 M-sample, 41 MB bench log, against 150-350 ms to read it (2 shared cores); a batch
    computes it only for logs whose `run_fingerprint`s are equal."""
    import numpy as np  # here: a warm batch, all kept in the cache, loads no numpy

    digest = hashlib.sha256()
    for samples in (run.power_W, run.speed_mps):
        if samples is not None:
            digest.update(memoryview(np.ascontiguousarray(samples, dtype=np.float64)))
        digest.update(b"|")
    ends = (run.time_at(0), run.time_at(-1)) if run.samples else (0.0, 0.0)
    digest.update(np.array([*ends, run.samples], dtype=np.float64).tobytes())
    return digest.hexdigest()


def run_fingerprint(run: Run) -> str:
    """A cheap key of a run's samples, equal whenever `run_identity` is (it reads the same
    bits): the sample count, the time axis's start and end, and of the power samples (and
    of the speed samples when there are some) the wrapping sum and the xor of their 64-bit
    patterns. Two integer reductions a column: ~0.04 ms for 330 k samples against ~1.7 ms
    for their SHA-256 (measured here, 2026-11-22), which was 5% of `fit`'s CPU on 10 kHz
    power-only logs. Different runs can share it (the same samples in another order, or
    edits that cancel in both sums), so it only says which logs to compare in full
    (`map_runs`)."""
    import numpy as np  # here, as in `run_identity`: a warm batch loads no numpy

    parts = [str(run.samples)]
    if run.samples:
        parts += [run.time_at(0).hex(), run.time_at(-1).hex()]
    for samples in (run.power_W, run.speed_mps):
        if samples is None or not samples.size:  # as `run_identity`: none and empty alike
            parts.append("-")
            continue
        bits = np.ascontiguousarray(samples, dtype=np.float64).view(np.uint64)
        total = int(np.add.reduce(bits, dtype=np.uint64))  # modulo 2**64
        folded = int(np.bitwise_xor.reduce(bits))
        parts.append(f"{bits.size}:{total:016x}:{folded:016x}")
    return "/".join(parts)


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
    on_problems: ProblemHook | None = None,
    prepare: Callable[[], object] | None = None,
    beside: Callable[[], object] | None = None,
) -> tuple[list[T], list[Skipped]]:
    """Read each log under `paths` and apply `work` to it, one file in memory at a time per
    worker; results in the order of the logs.

    `jobs` worker processes (None or 0: all cores) each take a file at a time; what `work`
    returns goes back to this process, so it should be small (a row, not the samples).
    `cache` (`wifibot_power.cache.ParseCache`) skips parsing files parsed before; with `memo`
    (how to keep what `work` returns) it skips the work too on content it has seen.
    `wrap(sources)` is a progress hook: an iterator over the sources, advanced as each file
    is done; if it has a `done(source)` method, that is called instead with the file done.

    `prepare()` is called in this process once, before the first file is worked on (not at
    all when every result is kept in the cache): e.g. importing what `work` needs, so forked
    workers inherit it instead of each importing it. `beside()` is called in a thread of
    this process while forked workers do the work (`parallel.map_ordered`).

    `on_problems(file, problems)` is called in this process, in the order of the logs, for
    each log read with problems (`Run.problems`: short gaps), after all are done.
    Problems come back from workers and from the cache too. A log with the same samples as
    one before it in the batch (`run_identity`) is left out of the results, and
    `on_problems` gets a "duplicate" problem for it that names both files. A different log
    with the run_id of a log before it is left out too, as a `Skipped` entry that names both:
    the results hold one run per run_id.

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
    batch = len(sources) > 1

    def with_problems(run: Run) -> Outcome[T]:
        # a kept result may serve a later batch: it keeps its fingerprint too
        identify = batch or memo is not None
        fingerprint = run_fingerprint(run) if identify else None
        return run.problems, fingerprint, run.meta.run_id, work(run)

    def one(source: LogSource) -> tuple[bool, Outcome[T] | Skipped]:
        from wifibot_power.io.reader import read_log  # loaded before workers fork (below)

        try:
            if cache is not None:
                return True, cache.process(
                    source.path,
                    options,
                    source.read_overrides,
                    origin=source.origin,
                    work=with_problems,
                    memo=_keeping_problems(memo) if memo is not None else None,
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

    tracker = wrap(sources) if wrap else None
    on_done = getattr(tracker, "done", None)
    if tracker is not None and on_done is None:
        iterator = iter(tracker)
        next(iterator, None)  # a generator hook yields the first source before any is done

        def on_done(source: LogSource) -> None:
            next(iterator, None)

    try:
        outcomes = _kept_outcomes(sources, cache, memo, options, on_done)
        # only what is not kept goes to workers: a warm batch starts none
        todo = [k for k, outcome in enumerate(outcomes) if outcome is None]
        computed: list[tuple[bool, object]] = []
        if todo:
            # the parser (and pyarrow), and the workers' multiprocessing, load only when
            # something is parsed: a warm batch skips them
            import wifibot_power.io.reader  # noqa: F401
            from wifibot_power.parallel import map_ordered

            if prepare is not None:
                prepare()
            computed = map_ordered(
                [sources[k] for k in todo],
                one,
                jobs=jobs,
                on_done=on_done,
                cost=_size_bytes,
                beside=beside,
            )
        for k, outcome in zip(todo, computed, strict=True):
            outcomes[k] = outcome
    finally:
        close = getattr(tracker, "close", None)
        if close is not None:
            close()
    keys = _duplicate_keys(sources, outcomes, options, jobs, cache)
    results: list[T] = []
    first_of: dict[str, str] = {}  # duplicate key -> the first file with it
    run_of: dict[str, str] = {}  # run_id -> the file of the run kept with it
    for source, (ok, value), identity in zip(sources, outcomes, keys, strict=True):
        if not ok:
            skipped.append(value)  # type: ignore[arg-type]
            continue
        problems, _, run_id, result = value  # type: ignore[misc]
        file = str(source.path)
        if identity is not None and identity in first_of:  # a copy first: analysed once
            problems = (_duplicate(first_of[identity], file),)
        elif run_id in run_of:  # another log: two runs under one name cannot be told apart
            skipped.append(_same_run_id(run_of[run_id], file, run_id))
            continue
        else:
            results.append(result)
            run_of[run_id] = file
            if identity is not None:
                first_of[identity] = file
        if problems and on_problems is not None:
            on_problems(file, problems)
    return results, skipped


def _same_run_id(first: str, this: str, run_id: str) -> Skipped:
    return Skipped(
        this,
        f"{this}: run_id '{run_id}' is also the run_id of {first}, a different log: left "
        "out, not merged with it into one run (give each run its own run_id in its metadata "
        "or runs.csv)",
    )


def _duplicate_keys(
    sources: list[LogSource],
    outcomes: list[tuple[bool, object]],
    options: ReadOptions,
    jobs: int | None,
    cache: ParseCache | None,
) -> list[str | None]:
    """Each log's key for finding duplicates (None: not looked for, or unknown): its
    `run_fingerprint` when no other log in the batch shares it, else its `run_identity`,
    computed by reading the log again (a log that cannot be read again, or whose samples
    changed since, gets a key of its own). Logs with equal keys hold the same samples."""
    fingerprints: list[str | None] = [
        value[1] if ok else None  # type: ignore[index]
        for ok, value in outcomes
    ]
    counts: dict[str, int] = {}
    for fingerprint in fingerprints:
        if fingerprint is not None:
            counts[fingerprint] = counts.get(fingerprint, 0) + 1
    shared = [k for k, f in enumerate(fingerprints) if f is not None and counts[f] > 1]
    keys: list[str | None] = [f"fingerprint {f}" if f is not None else None for f in fingerprints]
    if not shared:
        return keys

    def identity(k: int) -> str:
        source = sources[k]
        try:
            if cache is not None:
                run = cache.process(
                    source.path, options, source.read_overrides, origin=source.origin
                )
            else:
                from wifibot_power.io.reader import read_log

                run = read_log(source.path, options, source.read_overrides, origin=source.origin)
        except Exception:  # noqa: BLE001 - analysed already: not compared, kept as distinct
            return f"unread {k}"
        if run_fingerprint(run) != fingerprints[k]:  # changed since it was analysed
            return f"changed {k}"
        return f"identity {run_identity(run)}"

    from wifibot_power.parallel import map_ordered  # only when logs share a fingerprint

    for k, key in zip(shared, map_ordered(shared, identity, jobs=jobs), strict=True):
        keys[k] = key
    return keys


def _duplicate(first: str, this: str) -> Problem:
    if Path(first).resolve() == Path(this).resolve():  # named twice (or inside a folder named)
        return Problem("duplicate", "given twice in this batch: analysed once")
    return Problem(
        "duplicate",
        f"the same samples as {first} (a copy, or the same log compressed): analysed once, "
        f"as {first}",
    )


def _keeping_problems(memo: ResultMemo[T]) -> ResultMemo[Outcome[T]]:
    """`memo`, keeping the run's problems, identity and run_id beside its result, so a result
    taken from the cache still says what reading the log found, and is still known as a
    duplicate or as a run_id another log has."""
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
        key=f"{memo.key} +problems +fingerprint +run_id", to_json=to_json, from_json=from_json
    )


def _kept_outcomes(
    sources: list[LogSource],
    cache: ParseCache | None,
    memo: ResultMemo[T] | None,
    options: ReadOptions,
    on_done: Callable[[LogSource], None] | None,
) -> list[tuple[bool, object] | None]:
    """Each source's kept result (as `one` returns it), looked up in this process; None for a
    source whose content has no kept result (or when there is no cache or memo)."""
    if cache is None or memo is None:
        return [None] * len(sources)
    from wifibot_power.cache import MISSING

    keeping = _keeping_problems(memo)
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
