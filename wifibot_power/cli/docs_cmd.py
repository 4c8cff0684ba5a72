"""`wbpower docs [NAME]`: the project's documentation pages, shipped inside the package
(`wifibot_power/docs/*.md`, package data: pyproject.toml), so that every help text, error and
table title that points to a page (`wbpower docs log-format`) points to something an installed
wbpower has (issue 28; docs/cli-output.md, "References")."""

from __future__ import annotations

import sys
from importlib import resources
from importlib.abc import Traversable
from typing import Annotated

import typer

from wifibot_power.cli.common import JsonFlag, handles_errors, print_json
from wifibot_power.cli.help import command_help
from wifibot_power.cli.typer_app import app
from wifibot_power.errors import UsageError


def pages() -> dict[str, Traversable]:
    """Every documentation page shipped with the package: name (the file's stem) -> file."""
    folder = resources.files("wifibot_power").joinpath("docs")
    if not folder.is_dir():
        return {}
    found = {f.name.removesuffix(".md"): f for f in folder.iterdir() if f.name.endswith(".md")}
    return dict(sorted(found.items()))


def title(page: Traversable) -> str:
    """A page's first heading, without its `#`s and backquotes."""
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            return line.lstrip("#").strip().replace("`", "")
    return ""


def page_text(name: str) -> str:
    """The Markdown of page `name` (e.g. "causes"); a usage error naming the pages there are."""
    found = pages()
    key = name.removesuffix(".md").rsplit("/", 1)[-1]
    if key not in found:
        raise UsageError(
            f"no documentation page '{name}'",
            fix=f"give one of: {', '.join(found) or '(none installed)'}",
        )
    return found[key].read_text(encoding="utf-8")


@app.command("docs", **command_help("docs"))
@handles_errors
def docs_command(
    name: Annotated[
        str | None,
        typer.Argument(metavar="[NAME]", help="The page, e.g. causes; none: list the pages."),
    ] = None,
    json_out: JsonFlag = False,
) -> None:
    """Print one of wbpower's documentation pages (Markdown; through a pager at a terminal),
    or list them all with their titles."""
    if name is None:
        listing = {key: title(page) for key, page in pages().items()}
        if json_out:
            print_json({"pages": [{"name": k, "title": t} for k, t in listing.items()]})
            return
        width = max(map(len, listing), default=0)
        for key, heading in listing.items():
            print(f"{key:<{width}}  {heading}")
        print("\nwbpower docs NAME prints a page.")
        return
    text = page_text(name)
    if json_out:
        print_json({"name": name.removesuffix(".md"), "text": text})
    elif sys.stdout.isatty():
        import pydoc

        pydoc.pager(text)  # $PAGER, else less
    else:
        sys.stdout.write(text)
