"""A fit's records without the drive model's bins (pipeline/record.py `RunPlan.bins`,
models/drive.py `WorkerStats.without_bins`, pipeline/gather.py `ReadAgain`): the same model
as from records that carry them, the bins read again from the logs when a lag search falls
back to the windows, and kept by a run that fits itself so well that it may."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import wifibot_power.drive.gram as gram
from wifibot_power.drive import drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free, write_free
from wifibot_power.drive.sums import AT_RISK_SHARE, own_share, sums_of
from wifibot_power.drive.traces import heldout_traces
from wifibot_power.errors import LogError
from wifibot_power.models.drive import FAMILY, WorkerStats, drive_stats_of
from wifibot_power.pipeline import FIT_PLAN, gather
from wifibot_power.pipeline.gather import ReadAgain

CONFIG = FreeDriveConfig(runs_per_surface=3, run_s=120.0, seed=12)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("free")
    write_free(CONFIG, folder)
    return folder


def _drive(records):
    return [r.models["drive"] for r in records]


def test_a_fit_without_bins_is_the_fit_with_them(logs) -> None:
    light = gather(logs, plan=FIT_PLAN).records
    full = gather(logs, plan=dataclasses.replace(FIT_PLAN, bins=True)).records
    assert all(s.bins_left_out for s in _drive(light))
    assert not any(s.bins_left_out for s in _drive(full))
    # what goes back from a worker: the sums and the bins' scalars, not the bins
    light_bytes = sum(len(pickle.dumps(s)) for s in _drive(light))
    assert light_bytes < 0.5 * sum(len(pickle.dumps(s)) for s in _drive(full))
    assert FAMILY.fit(light).summary() == FAMILY.fit(full).summary()
    assert all(s.bins_left_out for s in _drive(light))  # the fit did not need them


def test_a_search_over_the_windows_reads_the_bins_again(logs, monkeypatch) -> None:
    """Every lag search from sums refused (as if its sum of squares lost its digits): the fit
    searches over the windows, which reads every run's bins again, once for the batch; the
    model is that of records with their bins, under the same refusal."""
    monkeypatch.setattr(gram, "CANCELLATION", 1.0)
    full = gather(logs, plan=dataclasses.replace(FIT_PLAN, bins=True)).records
    light = gather(logs, plan=FIT_PLAN).records
    calls = []
    read = ReadAgain.__call__
    monkeypatch.setattr(ReadAgain, "__call__", lambda self: calls.append(1) or read(self))
    assert all(s.bins_left_out for s in _drive(light))
    assert FAMILY.fit(light).summary() == FAMILY.fit(full).summary()
    assert len(calls) == 1
    for again, made in zip(_drive(light), _drive(full), strict=True):
        assert not again.bins_left_out
        assert np.array_equal(again.stats.power_W, made.stats.power_W, equal_nan=True)
        assert np.array_equal(again.surface_index, made.surface_index)


def test_a_log_changed_before_its_bins_are_read_again(tmp_path) -> None:
    write_free(dataclasses.replace(CONFIG, runs_per_surface=1), tmp_path)
    light = gather(tmp_path, plan=FIT_PLAN).records
    first = _drive(light)[0]
    path = tmp_path / f"{first.run_id}.csv"
    lines = path.read_text().splitlines()
    time_s, power_W, *rest = lines[-1].split(",")
    lines[-1] = ",".join([time_s, f"{float(power_W) + 50.0:.3f}", *rest])
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError, match="changed"):
        first.stats  # noqa: B018 - reading the bins again is the test


def test_a_log_that_lost_its_speed_before_its_bins_are_read_again(tmp_path) -> None:
    """Read again, the log gives no drive statistics at all (its speed column removed): the
    same one-line error naming the file, not a traceback (it was `replace() should be called
    on dataclass instances`)."""
    write_free(dataclasses.replace(CONFIG, runs_per_surface=1), tmp_path)
    first = _drive(gather(tmp_path, plan=FIT_PLAN).records)[0]
    with pytest.raises(LogError, match="changed") as raised:
        first.bins_from(None)
    assert first.file in str(raised.value)


def test_a_run_that_fits_itself_keeps_its_bins() -> None:
    """A run whose power its own least squares leaves almost nothing of (a constant power:
    idle explains it) may make a batch's search fall back to the windows: its bins stay."""
    run = simulate_free(dataclasses.replace(CONFIG, runs_per_surface=1))[0]
    stats = drive_stats(as_run(run))
    noisy = WorkerStats(stats, sums_of(stats))
    assert own_share(noisy.sums) > 10 * AT_RISK_SHARE
    assert noisy.without_bins().bins_left_out
    exact = dataclasses.replace(stats, power_W=np.where(np.isnan(stats.power_W), np.nan, 12.0))
    kept = WorkerStats(exact, sums_of(exact))
    assert own_share(kept.sums) < AT_RISK_SHARE
    assert kept.without_bins() is kept
    # without a way to read them again, bins left out are an error, not an empty array
    light = noisy.without_bins()
    assert light.bin_s == stats.bin_s and light.surfaces == stats.surfaces
    with pytest.raises(RuntimeError, match="left out"):
        light.power_W  # noqa: B018


def test_the_held_out_traces_are_the_same_from_bins_read_again(logs) -> None:
    """The report's held-out power traces (drive/traces.py) drawn from records whose bins
    were left out (read again when the traces ask for them) are those drawn from records
    that carry them (what the report's plan keeps)."""
    light = gather(logs, plan=FIT_PLAN).records
    full = gather(logs, plan=dataclasses.replace(FIT_PLAN, bins=True)).records
    drawn = heldout_traces([drive_stats_of(r) for r in full])
    again = heldout_traces([drive_stats_of(r) for r in light])
    assert len(drawn) >= 2 and len(again) == len(drawn)
    for a, b in zip(again, drawn, strict=True):
        assert (a.run_id, a.surface) == (b.run_id, b.surface)
        for name in ("time_s", "measured_W", "predicted_W"):
            assert np.array_equal(getattr(a, name), getattr(b, name))
