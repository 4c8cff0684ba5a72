"""ROS bags (log-format.md, section 3): a ROS 1 `.bag`, a ROS 2 bag folder (`metadata.yaml`
with its `.db3` or `.mcap` files) or a bare `.mcap`, read with `rosbags` (no ROS install;
the optional extra `wbpower[ros]`).

Which topics are read:

- power: the one `sensor_msgs/msg/BatteryState` topic, or `--power-topic` (BatteryState, or
  `std_msgs/msg/Float32`/`Float64` holding watts), or `--current-topic` (Float32/Float64 in
  amperes, positive while drawing) with `--voltage-topic` (volts) or `--supply-voltage`.
  BatteryState's power is P = V x (-I): ROS's convention (REP 147 and the message's own
  comment: "Negative when discharging (A)") makes the current negative while the battery
  feeds the robot, so a draw is positive power only once that sign is applied.
- speed and yaw rate: the one `nav_msgs/msg/Odometry` topic (twist.twist.linear.x [m/s],
  twist.twist.angular.z [rad/s], counter-clockwise positive as REP 103 has it), or
  `--speed-topic` (Odometry, or a `geometry_msgs/msg/Twist`/`TwistStamped` such as `cmd_vel`:
  read only when named, and reported as the commanded motion, not the measured one).

The samples are the power topic's messages, at their own stamps (the log's spacing is the
power topic's). Another topic is put on those stamps by its latest message at or before each
one (never a later one, never an interpolation), and only when that message is at most
`STALE_PERIODS` of the topic's own median spacing old: a power sample in a gap of the topic
gets NaN (speed unknown), reported, never a value carried across the gap. Time is each
message's header stamp where its type has a header and the stamps are set, else the time the
bag received it; a problem says which, per topic.

Deserialising is rosbags' (a Python call a message: ~10-20 us; a 100 Hz topic is 0.36 M
messages an hour), on the chosen topics only; what is per sample after it is numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from wifibot_power.errors import LogError
from wifibot_power.io.formats.files import FileFormat, Samples, require
from wifibot_power.io.options import FORMAT_ROSBAG, ReadOptions, is_bag
from wifibot_power.io.validate import GAP_FACTOR
from wifibot_power.run import Problem

BATTERY = "sensor_msgs/msg/BatteryState"
ODOMETRY = "nav_msgs/msg/Odometry"
TWISTS = ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped")
SCALARS = ("std_msgs/msg/Float32", "std_msgs/msg/Float64")
#: A topic's message is used for a power sample only when it is at most this many of the
#: topic's own median spacings older than the sample (the gap bar of validate.py: a step
#: over 1.5 spacings is a gap there too).
STALE_PERIODS = GAP_FACTOR
#: Header stamps before this (2000-01-01, ns since the epoch) are simulated or relative
#: time: no wall-clock `started_at` is taken from them.
WALL_CLOCK_NS = 946_684_800 * 10**9


@dataclass(frozen=True)
class TopicInfo:
    """A topic of a bag: its name, message type, messages and rate (for `inspect`)."""

    topic: str
    type: str
    messages: int
    rate_Hz: float | None

    def as_dict(self) -> dict[str, object]:
        return {
            "topic": self.topic,
            "type": self.type,
            "messages": self.messages,
            "rate_Hz": self.rate_Hz,
        }


@dataclass
class _Series:
    """One topic's messages, sorted by time: time [ns], values, and which clock."""

    topic: str
    type: str
    time_ns: np.ndarray
    values: dict[str, np.ndarray]
    clock: str  # "header stamps" or "receive times"
    reordered: int = 0


