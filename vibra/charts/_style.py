"""Shared look of vibra's matplotlib charts, and the PNG writer for them.

Figures are plain `matplotlib.figure.Figure` objects with their own Agg canvas: vibra never
imports `matplotlib.pyplot` nor calls `matplotlib.use`, so the backend of the caller's session
(a notebook's inline plots included) is left alone, and no figure is registered with pyplot
(nothing to close, no "too many open figures").

>>> figure, axes = new_figure()
>>> type(figure.canvas).__name__
'FigureCanvasAgg'
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from vibra._core.filesystem import atomic_write

__all__ = ["STYLE", "ChartFigure", "new_figure", "save_figure", "plain_math"]

#: rcParams applied (locally, via rc_context) to every chart: legible at the default size.
STYLE: Any = {
    "figure.figsize": (8.0, 5.0),
    "figure.dpi": 100,
    "savefig.dpi": 120,
    "font.size": 12,
    "axes.titlesize": 13,
    "axes.labelsize": 12,
    "legend.fontsize": 10,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "lines.linewidth": 1.8,
}

#: Keyword arguments of `new_figure` that describe the figure (the rest go to `Figure.subplots`).
_FIGURE_KEYWORDS = ("figsize", "dpi", "facecolor", "edgecolor", "frameon")


class ChartFigure(Figure):
    """A `Figure` that shows itself as a PNG in Jupyter and IPython, whatever the backend."""

    def _repr_png_(self) -> bytes:
        from io import BytesIO

        buffer = BytesIO()
        with matplotlib.rc_context(STYLE):
            self.savefig(buffer, format="png")
        return buffer.getvalue()


def new_figure(nrows: int = 1, ncols: int = 1, **kwargs: Any) -> tuple[ChartFigure, Any]:
    """A new figure on an Agg canvas and its axes, drawn with `STYLE` (global rcParams untouched).

    `figsize` and the other figure keywords describe the figure; the remaining keywords
    (``squeeze``, ``sharex``, ...) are those of `matplotlib.figure.Figure.subplots`.
    """
    figure_keywords = {k: kwargs.pop(k) for k in _FIGURE_KEYWORDS if k in kwargs}
    with matplotlib.rc_context(STYLE):
        figure = ChartFigure(layout="constrained", **figure_keywords)
        FigureCanvasAgg(figure)
        axes = figure.subplots(nrows, ncols, **kwargs)
    return figure, axes


def save_figure(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Write `fig` to `path` as PNG atomically (`vibra._core.filesystem.atomic_write`), mode 0666 less the umask."""
    def write(temporary: Path) -> None:
        with matplotlib.rc_context(STYLE):
            fig.savefig(temporary, format="png")

    return atomic_write(path, write)


#: Matplotlib mathtext a caption may carry -> its plain Unicode (for HTML and terminals).
_MATH_UNICODE = (("^{-1}", "⁻¹"), ("^{-2}", "⁻²"), ("^2", "²"), ("\\omega", "ω"), ("\\Omega", "Ω"),
                 ("\\gamma", "γ"), ("\\zeta", "ζ"), ("\\lambda", "λ"), ("\\pi", "π"), ("\\rho", "ρ"),
                 ("\\sigma", "σ"), ("\\Delta", "Δ"), ("\\mu", "μ"), ("\\theta", "θ"), ("\\phi", "φ"),
                 ("\\alpha", "α"), ("\\beta", "β"), ("_0", "₀"), ("_c", "c"), ("\\,", " "), ("\\pm", "±"))


def plain_math(text: str) -> str:
    """`text` with matplotlib mathtext (``$\\omega$``, ``cm$^{-1}$``) replaced by plain Unicode (ω, cm⁻¹).

    Plain-text exponents ``^-1`` and ``^-2`` (``cm^-1``) become superscripts too.

    >>> plain_math("wavenumber (cm$^{-1}$), $\\\\omega$ (rad/s)")
    'wavenumber (cm⁻¹), ω (rad/s)'
    """
    parts = text.split("$")
    for i in range(1, len(parts), 2):  # the odd parts were between dollars
        math = parts[i]
        for latex, unicode in _MATH_UNICODE:
            math = math.replace(latex, unicode)
        parts[i] = math.replace("{", "").replace("}", "").replace("\\", "")
    return "".join(parts).replace("^-1", "⁻¹").replace("^-2", "⁻²")
