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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

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


@dataclass(frozen=True)
class Split:
    """Result of `best_split`: the first index of the right piece, and the costs.

    `left_coef` / `right_coef` are each piece's polynomial in its own basis (x from -1/2 at
    the piece's start to +1/2 at its end, around the window mean; `_PolyCost`)."""

    index: int
    sse: float
    left_end_W: float
    right_start_W: float
    left_coef: tuple[float, ...] = ()
    right_coef: tuple[float, ...] = ()

    @property
    def jump_W(self) -> float:
        """Right piece minus left piece, both at the split."""
        return self.right_start_W - self.left_end_W


def _centred_power_sum(r: int, length: np.ndarray) -> np.ndarray:
    """sum over m = 0..L-1 of (m - (L-1)/2)^r, closed form (moments of the discrete uniform).

    Odd r: 0 (symmetric); r = 0: L; r = 2: L(L²-1)/12; r = 4: L(L²-1)(3L²-7)/240;
    r = 6: L(L²-1)(3L⁴-18L²+31)/1344.
    """
    L = np.asarray(length, dtype=np.float64)
    L2 = L * L
    if r % 2:
        return np.zeros_like(L)
    if r == 0:
        return L
    if r == 2:
        return L * (L2 - 1.0) / 12.0
    if r == 4:
        return L * (L2 - 1.0) * (3.0 * L2 - 7.0) / 240.0
    if r == 6:
        return L * (L2 - 1.0) * (3.0 * L2 * L2 - 18.0 * L2 + 31.0) / 1344.0
    raise ValueError(f"centred power sums are tabulated up to r = 6, not {r}")


#: nonzero entries of G(L)⁻¹ per polynomial degree, each indexed by piece length L
_GRAM_INVERSE: dict[int, dict[tuple[int, int], np.ndarray]] = {}


def _own_basis_rhs(
    sums: list[np.ndarray],
    shift_pow: list[np.ndarray],
    terms: dict[tuple[int, int], np.ndarray],
    ratio_pow: list[np.ndarray],
) -> list[np.ndarray]:
    """The right-hand side of each piece's normal equations in its own x = (u - u_c)·scale/L,
    from the prefix sums Σ u^q y of the piece (`sums`, q = 0..deg): b_p = (scale/L)^p
    Σ_q C(p, q) (-u_c)^(p-q) Σ u^q y (binomial expansion). `shift_pow[p]` is (-u_c)^p,
    `terms[p, q]` is C(p, q) (-u_c)^(p-q) and `ratio_pow[p]` is (scale/L)^p per piece
    (`_PieceShape`: they depend on the window's shape alone)."""
    m = len(sums)
    rhs = [sums[0]]
    for p in range(1, m):
        acc = shift_pow[p] * sums[0]  # q = 0: C(p, 0) = 1
        for q in range(1, p):
            acc += terms[p, q] * sums[q]
        rhs.append((sums[p] + acc) * ratio_pow[p])
    return rhs


