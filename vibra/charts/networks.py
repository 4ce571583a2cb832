"""Charts of elastic network models: predicted against crystallographic B-factors per residue."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure

from vibra.charts._style import new_figure

__all__ = ["plot_b_factors"]


def plot_b_factors(labels: Sequence[str], experimental: Any, predicted: Any, correlation: float, *,
                   title: str = "") -> Figure:
    """Predicted against crystallographic B-factors: per residue (left) and one against the other (right).

    An elastic network fixes B-factors only up to the scale kT / gamma, so in the profile each
    curve has its own axis; the scatter uses logarithmic axes (the values span decades, a
    flexible tail far above the core). The Pearson correlation in the title does not depend
    on the scale.
    """
    e = np.asarray(experimental, dtype=float)
    p = np.asarray(predicted, dtype=float)
    residues = np.arange(1, len(e) + 1)
    figure, (axes, scatter) = new_figure(1, 2, figsize=(13.0, 5.0), gridspec_kw={"width_ratios": [1.7, 1.0]})
    axes.plot(residues, e, color="0.25", linewidth=1.6, label="crystallographic (file)")
    axes.set_xlabel("residue (C-alpha site, in file order)")
    axes.set_ylabel("crystallographic B-factor (Å²)")
    right = axes.twinx()
    right.plot(residues, p, color="C3", linewidth=1.6, label="network (kT/gamma = 1)")
    right.set_ylabel("predicted B-factor (Å², kT/gamma = 1)", color="C3")
    right.tick_params(axis="y", colors="C3")
    right.set_ylim(0.0, 1.08 * float(p.max(initial=0.0)) or 1.0)
    axes.set_ylim(0.0, 1.08 * float(e.max(initial=0.0)) or 1.0)
    step = max(1, len(labels) // 8)
    ticks = residues[::step]
    axes.set_xticks(ticks, [labels[i - 1].split(":")[1] if ":" in labels[i - 1] else str(i) for i in ticks],
                    rotation=30, fontsize=9)
    handles = axes.get_legend_handles_labels()[0] + right.get_legend_handles_labels()[0]
    axes.legend(handles, [h.get_label() for h in handles], loc="upper left")
    axes.set_title("per residue")
    positive = (e > 0) & (p > 0)
    scatter.scatter(e[positive], p[positive], s=16, color="C3", alpha=0.8)
    scatter.set_xscale("log")
    scatter.set_yscale("log")
    scatter.set_xlabel("crystallographic B-factor (Å²)")
    scatter.set_ylabel("predicted B-factor (Å², kT/gamma = 1)")
    scatter.set_title(f"one point per residue, r = {correlation:.3f}")
    figure.suptitle(f"{title}{': ' if title else ''}B-factors, Pearson correlation r = {correlation:.3f}")
    return figure
