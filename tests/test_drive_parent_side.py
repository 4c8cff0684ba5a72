"""The parent's side of a drive fit (parentfast lane) made faster to the same numbers: each
shortcut against the way it replaced, written out here, bit for bit (docs/benchmarks.md,
"The drive fit's parent side")."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wifibot_power.drive.gram import FoldGrams
from wifibot_power.drive.heldout import lag_grid_of
from wifibot_power.drive.lagsums import SumsTable
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats
from wifibot_power.drive.sums import sums_of
from wifibot_power.drive.windows import WINDOW_S


@pytest.fixture(scope="module")
def table() -> SumsTable:
    """Simulated free driving at field realism, two surfaces, as the parent's table."""
    config = FreeDriveConfig(runs_per_surface=4, run_s=200.0, seed=7)
    sums = [sums_of(drive_stats(as_run(run)), WINDOW_S) for run in simulate_free(config)]
    surfaces = tuple(sorted({name for m in sums for name in m.surfaces}))
    return SumsTable(sums, surfaces)


def _masked_fold_grams(self, fold_of_trip, folds, lags) -> FoldGrams:
    """`SumsTable.fold_grams` as first written: every fold's trips copied out by a mask."""
    P = len(self.columns)
    count = np.zeros(folds, dtype=np.int64)
    xx, xy = np.zeros((folds, P, P)), np.zeros((folds, P, self.lags))
    yy = np.zeros((folds, 2, self.lags))
    noise_of_trip = self.noise_share[self.run_of_trip] * np.diagonal(self.xx, axis1=1, axis2=2)
    noise = np.zeros((folds, P))
    for f in range(folds):
        rows = fold_of_trip == f
        count[f] = int(self.count[rows].sum())
        xx[f] = self.xx[rows].sum(axis=0)
        xy[f] = self.wy[:, rows, :P].sum(axis=1).T
        yy[f] = self.yy[rows].sum(axis=0)
        noise[f] = noise_of_trip[rows].sum(axis=0)
    return FoldGrams(count, xx, xy, yy, lags, noise)


def _same_grams(got: FoldGrams, want: FoldGrams) -> bool:
    names = ("count", "xx", "xy", "yy", "noise")
    return all(getattr(got, n).tobytes() == getattr(want, n).tobytes() for n in names)


def test_a_fold_of_every_trip_sums_in_place_as_over_the_masked_copy(table) -> None:
    """The whole batch's lag search (one fold of every trip) reads the table in place: the
    same sums, to the last bit, as over the masked copies; ten folds are as they were."""
    lags = lag_grid_of(table)
    T = table.trips
    assert T > 30 and len(table.surfaces) == 2
    whole = np.zeros(T, int)
    assert _same_grams(table.fold_grams(whole, 1, lags), _masked_fold_grams(table, whole, 1, lags))
    tenth = np.random.default_rng(3).permutation(T) % 10
    got, want = table.fold_grams(tenth, 10, lags), _masked_fold_grams(table, tenth, 10, lags)
    assert _same_grams(got, want)


def test_the_collector_is_held_off_while_a_document_is_built_and_set_back() -> None:
    """`gc_paused` (outputs.py) holds the cyclic collector off inside, and sets it back as it
    was after, on an exception too; the values it wraps are untouched."""
    import gc

    from wifibot_power.outputs import dumps_indented, gc_paused

    assert gc.isenabled()
    with gc_paused():
        assert not gc.isenabled()
    assert gc.isenabled()
    with pytest.raises(ValueError), gc_paused():
        raise ValueError
    assert gc.isenabled()
    gc.disable()
    try:
        with gc_paused():
            pass
        assert not gc.isenabled()  # left as it was: off
    finally:
        gc.enable()
    doc = {"a": [1.5, float("nan"), {"b": None}], "c": (1, "x")}
    assert dumps_indented(doc) == json.dumps(
        {"a": [1.5, None, {"b": None}], "c": [1, "x"]}, indent=2
    )
    assert gc.isenabled()
