"""What a text log says of its robot to judge its power by (`validate.check_power_scale`):
`--max-power` or the `max_power_W` metadata, its voltage and current columns, and a power
column's median against the voltage x current logged beside it, from the head (io/reader.py
reads the log; moved here to keep it within the module size, tests/test_architecture.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wifibot_power.io.columns import PowerSource
from wifibot_power.io.formats import Preamble
from wifibot_power.io.formats.base import SNIFF_LINES
from wifibot_power.io.metadata import MAX_POWER_KEY, max_power_W
from wifibot_power.io.options import ReadOptions
from wifibot_power.io.transport import Content, head_lines
from wifibot_power.io.validate import PowerScale

#: Data lines of the head whose medians judge a power column against the voltage x current
#: logged beside it (a unit mistake holds through the whole column).
HEAD_ROWS = SNIFF_LINES


def power_scale(
    path: Path,
    content: Content,
    head: bytes,
    pre: Preamble,
    sources: list[PowerSource],
    options: ReadOptions,
    values: dict[str, str],
    where: dict[str, str],
) -> PowerScale:
    """What the log says of its robot to judge its power by (`validate.check_power_scale`):
    `--max-power`, else the `max_power_W` metadata; its voltage and current columns; and a
    power column's median against the voltage x current logged beside it, from the head."""
    if options.max_power_W is not None:
        ceiling_W, ceiling_where = options.max_power_W, "--max-power"
    else:
        ceiling_W = max_power_W(values, file=str(path), origins=where)
        ceiling_where = where.get(MAX_POWER_KEY, "metadata")
    head_medians = None
    if (
        len(sources) == 1
        and sources[0].power
        and (sources[0].logged_current or sources[0].logged_voltage)
    ):
        head_medians = _head_medians(path, content, head, pre, sources[0])
    return PowerScale(
        max_power_W=ceiling_W,
        max_power_where=ceiling_where,
        voltages=frozenset(source.voltage[0] for source in sources if source.voltage),
        currents=frozenset(source.current[0] for source in sources if source.current),
        head=head_medians,
    )


def _head_medians(
    path: Path, content: Content, head: bytes, pre: Preamble, source: PowerSource
) -> tuple[str, float, float | None, float | None] | None:
    """(power column, median |power| [W], median |voltage x current| [W] or None, median
    |voltage| [V] or None) over the first `HEAD_ROWS` data lines that parse; None when none
    do (the full parse then says what is wrong)."""
    import csv

    specs = {"power": source.power, "current": source.logged_current}
    specs["voltage"] = source.logged_voltage
    index = {key: pre.header.index(spec[0]) for key, spec in specs.items() if spec}
    lines = head_lines(path, content, head, limit=pre.header_line + 1 + HEAD_ROWS)
    rows: dict[str, list[float]] = {key: [] for key in index}
    data = (line for line in lines[pre.header_line + 1 :] if line.strip())
    for cells in csv.reader(data, delimiter=pre.delimiter):
        try:
            parsed = {
                key: float(cells[k].replace(",", ".") if pre.decimal_comma else cells[k])
                for key, k in index.items()
            }
        except (ValueError, IndexError):
            continue
        for key, value in parsed.items():
            rows[key].append(value * specs[key][1])
    if not rows["power"]:
        return None
    arrays = {key: np.abs(np.asarray(found)) for key, found in rows.items()}
    power = float(np.median(arrays["power"]))
    both = "current" in arrays and "voltage" in arrays
    vi = float(np.median(arrays["current"] * arrays["voltage"])) if both else None
    volts = float(np.median(arrays["voltage"])) if "voltage" in arrays else None
    return source.power[0], power, vi, volts
