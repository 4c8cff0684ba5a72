"""The Keysight N6705 DC power analyser's datalog export (log-format.md, section 2).

```
N6705C exported datalog

"Sample interval: 0.00100352"
"Trigger sample: 0"
"Date: Tue Sep  1 16:19:49 2020"

Sample,"Curr avg 3","Volt avg 4"
0,0.00160395,12.6013
```

Its column names live here and nowhere else: `Sample` (the sample index: time = index x
the interval), `Curr avg K`, `Volt avg K`, `Power avg K` and their min/max variants, K the
analyser output (1-4).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import ClassVar

from wifibot_power.errors import LogError
from wifibot_power.io.columns import PowerSource, column_hint, find_column
from wifibot_power.io.formats.base import (
    LogFormat,
    Preamble,
    TimeSource,
    check_header,
    delimiter_of,
    header_cells,
    sniff_data,
)
from wifibot_power.io.options import FORMAT_N6705, ReadOptions
from wifibot_power.run import Problem

#: The first line names the analyser: "N6705C exported datalog".
FIRST_LINE = re.compile(r"^N6705[ABC]?\b", re.IGNORECASE)
#: Datalog columns: "Curr avg 3", "Volt max 4", "Power avg 1" -> quantity, statistic, output.
COLUMN = re.compile(r"^\s*(curr|volt|power)\s+(avg|min|max)\s+([1-4])\s*$", re.IGNORECASE)
QUANTITY = {"curr": "current", "volt": "voltage", "power": "power"}
SAMPLE_COLUMN = "Sample"
#: Quoted preamble lines -> metadata keys.
PREAMBLE_KEYS = (
    ("sample interval:", "sample_period_s"),
    ("trigger sample:", "trigger_sample"),
    ("date:", "date"),
)


class N6705(LogFormat):
    """The analyser's datalog export: no run metadata (that comes from the manifest)."""

    name: ClassVar[str] = FORMAT_N6705

    def sniff(self, first_line: str) -> bool:
        return FIRST_LINE.match(first_line) is not None

    def preamble(self, path: Path, lines: list[str], named: tuple[str, ...]) -> Preamble:
        # the instrument's name opens the first line that is not blank (the one sniffed)
        first = next((line.split() for line in lines if line.strip()), ["N6705"])
        metadata: dict[str, str] = {"instrument": first[0]}
        where: dict[str, str] = {}
        for index, line in enumerate(lines):
            stripped = line.strip().strip('"')
            lowered = stripped.lower()
            for prefix, key in PREAMBLE_KEYS:
                if lowered.startswith(prefix):
                    metadata[key] = stripped.split(":", 1)[1].strip()
                    where[key] = f"line {index + 1}"
            if lowered.startswith("sample") and any(d in stripped for d in ",;\t"):
                delimiter = delimiter_of(line.strip())
                header = header_cells(line.strip(), delimiter)
                check_header(path, header, index)
                decimal_comma = sniff_data(path, lines, index, header, delimiter)
                return Preamble(index, header, delimiter, decimal_comma, self.name, metadata, where)
        raise LogError(
            "N6705 export without a 'Sample,...' header row",
            file=path,
            fix="re-export the datalog as CSV from the analyser",
        )

    def power_sources(self, path: Path, pre: Preamble, options: ReadOptions) -> list[PowerSource]:
        """Power of output K: `Power avg K`, else `Volt avg K` x `Curr avg K`; a current
        alone with `--supply-voltage`. Several candidates, or none, are errors."""
        outputs: dict[str, dict[str, str]] = {}
        for name in pre.header:
            match = COLUMN.match(name)
            if match and match.group(2).lower() == "avg":
                outputs.setdefault(match.group(3), {})[QUANTITY[match.group(1).lower()]] = name
        with_power = [k for k, q in outputs.items() if "power" in q]
        with_both = [k for k, q in outputs.items() if "current" in q and "voltage" in q]
        currents = [k for k, q in outputs.items() if "current" in q]
        if options.supply_voltage_V is not None:
            if len(currents) == 1:
                current = (outputs[currents[0]]["current"], 1.0)
                return [PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)]
            if len(currents) > 1:
                names = ", ".join(outputs[k]["current"] for k in currents)
                raise LogError(
                    f"several current columns ({names})",
                    file=path,
                    fix="name the one to use with --current-column",
                )
        for candidates, build in (
            (
                with_power,
                lambda k: PowerSource(
                    power=(outputs[k]["power"], 1.0),
                    logged_current=_logged(outputs[k], "current"),
                    logged_voltage=_logged(outputs[k], "voltage"),
                ),
            ),
            (
                with_both,
                lambda k: PowerSource(
                    current=(outputs[k]["current"], 1.0), voltage=(outputs[k]["voltage"], 1.0)
                ),
            ),
        ):
            if len(candidates) == 1:
                return [build(candidates[0])]
            if len(candidates) > 1:
                raise LogError(
                    f"several analyser outputs log power (outputs {', '.join(sorted(candidates))})",
                    file=path,
                    fix=_several_outputs_fix([outputs[k] for k in sorted(candidates)]),
                )
        if currents:
            have = ", ".join(f"'{n}'" for q in outputs.values() for n in q.values())
            raise LogError(
                f"no analyser output has both current and voltage (columns {have})",
                file=path,
                fix="give --supply-voltage V (power = current x V), or name the columns with "
                "--current-column and --voltage-column",
            )
        raise LogError(
            "no 'Curr avg K' or 'Power avg K' column",
            file=path,
            where=f"line {pre.header_line + 1}",
            fix=f"export the datalog with current logged, or name the columns: "
            f"{column_hint(pre.header, with_time=False)}",
        )

    def time_source(
        self, path: Path, pre: Preamble, options: ReadOptions
    ) -> tuple[TimeSource | None, list[Problem]]:
        """Time is `Sample` x the sample interval, so dropped samples show as gaps."""
        sample = find_column(pre.header, SAMPLE_COLUMN)
        return (TimeSource(sample, index=True) if sample else None), []

    def check_metadata(self, path: Path, values: dict[str, str]) -> None:
        if "sample_period_s" not in values:
            raise LogError(
                "N6705 export without a 'Sample interval' line",
                file=path,
                fix="give the sample spacing with --sample-period S, or re-export the datalog",
            )


def _logged(output: dict[str, str], quantity: str) -> tuple[str, float] | None:
    """An output's current or voltage column logged beside its power (judges its unit)."""
    return (output[quantity], 1.0) if quantity in output else None


def _several_outputs_fix(outputs: list[dict[str, str]]) -> str:
    """What to give when several outputs log power, in the file's own column names: the
    advice once named 'Power avg 1' and 'Power avg 2' whatever the file held."""
    first = outputs[0]
    if all("power" in q for q in outputs):
        summed = " ".join(f"--power-column '{q['power']}'" for q in outputs)
        return f"name the one to use with --power-column '{first['power']}', or sum them: {summed}"
    return (
        f"name one output's columns, e.g. --current-column '{first['current']}' "
        f"--voltage-column '{first['voltage']}' (outputs are summed only from their "
        "'Power avg K' columns, with --power-column)"
    )
