"""A Parquet cache of parsed logs, so a second run over the same files skips the CSV parsing.

An entry is the `Run` a log parses to: `<key>.parquet` (power, time, speed and channel columns;
metadata and problems in the Parquet key-value metadata) and `<key>.json` beside it (what the
entry is valid for: the file's stat and content hash). It is looked up by what the parse
depends on: the path as given, the reading options, the manifest values, and a digest of the
reader's own source code (a new wbpower reads the logs afresh). It is valid only for the
file's content:

- The content key is the SHA-256 of the file's bytes as stored (compressed bytes for .gz/.zst).
- Hashing a large corpus costs a fair share of parsing it, so, as git does for its index, a
  file whose `stat` (size, mtime, ctime, inode, device) is what it was when it was hashed is
  taken as unchanged, without reading it. Any write changes the ctime, which no program can
  set back. The one hole, a rewrite within the file system's timestamp tick, is closed the way
  git closes it ("racy git"): when the file's times were less than `SETTLE_S` before the
  moment it was read, the entry is marked unsettled and its content is hashed again at the
  next lookup (which marks it settled once it is).
- A changed file therefore never hits the cache: its stat differs, its bytes are hashed again,
  the hash differs, and it is parsed and its entry replaced (one entry per input, so a cache
  does not grow with edits).

A batch can also keep what its per-run work made of a run (`ResultMemo`: `fit` keeps each
run's row and phases, as a small JSON document), beside the parse and valid for the same
content, under a key that holds a digest of all of wifibot_power's code and the numeric
libraries' versions (`code_digest`): a warm `fit --cache` then neither parses nor segments,
and `kept_result` finds those results in the calling process without starting any worker.
A batch can keep what it made of all its runs together too (`kept_batch` / `keep_batch`:
`fit` keeps its fit, valid for the exact per-run rows it was fitted on), so a warm
`fit --cache` whose runs are all unchanged neither fits again nor loads numpy.

Every file's name starts with a tag of the code it is valid for, and a new `ParseCache`
deletes the files of other tags (`ParseCache.sweep`): without that, each new version of
wbpower (or each edit of its code) left a corpus's worth of parses behind for good.

What could still fool it: a system clock stepped back by more than `SETTLE_S` between runs, or
a network file system whose server clock runs more than `SETTLE_S` behind this machine's.
Delete the cache folder after either. Logs that fail to read are never cached. A cache entry
that cannot be read (cut short, another format) is a miss; a cache that cannot be written is
not an error (the result does not depend on it).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Generic, TypeVar

from wifibot_power.errors import UsageError
from wifibot_power.io.options import ReadOptions, codec_of, is_read_whole
from wifibot_power.run import Run
from wifibot_power.run_parquet import load_run as _load_run
from wifibot_power.run_parquet import run_table

#: Version of the entry layout; part of every key (2: the speed and channel columns; 3: the
#: rate of turn and the per-sample surface).
CACHE_FORMAT = 3
#: A file whose times are this close to when it was read may still change unseen [s].
SETTLE_S = 2.0
SETTLE_NS = int(SETTLE_S * 1e9)
_CONTENT_KEY = b"wbpower.content_sha256"
#: What `ParseCache.kept_result` returns when nothing is kept for the content.
MISSING = object()
T = TypeVar("T")


@functools.lru_cache(maxsize=1)
def reader_digest() -> str:
    """SHA-256 of the source of everything a parse depends on (the io package, run.py, this
    and the table form it stores, run_parquet.py)."""
    package = Path(__file__).parent
    digest = hashlib.sha256(f"cache format {CACHE_FORMAT}".encode())
    for source in sorted(
        [
            *package.joinpath("io").rglob("*.py"),  # the formats/ modules too
            package / "run.py",
            package / "run_parquet.py",
            package / "errors.py",
            Path(__file__),
        ]
    ):
        digest.update(source.name.encode())
        digest.update(source.read_bytes())
    return digest.hexdigest()


def _tag(digest: str) -> str:
    """The first characters of a code digest that start a cache file's name (`sweep`)."""
    return digest[:12]


