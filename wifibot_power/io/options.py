"""What a read is asked for, and which files are logs.

Kept apart from the parser so that finding logs and looking a file up in the parse cache
need neither pyarrow nor the parser: a warm `fit --cache` imports neither (docs/benchmarks.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

FORMAT_CANONICAL = "wbpower-csv"
FORMAT_N6705 = "n6705"
#: The compressions read, by file-name suffix, as pyarrow names the codec: the one place
#: compression is told (the reader, the parse cache and finding logs all ask `codec_of`).
COMPRESSIONS = {".gz": "gzip", ".zst": "zstd"}
LOG_SUFFIXES = (".csv", *(f".csv{suffix}" for suffix in COMPRESSIONS))


def codec_of(path: Path) -> str | None:
    """The compression of a file, from its name ("gzip", "zstd"), or None."""
    name = path.name.lower()
    return next((codec for suffix, codec in COMPRESSIONS.items() if name.endswith(suffix)), None)


#: `--time-unit` values and their scale to seconds.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6}


@dataclass(frozen=True)
class ReadOptions:
    """Options every log-reading command shares (cli.md: reading options; docs/log-format.md
    says what each does)."""

    supply_voltage_V: float | None = None
    current_column: str | None = None
    voltage_column: str | None = None
    sample_period_s: float | None = None
    #: the column holding the robot's speed [m/s] (default: `speed_mps`, log-format.md "Speed")
    speed_column: str | None = None
    #: power columns whose sum is the robot's power (`--power-column`, repeatable)
    power_columns: tuple[str, ...] = ()
    #: the time column (`--time-column`) and the unit of time columns (`--time-unit`)
    time_column: str | None = None
    time_unit: str | None = None
    #: negate the current (and so the power): a sensor wired the other way (`--flip-current`)
    flip_current: bool = False
    #: the column holding the rate of turn [rad/s] (default: `yaw_rate_radps`, log-format.md
    #: "Turning"), and the track width [m] that turns two wheel speeds into a rate of turn
    #: (`--track-width`; default: the `track_m` metadata)
    yaw_rate_column: str | None = None
    track_width_m: float | None = None

    def __post_init__(self) -> None:
        for option, value, unit in (
            ("--supply-voltage", self.supply_voltage_V, "V"),
            ("--sample-period", self.sample_period_s, "s"),
            ("--track-width", self.track_width_m, "m"),
        ):
            # 0 V would read every log as 0 W and 0 J, NaN as a NaN in the file's first
            # line: a usage error, named as such, before any file is read
            if value is not None and not (math.isfinite(value) and value > 0):
                from wifibot_power.errors import UsageError

                raise UsageError(f"{option} {value:g}", fix=f"give a number > 0 [{unit}]")
        if self.time_unit is not None and self.time_unit not in TIME_UNITS:
            from wifibot_power.errors import UsageError

            raise UsageError(
                f"time unit '{self.time_unit}'", fix=f"give --time-unit {'|'.join(TIME_UNITS)}"
            )
        if self.power_columns and (self.current_column or self.voltage_column):
            from wifibot_power.errors import UsageError

            raise UsageError(
                "--power-column with --current-column/--voltage-column",
                fix="name either the power columns or the current and voltage columns",
            )


def log_stem(path: Path) -> str:
    """A log's file name without its log suffix (`run1.csv.gz` -> `run1`): its run_id when
    neither its metadata nor the manifest gives one (the reader), and what `find_logs` tells
    logs named alike by."""
    name = path.name
    for suffix in LOG_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def is_log_name(path: Path) -> bool:
    return path.name.lower().endswith(LOG_SUFFIXES)
