"""Matplotlib charts (2-D plots) used by reports and notebooks, one module per analysis.

Every function takes result objects (what the analyses computed) and draws it, on a new
figure in the shared style (`new_figure`); it labels axes with units and returns the
`matplotlib.figure.Figure`. `save_figure` writes one as PNG, atomically. The charts of each topic
are in its module (`vibra.charts.chains`, `.crystals`, `.infrared`, `.response`, ...), each named
on that topic's page of the documentation. Figures have their own Agg canvas: pyplot is never
imported and the caller's matplotlib backend is left as it is.
"""

from vibra.charts._style import new_figure, plain_math, save_figure

__all__ = ["new_figure", "save_figure", "plain_math"]
