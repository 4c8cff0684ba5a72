"""What every command shares: reading options (declared once), error handling, output."""

from __future__ import annotations

import functools
import inspect
import json
import os
import sys
import typing
from collections.abc import Callable, Iterable
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, TypeVar

import typer

from wifibot_power.errors import UsageError, WbpowerError
from wifibot_power.io import ReadOptions, Skipped
from wifibot_power.outputs import json_safe, probe_folder, written
from wifibot_power.run import Problem
from wifibot_power.signals import interrupted

if TYPE_CHECKING:
    from rich.console import Console

    from wifibot_power.cache import ParseCache

EXIT_OK = 0
EXIT_SKIPPED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a command stopped by Ctrl-C


def _console(name: str) -> Console:
    from rich.console import Console

    if name == "stdout":
        # a pipe gets wide tables (not rich's 80 columns), whatever COLUMNS the environment has
        return Console(soft_wrap=False, width=None if sys.stdout.isatty() else 200)
    return Console(stderr=True, soft_wrap=True)


#: `stdout` and `stderr`: the rich consoles human output is drawn on, made (and rich
#: imported, ~40 ms) on first use: `--json` output and one-line messages need neither.
stdout: Console
stderr: Console


def __getattr__(name: str) -> object:
    if name in ("stdout", "stderr"):
        console = globals()[name] = _console(name)
        return console
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
SpeedColumn = Annotated[
    str | None,
    typer.Option(
        "--speed-column", help="Name of the speed column [m/s] (default: speed_mps, if any)."
    ),
]
PowerColumn = Annotated[
    list[str] | None,
    typer.Option(
        "--power-column", help="Name of a power column; repeat it to sum several (two motors)."
    ),
]
TimeColumn = Annotated[
    str | None, typer.Option("--time-column", help="Name of the time column (see --time-unit).")
]


class TimeUnit(StrEnum):
    s = "s"
    ms = "ms"
    us = "us"


TimeUnitOption = Annotated[
    TimeUnit | None,
    typer.Option("--time-unit", help="Unit of the time column, when its name does not say."),
]
FlipCurrent = Annotated[
    bool,
    typer.Option("--flip-current", help="Negate the current (and power): a reversed sensor."),
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


#: the reading options, as (parameter name, annotated type, default): one declaration for
#: every command
READING_OPTIONS = (
    ("supply_voltage", SupplyVoltage, None),
    ("current_column", CurrentColumn, None),
    ("voltage_column", VoltageColumn, None),
    ("power_column", PowerColumn, None),
    ("time_column", TimeColumn, None),
    ("time_unit", TimeUnitOption, None),
    ("speed_column", SpeedColumn, None),
    ("sample_period", SamplePeriod, None),
    ("flip_current", FlipCurrent, False),
)


def read_options(
    supply_voltage: float | None = None,
    current_column: str | None = None,
    voltage_column: str | None = None,
    power_column: list[str] | None = None,
    time_column: str | None = None,
    time_unit: TimeUnit | str | None = None,
    speed_column: str | None = None,
    sample_period: float | None = None,
    flip_current: bool = False,
) -> ReadOptions:
    return ReadOptions(
        supply_voltage_V=supply_voltage,
        current_column=current_column,
        voltage_column=voltage_column,
        sample_period_s=sample_period,
        speed_column=speed_column,
        power_columns=tuple(power_column or ()),
        time_column=time_column,
        time_unit=TimeUnit(time_unit).value if time_unit is not None else None,
        flip_current=bool(flip_current),
    )


def with_reading_options(command: Callable[..., object]) -> Callable[..., object]:
    """Give a command the shared reading options (cli.md); it receives them as one
    `options: ReadOptions` parameter instead of one per option."""
    signature = inspect.signature(command)
    hints = typing.get_type_hints(command, include_extras=True)  # resolves string annotations
    kept = [
        p.replace(annotation=hints.get(p.name, p.annotation))
        for p in signature.parameters.values()
        if p.name != "options"
    ]
    added = [
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=kind)
        for name, kind, default in READING_OPTIONS
    ]

    @functools.wraps(command)
    def wrapper(*args: object, **kwargs: object) -> object:
        values = {name: kwargs.pop(name, default) for name, _, default in READING_OPTIONS}
        return command(*args, options=read_options(**values), **kwargs)

    wrapper.__signature__ = signature.replace(parameters=kept + added)  # type: ignore[attr-defined]
    wrapper.__annotations__ = {
        **{k: v for k, v in hints.items() if k != "options"},
        **{name: kind for name, kind, _ in READING_OPTIONS},
    }
    del wrapper.__wrapped__  # typer must see the new signature, not the wrapped one
    return wrapper


F = TypeVar("F", bound=Callable[..., object])

#: click's ClickException (typer >= 0.22 vendors click as typer._click, older typers import it)
_CLICK_ERROR: type[Exception] = next(
    c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException"
)


