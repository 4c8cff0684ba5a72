"""What must be imported before workers fork, in one place.

Workers are forked (`parallel.py`): a module the calling process imported before forking is
imported once, not once in every worker. `map_runs` calls `preload_work(plan)` just before
it forks (never on a warm batch, whose records all come from the cache), and runs
`preload_tables` in a thread while the workers work when the command makes tables after.

Everything else in the pipeline imports where it is used, so that a warm `fit --cache`, whose
records and fit are all kept, loads neither numpy nor the segmenter (tests/test_cache.py,
`WARM_UNLOADED`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from wifibot_power.pipeline.record import RunPlan


def preload_work(plan: RunPlan | None = None) -> None:
    """What a worker's `run_record` imports under `plan` (by default `fit`'s): the run table,
    the segmenter, the model families (the drive model's package for a plan that makes their
    statistics: ~20 ms of CPU `diagnose` does without); the causes and trace statistics for
    a plan that diagnoses, the trace figure's envelope for one that draws. Not pandas: the
    records need none. numpy's submodules that load at first use: `numpy.ma` (`np.median`'s
    NaN check imports it, ~9 ms of CPU) and `numpy.fft` (the segmenter's ripple
    continuation, the trace statistics), which every worker would otherwise import for
    itself."""
    import numpy.fft  # noqa: F401
    import numpy.ma  # noqa: F401

    import wifibot_power.models  # noqa: F401
    import wifibot_power.runtable  # noqa: F401
    import wifibot_power.segment  # noqa: F401

    if plan is None or plan.families:
        import wifibot_power.drive  # noqa: F401  (the drive family's statistics: models/drive.py)
    if plan is not None and plan.causes:
        import wifibot_power.causes  # noqa: F401
        import wifibot_power.traces  # noqa: F401
    if plan is not None and plan.view:
        import wifibot_power.figures.trace  # noqa: F401


def preload_tables() -> None:
    """pandas (~0.3-0.4 s), for a command that makes tables once the workers are done: run
    beside them (`map_runs(beside=...)`) the import overlaps their work."""
    import pandas  # noqa: F401
