"""`best_splits`: `best_split` of many windows at once, short ones stacked as the rows of
one array (part of `wifibot_power.changepoint`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from wifibot_power.changepoint.splits import (
    Split,
    _edge_values,
    _gram_inverse,
    _own_basis_rhs,
    _piece_value,
    _solve,
    best_split,
)

#: how many numbers (windows x longest window) one stack of `best_splits` holds, and the
#: longest window stacked (longer ones cost more stacked than one by one: measured)
_STACK_SIZE = 8000
_STACKED_MAX = 700


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
    sizes = np.array([r[2] for r in rows], dtype=np.int64)
    leasts = np.array([r[3] for r in rows], dtype=np.int64)
    column = np.arange(int(sizes.max()) + 1)
    scale = sizes.astype(np.float64)[:, None]
    terms, offsets = _stacked_prefix_sums(y, rows, sizes, column, scale, max_deg)
    valid = (column[None, :] >= leasts[:, None]) & (column[None, :] <= (sizes - leasts)[:, None])
    sse_left, coef_left = _stacked_fit(terms, sizes, column, scale, deg_left, left=True)
    sse_right, coef_right = _stacked_fit(terms, sizes, column, scale, deg_right, left=False)
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
    row, best = np.arange(len(rows)), total.argmin(axis=1)
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


def _stacked_prefix_sums(
    y: np.ndarray,
    rows: list[tuple[int, int, int, int]],
    sizes: np.ndarray,
    column: np.ndarray,
    scale: np.ndarray,
    max_deg: int,
) -> tuple[np.ndarray, np.ndarray]:
    """`_PolyCost`'s prefix sums for every window (index, lo, length, min_len) at once
    (`sizes`: the lengths; `column`: 0..longest; `scale`: the lengths as floats, a column):
    `terms[q]` holds each window's prefix sums of u^q y (q = 0..max_deg) and `terms[-1]` of
    y^2, a window a row padded to the longest; and each window's mean (`offsets`)."""
    count = len(rows)
    lows = np.array([r[1] for r in rows], dtype=np.int64)
    longest = column.size - 1
    # each window's mean as `_PolyCost` takes it: its own pairwise sum over its own count
    offsets = np.array([float(np.add.reduce(y[lo : lo + n]) / n) for _, lo, n, _ in rows])
    inside = column[None, 1:] <= sizes[:, None]
    gathered = y[np.minimum(lows[:, None] + column[None, :-1], y.size - 1)]
    # u of each window (`_window_positions`), and the prefix sums of u^q y and y^2 per row;
    # a split s's left piece sums prefix[s], and every s = 0..longest is a column (the
    # splits a window does not allow are masked at the end): whole rows, no strided views
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
    return terms, offsets


def _stacked_fit(
    terms: np.ndarray,
    sizes: np.ndarray,
    column: np.ndarray,
    scale: np.ndarray,
    deg: int,
    left: bool,
) -> tuple[np.ndarray, list[np.ndarray]]:
    """`_PolyCost.fit_splits` and `_PieceShape` on every row of `_stacked_prefix_sums` at
    once (its `sizes`, `column`, `scale`): the SSE of the degree-`deg` piece left (or right)
    of every split s = 0..longest, and its coefficients by power. Masked splits get a piece
    length the G⁻¹ table holds (valid ones are >= deg + 2)."""
    m = deg + 1
    if left:
        sums = [terms[q] for q in range(m)]
        y2 = terms[-1]
        length = np.maximum(column, deg + 1)[None, :]
    else:
        totals = terms[:, np.arange(sizes.size), sizes][:, :, None]  # over each whole window
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
    table = _gram_inverse(deg, column.size - 1)  # no piece is longer than the longest window
    rhs = _own_basis_rhs(sums, shift_pow, pair_terms, ratio_pow)
    coef, explained = _solve(rhs, {key: row[length] for key, row in table.items()})
    return np.maximum(y2 - explained, 0.0), coef
