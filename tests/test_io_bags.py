"""ROS bags (log-format.md section 3): a ROS 1 bag, a ROS 2 bag (sqlite3) and an MCAP file of
one drive, written here by rosbags' own writers, read as the canonical CSV written from the
same samples is read.

The drive: BatteryState at 50 Hz (header stamps on the sensor's clock; the bag receives each
12 ms later), Odometry at ~20 Hz with +-4 ms of jitter and a 0.6 s gap while the robot
stands; the robot idles, accelerates to 0.8 m/s, cruises (turning on an arc for a while),
brakes and idles again. The current is negative while discharging, as ROS has it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags", reason="the 'ros' extra (pip install 'wbpower[ros]')")

from rosbags.rosbag1 import Writer as Writer1  # noqa: E402
from rosbags.rosbag2 import StoragePlugin  # noqa: E402
from rosbags.rosbag2 import Writer as Writer2  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from wifibot_power.errors import LogError  # noqa: E402
from wifibot_power.io import ReadOptions, find_logs, read_log  # noqa: E402
from wifibot_power.io.formats.rosbag import STALE_PERIODS  # noqa: E402
from wifibot_power.segment import segment_run  # noqa: E402

#: the bags' clock starts here (2024-05-01T12:00:00Z) [ns]
T0_NS = 1_714_564_800 * 10**9
BATTERY_PERIOD_NS = 20_000_000  # 50 Hz
ODOM_PERIOD_NS = 50_000_000  # 20 Hz
RECEIVE_LATENCY_NS = 12_000_000
#: odometry stops for this stretch [s from the start] while the robot stands
ODOM_GAP_S = (1.5, 2.1)
DURATION_S = 16.0


@dataclass(frozen=True)
class Drive:
    """The truth: the battery's stamps, voltage and current (as float32, as the message
    carries them), and the odometry's stamps, speed and yaw rate."""

    battery_ns: np.ndarray
    voltage_V: np.ndarray
    current_A: np.ndarray  # ROS sign: negative while discharging
    odom_ns: np.ndarray
    speed_mps: np.ndarray
    yaw_rate_radps: np.ndarray


def _speed_at(t_s: np.ndarray) -> np.ndarray:
    """Idle 3 s, accelerate 1.5 s to 0.8 m/s, cruise to 11 s, brake in 1 s, idle."""
    up = np.clip((t_s - 3.0) / 1.5, 0.0, 1.0)
    down = np.clip((12.0 - t_s) / 1.0, 0.0, 1.0)
    return 0.8 * np.minimum(up, down)


def _yaw_at(t_s: np.ndarray) -> np.ndarray:
    return np.where((t_s > 6.0) & (t_s < 8.0), 0.4, 0.0)


def make_drive(seed: int = 3) -> Drive:
    rng = np.random.default_rng(seed)
    battery_ns = T0_NS + np.arange(0, int(DURATION_S * 1e9), BATTERY_PERIOD_NS, dtype=np.int64)
    t_s = (battery_ns - T0_NS) * 1e-9
    speed = _speed_at(t_s)
    accel = np.gradient(speed, t_s)
    power_W = 18.0 + 14.0 * speed + 25.0 * np.clip(accel, 0, None) + rng.normal(0, 0.3, t_s.size)
    voltage_V = (12.6 - 0.004 * power_W).astype(np.float32)
    current_A = (-power_W / voltage_V).astype(np.float32)
    odom_ns = T0_NS + np.arange(0, int(DURATION_S * 1e9), ODOM_PERIOD_NS, dtype=np.int64)
    odom_ns = odom_ns + rng.integers(-4_000_000, 4_000_000, odom_ns.size)
    odom_s = (odom_ns - T0_NS) * 1e-9
    keep = (odom_s < ODOM_GAP_S[0]) | (odom_s >= ODOM_GAP_S[1])
    odom_ns = odom_ns[keep]
    odom_s = odom_s[keep]
    return Drive(
        battery_ns,
        voltage_V,
        current_A,
        odom_ns,
        _speed_at(odom_s) + rng.normal(0, 0.002, odom_s.size),
        _yaw_at(odom_s),
    )