#: The names a cache's files have (`ParseCache.sweep`): a parse and its validity; a kept
#: result (code tag, then its parse's name); a kept batch; the layout before tags; a
#: temporary file (`_replace`).
_PARSE_NAME = re.compile(r"(?P<reader>[0-9a-f]{12})-[0-9a-f]{40}\.(?:parquet|json)")
_RESULT_NAME = re.compile(
    r"(?P<code>[0-9a-f]{12})-(?P<reader>[0-9a-f]{12})-[0-9a-f]{40}\.[0-9a-f]{16}\.result\.json"
)
_BATCH_NAME = re.compile(r"(?P<code>[0-9a-f]{12})-[0-9a-f]{40}\.batch\.json")
_UNTAGGED_NAME = re.compile(r"[0-9a-f]{40}(?:\.[0-9a-f]{16}\.result|\.batch)?\.(?:parquet|json)")
_TEMP_NAME = re.compile(r"\.(?P<name>.+)\.\d+\.tmp")
#: A temporary file this old is left from a writer that was killed [ns].
_TEMP_AGE_NS = 24 * 3600 * 10**9


def _is_cache_name(name: str) -> bool:
    """Whether `name` is one a cache file has (`_replace`'s temporary files carry it)."""
    patterns = (_PARSE_NAME, _RESULT_NAME, _BATCH_NAME, _UNTAGGED_NAME)
    return any(pattern.fullmatch(name) for pattern in patterns)


def _untagged_is_ours(path: Path) -> bool:
    """Whether a file named as the layout before tags was written by a cache: a JSON
    document with its keys, or a Parquet entry beside such a document. A user's file that
    only looks like one (40 hex digits) is never deleted."""
    document = path if path.suffix == ".json" else path.with_suffix(".json")
    try:
        if document.stat().st_size > _UNTAGGED_JSON_MAX:
            return False
        kept = json.loads(document.read_bytes())
    except (OSError, ValueError):
        return False
    return isinstance(kept, dict) and bool({"cache_format", "content_sha256"} & set(kept))


#: A cache's JSON documents are small (a run's row and phases); larger is not one of them.
_UNTAGGED_JSON_MAX = 16 << 20


def _fingerprint(stat: os.stat_result) -> list[int]:
    return [stat.st_size, stat.st_mtime_ns, stat.st_ctime_ns, stat.st_ino, stat.st_dev]


def _identity(run: Run) -> Run:
    return run


