"""Tables that never cut a number, whatever the terminal's width (docs/cli-output.md).

rich shrinks a table that is wider than the terminal by cutting cells ("3.98…"). Here a
table is described as columns and rows of strings, and laid out for the width at hand:

- a *number* column (`Col(kind="num")`, the default) is exactly as wide as its widest cell
  (and its header's longest word), so no cell wraps or is cut; its header wraps at spaces
  ("1-step / energy J");
- a *text* column (`kind="text"`: file names, notes, evidence) folds onto more lines, at
  spaces: it is never narrower than its longest word, so a name is never broken mid-word;
- a column marked `once` whose every row holds the same value is not drawn: it is said
  once, in the caption ("format: wbpower-csv"), so many rows of one kind stay compact;
- when the number columns still do not fit, the table is split: the columns that do not fit
  move, in their order, to a second table (a third, ...) that repeats the *key* columns
  (`key=True`, e.g. the run or the parameter) so each row can still be read across.

`--wide` (every command that prints a table) keeps one table with every column, however
wide: the terminal then wraps the lines, or `less -S` scrolls them.
"""

from __future__ import annotations

import contextvars
import functools
import inspect
import typing
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Literal, TypeVar

import typer

if TYPE_CHECKING:  # rich loads when a table is drawn: `--json` output never needs it
    from rich.console import Console
    from rich.table import Table

#: Whether `--wide` was given to the running command.
WIDE: contextvars.ContextVar[bool] = contextvars.ContextVar("wide", default=False)
#: Whether the running command prints its tables as Markdown (`fit --markdown`).
MARKDOWN: contextvars.ContextVar[bool] = contextvars.ContextVar("markdown", default=False)
#: Narrowest a text column is planned at (it folds below its natural width).
TEXT_MIN_WIDTH = 12

WideFlag = Annotated[
    bool,
    typer.Option("--wide", help="All columns in one table, however wide (default: split to fit)."),
]


@dataclass(frozen=True)
class Col:
    """A column: its header, `num` (never cut) or `text` (folds), and whether it is a key
    repeated in every part of a split table."""

    name: str
    kind: Literal["num", "text"] = "num"
    key: bool = False
    justify: Literal["left", "right", "center"] | None = None
    #: said once in the caption instead of drawn when every row (of two or more) holds the
    #: same value
    once: bool = False


def _border_width(n_columns: int) -> int:
    # rich's default box and padding: "│ " before each cell, " " after it, a closing "│"
    return 3 * n_columns + 1


def _natural_width(col: Col, cells: Sequence[str], whole_header: bool = False) -> int:
    """The width a column is planned at: a number column's widest cell (and its header's
    longest word, or all of its header with `whole_header`); a text column's up to
    `TEXT_MIN_WIDTH` (it folds), and never below its longest word (`_longest_word`)."""
    header = [col.name] if whole_header else col.name.split()
    longest_word = max((len(w) for w in header), default=1)
    longest_line = max((len(line) for cell in cells for line in cell.splitlines()), default=1)
    if col.kind == "num":
        return max(longest_word, longest_line)
    return max(longest_word, _longest_word(cells), min(longest_line, TEXT_MIN_WIDTH))


def _longest_word(cells: Sequence[str]) -> int:
    """A text column's longest word: it folds at spaces, never inside a word (a file name)."""
    return max((len(word) for cell in cells for word in cell.split()), default=1)


def _said_once(cols: Sequence[Col], rows: Sequence[Sequence[str]]) -> tuple[list[int], list[str]]:
    """The columns to draw, and what the `once` columns that hold one value say instead."""
    drawn, said = [], []
    for i, col in enumerate(cols):
        values = {row[i] for row in rows}
        if col.once and len(rows) > 1 and len(values) == 1:
            value = values.pop()
            said.append(f"{col.name}: {'none' if value == '-' else value}")
        else:
            drawn.append(i)
    return drawn, said


def plan(cols: Sequence[Col], rows: Sequence[Sequence[str]], width: int) -> list[list[int]]:
    """Column indices of each table: all in one when they fit in `width`, else the key
    columns plus as many others (in order) as fit, then the next table."""
    needed = [_natural_width(c, [row[i] for row in rows]) for i, c in enumerate(cols)]
    keys = [i for i, c in enumerate(cols) if c.key]
    others = [i for i, c in enumerate(cols) if not c.key]
    parts: list[list[int]] = []
    current: list[int] = list(keys)
    for index in others:
        trial = sorted([*current, index])
        fits = sum(needed[i] for i in trial) + _border_width(len(trial)) <= width
        if fits or len(current) == len(keys):  # a column alone too wide still gets a table
            current = trial
        else:
            parts.append(current)
            current = sorted([*keys, index])
    parts.append(current)
    return parts


