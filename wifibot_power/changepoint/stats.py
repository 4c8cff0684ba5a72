"""Robust numbers of a power trace: block means, noise sd, median and percentile.

Part of `wifibot_power.changepoint` (its docstring says how the pieces fit together):
`block_means`, the trace averaged over blocks; `robust_sigma_W`, its noise from the median
absolute first difference; `median`, `percentile`: numpy's numbers without numpy's per-call
overhead.
"""

from __future__ import annotations

import math

import numpy as np

#: 1.4826 * MAD estimates the standard deviation of normal noise.
MAD_TO_SIGMA = 1.4826


def block_means(values: np.ndarray, block: int) -> np.ndarray:
    """Means of consecutive blocks of `block` samples; a partial last block is dropped.

    Row sums by `numpy.einsum` (its own SIMD loop): ~4x faster than `.mean(axis=1)`, whose
    reduction over a short inner axis costs per row (equal to it within a few ulp). Not a
    matrix product: BLAS threads spin and steal the CPU from the rest of segmentation on a
    busy machine.
    """
    values = np.asarray(values, dtype=np.float64)
    block = max(1, int(block))
    n_blocks = values.size // block
    if block == 1:
        return values.copy()
    return np.einsum("ij->i", values[: n_blocks * block].reshape(n_blocks, block)) / block


def robust_sigma_W(y: np.ndarray) -> float:
    """Noise standard deviation of a series from its first differences [same unit as y].

    sigma = 1.4826 * median(|d - median(d)|) / sqrt(2), d = diff(y): white noise of sd sigma
    gives differences of sd sigma*sqrt(2); the median ignores the few jumps.
    """
    y = np.asarray(y, dtype=np.float64)
    if y.size < 3:
        return 0.0
    d = np.diff(y)
    centre = _median_in_place(d)
    np.subtract(d, centre, out=d)
    np.abs(d, out=d)
    return float(MAD_TO_SIGMA * _median_in_place(d) / np.sqrt(2.0))


def median(values: np.ndarray) -> float:
    """`numpy.median` of finite values, the same number, without its Python-level overhead
    (a copy partitioned in place): segmentation takes some 20 medians per run. NaN for
    no values, as numpy gives (without its warning)."""
    x = np.array(values, dtype=np.float64)
    return _median_in_place(x) if x.size else float("nan")


def percentile(values: np.ndarray, q: float) -> float:
    """`numpy.percentile(values, q)` of finite values (its default, linear interpolation),
    the same number, without its Python-level overhead (~0.15 ms a call): the two order
    statistics around the virtual index (m - 1) q / 100 by a partition of a copy, then
    numpy's `_lerp` (a + (b - a) g, or b - (b - a)(1 - g) from g = 0.5 on)."""
    x = np.array(values, dtype=np.float64)
    m = x.size
    if m == 0:
        return float("nan")
    virtual = (m - 1) * (q / 100)
    below = math.floor(virtual)
    if virtual >= m - 1:
        below = m - 1
    above = min(below + 1, m - 1)
    x.partition([below, above] if above != below else [below])
    a, b = float(x[below]), float(x[above])
    gamma = virtual - below
    diff = b - a
    return b - diff * (1 - gamma) if gamma >= 0.5 else a + diff * gamma


def _median_in_place(x: np.ndarray) -> float:
    """`numpy.median` of a 1-d float array that may be reordered (no copy): the same
    value (the middle one, or the mean of the two middle ones).

    A long array (the noise of a run's 1 ms blocks: ~10-100 k differences) is first
    narrowed to a band of values that must hold the middle ones: the band is read off a
    sample of 2,048 values (its order statistics ± 3 sqrt(2,048) ranks around the wanted
    ones, 6 sd of the rank of a population's order statistic among the sample, by a
    partition of the sample), the values below it counted, and only those inside it kept:
    exact, checked by the counts (else what is left is partitioned whole). A band still
    longer than `_NARROW_FROM` is narrowed again the same way (the wanted ranks then
    anywhere in it), and the last one is partitioned at the upper wanted rank only: the
    lower of two middle ones is then the largest value before it. From ~4 k values on a
    fraction of the time of a partition of everything (measured, 33 k block differences
    of `power10k`: 182 µs with one narrowing and a two-rank partition, 146 µs so)."""
    n = x.size
    k = n // 2
    ranks = [k] if n % 2 else [k - 1, k]
    while x.size > _NARROW_FROM:
        m = x.size
        sample = x[:: m // 2048]
        s = sample.size
        reach = int(3.0 * np.sqrt(s)) + 2
        # the sample ranks around the wanted ones (floor and ceiling of their share)
        edges = [max(ranks[0] * s // m - reach, 0), min(-(-ranks[-1] * s // m) + reach, s - 1)]
        sample = np.partition(sample, edges)
        low, high = sample[edges[0]], sample[edges[1]]
        keep = x >= low
        below = m - int(np.count_nonzero(keep))
        keep &= x <= high
        # compress, not a boolean index: the same values in the same order, 3x faster
        band = np.compress(keep, x)
        inside = [r - below for r in ranks]
        if inside[0] < 0 or inside[-1] >= band.size:
            break  # the sample missed: partition what is left
        x, ranks = band, inside
        if 2 * band.size > m:
            break  # ties (many values equal to the middle one): narrowing no longer pays
    top = ranks[-1]
    x.partition(top)
    # + 0.0: a zero median is +0 whichever zero the partition put in the middle (with -0.0
    # and +0.0 both there, numpy's choice depends on the order: a 0 W idle read "-0")
    if n % 2:
        return float(x[top]) + 0.0
    return float((x[:top].max() + x[top]) / 2.0) + 0.0


#: arrays longer than this are narrowed before the median's partition (`_median_in_place`;
#: below ~4 k values the narrowing costs what it saves)
_NARROW_FROM = 4096
