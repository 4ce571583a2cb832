"""Text, notes and colour bars set with matplotlib onto a 3-D render (an RGB image from `vibra.pipeline.render`).

VTK's corner text has no glyphs for cm⁻¹, ω, γ or D∞h; matplotlib's fonts (DejaVu Sans) have them
and its mathtext sets sub- and superscripts. `annotate_render` takes the rendered pixels and
returns new pixels of the same size with each panel's title in its upper-left corner, an optional
note along the bottom edge and an optional horizontal colour bar with its label and unit.

>>> import numpy as np
>>> image = np.full((120, 200, 3), 255, dtype=np.uint8)
>>> annotate_render(image, titles=["ν1: 1595 cm⁻¹"], note="drawn with 41 beads").shape
(120, 200, 3)
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

__all__ = ["ColourBar", "annotate_render"]


@dataclass(frozen=True)
class ColourBar:
    """A colour bar drawn under a render.

    Attributes
    ----------
    label : str
        What the colours mean, with the unit (mathtext allowed).
    cmap : str
        The matplotlib colour map the render used.
    low, high : float
        The values at the two ends.
    """

    label: str
    cmap: str = "viridis"
    low: float = 0.0
    high: float = 1.0


def annotate_render(image: ArrayLike, *, grid: Sequence[int] = (1, 1), titles: Sequence[str] = (),
                    note: str | None = None, colour_bar: ColourBar | None = None,
                    font_size: float = 12.0) -> NDArray[np.uint8]:
    """`image` (height, width, 3 or 4) with titles, a note and a colour bar set on it by matplotlib.

    Parameters
    ----------
    image : (height, width, 3 or 4) array_like of uint8
        The render.
    grid : (rows, columns)
        The render's panels; title i goes to panel i (row-major), in its upper-left corner.
    titles : sequence of str
        One text per panel (several lines allowed), in points of `font_size`.
    note : str, optional
        A line along the bottom edge (what the picture leaves out, how it is scaled).
    colour_bar : ColourBar, optional
        A horizontal colour bar at the bottom right.
    font_size : float
        Title size, in points at 100 dpi (1 point = 1.39 pixels).

    Returns
    -------
    (height, width, 3) ndarray of uint8
    """
    pixels = np.asarray(image)
    if pixels.ndim != 3 or pixels.shape[2] not in (3, 4) or pixels.dtype != np.uint8:
        raise ValueError(f"image must be (height, width, 3 or 4) uint8, got shape {pixels.shape} {pixels.dtype}")
    rows, columns = int(grid[0]), int(grid[1])
    height, width = pixels.shape[:2]
    figure = Figure(figsize=(width / 100.0, height / 100.0), dpi=100)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.imshow(pixels[:, :, :3], interpolation="none", aspect="auto")
    axes.set_axis_off()
    pad_x, pad_y = 6.0 / width, 4.0 / height
    # a title wraps at its panel's width (about 0.55 em per character of DejaVu Sans)
    per_line = max(12, int((width / columns - 12.0) / (0.55 * font_size * 100.0 / 72.0)))
    for i, text in enumerate(titles):
        row, column = divmod(i, columns)
        if row >= rows:
            raise ValueError(f"titles has {len(titles)} entries; the grid {rows}x{columns} has {rows * columns} panels")
        text = "\n".join(textwrap.fill(line, per_line, subsequent_indent="  ") for line in text.split("\n"))
        figure.text(column / columns + pad_x, 1.0 - row / rows - pad_y, text, ha="left", va="top",
                    fontsize=font_size, color="black", linespacing=1.3)
    if note:
        figure.text(pad_x, pad_y, note, ha="left", va="bottom", fontsize=0.85 * font_size, color="0.25",
                    style="italic")
    if colour_bar is not None:
        from matplotlib.cm import ScalarMappable
        from matplotlib.colors import Normalize

        bar_height = 12.0 / height
        box = figure.add_axes((0.68, 30.0 / height, 0.29, bar_height))
        mappable = ScalarMappable(norm=Normalize(colour_bar.low, colour_bar.high), cmap=colour_bar.cmap)
        bar = figure.colorbar(mappable, cax=box, orientation="horizontal")
        bar.ax.tick_params(labelsize=0.75 * font_size, pad=1)
        bar.ax.set_title(colour_bar.label, fontsize=0.8 * font_size, pad=3, loc="right")
    canvas.draw()
    out = np.asarray(canvas.buffer_rgba())[:, :, :3]
    return np.ascontiguousarray(out, dtype=np.uint8)