class _PieceShape:
    """What `_PolyCost.fit_splits` needs that depends on the window's length, the range of
    splits and the degree alone, not on the data: the pieces' (-u_c)^p, C(p, q)
    (-u_c)^(p-q), (scale/L)^p and their rows of G⁻¹ (contiguous). Segmentation asks for a
    few dozen shapes over and over (windows of fixed widths: ~60 distinct among ~640
    `best_split` calls on 27 runs), so each is made once (`_piece_shape`); the arrays are
    the very numbers `fit_splits` computed each time (the same operations, in the same
    order), so every result is bit for bit the same."""

    def __init__(self, n: int, start: int, stop: int, deg: int, left: bool) -> None:
        m = deg + 1
        scale = float(max(n, 1))
        self.shift_pow: list[np.ndarray] = []
        self.ratio_pow: list[np.ndarray] = []
        self.terms: dict[tuple[int, int], np.ndarray] = {}
        if m > 1:
            s = np.arange(start, stop, dtype=np.int64)
            length = s if left else n - s
            # -u_c = (n - i - j) / 2 / scale, the piece's centre; i + j is s (left) or s + n
            shift = (((n - s) if left else (-s)) * 0.5) / scale
            ratio = scale / length
            self.shift_pow = [None, shift]  # type: ignore[list-item]
            self.ratio_pow = [None, ratio]  # type: ignore[list-item]
            for _ in range(2, m):
                self.shift_pow.append(self.shift_pow[-1] * shift)
                self.ratio_pow.append(self.ratio_pow[-1] * ratio)
            for p in range(1, m):
                for q in range(1, p):
                    self.terms[p, q] = math.comb(p, q) * self.shift_pow[p - q]
        # the lengths run start..stop-1 (left) or n-start down to n-stop+1 (right)
        lo_len, hi_len = (start, stop) if left else (n - stop + 1, n - start + 1)
        table = _gram_inverse(deg, hi_len)
        self.inverse_rows = {
            key: np.ascontiguousarray(row[lo_len:hi_len] if left else row[lo_len:hi_len][::-1])
            for key, row in table.items()
        }
        kept = [*self.shift_pow[1:], *self.ratio_pow[1:], *self.terms.values()]
        kept += self.inverse_rows.values()
        for array in kept:  # shared by every later call: never to be changed in place
            array.setflags(write=False)
        self.size = sum(a.size for a in kept)


#: shapes made so far, and how many numbers they hold (kept under `_SHAPES_MAX_SIZE`)
_SHAPES: dict[tuple[int, int, int, int, bool], _PieceShape] = {}
_SHAPES_SIZE = [0]
#: 1 M numbers (8 MB): the shapes of a run's segmentation, several times over
_SHAPES_MAX_SIZE = 1_000_000


def _window_positions(n: int) -> np.ndarray:
    """u: the positions 0..n-1 of a window of n, centred and scaled to [-1/2, 1/2] (made
    once per window length, as `_piece_shape`)."""
    u = _POSITIONS.get(n)
    if u is None:
        u = (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) / float(max(n, 1))
        if n <= _KEPT_POSITIONS_MAX:  # at most 64 x 8192 numbers (4 MB)
            if len(_POSITIONS) >= 64:
                _POSITIONS.clear()
            u.setflags(write=False)
            _POSITIONS[n] = u
    return u


_POSITIONS: dict[int, np.ndarray] = {}
_KEPT_POSITIONS_MAX = 8192


def _piece_shape(n: int, start: int, stop: int, deg: int, left: bool) -> _PieceShape:
    key = (n, start, stop, deg, left)
    shape = _SHAPES.get(key)
    if shape is None:
        shape = _PieceShape(n, start, stop, deg, left)
        if shape.size > _SHAPES_MAX_SIZE // 8:  # a window as long as a whole run: not kept
            return shape
        if _SHAPES_SIZE[0] + shape.size > _SHAPES_MAX_SIZE:
            _SHAPES.clear()
            _SHAPES_SIZE[0] = 0
        _SHAPES[key] = shape
        _SHAPES_SIZE[0] += shape.size
    return shape


def _solve(
    rhs: list[np.ndarray], inverse: dict[tuple[int, int], np.ndarray]
) -> tuple[list[np.ndarray], np.ndarray]:
    """Coefficients c = G⁻¹ b of each piece (`inverse[p, q]`: the (p, q) entry of G⁻¹ for
    every piece; zero where p + q is odd, so skipped) and the explained sum of squares
    c · b (the SSE is Σ y² minus it). Degrees 0 and 1 written out (most splits): the same
    operations in the same order as the loops."""
    m = len(rhs)
    if m == 1:
        c_0 = inverse[0, 0] * rhs[0]
        return [c_0], c_0 * rhs[0]
    if m == 2:
        c_0 = inverse[0, 0] * rhs[0]
        c_1 = inverse[1, 1] * rhs[1]
        return [c_0, c_1], c_0 * rhs[0] + c_1 * rhs[1]
    coef = []
    for p in range(m):
        c_p = inverse[p, p % 2] * rhs[p % 2]
        for q in range(p % 2 + 2, m, 2):
            c_p = c_p + inverse[p, q] * rhs[q]
        coef.append(c_p)
    explained = coef[0] * rhs[0]
    for p in range(1, m):
        explained = explained + coef[p] * rhs[p]
    return coef, explained


