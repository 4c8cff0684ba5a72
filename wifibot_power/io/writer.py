"""Write the canonical wbpower CSV (log-format.md §1): `#` metadata, then samples."""

from __future__ import annotations

import gzip
import io
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from wifibot_power.outputs import write_atomic
from wifibot_power.run import RunMeta

FORMAT_LINE = "# wbpower-log: 1"


def _meta_lines(meta: RunMeta, with_period: bool) -> list[str]:
    lines = [FORMAT_LINE, f"# run_id: {meta.run_id}", f"# mode: {meta.mode}"]
    for key, value in (
        ("speed_mps", meta.speed_mps),
        ("distance_m", meta.distance_m),
        ("steps", meta.steps if meta.mode == "motion" else None),
        ("payload_kg", meta.payload_kg or None),
        (
            "started_at",
            meta.started_at.isoformat().replace("+00:00", "Z") if meta.started_at else None,
        ),
        ("sample_period_s", meta.sample_period_s if with_period else None),
    ):
        if value is not None:
            lines.append(f"# {key}: {value:g}" if isinstance(value, float) else f"# {key}: {value}")
    lines += [f"# {k}: {v}" for k, v in meta.extra.items()]
    return lines


def format_log(
    meta: RunMeta,
    power_W: np.ndarray,
    *,
    voltage_V: np.ndarray | None = None,
    time_column: bool = True,
    decimals: int = 4,
) -> bytes:
    """CSV bytes of a log. With `voltage_V`, writes voltage, current and power columns; values are
    rounded to `decimals` so the shortest round-trip text is short."""
    columns: dict[str, np.ndarray] = {}
    if time_column:
        columns["time_s"] = np.round(np.arange(power_W.size) * meta.sample_period_s, 10)
    if voltage_V is not None:
        columns["voltage_V"] = np.round(voltage_V, decimals)
        columns["current_A"] = np.round(power_W / voltage_V, decimals + 1)
    columns["power_W"] = np.round(power_W, decimals)
    return csv_bytes(_meta_lines(meta, with_period=not time_column) + [",".join(columns)], columns)


def csv_bytes(header_lines: list[str], columns: dict[str, np.ndarray]) -> bytes:
    """`header_lines` (metadata, column names: written as given), then the columns' rows,
    each value in its shortest round-trip text (pyarrow's CSV writer)."""
    sink = io.BytesIO()
    sink.write(("\n".join(header_lines) + "\n").encode())
    pacsv.write_csv(
        pa.table(columns),
        sink,
        write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"),
    )
    return sink.getvalue()


def write_log(path: Path, data: bytes) -> Path:
    """Write log bytes atomically; `.gz` names are gzip-compressed, `.zst` names zstd (by
    pyarrow, which also reads them back: a standard zstd frame, as `zstd -d` reads)."""
    if str(path).endswith(".gz"):
        data = gzip.compress(data, compresslevel=6, mtime=0)
    elif str(path).endswith(".zst"):
        data = pa.compress(data, codec="zstd", asbytes=True)
    return write_atomic(Path(path), lambda tmp: tmp.write_bytes(data))