def tables(
    title: str,
    cols: Sequence[Col],
    rows: Sequence[Sequence[str]],
    *,
    width: int,
    wide: bool = False,
    caption: str | None = None,
    row_styles: Sequence[str | None] | None = None,
) -> list[Table]:
    """The rich table(s) showing `rows` under `cols` in `width` columns (see the module).
    Cells are plain text, never rich markup: a term of one surface, "rolling_W_per_mps[grass]",
    or a file or run id with brackets is shown as it is (as a string, rich took "[grass]" for
    a style and dropped it)."""
    from rich.table import Table
    from rich.text import Text

    drawn, said = _said_once(cols, rows)
    if said:
        caption = "; ".join([*said, *([caption] if caption else [])])
        cols = [cols[i] for i in drawn]
        rows = [[row[i] for i in drawn] for row in rows]
    parts = [list(range(len(cols)))] if wide else plan(cols, rows, width)
    out = []
    for number, part in enumerate(parts, start=1):
        # headers on one line when the part is narrow enough for it, else wrapped at spaces
        whole = wide or (
            sum(_natural_width(cols[i], [r[i] for r in rows], True) for i in part)
            + _border_width(len(part))
            <= width
        )
        suffix = f" ({number}/{len(parts)})" if len(parts) > 1 else ""
        table = Table(title=f"{title}{suffix}", title_justify="left")
        for i in part:
            col = cols[i]
            cells = [row[i] for row in rows]
            justify = col.justify or ("right" if col.kind == "num" else "left")
            if col.kind == "num":
                # exactly as wide as its widest cell, so no cell wraps or is cut; the header
                # (not no_wrap) wraps at its spaces instead
                table.add_column(col.name, justify=justify, width=_natural_width(col, cells, whole))
            else:  # folds at spaces; never narrower than a word
                table.add_column(
                    col.name, justify=justify, overflow="fold", min_width=_longest_word(cells)
                )
        for k, row in enumerate(rows):
            style = row_styles[k] if row_styles else None
            table.add_row(*(Text(row[i]) for i in part), style=style)
        if number == len(parts) and caption:
            table.caption = caption
            table.caption_justify = "left"
        out.append(table)
    return out


def print_table(
    console: Console,
    title: str,
    cols: Sequence[Col],
    rows: Sequence[Sequence[str]],
    *,
    caption: str | None = None,
    row_styles: Sequence[str | None] | None = None,
    notes: str | None = None,
) -> None:
    """Print the table(s) for the console's width; with `--wide`, one table at its full width
    (wider than the terminal if it must be); with `MARKDOWN`, one Markdown table. `notes`
    (long text: reasons a line each) follow the table at the console's width: a caption
    wraps to the table's own width, which made a few reasons 20 lines of 54 columns."""
    if MARKDOWN.get():
        text = markdown_table(title, cols, rows, caption=caption)
        console.print(text, markup=False, highlight=False, soft_wrap=True)
        if notes:
            console.print(notes, markup=False, highlight=False, soft_wrap=True)
        return
    _print_tables(console, title, cols, rows, caption, row_styles)
    if notes:
        console.print(notes, markup=False, highlight=False)


def _print_tables(
    console: Console,
    title: str,
    cols: Sequence[Col],
    rows: Sequence[Sequence[str]],
    caption: str | None,
    row_styles: Sequence[str | None] | None,
) -> None:
    """The table(s) of `print_table` in a terminal."""
    wide = WIDE.get()
    made = tables(
        title, cols, rows, width=console.width, wide=wide, caption=caption, row_styles=row_styles
    )
    for table in made:
        if not wide:
            console.print(table)
            continue
        # the console itself made wider for this table (print(width=) only narrows)
        needed = table.__rich_measure__(console, console.options.update_width(10**4)).maximum
        width = console.width
        console.width = max(needed, width)
        try:
            console.print(table)
        finally:
            console.width = width


_MARKDOWN_ALIGN = {"left": "---", "right": "---:", "center": ":---:"}


def markdown_table(
    title: str, cols: Sequence[Col], rows: Sequence[Sequence[str]], caption: str | None = None
) -> str:
    """One table as Markdown (GitHub's pipe tables), to paste into a paper or a report: the
    title in bold above it, the caption below; numbers right-aligned as in the terminal."""

    def cell(text: str) -> str:
        return " ".join(str(text).split()).replace("|", "\\|")

    def align(col: Col) -> str:
        return _MARKDOWN_ALIGN[col.justify or ("left" if col.kind == "text" else "right")]

    lines = [f"**{cell(title)}**", ""]
    lines.append("| " + " | ".join(cell(c.name) for c in cols) + " |")
    lines.append("| " + " | ".join(align(c) for c in cols) + " |")
    lines += ["| " + " | ".join(cell(x) for x in row) + " |" for row in rows]
    for line in (caption or "").splitlines():  # each line of the caption a paragraph
        if line.strip():
            lines += ["", cell(line)]
    return "\n".join(lines) + "\n"


F = TypeVar("F", bound=Callable[..., object])


def with_wide_option(command: F) -> F:
    """Give a command the `--wide` option; while it runs, `WIDE` holds its value."""
    signature = inspect.signature(command)
    hints = typing.get_type_hints(command, include_extras=True)
    kept = [
        p.replace(annotation=hints.get(p.name, p.annotation)) for p in signature.parameters.values()
    ]
    added = inspect.Parameter(
        "wide", inspect.Parameter.KEYWORD_ONLY, default=False, annotation=WideFlag
    )

    @functools.wraps(command)
    def wrapper(*args: object, wide: bool = False, **kwargs: object) -> object:
        token = WIDE.set(wide)
        try:
            return command(*args, **kwargs)
        finally:
            WIDE.reset(token)

    wrapper.__signature__ = signature.replace(parameters=[*kept, added])  # type: ignore[attr-defined]
    wrapper.__annotations__ = {**hints, "wide": WideFlag}
    if hasattr(wrapper, "__wrapped__"):
        del wrapper.__wrapped__  # typer must see the new signature, not the wrapped one
    return wrapper  # type: ignore[return-value]
