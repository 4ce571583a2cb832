"""Matplotlib charts (2-D plots) used by reports and notebooks, one module per analysis.

Every function takes result objects, draws on a new figure with the shared style of
`vibra.charts._style`, labels axes with units, and returns the `matplotlib.figure.Figure`
(`save_figure` writes it atomically). matplotlib is imported here only, with the Agg backend.
"""
