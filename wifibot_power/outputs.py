"""Writing results: every file is written atomically (temp file in the same folder, then rename),
so a crash or kill mid-write leaves the previous output intact; the files of one `-o DIR`
are written as a set (`write_set`): all new, or, stopped before the end, all as they were."""

from __future__ import annotations

import contextlib
import functools
import gc
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping
from datetime import date, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.errors import UsageError

if TYPE_CHECKING:
    import pandas as pd


def json_safe(value: object) -> object:
    """Plain JSON types: NaN/inf -> None, numpy scalars and arrays -> Python, tuples -> lists,
    paths -> str, datetimes -> ISO 8601."""
    kind = type(value)
    if kind in _PLAIN:  # the leaves of a document, first (most of its values)
        return value
    if kind is float:
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    np = sys.modules.get("numpy")  # not loaded (a warm `fit --json`): no array to convert
    if np is not None and isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, datetime | date):
        return value.isoformat()
    if hasattr(value, "item") and not isinstance(value, str | bytes):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


#: Types `json_safe` returns as they are (exactly these: not their subclasses).
_PLAIN = frozenset((str, int, bool, type(None)))


def write_atomic(path: Path, write: Callable[[Path], None]) -> Path:
    """Call `write(tmp_path)` and move the result onto `path` in one rename.

    The temporary file sits in the same folder (a rename across file systems is not atomic),
    is flushed to disk before the rename, and is removed if `write` fails. Readers of `path`
    see the old file or the new one, never a mixture; a SIGKILL at any moment leaves at worst
    a stray `.NAME.*.tmp` beside it.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temporary(path)
    try:
        _write_flushed(tmp, write)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)
    return path


@functools.cache
def _umask() -> int:
    # read once: os.umask can only be read by setting it
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _fsync_dir(folder: Path) -> None:
    """Make the rename itself durable (POSIX); not possible, nor needed, everywhere."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """CPython's cyclic garbage collector held off while a document is built or written (and
    set back as it was, on an exception too). A `fit --json` document holds a dict per
    held-out trip (16,568 on the bench corpus): that many new containers set off the
    collector, whose oldest generation walks the whole heap (~0.05-0.09 s of the parent's
    0.15 s `summary()` on the bench corpus, docs/benchmarks.md). The document makes no
    reference cycle, so nothing is left for it to collect; the values are the same."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


class _KeyNotStr:
    """`_indented`'s flag: a dict key that is not a str was met (`seen` makes it one)."""

    found = False

    @classmethod
    def seen(cls, key: object) -> str:
        cls.found = True
        return str(key)


def dumps_indented(data: object) -> str:
    """`json.dumps(json_safe(data), indent=2, allow_nan=False)`, character for character, in
    one pass: CPython's encoder drops to pure-Python generators whenever `indent` is set
    (3.11). A `fit --json` document of 16,568 held-out trips (4.6 MB): 0.195 s for
    `json_safe` and `json.dumps`, 0.116 s here (measured without a profiler, which makes
    the generators look ~3x dearer). Strings are encoded by json's own C function, floats
    by `float.__repr__` as json does; a leaf of any other type goes through `json_safe` and,
    if still not plain, `json.dumps` itself (which raises TypeError as it would)."""
    _KeyNotStr.found = False  # (left set by a call that raised)
    with gc_paused():
        return _indented(data, "\n")


