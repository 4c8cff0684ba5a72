"""Turning and standstills (docs/segmentation.md, "Turning and standstills"; cli.md
`segment`; log-format.md "Turning"): a robot that turns while its linear speed is ~0 gets
`turn` phases, never `idle`; without a turning column, a standstill at motion power is a
doubt that says what was seen. Runs are built here directly with the turning column set
(the reader of turning columns is the drive lane's)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from wifibot_power.errors import LogError
from wifibot_power.run import Run, RunMeta
from wifibot_power.segment import segment_run

#: the words that end the standstill doubt
AT_MOTION_POWER = "pushing (against an obstacle, at a current limit) or turning in place?"


def _piecewise(plan: list[tuple[float, ...]], dt: float, column: int) -> np.ndarray:
    """Column `column` of a plan of (seconds, v0, v1, yaw, power): a linear ramp for the
    speed (1, 2), a constant for the others."""
    if column == 1:
        return np.concatenate(
            [np.linspace(p[1], p[2], round(p[0] / dt), endpoint=False) for p in plan]
        )
    return np.concatenate([np.full(round(p[0] / dt), p[column]) for p in plan])


#: a skid-steer field robot (issue 25's): 28 W standing, 150-200 W driving straight at 1 m/s,
#: 500 W spinning in place at 1 rad/s. (seconds, v from, v to, yaw rate, power)
SKID_STEER = [
    (5, 0, 0, 0, 28),
    (2, 0, 1, 0, 200),
    (10, 1, 1, 0, 150),
    (2, 1, 0, 0, 60),
    (4, 0, 0, 0, 28),
    (6, 0, 0, 1.0, 500),  # spinning in place
    (4, 0, 0, 0, 28),
    (2, 0, 1, 0, 200),
    (8, 1, 1, 0, 150),
    (2, 1, 0, 0, 60),
    (5, 0, 0, 0, 28),
]


def skid_steer(
    plan=SKID_STEER,
    dt: float = 1 / 6.5,
    seed: int = 0,
    yaw: bool = True,
    track: str | None = "0.55",
    yaw_noise_radps: float = 0.02,
) -> Run:
    """The robot at 6.5 Hz (the field robot's logger), speed noise 0.01 m/s, yaw-rate noise
    `yaw_noise_radps`, power noise 3 W; its turning column when `yaw`."""
    rng = np.random.default_rng(seed)
    v = _piecewise(plan, dt, 1)
    n = v.size
    speed = v + rng.normal(0, 0.01, n)
    yaw_rate = _piecewise(plan, dt, 3) + rng.normal(0, yaw_noise_radps, n)
    power = _piecewise(plan, dt, 4) + rng.normal(0, 3.0, n)
    extra = {"track_m": track} if track else {}
    meta = RunMeta(
        run_id="skid", mode="motion", speed_mps=1.0, steps=2, sample_period_s=dt, extra=extra
    )
    return Run(
        "skid.csv",
        "canonical",
        meta,
        np.arange(n) * dt,
        power,
        speed_mps=speed,
        yaw_rate_radps=yaw_rate if yaw else None,
    )


def test_phases_carry_the_mean_turn_rate_and_null_without_a_turning_column() -> None:
    run = skid_steer()
    seg = segment_run(run)
    for phase in seg.phases:
        want = float(np.mean(np.abs(run.yaw_rate_radps[phase.i_start : phase.i_end])))
        assert phase.yaw_rate_radps == pytest.approx(want, rel=1e-12)
        assert phase.as_dict()["yaw_rate_radps"] == phase.yaw_rate_radps
    bare = segment_run(skid_steer(yaw=False))
    assert all(p.yaw_rate_radps is None for p in bare.phases)
    assert all(p.as_dict()["yaw_rate_radps"] is None for p in bare.phases)
    # NaN samples (drop-outs) are left out of the mean, not read as 0
    holes = run.yaw_rate_radps.copy()
    holes[::2] = np.nan
    seg = segment_run(dataclasses.replace(run, yaw_rate_radps=holes))
    (turn,) = seg.of("turn")  # one turn: the drop-outs bridged, not read as 0
    kept = holes[turn.i_start : turn.i_end]
    assert turn.yaw_rate_radps == pytest.approx(float(np.nanmean(np.abs(kept))), rel=1e-12)


@pytest.mark.parametrize("seed", range(3))
def test_spinning_in_place_is_a_turn_never_idle(seed: int) -> None:
    """The 6 s spin (22.9-28.9 s) is one `turn` phase, within one sample period at each end,
    at ~1 rad/s and 500 W; no idle phase holds any of it; the run is not in doubt."""
    run = skid_steer(seed=seed)
    dt = run.sample_period_s
    seg = segment_run(run)
    (turn,) = seg.of("turn")
    assert turn.t_start_s == pytest.approx(23.0, abs=dt + 1e-9)
    assert turn.t_end_s == pytest.approx(29.0, abs=dt + 1e-9)
    assert turn.yaw_rate_radps == pytest.approx(1.0, abs=0.05)
    assert turn.mean_power_W == pytest.approx(500.0, abs=10.0)
    assert turn.step == 1  # numbered as the idle it interrupts (after step 1)
    spin = slice(round(23.0 / dt) + 1, round(29.0 / dt) - 1)
    for idle in seg.of("idle"):
        assert idle.i_end <= spin.start or idle.i_start >= spin.stop, idle
        assert idle.mean_power_W < 40.0
    assert [p.phase for p in seg.phases].count("idle") == 4
    assert seg.doubts == ()
    # phases still cover every sample once
    assert seg.phases[0].i_start == 0 and seg.phases[-1].i_end == run.samples
    assert all(a.i_end == b.i_start for a, b in zip(seg.phases, seg.phases[1:], strict=False))


def test_a_run_that_only_spins_is_not_refused_as_no_motion() -> None:
    """Issue 26: a run that only spins was refused with "no motion found ... check the speed
    column and its unit". With a turning column it is idle, turn, idle."""
    plan = [(4, 0, 0, 0, 28), (6, 0, 0, -0.8, 530), (4, 0, 0, 0, 28)]  # clockwise
    seg = segment_run(skid_steer(plan))
    assert [p.phase for p in seg.phases] == ["idle", "turn", "idle"]
    assert seg.phases[1].yaw_rate_radps == pytest.approx(0.8, abs=0.05)
    # without the column there is nothing to say it moved: refused, as before
    with pytest.raises(LogError, match="no motion found"):
        segment_run(skid_steer(plan, yaw=False))


@pytest.mark.parametrize("seed", range(5))
def test_a_gyros_noise_at_standstill_is_no_turn(seed: int) -> None:
    """A robot that never turns, whose yaw-rate reading is noise of 0.05 rad/s a sample
    (more than its speed's): no turn phase (the threshold stands 5 sd of the smoothed noise
    above 0, and above 2% of the top rate)."""
    plan = [p if p[3] == 0 else (p[0], 0, 0, 0, 28) for p in SKID_STEER]
    seg = segment_run(skid_steer(plan, seed=seed, yaw_noise_radps=0.05, track=None))
    assert seg.of("turn") == []


def test_a_turn_slower_than_the_wheels_moving_threshold_is_no_turn() -> None:
    """With the track width, a turn counts only where each wheel of a robot spinning in
    place, at omega * track / 2, moves as fast as the speed column's moving threshold (2% of
    the top speed, 1 m/s here: 0.02 m/s, omega = 0.073 rad/s on a 0.55 m track). A gyro
    bias of 0.05 rad/s while the robot stands (a wheel speed of 0.014 m/s) is no turn with
    the track given; a turn at 0.3 rad/s (0.083 m/s a wheel) is one."""
    plan = [p if p[3] == 0 else (p[0], 0, 0, 0.3, 200) for p in SKID_STEER]
    biased = skid_steer(plan, yaw_noise_radps=0.002)
    biased = dataclasses.replace(biased, yaw_rate_radps=biased.yaw_rate_radps + 0.05)
    seg = segment_run(biased)
    (turn,) = seg.of("turn")
    assert turn.yaw_rate_radps == pytest.approx(0.35, abs=0.01)
    # the bias alone, without the turn, is no turn
    still = [p if p[3] == 0 else (p[0], 0, 0, 0, 28) for p in SKID_STEER]
    run = skid_steer(still, yaw_noise_radps=0.002)
    run = dataclasses.replace(run, yaw_rate_radps=run.yaw_rate_radps + 0.05)
    assert segment_run(run).of("turn") == []


def test_without_a_turning_column_a_spin_is_a_doubt_saying_what_was_seen() -> None:
    """Issue 26: labelled idle at 500 W against 28 W standing, no doubt. Now the idle that
    holds the spin is doubted, with its power, its speed and the log's own standing and
    moving powers."""
    seg = segment_run(skid_steer(yaw=False))
    (doubt,) = seg.doubts
    assert doubt.startswith("the idle of step 1 (18.923-33.077 s) stands still (")
    assert "at motion power for 6.00 s from 22.923 s: 500 W (median) against" in doubt
    assert "the log has no turning column" in doubt and doubt.endswith(AT_MOTION_POWER)
    standing, moving = re.search(
        r"against ([\d.]+) W standing and ([\d.]+) W moving", doubt
    ).groups()
    assert 25 < float(standing) < 31 and 130 < float(moving) < 160


def test_pushing_at_a_standstill_is_a_doubt_even_with_a_turning_column() -> None:
    """A robot standing at motion power whose turning column shows no turn (pushing against
    an obstacle): no turn phase, a doubt that says the column shows none."""
    plan = [p if p[3] == 0 else (p[0], 0, 0, 0, 300) for p in SKID_STEER]
    seg = segment_run(skid_steer(plan))
    assert seg.of("turn") == []
    (doubt,) = seg.doubts
    assert "its turning column shows no turn (" in doubt and doubt.endswith(AT_MOTION_POWER)


def _levels_run(dt: float, lag_s: float = 0.0, electronics_W: float = 2.0) -> Run:
    """Two motions at 2 m/s; electronics switched on after the first (5 -> 5 +
    `electronics_W` W); a commanded speed that reads 0 `lag_s` before the drive stops
    (the stop's tail read as standing)."""
    pieces = [(1.0, 0.0, 0.0), (0.5, 0.0, 2.0), (3.0, 2.0, 2.0), (0.5, 2.0, 0.0)]
    pieces += [(1.5, 0.0, 0.0), (0.5, 0.0, 2.0), (3.0, 2.0, 2.0), (0.5, 2.0, 0.0), (1.0, 0.0, 0.0)]
    speed = np.concatenate([np.linspace(a, b, round(s / dt), endpoint=False) for s, a, b in pieces])
    rng = np.random.default_rng(3)
    time_s = np.arange(speed.size) * dt
    base_W = np.where(time_s < 5.0, 5.0, 5.0 + electronics_W)
    driven = np.where(speed > 0, 1.0 + 0.5 * speed, 0.0)
    power = base_W + driven + rng.normal(0.0, 0.05, speed.size)
    commanded = np.roll(speed, -round(lag_s / dt)) if lag_s else speed  # reads 0 early
    meta = RunMeta(run_id="levels", mode="motion", speed_mps=2.0, steps=2, sample_period_s=dt)
    return Run("levels.csv", "canonical", meta, time_s, power, speed_mps=commanded)


@pytest.mark.parametrize("dt", [0.055, 1e-3])
def test_a_lagging_speed_or_another_flat_level_is_no_standstill_doubt(dt: float) -> None:
    """The two cases that had a fifth session's "pushing" doubt taken out (docs): an idle at
    another flat level (5 -> 7 W, below the 7.9 W moving on average) and a commanded speed
    that reads 0 up to 0.2 s before the drive stops (the stop's tail at motion power, but
    running on from the motion before: not a stretch of the idle's own)."""
    for lag_s in (0.0, 0.06, 0.2):
        seg = segment_run(_levels_run(dt, lag_s))
        assert [p.phase for p in seg.phases].count("idle") == 3, lag_s
        assert not [d for d in seg.doubts if d.endswith(AT_MOTION_POWER)], (lag_s, seg.doubts)
    # the same electronics step up to above the moving power is a standstill at motion power
    seg = segment_run(_levels_run(dt, electronics_W=6.0))
    assert [d for d in seg.doubts if d.endswith(AT_MOTION_POWER)]


def _with_true_speed(sim) -> Run:
    """A simulated run with its true speed as a speed column (a linear ramp over each
    accel and decel phase of its truth, the run's speed over each cruise) plus 0.5% of
    it as noise: the simulator's grid as a logger with odometry would give it."""
    run = sim.run
    dt = run.sample_period_s
    speed = np.zeros(run.samples)
    v = sim.truth["speed_mps"]
    for phase in sim.truth["phases"]:
        a = round(phase["t_start_s"] / dt)
        b = min(round(phase["t_end_s"] / dt), run.samples)
        if phase["phase"] == "cruise":
            speed[a:b] = v
        elif phase["phase"] in ("accel", "decel"):
            ramp = (np.arange(b - a) + 0.5) / max(b - a, 1)
            speed[a:b] = v * (ramp if phase["phase"] == "accel" else 1.0 - ramp)
    rng = np.random.default_rng(0)
    return dataclasses.replace(run, speed_mps=speed + rng.normal(0.0, 0.005 * v, speed.size))


@pytest.mark.parametrize("level", ["lab", "field"])
def test_no_standstill_doubt_on_the_simulators_grid(level: str) -> None:
    """The simulator's grid (every speed, the three trips, every catalogue effect, at lab
    and field realism, 1.024 ms), given its true speed as a column: no idle at motion
    power anywhere (the simulator's robot stands at idle power when it stands)."""
    from wifibot_power.simulate import EFFECTS, SimConfig, realism, simulate_runs

    config = SimConfig(
        repeats=1,
        modes=(),
        sample_period_s=0.001024,
        effects=dict.fromkeys(EFFECTS, 1.0) | {"decel_phase": 0.3},
        seed=5,
        **realism(level),
    )
    runs = 0
    for sim in simulate_runs(config):
        seg = segment_run(_with_true_speed(sim))
        runs += 1
        assert not [d for d in seg.doubts if d.endswith(AT_MOTION_POWER)], sim.run.meta.run_id
    assert runs >= 27


@pytest.mark.parametrize("seed", range(5))
def test_noise_at_a_standstill_is_no_stretch_at_motion_power(seed: int) -> None:
    """A robot whose driving draws 2 W over its 28 W standing, logged at 6.5 Hz with 3 W of
    noise a sample: samples of its idles stand above the 30 W moving power by chance, two
    in a row now and then, but never 5 sd of a median of so few samples clear of standing
    (10.6 W for two): no doubt."""
    plan = [(p[0], p[1], p[2], 0, 28 if p[1] == p[2] == 0 else 30) for p in SKID_STEER]
    plan = [(60, 0, 0, 0, 28), *plan, (60, 0, 0, 0, 28)]  # long idles: many chances
    seg = segment_run(skid_steer(plan, seed=seed, yaw=False))
    assert not [d for d in seg.doubts if d.endswith(AT_MOTION_POWER)]


def _burst(dt: float, seconds: float) -> list[str]:
    """The standstill doubts of the skid-steer run without its spin, whose idle after step
    1 holds a burst at 500 W of `seconds` instead."""
    plan = list(SKID_STEER)
    plan[5:6] = [(3, 0, 0, 0, 28), (seconds, 0, 0, 0, 500), (3, 0, 0, 0, 28)]
    seg = segment_run(skid_steer(plan, dt=dt, yaw=False))
    return [d for d in seg.doubts if d.endswith(AT_MOTION_POWER)]


def test_a_burst_within_a_boundarys_tolerance_or_of_one_sample_is_no_standstill() -> None:
    """A stretch at motion power must last more than the 50 ms a boundary may be off, and
    two samples or more: at 1 kHz, 40 ms is not enough and 100 ms is; at 6.5 Hz one reading
    (0.154 s) is not, two are."""
    assert _burst(1e-3, 0.04) == []
    assert len(_burst(1e-3, 0.1)) == 1
    assert _burst(1 / 6.5, 1 / 6.5) == []
    assert len(_burst(1 / 6.5, 2 / 6.5)) == 1


def test_segment_shows_turn_phases_and_their_turn_rate(wbpower, tmp_path, monkeypatch) -> None:
    """`wbpower segment` of a run with a turning column: `turn` in the table with a
    "|yaw rate| rad/s" column, and `yaw_rate_radps` on every phase of `--json` (cli.md); the
    run comes from the reader (the drive lane's reads the column; here it is handed over)."""
    import json

    import wifibot_power.io

    run = skid_steer()
    path = tmp_path / "skid.csv"
    path.write_text("time_s,power_W\n0,28\n")
    monkeypatch.setattr(wifibot_power.io, "read_log", lambda *args, **kwargs: run)
    table = wbpower("segment", path)
    assert table.exit_code == 0, table.stderr
    assert "|yaw rate| rad/s" in table.stdout and " turn " in table.stdout
    doc = json.loads(wbpower("segment", path, "--json").stdout)
    (turn,) = [p for p in doc["phases"] if p["phase"] == "turn"]
    assert turn["yaw_rate_radps"] == pytest.approx(1.0, abs=0.05)
    assert all(isinstance(p["yaw_rate_radps"], float) for p in doc["phases"])
    # without the column: null, and no yaw column in the table
    monkeypatch.setattr(wifibot_power.io, "read_log", lambda *a, **k: skid_steer(yaw=False))
    doc = json.loads(wbpower("segment", path, "--json").stdout)
    assert all(p["yaw_rate_radps"] is None for p in doc["phases"])
    assert "yaw" not in wbpower("segment", path).stdout


def test_a_run_that_only_spins_without_a_turning_column_is_refused_with_what_was_seen() -> None:
    """Issue 26: "no motion found ... check the speed column and its unit", advice about
    units for a run drawing 530 W. The refusal now gives the power seen and names the
    turning column."""
    plan = [(4, 0, 0, 0, 28), (6, 0, 0, -0.8, 530), (4, 0, 0, 0, 28)]
    with pytest.raises(LogError) as caught:
        segment_run(skid_steer(plan, yaw=False))
    message = caught.value.one_line()
    assert re.search(r"\(power 2\d\.?\d*-5\d\d W, 5th-95th percentile\)", message), message
    assert "--yaw-rate-column" in message and "--track-width" in message
