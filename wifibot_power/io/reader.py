"""Read one log (canonical wbpower CSV or Keysight N6705 datalog) into a `Run`.

Parsing goes through pyarrow's multi-threaded CSV reader; per-sample work is
vectorised. The preamble (metadata lines, N6705 header) is parsed in Python:
it is a handful of lines.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from wifibot_power.errors import LogError
from wifibot_power.io.columns import (
    CANONICAL_COLUMNS,
    N6705_COLUMN,
    N6705_QUANTITY,
    PowerSource,
    find_column,
    unit_scale,
)
from wifibot_power.io.metadata import build_meta
from wifibot_power.io.validate import check_samples
from wifibot_power.run import Run

FORMAT_CANONICAL = "wbpower-csv"
FORMAT_N6705 = "n6705"
LOG_SUFFIXES = (".csv", ".csv.gz", ".csv.zst")
_HEAD_BYTES = 1 << 16
_ROW_IN_MESSAGE = re.compile(r"Row #(\d+)")
_COLUMN_IN_MESSAGE = re.compile(r"column #(\d+)")


@dataclass(frozen=True)
class ReadOptions:
    """Options every log-reading command shares (cli.md: reading options)."""

    supply_voltage_V: float | None = None
    current_column: str | None = None
    voltage_column: str | None = None
    sample_period_s: float | None = None


@dataclass(frozen=True)
class _Preamble:
    format: str
    header_line: int  # 0-based index of the header row in the file
    header: list[str]
    metadata: dict[str, str]
    delimiter: str
    decimal_comma: bool


def is_log_name(path: Path) -> bool:
    return path.name.lower().endswith(LOG_SUFFIXES)


def read_bytes(path: Path) -> bytes:
    """The file's bytes, decompressed by extension (.gz, .zst)."""
    name = path.name.lower()
    try:
        if name.endswith((".gz", ".zst")):
            codec = "gzip" if name.endswith(".gz") else "zstd"
            with pa.input_stream(str(path), compression=codec) as stream:
                return stream.read()
        return path.read_bytes()
    except FileNotFoundError:
        raise LogError("no such file", file=path, fix="check the path") from None
    except IsADirectoryError:
        raise LogError("is a folder, not a log", file=path, fix="name a log file") from None
    except (OSError, pa.ArrowException) as exc:
        raise LogError(
            f"cannot read or decompress ({str(exc).splitlines()[0][:80]})",
            file=path,
            fix="check the file is complete and its extension matches its compression",
        ) from None


def read_log(
    path: str | Path,
    options: ReadOptions | None = None,
    overrides: dict[str, str] | None = None,
    *,
    data: bytes | None = None,
) -> Run:
    """Read a log file into a `Run`; `overrides` (manifest values) win over the file's metadata.

    Raises `LogError` with a one-line message for anything it cannot read honestly.
    """
    options = options or ReadOptions()
    path = Path(path)
    raw = read_bytes(path) if data is None else data
    if raw.startswith(b"\xef\xbb\xbf"):
        raw = raw[3:]
    pre = _parse_preamble(path, raw)
    table = _read_table(path, raw, pre)
    source = _power_source(path, pre, table.column_names, options)
    power_W = _power(path, pre, table, source)
    values = dict(pre.metadata)
    values.update(overrides or {})
    if options.sample_period_s is not None and "time_s" not in _lower(table.column_names):
        values["sample_period_s"] = repr(options.sample_period_s)
    meta = build_meta(values, file=str(path), stem=_stem(path), where="metadata")
    time_s = _time(path, pre, table, meta.sample_period_s)
    period_s, problems = check_samples(
        str(path), time_s, power_W, first_data_line=pre.header_line + 2,
        default_period_s=meta.sample_period_s,
    )
    if time_s is None:
        time_s = np.arange(power_W.size) * period_s
    elif period_s != meta.sample_period_s:
        values["sample_period_s"] = repr(period_s)
        meta = build_meta(values, file=str(path), stem=_stem(path), where="metadata")
    return Run(
        file=str(path),
        format=pre.format,
        meta=meta,
        time_s=time_s,
        power_W=power_W,
        problems=tuple(problems),
    )


