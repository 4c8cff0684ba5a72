"""The registry of named causes: the only list of them (shared/spec/causes.md).

`wifibot_power.causes` fills it with the catalogue's causes; `register` adds another
(e.g. a test's toy cause, or a user's), `registered` adds one for a `with` block.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from wifibot_power.causes.base import Cause

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