@dataclasses.dataclass(frozen=True)
class ResultMemo(Generic[T]):
    """How to keep what a batch's per-run work made of a run, beside the parse.

    `key` names the work and everything its result depends on (e.g. a digest of the code that
    computes it: `code_digest()`); `to_json` / `from_json` are an exact round trip of the
    result through JSON values (dicts, lists, str, float with NaN, int, bool, None). A kept
    result is valid for the same content as the parse. JSON, not Parquet: a warm batch reads
    a small document per file and needs neither pyarrow.parquet nor pandas to do it.
    """

    key: str
    to_json: Callable[[T], object]
    from_json: Callable[[object], T]


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 of all of wifibot_power's source and the numeric libraries' versions: a result
    computed by other code, or other numpy/pandas/scipy/pyarrow, is computed again. The
    versions are found without importing the libraries (pandas and scipy cost ~0.7 s to
    import: a warm run needs neither; `_installed_version`)."""
    package = Path(__file__).parent
    versions = " ".join(_installed_version(n) for n in ("numpy", "pandas", "scipy", "pyarrow"))
    digest = hashlib.sha256(versions.encode())
    for source in sorted(package.rglob("*.py")):
        digest.update(str(source.relative_to(package)).encode())
        digest.update(source.read_bytes())
    return digest.hexdigest()


def _installed_version(name: str) -> str:
    """The installed version of distribution `name`, from the name of its `.dist-info` folder
    beside the package (`{name}-{version}.dist-info`, the wheel spec, PEP 427), found without
    importing the package; else from `importlib.metadata` (whose import and header parsing
    cost ~20 ms of a warm run)."""
    import importlib.util

    spec = importlib.util.find_spec(name)
    if spec is None:
        return "absent"
    if spec.origin:
        found = sorted(Path(spec.origin).parent.parent.glob(f"{name}-*.dist-info"))
        if len(found) == 1:
            return found[0].name[len(name) + 1 : -len(".dist-info")]
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return "absent"


@functools.lru_cache(maxsize=16)
def _options_key(options: ReadOptions) -> dict[str, object]:
    return dataclasses.asdict(options)  # a deep copy: once per batch, not once per file


@dataclasses.dataclass(frozen=True)
class ParseCache:
    """A folder of cached parses (`--cache DIR`). Safe to share between concurrent workers:
    entries are written to a temporary file and renamed into place."""

    directory: Path

    def __post_init__(self) -> None:
        directory = Path(self.directory)
        object.__setattr__(self, "directory", directory)
        try:
            directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UsageError(
                f"cannot create the cache folder ({exc.strerror or exc})",
                file=directory,
                fix="give a writable folder with --cache",
            ) from None
        self.sweep()

    def sweep(self) -> int:
        """Delete what no run of this wbpower can use again; returns how many files went.

        Every file's name starts with the tag of the code it is valid for (`_tag`): a parse
        and what it is valid for, the reader's; a kept result, all of wifibot_power's code
        (and the reader's of its parse); a kept batch, all the code. A file of another tag was
        written by another version of wbpower (an upgrade, an edit) and would never be read
        again, so without this a cache would grow by a corpus's worth with every version.
        Also deleted: files of the layout before tags (JSON documents with the cache's keys,
        and Parquet entries beside them), and the cache's temporary files left by a writer
        that was killed, a day old. Other files in the folder are never touched. Run once per
        `ParseCache`, in the process that makes it: a scan of the folder (~1 ms a thousand
        files). Two versions of wbpower sharing one folder delete each other's entries (each
        parses again); give each its own."""
        reader_tag, code_tag = _tag(reader_digest()), _tag(code_digest())
        old_enough_ns = time.time_ns() - _TEMP_AGE_NS
        removed = 0
        doomed: list[str] = []
        try:
            listing = list(os.scandir(self.directory))
        except OSError:
            return 0
        for item in listing:
            name = item.name
            if match := _PARSE_NAME.fullmatch(name):
                stale = match["reader"] != reader_tag
            elif match := _RESULT_NAME.fullmatch(name):
                stale = match["code"] != code_tag or match["reader"] != reader_tag
            elif match := _BATCH_NAME.fullmatch(name):
                stale = match["code"] != code_tag
            elif _UNTAGGED_NAME.fullmatch(name):
                stale = _untagged_is_ours(Path(item.path))
            elif (match := _TEMP_NAME.fullmatch(name)) and _is_cache_name(match["name"]):
                try:
                    stale = item.stat(follow_symlinks=False).st_mtime_ns < old_enough_ns
                except OSError:
                    stale = False
            else:
                continue
            if stale and item.is_file(follow_symlinks=False):
                doomed.append(item.path)  # deleted after the scan: an untagged Parquet entry
                # is judged by the JSON beside it
        for path in doomed:
            try:
                os.unlink(path)
                removed += 1
            except OSError:
                pass  # another sweep got it, or a read-only folder: nothing depends on it
        return removed

    def entry_path(
        self,
        path: Path,
        options: ReadOptions,
        overrides: dict[str, str] | None,
        origin: str | None,
    ) -> Path:
        """Where the parse of `path` with these reading inputs is kept."""
        inputs = json.dumps(
            [
                reader_digest(),
                str(path),
                _options_key(options),
                sorted((overrides or {}).items()),
                origin,
            ],
            sort_keys=True,
        )
        named = hashlib.sha256(inputs.encode()).hexdigest()[:40]
        return self.directory / f"{_tag(reader_digest())}-{named}.parquet"

    def read_log(
        self,
        path: str | Path,
        options: ReadOptions | None = None,
        overrides: dict[str, str] | None = None,
        *,
        origin: str | None = None,
    ) -> Run:
        """`io.read_log`, from the cache when the file's content has been parsed before."""
        return self.process(path, options, overrides, origin=origin)

    def kept_result(
        self,
        path: str | Path,
        options: ReadOptions | None = None,
        overrides: dict[str, str] | None = None,
        *,
        origin: str | None = None,
        memo: ResultMemo[T],
    ) -> T | object:
        """The kept result of `memo`'s work on the file's current content, or `MISSING`.

        Cheap when the file is settled and unchanged (a stat and two small reads), so a
        batch can sort hits from misses in the calling process before starting any worker.
        The content rule is the same as `process`'s: a changed file is hashed and misses.
        """
        path = Path(path)
        options = options or ReadOptions()
        if is_read_whole(path):
            return MISSING  # not cached: read by its own library (`process`)
        try:
            stat = os.stat(path)
        except OSError:
            return MISSING  # the worker reading it names the problem
        entry = self.entry_path(path, options, overrides, origin)
        validity = _read_validity(entry)
        content, fresh = self._content(path, stat, validity)
        kept = _load_result(_result_path(entry, memo), content, memo)
        if kept is not MISSING and validity is not None and fresh != validity:
            if validity["content_sha256"] == content:  # touched, or settled: trust stat next
                _write_validity(entry, fresh)
        return kept

    @staticmethod
    def _content(
        path: Path, stat: os.stat_result, validity: dict | None
    ) -> tuple[str, dict[str, object]]:
        """The file's content hash, from the entry when its stat is trusted, else by reading."""
        if validity and validity["settled"] and validity["fingerprint"] == _fingerprint(stat):
            return validity["content_sha256"], validity
        _, fresh = _hash(path, stat)
        return str(fresh["content_sha256"]), fresh

    def process(
        self,
        path: str | Path,
        options: ReadOptions | None = None,
        overrides: dict[str, str] | None = None,
        *,
        origin: str | None = None,
        work: Callable[[Run], T] = _identity,
        memo: ResultMemo[T] | None = None,
    ) -> T:
        """`work(read_log(path, ...))`, skipping the parse when the content was parsed before,
        and skipping the work too when `memo` says how to keep its result and it is kept."""
        from wifibot_power.io.reader import read_log  # here, not above: `kept_result` needs none

        path = Path(path)
        options = options or ReadOptions()
        if is_read_whole(path):  # a bag folder has no bytes to hash, a recording too many
            return work(read_log(path, options, overrides, origin=origin))
        try:
            stat = os.stat(path)
        except OSError:
            return work(read_log(path, options, overrides, origin=origin))  # its own error
        entry = self.entry_path(path, options, overrides, origin)
        validity = _read_validity(entry)
        raw: bytes | None = None
        if validity and validity["settled"] and validity["fingerprint"] == _fingerprint(stat):
            content, fresh = validity["content_sha256"], validity
        else:
            raw, fresh = _hash(path, stat)
            content = fresh["content_sha256"]
        known = validity is not None and validity["content_sha256"] == content
        if memo is not None:
            kept = _load_result(_result_path(entry, memo), content, memo)
            if kept is not MISSING:
                if known and fresh != validity:  # touched, or settled since: trust stat next
                    _write_validity(entry, fresh)
                return kept  # type: ignore[return-value]
        run = _load_run(entry, content) if known else None
        if run is None:
            if raw is None:  # stat was trusted but the entry is gone: read and hash afresh
                raw, fresh = _hash(path, stat)
                content = fresh["content_sha256"]
            run = read_log(path, options, overrides, data=_decompressed(path, raw), origin=origin)
            _store(entry, run, fresh)
        elif fresh != validity:
            _write_validity(entry, fresh)
        result = work(run)
        if memo is not None:
            _store_result(_result_path(entry, memo), memo.to_json(result), content)
        return result

    def batch_path(self, inputs: object) -> Path:
        """Where the kept result of the batch named by `inputs` (JSON values: e.g. the paths,
        the reading options and the work's key) is: one document per batch, replaced when
        what it is valid for changes, so the cache does not grow with edits."""
        named = json.dumps(inputs, sort_keys=True).encode()
        return (
            self.directory
            / f"{_tag(code_digest())}-{hashlib.sha256(named).hexdigest()[:40]}.batch.json"
        )

    def kept_batch(self, inputs: object, content_sha256: str) -> object:
        """The JSON value kept for the batch `inputs` when it was made from `content_sha256`
        (a digest of everything it depends on), else `MISSING`."""
        try:
            kept = json.loads(self.batch_path(inputs).read_bytes())
            if kept["content_sha256"] != content_sha256:
                return MISSING
            return kept["result"]
        except (OSError, KeyError, TypeError, ValueError):
            return MISSING

    def keep_batch(self, inputs: object, content_sha256: str, result: object) -> None:
        """Keep `result` (JSON values) for the batch `inputs` made from `content_sha256`; a
        result that cannot be written or encoded is not kept (nothing depends on it)."""
        try:
            _store_result(self.batch_path(inputs), result, content_sha256)
        except (TypeError, ValueError):
            pass


