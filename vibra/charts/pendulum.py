"""Charts of the pendulum analyses: period versus amplitude, double-pendulum mode shapes,
exact versus harmonic trajectories (Kneller, Mécanique analytique, figure 2; Vieille 1849, problem II).

Each function takes result objects, draws on a new figure with vibra's shared style and
returns the `matplotlib.figure.Figure`; save it with `vibra.charts.save_figure`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from vibra._core import validate as _validate
from vibra.charts._style import new_figure
from vibra.modes import Modes
from vibra.mechanics.pendulum import HarmonicError, PendulumMotion

__all__ = ["plot_period_vs_amplitude", "plot_double_pendulum_modes", "plot_trajectory_comparison"]


def plot_period_vs_amplitude(errors: HarmonicError) -> Figure:
    """Exact and harmonic periods against the release angle, and the harmonic errors.

    Left: the period in units of 2 pi / Omega, exact (4 K(sin^2(theta0/2)) / Omega) and
    harmonic (1). Right, log-log: the relative period error and the trajectory error
    relative to the amplitude, with the leading-order slope theta0^2 / 16.

    Parameters
    ----------
    errors : HarmonicError
        From `vibra.mechanics.pendulum.harmonic_error`, amplitudes ascending.
    """
    if not isinstance(errors, HarmonicError):
        raise TypeError(f"errors must be a HarmonicError, got {type(errors).__name__}")
    fig, (left, right) = new_figure(1, 2, figsize=(11.0, 4.6))
    degrees = np.degrees(errors.amplitudes)
    left.plot(degrees, errors.exact_period / errors.harmonic_period, label="exact, 4K(sin²(θ₀/2))/Ω")
    left.plot(degrees, np.ones_like(degrees), "--", label="harmonic, 2π/Ω")
    left.set_xlabel("release angle θ₀ (deg)")
    left.set_ylabel("period / (2π/Ω)")
    left.set_title("Pendulum period versus amplitude")
    left.legend(loc="upper left")
    right.loglog(errors.amplitudes, errors.period_error, "o-", ms=4, label="period error T/T₀ − 1")
    right.loglog(errors.amplitudes, errors.relative_trajectory_error, "s-", ms=4,
                 label=f"max |θ_harm − θ| / θ₀, {errors.n_periods:g} period(s)")
    right.loglog(errors.amplitudes, errors.amplitudes**2 / 16.0, ":", color="gray", label="θ₀²/16")
    right.set_xlabel("release angle θ₀ (rad)")
    right.set_ylabel("relative error (dimensionless)")
    right.set_title("Harmonic approximation error")
    right.legend(loc="upper left")
    return fig


def plot_double_pendulum_modes(modes: Modes, a: float, b: float, *, amplitude: float = 0.35) -> Figure:
    """The two normal modes of the double pendulum drawn as pendulum positions.

    Each panel shows the hanging position (dashed), and the mode shape (theta_k, phi_k)
    scaled so that its larger angle is `amplitude`, at both extremes of the swing.

    Parameters
    ----------
    modes : Modes
        Modes of `vibra.mechanics.lagrangian.double_pendulum` (coordinates theta, phi; 2 modes with
        shapes), omega in rad/s.
    a, b : float
        Lengths of the upper and lower string, in m.
    amplitude : float
        Largest angle drawn, in rad, in (0, pi/2].

    Raises
    ------
    TypeError
        modes not a Modes; a, b or amplitude not real numbers.
    ValueError
        modes without the 2 shapes of a double pendulum; a, b not positive; amplitude
        outside (0, pi/2].
    """
    if not isinstance(modes, Modes):
        raise TypeError(f"modes must be a Modes, got {type(modes).__name__}")
    if modes.shapes is None or modes.shapes.shape != (2, 2):
        raise ValueError("modes must hold the 2 mode shapes of a double pendulum (computed with vectors=True)")
    for value, name in ((a, "a"), (b, "b")):
        if not _validate.real_scalar(value, name) > 0:
            raise ValueError(f"{name} is {value!r} m; a string length must be positive")
    if not 0 < _validate.real_scalar(amplitude, "amplitude") <= np.pi / 2:
        raise ValueError(f"amplitude is {amplitude!r} rad; the drawn angle must lie in (0, pi/2]")
    fig, axes = new_figure(1, 2, figsize=(10.0, 4.8))
    reach = a + b
    for k, ax in enumerate(axes):
        shape = modes.shapes[:, k] / np.abs(modes.shapes[:, k]).max() * amplitude
        ax.plot([0.0, 0.0], [0.0, -reach], "--", color="gray", lw=1.0, label="hanging at rest")
        for sign, style in ((1.0, dict(color="C0", alpha=1.0)), (-1.0, dict(color="C0", alpha=0.35))):
            theta, phi = sign * shape
            x1, y1 = a * np.sin(theta), -a * np.cos(theta)
            x2, y2 = x1 + b * np.sin(phi), y1 - b * np.cos(phi)
            ax.plot([0.0, x1, x2], [0.0, y1, y2], "-", lw=2.0, **style)
            ax.plot([x1], [y1], "o", ms=11, color="C1", alpha=style["alpha"])
            ax.plot([x2], [y2], "o", ms=11, color="C3", alpha=style["alpha"])
        ax.plot([0.0], [0.0], "k^", ms=10)
        ratio = modes.shapes[1, k] / modes.shapes[0, k]
        ax.set_title(f"mode {k + 1}: ω = {modes.omega[k]:.4g} rad/s, φ/θ = {ratio:.3g}")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("height (m)")
        ax.set_aspect("equal")
        ax.set_xlim(-0.75 * reach, 0.75 * reach)
        ax.set_ylim(-1.1 * reach, 0.1 * reach)
    axes[0].plot([], [], "o", color="C1", label="m (upper)")
    axes[0].plot([], [], "o", color="C3", label="m′ (lower)")
    axes[0].legend(loc="upper left", fontsize=9)
    fig.suptitle("Double pendulum normal modes (Vieille 1849, problem II)")
    return fig


def plot_trajectory_comparison(pairs: Sequence[tuple[PendulumMotion, PendulumMotion]]) -> Figure:
    """Exact versus harmonic theta(t), one panel per (exact, harmonic) pair (Kneller, Mécanique analytique, fig. 2).

    Parameters
    ----------
    pairs : sequence of (PendulumMotion, PendulumMotion)
        Typically a small and a large amplitude; the time axis is Omega t (rad).
    """
    if isinstance(pairs, tuple) and len(pairs) == 2 and isinstance(pairs[0], PendulumMotion):
        pairs = [pairs]  # type: ignore[list-item]
    pair_list = list(pairs)
    if not pair_list:
        raise ValueError("pairs is empty; give at least one (exact, harmonic) pair")
    for i, pair in enumerate(pair_list):
        if len(pair) != 2 or not all(isinstance(p, PendulumMotion) for p in pair):
            raise TypeError(f"pairs[{i}] must be a pair of PendulumMotion (exact, harmonic)")
    fig, axes = new_figure(1, len(pair_list), figsize=(5.5 * len(pair_list), 4.4), squeeze=False)
    for ax, (exact, harmonic) in zip(axes[0], pair_list):
        ax.plot(exact.omega * exact.t, exact.theta, label=f"exact ({exact.method})")
        ax.plot(harmonic.omega * harmonic.t, harmonic.theta, "--", label="harmonic")
        theta0 = abs(float(exact.theta[0]))
        ax.set_title(f"θ₀ = {theta0:.3g} rad ({np.degrees(theta0):.0f}°)")
        ax.set_xlabel("Ω t (rad)")
        ax.set_ylabel("θ (rad)")
        ax.set_ylim(-1.45 * theta0, 1.1 * theta0)  # room for the legend below the curves
        ax.legend(loc="lower center", ncol=2, fontsize=9)
    return fig
