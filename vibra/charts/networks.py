"""Charts of elastic network models: fitted against crystallographic B-factors per residue, and the
residue cross-correlation map."""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra.charts._style import new_figure

__all__ = ["b_factor_axis", "plot_b_factors", "plot_cross_correlations", "plot_mode_profiles"]


def _residue_ticks(axes: Any, labels: Sequence[str], *, axis: str = "x") -> None:
    """About 8 residue-number ticks (the ``"A:MET1:CA"`` labels' middle part) on `axis`."""
    n = len(labels)
    step = max(1, n // 8)
    ticks = np.arange(1, n + 1)[::step]
    names = [labels[i - 1].split(":")[1] if labels[i - 1].count(":") >= 1 else str(i) for i in ticks]
    if axis == "x":
        axes.set_xticks(ticks, names, rotation=30, fontsize=9)
    else:
        axes.set_yticks(ticks, names, fontsize=9)


#: Legend wording of `vibra.networks.fit_bfactors`' scale conventions.
_FIT_WORDS = {"sum": "ProDy's scale (ΣB / Σf)", "least_squares": "least-squares scale"}


def b_factor_axis(experimental: ArrayLike, fitted: ArrayLike) -> str:
    """``"linear"`` or ``"log"``: the axis on which both B-factor curves read, decided by the data.

    Linear when the data span less than a decade: the largest value of either curve is below
    10 times the smaller of their two medians, so the bulk of the residues fills at least a tenth
    of a linear axis. Log otherwise: a few residues far above the rest (a free terminus) would
    squash every other residue to the baseline of a linear axis.

    Examples
    --------
    >>> b_factor_axis([8.0, 10.0, 30.0], [9.0, 12.0, 25.0]), b_factor_axis([8.0, 10.0, 30.0], [0.1, 0.2, 50.0])
    ('linear', 'log')
    """
    e = np.asarray(experimental, dtype=float)
    p = np.asarray(fitted, dtype=float)
    values = np.concatenate([e, p])
    bulk = min(float(np.median(e)), float(np.median(p)))
    return "linear" if bulk > 0 and float(values.max(initial=0.0)) < 10.0 * bulk else "log"


def plot_b_factors(labels: Sequence[str], experimental: ArrayLike, fitted: ArrayLike, correlation: float, *,
                   scale: float | None = None, method: str = "sum", title: str = "") -> Figure:
    """Fitted against crystallographic B-factors: per residue on one axis (left), one against the other (right).

    An elastic network fixes B-factors only up to the scale kT / gamma; `fitted` are the
    network's fluctuations times the scale `vibra.networks.fit_bfactors` chose (`method`:
    ProDy's ratio of the sums by default, or least squares), so both curves share one axis in
    Å². That axis is linear or logarithmic as the data need (`b_factor_axis`); on a log axis
    values <= 0 are left off. The Pearson correlation, in the legend and the titles, does not
    depend on the scale.

    Parameters
    ----------
    labels : (n_sites,) sequence of str
        ``"chain:RESNAMEnumber:CA"`` per site (`vibra.networks.Structure.labels`).
    experimental, fitted : (n_sites,) array_like
        B-factors, in Å².
    correlation : float
        Pearson correlation of the two.
    scale : float, optional
        The fitted scale (shown in the legend), in Å² per unit of the network's fluctuations.
    method : {"sum", "least_squares"}
        How `scale` was chosen (`vibra.networks.fit_bfactors`), for the legend.
    title : str
        Prefix of the figure title (the scene's title).

    Raises
    ------
    ValueError
        experimental and fitted not two 1-D arrays of one length; an unknown method.
    """
    e = np.asarray(experimental, dtype=float)
    p = np.asarray(fitted, dtype=float)
    if e.shape != p.shape or e.ndim != 1:
        raise ValueError(f"experimental and fitted must be two equal 1-D arrays, got shapes {e.shape} and {p.shape}")
    if method not in _FIT_WORDS:
        raise ValueError(f"method is {method!r}; expected one of {', '.join(repr(m) for m in _FIT_WORDS)}")
    axis = b_factor_axis(e, p)
    residues = np.arange(1, len(e) + 1)
    figure, (axes, scatter) = new_figure(1, 2, figsize=(13.0, 5.0), gridspec_kw={"width_ratios": [1.7, 1.0]})
    axes.plot(residues, e, color="0.25", linewidth=1.6, label="crystallographic (file)")
    how = f"network, {_FIT_WORDS[method]}" + ("" if scale is None else f" x {scale:.3g}")
    axes.plot(residues, p, color="C3", linewidth=1.6, label=f"{how}, r = {correlation:.3f}")
    axes.set_xlabel("residue (C-alpha site, in file order)")
    axes.set_ylabel("B-factor (Å²)" + (", log scale" if axis == "log" else ""))
    top = max(float(e.max(initial=0.0)), float(p.max(initial=0.0)), 1e-300)
    if axis == "log":
        positive = np.concatenate([e[e > 0], p[p > 0]])
        bottom = float(positive.min(initial=top))
        low, high = bottom / 1.5, top * 1.5
        for panel in (axes, scatter):
            panel.set_yscale("log")
        scatter.set_xscale("log")
    else:
        low, high = 0.0, 1.08 * top
    axes.set_ylim(low, high)
    _residue_ticks(axes, labels)
    axes.legend(loc="lower left", bbox_to_anchor=(0.0, 1.01), ncols=2, frameon=False)
    shown = (e > 0) & (p > 0) if axis == "log" else np.ones(e.shape, dtype=bool)
    scatter.scatter(e[shown], p[shown], s=16, color="C3", alpha=0.8)
    scatter.plot([low, high], [low, high], color="0.4", linestyle="--", linewidth=1.0,
                 label="fitted = crystallographic")
    scatter.set_xlim(low, high)
    scatter.set_ylim(low, high)
    scatter.set_xlabel("crystallographic B-factor (Å²)")
    scatter.set_ylabel("fitted B-factor (Å²)")
    scatter.legend(loc="upper left")
    scatter.set_title(f"one point per residue, r = {correlation:.3f}")
    figure.suptitle(f"{title}{': ' if title else ''}B-factors, Pearson correlation r = {correlation:.3f}")
    return figure


def plot_cross_correlations(labels: Sequence[str], correlations: ArrayLike, *, n_modes: int | None = None,
                            title: str = "") -> Figure:
    """The residue cross-correlation map C_ij in [-1, 1], on a diverging colour map with its colour bar.

    Parameters
    ----------
    labels : (n_sites,) sequence of str
        ``"chain:RESNAMEnumber:CA"`` per site.
    correlations : (n_sites, n_sites) array_like
        Normalised cross-correlations (`vibra.networks.cross_correlations`), dimensionless.
    n_modes : int, optional
        Modes summed (for the title).
    title : str
        Prefix of the figure title.
    """
    C = np.asarray(correlations, dtype=float)
    if C.ndim != 2 or C.shape[0] != C.shape[1] or C.shape[0] != len(labels):
        raise ValueError(f"correlations must be ({len(labels)}, {len(labels)}) for {len(labels)} labels, "
                         f"got shape {C.shape}")
    figure, axes = new_figure(figsize=(7.6, 6.4))
    n = C.shape[0]
    image = axes.imshow(C, cmap="RdBu_r", vmin=-1.0, vmax=1.0, origin="lower", interpolation="nearest",
                        extent=(0.5, n + 0.5, 0.5, n + 0.5))
    axes.grid(False)
    _residue_ticks(axes, labels, axis="x")
    _residue_ticks(axes, labels, axis="y")
    axes.set_xlabel("residue")
    axes.set_ylabel("residue")
    bar = figure.colorbar(image, ax=axes, shrink=0.9)
    bar.set_label("cross-correlation C$_{ij}$ (dimensionless): + together, − opposite")
    modes = "" if n_modes is None else f" from the {n_modes} lowest modes"
    axes.set_title(f"{title}{chr(10) if title else ''}residue cross-correlations{modes}", fontsize=12)
    return figure


def plot_mode_profiles(labels: Sequence[str], shapes: ArrayLike, names: Sequence[str], *, title: str = "") -> Figure:
    """Mode shapes along the sequence: each mode's amplitude per residue, one row per mode (a GNM's modes).

    Parameters
    ----------
    labels : (n_sites,) sequence of str
        ``"chain:RESNAMEnumber:CA"`` per site.
    shapes : (n_sites, n_modes) array_like
        One scalar amplitude per residue and mode (any normalisation: each is drawn as
        u_i / max |u|, dimensionless; the sign of a mode is arbitrary).
    names : (n_modes,) sequence of str
        Each mode's name and frequency, for its row.
    title : str
        Prefix of the figure title.
    """
    U = np.asarray(shapes, dtype=float)
    if U.ndim != 2 or U.shape[0] != len(labels) or U.shape[1] != len(names):
        raise ValueError(f"shapes must be ({len(labels)}, {len(names)}) for {len(labels)} labels and "
                         f"{len(names)} names, got shape {U.shape}")
    figure, axes = new_figure(len(names), 1, figsize=(8.0, 1.2 + 1.5 * len(names)), squeeze=False, sharex=True)
    residues = np.arange(1, U.shape[0] + 1)
    for row, (panel, name) in enumerate(zip(axes[:, 0], names)):
        u = U[:, row] / max(float(np.abs(U[:, row]).max()), 1e-300)
        panel.bar(residues, u, width=1.0, color=np.where(u >= 0, "#b2182b", "#2166ac"))
        panel.axhline(0.0, color="black", linewidth=0.8)
        panel.set_ylim(-1.05, 1.05)
        panel.set_ylabel("u$_i$ / max |u|", fontsize=9)
        panel.set_title(name, fontsize=10, loc="left")
    _residue_ticks(axes[-1, 0], labels, axis="x")
    axes[-1, 0].set_xlabel("residue")
    figure.suptitle(f"{title}{chr(10) if title else ''}mode shapes along the sequence (a sign change is a hinge)")
    return figure