def _hash(path: Path, stat: os.stat_result) -> tuple[bytes, dict[str, object]]:
    """The file's bytes and what an entry made from them is valid for."""
    read_at_ns = time.time_ns()
    raw = path.read_bytes()
    return raw, {
        "fingerprint": _fingerprint(stat),
        "content_sha256": hashlib.sha256(raw).hexdigest(),
        "settled": max(stat.st_mtime_ns, stat.st_ctime_ns) < read_at_ns - SETTLE_NS,
    }


def _result_path(entry: Path, memo: ResultMemo) -> Path:
    work = hashlib.sha256(memo.key.encode()).hexdigest()[:16]
    return entry.with_name(f"{_tag(code_digest())}-{entry.stem}.{work}.result.json")


def _load_result(path: Path, content_sha256: str, memo: ResultMemo[T]) -> T | object:
    """The kept result of the work on this content, or `MISSING`."""
    try:
        kept = json.loads(path.read_bytes())
        if kept["content_sha256"] != content_sha256:
            return MISSING
        return memo.from_json(kept["result"])
    except (OSError, KeyError, TypeError, ValueError, AttributeError):
        return MISSING


def _store_result(path: Path, result: object, content_sha256: str) -> None:
    # NaN is kept as NaN (Python's json writes and reads it back exactly); floats round-trip
    # bit for bit through repr
    document = json.dumps({"content_sha256": content_sha256, "result": result})
    _replace(path, lambda tmp: tmp.write_text(document, encoding="utf-8"))


