"""`fit` says when its model is implausible or weakly determined (cli.md `warnings`, issue 12)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wifibot_power.fit import speed_levels
from wifibot_power.models.paper import fit_rows


def _rows(speeds, accel_W, cruise_W, idle_runs: int = 2) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = [
        {
            "usable": True,
            "mode": "motion",
            "speed_mps": v,
            "accel_mean_power_W": a,
            "cruise_mean_power_W": c,
            "t_acc_s": 0.1 + 0.2 * v,
            "mean_power_W": 25.0,
            "idle_mean_power_W": 23.3,
        }
        for v, a, c in zip(speeds, accel_W, cruise_W, strict=True)
    ]
    rows += [
        {"usable": True, "mode": "idle", "speed_mps": np.nan, "mean_power_W": 23.3 + 0.01 * k}
        for k in range(idle_runs)
    ]
    return rows


def _fit(rows):
    return fit_rows(rows)


SPEEDS = [0.2, 0.2, 0.5, 0.5, 0.8, 0.8]


def test_a_sound_fit_has_no_warning() -> None:
    speeds = np.array(SPEEDS)
    result = _fit(_rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds))
    assert result.warnings == ()
    assert result.summary()["warnings"] == []


def test_issue_reproduction_negative_slope_warns() -> None:
    # issue 12: fit printed P_acc = 16.7 - 5.3 v (and P_v = -3.9 + 3.8 v) with no warning
    speeds = np.array(SPEEDS)
    result = _fit(_rows(speeds, 16.7 - 5.3 * speeds, -3.9 + 3.8 * speeds))
    assert result.model.accel.slope == pytest.approx(-5.3)
    text = " | ".join(result.warnings)
    assert "P_acc slope is negative" in text
    assert "P_v intercept is negative" in text
    assert "P_acc intercept" not in text and "P_v slope" not in text


def test_fewer_than_three_speeds_warns() -> None:
    speeds = np.array([0.3, 0.3, 0.6, 0.6])
    result = _fit(_rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds))
    assert any("2 distinct speed level(s)" in w for w in result.warnings)


def test_speeds_closer_than_their_resolution_are_one_level() -> None:
    # 0.500 and 0.505 m/s differ by 1% (< 2%): one level; 0.2 / 0.5 / 0.8 stay three
    assert speed_levels(np.array([0.2, 0.5, 0.505, 0.8])) == [[0.2], [0.5, 0.505], [0.8]]
    # the resolution is max(5 mm/s, 2%): 0.100 and 0.104 are one, 0.100 and 0.106 two
    assert len(speed_levels(np.array([0.100, 0.104]))) == 1
    assert len(speed_levels(np.array([0.100, 0.106]))) == 2
    speeds = np.array([0.2, 0.5, 0.505, 0.8])
    result = _fit(_rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds))
    assert any("0.5, 0.505 m/s are closer than their resolution" in w for w in result.warnings)
    assert not any("distinct speed level" in w for w in result.warnings)
    # 0.295 and 0.3 (5 mm/s apart) plus 0.5: only two levels -> the three-speed warning too
    speeds = np.array([0.295, 0.3, 0.5, 0.5])
    result = _fit(_rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds))
    assert any("2 distinct speed level(s)" in w for w in result.warnings)


def test_idle_from_motion_runs_warns() -> None:
    speeds = np.array(SPEEDS)
    result = _fit(_rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds, idle_runs=0))
    assert result.idle_source == "idle phases of motion runs"
    assert any(
        "idle power is taken from the idle phases of motion runs" in w for w in result.warnings
    )


def test_fit_command_prints_warnings_on_stderr_and_in_json(tmp_path, wbpower) -> None:
    from wifibot_power.simulate import SimConfig, write_simulation

    # two speeds, no idle runs: two warnings, both in --json and on stderr
    config = SimConfig(
        speeds_mps=(0.3, 0.6),
        trips=((2.0, 1),),
        repeats=2,
        modes=(),
        seed=3,
        sample_period_s=1.024e-3,
    )
    write_simulation(config, tmp_path)
    result = wbpower("fit", tmp_path, "--json", "--jobs", "1")
    doc = json.loads(result.stdout)
    assert len(doc["warnings"]) == 2
    for warning in doc["warnings"]:
        assert warning.split(":")[0] in result.stderr


def test_t_acc_quantized_to_the_sample_period_gets_its_interval_and_a_warning() -> None:
    # issue 26: a 6.5 Hz log's accelerations are one sample each (0.154 s): every run's t_acc
    # is the same and a least-squares interval shrinks to [0.154, 0.154]
    period_s = 1 / 6.5
    speeds = np.array([0.3, 0.3, 0.6, 0.6, 0.9, 0.9, 1.2, 1.2])
    rows = _rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds)
    for row in rows:
        if row["mode"] == "motion":
            row["t_acc_s"] = period_s
            row["sample_period_s"] = period_s
    t_acc = _fit(rows).model.t_acc
    low, high = t_acc.intercept_ci95
    assert low <= t_acc.intercept - period_s and high >= t_acc.intercept + period_s
    # each point known to +- one period over a 0.9 m/s span: the slope to +- 2 periods / span
    s_low, s_high = t_acc.slope_ci95
    assert s_high - s_low >= 2 * (2 * period_s / 0.9) - 1e-12
    assert any("t_acc is quantized to the sample period" in w for w in _fit(rows).warnings)


def test_t_acc_many_samples_long_keeps_its_interval() -> None:
    # the same runs at 1 kHz: 154 samples each, the scatter over runs is their error
    speeds = np.array(SPEEDS)
    rows = _rows(speeds, 23.9 + 14.8 * speeds, 23.9 + 11.2 * speeds)
    for row in rows:
        row["sample_period_s"] = 0.001
    result = _fit(rows)
    assert not any("quantized" in w for w in result.warnings)
