"""What every command shares: reading options (declared once), error handling, output."""

from __future__ import annotations

import contextvars
import functools
import inspect
import os
import sys
import typing
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, TypeVar

import typer

from wifibot_power.cli import consoles
from wifibot_power.cli.json_document import (  # noqa: F401 - re-exported: importers use common
    DOCUMENT,
    JsonDocument,
    json_defaults,
    json_usage_error,
    print_json,
)
from wifibot_power.cli.json_document import one_line as _one_line
from wifibot_power.cli.progress import (  # noqa: F401 - re-exported: importers use common
    progress,
    progress_done,
    progress_on,
    stage,
)
from wifibot_power.errors import UsageError, WbpowerError
from wifibot_power.io import ReadOptions, Skipped
from wifibot_power.outputs import probe_folder, written
from wifibot_power.run import Problem
from wifibot_power.signals import interrupted

if TYPE_CHECKING:
    from rich.console import Console

    from wifibot_power.cache import ParseCache

EXIT_OK = 0
EXIT_SKIPPED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report a command stopped by Ctrl-C


#: `stdout` and `stderr`: the rich consoles human output is drawn on (`cli.consoles`, made on
#: first use: `--json` output and one-line messages need neither).
stdout: Console
stderr: Console


def __getattr__(name: str) -> object:
    if name in ("stdout", "stderr"):
        return getattr(consoles, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# -- reading options: every command that reads logs takes these (cli.md) --------------
SupplyVoltage = Annotated[
    float | None,
    typer.Option(
        "--supply-voltage", metavar="V", help="Supply voltage [V], > 0: power = current x V."
    ),
]
CurrentColumn = Annotated[
    str | None,
    typer.Option("--current-column", metavar="NAME", help="Name of the current column to use."),
]
VoltageColumn = Annotated[
    str | None,
    typer.Option("--voltage-column", metavar="NAME", help="Name of the voltage column to use."),
]
SpeedColumn = Annotated[
    str | None,
    typer.Option(
        "--speed-column",
        metavar="NAME",
        help="Name of the speed column [m/s] (default: speed_mps, if any).",
    ),
]
PowerColumn = Annotated[
    list[str] | None,
    typer.Option(
        "--power-column",
        metavar="NAME",
        help="Name of a power column; repeat it to sum several (two motors).",
    ),
]
YawRateColumn = Annotated[
    str | None,
    typer.Option(
        "--yaw-rate-column",
        metavar="NAME",
        help="Name of the rate-of-turn column [rad/s] (default: yaw_rate_radps, if any).",
    ),
]
TrackWidth = Annotated[
    float | None,
    typer.Option(
        "--track-width",
        metavar="M",
        help="Track width [m], > 0, turning speed_left_mps/speed_right_mps into a rate of turn.",
    ),
]
TimeColumn = Annotated[
    str | None,
    typer.Option(
        "--time-column", metavar="NAME", help="Name of the time column (see --time-unit)."
    ),
]


class TimeUnit(StrEnum):
    s = "s"
    ms = "ms"
    us = "us"


TimeUnitOption = Annotated[
    TimeUnit | None,
    typer.Option(
        "--time-unit",
        metavar="s|ms|us",
        help="Unit of the time column, when its name does not say.",
    ),
]
FlipCurrent = Annotated[
    bool,
    typer.Option("--flip-current", help="Negate the current (and power): a reversed sensor."),
]
MaxPower = Annotated[
    float | None,
    typer.Option(
        "--max-power",
        metavar="W",
        help="The most the robot can draw [W], > 0: above it a reading is an error (a unit "
        "mistake); wins over the logs' max_power_W metadata.",
    ),
]
SamplePeriod = Annotated[
    float | None,
    typer.Option(
        "--sample-period", metavar="S", help="Sample spacing [s], > 0, for logs without time."
    ),
]
PowerTopic = Annotated[
    str | None,
    typer.Option(
        "--power-topic",
        metavar="TOPIC",
        help="A bag's power topic: BatteryState (P = V x -I), or Float32/64 in W "
        "(default: the one BatteryState topic).",
    ),
]
CurrentTopic = Annotated[
    str | None,
    typer.Option(
        "--current-topic",
        metavar="TOPIC",
        help="A bag's current topic (Float32/64 in A, draw > 0).",
    ),
]
VoltageTopic = Annotated[
    str | None,
    typer.Option(
        "--voltage-topic", metavar="TOPIC", help="A bag's voltage topic (Float32/64 in V)."
    ),
]
SpeedTopic = Annotated[
    str | None,
    typer.Option(
        "--speed-topic",
        metavar="TOPIC",
        help="A bag's speed and yaw-rate topic: Odometry, or a Twist such as cmd_vel (read as "
        "commanded) (default: the one Odometry topic).",
    ),
]
JsonFlag = Annotated[bool, typer.Option("--json", help="Print one JSON document on stdout.")]


def out_dir(files: str) -> object:
    """The `-o/--out DIR` option of a command, its help naming the files it writes there
    (`tests/test_cli_summaries.py` checks each file written is named)."""
    return Annotated[
        Path | None,
        typer.Option(
            "-o", "--out", metavar="DIR", help=f"Also write {files} into DIR (made if missing)."
        ),
    ]


ModelSpec = Annotated[
    str,
    typer.Option(
        "--model", metavar="paper|FILE", help="'paper' (the paper's coefficients) or a model.json."
    ),
]


#: the reading options, as (parameter name, annotated type, default): one declaration for
#: every command
READING_OPTIONS = (
    ("supply_voltage", SupplyVoltage, None),
    ("max_power", MaxPower, None),
    ("current_column", CurrentColumn, None),
    ("voltage_column", VoltageColumn, None),
    ("power_column", PowerColumn, None),
    ("time_column", TimeColumn, None),
    ("time_unit", TimeUnitOption, None),
    ("speed_column", SpeedColumn, None),
    ("yaw_rate_column", YawRateColumn, None),
    ("track_width", TrackWidth, None),
    ("sample_period", SamplePeriod, None),
    ("flip_current", FlipCurrent, False),
    ("power_topic", PowerTopic, None),
    ("current_topic", CurrentTopic, None),
    ("voltage_topic", VoltageTopic, None),
    ("speed_topic", SpeedTopic, None),
)


def read_options(
    supply_voltage: float | None = None,
    max_power: float | None = None,
    current_column: str | None = None,
    voltage_column: str | None = None,
    power_column: list[str] | None = None,
    time_column: str | None = None,
    time_unit: TimeUnit | str | None = None,
    speed_column: str | None = None,
    yaw_rate_column: str | None = None,
    track_width: float | None = None,
    sample_period: float | None = None,
    flip_current: bool = False,
    power_topic: str | None = None,
    current_topic: str | None = None,
    voltage_topic: str | None = None,
    speed_topic: str | None = None,
) -> ReadOptions:
    return ReadOptions(
        supply_voltage_V=supply_voltage,
        max_power_W=max_power,
        current_column=current_column,
        voltage_column=voltage_column,
        sample_period_s=sample_period,
        speed_column=speed_column,
        power_columns=tuple(power_column or ()),
        time_column=time_column,
        time_unit=TimeUnit(time_unit).value if time_unit is not None else None,
        flip_current=bool(flip_current),
        power_topic=power_topic,
        current_topic=current_topic,
        voltage_topic=voltage_topic,
        speed_topic=speed_topic,
        yaw_rate_column=yaw_rate_column,
        track_width_m=track_width,
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
    """Library errors become one line on stderr and exit 2; never a traceback. With
    `--json` (a `json_out` parameter), the command's one JSON document (`JsonDocument`) is
    printed on stdout however it ends: its result, or the error, with what was skipped and
    every warning said (cli.md).

    Set WBPOWER_DEBUG=1 to see the traceback of an unexpected error.
    """

    @functools.wraps(command)
    def wrapper(*args: object, **kwargs: object) -> object:
        written.clear()  # (several commands may run in one process: tests)
        document = JsonDocument() if kwargs.get("json_out") else None
        token = DOCUMENT.set(document)
        said = _SAID_WRITTEN.set([])
        problem_files, problems_left = _PROBLEM_FILES.set({}), _PROBLEMS_LEFT.set({})
        try:
            return _reporting_errors(_saying_written(command), *args, **kwargs)
        finally:
            progress_done()
            _say_problems_left()
            DOCUMENT.reset(token)
            _SAID_WRITTEN.reset(said)
            _PROBLEM_FILES.reset(problem_files)
            _PROBLEMS_LEFT.reset(problems_left)
            if document is not None:
                document.emit()

    return wrapper  # type: ignore[return-value]


def _saying_written(command: Callable[..., object]) -> Callable[..., object]:
    """`command`, then every file (or folder) it wrote in full (`outputs.written`) said once
    (`say_written`), when it ends with its result or its exit code; a Ctrl-C says what was
    written in its own line (`signals.interrupted`)."""

    def run(*args: object, **kwargs: object) -> object:
        try:
            result = command(*args, **kwargs)
        except (typer.Exit, SystemExit):
            say_written(written)
            raise
        say_written(written)
        return result

    return run


def _reporting_errors(command: Callable[..., object], *args: object, **kwargs: object) -> object:
    try:
        return command(*args, **kwargs)
    except WbpowerError as exc:
        # a batch that failed as a whole still says why each input was left out
        report_skipped(list(getattr(exc, "skipped", ())))
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


# -- output: the --json document (`cli/json_document.py`), -o DIR, errors, warnings ---------
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
    """Print `wbpower: error: message` on stderr (one line) and exit; with `--json`, the
    message is the document's `error`."""
    one_line = _one_line(message)
    document = DOCUMENT.get()
    if document is not None:
        document.error = one_line
    print(f"wbpower: error: {one_line}", file=sys.stderr)
    raise typer.Exit(code)


#: the outputs said written so far by the running command (`say_written`)
_SAID_WRITTEN: contextvars.ContextVar[list[str]] = contextvars.ContextVar("said_written")


def say_written(paths: Iterable[Path | str]) -> None:
    """Say each output written, once: `wbpower: wrote PATH` on stderr, and in the `--json`
    document's `written` (docs/cli-output.md, "-o DIR"). `handles_errors` says every file
    of `outputs.written` (`write_set`, `staged_folder`) when the command ends
    (`_saying_written`)."""
    said = _SAID_WRITTEN.get(None)
    document = DOCUMENT.get()
    for path in map(str, paths):
        if said is not None:
            if path in said:
                continue
            said.append(path)
        if document is not None:
            document.written.append(path)
        print(f"wbpower: wrote {path}", file=sys.stderr)


def warn(message: str) -> None:
    """A warning: one line on stderr, and in the `--json` document's `warnings`."""
    one_line = _one_line(message)
    document = DOCUMENT.get()
    if document is not None and one_line not in document.warnings:
        document.warnings.append(one_line)
    print(f"wbpower: warning: {one_line}", file=sys.stderr)


#: problems of one kind said one by one per file; the rest in one line (`warn_problems`)
PROBLEMS_SAID = 3
#: files whose problems of a kind are said; those of later files are counted, and said in
#: one line per kind when the command ends (`_say_problems_left`)
PROBLEM_FILES_SAID = 3
#: kinds said for every file whatever the batch: each names the other file it concerns
EVERY_FILE_KINDS = frozenset({"duplicate"})


@dataclass
class _ProblemsLeft:
    """Problems of one kind in the files after the first `PROBLEM_FILES_SAID` of a batch."""

    files: int = 0
    problems: int = 0
    duration_s: float = 0.0
    #: the first such file and its problems: said as any file's when it is the only one
    first: tuple[str, list[Problem]] | None = None


#: kind -> the files with problems of that kind said so far, and what was left unsaid
_PROBLEM_FILES: contextvars.ContextVar[dict[str, set[str]] | None] = contextvars.ContextVar(
    "problem_files", default=None
)
_PROBLEMS_LEFT: contextvars.ContextVar[dict[str, _ProblemsLeft] | None] = contextvars.ContextVar(
    "problems_left", default=None
)


def warn_problems(file: str, problems: tuple[Problem, ...]) -> None:
    """What reading a log found but did not stop it (short gaps): a warning line each on
    stderr, naming the file (as `inspect` prints them), the first `PROBLEMS_SAID` of each
    kind, then one line for the rest of that kind with their count and time in all (a field
    logger's hour of 20 Hz drop-outs made ~120 lines a file). In a batch, only the first
    `PROBLEM_FILES_SAID` files with problems of a kind are said so; the others' are counted
    and said in one line per kind when the command ends (200 field logs made 800 lines).
    Every one stays in `inspect --json`'s `problems`."""
    by_kind: dict[str, list[Problem]] = {}
    for problem in problems:
        by_kind.setdefault(problem.kind, []).append(problem)
    said_files = _PROBLEM_FILES.get()
    left = _PROBLEMS_LEFT.get()
    for kind, items in by_kind.items():
        if said_files is not None and left is not None and kind not in EVERY_FILE_KINDS:
            files = said_files.setdefault(kind, set())
            if file not in files and len(files) >= PROBLEM_FILES_SAID:
                tally = left.setdefault(kind, _ProblemsLeft())
                tally.first = tally.first or (file, items)
                tally.files += 1
                tally.problems += len(items)
                tally.duration_s += sum(p.duration_s or 0.0 for p in items)
                continue
            files.add(file)
        _say_file_problems(file, kind, items)


def _say_file_problems(file: str, kind: str, items: list[Problem]) -> None:
    """A file's problems of one kind: the first `PROBLEMS_SAID`, then one line for the rest."""
    for problem in items[:PROBLEMS_SAID]:
        warn(f"{file}: {problem.message}")
    rest = items[PROBLEMS_SAID:]
    if rest:
        durations = [p.duration_s for p in rest if p.duration_s is not None]
        in_all = f", {sum(durations):.4g} s in all" if durations else ""
        warn(
            f"{file}: and {len(rest)} more of kind '{kind}' like these{in_all} (each in "
            "'wbpower inspect FILE --json', problems)"
        )


def _say_problems_left() -> None:
    """One warning per kind for the problems `warn_problems` counted and did not say (one
    file's are said as any file's: a count would say less in as many lines)."""
    for kind, tally in (_PROBLEMS_LEFT.get() or {}).items():
        if tally.files == 1 and tally.first is not None:
            _say_file_problems(tally.first[0], kind, tally.first[1])
            continue
        in_all = f", {tally.duration_s:.4g} s in all" if tally.duration_s > 0 else ""
        warn(
            f"and {tally.problems} more problem(s) of kind '{kind}' in {tally.files} more "
            f"file(s){in_all} (each file's in 'wbpower inspect FILE --json', problems)"
        )


def report_skipped(skipped: list[Skipped]) -> int:
    """List skipped inputs on stderr, each with its own reason, and in the `--json`
    document's `skipped`; the exit code per cli.md."""
    document = DOCUMENT.get()
    for item in skipped:
        if document is not None and item.as_dict() not in document.skipped:
            document.skipped.append(item.as_dict())
        print(f"wbpower: skipped: {_one_line(item.reason)}", file=sys.stderr)
    return EXIT_SKIPPED if skipped else EXIT_OK


# -- batch options: parallel files and the parse cache ----------------------------------
Jobs = Annotated[
    int,
    typer.Option(
        "--jobs",
        "-j",
        min=0,
        metavar="N",
        help="Files processed in parallel (worker processes); 0 = all cores.",
    ),
]
CacheDir = Annotated[
    Path | None,
    typer.Option(
        "--cache",
        metavar="DIR",
        help="Keep parsed logs as Parquet in DIR so a second run skips parsing unchanged "
        "files (keyed by content; see 'wbpower docs benchmarks').",
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
