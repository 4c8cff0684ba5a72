"""ROS bags give the drive model's terms of the CSV they were written from (issue 30, the first
"Done when" point; log-format.md, "ROS bags").

A free drive (`wbpower simulate --drive free`'s simulator: stops, straight runs and arcs at
varying speeds, turns in place, reversing; 10 runs of 60 s over two surfaces) is written as
canonical CSVs and as a ROS 1 bag, a ROS 2 sqlite3 bag and an MCAP file each, by rosbags'
writers (`test_io_bags.write_bag`):

- `/battery` (BatteryState) at the simulator's 20 Hz: voltage and current as float32, as the
  message carries them, the current negative while discharging (ROS's sign); the CSV carries
  the same float32 values with the current as a draw, so power is the same to the bit;
- `/odom` (Odometry) at 30 Hz with +-5 ms of jitter, starting ~10 ms after the battery: the
  robot's speed and rate of turn at each odometry stamp (float64, as Twist carries them).

The surface comes from the manifest for a bag (here its row as `overrides`) and from the CSV's
own metadata. The simulator's speed and rate of turn are exact here (no encoder steps, no gyro
noise): what is compared is what the bag reader does with the topics, not two noises.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags", reason="the 'ros' extra (pip install 'wbpower[ros]')")

from test_io_bags import KINDS, T0_NS, Drive, write_bag  # noqa: E402

from wifibot_power.drive import fit_drive  # noqa: E402
from wifibot_power.drive.simulate import FreeDriveConfig, FreeRun, simulate_free  # noqa: E402
from wifibot_power.io import read_log  # noqa: E402

#: the free drive: 5 runs on each of two surfaces (10 runs: the intervals are clustered by run,
#: `drive.model.MIN_RUN_CLUSTERS`), a 20 Hz logger with its power noise and drop-outs
CONFIG = FreeDriveConfig(
    runs_per_surface=5,
    run_s=60.0,
    seed=11,
    realism_overrides={"speed_noise_mps": 0.0, "speed_step_mps": 0.0, "yaw_noise_radps": 0.0},
)
BATTERY_PERIOD_S = CONFIG.level()["sample_period_s"]  # 0.05 s
ODOM_PERIOD_NS = 33_333_333  # 30 Hz
ODOM_JITTER_NS = 5_000_000  # +-5 ms
ODOM_START_NS = 10_000_000  # the odometry's first message ~10 ms after the battery's
#: the windows the drive model fits its terms on [s] (drive/windows.py, WINDOW_S)
WINDOW_S = 0.5

#: The tolerance. Power is the CSV's to the bit (checked), so the terms differ only by how the
#: odometry's readings are put on the power stamps: the latest reading at or before each one
#: (rosbag.py; never interpolated), up to one odometry period (+ jitter) old. The mean of that
#: age, half a period, and the CSV's speed being the mean over its sample's period (also the
#: bag's power's, placed at the period's start) make the bag's speed later by P/2 + T_o/2:
#: the lag the drive model fits takes that up (`LAG_SHIFT_S`, checked to the odometry's
#: jitter). What is left is the age's spread around its mean, +-T_o/2: each window's edge
#: speeds, from which the inertial terms are taken (d(v^2/2)/dt over the window), are placed
#: in time to +-T_o/2 of a 0.5 s window, +-3.3%; every term is held to that, relative.
RELATIVE_TOLERANCE = ODOM_PERIOD_NS * 1e-9 / 2 / WINDOW_S
LAG_SHIFT_S = BATTERY_PERIOD_S / 2 + ODOM_PERIOD_NS * 1e-9 / 2


def voltage_and_current(power_W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A 3-cell lithium-ion pack's voltage (12.6 V full, sagging with the draw) and the
    current, as BatteryState carries them: float32, the current negative while discharging."""
    voltage_V = (12.6 - 0.004 * power_W).astype(np.float32)
    return voltage_V, (-power_W / voltage_V).astype(np.float32)


def drive_of(run: FreeRun, rng: np.random.Generator) -> Drive:
    """The run as the topics carry it. The odometry's reading at its stamp s is the robot's
    speed at s: the simulator's sample at t is the mean over [t, t + P) (simulate.py), so its
    value is placed at t + P/2 and interpolated (the speed ramps linearly between targets)."""
    battery_ns = T0_NS + np.round(run.time_s * 1e9).astype(np.int64)
    voltage_V, current_A = voltage_and_current(run.power_W)
    span_ns = int(battery_ns[-1] - battery_ns[0])
    odom_ns = T0_NS + ODOM_START_NS + np.arange(0, span_ns, ODOM_PERIOD_NS, dtype=np.int64)
    odom_ns = odom_ns + rng.integers(-ODOM_JITTER_NS, ODOM_JITTER_NS, odom_ns.size)
    odom_s = (odom_ns - T0_NS) * 1e-9
    middle_s = run.time_s + BATTERY_PERIOD_S / 2
    return Drive(
        battery_ns,
        voltage_V,
        current_A,
        odom_ns,
        np.interp(odom_s, middle_s, run.speed_mps),
        np.interp(odom_s, middle_s, run.yaw_rate_radps),
    )


