"""One run per recording and per run_id in a batch (log-format.md): the last stage of
`pipeline.batch.map_runs`.

The same log given twice in one batch (a copy, a renamed copy, the .csv and its .csv.gz) is
analysed once, with a warning naming both files: each worker returns the run's
`run_fingerprint`, a cheap key that the same samples always share, and the calling process
keeps the first of each. Only logs whose fingerprints are equal are read again, for their
`run_identity` (a SHA-256 of the samples): two logs are duplicates when those are equal,
never on the fingerprint alone.

A log whose samples are part of another log of the batch (a piece cut from it: the F1/10
excerpts, BorealTC's snow runs pro_12 and pro_13) is left out alike, said as a "piece"
problem; two logs that share a stretch of samples are both kept, the later with an
"overlap" problem (`pipeline.pieces`: each worker's fingerprint carries its run's piece
signature).

A run_id names one run of the batch: of two different logs that give one run_id in their
metadata or the manifest, the later is left out, listed in `skipped` with both files named:
never merged into one run. Copies are found first, so a copy (which has its original's
run_id) stays a duplicate, not a contradiction.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from wifibot_power.io.discover import LogSource, Skipped
from wifibot_power.io.options import ReadOptions
from wifibot_power.pipeline import pieces  # no numpy until used: loaded before workers fork
from wifibot_power.run import Problem, Run

if TYPE_CHECKING:
    from wifibot_power.cache import ParseCache

T = TypeVar("T")

#: What a worker returns for a log: its problems, its fingerprint (None: not asked for), its
#: run_id and what the work made of it.
Outcome = tuple[tuple[Problem, ...], str | None, str, T]

#: `hook(file, problems)`: called in the calling process for each log read with problems.
ProblemHook = Callable[[str, tuple[Problem, ...]], None]


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
    (`duplicate_keys`)."""
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


def batch_fingerprint(run: Run) -> str:
    """What a worker returns to find copies and pieces: `run_fingerprint`, then the run's
    piece signature (`pipeline.pieces`; both are the samples' alone)."""
    return f"{run_fingerprint(run)}#{pieces.piece_signature(run).encode()}"