class RosBag(FileFormat):
    """ROS 1 and ROS 2 bags, MCAP."""

    name: ClassVar[str] = FORMAT_ROSBAG

    def claims(self, path: Path) -> bool:
        return is_bag(path)

    def read_samples(self, path: Path, options: ReadOptions) -> Samples:
        with _open(path) as reader:
            types = {c.topic: c.msgtype for c in reader.connections}
            counts = _counts(reader)
            power_plan = _power_plan(path, types, counts, options)
            speed_topic = _speed_topic(path, types, options)
            wanted = {topic for topic, _ in power_plan} | ({speed_topic} if speed_topic else set())
            series = _read_topics(path, reader, types, wanted)
        power_W, time_ns, where, power_problems = _power(path, power_plan, series, options)
        problems = [_clock_problem(series, [t for t, _ in power_plan], speed_topic)]
        problems += power_problems
        time_s = (time_ns - time_ns[0]) * 1e-9 if time_ns.size else time_ns.astype(np.float64)
        metadata: dict[str, str] = {}
        if time_ns.size and time_ns[0] >= WALL_CLOCK_NS:
            start = datetime.fromtimestamp(int(time_ns[0]) // 10**9, tz=UTC)
            metadata["started_at"] = start.isoformat().replace("+00:00", "Z")
        speed = yaw = None
        if speed_topic:
            motion = series[speed_topic]
            speed, speed_problem = on_time_base(motion.time_ns, motion.values["speed"], time_ns)
            yaw, _ = on_time_base(motion.time_ns, motion.values["yaw"], time_ns)
            if speed_problem is not None:
                limit_ns = stale_limit_ns(motion.time_ns)
                problems.append(_stale_problem(speed_topic, speed_problem, time_ns, limit_ns))
            if motion.type in TWISTS:
                problems.append(
                    Problem(
                        "commanded",
                        f"speed and yaw rate from {speed_topic} ({motion.type}): the commanded "
                        "motion, not the measured one",
                    )
                )
        return Samples(
            power_W=power_W,
            time_s=time_s,
            metadata=metadata,
            problems=problems,
            speed_mps=speed,
            yaw_rate_radps=yaw,
            where_of=where,
        )


def bag_topics(path: str | Path) -> list[TopicInfo]:
    """Every topic of a bag, with its type, message count and mean rate [Hz] (messages over
    the span of their receive times): `inspect`'s table. Reads the message times, not their
    contents."""
    path = Path(path)
    with _open(path) as reader:
        first: dict[str, int] = {}
        last: dict[str, int] = {}
        count: dict[str, int] = {}
        for connection, stamp_ns, _ in reader.messages():
            topic = connection.topic
            first.setdefault(topic, stamp_ns)
            last[topic] = stamp_ns
            count[topic] = count.get(topic, 0) + 1
        types = {c.topic: c.msgtype for c in reader.connections}
    rows = []
    for topic in sorted(types):
        n = count.get(topic, 0)
        span_s = (last[topic] - first[topic]) * 1e-9 if n > 1 else 0.0
        rows.append(TopicInfo(topic, types[topic], n, (n - 1) / span_s if span_s > 0 else None))
    return rows


def on_time_base(
    time_ns: np.ndarray, values: np.ndarray, base_ns: np.ndarray
) -> tuple[np.ndarray, np.ndarray | None]:
    """`values` (at `time_ns`, sorted) on the samples at `base_ns`: at each, the latest value
    at or before it when at most `STALE_PERIODS` median spacings of `time_ns` old, else NaN.
    Also a mask of the samples left NaN (None when there are none). Nothing is interpolated
    and no value is carried across a gap."""
    out = np.full(base_ns.shape, np.nan)
    if not time_ns.size:
        return out, np.ones(base_ns.shape, dtype=bool) if base_ns.size else None
    spacing_ns = stale_limit_ns(time_ns) / STALE_PERIODS
    previous = np.searchsorted(time_ns, base_ns, side="right") - 1
    found = previous >= 0
    age_ns = base_ns - time_ns[np.maximum(previous, 0)]
    fresh = found & (age_ns <= STALE_PERIODS * spacing_ns)
    out[fresh] = values[previous[fresh]]
    missing = ~fresh
    return out, missing if missing.any() else None


def stale_limit_ns(time_ns: np.ndarray) -> float:
    """How old a topic's message may be and still be used [ns]: `STALE_PERIODS` x the median
    spacing of its messages (0 for a single message: used only at its own stamp)."""
    return STALE_PERIODS * float(np.median(np.diff(time_ns))) if time_ns.size > 1 else 0.0


# -- reading ---------------------------------------------------------------------------------


def _open(path: Path) -> Any:
    """An opened rosbags `AnyReader` (a context manager), or a one-line error."""
    highlevel = require("rosbags.highlevel", "ros", path, "ROS bags")
    typesys = require("rosbags.typesys", "ros", path, "ROS bags")
    # a bag without its own message definitions (ROS 2 sqlite3 before Iron) is read with the
    # newest ROS 2 definitions of the standard messages
    store = typesys.get_typestore(typesys.Stores.LATEST)
    try:
        reader = highlevel.AnyReader([path], default_typestore=store)
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, and sqlite3/OSError ones
        raise LogError(
            f"not a readable ROS bag ({exc.__class__.__name__}: {exc})",
            file=path,
            fix="check the file is a complete .bag, .mcap or ROS 2 bag folder",
        ) from None
    return _Closing(reader)


class _Closing:
    def __init__(self, reader: Any) -> None:
        self.reader = reader

    def __enter__(self) -> Any:
        return self.reader

    def __exit__(self, *exc: object) -> None:
        self.reader.close()


def _counts(reader: Any) -> dict[str, int]:
    counts: dict[str, int] = {}
    for connection in reader.connections:
        counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
    return counts


def _topics_line(types: dict[str, str], counts: dict[str, int]) -> str:
    return ", ".join(f"{t} ({types[t]}, {counts.get(t, 0)} msgs)" for t in sorted(types))


def _named(path: Path, types: dict[str, str], topic: str, option: str, allowed: tuple) -> str:
    if topic not in types:
        raise LogError(
            f"no topic '{topic}' (topics: {', '.join(sorted(types)) or 'none'})",
            file=path,
            fix=f"check {option}",
        )
    if types[topic] not in allowed:
        raise LogError(
            f"topic '{topic}' is {types[topic]}, which {option} cannot read",
            file=path,
            fix=f"name a topic of type {' or '.join(allowed)}",
        )
    return types[topic]


def _power_plan(
    path: Path, types: dict[str, str], counts: dict[str, int], options: ReadOptions
) -> list[tuple[str, str]]:
    """The topics power is made from, as (topic, role): role "battery" (BatteryState),
    "power" (watts), "current" and "voltage"."""
    if options.power_topic:
        kind = _named(path, types, options.power_topic, "--power-topic", (BATTERY, *SCALARS))
        return [(options.power_topic, "battery" if kind == BATTERY else "power")]
    if options.current_topic:
        _named(path, types, options.current_topic, "--current-topic", SCALARS)
        plan = [(options.current_topic, "current")]
        if options.voltage_topic:
            _named(path, types, options.voltage_topic, "--voltage-topic", SCALARS)
            plan.append((options.voltage_topic, "voltage"))
        elif options.supply_voltage_V is None:
            raise LogError(
                "--current-topic needs a voltage",
                file=path,
                fix="give --voltage-topic or --supply-voltage",
            )
        return plan
    if options.voltage_topic:
        raise LogError(
            "--voltage-topic needs --current-topic too", file=path, fix="name both topics"
        )
    batteries = sorted(t for t, kind in types.items() if kind == BATTERY)
    if len(batteries) == 1:
        return [(batteries[0], "battery")]
    if batteries:
        raise LogError(
            f"several {BATTERY} topics ({', '.join(batteries)})",
            file=path,
            fix=f"name the one to use with --power-topic {batteries[0]}",
        )
    raise LogError(
        f"no power topic: no {BATTERY} topic among {_topics_line(types, counts) or 'no topics'}",
        file=path,
        fix="name one with --power-topic (BatteryState, or Float32/Float64 in W), or "
        "--current-topic with --voltage-topic or --supply-voltage",
    )


def _speed_topic(path: Path, types: dict[str, str], options: ReadOptions) -> str | None:
    """The topic speed and yaw rate come from: `--speed-topic`, else the one Odometry topic
    (none: the run has no speed; several: an error)."""
    if options.speed_topic:
        _named(path, types, options.speed_topic, "--speed-topic", (ODOMETRY, *TWISTS))
        return options.speed_topic
    odometry = sorted(t for t, kind in types.items() if kind == ODOMETRY)
    if len(odometry) > 1:
        raise LogError(
            f"several {ODOMETRY} topics ({', '.join(odometry)})",
            file=path,
            fix=f"name the one to use with --speed-topic {odometry[0]}",
        )
    return odometry[0] if odometry else None


def _fields(msgtype: str, message: Any) -> tuple[int | None, tuple[float, ...]]:
    """The header stamp [ns] (None without a header) and the numbers read from a message."""
    header = getattr(message, "header", None)
    stamp = header.stamp.sec * 10**9 + header.stamp.nanosec if header is not None else None
    if msgtype == BATTERY:
        return stamp, (message.voltage, message.current)
    if msgtype == ODOMETRY:
        twist = message.twist.twist
        return stamp, (twist.linear.x, twist.angular.z)
    if msgtype == TWISTS[1]:
        return stamp, (message.twist.linear.x, message.twist.angular.z)
    if msgtype == TWISTS[0]:
        return stamp, (message.linear.x, message.angular.z)
    return stamp, (message.data,)


#: the names of the numbers `_fields` reads, by type
_NAMES = {
    BATTERY: ("voltage", "current"),
    ODOMETRY: ("speed", "yaw"),
    TWISTS[0]: ("speed", "yaw"),
    TWISTS[1]: ("speed", "yaw"),
}


def _read_topics(
    path: Path, reader: Any, types: dict[str, str], wanted: set[str]
) -> dict[str, _Series]:
    """The messages of the `wanted` topics, deserialised, by topic, sorted by time."""
    connections = [c for c in reader.connections if c.topic in wanted]
    received: dict[str, list[int]] = {t: [] for t in wanted}
    stamps: dict[str, list[int | None]] = {t: [] for t in wanted}
    numbers: dict[str, list[tuple[float, ...]]] = {t: [] for t in wanted}
    try:
        for connection, received_ns, raw in reader.messages(connections=connections):
            topic = connection.topic
            stamp, values = _fields(types[topic], reader.deserialize(raw, connection.msgtype))
            received[topic].append(received_ns)
            stamps[topic].append(stamp)
            numbers[topic].append(values)
    except LogError:
        raise
    except Exception as exc:
        raise LogError(
            f"a message could not be read ({exc.__class__.__name__}: {exc})",
            file=path,
            fix="check the bag is complete (a recording cut short can be reindexed)",
        ) from None
    series = {}
    for topic in wanted:
        names = _NAMES.get(types[topic], ("value",))
        values = np.array(numbers[topic], dtype=np.float64).reshape(-1, len(names))
        header = [s for s in stamps[topic] if s is not None]
        use_header = len(header) == len(stamps[topic]) and any(s != 0 for s in header)
        clock = "header stamps" if use_header else "receive times"
        time_ns = np.array(header if use_header else received[topic], dtype=np.int64)
        order = np.argsort(time_ns, kind="stable")
        reordered = int(np.count_nonzero(order != np.arange(order.size)))
        series[topic] = _Series(
            topic,
            types[topic],
            time_ns[order],
            {name: values[order, k] for k, name in enumerate(names)},
            clock,
            reordered,
        )
    return series


def _power(
    path: Path, plan: list[tuple[str, str]], series: dict[str, _Series], options: ReadOptions
) -> tuple[np.ndarray, np.ndarray, str, list[Problem]]:
    """Power [W] on the power topic's stamps [ns], how a sample is named in errors, and what
    to report."""
    topic, role = plan[0]
    base = series[topic]
    if not base.time_ns.size:
        raise LogError(f"topic '{topic}' holds no messages", file=path, fix="name another topic")
    where = f"topic {topic}, message"
    problems: list[Problem] = []
    if role == "battery":
        voltage_V, current_A = base.values["voltage"], base.values["current"]
        _require_measured(path, topic, "voltage", voltage_V)
        _require_measured(path, topic, "current", current_A)
        power_W = voltage_V * -current_A  # ROS: current < 0 while discharging (REP 147)
    elif role == "power":
        power_W = base.values["value"]
    else:
        current_A = base.values["value"]
        if len(plan) > 1:
            other = series[plan[1][0]]
            voltage_V, missing = on_time_base(other.time_ns, other.values["value"], base.time_ns)
            head = int(np.argmin(missing)) if missing is not None else 0
            if missing is not None and head and not missing[head:].any():
                # current logged before the first voltage reading: those samples left out
                problems.append(
                    Problem(
                        "cut",
                        f"the first {head} sample(s) of {topic} precede the first reading of "
                        f"{other.topic}: left out",
                        0.0,
                        float(base.time_ns[head] - base.time_ns[0]) * 1e-9,
                    )
                )
                base = _Series(
                    base.topic,
                    base.type,
                    base.time_ns[head:],
                    {k: values[head:] for k, values in base.values.items()},
                    base.clock,
                    base.reordered,
                )
                current_A, voltage_V, missing = current_A[head:], voltage_V[head:], None
            if missing is not None:
                raise LogError(
                    f"voltage topic {other.topic} has no message up to "
                    f"{1e-6 * stale_limit_ns(other.time_ns):.4g} ms before "
                    f"{int(missing.sum())} of the current samples (first at t = "
                    f"{(base.time_ns[np.argmax(missing)] - base.time_ns[0]) * 1e-9:.6g} s)",
                    file=path,
                    fix="give --supply-voltage V instead, or cut the bag where both are logged",
                )
        else:
            voltage_V = np.float64(options.supply_voltage_V)
        power_W = current_A * voltage_V
    if base.reordered:
        problems.append(
            Problem(
                "reordered",
                f"{base.reordered} message(s) of {topic} were recorded out of the order of "
                f"their {base.clock}: read in the order of their {base.clock}",
            )
        )
    return power_W, base.time_ns, where, problems


def _require_measured(path: Path, topic: str, name: str, values: np.ndarray) -> None:
    """BatteryState leaves a quantity it does not measure NaN: no power from that."""
    if values.size and not np.isfinite(values).all():
        index = int(np.argmax(~np.isfinite(values)))
        raise LogError(
            f"{BATTERY} on {topic} has no {name} ({values[index]}) from message {index + 1}",
            file=path,
            fix="name the topics that measure it with --current-topic and --voltage-topic, "
            "or give --supply-voltage",
        )


def _clock_problem(series: dict[str, _Series], power: list[str], speed: str | None) -> Problem:
    """Which clock each topic's time comes from (log-format.md: the report says which)."""
    parts = [f"{t}: {series[t].clock}" for t in [*power, *([speed] if speed else [])]]
    fallback = [t for t in series if series[t].clock == "receive times"]
    why = (
        " (no header, or its stamps unset: receive times include the recorder's delays)"
        if fallback
        else ""
    )
    return Problem("time_base", f"time from {'; '.join(parts)}{why}")


def _stale_problem(
    topic: str, missing: np.ndarray, time_ns: np.ndarray, limit_ns: float
) -> Problem:
    """Power samples left without a speed: how many, and the longest stretch."""
    edges = np.diff(np.concatenate(([0], missing.view(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    t_s = (time_ns - time_ns[0]) * 1e-9
    spans = t_s[ends - 1] - t_s[starts]
    longest = int(np.argmax(spans))
    return Problem(
        "no_speed",
        f"{int(missing.sum())} power sample(s) in {starts.size} stretch(es) have no message "
        f"of {topic} up to {1e-6 * limit_ns:.4g} ms ({STALE_PERIODS:g} x its median spacing) "
        "before them, the longest from "
        f"t = {t_s[starts[longest]]:.6g} s to {t_s[ends[longest] - 1]:.6g} s: speed and yaw "
        "rate unknown (NaN) there, not carried across the gap",
        float(t_s[starts[longest]]),
        float(spans[longest]),
    )