def _stem(path: Path) -> str:
    name = path.name
    for suffix in LOG_SUFFIXES:
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def _lower(names: list[str]) -> list[str]:
    return [n.strip().strip('"').lower() for n in names]


def _not_a_log(path: Path, why: str) -> LogError:
    return LogError(
        f"not a power log ({why})",
        file=path,
        fix="give a wbpower CSV (see docs/log-format.md) or a Keysight N6705 datalog export",
    )


def _parse_preamble(path: Path, raw: bytes) -> _Preamble:
    if not raw.strip():
        raise LogError("the file is empty", file=path, fix="re-export the log")
    head = raw[:_HEAD_BYTES]
    if b"\x00" in head:
        raise _not_a_log(path, "binary data")
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a multi-byte char cut by the head limit
            raise _not_a_log(path, f"not UTF-8 text at byte {exc.start}") from None
        text = head[: exc.start].decode("utf-8")
    lines = text.splitlines()
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    if re.match(r"^N6705[ABC]?\b", first, re.IGNORECASE):
        return _n6705_preamble(path, lines)
    return _canonical_preamble(path, lines)


def _canonical_preamble(path: Path, lines: list[str]) -> _Preamble:
    metadata: dict[str, str] = {}
    for index, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            body = stripped.lstrip("#").strip()
            if ":" in body:
                key, _, value = body.partition(":")
                metadata[key.strip().lower()] = value.strip()
            continue
        delimiter = _delimiter(stripped)
        header = [h.strip().strip('"') for h in stripped.split(delimiter)]
        known = [h for h in header if h.lower() in CANONICAL_COLUMNS]
        if not known:
            if any(ch.isdigit() for ch in stripped) and not any(ch.isalpha() for ch in stripped):
                raise _not_a_log(path, f"line {index + 1} is data but there is no header row")
            raise _not_a_log(path, f"line {index + 1} is not a header with power_W/voltage_V/current_A")
        data_line = next((ln for ln in lines[index + 1 :] if ln.strip()), None)
        if data_line is None and index + 1 >= len(lines):
            raise LogError(
                "header only: no samples", file=path, where=f"line {index + 1}",
                fix="the log holds no data; re-export it",
            )
        decimal_comma = _decimal_comma(path, delimiter, data_line, index + 2)
        return _Preamble(FORMAT_CANONICAL, index, header, metadata, delimiter, decimal_comma)
    if metadata:
        raise LogError(
            "metadata only: no header row and no samples", file=path,
            fix="the log holds no data; re-export it",
        )
    raise _not_a_log(path, "no header row")


def _n6705_preamble(path: Path, lines: list[str]) -> _Preamble:
    metadata: dict[str, str] = {"instrument": lines[0].split()[0] if lines else "N6705"}
    for index, line in enumerate(lines):
        stripped = line.strip().strip('"')
        lowered = stripped.lower()
        if lowered.startswith("sample interval:"):
            metadata["sample_period_s"] = stripped.split(":", 1)[1].strip()
        elif lowered.startswith("trigger sample:"):
            metadata["trigger_sample"] = stripped.split(":", 1)[1].strip()
        elif lowered.startswith("date:"):
            metadata["date"] = stripped.split(":", 1)[1].strip()
        elif lowered.startswith("sample") and ("," in stripped or ";" in stripped or "\t" in stripped):
            delimiter = _delimiter(line.strip())
            header = [h.strip().strip('"') for h in line.strip().split(delimiter)]
            data_line = next((ln for ln in lines[index + 1 :] if ln.strip()), None)
            if data_line is None and index + 1 >= len(lines):
                raise LogError(
                    "header only: no samples", file=path, where=f"line {index + 1}",
                    fix="the datalog holds no data; re-export it",
                )
            decimal_comma = _decimal_comma(path, delimiter, data_line, index + 2)
            return _Preamble(FORMAT_N6705, index, header, metadata, delimiter, decimal_comma)
    raise LogError(
        "N6705 export without a 'Sample,...' header row", file=path,
        fix="re-export the datalog as CSV from the analyser",
    )


def _delimiter(header: str) -> str:
    counts = {d: header.count(d) for d in (",", ";", "\t")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] else ","


