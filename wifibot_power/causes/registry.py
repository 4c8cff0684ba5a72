"""The registry of named causes: the only list of them (shared/spec/causes.md).

`wifibot_power.causes` fills it with the catalogue's causes; `register` adds another
(e.g. a test's toy cause, or a user's), `registered` adds one for a `with` block.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from wifibot_power.causes.base import Cause, RunView

#: name -> cause, in the order causes are tried and reported
CAUSES: dict[str, Cause] = {}


def register(cause: Cause) -> Cause:
    """Add `cause` to the registry under `cause.name` (replacing one of that name)."""
    CAUSES[cause.name] = cause
    return cause


def unregister(name: str) -> None:
    CAUSES.pop(name, None)


@contextmanager
def registered(cause: Cause) -> Iterator[Cause]:
    """`with registered(MyCause()):` the cause is in the registry for the block only."""
    previous = CAUSES.get(cause.name)
    register(cause)
    try:
        yield cause
    finally:
        if previous is None:
            unregister(cause.name)
        else:
            CAUSES[cause.name] = previous


def ordered(names) -> list[str]:
    """`names` in registry order, unknown ones dropped."""
    wanted = set(names)
    return [name for name in CAUSES if name in wanted]


def run_statistics(view: RunView) -> tuple[dict[str, float], dict[str, object]]:
    """Every cause's per-run statistics of a segmented motion run (`Cause.run_stats`) and
    its trace data (`Cause.run_trace`, by cause; None left out). The windows the causes ask
    for (`Cause.energy_windows`) are summed in one pass over the samples first."""
    asked = {}
    for name, cause in CAUSES.items():
        windows = view.windows_of(cause)
        if len(windows[0]):
            asked[name] = windows
    if asked:
        starts = np.concatenate([np.asarray(w[0], dtype=np.int64) for w in asked.values()])
        ends = np.concatenate([np.asarray(w[1], dtype=np.int64) for w in asked.values()])
        energies = view.energy.between(starts, ends) if starts.size else np.zeros(0)
        at = 0
        for name, windows in asked.items():
            view.window_J[name] = energies[at : at + len(windows[0])]
            at += len(windows[0])
    stats: dict[str, float] = {}
    traces: dict[str, object] = {}
    for name, cause in CAUSES.items():
        stats.update(cause.run_stats(view))
        trace = cause.run_trace(view)
        if trace is not None:
            traces[name] = trace
    return stats, traces