def handles_errors(command: F) -> F:
    """Library errors become one line on stderr and exit 2; never a traceback.

    Set WBPOWER_DEBUG=1 to see the traceback of an unexpected error.
    """

    @functools.wraps(command)
    def wrapper(*args: object, **kwargs: object) -> object:
        written.clear()  # (several commands may run in one process: tests)
        try:
            return command(*args, **kwargs)
        except WbpowerError as exc:
            fail(exc.one_line())
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM (`signals.Terminated`)
            fail(*interrupted(exc))
        except (typer.Exit, typer.Abort, SystemExit):
            raise
        except _CLICK_ERROR as exc:  # e.g. typer.BadParameter from an option's parser
            fail(exc.format_message())
        except OSError as exc:  # an output that cannot be written (disk full, read-only, ...)
            where = f"{exc.filename}: " if exc.filename else ""
            fail(f"{where}cannot write: {exc.strerror or exc} (check the path and free space)")
        except Exception as exc:  # noqa: BLE001 - the promise is: no traceback, ever
            if os.environ.get("WBPOWER_DEBUG"):
                raise
            fail(
                f"internal error: {exc.__class__.__name__}: {exc} (please report it; "
                "WBPOWER_DEBUG=1 shows the traceback)"
            )
        return None

    return wrapper  # type: ignore[return-value]


def check_out_dir(out: Path | None) -> None:
    """Refuse an `-o DIR` that cannot be written before any work is done (cli.md): an
    existing file, or a folder (or the nearest existing parent of one to create) that is not
    writable. Nothing is created here: a run that fails or is interrupted writes nothing."""
    if out is None:
        return
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise UsageError(
            f"-o {out}: is a file, not a folder", fix="give a folder to write the outputs into"
        )
    existing = next((p for p in (out, *out.absolute().parents) if p.exists()), None)
    if existing is None or not existing.is_dir():
        raise UsageError(f"-o {out}: {existing} is not a folder", fix="give another folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(
            f"-o {out}: {existing} is not writable", fix="give a folder you can write to"
        )
    probe_folder(out, existing)  # what access() cannot tell (/proc, /sys, a full inode table)


def fail(message: str, code: int = EXIT_USAGE) -> None:
    """Print `wbpower: error: message` on stderr (one line) and exit."""
    one_line = " ".join(str(message).split())
    print(f"wbpower: error: {one_line}", file=sys.stderr)
    raise typer.Exit(code)


def warn(message: str) -> None:
    print(f"wbpower: warning: {' '.join(str(message).split())}", file=sys.stderr)


def warn_problems(file: str, problems: tuple[Problem, ...]) -> None:
    """What reading a log found but did not stop it (short gaps): one warning
    line each on stderr, naming the file (as `inspect` prints them)."""
    for problem in problems:
        warn(f"{file}: {problem.message}")


def print_json(data: object) -> None:
    """The one JSON document on stdout."""
    sys.stdout.write(json.dumps(json_safe(data), indent=2, allow_nan=False) + "\n")


def report_skipped(skipped: list[Skipped]) -> int:
    """List skipped inputs on stderr; the exit code per cli.md."""
    for item in skipped:
        print(f"wbpower: skipped: {' '.join(item.reason.split())}", file=sys.stderr)
    return EXIT_SKIPPED if skipped else EXIT_OK


T = TypeVar("T")


def progress(items: list[T], label: str) -> Iterable[T]:
    """A progress bar over files (files done, MB/s) on stderr, for `map_runs(wrap=...)`;
    silent (a plain list) when stderr is not a terminal or there is a single file. rich
    loads only when a bar is drawn (`cli/progress_bar.py`)."""
    if not sys.stderr.isatty() or len(items) < 2:
        return items
    from wifibot_power.cli.progress_bar import FileProgress

    return FileProgress(items, label)


# -- batch options: parallel files and the parse cache ----------------------------------
Jobs = Annotated[
    int,
    typer.Option(
        "--jobs",
        "-j",
        min=0,
        help="Files processed in parallel (worker processes); 0 = all cores.",
    ),
]
CacheDir = Annotated[
    Path | None,
    typer.Option(
        "--cache",
        help="Keep parsed logs as Parquet in DIR so a second run skips parsing unchanged "
        "files (keyed by content; see docs/benchmarks.md).",
    ),
]


def parse_cache(directory: Path | None) -> ParseCache | None:
    """The `--cache DIR` cache (None without the option)."""
    if directory is None:
        return None
    from wifibot_power.cache import ParseCache  # pyarrow.parquet loads only when asked for

    return ParseCache(directory)


KeepDoubtful = Annotated[
    bool,
    typer.Option(
        "--keep-doubtful",
        help="Use runs whose segmentation is in doubt (left out and listed by default).",
    ),
]
