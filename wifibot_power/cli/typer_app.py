"""The Typer app every command module registers on."""

from __future__ import annotations

import sys
from typing import Annotated, Any

import typer
import typer.core

from wifibot_power import __version__

#: click's UsageError and NoArgsIsHelpError (typer >= 0.22 vendors click as typer._click,
#: older typers import it; NoArgsIsHelpError is click >= 8.2's)
_USAGE_ERROR: type[Exception] = next(
    c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError"
)
_NO_ARGS_IS_HELP: tuple[type[Exception], ...] = tuple(
    getattr(sys.modules[_USAGE_ERROR.__module__], name)
    for name in ("NoArgsIsHelpError",)
    if hasattr(sys.modules[_USAGE_ERROR.__module__], name)
)


def usage_line(exc: Exception, command: str) -> str:
    """click's usage error as wbpower's one line (cli.md: "A usage error is a usage error
    (exit 2, one line)"), the message `common.fail` prints after `wbpower: error: `:
    `no such option: --bogus (see 'wbpower fit --help')`, instead of click's Usage / Try /
    blank / Error block."""
    possibilities = sorted(getattr(exc, "possibilities", None) or ())  # of NoSuchOption
    text = exc.message if possibilities else exc.format_message()  # type: ignore[attr-defined]
    message = " ".join(text.split()).rstrip(".")
    if message[:1].isupper() and message[1:2].islower():  # "No such option", not "P_v ..."
        message = message[0].lower() + message[1:]
    hint = f"see '{command} --help'"
    if possibilities:
        hint = f"possible options: {', '.join(possibilities)}; {hint}"
    return f"{message} ({hint})"


class OneLineUsageGroup(typer.core.TyperGroup):
    """The root command: every usage error of every command (an unknown option, a bad value,
    a missing argument, an unknown command) is one line on stderr and exit 2. The one place
    they are caught: the root's own parse (`make_context`) and its subcommand's
    (`invoke`). `--help`, and `wbpower` alone (the command list), are unchanged."""

    def make_context(self, info_name: str | None, args: list[str], **extra: Any) -> Any:
        try:
            return super().make_context(info_name, args, **extra)
        except _NO_ARGS_IS_HELP:
            raise
        except _USAGE_ERROR as exc:
            self._fail(exc, info_name or "wbpower", wants_json(args))

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        command = super().get_command(ctx, cmd_name)
        if command is not None:
            plain_metavars(command)
        return command

    def resolve_command(self, ctx: Any, args: list[str]) -> Any:
        # remembered for an error raised without a context ("Option '--speed' requires an
        # argument"): the hint still names the subcommand
        ctx.meta["wbpower.command"] = f"{ctx.command_path} {args[0]}" if args else None
        ctx.meta["wbpower.json"] = wants_json(args[1:])
        return super().resolve_command(ctx, args)

    def invoke(self, ctx: Any) -> Any:
        try:
            return super().invoke(ctx)
        except _NO_ARGS_IS_HELP:
            raise
        except _USAGE_ERROR as exc:
            command = ctx.command_path
            resolved = ctx.meta.get("wbpower.command")
            failing = getattr(exc, "ctx", None)
            if failing is not None:
                command = failing.command_path
            elif resolved and self.get_command(ctx, resolved.rsplit(" ", 1)[-1]) is not None:
                command = resolved
            self._fail(exc, command, ctx.meta.get("wbpower.json", False))

    @staticmethod
    def _fail(exc: Exception, command: str, json_out: bool) -> None:
        # every command loads common: no start-up cost
        from wifibot_power.cli.common import fail, json_usage_error

        line = usage_line(exc, command)
        if json_out:  # cli.md: `--json` prints its one document also on a usage error
            json_usage_error(line)
        fail(line)


#: click type -> the placeholder help shows for a value of it, where the option names none
#: (typer's own are `<float range>`, `<str>`, `{paths}...`: issue 28)
_METAVARS = {
    "FloatParamType": "NUMBER",
    "FloatRange": "NUMBER",
    "IntParamType": "N",
    "IntRange": "N",
    "StringParamType": "TEXT",
}


def plain_metavars(command: Any) -> None:
    """Give every option of `command` without a metavar a plain one (`NUMBER`, `N`, `TEXT`,
    a choice's `a|b`; a path `DIR` or `FILE` when its help says which, else `PATH`), and its
    arguments their name in capitals (`PATH...`), as `--plot FILE` has. Idempotent."""
    for param in command.params:
        if param.metavar is not None or getattr(param, "is_flag", False):
            continue
        kind = type(param.type).__name__
        if param.param_type_name == "argument":
            name = (param.name or "arg").upper().removesuffix("S")
            text = name + ("..." if param.nargs != 1 else "")
            param.metavar = text
            # typer wraps a required argument's metavar in braces ("{PATH...}") in usage
            param.make_metavar = lambda *args, _text=text, **kwargs: _text
        elif kind.endswith("Choice"):  # click's Choice, typer's TyperChoice
            param.metavar = "|".join(str(getattr(c, "value", c)) for c in param.type.choices)
        elif kind.endswith("Path"):  # click's Path, typer's TyperPath
            help_text = (param.help or "").lower()
            param.metavar = "DIR" if "dir" in help_text or "folder" in help_text else "PATH"
            param.metavar = "FILE" if "file" in help_text.split(".")[0] else param.metavar
        else:
            param.metavar = _METAVARS.get(kind, "VALUE")


def wants_json(args: list[str]) -> bool:
    """Whether a command line asks for `--json` (before a `--`, which ends the options)."""
    options = args[: args.index("--")] if "--" in args else args
    return "--json" in options


app = typer.Typer(
    name="wbpower",
    cls=OneLineUsageGroup,
    help="Energy models of a mobile robot from power-analyser logs, and where they go wrong.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


def _version(value: bool) -> None:
    if value:
        print(f"wbpower {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version.")
    ] = False,
) -> None:
    """Energy models of a mobile robot from power-analyser logs, and where they go wrong."""
