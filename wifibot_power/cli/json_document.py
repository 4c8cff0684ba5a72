"""The one JSON document a command prints with `--json`, however it ends (cli.md): the
document (`JsonDocument`), the running command's document (`DOCUMENT`, set by
`common.handles_errors`) and the functions that fill or print it. `cli.common` re-exports the
public names; its `fail`, `warn`, `say_written` and `report_skipped` fill the document too."""

from __future__ import annotations

import contextvars
import json
import sys
from dataclasses import dataclass, field

from wifibot_power.outputs import dumps_indented, json_safe


def one_line(message: object) -> str:
    return " ".join(str(message).split())


@dataclass
class JsonDocument:
    """The one JSON document a command prints with `--json`, whatever happens (cli.md): what
    it computed (`print_json`), `error` (the one-line message, null on success), `skipped`
    (`[{file, reason}]`, every input left out) and `warnings` (every warning said on
    stderr, the reader's included). `handles_errors` makes one per `--json` run and prints
    it when the command ends, returns or fails; `fail`, `warn` and `report_skipped` fill it.
    """

    #: keys the document holds also when the command fails (`json_defaults`)
    defaults: dict[str, object] = field(default_factory=dict)
    #: what the command computed (`print_json`), None until it has
    result: dict[str, object] | None = None
    error: str | None = None
    skipped: list[dict[str, str]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    #: every output written (`say_written`): the document's `written`, when there is one
    written: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, object]:
        result = self.result or {}
        skipped = list(result.get("skipped") or [])
        skipped += [s for s in self.skipped if s not in skipped]
        warnings = [str(w) for w in result.get("warnings") or []]
        said = {one_line(w) for w in warnings}
        warnings += [w for w in self.warnings if w not in said]
        document = {
            **self.defaults,
            **result,
            "error": self.error,
            "skipped": skipped,
            "warnings": warnings,
        }
        if self.written:  # only with -o or --plot: a run that writes nothing has no key
            document["written"] = list(self.written)
        return document

    def emit(self) -> None:
        write_json(self.as_dict())


DOCUMENT: contextvars.ContextVar[JsonDocument | None] = contextvars.ContextVar(
    "json_document", default=None
)


def json_defaults(**keys: object) -> None:
    """Keys the `--json` document holds also if the command fails from here on (e.g.
    `inspect`'s empty `logs`); nothing without `--json`."""
    document = DOCUMENT.get()
    if document is not None:
        document.defaults.update(keys)


def print_json(data: dict[str, object]) -> None:
    """The command's result as its one JSON document on stdout: printed when the command
    ends, with `error`, `skipped` and `warnings` (`JsonDocument`); at once outside a
    command."""
    document = DOCUMENT.get()
    if document is None:
        write_json(data)
    else:
        # encoded once inside the command (json's C encoder, leaves `json_safe` converts):
        # a value JSON cannot hold is the command's error (one line, exit 2), never a
        # traceback from printing the document at the end, which makes it JSON-safe
        # (`dumps_indented`); kept as it is, not copied (a fit's is 16,000 held-out trips)
        try:
            json.dumps(data, default=_leaf)
        except TypeError:  # a key json's encoder refuses (json_safe makes it a string)?
            json.dumps(json_safe(data), allow_nan=False)
        document.result = data


def _leaf(value: object) -> object:
    """What `json_safe` makes of a value json's encoder cannot hold (a numpy scalar or array,
    a path, a date), or TypeError as json raises it."""
    safe = json_safe(value)
    # what json_safe makes of it is printed as it is (`dumps_indented`): a leaf it leaves
    # unplain (np.datetime64's datetime) fails now, as it would at the end
    if safe is value or not isinstance(safe, str | int | float | list | dict | None):
        raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")
    return safe


def write_json(data: object) -> None:
    sys.stdout.write(dumps_indented(data) + "\n")


def json_usage_error(message: str) -> None:
    """A usage error found while parsing the command line (before the command runs), as
    the `--json` document: `fail` prints the line on stderr."""
    write_json({"error": one_line(message), "skipped": [], "warnings": []})
