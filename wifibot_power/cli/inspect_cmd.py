"""`wbpower inspect FILE...` (see shared/spec/cli.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from wifibot_power.cli.common import (
    JsonFlag,
    check_out_dir,
    handles_errors,
    json_defaults,
    out_dir,
    print_json,
    progress,
    report_skipped,
    stdout,
    warn_problems,
    with_reading_options,
)
from wifibot_power.cli.help import command_help
from wifibot_power.cli.tables import Col, print_table, with_wide_option
from wifibot_power.cli.typer_app import app
from wifibot_power.inspect import inspect_logs
from wifibot_power.io import ReadOptions
from wifibot_power.io.options import log_stem

#: file is the key (repeated if the table is split); numbers never cut, text folds; what
#: every log shares (one format, one period, no problem) is said once, in the caption
COLUMNS = (
    Col("file", "text", key=True),
    Col("format", "text", once=True),
    Col("run_id", "text"),
    Col("mode", "text"),
    Col("samples"),
    Col("period ms", once=True),
    Col("duration s"),
    Col("mean W"),
    Col("energy J"),
    Col("problems", "text", once=True),
)


#: `-o DIR`: what it writes there (cli.md)
Out = out_dir("logs.parquet (a row per log)")


@app.command("inspect", **command_help("inspect"))
@handles_errors
@with_wide_option
@with_reading_options
def inspect_command(
    paths: Annotated[list[Path], typer.Argument(help="Log files or folders.")],
    options: ReadOptions,
    json_out: JsonFlag = False,
    out: Out = None,
) -> None:
    """What is in each log: format, samples, period, duration, mean power, energy, metadata."""
    check_out_dir(out)  # before any work (cli.md)
    # cli.md: {logs, skipped, warnings, error}, also on failure (`common.JsonDocument`)
    json_defaults(logs=[])
    rows, skipped = inspect_logs(
        paths, options, wrap=lambda s: progress(s, "reading"), on_problems=warn_problems
    )
    if out is not None:
        write_inspection(rows, out)  # said by handles_errors (common.say_written)
    if json_out:  # skipped inputs: in `skipped` and on stderr (exit 1), as warnings are
        print_json({"logs": rows})
    else:
        cells = [
            [
                Path(str(row["file"])).name,
                str(row["format"]),
                str(row["run_id"]),
                str(row["meta"]["mode"]),
                f"{row['samples']:,}",
                f"{row['sample_period_s'] * 1e3:.5g}",
                f"{row['duration_s']:.3f}",
                f"{row['mean_power_W']:.3f}",
                f"{row['energy_J']:.1f}",
                _problems_cell(row["problems"]),
            ]
            for row in rows
        ]
        columns, caption = COLUMNS, None
        if all(str(row["run_id"]) == log_stem(Path(str(row["file"]))) for row in rows):
            # each run_id is its file's name: not a column of its own (issue 28: compact)
            columns = tuple(c for c in COLUMNS if c.name != "run_id")
            cells = [cell[:2] + cell[3:] for cell in cells]
            caption = "run_id: the file's name"
        print_table(stdout, f"{len(rows)} log(s)", columns, cells, caption=caption)
        for row in rows:
            if row["channels"]:
                summed = ", ".join(
                    f"{c['name']} {c['mean_power_W']:.3f} W" for c in row["channels"]
                )
                name = Path(str(row["file"])).name
                stdout.print(f"{name}: power is the sum of channels {summed}", highlight=False)
        for row in rows:
            if row.get("topics"):
                _print_topics(Path(str(row["file"])).name, row["topics"])
    raise typer.Exit(report_skipped(skipped))


#: a bag's topics (log-format.md section 3)
TOPIC_COLUMNS = (Col("topic", "text", key=True), Col("type", "text"), Col("messages"), Col("Hz"))


def _print_topics(name: str, topics: list[dict[str, object]]) -> None:
    cells = [
        [
            str(t["topic"]),
            str(t["type"]),
            f"{t['messages']:,}",
            "-" if t["rate_Hz"] is None else f"{t['rate_Hz']:.4g}",
        ]
        for t in topics
    ]
    print_table(stdout, f"{name}: {len(topics)} topic(s)", TOPIC_COLUMNS, cells)


def _problems_cell(problems: list[str], shown: int = 2) -> str:
    if not problems:
        return "-"
    more = f"; and {len(problems) - shown} more (see stderr)" if len(problems) > shown else ""
    return "; ".join(problems[:shown]) + more


#: logs.parquet's columns: the keys of `inspect --json`, in its order (cli.md)
LOG_COLUMNS = (
    "file",
    "format",
    "run_id",
    "samples",
    "sample_period_s",
    "duration_s",
    "mean_power_W",
    "energy_J",
    "meta",
    "channels",
    "speed_column",
    "problems",
    "problem_details",
    "topics",
)


def _nested_types() -> dict[str, object]:
    """The Parquet types of the columns whose values nest (docs/cli-output.md, "-o DIR"):
    `meta` a struct of RunMeta's fields, the log's other metadata keys in `extra` (a map of
    text: a log's metadata holds whatever keys its file gives, as text); the lists as lists
    of structs, `problems` a list of text."""
    import pyarrow as pa

    text, number, count = pa.string(), pa.float64(), pa.int64()

    def rows_of(**fields: pa.DataType) -> pa.DataType:
        return pa.list_(pa.struct(list(fields.items())))

    meta = pa.struct(
        [
            ("run_id", text),
            ("mode", text),
            ("speed_mps", number),
            ("distance_m", number),
            ("steps", count),
            ("payload_kg", number),
            ("started_at", text),
            ("sample_period_s", number),
            ("extra", pa.map_(text, text)),
        ]
    )
    return {
        "meta": meta,
        "channels": rows_of(name=text, mean_power_W=number, energy_J=number),
        "problems": pa.list_(text),
        "problem_details": rows_of(kind=text, message=text, t_start_s=number, duration_s=number),
        "topics": rows_of(topic=text, type=text, messages=count, rate_Hz=number),
    }


def _meta_struct(meta: dict[str, object], fields: list[str]) -> dict[str, object]:
    """A row's `meta` as the struct's fields, its other keys (as text) in `extra`."""
    extra = [(str(k), str(v)) for k, v in meta.items() if k not in fields]
    return {**{k: meta.get(k) for k in fields}, "extra": extra}


def write_inspection(rows: list[dict[str, object]], out: Path) -> list[Path]:
    """`inspect -o DIR`: `logs.parquet`, a row per log read, the `--json` keys as columns,
    the nested ones (`meta`, `channels`, `problems`, `problem_details`, `topics`) as Parquet
    structs and lists (`_nested_types`), written with `outputs.write_set`."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from wifibot_power.outputs import write_set

    nested = _nested_types()
    flat = {
        "file": pa.string(),
        "format": pa.string(),
        "run_id": pa.string(),
        "samples": pa.int64(),
        "sample_period_s": pa.float64(),
        "duration_s": pa.float64(),
        "mean_power_W": pa.float64(),
        "energy_J": pa.float64(),
        "speed_column": pa.bool_(),
    }
    schema = pa.schema([(key, flat.get(key) or nested[key]) for key in LOG_COLUMNS])
    meta_fields = [f.name for f in nested["meta"] if f.name != "extra"]
    columns = {key: [row.get(key) for row in rows] for key in LOG_COLUMNS}
    columns["meta"] = [_meta_struct(dict(m or {}), meta_fields) for m in columns["meta"]]
    columns["topics"] = [t or [] for t in columns["topics"]]
    table = pa.table(columns, schema=schema)
    return write_set(out, {"logs.parquet": lambda path: pq.write_table(table, path)})
