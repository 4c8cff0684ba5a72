"""Find the logs under the paths a command is given, with their manifest metadata, and the
run_id of each log whose run_id would otherwise be a file name another log of the batch has
(log-format.md, "Bad input")."""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

from wifibot_power.errors import LogError
from wifibot_power.io.manifest import MANIFEST_NAME, is_manifest, read_manifest
from wifibot_power.io.metadata import DEFAULT_RUN_ID
from wifibot_power.io.options import BAG_METADATA, is_bag_folder, is_log_name, log_stem


@dataclass(frozen=True)
class LogSource:
    """A log to read: its path and the manifest values that override its own metadata."""

    path: Path
    overrides: dict[str, str] = field(default_factory=dict)
    #: where the overrides come from ("runs.csv line 4"), for messages that name the row
    origin: str | None = None
    #: the run_id when neither the log's metadata nor the manifest gives one, if not its file
    #: name: another log of the batch has that file name (`find_logs`)
    default_run_id: str | None = None

    @property
    def read_overrides(self) -> dict[str, str]:
        """What the reader takes as `overrides`: the manifest's values, and the default
        run_id if there is one (under a key no metadata line or manifest column can set)."""
        if self.default_run_id is None:
            return self.overrides
        return {**self.overrides, DEFAULT_RUN_ID: self.default_run_id}


@dataclass(frozen=True)
class Skipped:
    """An input left out of a batch, and why (cli.md: `skipped`)."""

    file: str
    reason: str

    def as_dict(self) -> dict[str, str]:
        return {"file": self.file, "reason": self.reason}

    @property
    def why(self) -> str:
        """The reason without the file it names first ("FILE: why" -> "why")."""
        prefix = f"{self.file}: "
        return self.reason[len(prefix) :] if self.reason.startswith(prefix) else self.reason


def reasons_in_brief(skipped: list[Skipped], most: int = 2) -> str:
    """Why inputs were left out, for a one-line error: the `most` commonest reasons with
    how many inputs each left out and the first file it names, then how many inputs were
    left out for how many other reasons ("15 x motion run without a distance (...; first: a.csv);
    3 for 2 other reasons"); the callers list every input with its reason (`skipped`)."""
    by_why: dict[str, list[Skipped]] = {}
    for skip in skipped:
        by_why.setdefault(skip.why, []).append(skip)
    common = sorted(by_why.items(), key=lambda item: -len(item[1]))  # stable: first seen first
    parts = [f"{len(s)} x {why} (first: {s[0].file})" for why, s in common[:most]]
    others = sum(len(s) for _, s in common[most:])
    if others:
        kinds = len(common) - most
        plural = "s" if kinds > 1 else ""
        parts.append(f"{others} for {kinds} other reason{plural}")
    return "; ".join(parts)


def find_logs(paths: list[Path]) -> tuple[list[LogSource], list[Skipped]]:
    """Every log under `paths` (folders recursively), in a stable order, with manifest overrides.

    A manifest applies to the files it names; files it does not name are still read with
    their own metadata; a manifest named on the command line brings the files it lists; a
    row naming a missing file becomes a `Skipped` entry that names the row.

    Logs whose run_id defaults to their file name (no run_id in the manifest) and that share
    that name get a `default_run_id` from their paths (`_path_run_ids`): decided here, before
    any is read, so it is the same whatever order workers finish in.
    """
    files, roots, manifests, named_manifests, skipped = _walk(paths)
    # each path resolved once (a resolve is a few lstat calls and ~30 us: 1/6 of a warm
    # `fit --cache` went into resolving the same 89 paths three times)
    resolved = {f: f.resolve() for f in files}
    overrides = _manifest_overrides(
        paths, files, roots, manifests, named_manifests, skipped, set(resolved.values())
    )
    sources = []
    missing = {Path(s.file) for s in skipped}
    for file in files:  # a file named twice stays twice: the batch warns it is a duplicate
        if file in missing:
            continue  # already listed, naming the manifest row
        real = resolved.get(file) or file.resolve()
        if not file.exists() or is_log_name(file) or real in overrides or is_bag_folder(file):
            values, origin = overrides.get(real, ({}, None))
            sources.append(LogSource(file, values, origin))
    return _path_run_ids(sources, roots, resolved), skipped


