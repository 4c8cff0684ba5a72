"""A step run at risk (its bins kept for the parent's lag search over the windows) sends the
windows its worker made with them when they weigh little beside its samples (models/drive.py
`SEND_WINDOWS_SHARE`), and the search takes them (sums.py `windows_of`) instead of making
them again: the same arrays, the same model."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np

import wifibot_power.drive.model as drive_model
from wifibot_power.models.drive import FAMILY, drive_stats_of, drive_sums_of
from wifibot_power.phases import Phase, Segmentation
from wifibot_power.run import Run, RunMeta


def _step_run(period_s: float, speed_mps: float = 0.5, name: str = "r") -> tuple[Run, Segmentation]:
    """idle 1 s, accel 0.5 s, cruise 3 s, decel 0.5 s, idle 1 s, exact power from its speed."""
    bounds = np.round(np.cumsum([0, 1.0, 0.5, 3.0, 0.5, 1.0]) / period_s).astype(int)
    names, speeds = (
        ["idle", "accel", "cruise", "decel", "idle"],
        [None, None, speed_mps, None, None],
    )
    phases = tuple(
        Phase(1 if k else 0, n, int(bounds[k]), int(bounds[k + 1]), 0.0, 0.0, 0.0, 0.0, v)
        for k, (n, v) in enumerate(zip(names, speeds, strict=True))
    )
    meta = RunMeta(run_id=name, mode="motion", speed_mps=speed_mps, distance_m=1.75,
                   sample_period_s=period_s)  # fmt: skip
    segmentation = Segmentation(name, phases)
    from wifibot_power.drive.stats import speed_from_phases

    v = speed_from_phases(
        Run("x.csv", "wbpower-csv", meta, None, np.zeros(bounds[-1])), segmentation
    )
    power = 20.0 + 1.0 * (v > 0) + 10.0 * v + 6.0 * np.gradient(v * v, period_s)
    return Run(f"{name}.csv", "wbpower-csv", meta, None, power), segmentation


def _sent(period_s: float, name: str = "r"):
    """The run's drive statistics as the parent gets them from a worker (pickled)."""
    run, segmentation = _step_run(period_s, name=name)
    made = FAMILY.run_stats(run, segmentation).without_bins()
    return pickle.loads(pickle.dumps(made))


def test_a_fast_step_run_sends_its_windows_and_the_search_takes_them(monkeypatch):
    from wifibot_power.drive.sums import windows_of
    from wifibot_power.drive.windows import run_windows

    worker = _sent(1e-4)
    stats = drive_stats_of(worker)
    sent = stats.__dict__.get("_sent_windows")
    assert sent is not None and sent.stats is stats  # sent, with the bins they were made from
    again = run_windows(stats)
    for field in dataclasses.fields(again):
        if field.name != "stats":
            made, theirs = getattr(again, field.name), getattr(sent, field.name)
            assert np.array_equal(made, theirs), field.name
    assert windows_of(stats) is sent
    # the fit's search takes them: no windows made in the parent
    made_here = []
    monkeypatch.setattr(
        drive_model, "windows_of", lambda s, w: made_here.append(s) or windows_of(s, w)
    )
    monkeypatch.setattr(
        drive_model,
        "run_windows",
        lambda *a, **k: (_ for _ in ()).throw(AssertionError("windows made again")),
    )
    runs = [_sent(1e-4, f"r{k}") for k in range(3)]
    FAMILY.fit(runs)
    assert len(made_here) == 3
    # windows for another window length are made, not taken
    assert windows_of(stats, 1.0) is not sent


def test_a_slow_step_runs_windows_are_not_sent_and_the_model_is_the_same():
    """A 1 kHz run's windows weigh 1.7% of its samples: not sent (its record stays small);
    the model from sent windows is the model from windows made in the parent."""
    slow = _sent(1e-3)
    assert "_sent_windows" not in drive_stats_of(slow).__dict__
    fast = [_sent(1e-4, f"r{k}") for k in range(3)]
    bare = [pickle.loads(pickle.dumps(r)) for r in fast]
    for record in bare:
        drive_stats_of(record).__dict__.pop("_sent_windows")
    with_sent, without = FAMILY.fit(fast), FAMILY.fit(bare)
    assert with_sent.to_json() == without.to_json()
    assert drive_sums_of(fast[0]) is not None


def test_the_record_keeps_no_windows_in_process():
    """In one process (`--jobs 1`) the record is the worker's object: it kept the worker's
    windows and their bins-sized caches beside the bins (review, fourteenth session). After
    `without_bins` it holds none; the sent copy is of their fields only."""
    for period_s in (1e-4, 1e-3):
        run, segmentation = _step_run(period_s)
        made = FAMILY.run_stats(run, segmentation)
        kept = made.without_bins()
        assert made._windows is None and kept._windows is None
        sent = drive_stats_of(kept).__dict__.get("_sent_windows")
        if sent is not None:
            assert not {"_padded", "_power_sums", "_span_means"} & set(sent.__dict__)