def _indented(value: object, pad: str) -> str:
    """`value` indented by 2 per level; `pad` is a line end and the current indentation."""
    kind = type(value)
    if kind is str:
        return _encode_str(value)
    if kind is float:
        return float.__repr__(value) if math.isfinite(value) else "null"
    if kind is int:
        return int.__repr__(value)
    if value is None:
        return "null"
    if value is True:
        return "true"
    if value is False:
        return "false"
    if kind is dict or isinstance(value, dict):
        if not value:
            return "{}"
        inner = pad + "  "
        outer, _KeyNotStr.found = _KeyNotStr.found, False  # (a dict inside keeps its own)
        items = [
            _encode_str(k if type(k) is str else _KeyNotStr.seen(k)) + ": " + _indented(v, inner)
            for k, v in value.items()
        ]
        mine, _KeyNotStr.found = _KeyNotStr.found, outer
        if mine:  # a key not a str: made one as json_safe does, where two keys may then be
            # one ({'False': 1, False: 2} is {"False": 2}: the first's place, the last's
            # value); found so, without a Python test per key of every other dict
            value = {str(k): v for k, v in value.items()}
            items = [_encode_str(k) + ": " + _indented(v, inner) for k, v in value.items()]
        return "{" + inner + ("," + inner).join(items) + pad + "}"
    if kind is list or isinstance(value, list | tuple):
        if not value:
            return "[]"
        inner = pad + "  "
        return "[" + inner + ("," + inner).join([_indented(v, inner) for v in value]) + pad + "]"
    safe = json_safe(value)
    if type(safe) in _PLAIN or type(safe) is float or isinstance(safe, dict | list):
        return _indented(safe, pad)
    return json.dumps(safe, allow_nan=False)  # a str or int subclass, or TypeError


#: json's own string encoder (its C version where built), as `json.dumps` uses by default
_encode_str = json.encoder.encode_basestring_ascii


def json_file(data: object) -> Callable[[Path], None]:
    """What writes `data` as indented JSON (NaN -> null) to a path (`write_atomic`,
    `write_set`); the document is made now, so a value JSON cannot hold fails here."""
    text = dumps_indented(data) + "\n"
    return lambda path: path.write_text(text, encoding="utf-8")


def parquet_file(frame: pd.DataFrame) -> Callable[[Path], None]:
    """What writes `frame` as Parquet (no index) to a path (`write_atomic`, `write_set`)."""
    return lambda path: frame.to_parquet(path, index=False)


def write_json(path: Path, data: object) -> Path:
    """`data` as indented JSON (NaN -> null), written atomically."""
    return write_atomic(path, json_file(data))


def write_parquet(path: Path, frame: pd.DataFrame) -> Path:
    """`frame` as Parquet (no index), written atomically."""
    return write_atomic(path, parquet_file(frame))


