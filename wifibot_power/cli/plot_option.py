"""`--plot FILE`: the one figure of `segment`, `fit`, `diagnose`, `energy` and `lifetime`
(cli.md, "Figures"), declared once here. The file is checked before any work is done;
matplotlib is imported only when a figure is drawn."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

PlotFile = Annotated[
    Path | None,
    typer.Option(
        "--plot",
        metavar="FILE",
        help="Also draw this command's figure into FILE (.png or .svg; 'wbpower docs report').",
    ),
]


def check_plot(path: Path | None) -> None:
    """Refuse a `--plot` file that cannot be drawn or written, before any work is done."""
    if path is None:
        return
    from wifibot_power.cli.common import check_out_dir
    from wifibot_power.figures.style import check_plot_path

    check_plot_path(path)
    if path.is_dir():
        from wifibot_power.errors import UsageError

        raise UsageError(f"--plot {path} is a folder", fix="give a file ending in .png or .svg")
    check_out_dir(path.parent if str(path.parent) else Path("."))


def plot_to(path: Path | None, figure: str, *args: object, **kwargs: object) -> None:
    """Draw the named figure of `figures.FIGURES` with these arguments into `path` (nothing
    without `--plot`) and say so on stderr."""
    if path is None:
        return
    from wifibot_power.figures import FIGURES, save_figure

    save_figure(FIGURES[figure].draw(*args, **kwargs), path)
    from wifibot_power.cli.common import say_written

    say_written([path])