def write_csv(path: Path, run: FreeRun, drive: Drive) -> Path:
    """The canonical CSV the bags are written from: time from the battery's stamps, the same
    float32 voltage and current (a draw: positive), the simulator's speed and rate of turn."""
    t_s = (drive.battery_ns - drive.battery_ns[0]) * 1e-9
    columns = (t_s, drive.voltage_V, -drive.current_A, run.speed_mps, run.yaw_rate_radps)
    lines = [
        "# wbpower-log: 1",
        f"# run_id: {run.run_id}",
        f"# surface: {run.surface}",
        "time_s,voltage_V,current_A,speed_mps,yaw_rate_radps",
    ]
    lines += [",".join(repr(float(x)) for x in row) for row in zip(*columns, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, list[tuple[Path, FreeRun]]]:
    """Each run as a CSV and as each kind of bag: {"csv" or kind: [(path, run)]}."""
    folder = tmp_path_factory.mktemp("free_drive")
    rng = np.random.default_rng(5)
    out: dict[str, list[tuple[Path, FreeRun]]] = {"csv": [], **{kind: [] for kind in KINDS}}
    for run in simulate_free(CONFIG):
        drive = drive_of(run, rng)
        out["csv"].append((write_csv(folder / f"{run.run_id}.csv", run, drive), run))
        for kind in KINDS:
            name = {"ros1": ".bag", "sqlite3": "_ros2", "mcap": "_mcap"}[kind]
            out[kind].append((write_bag(folder / f"{run.run_id}{name}", drive, kind), run))
    return out


@pytest.fixture(scope="module")
def csv_runs(logs):
    return [read_log(path) for path, _ in logs["csv"]]


@pytest.fixture(scope="module")
def csv_model(csv_runs):
    model = fit_drive(csv_runs)
    # the comparison has teeth only when the CSV determines every term, turning included
    assert model is not None and not model.not_determined, model.not_determined
    assert set(model.surfaces) == {"asphalt", "grass"}
    assert all("turning_Nm" in terms for terms in model.surfaces.values())
    return model


def terms_of(model) -> dict[str, tuple[float, tuple[float, float]]]:
    """Every determined term of a summary, per-surface ones as `name[surface]`: (value, ci95)."""
    summary = model.summary()
    flat = {name: term for name, term in summary["terms"].items()}
    for surface, named in summary["surfaces"].items():
        flat.update({f"{name}[{surface}]": term for name, term in named.items()})
    return {name: (term["value"], tuple(term["ci95"])) for name, term in flat.items()}


@pytest.mark.parametrize("kind", KINDS)
def test_bag_drive_terms_are_the_csv_terms(logs, csv_runs, csv_model, kind):
    """The drive model fitted on the bags has the CSV fit's terms: the same terms determined,
    each within `RELATIVE_TOLERANCE` of the CSV's value and inside its 95% interval, and the
    lag shorter by the odometry's hold (`LAG_SHIFT_S`). Dropping the bag reader's yaw rate
    leaves the turning terms undetermined (and the rolling terms take their power); dropping
    the discharge sign makes the power negative, which the reader refuses."""
    runs = [
        read_log(path, overrides={"run_id": run.run_id, "surface": run.surface})
        for path, run in logs[kind]
    ]
    for bag, csv in zip(runs, csv_runs, strict=True):
        assert bag.format == "rosbag"
        # the precision BatteryState carries (float32), which the CSV carries too: the same
        # power to the bit, so any difference below is the odometry's resampling
        np.testing.assert_array_equal(bag.power_W, csv.power_W)
        np.testing.assert_allclose(bag.time_s, csv.time_s, rtol=0, atol=1e-9)
        assert bag.yaw_rate_radps is not None
        # the odometry starts after the battery: the first power sample has no speed (NaN,
        # never a later reading), which the drive model must take as unknown
        assert np.isnan(bag.speed_mps[0]) and np.isfinite(bag.speed_mps[1:]).all()
    model = fit_drive(runs)
    assert model is not None
    assert model.not_determined == csv_model.not_determined
    ours, theirs = terms_of(model), terms_of(csv_model)
    assert set(ours) == set(theirs)
    for name, (csv_value, (low, high)) in theirs.items():
        bag_value = ours[name][0]
        assert bag_value == pytest.approx(csv_value, rel=RELATIVE_TOLERANCE), name
        assert low <= bag_value <= high, (name, bag_value, (low, high))
    assert csv_model.lag_s - model.lag_s == pytest.approx(LAG_SHIFT_S, abs=ODOM_JITTER_NS * 1e-9)


def test_a_bag_a_manifest_calls_motion_needs_no_commanded_speed(logs):
    """A bag's odometry is its speed: a manifest row saying `mode: motion` without speed_mps
    reads it as free driving (log-format.md, "Speed"), not as a step run missing its speed."""
    path = logs["mcap"][0][0]
    run = read_log(path, None, {"mode": "motion"})
    assert run.meta.mode == "motion" and run.meta.speed_mps is None
