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
FORMAT_ROSBAG = "rosbag"
FORMAT_JLS = "jls"
#: The compressions read, by file-name suffix, as pyarrow names the codec: the one place
#: compression is told (the reader, the parse cache and finding logs all ask `codec_of`).
COMPRESSIONS = {".gz": "gzip", ".zst": "zstd"}
#: Logs that are not text (log-format.md, section 3): a ROS 1 bag, a bare MCAP file (a ROS 2
#: bag folder, with its `metadata.yaml`, is told by `is_bag_folder`), a Joulescope recording.
BAG_SUFFIXES = (".bag", ".mcap")
JLS_SUFFIX = ".jls"
LOG_SUFFIXES = (".csv", *(f".csv{suffix}" for suffix in COMPRESSIONS), *BAG_SUFFIXES, JLS_SUFFIX)
#: The file that makes a folder a ROS 2 bag (with its .db3 or .mcap files beside it).
BAG_METADATA = "metadata.yaml"


def is_bag_folder(path: Path) -> bool:
    """A ROS 2 bag: a folder holding `metadata.yaml` (its .db3/.mcap files are not logs of
    their own)."""
    return path.is_dir() and (path / BAG_METADATA).is_file()


def is_bag(path: Path) -> bool:
    """A ROS 1 bag, a bare MCAP file or a ROS 2 bag folder."""
    return path.name.lower().endswith(BAG_SUFFIXES) or is_bag_folder(path)


def is_read_whole(path: Path) -> bool:
    """A log its own library reads whole (a bag, a Joulescope recording), not as text: the
    parse cache, which hashes a file's bytes, leaves it alone (a bag may be a folder, a
    recording gigabytes)."""
    return path.name.lower().endswith(JLS_SUFFIX) or is_bag(path)


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
    #: the most the robot can draw [W] (`--max-power`): above it a reading is an error (a unit
    #: mistake); wins over the logs' `max_power_W` metadata (log-format.md, "Bad input")
    max_power_W: float | None = None
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
    #: bags (log-format.md, section 3): the topics power, voltage, current and speed come
    #: from (default: the one `sensor_msgs/BatteryState` topic, the one `nav_msgs/Odometry`)
    power_topic: str | None = None
    voltage_topic: str | None = None
    current_topic: str | None = None
    speed_topic: str | None = None
    #: the column holding the rate of turn [rad/s] (default: `yaw_rate_radps`, log-format.md
    #: "Turning"), and the track width [m] that turns two wheel speeds into a rate of turn
    #: (`--track-width`; default: the `track_m` metadata)
    yaw_rate_column: str | None = None
    track_width_m: float | None = None

    def __post_init__(self) -> None:
        for option, value, unit in (
            ("--supply-voltage", self.supply_voltage_V, "V"),
            ("--sample-period", self.sample_period_s, "s"),
            ("--max-power", self.max_power_W, "W"),
            ("--track-width", self.track_width_m, "m"),
        ):
            # 0 V would read every log as 0 W and 0 J, NaN as a NaN in the file's first
            # line: a usage error, named as such, before any file is read
            if value is not None and not (math.isfinite(value) and value > 0):
                from wifibot_power.errors import UsageError

                raise UsageError(f"{option} {value:g}", fix=f"give a number > 0 [{unit}]")
        _check_plausible_options(self)
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
        if self.power_topic and (self.current_topic or self.voltage_topic):
            from wifibot_power.errors import UsageError

            raise UsageError(
                "--power-topic with --current-topic/--voltage-topic",
                fix="name either the power topic or the current and voltage topics",
            )


#: Above this a supply voltage is not in volts (mV by mistake): the largest battery vehicles
#: run on 800-V packs [V] (log-format.md, "Bad input"; `validate.MAX_SUPPLY_VOLTAGE_V`).
MAX_SUPPLY_VOLTAGE_V = 1000.0
#: The plausible range of a sample period [s]: from a 100 MHz sampler's 10 ns to a day (a
#: logger writing once a day is not a power log); outside it the number is a unit or typing
#: mistake (an N6705 "Sample interval: 1e300", `--sample-period 1e300`).
SAMPLE_PERIOD_RANGE_S = (1e-8, 86400.0)


def _check_plausible_options(options: ReadOptions) -> None:
    """Option values no log can mean: a usage error before any file is read."""
    from wifibot_power.errors import UsageError

    volts = options.supply_voltage_V
    if volts is not None and volts > MAX_SUPPLY_VOLTAGE_V:
        raise UsageError(
            f"--supply-voltage {volts:g}: over {MAX_SUPPLY_VOLTAGE_V:g} V",
            fix="give the supply voltage in volts (12.6, not 12600 mV)",
        )
    period = options.sample_period_s
    low, high = SAMPLE_PERIOD_RANGE_S
    if period is not None and not low <= period <= high:
        raise UsageError(
            f"--sample-period {period:g}: outside {low:g}-{high:g} s",
            fix="give the sample spacing in seconds (0.001 for 1 kHz)",
        )


def log_stem(path: Path) -> str:
    """A log's file name without its log suffix (`run1.csv.gz` -> `run1`): its run_id when
    neither its metadata nor the manifest gives one (the reader), and what `find_logs` tells
    logs named alike by."""
    name = path.name
    for suffix in LOG_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return name if is_bag_folder(path) else path.stem


def is_log_name(path: Path) -> bool:
    return path.name.lower().endswith(LOG_SUFFIXES)
