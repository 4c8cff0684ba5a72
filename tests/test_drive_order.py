"""The drive model does not depend on the order its logs are given in (drive/model.py
`fit_drive_stats`: the runs taken in the order of their run ids, as the paper's folds are dealt,
diagnose/folds.py `assign_folds`). Before, `fit a.csv b.csv` and `fit b.csv a.csv` dealt the
held-out folds and the lag's bootstrap draws to other runs: the lag's interval and the held-out
energies moved with the order of the arguments."""

from __future__ import annotations

import dataclasses
import json

import pytest

from wifibot_power.drive.model import MIN_RUN_CLUSTERS, fit_drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats
from wifibot_power.drive.sums import sums_of


def _stats(runs_per_surface: int, seed: int) -> list:
    config = FreeDriveConfig(seed=seed, runs_per_surface=runs_per_surface, run_s=60.0)
    return [drive_stats(as_run(r)) for r in simulate_free(config)]


def _document(stats: list, **options) -> str:
    return json.dumps(fit_drive_stats(stats, **options).to_json(), sort_keys=True)


@pytest.mark.parametrize(
    ("runs_per_surface", "by_run"),
    [(6, True), (3, False)],  # 12 runs: clusters by run; 6 runs: by trip (MIN_RUN_CLUSTERS)
)
def test_drive_model_is_the_same_in_any_order_of_its_logs(runs_per_surface, by_run):
    stats = _stats(runs_per_surface, seed=3)
    assert (len(stats) >= MIN_RUN_CLUSTERS) == by_run
    given = _document(stats)
    reversed_ = _document(stats[::-1])
    shuffled = _document(stats[1::2] + stats[0::2])
    assert given == reversed_ == shuffled
    # what moved before: the lag's interval and the held-out energies are in the document
    model = json.loads(given)
    assert model["lag_ci95_s"] is not None and model["heldout"]["runs"]


def test_drive_model_over_the_windows_is_the_same_in_any_order():
    """`direct=True` (the fit over the windows, the sums' reference) sorts as the sums do."""
    stats = _stats(3, seed=4)
    assert _document(stats, direct=True) == _document(stats[::-1], direct=True)


def test_the_workers_sums_stay_with_their_runs_when_sorted():
    """`sums=` given beside the statistics (as the workers send them) move with their runs:
    the same model as the sums made here, in any order."""
    stats = _stats(3, seed=6)
    sums = [sums_of(s) for s in stats]
    given = _document(stats)
    order = [4, 1, 5, 0, 3, 2]
    shuffled = _document([stats[k] for k in order], sums=[sums[k] for k in order])
    assert given == shuffled
    # a sums list out of step with its runs is not what the fit reads: a different model
    swapped = _document(stats, sums=sums[1:] + sums[:1])
    assert swapped != given


def test_runs_of_one_run_id_are_ordered_by_file():
    """A library caller may give two runs one run id (a batch cannot: pipeline/duplicates.py):
    their files order them."""
    stats = _stats(3, seed=8)
    same = [dataclasses.replace(s, run_id="r") if k < 2 else s for k, s in enumerate(stats)]
    assert same[0].file != same[1].file
    swapped = [same[1], same[0], *same[2:]]
    assert _document(same) == _document(swapped)
