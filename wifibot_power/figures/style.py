"""What every figure shares: colours (one per phase, the same in every figure), sizes, and
writing a figure to a file. Nothing here imports matplotlib at module level: commands that
draw nothing start no slower (STYLE.md, "Figures")."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: One colour per phase, used by every figure (Okabe-Ito, readable by colour-blind readers).
PHASE_COLOURS = {
    "idle": "#bbbbbb",
    "accel": "#e69f00",
    "cruise": "#56b4e9",
    "decel": "#cc79a7",
    "level": "#009e73",
}
#: Our fit (solid) and the paper's values (dashed, black), in every figure.
FIT_COLOUR = "#0072b2"
PAPER_COLOUR = "black"
PAPER_STYLE = {"color": PAPER_COLOUR, "linestyle": "--", "linewidth": 1.2}
EXTENDED_COLOUR = "#009e73"
BASELINE_COLOUR = "#d55e00"
POWER_COLOUR = "#222222"
SPEED_COLOUR = "#d55e00"
#: Data-rate colours of Figure 7 (paper Table 2 rates).
RATE_COLOURS = {10.0: "#e69f00", 54.0: "#009e73", 100.0: "#0072b2"}
#: Resolution of the PNGs the report writes [dots per inch] (readable at 100% zoom).
DPI = 100
SUFFIXES = (".png", ".svg")


def new_figure(width_in: float, height_in: float, layout: str | None = "constrained") -> Figure:
    """A bare `Figure` on the Agg canvas (no pyplot: no global state, no GUI backend).
    `layout=None` for figures drawn by the hundred (traces): constrained layout costs ~2x."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width_in, height_in), dpi=DPI, layout=layout)
    FigureCanvasAgg(figure)
    return figure


def save_figure(figure: Figure, path: str | Path) -> Path:
    """Write `figure` as PNG or SVG (by the suffix), atomically (`outputs.write_atomic`).

    A PNG is reduced to 256 colours (Pillow's octree): a third of the bytes, with no
    difference to see in line plots, which keeps a report of a hundred figures small."""
    from wifibot_power.outputs import write_atomic

    path = Path(path)
    suffix = check_plot_path(path)
    if suffix == ".svg":
        return write_atomic(
            path, lambda tmp: figure.savefig(tmp, format="svg", metadata=_metadata(suffix))
        )
    return write_atomic(path, lambda tmp: tmp.write_bytes(png_bytes(figure)))


def png_bytes(figure: Figure) -> bytes:
    """The figure as a 256-colour PNG at `DPI`."""
    import io

    from PIL import Image

    raw = io.BytesIO()
    figure.savefig(raw, format="png", dpi=DPI, metadata=_metadata(".png"))
    raw.seek(0)
    with Image.open(raw) as image:
        quantized = image.convert("RGB").quantize(colors=256, method=Image.Quantize.FASTOCTREE)
    out = io.BytesIO()
    quantized.save(out, format="png", optimize=True)
    return out.getvalue()


def check_plot_path(path: str | Path) -> str:
    """The suffix of a figure file (.png or .svg); a `UsageError` for any other."""
    suffix = Path(path).suffix.lower()
    if suffix not in SUFFIXES:
        from wifibot_power.errors import UsageError

        raise UsageError(f"cannot draw to '{path}'", fix="give a file ending in .png or .svg")
    return suffix


def _metadata(suffix: str) -> dict[str, object]:
    # no creation date or software version: the same figure makes the same bytes
    return {"Software": None} if suffix == ".png" else {"Date": None, "Creator": None}


def svg_bytes(figure: Figure) -> bytes:
    """The figure as SVG (no date or creator: the same figure makes the same bytes)."""
    import io

    out = io.BytesIO()
    figure.savefig(out, format="svg", metadata=_metadata(".svg"))
    return out.getvalue()
