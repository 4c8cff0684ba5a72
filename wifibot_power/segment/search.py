"""The state of a motion run's step search (`wifibot_power.segment.steps`, `.stop`): the
trace it runs on, each step's boundaries as they are found, and the batched split every
stage asks for."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wifibot_power.changepoint import Split, best_splits
from wifibot_power.segment.params import MotionParams


@dataclass(frozen=True)
class _Step:
    t0: int  # accel start (block index)
    t1: int  # accel end = cruise start
    t2: int  # cruise end (= t3 without a stop phase)
    t3: int  # motion end
    wavy: bool = False  # [t1, motion end) wavy (a ripple), before any stop was split off


#: a split asked for: (lo, hi, deg_left, deg_right, min_len, jump_sign), the arguments of
#: `best_split`
_SplitAsked = tuple[int, int, int, int, int, int]


@dataclass(frozen=True)
class _Trace:
    """The 1 ms block means `y` a motion run's steps are searched on, their noise sd
    `sigma_b`, the block length [s] and the parameters."""

    y: np.ndarray
    block_dt: float
    sigma_b: float
    params: MotionParams

    def blocks(self, seconds: float) -> int:
        """The number of blocks (at least one) that last `seconds`."""
        return max(1, round(seconds / self.block_dt))

    @property
    def min_len(self) -> int:
        """The fewest blocks of a piece of any split."""
        return max(5, self.blocks(0.005))

    @property
    def refine(self) -> int:
        """Half width of the window of each fine split [blocks]."""
        return self.blocks(self.params.refine_s)


@dataclass
class _Search:
    """One step's search as it goes: its coarse motion [a, b), where the step before ends
    and the next starts, and the boundaries found so far (block indices)."""

    a: int
    b: int
    prev_end: int
    next_start: int
    idle_from: int = 0  # first block of the idle its start is fitted from
    t0: int = 0
    t1_coarse: int | None = None  # the drop that ends the acceleration, if clear
    t1: int = 0
    t2: int = 0
    t3: int = 0
    end_hi: int = 0  # the motion end's window ends here
    wavy: bool = False  # the cruise is wavy (its stop searched as under a ripple)
    wavy_at_first: bool = False  # [t1, b) wavy, any stop in it included

    def step(self) -> _Step:
        return _Step(t0=self.t0, t1=self.t1, t2=self.t2, t3=self.t3, wavy=self.wavy_at_first)


def _splits(y: np.ndarray, asked: list[_SplitAsked | None]) -> list[Split | None]:
    """`best_split` of each window asked (None where none is), the windows of one kind
    (degrees and jump sign) by one `best_splits` call: the same splits, one call per kind."""
    kinds: dict[tuple[int, int, int], list[int]] = {}
    for i, ask in enumerate(asked):
        if ask is not None:
            kinds.setdefault((ask[2], ask[3], ask[5]), []).append(i)
    found: list[Split | None] = [None] * len(asked)
    for (deg_left, deg_right, sign), who in kinds.items():
        windows = [(asked[i][0], asked[i][1], asked[i][4]) for i in who]  # type: ignore[index]
        splits = best_splits(y, windows, deg_left, deg_right, 5, sign)
        for i, split in zip(who, splits, strict=True):
            found[i] = split
    return found