def _messages(store, drive: Drive, ros1: bool, cmd_vel: bool = False):
    """(topic, msgtype, receive time [ns], message), in receive order."""
    types = store.types
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Vector3, Twist = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Twist"]
    Pose, Point = types["geometry_msgs/msg/Pose"], types["geometry_msgs/msg/Point"]
    Quaternion = types["geometry_msgs/msg/Quaternion"]
    PoseCov = types["geometry_msgs/msg/PoseWithCovariance"]
    TwistCov = types["geometry_msgs/msg/TwistWithCovariance"]
    Odometry, Battery = types["nav_msgs/msg/Odometry"], types["sensor_msgs/msg/BatteryState"]

    def header(stamp_ns: int, frame: str):
        stamp = Time(sec=int(stamp_ns // 10**9), nanosec=int(stamp_ns % 10**9))
        if ros1:
            return Header(seq=0, stamp=stamp, frame_id=frame)
        return Header(stamp=stamp, frame_id=frame)

    out = []
    empty = np.zeros(0, dtype=np.float32)
    for stamp, v, i in zip(drive.battery_ns, drive.voltage_V, drive.current_A, strict=True):
        message = Battery(
            header=header(int(stamp), "battery"),
            voltage=float(v),
            temperature=float("nan"),
            current=float(i),
            charge=float("nan"),
            capacity=float("nan"),
            design_capacity=float("nan"),
            percentage=0.8,
            power_supply_status=2,
            power_supply_health=1,
            power_supply_technology=3,
            present=True,
            cell_voltage=empty,
            cell_temperature=empty,
            location="",
            serial_number="",
        )
        # the recorder receives each message 12-20 ms after its stamp, unevenly
        latency_ns = RECEIVE_LATENCY_NS + (int(stamp) // BATTERY_PERIOD_NS * 7919 % 9) * 10**6
        out.append(("/battery", Battery.__msgtype__, int(stamp) + latency_ns, message))
    for stamp, speed, yaw in zip(drive.odom_ns, drive.speed_mps, drive.yaw_rate_radps, strict=True):
        twist = Twist(
            linear=Vector3(x=float(speed), y=0.0, z=0.0),
            angular=Vector3(x=0.0, y=0.0, z=float(yaw)),
        )
        message = Odometry(
            header=header(int(stamp), "odom"),
            child_frame_id="base_link",
            pose=PoseCov(
                pose=Pose(
                    position=Point(x=0.0, y=0.0, z=0.0),
                    orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                ),
                covariance=np.zeros(36),
            ),
            twist=TwistCov(twist=twist, covariance=np.zeros(36)),
        )
        out.append(("/odom", Odometry.__msgtype__, int(stamp) + 3_000_000, message))
        if cmd_vel:
            command = Twist(
                linear=Vector3(x=0.5, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.1)
            )
            out.append(("/cmd_vel", Twist.__msgtype__, int(stamp) + 1_000_000, command))
    out.sort(key=lambda m: m[2])
    return out


def write_bag(path: Path, drive: Drive, kind: str, *, cmd_vel: bool = False, only=None) -> Path:
    """The drive as a ROS 1 bag (`ros1`), a ROS 2 sqlite3 bag folder (`sqlite3`) or a bare
    MCAP file (`mcap`), by rosbags' writers. `only`: the topics to write."""
    ros1 = kind == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    messages = [m for m in _messages(store, drive, ros1, cmd_vel) if only is None or m[0] in only]
    if ros1:
        writer = Writer1(path)
        serialize = store.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    connections = {}
    with writer:
        for topic, msgtype, received_ns, message in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], received_ns, serialize(message, msgtype))
    if kind == "mcap":  # the bare file, without its folder's metadata.yaml
        (mcap,) = path.glob("*.mcap")
        bare = path.with_suffix(".mcap")
        mcap.rename(bare)
        for leftover in path.iterdir():
            leftover.unlink()
        path.rmdir()
        return bare
    return path


def write_csv(path: Path, drive: Drive) -> Path:
    """The canonical CSV of the same samples, as a careful converter writes it: time from the
    battery's header stamps, current as a draw (positive), speed and yaw rate of the
    truth at each battery stamp (`_speed_at`: the robot's own, not the odometry's)."""
    t_s = (drive.battery_ns - drive.battery_ns[0]) * 1e-9
    lines = ["time_s,voltage_V,current_A,speed_mps,yaw_rate_radps"]
    speed, yaw = _speed_at(t_s), _yaw_at(t_s)
    for row in zip(t_s, drive.voltage_V, -drive.current_A, speed, yaw, strict=True):
        lines.append(",".join(repr(float(x)) for x in row))
    path.write_text("\n".join(lines) + "\n")
    return path


KINDS = ("ros1", "sqlite3", "mcap")
NAMES = {"ros1": "drive.bag", "sqlite3": "drive_ros2", "mcap": "drive_mcap"}


@pytest.fixture(scope="module")
def drive() -> Drive:
    return make_drive()


@pytest.fixture(scope="module")
def bags(tmp_path_factory, drive) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("bags")
    return {kind: write_bag(folder / NAMES[kind], drive, kind) for kind in KINDS}


@pytest.fixture(scope="module")
def csv_run(tmp_path_factory, drive):
    path = write_csv(tmp_path_factory.mktemp("csv") / "drive.csv", drive)
    return read_log(path)


MOTION = {"mode": "motion", "speed_mps": "0.8"}


@pytest.mark.parametrize("kind", KINDS)
def test_bag_energy_is_the_csv_energy(bags, csv_run, kind):
    run = read_log(bags[kind])
    assert run.format == "rosbag"
    assert run.samples == csv_run.samples
    # the same samples: power to the last bit (float32 voltage x float32 current, as the CSV)
    np.testing.assert_array_equal(run.power_W, csv_run.power_W)
    np.testing.assert_allclose(run.time_s, csv_run.time_s, rtol=0, atol=1e-9)
    assert run.sample_period_s == pytest.approx(csv_run.sample_period_s, rel=1e-9)
    assert run.energy_J == pytest.approx(csv_run.energy_J, rel=1e-9)
    assert run.energy_J > 0  # the discharge sign applied: a draw is positive power


@pytest.mark.parametrize("kind", KINDS)
def test_discharge_sign_is_applied(bags, drive, kind):
    """P = V x (-I): each sample's power is the battery's voltage times the current's
    negation (the current is negative while discharging); dropping the sign makes the
    power negative throughout, which the reader refuses as a reversed sensor."""
    run = read_log(bags[kind])
    expected = drive.voltage_V.astype(np.float64) * -drive.current_A.astype(np.float64)
    np.testing.assert_array_equal(run.power_W, expected)
    assert run.power_W.min() > 15.0
    # --flip-current negates it, and then it is negative most of the time: refused
    with pytest.raises(LogError, match="negative most of the time"):
        read_log(bags[kind], ReadOptions(flip_current=True))


@pytest.mark.parametrize("kind", KINDS)
def test_phases_are_the_csv_phases(bags, csv_run, kind):
    bag_run = read_log(bags[kind], overrides=MOTION)
    csv_motion = read_log(csv_run.file, overrides=MOTION)
    bag_phases = segment_run(bag_run).phases
    csv_phases = segment_run(csv_motion).phases
    assert [p.phase for p in bag_phases] == [p.phase for p in csv_phases]
    assert "cruise" in [p.phase for p in csv_phases]
    # boundaries within an odometry period and its jitter: the bag's speed is odometry's
    # latest reading, the CSV's the robot's own speed at the battery stamp
    for ours, theirs in zip(bag_phases, csv_phases, strict=True):
        assert abs(ours.t_start_s - theirs.t_start_s) <= 0.1
        assert abs(ours.t_end_s - theirs.t_end_s) <= 0.1
    bag_J = sum(p.energy_J for p in bag_phases)
    csv_J = sum(p.energy_J for p in csv_phases)
    assert bag_J == pytest.approx(csv_J, rel=1e-9)


def _latest_before(odom_ns: np.ndarray, values: np.ndarray, at_ns: int, limit_ns: float):
    """The reference, one sample at a time: the odometry reading at or before `at_ns` no
    older than `limit_ns`, else NaN."""
    best = None
    for stamp, value in zip(odom_ns, values, strict=True):
        if stamp <= at_ns and (best is None or stamp >= best[0]):
            best = (stamp, value)
    if best is None or at_ns - best[0] > limit_ns:
        return float("nan")
    return float(best[1])


@pytest.mark.parametrize("kind", KINDS)
def test_speed_is_never_carried_across_the_gap(bags, drive, kind):
    run = read_log(bags[kind])
    order = np.argsort(drive.odom_ns)
    odom_ns, speed = drive.odom_ns[order], drive.speed_mps[order]
    limit_ns = STALE_PERIODS * float(np.median(np.diff(odom_ns)))
    expected = np.array(
        [_latest_before(odom_ns, speed, int(t), limit_ns) for t in drive.battery_ns]
    )
    np.testing.assert_array_equal(np.isnan(run.speed_mps), np.isnan(expected))
    np.testing.assert_array_equal(run.speed_mps[~np.isnan(expected)], expected[~np.isnan(expected)])
    # the gap: no reading within the tolerance, so NaN there, not the last one carried on
    t_s = run.time_s
    inside = (t_s > ODOM_GAP_S[0] + 0.1) & (t_s < ODOM_GAP_S[1] - 0.01)
    assert inside.sum() >= 20 and np.isnan(run.speed_mps[inside]).all()
    assert np.isnan(run.yaw_rate_radps[inside]).all()
    assert np.isfinite(run.speed_mps[t_s > ODOM_GAP_S[1] + 0.06]).all()
    (no_speed,) = [p for p in run.problems if p.kind == "no_speed"]
    assert "/odom" in no_speed.message and "not carried across the gap" in no_speed.message
    assert no_speed.t_start_s == pytest.approx(ODOM_GAP_S[0], abs=0.1)
    # yaw rate from the same messages: the arc's 0.4 rad/s
    turning = (t_s > 6.2) & (t_s < 7.8)
    np.testing.assert_array_equal(run.yaw_rate_radps[turning], 0.4)


@pytest.mark.parametrize("kind", KINDS)
def test_header_stamps_not_receive_times(bags, drive, kind):
    run = read_log(bags[kind])
    (clock,) = [p for p in run.problems if p.kind == "time_base"]
    assert "/battery: header stamps" in clock.message
    assert "/odom: header stamps" in clock.message
    # the header stamps, evenly spaced (the receive times are not: 12-20 ms late)
    np.testing.assert_allclose(np.diff(run.time_s), BATTERY_PERIOD_NS * 1e-9, rtol=0, atol=1e-9)
    assert run.meta.started_at.isoformat().startswith("2024-05-01T12:00:00")
    assert run.sample_period_s == pytest.approx(BATTERY_PERIOD_NS * 1e-9, rel=1e-9)


def test_cmd_vel_only_when_named_and_reported_as_commanded(tmp_path, drive):
    path = write_bag(tmp_path / "cmd.bag", drive, "ros1", cmd_vel=True)
    measured = read_log(path)
    assert not [p for p in measured.problems if p.kind == "commanded"]
    assert np.nanmax(measured.speed_mps) > 0.7  # odometry's
    commanded = read_log(path, ReadOptions(speed_topic="/cmd_vel"))
    (note,) = [p for p in commanded.problems if p.kind == "commanded"]
    assert "/cmd_vel" in note.message and "commanded" in note.message
    assert (
        "/cmd_vel: receive times"
        in next(p for p in commanded.problems if p.kind == "time_base").message
    )
    assert np.nanmax(commanded.speed_mps) == 0.5


def test_no_power_topic_names_the_topics_and_the_option(tmp_path, drive, wbpower):
    path = write_bag(tmp_path / "odom_only.bag", drive, "ros1", only={"/odom"})
    with pytest.raises(LogError) as caught:
        read_log(path)
    line = caught.value.one_line()
    assert "\n" not in line
    assert "/odom (nav_msgs/msg/Odometry" in line and "--power-topic" in line
    result = wbpower("inspect", path)
    assert result.exit_code == 2
    assert "/odom" in result.stderr and "--power-topic" in result.stderr


def test_inspect_lists_topics(bags, wbpower):
    result = wbpower("inspect", bags["sqlite3"], "--json")
    assert result.exit_code == 0, result.stderr
    (row,) = json.loads(result.stdout)["logs"]
    topics = {t["topic"]: t for t in row["topics"]}
    assert topics["/battery"]["type"] == "sensor_msgs/msg/BatteryState"
    assert topics["/battery"]["messages"] == int(DURATION_S * 1e9 / BATTERY_PERIOD_NS)
    assert topics["/battery"]["rate_Hz"] == pytest.approx(50.0, rel=2e-3)
    assert topics["/odom"]["rate_Hz"] == pytest.approx(20.0 * 0.96, rel=0.03)
    table = wbpower("inspect", bags["ros1"])
    assert "/battery" in table.stdout and "BatteryState" in table.stdout
    assert re.search(
        r"/battery\W+sensor_msgs/msg/BatteryState\W+800\W+(49\.9\d|50)\W", table.stdout
    )


def test_topic_options(bags):
    with pytest.raises(LogError, match="no topic '/nope'.*--power-topic"):
        read_log(bags["mcap"], ReadOptions(power_topic="/nope"))
    with pytest.raises(LogError, match="is nav_msgs/msg/Odometry, which --power-topic"):
        read_log(bags["mcap"], ReadOptions(power_topic="/odom"))
    named = read_log(bags["mcap"], ReadOptions(power_topic="/battery", speed_topic="/odom"))
    assert named.energy_J == read_log(bags["mcap"]).energy_J


def test_folder_yields_each_bag_once(bags):
    sources, skipped = find_logs([bags["sqlite3"].parent])
    found = sorted(s.path.name for s in sources)
    assert found == sorted(p.name for p in bags.values())
    assert not skipped
    # a ROS 2 bag folder named alone is one log
    (single,), _ = find_logs([bags["sqlite3"]])
    assert single.path == bags["sqlite3"]


def test_segment_and_the_parse_cache_take_a_bag_folder(bags, tmp_path, wbpower):
    """A ROS 2 bag is a folder: `segment` takes it as one log, and `--cache` (which hashes a
    file's bytes) reads it without caching it."""
    from wifibot_power.cache import ParseCache

    result = wbpower("segment", bags["sqlite3"], "--json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)["phases"]
    cached = ParseCache(tmp_path / "cache").read_log(bags["sqlite3"])
    assert cached.energy_J == read_log(bags["sqlite3"]).energy_J
    assert cached.yaw_rate_radps is not None


def test_inspect_out_keeps_the_topics(bags, tmp_path, wbpower):
    import pandas as pd

    result = wbpower("inspect", bags["mcap"], "-o", tmp_path / "out")
    assert result.exit_code == 0, result.stderr
    table = pd.read_parquet(tmp_path / "out" / "logs.parquet")
    topics = list(table["topics"].iloc[0])  # a list of structs (docs/cli-output.md, "-o DIR")
    assert {t["topic"] for t in topics} == {"/battery", "/odom"}


def test_current_and_voltage_topics(tmp_path, drive):
    """`--current-topic` (A, a draw positive) x `--voltage-topic` (V) on the current's stamps:
    the voltage is the latest reading at or before each current sample."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    Float32 = store.types["std_msgs/msg/Float32"]
    path = tmp_path / "iv"
    current_ns = drive.battery_ns
    voltage_ns = drive.battery_ns[::5] + 1_000_000  # 10 Hz, 1 ms after a current sample
    with Writer2(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        c = writer.add_connection("/current", Float32.__msgtype__, typestore=store)
        v = writer.add_connection("/voltage", Float32.__msgtype__, typestore=store)
        rows = [(int(t), c, float(-i)) for t, i in zip(current_ns, drive.current_A, strict=True)]
        rows += [(int(t), v, 12.5) for t in voltage_ns]
        for stamp, connection, value in sorted(rows, key=lambda r: r[0]):
            writer.write(
                connection, stamp, store.serialize_cdr(Float32(data=value), "std_msgs/msg/Float32")
            )
    with pytest.raises(LogError, match="no power topic"):
        read_log(path)
    options = ReadOptions(current_topic="/current", voltage_topic="/voltage")
    run = read_log(path, options)
    # the first current sample precedes every voltage reading: left out, and said
    (cut,) = [p for p in run.problems if p.kind == "cut"]
    assert "first 1 sample(s) of /current" in cut.message
    assert run.samples == drive.current_A.size - 1
    np.testing.assert_array_equal(run.power_W, -drive.current_A[1:].astype(np.float64) * 12.5)
    # a voltage gap in the middle: an error, not a voltage carried across it
    gappy = tmp_path / "gappy"
    with Writer2(gappy, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        c = writer.add_connection("/current", Float32.__msgtype__, typestore=store)
        v = writer.add_connection("/voltage", Float32.__msgtype__, typestore=store)
        rows = [(int(t), c, 1.0) for t in current_ns]
        rows += [(int(t), v, 12.5) for t in voltage_ns if not 5e9 < t - T0_NS < 6e9]
        for stamp, connection, value in sorted(rows, key=lambda r: r[0]):
            data = store.serialize_cdr(Float32(data=value), "std_msgs/msg/Float32")
            writer.write(connection, stamp, data)
    with pytest.raises(LogError, match="voltage topic /voltage has no message up to 150 ms"):
        read_log(gappy, options)
    supplied = read_log(path, ReadOptions(current_topic="/current", supply_voltage_V=12.5))
    np.testing.assert_array_equal(supplied.power_W, -drive.current_A.astype(np.float64) * 12.5)
    (clock,) = [p for p in supplied.problems if p.kind == "time_base"]
    assert "/current: receive times" in clock.message  # Float32 has no header