def _walk(
    paths: list[Path],
) -> tuple[list[Path], dict[Path, Path], list[Path], set[Path], list[Skipped]]:
    """The files under `paths` (a ROS 2 bag folder one file), the folder each was found in,
    the manifests found and those named, and what is skipped (not a regular file)."""
    files: list[Path] = []
    #: a file found in a folder given, or listed by a manifest named: that folder, for its
    #: run_id from its path (`_path_run_ids`)
    roots: dict[Path, Path] = {}
    manifests: list[Path] = []
    named_manifests: set[Path] = set()
    skipped: list[Skipped] = []
    for path in paths:
        if is_bag_folder(path):  # a ROS 2 bag is one log, its files are not logs of their own
            files.append(path)
        elif path.is_dir():
            everything = sorted(path.rglob("*"))
            bags = {f.parent for f in everything if f.name == BAG_METADATA and f.is_file()}
            for found in everything:
                if found in bags:
                    files.append(found)
                    roots.setdefault(found, path)
                elif bags and not bags.isdisjoint(found.parents):
                    continue  # inside a ROS 2 bag: part of it
                elif found.is_file():
                    (manifests if is_manifest(found) else files).append(found)
                    roots.setdefault(found, path)
                elif is_log_name(found) or is_manifest(found):
                    odd = not_a_regular_file(found)  # a FIFO, a device, a link to nothing
                    if odd is not None:
                        skipped.append(Skipped(str(found), f"{found}: {odd}"))
        elif (odd := not_a_regular_file(path)) is not None:
            if len(paths) == 1 and not is_manifest(path):  # a single input: exit 2 (cli.md)
                raise LogError(odd.removeprefix("not a log: "), file=path)
            skipped.append(Skipped(str(path), f"{path}: {odd}"))
        elif is_manifest(path) and path.is_file():
            manifests.append(path)
            named_manifests.add(path)
        else:
            files.append(path)
            beside = path.parent / MANIFEST_NAME
            if beside.is_file():
                manifests.append(beside)
    return files, roots, manifests, named_manifests, skipped


def _manifest_overrides(
    paths: list[Path],
    files: list[Path],
    roots: dict[Path, Path],
    manifests: list[Path],
    named_manifests: set[Path],
    skipped: list[Skipped],
    wanted: set[Path],
) -> dict[Path, tuple[dict[str, str], str]]:
    """Each manifest row's values by the file it names, and where they come from; the files a
    named manifest lists added to `files` (and `roots`), and each row that cannot be read
    (outside its folder, a missing file) added to `skipped`."""
    overrides: dict[Path, tuple[dict[str, str], str]] = {}
    only_files = all(not p.is_dir() for p in paths)
    for manifest in dict.fromkeys(manifests):
        try:
            rows = read_manifest(manifest)
        except LogError as exc:
            skipped.append(Skipped(str(manifest), exc.one_line()))
            continue
        for row in rows:
            if row.outside:
                if manifest in named_manifests or not only_files:
                    skipped.append(
                        Skipped(
                            str(row.file),
                            f"{manifest}: line {row.line}: names '{row.name}', outside the "
                            "manifest's folder: not read (a runs.csv names logs in its folder "
                            "or below it; move the log there, or name it on the command line)",
                        )
                    )
                continue
            if manifest in named_manifests and row.file not in wanted:
                files.append(row.file)
                wanted.add(row.file)
                roots.setdefault(row.file, manifest.parent.resolve())
            if row.file.is_file() or is_bag_folder(row.file):
                overrides[row.file] = (row.values, f"{manifest} line {row.line}")
            elif manifest in named_manifests or not only_files or row.file in wanted:
                # a manifest found beside a single file only matters for that file
                odd = not_a_regular_file(row.file)
                if row.file.is_dir():
                    what = "which is a folder, not a log (name a log file in it)"
                elif odd is None:
                    what = "which does not exist (fix the row or restore the file)"
                else:
                    what = f"which is {odd.removeprefix('not a log: ')}"
                skipped.append(
                    Skipped(
                        str(row.file),
                        f"{manifest}: line {row.line}: names '{row.name}', {what}",
                    )
                )
    return overrides