def duplicate_keys(
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
        if batch_fingerprint(run) != fingerprints[k]:  # changed since it was analysed
            return f"changed {k}"
        return f"identity {run_identity(run)}"

    from wifibot_power.parallel import map_ordered  # only when logs share a fingerprint

    for k, key in zip(shared, map_ordered(shared, identity, jobs=jobs), strict=True):
        keys[k] = key
    return keys


def settle(
    sources: Sequence[LogSource],
    outcomes: Sequence[tuple[bool, object]],
    keys: Sequence[str | None],
    skipped: list[Skipped],
    on_problems: ProblemHook | None = None,
) -> list[object]:
    """The results of the batch, one per recording and per run_id, in the order of the logs:
    a failed log's `Skipped` goes to `skipped`; a copy of a log before it, or a piece of
    another log, is left out and said as a "duplicate" or "piece" problem; a log sharing
    samples with another keeps an "overlap" problem; a different log with the run_id of a
    log before it is left out as a `Skipped` naming both. `on_problems(file, problems)` is
    called for each log read with problems."""
    copies = _copies(keys)
    piece_of, shared = _kept_pieces(sources, outcomes, copies)
    results: list[object] = []
    run_of: dict[str, str] = {}  # run_id -> the file of the run kept with it
    for k, (source, (ok, value)) in enumerate(zip(sources, outcomes, strict=True)):
        if not ok:
            skipped.append(value)  # type: ignore[arg-type]
            continue
        problems, _, run_id, result = value  # type: ignore[misc]
        file = str(source.path)
        if k in copies:  # a copy first: analysed once
            problems = (_duplicate(str(sources[copies[k]].path), file),)
        elif k in piece_of:
            problems = (piece_of[k],)
        elif run_id in run_of:  # another log: two runs under one name cannot be told apart
            skipped.append(_same_run_id(run_of[run_id], file, run_id))
            continue
        else:
            results.append(result)
            run_of[run_id] = file
            problems = (*problems, *shared.get(k, ()))
        if problems and on_problems is not None:
            on_problems(file, problems)
    return results


def _copies(keys: Sequence[str | None]) -> dict[int, int]:
    """Each log that is a copy of a log before it -> that log's index."""
    first_of: dict[str, int] = {}
    copies: dict[int, int] = {}
    for k, key in enumerate(keys):
        if key is None:
            continue
        if key in first_of:
            copies[k] = first_of[key]
        else:
            first_of[key] = k
    return copies


def _kept_pieces(
    sources: Sequence[LogSource], outcomes: Sequence[tuple[bool, object]], copies: dict[int, int]
) -> tuple[dict[int, Problem], dict[int, list[Problem]]]:
    """`_pieces`, with only logs the batch keeps as the longer logs: a log left out for its
    run_id (`_run_id_left_out`) takes no piece with it, or the piece's samples would be in
    neither. Kept so, a piece may then clash by run_id itself and leave out a log after it
    (with its own pieces): repeated until nothing more is left out (each round only adds)."""
    found = pieces.overlaps(_signatures(outcomes, copies))
    left_out: set[int] = set()
    while True:
        piece_of, shared = _pieces(sources, found, left_out)
        more = _run_id_left_out(outcomes, set(copies) | set(piece_of))
        if more <= left_out:
            return piece_of, shared
        left_out |= more


def _signatures(
    outcomes: Sequence[tuple[bool, object]], copies: dict[int, int]
) -> list[str | None]:
    """Each log's piece signature (None: not read, a copy, or none returned)."""
    signatures: list[str | None] = [None] * len(outcomes)
    for k, (ok, value) in enumerate(outcomes):
        fingerprint = value[1] if ok else None  # type: ignore[index]
        if k not in copies and fingerprint is not None and "#" in fingerprint:
            signatures[k] = fingerprint.split("#", 1)[1]
    return signatures


def _run_id_left_out(outcomes: Sequence[tuple[bool, object]], dropped: set[int]) -> set[int]:
    """The logs `settle` leaves out for a run_id a log before them has, `dropped` (copies
    and pieces) aside."""
    seen: set[str] = set()
    left_out: set[int] = set()
    for k, (ok, value) in enumerate(outcomes):
        if not ok or k in dropped:
            continue
        run_id = value[2]  # type: ignore[index]
        if run_id in seen:
            left_out.add(k)
        seen.add(run_id)
    return left_out


def _pieces(
    sources: Sequence[LogSource], found: Sequence[pieces.Overlap], left_out: set[int]
) -> tuple[dict[int, Problem], dict[int, list[Problem]]]:
    """The logs that are pieces of another (index -> its "piece" problem) and those that
    share samples with another ("overlap" problems), of the overlaps `found`, those with a
    log in `left_out` aside."""
    piece_of: dict[int, Problem] = {}
    shared: dict[int, list[Problem]] = {}
    for overlap in found:
        if overlap.this in left_out or overlap.other in left_out:
            continue
        other = str(sources[overlap.other].path)
        if overlap.is_piece:
            piece_of.setdefault(overlap.this, _piece(other, overlap.offset))
        elif overlap.this > overlap.other:  # said of the later log
            shared.setdefault(overlap.this, []).append(_overlap(other, overlap.share, ours=True))
        else:
            this = str(sources[overlap.this].path)
            shared.setdefault(overlap.other, []).append(_overlap(this, overlap.share, ours=False))
    return piece_of, shared


def _piece(other: str, offset: int) -> Problem:
    return Problem(
        "piece",
        f"its samples are part of {other} (from its sample {offset}): analysed once, as "
        f"{other} (give a recording once, whole or in pieces, not both)",
    )


def _overlap(other: str, share: float, *, ours: bool) -> Problem:
    """`share` of the shorter log's samples are in the longer: this log's (`ours`) or
    `other`'s."""
    whose = (
        f"about {share:.0%} of its samples are also in {other}"
        if ours
        else (f"it holds about {share:.0%} of the samples of {other}")
    )
    return Problem(
        "overlap",
        f"{whose}: a fit counts them twice, and the held-out check may test on samples it "
        "was fitted on (give each stretch of a recording once)",
    )


def _same_run_id(first: str, this: str, run_id: str) -> Skipped:
    return Skipped(
        this,
        f"{this}: run_id '{run_id}' is also the run_id of {first}, a different log: left "
        "out, not merged with it into one run (give each run its own run_id in its metadata "
        "or runs.csv)",
    )


def _duplicate(first: str, this: str) -> Problem:
    if Path(first).resolve() == Path(this).resolve():  # named twice (or inside a folder named)
        return Problem("duplicate", "given twice in this batch: analysed once")
    return Problem(
        "duplicate",
        f"the same samples as {first} (a copy, or the same log compressed): analysed once, "
        f"as {first}",
    )