def _gram_inverse(deg: int, max_len: int) -> dict[tuple[int, int], np.ndarray]:
    """Entries (p, q) of G(L)⁻¹ for every piece length L = 0..(at least) max_len.

    G(L)_pq = sum over the piece of x^(p+q), x = (k - c) / L, which is
    `_centred_power_sum(p + q, L) / L^(p+q)`: zero for odd p + q, and so is (G⁻¹)_pq. In
    this basis G is well conditioned (x in [-1/2, 1/2]; cond < 1e4 up to degree 3), so its
    inverse is tabulated once per degree and looked up by length. Only the nonzero entries
    (p + q even) are kept. Rows L <= deg (fewer points than coefficients) are NaN:
    `best_split` never asks for them.
    """
    table = _GRAM_INVERSE.get(deg)
    if table is not None and table[0, 0].size > max_len:
        return table
    size = max(2 * int(max_len) + 1, 4096)
    m = deg + 1
    length = np.arange(size, dtype=np.float64)
    valid = length > deg
    L = length[valid]
    gram = np.empty((L.size, m, m))
    for p in range(m):
        for q in range(m):
            gram[:, p, q] = _centred_power_sum(p + q, L) / L ** (p + q)
    inverse = np.full((size, m, m), np.nan)
    inverse[valid] = np.linalg.inv(gram)
    table = {
        (p, q): np.ascontiguousarray(inverse[:, p, q])
        for p in range(m)
        for q in range(m)
        if (p + q) % 2 == 0
    }
    _GRAM_INVERSE[deg] = table
    return table


class _PolyCost:
    """Least-squares cost of polynomial pieces over [i, j) of a window, each in O(1).

    Each piece [i, j) is fitted in its own basis x = (k - c) / L, c = (i + j - 1) / 2 its
    centre and L = j - i its length, so x lies in [-1/2, 1/2]. Positions are integers, so
    the Gram matrix G_pq = sum x^(p+q) depends on L alone, in closed form
    (`_centred_power_sum`), and its inverse is looked up by L (`_gram_inverse`): no prefix
    sums of x^p, no cancellation in G, no per-candidate solve. Coefficients c = G⁻¹b and
    SSE = sum y² - bᵀG⁻¹b (ordinary least squares), for every candidate at once in a fixed
    number of numpy operations (powers by multiplication: `**` on arrays is slow). The
    right-hand sides b_p = sum x^p y come from prefix sums of u^q y (u: the position
    centred on the window, scaled to [-1/2, 1/2]) by the binomial expansion of
    (u - u_c)^p. y is centred on its window mean. Degrees up to 3.
    """

    def __init__(self, y: np.ndarray, max_deg: int) -> None:
        if max_deg > 3:
            raise ValueError(f"polynomial pieces up to degree 3, not {max_deg}")
        n = y.size
        self.n = n
        # np.mean's number (pairwise sum / count) without its Python-level overhead
        self.offset = float(np.add.reduce(y) / n) if n else 0.0
        self.scale = float(max(n, 1))
        u = _window_positions(n)
        terms = np.empty((max_deg + 2, n + 1))
        terms[:, 0] = 0.0  # the prefix sums start at 0
        yc = terms[0, 1:]
        np.subtract(y, self.offset, out=yc)
        for q in range(1, max_deg + 1):
            np.multiply(terms[q - 1, 1:], u, out=terms[q, 1:])
        np.multiply(yc, yc, out=terms[-1, 1:])
        terms.cumsum(axis=1, out=terms)
        # rows: prefix sums of u^q y (q = 0..max_deg), then of y^2 (one array, no views)
        self.terms = terms

    def fit_splits(
        self, start: int, stop: int, deg: int, left: bool
    ) -> tuple[np.ndarray, list[np.ndarray]]:
        """The degree-`deg` fit (in each piece's own x) of every piece [0, s) (`left`) or
        [s, n) (right) for s = start..stop-1, by slices of the prefix sums and of the G⁻¹
        table (no index arrays, no stacked coefficients: `best_split` calls this twice per
        window, most of its cost). Returns the SSE and the coefficients as one array per
        power."""
        n = self.n
        terms = self.terms
        if left:
            # sums over [0, s): prefix[s] - prefix[0], and prefix[0] is 0
            sums = [terms[q, start:stop] for q in range(deg + 1)]
            y2 = terms[-1, start:stop]
        else:
            sums = [terms[q, n] - terms[q, start:stop] for q in range(deg + 1)]
            y2 = terms[-1, n] - terms[-1, start:stop]
        shape = _SHAPES.get((n, start, stop, deg, left)) or _piece_shape(n, start, stop, deg, left)
        rhs = _own_basis_rhs(sums, shape.shift_pow, shape.terms, shape.ratio_pow) if deg else sums
        coef, explained = _solve(rhs, shape.inverse_rows)
        sse = y2 - explained
        return np.maximum(sse, 0.0, out=sse), coef

    def value(self, coef: np.ndarray | list[float], x: float) -> float:
        """The piece at x (its own basis: -1/2 at its first sample's start edge, +1/2 at its
        last one's end edge) [W]."""
        return _piece_value(coef, x, self.offset)


