"""A parsed `Run` as a Parquet table and back: what the parse cache (`cache.py`) stores.

The samples are columns (power, and where the run has them time, speed, rate of turn,
surface and channels); the rest of the run (file, format, metadata, problems, which columns
are there) is JSON in the table's schema metadata, with the SHA-256 of the content it was
parsed from. Split out of `cache.py` (issue 24: one job a module).
"""

from __future__ import annotations

import dataclasses
import json
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from wifibot_power.run import Problem, Run, RunMeta

if TYPE_CHECKING:
    import pyarrow as pa

_METADATA_KEY = b"wbpower.run"


def load_run(entry: Path, content_sha256: str) -> Run | None:
    """The cached `Run`, or None when the entry is missing, unreadable or of other content."""
    import pyarrow as pa
    import pyarrow.parquet as pq  # only for a parse that is read back: a warm fit needs none

    try:
        # one thread, as every CSV parse (transport._csv_options): pyarrow's threaded CSV
        # reader can drop a table's last block silently; this reader is other code, not
        # known to, but a cached run read short would be as quietly wrong, and the entries
        # are small
        table = pq.read_table(entry, use_threads=False)
        stored = json.loads((table.schema.metadata or {})[_METADATA_KEY])
        if stored["content_sha256"] != content_sha256:
            return None  # a pair torn by concurrent writers: parse again
        power_W = table["power_W"].to_numpy()
        meta_values = dict(stored["meta"])
        started = meta_values.get("started_at")
        meta_values["started_at"] = datetime.fromisoformat(started) if started else None
        meta = RunMeta(**meta_values)
        # a regular axis is made when asked for (`Run.time_s`): the same floats
        time_s = table["time_s"].to_numpy() if stored["time"] == "column" else None
        problems = tuple(Problem(**p) for p in stored["problems"])
        speed_mps = table["speed_mps"].to_numpy() if stored["speed"] else None
        yaw_rate_radps = table["yaw_rate_radps"].to_numpy() if stored.get("yaw_rate") else None
        surfaces = tuple(stored.get("surfaces") or ())
        surface_index = table["surface_index"].to_numpy() if surfaces else None
        channels_W = {name: table[f"channel:{name}"].to_numpy() for name in stored["channels"]}
    except (OSError, KeyError, TypeError, ValueError, pa.ArrowException):
        return None
    return Run(
        file=stored["file"],
        format=stored["format"],
        meta=meta,
        stamps_s=time_s,
        power_W=power_W,
        problems=problems,
        speed_mps=speed_mps,
        yaw_rate_radps=yaw_rate_radps,
        channels_W=channels_W,
        surface_index=surface_index,
        surface_names=surfaces,
    )


def run_table(run: Run, content_sha256: str) -> pa.Table:
    """The run as a table: its samples as columns, the rest in the schema's metadata."""
    import numpy as np
    import pyarrow as pa

    meta = dataclasses.asdict(run.meta)
    meta["started_at"] = run.meta.started_at.isoformat() if run.meta.started_at else None
    # a time column that is exactly sample index x period need not be stored
    regular = run.stamps_s is None or np.array_equal(
        run.stamps_s, np.arange(run.samples) * run.sample_period_s
    )
    header = {
        "content_sha256": content_sha256,
        "file": run.file,
        "format": run.format,
        "meta": meta,
        "problems": [dataclasses.asdict(p) for p in run.problems],
        "time": "arange" if regular else "column",
        "speed": run.speed_mps is not None,
        "yaw_rate": run.yaw_rate_radps is not None,
        "surfaces": list(run.surface_names) if run.surface_index is not None else None,
        "channels": list(run.channels_W),
    }
    columns = {"power_W": run.power_W}
    if not regular:
        columns["time_s"] = run.time_s
    if run.speed_mps is not None:
        columns["speed_mps"] = run.speed_mps
    if run.yaw_rate_radps is not None:
        columns["yaw_rate_radps"] = run.yaw_rate_radps
    if run.surface_index is not None:
        columns["surface_index"] = run.surface_index
    for name, channel_W in run.channels_W.items():
        columns[f"channel:{name}"] = channel_W
    return pa.table(columns).replace_schema_metadata({_METADATA_KEY: json.dumps(header)})
