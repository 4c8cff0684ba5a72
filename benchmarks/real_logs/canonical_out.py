"""What the real-log converters share: reading a fetched mirror's files, and writing a
converted log as canonical wbpower CSV (docs/log-format.md), gzipped the same way each time.

A module beside the converter scripts, not a package: each converter puts its own folder
on `sys.path` to import it (as `study_f1tenth.py` imports the converter)."""

from __future__ import annotations

import argparse
import gzip
import os
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np


def git(mirror: Path, *args: str) -> bytes:
    """`git --git-dir=MIRROR ARGS`'s output (e.g. `show COMMIT:PATH`): a fetched mirror has
    no work tree."""
    return subprocess.run(
        ["git", f"--git-dir={mirror}", *args], check=True, capture_output=True
    ).stdout


def canonical_text(
    meta: dict[str, str], names: Sequence[str], formats: Sequence[str], table: np.ndarray
) -> str:
    """A canonical wbpower CSV: `# key: value` metadata lines (the format's version first),
    the header `names`, then each row of `table` with its columns' printf `formats`."""
    head = ["# wbpower-log: 1", *(f"# {k}: {v}" for k, v in meta.items())]
    lines = [",".join(names)]
    lines += [",".join(f % x for f, x in zip(formats, row, strict=True)) for row in table]
    return "\n".join(head + lines) + "\n"


def write_gzip(target: Path, text: str) -> None:
    """`text` gzipped into `target` with mtime 0: the same input gives the same bytes (no
    churn where the files are kept)."""
    with open(target, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0) as gz:
        gz.write(text.encode())


#: where the converted free-driving logs live (issue 25, step 7): outside the repository
REAL_DRIVE_VAR = "WBPOWER_REAL_DRIVE"
DEFAULT_REAL_DRIVE = Path("/work/real_drive")


def real_drive_root() -> Path:
    """The folder of the converted free-driving sets: `$WBPOWER_REAL_DRIVE`, else
    `DEFAULT_REAL_DRIVE` (docs/real-logs.md, "Free driving")."""
    return Path(os.environ.get(REAL_DRIVE_VAR) or DEFAULT_REAL_DRIVE)


def add_out_argument(parser: argparse.ArgumentParser, where: str) -> None:
    """`--out DIR` of a free-driving converter: default `real_drive_root() / where`."""
    parser.add_argument(
        "--out",
        type=Path,
        default=None,
        help=f"folder for the .csv.gz files (default: ${REAL_DRIVE_VAR}/{where}, "
        f"else {DEFAULT_REAL_DRIVE}/{where})",
    )