def write_text(path: Path, text: str) -> Path:
    """UTF-8 text, written atomically."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


#: What this process has written in full so far (`write_set`, `staged_folder`): a command
#: stopped by Ctrl-C or SIGTERM after it wrote its outputs says so (`signals.interrupted`).
written: list[Path] = []

#: the name a stale temporary file of ours has beside `NAME` (`_temporary`)
_TEMPORARY = ".{name}.*.tmp"


def write_set(
    out_dir: Path,
    files: Mapping[str, Callable[[Path], None]],
    *,
    remove: Iterable[str] = (),
) -> list[Path]:
    """Write the files of one command's `-o DIR` as a set: `files[name](tmp_path)` writes
    each to a temporary file beside its target first; only once all are written (and
    flushed to disk) are they renamed over their targets, and the names in `remove` (what
    an earlier run left there that this one does not make, e.g. fit's `model.json`) deleted,
    with Ctrl-C and SIGTERM held off for those renames (`signals.held`).

    One writer at a time per folder: an advisory lock on DIR itself (flock(2) on the
    folder, so no lock file is left behind) is taken first; held by another process, this
    one stops with a one-line error before it writes anything (two `fit -o DIR` at once
    could otherwise leave model.json of one beside runs.parquet of the other). Under the
    lock, temporary files of these names that a killed writer left (`.NAME.*.tmp`) are
    removed.

    A failure, Ctrl-C or SIGTERM while writing leaves DIR as it was (the temporary files
    removed, folders this call created removed again), so a command writes nothing partial
    (cli.md); only a SIGKILL or power loss during the renames themselves can leave some new,
    some old. An error writing a file names it. Returns the files written, in the order of
    `files`.
    """
    out_dir = Path(out_dir)
    made: list[Path] = []
    staged: list[tuple[Path, Path]] = []
    lock: int | None = None
    try:
        try:
            with hold_ctrl_c():
                made = make_dirs(out_dir)
            try:
                lock = _lock_folder(out_dir)
            except FolderLockedError:
                made = []  # the folder is another writer's now: left as it is
                raise
            _remove_stale(out_dir, [*files, *remove])
            for name, write in files.items():
                target = out_dir / name
                with hold_ctrl_c():  # a signal comes once the file is known, to be removed
                    staged.append((_temporary(target), target))
                with _naming(target):
                    _write_flushed(staged[-1][0], write)
        except BaseException:
            for tmp, _ in staged:
                tmp.unlink(missing_ok=True)
            remove_made_dirs(made)
            raise
        with hold_ctrl_c():
            try:
                # a target that is a folder would fail its rename after the ones before it
                # were done: refused first, nothing replaced
                for _, target in staged:
                    if target.is_dir() and not target.is_symlink():
                        raise IsADirectoryError(21, "a folder is in the way", str(target))
                for tmp, target in staged:
                    os.replace(tmp, target)
            except BaseException:
                for tmp, _ in staged:
                    tmp.unlink(missing_ok=True)
                raise
            for name in remove:
                (out_dir / name).unlink(missing_ok=True)
            _fsync_dir(out_dir)
            written.extend(target for _, target in staged)
    finally:
        if lock is not None:
            os.close(lock)  # the lock goes with it
    return [target for _, target in staged]


class FolderLockedError(UsageError):
    """Another process holds an output folder's lock (`write_set`)."""


def _lock_folder(folder: Path) -> int:
    """An exclusive advisory lock (flock(2)) on `folder` itself, held until the descriptor
    returned is closed; a one-line error when another process holds it."""
    import fcntl

    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise FolderLockedError(
            "another wbpower is writing into this folder now",
            file=folder,
            fix="wait for it to finish, or write into another folder",
        ) from None
    except BaseException:
        os.close(fd)
        raise
    return fd


def _remove_stale(folder: Path, names: Iterable[str]) -> None:
    """Remove the temporary files (`.NAME.*.tmp`) of `names` that a writer killed by
    SIGKILL left in `folder`: called under the folder's lock, so no live writer owns one."""
    import glob

    for name in names:
        for stale in folder.glob(_TEMPORARY.format(name=glob.escape(name))):
            stale.unlink(missing_ok=True)


@contextlib.contextmanager
def _naming(target: Path) -> Iterator[None]:
    """An OSError writing `target`'s temporary file that names no file (pyarrow's "No space
    left on device") names `target`: the message then says which file could not be
    written."""
    try:
        yield
    except OSError as exc:
        if exc.filename is not None:
            raise
        raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from exc


def _temporary(path: Path) -> Path:
    """A new empty temporary file beside `path` (`.NAME.*.tmp`): in the same folder, since a
    rename across file systems is not atomic."""
    import tempfile  # here: a command that writes nothing (`fit --json`) does not load it

    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    return Path(tmp_name)


def _write_flushed(tmp: Path, write: Callable[[Path], None]) -> None:
    """`write(tmp)`, with the permissions a plain open() gives (mkstemp makes it 0600),
    flushed to disk."""
    write(tmp)
    os.chmod(tmp, 0o666 & ~_umask())
    with open(tmp, "rb") as handle:
        os.fsync(handle.fileno())


def probe_folder(out: Path, existing: Path) -> None:
    """Whether `-o out` can be written, tried before any work (`cli.common.check_out_dir`):
    a folder made and removed at once in `existing`, the nearest folder of `out` that
    exists. Root's access(2) says yes to /proc and /sys, which refuse; the error naming
    them came only after the work was done (issue 29)."""
    import tempfile

    try:
        os.rmdir(tempfile.mkdtemp(prefix=".wbpower-probe.", dir=existing))
    except OSError as exc:
        raise UsageError(
            f"-o {out}: cannot create anything in {existing} ({exc.strerror or exc})",
            fix="give a folder you can write to",
        ) from None


def make_dirs(folder: Path) -> list[Path]:
    """Create `folder` and its missing parents; return those created, outermost first (for
    `remove_made_dirs` to undo)."""
    folder = Path(folder).absolute()
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    missing.reverse()
    for path in missing:
        path.mkdir(exist_ok=True)
    return missing


def remove_made_dirs(made: list[Path]) -> None:
    """Remove the folders `make_dirs` created, innermost first, where they are empty."""
    for path in reversed(made):
        try:
            path.rmdir()
        except OSError:
            return


def hold_ctrl_c() -> contextlib.AbstractContextManager[None]:
    """Hold Ctrl-C (SIGINT) and SIGTERM back until the block ends, then act on them: for a
    few renames that must happen all or not at all (`signals.held`)."""
    from wifibot_power.signals import held

    return held()


@contextlib.contextmanager
def staged_folder(out_dir: Path) -> Iterator[Path]:
    """A temporary folder to build the new contents of `out_dir` in (e.g. `report -o DIR`:
    report.html and figures/), put in place only when the block ends normally: each entry
    of it then replaces the entry of the same name in `out_dir` whole, a folder included
    (none of the old folder's files stays mixed in with the new), with Ctrl-C held off for
    those renames (`hold_ctrl_c`); entries it does not make are left alone. Stopped before
    (an error, Ctrl-C), the temporary folder is removed and `out_dir` is as it was, or not
    there if it was not (cli.md: "writes nothing partial").

    One writer at a time, as for `write_set`: `out_dir` is made first and locked (flock(2))
    for the whole block; held by another process, this one stops with a one-line error
    before anything is built (two `report -o DIR` at once swapped their entries into DIR in
    turn: one's page beside the other's figures).

    The temporary folder is next to `out_dir` (`.NAME.*.tmp`, on the same file system, so
    every move is a rename), or inside it (`.staged.*.tmp`) where its parent cannot be
    written or is on another file system.
    """
    import shutil

    out_dir = Path(out_dir).absolute()
    if out_dir.exists():
        out_dir = out_dir.resolve()  # a link's folder: the stage goes beside the folder
    made: list[Path] = []
    stage: Path | None = None
    lock: int | None = None
    try:
        try:
            with hold_ctrl_c():  # a Ctrl-C here comes once both are known, to be removed
                made = make_dirs(out_dir)
                lock = _lock_folder(out_dir)
                stage = _stage_for(out_dir)
            yield stage
            _fsync_dir(stage)
            with hold_ctrl_c():
                _swap_entries(stage, out_dir)
                written.append(out_dir)
        except BaseException:
            if stage is not None:  # (after the renames: what is left of it, the old entries)
                shutil.rmtree(stage, ignore_errors=True)
            if lock is not None:  # (a folder not locked is another writer's: left as it is)
                remove_made_dirs(made)
            raise
    finally:
        if lock is not None:
            os.close(lock)  # the lock goes with it
    shutil.rmtree(stage, ignore_errors=True)  # what is left: the old entries replaced
    _fsync_dir(out_dir)


def _stage_for(out_dir: Path) -> Path:
    """A new temporary folder for `out_dir`'s new entries: beside it where its parent can be
    written and is on its file system (every move a rename), else inside it."""
    import tempfile

    beside = os.access(out_dir.parent, os.W_OK | os.X_OK) and (
        os.stat(out_dir.parent).st_dev == os.stat(out_dir).st_dev
    )
    return Path(
        tempfile.mkdtemp(
            prefix=f".{out_dir.name}." if beside else ".staged.",
            suffix=".tmp",
            dir=out_dir.parent if beside else out_dir,
        )
    )


def _swap_entries(stage: Path, out_dir: Path) -> None:
    """Each entry of `stage` in place of the one of the same name in `out_dir`; a replaced
    folder (or what a new folder replaces) moves into `stage`, removed with it. Should a
    rename fail part way, what was moved away goes back where nothing new took its place."""
    old = stage / ".replaced"
    old.mkdir()
    try:
        for entry in sorted(p for p in stage.iterdir() if p != old):
            target = out_dir / entry.name
            there = target.exists() or target.is_symlink()
            if there and ((target.is_dir() and not target.is_symlink()) or entry.is_dir()):
                os.rename(target, old / entry.name)
            os.replace(entry, target)
    except BaseException:
        for moved in old.iterdir():
            if not (out_dir / moved.name).exists():
                os.rename(moved, out_dir / moved.name)
        raise
