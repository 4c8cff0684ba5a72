"""The jackknife's per-cluster sums (drive/lagsums.py `SumMoments._cluster_sums`) are the sums
the masked loop made, bit for bit: a change for speed must not move a covariance's last
digit (issue 24's answers byte for byte). Each cluster's edge windows are a stretch of rows;
`rows.T @ rows` on one buffer takes BLAS's symmetric product (syrk), which differs from the
general one (gemm) the two masked copies took in the last bits (this simulated set's
drive_on_W interval: 2.821669222741529 against 2.8216692227415283)."""

from __future__ import annotations

import json

import numpy as np

from wifibot_power.drive import lagsums
from wifibot_power.drive.model import fit_drive_stats
from wifibot_power.drive.simulate import FreeDriveConfig, as_run, simulate_free
from wifibot_power.drive.stats import drive_stats


def _masked_cluster_sums(self):
    """The cluster sums as first written: the trips' sums copied out by a mask, each
    cluster's edge windows found by a mask over all of them."""
    at, table = self.at, self.at.table
    cluster_of_trip = self._cluster_of_trip()
    has_rows = self.train & (at.count > 0)
    cluster = cluster_of_trip[has_rows]
    clusters, starts = np.unique(cluster, return_index=True)
    if not clusters.size:
        Q = 2 * self.P
        return np.zeros((0, Q, Q)), np.zeros((0, Q))
    ww = np.add.reduceat(table.ww[has_rows], starts, axis=0)
    wy = np.add.reduceat(at.wy[has_rows], starts, axis=0)
    edge_cluster = np.searchsorted(clusters, cluster_of_trip[at.edge_trip[self.edge]])
    W = np.hstack((at.edge_x[self.edge], at.edge_r[self.edge]))
    y = at.edge_y[self.edge]
    for g in np.unique(edge_cluster):
        rows = edge_cluster == g
        ww[g] += W[rows].T @ W[rows]
        wy[g] += W[rows].T @ y[rows]
    return ww, wy


def test_the_cluster_sums_are_the_masked_loops_bit_for_bit(monkeypatch):
    config = FreeDriveConfig(runs_per_surface=6, run_s=200.0, seed=5)
    stats = [drive_stats(as_run(run)) for run in simulate_free(config)]
    made = json.dumps(fit_drive_stats(stats).to_json(), default=str)
    monkeypatch.setattr(lagsums.SumMoments, "_cluster_sums", _masked_cluster_sums)
    assert json.dumps(fit_drive_stats(stats).to_json(), default=str) == made
