"""Where one least-squares polynomial piece ends and the next begins inside a window.

Part of `wifibot_power.changepoint`: `best_split` (closed-form Gram matrices and prefix
sums: every candidate split of a window at once, in O(1) numpy operations each), its
result `Split`, and the cost `_PolyCost` with what it keeps between calls (`_piece_shape`,
`_window_positions`, `_gram_inverse`), also used by the stacked form (`stacked.py`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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