def _piece_value(coef: np.ndarray | list[float], x: float, offset: float) -> float:
    """A piece's polynomial `coef` at x (its own basis), plus its window's mean [W]."""
    total = 0  # as sum(): 0 + the first term + the next ..., left to right
    for p, c in enumerate(coef):
        total = total + c * x**p
    return float(total + offset)


def _edge_values(
    coef_left: list[np.ndarray], coef_right: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Each candidate's pieces at the split: the left piece at its x = +1/2, the right one
    at its x = -1/2 (each in its own basis, `_PolyCost`), coefficients by power."""
    left_end = coef_left[0]
    for p in range(1, len(coef_left)):
        left_end = left_end + coef_left[p] * 0.5**p
    right_start = coef_right[0]
    for p in range(1, len(coef_right)):
        right_start = right_start + coef_right[p] * (-0.5) ** p
    return left_end, right_start


def best_split(
    y: np.ndarray,
    lo: int,
    hi: int,
    deg_left: int,
    deg_right: int,
    min_len: int = 5,
    jump_sign: int = 0,
) -> Split | None:
    """Least-squares split of y[lo:hi] into a degree-`deg_left` then a degree-`deg_right`
    polynomial piece (a segmented regression with one break, [2]).

    `jump_sign` = +1 (-1) keeps only splits where the right piece starts above (below) where
    the left piece ends, when the physics says which way the power jumps.
    Returns the first index of the right piece (in y's indices), or None when the window is
    too short for two pieces of `min_len` points.
    """
    lo = max(0, int(lo))
    hi = min(int(hi), np.asarray(y).size)
    min_len = max(int(min_len), deg_left + 2, deg_right + 2)
    if hi - lo < 2 * min_len:
        return None
    window = np.asarray(y[lo:hi], dtype=np.float64)
    cost = _PolyCost(window, max(deg_left, deg_right))
    n = window.size
    # every split s = min_len .. n - min_len: left piece [0, s), right piece [s, n)
    start, stop = min_len, n - min_len + 1
    sse_left, coef_left = cost.fit_splits(start, stop, deg_left, left=True)
    sse_right, coef_right = cost.fit_splits(start, stop, deg_right, left=False)
    total = sse_left + sse_right
    if jump_sign:
        left_end, right_start = _edge_values(coef_left, coef_right)
        # (right - left) * sign >= 0, without the two array operations: the sign of a
        # difference of doubles is that of their comparison (gradual underflow)
        allowed = right_start >= left_end if jump_sign > 0 else right_start <= left_end
        if allowed.any():
            total = np.where(allowed, total, np.inf)
    best = int(total.argmin())
    # Python floats: the same doubles, and the same float operations in `_piece_value`
    left_best = tuple([c.item(best) for c in coef_left])
    right_best = tuple([c.item(best) for c in coef_right])
    return Split(
        index=lo + start + best,
        sse=total.item(best),
        left_end_W=_piece_value(left_best, 0.5, cost.offset),
        right_start_W=_piece_value(right_best, -0.5, cost.offset),
        left_coef=left_best,
        right_coef=right_best,
    )


def best_splits(
    y: np.ndarray,
    windows: Sequence[tuple[int, int] | tuple[int, int, int]],
    deg_left: int,
    deg_right: int,
    min_len: int = 5,
    jump_sign: int = 0,
) -> list[Split | None]:
    """`best_split` of each window (lo, hi) of y, or (lo, hi, min_len) with a minimum piece
    length of its own, all in one pass: the same `Split`s, bit for bit.

    Segmentation asks for one split per step and stage of a run (ten steps: ten windows of
    the same kind), and a `best_split` costs some 60 numpy operations whatever its window's
    length (~100 µs on a few hundred blocks): here the windows are stacked as rows (padded
    to the longest, the padding masked) and each operation runs once for all of them. Every
    number is made by the same elementwise operations, in the same order, as in
    `best_split` (each window's mean by its own pairwise sum, its prefix sums sequential
    along its row, its pieces' bases and G⁻¹ from the same integers), so every split, SSE
    and coefficient is the one `best_split` gives (tests/test_segment.py checks it).
    Only windows of up to `_STACKED_MAX` blocks are stacked, at most `_STACK_SIZE` numbers
    a stack: longer ones, or more of them, make 2-D operations that cost more per number
    than the per-call overhead they save (ten windows of 2,000 blocks: 2.3-3.1 ms stacked
    against 1.1-1.6 ms one by one), so they are split one by one.
    """
    y = np.asarray(y, dtype=np.float64)
    out: list[Split | None] = [None] * len(windows)
    rows: list[tuple[int, int, int, int]] = []  # (window, lo, length, min_len)
    for k, window in enumerate(windows):
        lo, hi = max(0, int(window[0])), min(int(window[1]), y.size)
        own = int(window[2]) if len(window) > 2 else int(min_len)
        least = max(own, deg_left + 2, deg_right + 2)
        if hi - lo >= 2 * least:
            rows.append((k, lo, hi - lo, least))
    # stacks of windows of similar lengths (shortest first), each of at most `_STACK_SIZE`
    # numbers (windows x the longest of them)
    rows.sort(key=lambda r: r[2])
    stacks: list[list[tuple[int, int, int, int]]] = []
    for row in rows:
        if stacks and row[2] <= _STACKED_MAX and (len(stacks[-1]) + 1) * row[2] <= _STACK_SIZE:
            stacks[-1].append(row)
        else:
            stacks.append([row])
    for stack in stacks:
        if len(stack) == 1:  # one window: slices, not gathers
            k, lo, n, least = stack[0]
            out[k] = best_split(y, lo, lo + n, deg_left, deg_right, least, jump_sign)
        else:
            found = _stacked_splits(y, stack, deg_left, deg_right, jump_sign)
            for (k, *_), split in zip(stack, found, strict=True):
                out[k] = split
    return out


def _stacked_splits(
    y: np.ndarray,
    rows: list[tuple[int, int, int, int]],
    deg_left: int,
    deg_right: int,
    jump_sign: int,
) -> list[Split]:
    """`best_splits` of windows (index, lo, length, min_len), stacked as the rows of padded
    arrays."""
    max_deg = max(deg_left, deg_right)
    if max_deg > 3:
        raise ValueError(f"polynomial pieces up to degree 3, not {max_deg}")
    count = len(rows)
    lows = np.array([r[1] for r in rows], dtype=np.int64)
    sizes = np.array([r[2] for r in rows], dtype=np.int64)
    leasts = np.array([r[3] for r in rows], dtype=np.int64)
    longest = int(sizes.max())
    # each window's mean as `_PolyCost` takes it: its own pairwise sum over its own count
    offsets = np.array([float(np.add.reduce(y[lo : lo + n]) / n) for _, lo, n, _ in rows])
    column = np.arange(longest + 1)
    inside = column[None, 1:] <= sizes[:, None]
    gathered = y[np.minimum(lows[:, None] + column[None, :-1], y.size - 1)]
    # u of each window (`_window_positions`), and the prefix sums of u^q y and y^2 per row;
    # a split s's left piece sums prefix[s], and every s = 0..longest is a column (the
    # splits a window does not allow are masked at the end): whole rows, no strided views
    scale = sizes.astype(np.float64)[:, None]
    position = column[:-1].astype(np.float64)
    u = (position[None, :] - ((sizes - 1) / 2.0)[:, None]) / scale
    terms = np.empty((max_deg + 2, count, longest + 1))
    terms[:, :, 0] = 0.0
    yc = terms[0, :, 1:]
    np.subtract(gathered, offsets[:, None], out=yc)
    yc[~inside] = 0.0  # past a window's end: nothing added to its sums
    for q in range(1, max_deg + 1):
        np.multiply(terms[q - 1, :, 1:], u, out=terms[q, :, 1:])
    np.multiply(yc, yc, out=terms[-1, :, 1:])
    terms.cumsum(axis=2, out=terms)
    totals = terms[:, np.arange(count), sizes][:, :, None]  # over each whole window
    valid = (column[None, :] >= leasts[:, None]) & (column[None, :] <= (sizes - leasts)[:, None])

    def fit(deg: int, left: bool) -> tuple[np.ndarray, list[np.ndarray]]:
        # `_PolyCost.fit_splits` and `_PieceShape` on every row at once; masked splits get
        # a piece length the G⁻¹ table holds (valid ones are >= deg + 2)
        m = deg + 1
        if left:
            sums = [terms[q] for q in range(m)]
            y2 = terms[-1]
            length = np.maximum(column, deg + 1)[None, :]
        else:
            sums = [totals[q] - terms[q] for q in range(m)]
            y2 = totals[-1] - terms[-1]
            length = np.maximum(sizes[:, None] - column[None, :], deg + 1)
        shift_pow: list[np.ndarray] = []
        ratio_pow: list[np.ndarray] = []
        pair_terms: dict[tuple[int, int], np.ndarray] = {}
        if m > 1:
            shift = (((sizes[:, None] - column) if left else (-column[None, :])) * 0.5) / scale
            ratio = scale / length
            shift_pow, ratio_pow = [None, shift], [None, ratio]  # type: ignore[list-item]
            for _ in range(2, m):
                shift_pow.append(shift_pow[-1] * shift)
                ratio_pow.append(ratio_pow[-1] * ratio)
            for p in range(1, m):
                for q in range(1, p):
                    pair_terms[p, q] = math.comb(p, q) * shift_pow[p - q]
        table = _gram_inverse(deg, longest)  # no piece is longer than the longest window
        rhs = _own_basis_rhs(sums, shift_pow, pair_terms, ratio_pow)
        coef, explained = _solve(rhs, {key: row[length] for key, row in table.items()})
        return np.maximum(y2 - explained, 0.0), coef

    sse_left, coef_left = fit(deg_left, left=True)
    sse_right, coef_right = fit(deg_right, left=False)
    total = sse_left + sse_right
    total[~valid] = np.inf
    if jump_sign:
        left_end, right_start = _edge_values(coef_left, coef_right)
        allowed = (right_start >= left_end if jump_sign > 0 else right_start <= left_end) & valid
        # `best_split`: the sign is kept only in a window where some split has it
        allowed |= ~allowed.any(axis=1)[:, None]
        total[~allowed] = np.inf
    # each window's best split and its pieces, as Python floats (the same doubles: the
    # pieces' values by the same float operations as `best_split`'s on numpy scalars)
    row, best = np.arange(count), total.argmin(axis=1)
    lefts = list(zip(*(c[row, best].tolist() for c in coef_left), strict=True))
    rights = list(zip(*(c[row, best].tolist() for c in coef_right), strict=True))
    return [
        Split(
            index=lo + b,
            sse=sse,
            left_end_W=_piece_value(left, 0.5, offset),
            right_start_W=_piece_value(right, -0.5, offset),
            left_coef=left,
            right_coef=right,
        )
        for (_, lo, _, _), b, sse, left, right, offset in zip(
            rows,
            best.tolist(),
            total[row, best].tolist(),
            lefts,
            rights,
            offsets.tolist(),
            strict=True,
        )
    ]


#: how many numbers (windows x longest window) one stack of `best_splits` holds, and the
#: longest window stacked (longer ones cost more stacked than one by one: measured)
_STACK_SIZE = 8000
_STACKED_MAX = 700


@dataclass(frozen=True)
class LevelSpike:
    """A short start-up excursion at the start of a level, in samples."""

    i_start: int
    i_end: int
    peak_W: float
    energy_above_level_J: float


@dataclass(frozen=True)
class Levels:
    """Steady levels of a trace: `bounds` are sample indices (0, ..., n), one more than levels."""

    bounds: tuple[int, ...]
    levels_W: tuple[float, ...]
    spikes: tuple[LevelSpike, ...]
    block: int
    noise_W: float
    min_step_W: float


@dataclass(frozen=True)
class LevelParams:
    """Parameters of `detect_levels` (docs/segmentation.md)."""

    #: block length [s] of the block means everything works on
    block_s: float = 0.005
    #: each line of the jump statistic is fitted over this long [s]
    half_width_s: float = 0.05
    #: a jump must exceed z times its noise sd
    z: float = 6.0
    #: smallest change between levels that counts [W]; None: 2% of the trace's 1-99% range
    min_step_W: float | None = None
    #: longest start-up spike [s]; a level must last longer than this
    spike_max_s: float = 0.3


def detect_levels(
    power_W: np.ndarray, sample_period_s: float, params: LevelParams | None = None
) -> Levels:
    """Steady levels of a power trace and the sample indices of the changes between them.

    1. block means over `block_s`; noise sd from `robust_sigma_W`;
    2. candidate changes: peaks of |J| (`jump_statistic_W`) above max(z sd(J), min_step_W);
       each is put on the sample where a two-mean split of the +-1 block around it is best;
    3. a level shorter than `spike_max_s` that overshoots the level after it (in the
       direction of the change that started it) is a start-up spike: merged into that level;
    4. neighbouring levels closer than `min_step_W` are merged.
    """
    params = params or LevelParams()
    power_W = np.asarray(power_W, dtype=np.float64)
    n = power_W.size
    block = max(1, round(params.block_s / sample_period_s))
    y = block_means(power_W, block)
    w = max(2, round(params.half_width_s / (block * sample_period_s)))
    sigma = robust_sigma_W(y)
    if params.min_step_W is not None:
        min_step = float(params.min_step_W)
    elif y.size:
        # numpy's percentiles, the same numbers, without its overhead (~3 ms on an idle run)
        lo_W, hi_W = percentile(y, 1), percentile(y, 99)
        min_step = 0.02 * float(hi_W - lo_W)
    else:
        min_step = 0.0
    bounds = [0]
    if y.size >= 2 * w + 1:
        jump = jump_statistic_W(y, w)
        threshold = max(params.z * jump_sd_factor(w) * sigma, min_step, 1e-12)
        for k in peaks(np.abs(jump), threshold, w):
            bounds.append(_refine_to_sample(power_W, int(k) * block, block))
    bounds.append(n)
    bounds = sorted(set(b for b in bounds if 0 <= b <= n))
    spike_max = max(1, round(params.spike_max_s / sample_period_s))
    bounds = _merge_spikes(power_W, bounds, spike_max)
    bounds = _merge_small(power_W, bounds, min_step)
    levels = tuple(_level(power_W, a, b) for a, b in pairwise(bounds))
    spikes = _find_spikes(
        power_W, sample_period_s, bounds, levels, block, spike_max, sigma, params.z
    )
    return Levels(tuple(bounds), levels, spikes, block, sigma, min_step)


def _refine_to_sample(power_W: np.ndarray, i_guess: int, block: int) -> int:
    """The sample where a two-mean split of [i_guess - block, i_guess + block) is best."""
    lo = max(0, i_guess - block)
    hi = min(power_W.size, i_guess + block)
    if hi - lo < 2:
        return i_guess
    seg = power_W[lo:hi] - power_W[lo:hi].mean()
    c = np.cumsum(seg)
    m = seg.size
    k = np.arange(1, m)
    # between-class sum of squares of a split at k (maximal where SSE is minimal)
    score = c[k - 1] ** 2 / k + c[k - 1] ** 2 / (m - k)
    return lo + int(k[np.argmax(score)])


def _level(power_W: np.ndarray, a: int, b: int) -> float:
    """The median of the samples [a, b): `numpy.median`'s number (`median`, narrowed first:
    a level of a whole idle run is some 10^5-10^6 samples)."""
    return median(power_W[a:b])


def _merge_spikes(power_W: np.ndarray, bounds: list[int], spike_max: int) -> list[int]:
    """Merge a short segment that overshoots the segment after it into that segment."""
    changed = True
    while changed and len(bounds) > 3:
        changed = False
        for s in range(1, len(bounds) - 2):  # segment s = [bounds[s], bounds[s+1]), not the first
            a, b, c = bounds[s], bounds[s + 1], bounds[s + 2]
            if b - a >= spike_max:
                continue
            before = _level(power_W, bounds[s - 1], a)
            here = float(np.mean(power_W[a:b]))
            after = _level(power_W, b, c)
            rise = after - before
            overshoot = here - after
            if rise != 0 and np.sign(overshoot) == np.sign(rise):
                # a spike that settles to a new level belongs to that level
                del bounds[s + 1]
                changed = True
                break
            if abs(after - before) < abs(here - before) * 0.25 and c - a < spike_max:
                # a short excursion that returns (a glitch): one level with its neighbours
                del bounds[s + 1]
                changed = True
                break
    return bounds


def _merge_small(power_W: np.ndarray, bounds: list[int], min_step: float) -> list[int]:
    """Merge neighbouring levels closer than `min_step`, the closest pair first."""
    while len(bounds) > 2:
        levels = [_level(power_W, a, b) for a, b in pairwise(bounds)]
        diffs = np.abs(np.diff(levels))
        k = int(np.argmin(diffs))
        if diffs[k] >= min_step:
            break
        del bounds[k + 1]
    return bounds


def _find_spikes(
    power_W: np.ndarray,
    sample_period_s: float,
    bounds: list[int],
    levels: tuple[float, ...],
    block: int,
    spike_max: int,
    sigma_W: float,
    z: float,
) -> tuple[LevelSpike, ...]:
    """The leading run of blocks of each level (after the first) that stands out from it."""
    spikes = []
    for s in range(1, len(levels)):
        a, b = bounds[s], bounds[s + 1]
        step_W = levels[s] - levels[s - 1]
        stop = min(b, a + spike_max)
        head = block_means(power_W[a:stop], block)
        if head.size == 0 or step_W == 0:
            continue
        # excursions beyond the level in the direction of the step (overshoot)
        excess = (head - levels[s]) * np.sign(step_W)
        threshold = max(z * sigma_W, 0.05 * abs(step_W))
        out = excess > threshold
        if not out[: min(2, out.size)].any():
            continue
        first_in = np.flatnonzero(~out[np.argmax(out) :])
        n_out = int(first_in[0]) + int(np.argmax(out)) if first_in.size else out.size
        i_end = min(b, a + n_out * block)
        seg = power_W[a:i_end]
        spikes.append(
            LevelSpike(
                i_start=a,
                i_end=i_end,
                peak_W=float(seg.max() if step_W > 0 else seg.min()),
                energy_above_level_J=float(np.sum(seg - levels[s]) * sample_period_s),
            )
        )
    return tuple(spikes)
