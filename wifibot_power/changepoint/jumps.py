"""Jumps between steady levels: the jump statistic, its noise, and its peaks.

Part of `wifibot_power.changepoint`: `jump_statistic_W` (straight lines fitted just after
and just before every block boundary, both extrapolated to it), `jump_sd_factor` (its sd
on white noise), `peaks` of it above a threshold (with `sliding_max`).
"""

from __future__ import annotations

import numpy as np


def jump_statistic_W(y: np.ndarray, half_width: int) -> np.ndarray:
    """Jump at each block boundary: right line minus left line, both at the boundary [W].

    `J[k]` is for the boundary just before block k (k = 0..n); NaN where a window of
    `half_width` blocks does not fit on both sides. Lines are least-squares fits over
    [k - w, k) and [k, k + w), evaluated at the boundary position k - 1/2.
    """
    y = np.asarray(y, dtype=np.float64)
    n = y.size
    w = int(half_width)
    out = np.full(n + 1, np.nan)
    if w < 2 or n < 2 * w:
        return out
    # centred on the mean (pairwise sum / n, 20x cheaper than the median that was here: a
    # jump is a difference of lines, the centre only keeps the prefix sums small)
    yc = y - np.add.reduce(y) / n
    j = np.arange(n, dtype=np.float64)
    s0 = np.empty(n + 1)
    s1 = np.empty(n + 1)
    s0[0] = s1[0] = 0.0
    yc.cumsum(out=s0[1:])  # methods, not np.cumsum: no Python-level wrapper per call
    np.multiply(j, yc, out=j)
    j.cumsum(out=s1[1:])
    count = n - 2 * w + 1  # boundaries k = w .. n - w
    s_xx = w * (w * w - 1) / 12.0
    # the line over [i, i + w) for every i = 0 .. n - w, once: the line before boundary k
    # starts at i = k - w, the one after it at i = k. Its sums by slices of the prefix
    # sums; its centre i + (w - 1) / 2 (half-integers: exact in doubles, whether summed or
    # counted by arange); its slope (sum_jy - centre sum_y) / S_xx; and its value at the
    # boundary from its centre, mean + slope (+-w/2): the line before the boundary ends
    # w/2 after its centre, the one after starts w/2 before its centre. Each number is
    # made by the same operations as when the two sides were fitted apart (slope (-w/2) is
    # -(slope w/2) in IEEE doubles, and a + (-b) is a - b), so the jumps are the same bit
    # for bit, in half the array operations
    lines = n - w + 1
    sum_y = s0[w : w + lines] - s0[:lines]
    slope = s1[w : w + lines] - s1[:lines]
    centre = np.arange((w - 1) / 2.0, (w - 1) / 2.0 + lines)
    np.multiply(centre, sum_y, out=centre)
    np.subtract(slope, centre, out=slope)
    slope /= s_xx
    sum_y /= w  # each line's mean
    slope *= w / 2.0  # each line's rise over half its width
    after = sum_y[w:] - slope[w:]  # a new array: the two sides overlap in sum_y
    before = sum_y[:count]
    before += slope[:count]
    np.subtract(after, before, out=out[w : n - w + 1])
    return out


def jump_sd_factor(half_width: int) -> float:
    """sd(J) / sigma for white noise of sd sigma per block (line fits over w blocks each).

    The variance of a line fitted to w points, evaluated half a point beyond its last one,
    is sigma^2 (1/w + (w/2)^2 / S_xx) with S_xx = w (w^2 - 1) / 12; J is the difference of two
    independent such values.
    """
    w = int(half_width)
    return float(np.sqrt(2.0 * (1.0 / w + 3.0 * w / (w * w - 1.0))))


def sliding_max(values: np.ndarray, size: int) -> np.ndarray:
    """Maximum over the centred window of odd `size` at every index, -inf beyond the ends
    (as scipy.ndimage.maximum_filter1d with mode="constant", cval=-inf), in O(n) by the
    van Herk / Gil-Werman method: per-block prefix and suffix maxima, vectorised. Written
    here because importing scipy.ndimage cost 0.2 s of every 'wbpower fit'."""
    n = values.size
    half = size // 2
    padded_n = -(-(n + size - 1) // size) * size
    padded = np.full(padded_n, -np.inf)
    padded[half : half + n] = values
    blocks = padded.reshape(-1, size)
    prefix = np.maximum.accumulate(blocks, axis=1).ravel()
    suffix = np.maximum.accumulate(blocks[:, ::-1], axis=1)[:, ::-1].ravel()
    # the window of index j covers padded[j : j + size]: a suffix of one block and a prefix
    # of the next (or one whole block)
    return np.maximum(suffix[:n], prefix[size - 1 : size - 1 + n])


def peaks(score: np.ndarray, threshold: float, separation: int) -> np.ndarray:
    """Indices of local maxima of `score` above `threshold`, at least `separation` apart
    (greedy from the largest)."""
    s = np.asarray(score, dtype=np.float64)
    size = 2 * max(1, int(separation)) + 1
    above = np.flatnonzero(s > threshold)  # NaN is never above
    if above.size * size <= s.size:
        # few above the threshold (the usual case): the window maximum of those alone, from
        # a gather of their windows (NaN and beyond the ends: -inf), not a sliding maximum
        # of every index; the same local maxima
        half = size // 2
        padded = np.full(s.size + 2 * half, -np.inf)
        padded[half : half + s.size] = s
        windows = padded[above[:, None] + np.arange(size)]
        candidates = above[s[above] == np.fmax.reduce(windows, axis=1)]
    else:
        s = np.nan_to_num(s, nan=-np.inf)
        local = (s == sliding_max(s, size)) & (s > threshold)
        candidates = np.flatnonzero(local)
    # (in index order) each is the maximum of its window, so two closer than `separation`
    # are equal: the greedy pass below drops one of a tie. Without two that close (as a
    # rule) it keeps every one
    if candidates.size < 2 or int((candidates[1:] - candidates[:-1]).min()) >= separation:
        return candidates.astype(np.int64)
    kept: list[int] = []
    for idx in candidates[(-s[candidates]).argsort(kind="stable")].tolist():
        for k in kept:
            if abs(idx - k) < separation:
                break
        else:
            kept.append(idx)
    return np.array(sorted(kept), dtype=np.int64)