def _decimal_comma(path: Path, delimiter: str, data_line: str | None, line_no: int) -> bool:
    if data_line is None or delimiter == ",":
        return False
    cells = data_line.strip().split(delimiter)
    has_comma = any("," in c for c in cells)
    has_point = any("." in c for c in cells)
    if has_comma and has_point:
        raise LogError(
            "both ',' and '.' appear in numbers", file=path, where=f"line {line_no}",
            fix="export with one decimal separator",
        )
    return has_comma


def _read_table(path: Path, raw: bytes, pre: _Preamble) -> pa.Table:
    column_types = None if pre.decimal_comma else {
        name: pa.float64() for name in pre.header if name.lower() in CANONICAL_COLUMNS
        or N6705_COLUMN.match(name)
    }
    try:
        table = pacsv.read_csv(
            pa.BufferReader(raw),
            read_options=pacsv.ReadOptions(skip_rows=pre.header_line, block_size=1 << 24),
            parse_options=pacsv.ParseOptions(delimiter=pre.delimiter),
            convert_options=pacsv.ConvertOptions(
                column_types=column_types,
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except pa.ArrowInvalid as exc:
        raise _parse_error(path, pre, str(exc)) from None
    if table.num_rows == 0:
        raise LogError(
            "header only: no samples", file=path, where=f"line {pre.header_line + 1}",
            fix="the log holds no data; re-export it",
        )
    if pre.decimal_comma:
        table = _decimal_comma_to_float(path, pre, table)
    return table


def _parse_error(path: Path, pre: _Preamble, message: str) -> LogError:
    first = message.splitlines()[0]
    row = _ROW_IN_MESSAGE.search(first)
    where = f"line {pre.header_line + 1 + int(row.group(1))}" if row else None
    col = _COLUMN_IN_MESSAGE.search(first)
    if col and int(col.group(1)) < len(pre.header):
        name = pre.header[int(col.group(1))]
        where = f"{where}, column '{name}'" if where else f"column '{name}'"
    if "conversion error" in first or "invalid value" in first:
        value = first.rsplit("invalid value", 1)[-1].strip(" '")
        return LogError(
            f"'{value}' where a number belongs", file=path, where=where,
            fix="fix or delete that line",
        )
    if "Expected" in first and "columns" in first:
        return LogError(
            f"wrong number of fields ({first.split(':')[0].strip()})", file=path, where=where,
            fix="the line is truncated or malformed; delete it or re-export the log",
        )
    return LogError(f"cannot parse the CSV ({first[:100]})", file=path, where=where,
                    fix="check the delimiter and quoting")


def _decimal_comma_to_float(path: Path, pre: _Preamble, table: pa.Table) -> pa.Table:
    columns = {}
    for name in table.column_names:
        col = table[name]
        if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
            col = pc.replace_substring(col, ",", ".")
        try:
            columns[name] = pc.cast(col, pa.float64())
        except pa.ArrowInvalid:
            raise LogError(
                f"column '{name}' has text where a number belongs", file=path,
                where=f"column '{name}'", fix="fix or delete the offending lines",
            ) from None
    return pa.table(columns)


def _power_source(path: Path, pre: _Preamble, names: list[str], options: ReadOptions) -> PowerSource:
    if options.current_column or options.voltage_column:
        return _named_source(path, names, options)
    if pre.format == FORMAT_CANONICAL:
        lowered = {n.lower(): n for n in names}
        for key in ("power_w", "power_mw"):
            if key in lowered:
                return PowerSource(power=(lowered[key], CANONICAL_COLUMNS[key][1]))
        current = next(((lowered[k], CANONICAL_COLUMNS[k][1]) for k in ("current_a", "current_ma") if k in lowered), None)
        voltage = next(((lowered[k], CANONICAL_COLUMNS[k][1]) for k in ("voltage_v", "voltage_mv") if k in lowered), None)
        if current and voltage:
            return PowerSource(current=current, voltage=voltage)
        if current and options.supply_voltage_V:
            return PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)
        if current:
            raise LogError(
                "current only, no power or voltage column", file=path,
                fix="give --supply-voltage V, or name the voltage column with --voltage-column",
            )
        raise LogError(
            "no power_W, power_mW, or voltage_V x current_A columns", file=path,
            where=f"line {pre.header_line + 1}",
            fix="name the columns as in docs/log-format.md, or use --current-column/--voltage-column",
        )
    return _n6705_source(path, pre, names, options)


def _n6705_source(path: Path, pre: _Preamble, names: list[str], options: ReadOptions) -> PowerSource:
    outputs: dict[str, dict[str, str]] = {}
    for name in names:
        match = N6705_COLUMN.match(name)
        if match and match.group(2).lower() == "avg":
            outputs.setdefault(match.group(3), {})[N6705_QUANTITY[match.group(1).lower()]] = name
    with_power = [k for k, q in outputs.items() if "power" in q]
    with_both = [k for k, q in outputs.items() if "current" in q and "voltage" in q]
    currents = [k for k, q in outputs.items() if "current" in q]
    if options.supply_voltage_V is not None:
        if len(currents) == 1:
            return PowerSource(current=(outputs[currents[0]]["current"], 1.0),
                               supply_voltage_V=options.supply_voltage_V)
        if len(currents) > 1:
            raise LogError(
                f"several current columns ({', '.join(outputs[k]['current'] for k in currents)})",
                file=path, fix="name the one to use with --current-column",
            )
    for candidates, build in (
        (with_power, lambda k: PowerSource(power=(outputs[k]["power"], 1.0))),
        (with_both, lambda k: PowerSource(current=(outputs[k]["current"], 1.0),
                                          voltage=(outputs[k]["voltage"], 1.0))),
    ):
        if len(candidates) == 1:
            return build(candidates[0])
        if len(candidates) > 1:
            raise LogError(
                f"several analyser outputs log power (outputs {', '.join(sorted(candidates))})",
                file=path, fix="name the columns to use with --current-column and --voltage-column",
            )
    if currents:
        have = ", ".join(f"'{n}'" for q in outputs.values() for n in q.values())
        raise LogError(
            f"no analyser output has both current and voltage (columns {have})",
            file=path,
            fix="give --supply-voltage V (power = current x V), or name the columns with "
            "--current-column and --voltage-column",
        )
    raise LogError("no 'Curr avg K' or 'Power avg K' column", file=path,
                   where=f"line {pre.header_line + 1}", fix="export the datalog with current logged")


def _named_source(path: Path, names: list[str], options: ReadOptions) -> PowerSource:
    def lookup(wanted: str, option: str) -> tuple[str, float]:
        found = find_column(names, wanted)
        if found is None:
            raise LogError(
                f"no column '{wanted}' (columns: {', '.join(names)})", file=path,
                fix=f"check {option}",
            )
        return found, unit_scale(found)

    if not options.current_column:
        raise LogError("--voltage-column needs --current-column too", file=path,
                       fix="name both columns")
    current = lookup(options.current_column, "--current-column")
    if options.voltage_column:
        return PowerSource(current=current, voltage=lookup(options.voltage_column, "--voltage-column"))
    if options.supply_voltage_V is None:
        raise LogError("--current-column needs a voltage", file=path,
                       fix="give --voltage-column or --supply-voltage")
    return PowerSource(current=current, supply_voltage_V=options.supply_voltage_V)


def _column(path: Path, table: pa.Table, spec: tuple[str, float]) -> np.ndarray:
    name, scale = spec
    col = table[name]
    if not pa.types.is_floating(col.type) and not pa.types.is_integer(col.type):
        raise LogError(f"column '{name}' holds text, not numbers", file=path,
                       where=f"column '{name}'", fix="fix the column or re-export")
    values = col.to_numpy().astype(np.float64, copy=False)
    return values * scale if scale != 1.0 else values


def _power(path: Path, pre: _Preamble, table: pa.Table, source: PowerSource) -> np.ndarray:
    if source.power:
        return _column(path, table, source.power)
    current = _column(path, table, source.current)
    if source.voltage:
        return current * _column(path, table, source.voltage)
    return current * float(source.supply_voltage_V)


def _time(path: Path, pre: _Preamble, table: pa.Table, period_s: float) -> np.ndarray | None:
    if pre.format == FORMAT_CANONICAL:
        name = find_column(table.column_names, "time_s")
        if name is not None:
            return _column(path, table, (name, 1.0))
        return None
    name = find_column(table.column_names, "Sample")
    if name is None:
        return None
    return _column(path, table, (name, 1.0)) * period_s
