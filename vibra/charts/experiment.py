"""Chart of computed against observed fundamentals (`vibra.spectra.ExperimentComparison`).

`plot_experiment_comparison(comparison)`: a mirrored stick spectrum (computed lines, scaled,
upwards; observed lines downwards; a thin line joins each pair so the shift reads at a glance)
over a table of the deviations (harmonic, scaled and observed wavenumbers, the deviation in
cm^-1 and percent, computed and observed intensities in km/mol). The level of theory and the
scale factor are in the title; the sources of the observed values beneath the table.

`needs_figure(title, message)`: the page of a scene whose engine is not installed, a figure that
says what it needs (the report shows figures first).
"""

from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

import numpy as np

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from vibra.spectra.experiment import ExperimentComparison

__all__ = ["plot_experiment_comparison", "needs_figure"]

#: Height of an observed line without a sourced intensity, as a fraction of the tallest line.
_UNSOURCED_HEIGHT = 0.15
#: Height of the line chart, of a table row and of a line of the sources beneath the table, in inches.
_CHART_INCHES, _ROW_INCHES, _SOURCE_LINE_INCHES = 5.0, 0.28, 0.13
#: Characters per line of the sources (7 pt across the table's width, about 8 inches).
_SOURCE_WIDTH = 145
#: Relative widths of the table's columns (the intensity columns have the longest headers).
_COLUMN_WIDTHS = (0.6, 1.0, 1.0, 0.9, 1.0, 1.1, 0.8, 1.25, 1.2)
#: Labels closer than this fraction of the wavenumber axis (and of the intensity axis) move apart.
_LABEL_GAP = 0.07


