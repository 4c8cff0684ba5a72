"""Logs that are not text: a format that reads the whole file itself through its own library
(ROS bags: `rosbag.py`; Joulescope recordings: `jls.py`), behind one interface
(`FileFormat`), registered in `formats/__init__.py` (`FILE_FORMATS`).

A text format (`base.LogFormat`) hands the reader a preamble and columns; a file format hands
it the samples (`Samples`), and `samples_to_run` makes the `Run` as the text reader does:
the manifest's values over the file's own metadata (`metadata.build_meta`), the checks of
`validate.check_samples` on time and power, and `--flip-current`. Not the unit-slip warnings
of io/kinematics.py (deg/s, a time in ms): a bag's twist is rad/s by ROS's REP 103 and its
time comes from its stamps in ns; a recording has no speed.

The libraries are optional extras (`wbpower[ros]`, `wbpower[jls]`: pyproject.toml says why):
`require` imports one or raises a one-line error that names the extra to install.
"""

from __future__ import annotations

import functools
import importlib
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import ClassVar

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.metadata import build_meta
from wifibot_power.io.options import ReadOptions, log_stem
from wifibot_power.io.validate import ABSURD_SPEED_MPS, check_log_samples
from wifibot_power.run import Problem, Run


@dataclass
class Samples:
    """What a file format reads: power [W] at each sample, the samples' time [s] (None:
    evenly spaced at the metadata's `sample_period_s`), speed [m/s] and yaw rate [rad/s] on
    the same samples (NaN where unknown), the file's own metadata and what to report."""

    power_W: np.ndarray
    time_s: np.ndarray | None
    metadata: dict[str, str] = field(default_factory=dict)
    problems: list[Problem] = field(default_factory=list)
    speed_mps: np.ndarray | None = None
    yaw_rate_radps: np.ndarray | None = None
    #: the sample a message index names in errors ("message 12 on /battery")
    where_of: str = "sample"
    #: the format reports gaps itself (in full-rate samples): not again from the time stamps
    gaps_reported: bool = False


class FileFormat(ABC):
    """A log format read by its own library, from the path (a file, or a ROS 2 bag folder)."""

    #: the name in `Run.format` and `inspect` (FORMAT_* in options.py)
    name: ClassVar[str]

    @abstractmethod
    def claims(self, path: Path) -> bool:
        """Whether `path` is a log of this format (by its name: no file is opened)."""

    @abstractmethod
    def read_samples(self, path: Path, options: ReadOptions) -> Samples:
        """The samples of the log (raise `LogError` for anything not read honestly)."""


def require(module: str, extra: str, path: Path, what: str) -> ModuleType:
    """`import module`, or a one-line error naming the optional extra that brings it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise LogError(
            f"reading {what} needs the '{module.split('.')[0]}' library, which is not installed",
            file=path,
            fix=f"pip install 'wbpower[{extra}]'",
        ) from None


def samples_to_run(
    path: Path,
    file_format: FileFormat,
    samples: Samples,
    options: ReadOptions,
    overrides: dict[str, str] | None,
    origin: str | None,
) -> Run:
    """The `Run` of a file format's samples: metadata (the manifest's values win), the sample
    checks every log gets, `--flip-current`."""
    values = dict(samples.metadata)
    where = dict.fromkeys(samples.metadata, "the file")
    for key, value in (overrides or {}).items():
        values[key] = value
        where[key] = origin or "manifest"
    if options.sample_period_s is not None and "sample_period_s" not in values:
        values["sample_period_s"] = repr(options.sample_period_s)
        where["sample_period_s"] = "--sample-period"
    # the run's metadata from `values`, made again once the stamps give the period
    meta_of = functools.partial(
        build_meta,
        file=str(path),
        stem=log_stem(path),
        where="metadata",
        origins=where,
        speed_column=samples.speed_mps is not None,
    )
    meta = meta_of(values)
    power_W = -samples.power_W if options.flip_current else samples.power_W
    try:
        period_s, problems, grid = check_log_samples(
            str(path),
            samples.time_s,
            power_W,
            line_of=lambda index: index + 1,
            default_period_s=meta.sample_period_s,
        )
    except LogError as exc:  # named as the format counts its samples, not as a line of text
        if exc.where and exc.where.startswith("line "):
            exc.where = f"{samples.where_of} {exc.where[len('line ') :]}"
            exc.args = (exc.one_line(),)
        raise
    if samples.speed_mps is not None:
        _check_absurd(path, samples.speed_mps)
    if samples.time_s is not None and period_s != meta.sample_period_s:
        values["sample_period_s"] = repr(period_s)
        meta = meta_of(values)
    time_s, speed_mps, yaw_rate_radps = samples.time_s, samples.speed_mps, samples.yaw_rate_radps
    if grid is not None:  # a logger stamping rows as they arrive: read by sample and hold
        time_s, power_W, speed_mps, yaw_rate_radps = (
            grid.stamps_s,
            *map(grid.take, (power_W, speed_mps, yaw_rate_radps)),
        )
    return Run(
        file=str(path),
        format=file_format.name,
        meta=meta,
        stamps_s=time_s,
        power_W=power_W,
        problems=(
            *samples.problems,
            *(p for p in problems if not (samples.gaps_reported and p.kind == "gap")),
        ),
        speed_mps=speed_mps,
        yaw_rate_radps=yaw_rate_radps,
    )


def _check_absurd(path: Path, speed_mps: np.ndarray) -> None:
    """A speed over `ABSURD_SPEED_MPS` is not in m/s (validate.check_speed's bar; NaN, a
    speed unknown there, is allowed here: the format reports where)."""
    finite = speed_mps[np.isfinite(speed_mps)]
    if finite.size and float(np.max(np.abs(finite))) > ABSURD_SPEED_MPS:
        raise LogError(
            f"absurd speed ({float(np.max(np.abs(finite))):.4g} m/s, over "
            f"{ABSURD_SPEED_MPS:g} m/s)",
            file=path,
            fix="check the topic named for speed (it must be in m/s)",
        )
