"""`mode: motion` on a log with a speed column and no commanded `speed_mps` is free driving,
not an error: "a log with a speed column is a motion log whether or not its metadata gives a
commanded speed: it may be free driving" (log-format.md, "Speed"). It was refused ("a motion
run with speed_mps missing"), which asked the user to make a speed up."""

from __future__ import annotations

import json

import pytest

from wifibot_power.drive.simulate import FreeDriveConfig, format_free_log, simulate_free
from wifibot_power.errors import LogError
from wifibot_power.io import read_log
from wifibot_power.runtable import usability
from wifibot_power.segment import segment_run

CONFIG = FreeDriveConfig(runs_per_surface=2, run_s=40.0, seed=2)


@pytest.fixture(scope="module")
def motion_logs(tmp_path_factory):
    """Free-driving logs whose metadata says `mode: motion` and gives no speed_mps."""
    folder = tmp_path_factory.mktemp("motion_free")
    for run in simulate_free(CONFIG):
        first, rest = format_free_log(run).split(b"\n", 1)
        (folder / f"{run.run_id}.csv").write_bytes(first + b"\n# mode: motion\n" + rest)
    return folder


def test_read_as_a_motion_run_without_a_commanded_speed(motion_logs):
    run = read_log(sorted(motion_logs.glob("*.csv"))[0])
    assert run.meta.mode == "motion" and run.meta.speed_mps is None
    assert run.speed_mps is not None


def test_fit_takes_them_into_the_drive_model(motion_logs, wbpower):
    result = wbpower("fit", motion_logs, "--json")
    assert result.exit_code == 0, result.stdout
    document = json.loads(result.stdout)
    assert document["skipped"] == []
    assert document["drive"]["n_runs"] == 4


def test_no_step_count_doubt_without_one(motion_logs):
    """Free driving has no step count: the default (1) is not held against its motions; a
    count the metadata gives still is."""
    path = sorted(motion_logs.glob("*.csv"))[0]
    doubts = segment_run(read_log(path)).doubts
    assert not any("step(s)" in d for d in doubts), doubts
    text = path.read_bytes().replace(b"# mode: motion\n", b"# mode: motion\n# steps: 7\n")
    stepped = path.with_name("stepped.csv")
    stepped.write_bytes(text)
    assert any("metadata says 7 step(s)" in d for d in segment_run(read_log(stepped)).doubts)


def test_two_wheel_speeds_are_a_speed(tmp_path):
    log = tmp_path / "wheels.csv"
    rows = [f"{0.1 * k:.1f},20,0.5,0.6" for k in range(50)]
    header = "# mode: motion\n# track_m: 0.4\ntime_s,power_W,speed_left_mps,speed_right_mps\n"
    log.write_text(header + "\n".join(rows) + "\n")
    run = read_log(log)
    assert run.meta.mode == "motion" and run.speed_mps is not None


@pytest.mark.parametrize(
    ("body", "said"),
    [
        # no speed at all: the paper's step run needs its commanded speed, as before
        ("# mode: motion\ntime_s,power_W\n0,23.3\n0.1,23.3\n", "speed_mps missing"),
        # a commanded speed of 0 is wrong whatever the columns
        ("# mode: motion\n# speed_mps: 0\ntime_s,power_W,speed_mps\n0,23,0\n0.1,23,0\n", "0"),
    ],
)
def test_a_motion_run_without_any_speed_or_with_zero_is_still_refused(tmp_path, body, said):
    log = tmp_path / "bad.csv"
    log.write_text(body)
    with pytest.raises(LogError, match="a motion run with speed_mps") as raised:
        read_log(log)
    assert said in str(raised.value)


def test_the_papers_reason_says_free_driving_not_split_the_log(motion_logs, wbpower):
    """The paper's fit cannot use free driving: its reason says so, never the step run's
    advice to split the log at a level change or to check a step count it never gave."""
    document = json.loads(wbpower("fit", motion_logs, "--json").stdout)
    said = " ".join(document["warnings"])
    assert "free driving (no commanded speed_mps)" in said
    assert "split the log" not in said and "metadata says 1" not in said


def test_a_step_run_keeps_its_reasons():
    row = {
        "mode": "motion",
        "speed_mps": 0.5,
        "commanded_speed_mps": 0.5,
        "distance_m": 10.0,
        "cruise_levels": 2,
        "steps": 1,
        "steps_found": 1,
    }
    assert "split the log" in usability(row)
    free = {**row, "commanded_speed_mps": float("nan")}
    assert usability(free).startswith("free driving (no commanded speed_mps): its cruises hold 2")
    steps = {**row, "cruise_levels": 1, "steps_found": 3}
    assert "metadata says 1" in usability(steps)
    assert "shows 3 motion(s)" in usability({**steps, "commanded_speed_mps": float("nan")})
    # a step count the metadata gave is held even without a commanded speed
    given = {**steps, "commanded_speed_mps": float("nan"), "steps": 2}
    assert "metadata says 2" in usability(given)
