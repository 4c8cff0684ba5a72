"""What every command shares: reading options (declared once), error handling, output."""

from __future__ import annotations

import functools
import json
import os
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Annotated, TypeVar

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from wifibot_power.errors import WbpowerError
from wifibot_power.io import ReadOptions, Skipped
from wifibot_power.outputs import json_safe

EXIT_OK = 0
EXIT_SKIPPED = 1
EXIT_USAGE = 2

stdout = Console(soft_wrap=False, width=None if sys.stdout.isatty() else 200)
stderr = Console(stderr=True, soft_wrap=True)

# -- reading options: every command that reads logs takes these (cli.md) --------------
SupplyVoltage = Annotated[
    float | None,
    typer.Option("--supply-voltage", min=0.0, help="Supply voltage [V]: power = current x V."),
]
CurrentColumn = Annotated[
    str | None, typer.Option("--current-column", help="Name of the current column to use.")
]
VoltageColumn = Annotated[
    str | None, typer.Option("--voltage-column", help="Name of the voltage column to use.")
]
SamplePeriod = Annotated[
    float | None,
    typer.Option("--sample-period", min=0.0, help="Sample spacing [s] for logs without time."),
]
JsonFlag = Annotated[bool, typer.Option("--json", help="Print one JSON document on stdout.")]
OutDir = Annotated[
    Path | None, typer.Option("-o", "--out", help="Write the tables (Parquet, JSON) into DIR.")
]
ModelSpec = Annotated[
    str, typer.Option("--model", help="'paper' (the paper's coefficients) or a model.json.")
]


def read_options(
    supply_voltage: float | None,
    current_column: str | None,
    voltage_column: str | None,
    sample_period: float | None,
) -> ReadOptions:
    return ReadOptions(
        supply_voltage_V=supply_voltage,
        current_column=current_column,
        voltage_column=voltage_column,
        sample_period_s=sample_period,
    )


F = TypeVar("F", bound=Callable[..., object])


def handles_errors(command: F) -> F:
    """Library errors become one line on stderr and exit 2; never a traceback.

    Set WBPOWER_DEBUG=1 to see the traceback of an unexpected error.
    """

    @functools.wraps(command)
    def wrapper(*args: object, **kwargs: object) -> object:
        try:
            return command(*args, **kwargs)
        except WbpowerError as exc:
            fail(exc.one_line())
        except KeyboardInterrupt:
            fail("interrupted")
        except (typer.Exit, typer.Abort, SystemExit):
            raise
        except Exception as exc:  # noqa: BLE001 - the promise is: no traceback, ever
            if os.environ.get("WBPOWER_DEBUG"):
                raise
            fail(f"internal error: {exc.__class__.__name__}: {exc} (please report it; "
                 "WBPOWER_DEBUG=1 shows the traceback)")
        return None

    return wrapper  # type: ignore[return-value]


def fail(message: str, code: int = EXIT_USAGE) -> None:
    """Print `wbpower: error: message` on stderr (one line) and exit."""
    one_line = " ".join(str(message).split())
    print(f"wbpower: error: {one_line}", file=sys.stderr)
    raise typer.Exit(code)


def warn(message: str) -> None:
    print(f"wbpower: warning: {' '.join(str(message).split())}", file=sys.stderr)


def print_json(data: object) -> None:
    """The one JSON document on stdout."""
    sys.stdout.write(json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n")


def report_skipped(skipped: list[Skipped]) -> int:
    """List skipped inputs on stderr; the exit code per cli.md."""
    for item in skipped:
        print(f"wbpower: skipped: {' '.join(item.reason.split())}", file=sys.stderr)
    return EXIT_SKIPPED if skipped else EXIT_OK


T = TypeVar("T")


def progress(items: list[T], label: str, total_bytes: int | None = None) -> Iterable[T]:
    """A rich progress bar on stderr (files done, MB/s); silent when stderr is not a terminal."""
    if not sys.stderr.isatty() or len(items) < 2:
        yield from items
        return
    columns = [TextColumn(f"[bold]{label}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()]
    with Progress(*columns, console=stderr, transient=True) as bar:
        task = bar.add_task(label, total=len(items))
        for item in items:
            yield item
            bar.advance(task)
