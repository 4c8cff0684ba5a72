"""Writing results: every file is written atomically (temp file in the same folder, then rename),
so a crash or kill mid-write leaves the previous output intact."""

from __future__ import annotations

import functools
import json
import math
import os
import sys
from collections.abc import Callable
from datetime import date, datetime
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd


def json_safe(value: object) -> object:
    """Plain JSON types: NaN/inf -> None, numpy scalars and arrays -> Python, tuples -> lists,
    paths -> str, datetimes -> ISO 8601."""
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


def write_atomic(path: Path, write: Callable[[Path], None]) -> Path:
    """Call `write(tmp_path)` and move the result onto `path` in one rename.

    The temporary file sits in the same folder (a rename across file systems is not atomic),
    is flushed to disk before the rename, and is removed if `write` fails. Readers of `path`
    see the old file or the new one, never a mixture; a SIGKILL at any moment leaves at worst
    a stray `.NAME.*.tmp` beside it.
    """
    import tempfile  # here: a command that writes nothing (`fit --json`) does not load it

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        # mkstemp makes the file 0600; give it what a plain open() would have
        os.chmod(tmp, 0o666 & ~_umask())
        with open(tmp, "rb") as handle:
            os.fsync(handle.fileno())
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


def write_json(path: Path, data: object) -> Path:
    """`data` as indented JSON (NaN -> null), written atomically."""
    text = json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n"
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_parquet(path: Path, frame: pd.DataFrame) -> Path:
    """`frame` as Parquet (no index), written atomically."""
    return write_atomic(path, lambda tmp: frame.to_parquet(tmp, index=False))


def write_text(path: Path, text: str) -> Path:
    """UTF-8 text, written atomically."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))
