"""The drive model does not depend on the order its logs are given in (drive/model.py
`fit_drive_stats`: the runs taken in the order of their run ids, as the paper's folds are dealt,
diagnose/folds.py `assign_folds`). Before, `fit a.csv b.csv` and `fit b.csv a.csv` dealt the
held-out folds and the lag's bootstrap draws to other runs: the lag's interval and the held-out
energies moved with the order of the arguments."""

from __future__ import annotations

import json

import pytest

from wifibot_power.drive.model import MIN_RUN_CLUSTERS, fit_drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats


def _stats(runs_per_surface: int, seed: int) -> list:
    config = FreeDriveConfig(seed=seed, runs_per_surface=runs_per_surface, run_s=60.0)
    return [drive_stats(as_run(r)) for r in simulate_free(config)]


def _document(stats: list) -> str:
    return json.dumps(fit_drive_stats(stats).to_json(), sort_keys=True)


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
