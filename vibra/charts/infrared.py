"""Charts of a polar crystal's infrared response: ε(ω) and the normal-incidence reflectivity.

The chart draws what `vibra.crystals.infrared.InfraredResponse` computes (ε along one
polarisation, the reflectivity, the TO and LO frequencies); it computes no physics itself.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra._core import validate as _validate
from vibra.charts._style import new_figure, save_figure
from vibra.crystals.infrared import InfraredResponse

__all__ = ["infrared_figure", "plot_infrared"]

#: Points of the wavenumber grid drawn by default.
GRID_POINTS = 2001


def infrared_figure(response: InfraredResponse, *, direction: ArrayLike = (1.0, 0.0, 0.0), title: str = "",
                    wavenumbers: ArrayLike | None = None) -> Figure:
    """Re ε and Im ε along `direction` (top) and the reflectivity (bottom) against wavenumber.

    Each reststrahlen band (ω_TO to ω_LO along `direction`) is shaded, its TO frequency marked
    with a dashed line and its LO frequency with a dotted one.

    Parameters
    ----------
    response : InfraredResponse
        The crystal's response (physical units: the axis is in cm^-1).
    direction : (3,) array_like
        Cartesian polarisation p of the light, dimensionless; ε_pp = p·ε·p is drawn.
    title : str
        Figure title (default: the point group and direction).
    wavenumbers : (n,) array_like, optional
        Wavenumbers to draw, in cm^-1; default 0 to 1.4 times the highest LO wavenumber.

    Returns
    -------
    Figure
    """
    if not isinstance(response, InfraredResponse):
        raise TypeError(f"response must be an InfraredResponse, got {type(response).__name__}")
    p = _validate.real_array(direction, "direction", ndim=1)
    if p.shape != (3,) or not np.linalg.norm(p) > 0:
        raise ValueError(f"direction must be a nonzero Cartesian 3-vector, got {p.tolist()}")
    p = p / np.linalg.norm(p)
    units = response.units
    bands = np.asarray(units.omega_to_cm1(response.reststrahlen_bands(p).reshape(-1))).reshape(-1, 2)
    if wavenumbers is None:
        top = 1.4 * float(bands[:, 1].max()) if bands.size else 1.4 * float(response.wavenumbers_cm1().max())
        axis = np.linspace(0.0, top, GRID_POINTS)
    else:
        axis = _validate.real_array(wavenumbers, "wavenumbers", ndim=1)
    epsilon = np.einsum("a,wab,b->w", p, response.dielectric_cm1(axis), p)
    reflect = response.reflectivity_cm1(axis, p)

    figure, (upper, lower) = new_figure(2, 1, figsize=(8.0, 7.0), sharex=True)
    for axes in (upper, lower):
        for k, (to, lo) in enumerate(bands):
            axes.axvspan(to, lo, color="C3", alpha=0.12, linewidth=0,
                         label="reststrahlen band" if k == 0 and axes is lower else None)
            axes.axvline(to, color="C3", linestyle="--", linewidth=1.0)
            axes.axvline(lo, color="C3", linestyle=":", linewidth=1.2)
    finite = np.isfinite(epsilon.real)
    x, real, imag = axis[finite], epsilon.real[finite], epsilon.imag[finite]
    if not response.damping.any():  # undamped: no line drawn through a pole from +inf to -inf
        cuts = np.searchsorted(x, bands[:, 0])
        x, real, imag = (np.insert(v, cuts, np.nan) for v in (x, real, imag))
    upper.plot(x, real, color="C0", label="Re ε")
    upper.plot(x, imag, color="C1", label="Im ε")
    upper.axhline(0.0, color="0.3", linewidth=0.7)
    limit = _clip(epsilon[finite])
    upper.set_ylim(-limit, limit)
    upper.set_ylabel("dielectric function ε (dimensionless)")
    upper.legend(loc="upper right")
    lower.plot(axis, reflect, color="C2", label="reflectivity R")
    lower.set_ylim(0.0, 1.05)
    lower.set_ylabel("reflectivity R (dimensionless)")
    lower.set_xlabel("wavenumber (cm$^{-1}$)")
    lower.set_xlim(float(axis[0]), float(axis[-1]))
    for to, lo in bands:  # along the lines: TO at the foot left of its line, LO at the top right of its own
        lower.annotate(f"TO {to:.0f}", (to, 0.03), xytext=(-2, 0), textcoords="offset points", ha="right",
                       va="bottom", rotation=90, fontsize="small", color="C3")
        lower.annotate(f"LO {lo:.0f}", (lo, 0.97), xytext=(2, 0), textcoords="offset points", ha="left",
                       va="top", rotation=90, fontsize="small", color="C3")
    lower.legend(loc="center right")
    gamma = units.omega_to_cm1(response.damping[~response.acoustic])
    damping = "undamped" if not gamma.size or gamma.max() == 0 else \
        f"damping {gamma.min():.3g}{'' if gamma.min() == gamma.max() else f'..{gamma.max():.3g}'} cm$^{{-1}}$"
    upper.set_title(f"point group {response.point_group}, light polarised along "
                    f"[{', '.join(f'{x:.3g}' for x in p)}], {damping}", fontsize="medium")
    if title:
        figure.suptitle(title)
    return figure


def plot_infrared(response: InfraredResponse, path: str | os.PathLike[str], *,
                  direction: ArrayLike = (1.0, 0.0, 0.0), title: str = "",
                  wavenumbers: ArrayLike | None = None) -> Path:
    """Draw `infrared_figure` and write it to `path` as PNG (atomically); returns the path."""
    return save_figure(infrared_figure(response, direction=direction, title=title, wavenumbers=wavenumbers), path)


def _clip(epsilon: np.ndarray) -> float:
    """A symmetric y-limit that shows the curves without the poles' spikes (drawing only)."""
    size = np.abs(np.concatenate([epsilon.real, epsilon.imag]))
    if size.size == 0:
        return 1.0
    return float(max(1.2 * np.percentile(size, 90), 1.5 * np.abs(epsilon.real[0]), 1.0))
