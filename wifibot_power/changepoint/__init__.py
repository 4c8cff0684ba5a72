"""Generic change-point layer: steady levels and the jumps between them, on any power trace.

Everything here works on *block means* (the trace averaged over blocks of a few ms), so the
cost is linear in the number of samples and independent of the analyser's sample rate:

- `block_means`: the trace averaged over blocks of `block` samples.
- `robust_sigma_W`: the noise of a series from the median absolute first difference
  (a slow ripple or a few jumps do not move it); `median`, `percentile`: numpy's numbers
  without numpy's per-call overhead.
- `jump_statistic_W`: at every block boundary, the difference between straight lines fitted
  just after and just before it, both extrapolated to the boundary. A step of height h gives
  h; a straight trend or any symmetric curvature (a slow ripple near its crest) gives ~0.
- `best_split`: where one least-squares polynomial piece ends and the next begins inside a
  window (closed-form Gram matrices and prefix sums: every candidate split at once, in O(1)
  numpy operations each); the fine locator of every boundary. `best_splits`: the same for
  many windows at once (short ones stacked as rows of one array).
- `detect_levels`: steady levels of any trace (e.g. a load switching between levels):
  jumps above a noise threshold, then short start-up spikes (inrush, overshoot) merged into
  the level they start, then changes too small to matter merged.

References
----------
[1] C. Truong, L. Oudre, N. Vayatis, "Selective review of offline change point detection
    methods", Signal Processing 167 (2020): piecewise-polynomial costs, window methods.
[2] J. Bai, P. Perron, "Estimating and testing linear models with multiple structural
    changes", Econometrica 66 (1998): least-squares break location in segmented regression.

Modules, by job (every function and class is importable from here): `stats` (block means,
noise, median, percentile), `jumps` (jump statistic and its peaks), `splits` (`best_split`
and its least-squares cost), `stacked` (`best_splits`), `levels` (`detect_levels`). What
is kept between calls and its bounds (`splits._SHAPES`, `splits._SHAPES_MAX_SIZE`,
`stacked._STACKED_MAX`, ...) live in their module: set them there.
"""

from wifibot_power.changepoint.jumps import jump_sd_factor, jump_statistic_W, peaks, sliding_max
from wifibot_power.changepoint.levels import (
    LevelParams,
    Levels,
    LevelSpike,
    _find_spikes,
    _level,
    _merge_small,
    _merge_spikes,
    _refine_to_sample,
    detect_levels,
)
from wifibot_power.changepoint.splits import (
    Split,
    _centred_power_sum,
    _edge_values,
    _gram_inverse,
    _own_basis_rhs,
    _piece_shape,
    _piece_value,
    _PieceShape,
    _PolyCost,
    _solve,
    _window_positions,
    best_split,
)
from wifibot_power.changepoint.stacked import _stacked_splits, best_splits
from wifibot_power.changepoint.stats import (
    MAD_TO_SIGMA,
    _median_in_place,
    block_means,
    median,
    percentile,
    robust_sigma_W,
)

__all__ = [
    "MAD_TO_SIGMA",
    "LevelParams",
    "LevelSpike",
    "Levels",
    "Split",
    "best_split",
    "best_splits",
    "block_means",
    "detect_levels",
    "jump_sd_factor",
    "jump_statistic_W",
    "median",
    "peaks",
    "percentile",
    "robust_sigma_W",
    "sliding_max",
    # private, importable as before (tests): the splits' and levels' inner steps
    "_PieceShape",
    "_PolyCost",
    "_centred_power_sum",
    "_edge_values",
    "_find_spikes",
    "_gram_inverse",
    "_level",
    "_median_in_place",
    "_merge_small",
    "_merge_spikes",
    "_own_basis_rhs",
    "_piece_shape",
    "_piece_value",
    "_refine_to_sample",
    "_solve",
    "_stacked_splits",
    "_window_positions",
]
