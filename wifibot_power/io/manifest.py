"""The run manifest (`runs.csv` in a logs folder): metadata attached to files by name."""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.errors import LogError

if TYPE_CHECKING:
    from wifibot_power.run import RunMeta

MANIFEST_NAME = "runs.csv"
MANIFEST_KEYS = ("run_id", "mode", "speed_mps", "distance_m", "steps", "payload_kg", "started_at")


#: the header line a manifest is written with (`manifest_line` writes its rows)
MANIFEST_HEADER = ",".join(("file", *MANIFEST_KEYS))


def manifest_line(file: str, meta: RunMeta, started_at: str) -> str:
    """One manifest row for a log written as `file` (the motion keys empty for other modes)."""
    motion = meta.mode == "motion"
    cells = [
        file,
        meta.run_id,
        meta.mode,
        f"{meta.speed_mps:g}" if motion else "",
        f"{meta.distance_m:g}" if motion else "",
        str(meta.steps) if motion else "",
        f"{meta.payload_kg:g}" if motion else "",
        started_at,
    ]
    return ",".join(cells)


@dataclass(frozen=True)
class ManifestRow:
    """One manifest row: the file it names (absolute) and the metadata it sets."""

    manifest: Path
    line: int
    file: Path
    values: dict[str, str]
    #: the file as the row names it
    name: str = ""

    @property
    def outside(self) -> bool:
        """Whether the row names a file outside the manifest's folder (an absolute path, or
        `..` out of it): such rows are refused (`find_logs`), so that a runs.csv cannot make
        wbpower read `/etc/shadow` or `../../elsewhere.csv`. Decided on the name as written:
        a symbolic link placed in the folder is the folder owner's choice and is followed."""
        return outside_folder(self.name)


def outside_folder(name: str) -> bool:
    """Whether a manifest's `file` cell leaves the manifest's folder: absolute, or `..`
    beyond it once the path is normalised (`a/../b.csv` stays inside)."""
    if not name or os.path.isabs(name) or name.startswith(("\\", "/")):
        return True
    normal = os.path.normpath(name.replace("\\", "/"))
    return normal == ".." or normal.startswith("../")


def is_manifest(path: Path) -> bool:
    return path.name.lower() == MANIFEST_NAME


def read_manifest(path: Path) -> list[ManifestRow]:
    """Rows of a manifest; empty cells set nothing. A row naming a missing file is kept:
    the caller reports it (log-format.md: "a manifest row whose file does not exist")."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise LogError(
            f"cannot read the manifest ({exc.__class__.__name__})",
            file=path,
            fix="check the file is a UTF-8 CSV with a 'file' column",
        ) from None
    lines = text.splitlines()
    header = next((ln for ln in lines if ln.strip()), "")
    delimiter = ";" if header.count(";") > header.count(",") else ","
    reader = csv.DictReader(lines, delimiter=delimiter)
    fields = [f.strip().lower() for f in (reader.fieldnames or [])]
    if "file" not in fields:
        raise LogError(
            "manifest has no 'file' column",
            file=path,
            where="line 1",
            fix="the header must start with: file,run_id,mode,speed_mps,...",
        )
    rows: list[ManifestRow] = []
    seen: dict[Path, int] = {}
    folder = path.parent.resolve()
    for raw in reader:
        line_no = reader.line_num
        row = {(k or "").strip().lower(): (v or "").strip() for k, v in raw.items()}
        name = row.pop("file", "")
        values = {k: v for k, v in row.items() if v != "" and k}
        if not name:
            if values:
                raise LogError(
                    "a row with values but no file",
                    file=path,
                    where=f"line {line_no}",
                    fix="name the log file in the 'file' column, or delete the row",
                )
            continue
        file = _resolved(folder, name)
        if file in seen:
            raise LogError(
                f"'{name}' is named twice (lines {seen[file]} and {line_no})",
                file=path,
                where=f"line {line_no}",
                fix="keep one row per file",
            )
        seen[file] = line_no
        rows.append(ManifestRow(path, line_no, file, values, name))
    return rows


def _resolved(folder: Path, name: str) -> Path:
    """`(folder / name).resolve()` for `folder` already resolved: a plain name that is not a
    symbolic link resolves to itself in the folder (one lstat, not one per component of the
    path); anything else (a link, a sub-path, "..") is resolved in full."""
    plain = name not in ("", ".", "..") and "/" not in name and "\\" not in name
    if plain:
        candidate = folder / name
        try:
            if not candidate.is_symlink():
                return candidate
        except OSError:
            pass
    return (folder / name).resolve()