def plot_experiment_comparison(comparison: ExperimentComparison, *, title: str = "") -> Figure:
    """Computed (scaled) against observed fundamentals, frequencies and intensities.

    Parameters
    ----------
    comparison : ExperimentComparison
        From `vibra.spectra.compare_with_experiment`.
    title : str
        Prefix of the figure title (the scene's title).

    Returns
    -------
    matplotlib.figure.Figure
        Top: computed lines up (km/mol), observed down (km/mol; a fundamental without a sourced
        intensity is a short dashed line, its height meaningless, said in the legend); bottom:
        the deviation table.

    Raises
    ------
    TypeError
        `comparison` not an `ExperimentComparison`.
    """
    from vibra.spectra.experiment import ExperimentComparison

    if not isinstance(comparison, ExperimentComparison):
        raise TypeError(f"comparison must be a vibra.spectra.ExperimentComparison, got {type(comparison).__name__}")
    c = comparison
    sources = [f"observed wavenumbers: {c.frequency_source}"]
    if c.intensity_source:
        sources.append(f"observed intensities: {c.intensity_source}")
    sources_text = "\n".join(textwrap.fill(line, _SOURCE_WIDTH, subsequent_indent="    ") for line in sources)
    table_inches = (len(c) + 1) * _ROW_INCHES
    sources_inches = (sources_text.count("\n") + 1) * _SOURCE_LINE_INCHES + 0.1
    figure, (axes, table_axes) = new_figure(
        2, 1, figsize=(9.0, _CHART_INCHES + table_inches + sources_inches + 1.0),
        gridspec_kw={"height_ratios": [_CHART_INCHES, table_inches + sources_inches]})
    computed, observed = c.computed_km_per_mol, c.observed_km_per_mol
    sourced = ~np.isnan(observed)
    top = max(float(np.max(computed, initial=0.0)), float(np.max(np.where(sourced, observed, 0.0), initial=0.0)), 1e-9)
    axes.vlines(c.computed_cm1, 0.0, computed, color="C0", linewidth=2.5,
                label=f"computed, {c.level}, x {c.scale_factor:g}")
    axes.vlines(c.observed_cm1[sourced], 0.0, -observed[sourced], color="C3", linewidth=2.5,
                label="observed (gas phase)")
    if np.any(~sourced):
        axes.vlines(c.observed_cm1[~sourced], 0.0, -_UNSOURCED_HEIGHT * top, color="C3", linewidth=1.5,
                    linestyles="dashed", label="observed position, no sourced intensity")
    span = np.concatenate([c.computed_cm1, c.observed_cm1])
    margin = max(100.0, 0.08 * float(np.ptp(span)))
    axes.set_xlim(float(span.min()) - margin, float(span.max()) + margin)
    width = float(np.ptp(span)) + 2.0 * margin
    lows = np.where(sourced, -np.nan_to_num(observed), -_UNSOURCED_HEIGHT * top)
    above = _stagger(c.computed_cm1, computed, _LABEL_GAP * width, _LABEL_GAP * top)
    below = _stagger(c.observed_cm1, lows, _LABEL_GAP * width, _LABEL_GAP * top)
    for i in range(len(c)):
        axes.plot([c.computed_cm1[i], c.observed_cm1[i]], [0.0, 0.0], color="0.4", linewidth=0.8)
        axes.annotate(f"{c.names[i]} {c.species[i]}", (c.computed_cm1[i], computed[i]), textcoords="offset points",
                      xytext=(0, 5 + 11 * above[i]), ha="center", fontsize=9)
        axes.annotate(f"{c.deviation_percent()[i]:+.1f} %", (c.observed_cm1[i], lows[i]), textcoords="offset points",
                      xytext=(0, -13 - 11 * below[i]), ha="center", fontsize=9, color="C3")
    axes.axhline(0.0, color="0.2", linewidth=0.8)
    deepest = float(-np.min(lows, initial=0.0))           # the observed side needs only its own depth
    axes.set_ylim(-(1.3 * deepest + (0.1 + 0.04 * max(below, default=0)) * top),
                  (1.25 + 0.04 * max(above, default=0)) * top)
    ticks = [t for t in axes.get_yticks() if axes.get_ylim()[0] <= t <= axes.get_ylim()[1]]
    axes.set_yticks(ticks)
    axes.set_yticklabels([f"{abs(t):g}" for t in ticks])
    axes.set_ylabel("IR intensity (km/mol):\ncomputed up, observed down")
    axes.set_xlabel("wavenumber (cm$^{-1}$)")
    axes.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, fontsize=9, frameon=False)
    table_axes.axis("off")
    header = ["", "species", "harmonic", "scaled", "observed", "dev. cm$^{-1}$", "dev. %", "calc. km/mol",
              "obs. km/mol"]
    rows = [[c.names[i], c.species[i], f"{c.harmonic_cm1[i]:.0f}", f"{c.computed_cm1[i]:.0f}",
             f"{c.observed_cm1[i]:.0f}", f"{c.deviation_cm1()[i]:+.0f}", f"{c.deviation_percent()[i]:+.1f}",
             f"{computed[i]:.1f}", f"{observed[i]:.1f}" if sourced[i] else "-"] for i in range(len(c))]
    # The table fills the axes above the sources (a bbox, so its rows never run into them).
    below_table = sources_inches / (table_inches + sources_inches)
    table = table_axes.table(cellText=rows, colLabels=header, cellLoc="center", colWidths=list(_COLUMN_WIDTHS),
                             bbox=[0.0, below_table, 1.0, 1.0 - below_table])
    table.auto_set_font_size(False)
    table.set_fontsize(9)
    table_axes.text(0.0, 0.0, sources_text, transform=table_axes.transAxes, fontsize=7, va="bottom", ha="left",
                    color="0.3")
    prefix = f"{title}: " if title else ""
    figure.suptitle(f"{prefix}computed against observed fundamentals")
    return figure


def _stagger(x: np.ndarray, y: np.ndarray, gap_x: float, gap_y: float) -> list[int]:
    """Per label at (x, y), how many label heights to move it away from the line so that labels
    closer than `gap_x` and `gap_y` to each other do not overlap (0 for most; left to right)."""
    levels = [0] * len(x)
    placed: list[int] = []
    for i in np.argsort(x, kind="stable"):
        taken = {levels[j] for j in placed if abs(x[j] - x[i]) < gap_x and abs(y[j] - y[i]) < gap_y}
        levels[i] = min(set(range(len(taken) + 1)) - taken)
        placed.append(int(i))
    return levels


def needs_figure(title: str, message: str) -> Figure:
    """A figure that says why a scene drew nothing and what to install (`message`, wrapped).

    Parameters
    ----------
    title : str
        The scene's title.
    message : str
        What is missing and the command that installs it.
    """
    figure, axes = new_figure(figsize=(8.0, 2.6))
    axes.axis("off")
    axes.text(0.5, 0.62, f"{title}: not computed on this machine", ha="center", va="center", fontsize=18,
              transform=axes.transAxes)
    axes.text(0.5, 0.3, textwrap.fill(message, 64), ha="center", va="center", fontsize=13, color="0.25",
              transform=axes.transAxes)
    return figure
