"""Orbits of gyroscopic modes: each complex mode shape traced in the plane of two coordinates.

A mode of M q'' + G q' + K q = 0 (`vibra.solvers.structured.quadratic.QuadraticModes`) moves as
q(t) = Re{x exp(i omega t)}: with two coordinates (x, y) it traces an ellipse, a circle when
|x_1| = |x_2| with a quarter-period lag (the charged particle in a magnetic field: one mode
turns one way, the other the other way). `plot_mode_orbits` draws one panel per mode, the
orbit over one period, the start marked and the sense of rotation arrowed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from vibra.solvers.structured.quadratic import QuadraticModes

__all__ = ["mode_orbit", "rotation_sense", "plot_mode_orbits"]


def mode_orbit(shape: ArrayLike, n_points: int = 181) -> np.ndarray:
    """(n_points, n_dof) points Re{x exp(i phi)} for phi over one period [0, 2 pi].

    >>> orbit = mode_orbit([1.0, 1.0j], n_points=5)
    >>> np.round(orbit, 12).tolist()[:2]
    [[1.0, 0.0], [0.0, -1.0]]
    """
    x = np.asarray(shape, dtype=complex)
    phase = np.linspace(0.0, 2.0 * np.pi, n_points)
    return np.real(np.exp(1j * phase)[:, None] * x[None, :])


def rotation_sense(shape: ArrayLike) -> str:
    """``"counter-clockwise"``, ``"clockwise"`` or ``"linear"``: how Re{x exp(i omega t)} turns in the plane of its first two coordinates.

    The signed area swept, Im(conj(x_1) x_2), is negative for a counter-clockwise turn
    (x = [1, -i] gives (cos, sin)).

    >>> rotation_sense([1.0, -1.0j]), rotation_sense([1.0, 1.0j]), rotation_sense([1.0, 2.0])
    ('counter-clockwise', 'clockwise', 'linear')
    """
    x = np.asarray(shape, dtype=complex)
    area = float(np.imag(np.conj(x[0]) * x[1]))
    scale = float(np.abs(x[:2]).max() ** 2) or 1.0
    if abs(area) <= 1e-9 * scale:
        return "linear"
    return "counter-clockwise" if area < 0 else "clockwise"


def plot_mode_orbits(modes: QuadraticModes, *, coordinates: Sequence[str] = ("x", "y"), length_unit: str = "m",
                     title: str = "") -> Figure:
    """One panel per mode: the orbit of the mode's first two coordinates over one period.

    Parameters
    ----------
    modes : vibra.solvers.structured.quadratic.QuadraticModes
        Complex shapes (n_dof >= 2; the first two coordinates are drawn) and frequencies.
    coordinates : pair of str
        Names of the two coordinates (axis labels).
    length_unit : str
        Unit of the coordinates (axis labels; shapes are scaled to a largest entry of 1).
    title : str
        Figure title.
    """
    shapes = np.asarray(modes.shapes, dtype=complex)
    n = shapes.shape[1]
    figure, axes = new_figure(1, n, figsize=(4.2 * n + 0.8, 4.6), squeeze=False)
    frequency = np.asarray(modes.natural_frequency)
    omega_unit = modes.units.omega if hasattr(modes, "units") else "rad/s"  # the modes' own unit system
    for panel, k in zip(axes[0], range(n)):
        x = shapes[:2, k]
        x = x / max(float(np.abs(x).max()), 1e-300)
        orbit = mode_orbit(x)
        color = f"C{k}"
        panel.plot(orbit[:, 0], orbit[:, 1], color=color, linewidth=2.0)
        panel.plot(orbit[0, 0], orbit[0, 1], "o", color=color)
        for start in (0, 45, 90, 135):  # arrows along the orbit show the sense of rotation
            a, b = orbit[start], orbit[start + 8]
            panel.annotate("", xy=(b[0], b[1]), xytext=(a[0], a[1]),
                           arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.5})
        panel.axhline(0.0, color="0.7", linewidth=0.8)
        panel.axvline(0.0, color="0.7", linewidth=0.8)
        panel.set_aspect("equal")
        panel.set_xlim(-1.25, 1.25)
        panel.set_ylim(-1.25, 1.25)
        panel.set_xlabel(f"{coordinates[0]} ({length_unit}, relative)")
        panel.set_ylabel(f"{coordinates[1]} ({length_unit}, relative)")
        panel.set_title(f"mode {k}: omega = {frequency[k]:.4g} {omega_unit}\n{rotation_sense(x)}", fontsize=11)
    if title:
        figure.suptitle(title)
    return figure
