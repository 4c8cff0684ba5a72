"""A speed column with unknown stretches (NaN: a bag's odometry drop-out, log-format.md
"ROS bags") while the robot moves: never read as a stop, filled by a straight line across
with a doubt where a stop could hide, and the path never NaN (docs/segmentation.md)."""

from __future__ import annotations

import numpy as np
import pytest

from wifibot_power.run import Run, RunMeta
from wifibot_power.runtable import _path_m
from wifibot_power.segment import segment_run
from wifibot_power.segment.common import speed_across_gaps

DT_S = 0.01  # a 100 Hz robot log


def _one_trip(gap: tuple[float, float] | None, seed: int = 0) -> Run:
    """2 s standing, 1 s speeding up to 0.8 m/s, 8 s at it, 1 s slowing, 2 s standing; power
    20 W + 30 W/(m/s) x v; the speed unknown over `gap` = (from, to) [s] when given."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 14, DT_S)
    v = 0.8 * np.clip(np.minimum(t - 2.0, 12.0 - t), 0.0, 1.0)
    power = 20.0 + 30.0 * v + rng.normal(0, 0.3, t.size)
    speed = v + rng.normal(0, 0.005, t.size)
    if gap is not None:
        speed[(t >= gap[0]) & (t < gap[1])] = np.nan
    meta = RunMeta(
        run_id="trip", mode="motion", speed_mps=0.8, distance_m=8.8, sample_period_s=DT_S
    )
    return Run("trip.bag", "rosbag", meta, t, power, speed_mps=speed)


def test_filling_is_a_straight_line_between_the_known_samples():
    speed = np.array([np.nan, 1.0, np.nan, np.nan, 4.0, np.nan])
    filled, gaps = speed_across_gaps(speed)
    assert filled.tolist() == [1.0, 1.0, 2.0, 3.0, 4.0, 4.0]
    assert gaps == [(0, 1), (2, 4), (5, 6)]
    whole, none = speed_across_gaps(np.array([0.5, 0.25]))
    assert whole.tolist() == [0.5, 0.25] and none == []


def test_a_drop_out_while_cruising_is_no_stop_and_says_what_was_assumed():
    clean = segment_run(_one_trip(None))
    gapped_run = _one_trip((6.0, 7.5))  # 1.5 s of unknown speed at 0.8 m/s
    gapped = segment_run(gapped_run)
    motions = [p for p in gapped.phases if p.phase in ("accel", "cruise", "decel")]
    assert {p.step for p in motions} == {1}, [(p.step, p.phase) for p in gapped.phases]
    assert [p.phase for p in gapped.phases] == [p.phase for p in clean.phases]
    # the same phases as with the speed known throughout, within a block of samples
    for a, b in zip(gapped.phases, clean.phases, strict=True):
        assert abs(a.t_start_s - b.t_start_s) <= 0.05
    (doubt,) = [d for d in gapped.doubts if "unknown" in d]
    assert "1.5 s" in doubt and "t = 6 s" in doubt and "stop or a start inside" in doubt
    assert not any("unknown" in d for d in clean.doubts)
    path_m = _path_m(gapped_run, gapped.phases)
    assert np.isfinite(path_m)
    assert path_m == pytest.approx(_path_m(_one_trip(None), clean.phases), rel=0.01)


def test_a_drop_out_shorter_than_a_stop_needs_is_filled_without_a_doubt():
    seg = segment_run(_one_trip((6.0, 6.05)))  # 5 samples, below still_s = 0.1 s
    assert not any("unknown" in d for d in seg.doubts)
    assert [p.phase for p in seg.phases] == [p.phase for p in segment_run(_one_trip(None)).phases]