def _decompressed(path: Path, raw: bytes) -> bytes | None:
    """The bytes `read_log` parses (None: let it read the file and name the problem)."""
    codec = codec_of(path)
    if codec is None:
        return raw
    import pyarrow as pa

    try:
        with pa.input_stream(pa.BufferReader(raw), compression=codec) as stream:
            return stream.read()
    except (OSError, pa.ArrowException):
        return None


def _validity_path(entry: Path) -> Path:
    return entry.with_suffix(".json")


def _read_validity(entry: Path) -> dict | None:
    """What the entry is valid for: the file's stat fingerprint and content hash (or None)."""
    try:
        validity = json.loads(_validity_path(entry).read_text(encoding="utf-8"))
        return validity if validity.get("cache_format") == CACHE_FORMAT else None
    except (OSError, ValueError, AttributeError):
        return None


def _write_validity(entry: Path, validity: dict[str, object]) -> None:
    _replace(
        _validity_path(entry),
        lambda tmp: tmp.write_text(
            json.dumps({"cache_format": CACHE_FORMAT, **validity}), encoding="utf-8"
        ),
    )


def _store(entry: Path, run: Run, validity: dict[str, object]) -> None:
    """Write the parse (Parquet, `run_parquet.run_table`), then what it is valid for (JSON
    beside it)."""
    import pyarrow.parquet as pq

    table = run_table(run, validity["content_sha256"])
    # no compression, dictionary or statistics: measured power does not compress, and this is
    # the fastest layout to read back
    written = _replace(
        entry,
        lambda tmp: pq.write_table(
            table, tmp, compression="none", use_dictionary=False, write_statistics=False
        ),
    )
    if written:
        _write_validity(entry, validity)


def _replace(path: Path, write: Callable[[Path], object]) -> bool:
    """Write through a temporary file renamed into place (atomic for concurrent readers).

    No fsync: an entry lost in a crash is only a parse to do again. A write that fails (full
    disk, read-only folder) costs the next run a parse, nothing else: False is returned.
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)
        return False
    except BaseException:  # interrupted (a stopped worker unwinds): no half-written entry
        tmp.unlink(missing_ok=True)
        raise
    return True