def not_a_regular_file(path: Path) -> str | None:
    """Why `path` cannot be read as a log although something is there, or None (a regular
    file, or nothing at all): a FIFO would block `open()` forever, a device never ends, a
    link to nothing is no file. Said with a reason, never skipped in silence (issue 29)."""
    import stat

    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        if path.is_symlink():
            return f"not a log: a link to nothing ({os.readlink(path)}) (fix the link or remove it)"
        return None
    except OSError:
        return None  # (the reader says why: permission denied, ...)
    kinds = (
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    for test, kind in kinds:
        if test(mode):
            return f"not a log: {kind}, not a regular file (give a file; copy a stream first)"
    return None


def _path_run_ids(
    sources: list[LogSource], roots: dict[Path, Path], resolved: dict[Path, Path]
) -> list[LogSource]:
    """`sources`, each log whose default run_id (its file name, `log_stem`) another log of the
    batch shares given a `default_run_id` from its path: relative to the folder given it
    was found in (`day1/run1`; a file named on its own: its path as given), without the log
    suffix. Where those still collide (two folders given that hold `day1/run1.csv` each, or
    `run1.csv` beside a different `run1.csv.gz`), the first of these that tells the group's
    logs apart: the relative path with the suffix, the path as given without it and with
    it, the full path. A file reached twice (named twice, or named and in a folder given)
    is one log, not a collision: the duplicate check says so. Logs the manifest gives a
    run_id are left alone; a log whose own metadata names its run_id keeps it (its
    `default_run_id` is then not used)."""
    by_stem: dict[str, dict[Path, list[int]]] = {}
    for k, source in enumerate(sources):
        if source.overrides.get("run_id"):
            continue
        real = resolved.get(source.path) or source.path.resolve()
        by_stem.setdefault(log_stem(source.path), {}).setdefault(real, []).append(k)

    def relative(path: Path) -> Path:
        root = roots.get(path)
        if root is not None and path.is_relative_to(root):  # a manifest row may name ../x.csv
            return path.relative_to(root)
        return path

    namings = (
        lambda path: relative(path).with_name(log_stem(path)),
        relative,
        lambda path: path.with_name(log_stem(path)),
        lambda path: path,
    )
    named = list(sources)
    for files in by_stem.values():
        if len(files) < 2:
            continue
        firsts = [sources[places[0]].path for places in files.values()]
        for naming in namings:
            run_ids = [naming(path).as_posix() for path in firsts]
            if len(set(run_ids)) == len(run_ids):
                break
        else:  # distinct files: their full paths differ
            run_ids = [real.as_posix() for real in files]
        for places, run_id in zip(files.values(), run_ids, strict=True):
            for k in places:
                named[k] = replace(sources[k], default_run_id=run_id)
    return named


def single_source(path: Path) -> LogSource:
    """One log named on the command line, with the row of the `runs.csv` beside it, if any
    (log-format.md: "A command given a single file also reads the runs.csv beside it").

    A manifest beside it that cannot be read is an error: its metadata (mode, speed) would
    otherwise be silently missing.
    """
    sources, skipped = find_logs([Path(path)])
    if skipped:
        raise LogError(skipped[0].reason)
    # a file not named like a log (`run.txt`) is still read when named on its own
    return sources[0] if sources else LogSource(Path(path))
