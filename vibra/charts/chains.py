"""Charts of chains and the continuum limit: dispersion, convergence, mode shapes, pulses.

Every function returns a `matplotlib.figure.Figure` drawn with vibra's shared style;
save it with `vibra.charts.save_figure`. They draw what `vibra.continuum` computed.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from vibra._core import validate as _validate
from vibra.charts._style import new_figure
from vibra.continuum import ConvergenceStudy, DispersionCurves, PulseResult
from vibra.modes import Modes
from vibra.system import System
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

__all__ = ["plot_dispersion_curves", "plot_dispersion", "plot_convergence", "plot_chain_mode_shapes", "plot_pulse_spacetime"]


def _unit_names(units: UnitSystem) -> tuple[str, str, str]:
    """(length, time, omega) unit labels for axes."""
    if units.time_s is None:
        return "length unit", "time unit", "√(k/m)"
    time = "s" if units.time_s == 1.0 else f"{units.time_s:.4g} s"
    return units.length, time, units.omega


def plot_dispersion_curves(
    q: ArrayLike,
    branches: ArrayLike,
    *,
    mode_q: ArrayLike | None = None,
    mode_omega: ArrayLike | None = None,
    n_sites: int | None = None,
    ends: str = "free",
    units: str | UnitSystem | None = None,
    title: str | None = None,
) -> Figure:
    """Draw computed dispersion branches omega(q), and a finite chain's modes on top.

    Parameters
    ----------
    q : (n_q,) array_like
        Wavenumbers from 0 to the zone edge, in rad per length unit.
    branches : (n_branches, n_q) array_like
        omega(q) of each branch, in rad per time unit (`vibra.continuum.dispersion`); two
        branches are drawn as acoustic and optical with the band gap shaded.
    mode_q, mode_omega : (n_modes,) array_like, optional
        Wavenumber (`vibra.continuum.assign_wavenumbers`) and omega of each mode of a finite
        chain, drawn as points.
    n_sites : int, optional
        Sites of that chain (legend).
    ends : str
        Its end conditions (legend).
    units : str or UnitSystem, optional
        Units of the axes (dimensionless by default).
    title : str, optional
        Figure title.
    """
    unit = unit_system(units) if units is not None else DIMENSIONLESS
    length, _, omega_unit = _unit_names(unit)
    q_values = np.asarray(q, dtype=float)
    curves = np.atleast_2d(np.asarray(branches, dtype=float))
    n_branches = curves.shape[0]
    fig, ax = new_figure()
    edge = float(q_values[-1])  # the zone edge pi/a (a: the repeat length)
    q_values = q_values / edge
    names = ["acoustic branch", "optical branch"] if n_branches == 2 else ["infinite chain"]
    for row, label in zip(curves, names):
        ax.plot(q_values, row, label=label)
    if n_branches == 2:
        ax.axhspan(curves[0].max(), curves[1].min(), color="0.85", label="band gap")
    if mode_q is not None and mode_omega is not None:
        sites = f"{n_sites} sites, " if n_sites is not None else ""
        ax.plot(np.asarray(mode_q) / edge, np.asarray(mode_omega), "o", ms=5, mfc="none",
                label=f"finite chain, {sites}{ends} ends")
    ax.axvline(1.0, color="0.3", linestyle="--", linewidth=1.0, label=f"zone edge q = π/a\n= {edge:.4g} rad/{length}")
    ax.set_xlim(0.0, 1.04)
    ax.set_xticks([0.0, 0.25, 0.5, 0.75, 1.0], ["0", "π/4a", "π/2a", "3π/4a", "π/a"])
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel(f"wavenumber q (in units of π/a; a = repeat length, {length})")
    ax.set_ylabel(f"angular frequency ω ({omega_unit})")
    ax.set_title(title or ("Diatomic chain dispersion" if n_branches == 2 else "Monatomic chain dispersion"))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False, fontsize=9)  # outside the data
    return fig


def plot_dispersion(curves: DispersionCurves, *, title: str | None = None) -> Figure:
    """Draw a `vibra.continuum.DispersionCurves` (branches, and the finite chain's modes when it has them).

    The curves come from `vibra.continuum.dispersion_curves`; this only draws them.
    """
    return plot_dispersion_curves(curves.q, curves.omega, mode_q=curves.mode_wavenumbers,
                                  mode_omega=curves.mode_omega, n_sites=curves.n_sites, ends=curves.ends,
                                  units=curves.units, title=title)


def plot_convergence(study: ConvergenceStudy, *, title: str | None = None) -> Figure:
    """Log-log |relative error| of each chain mode against the continuum versus N.

    Draws the measured errors, the fitted power law (order in the legend) and the
    small-angle prediction C_k / (L/dx)^2 as a dashed line.
    """
    if not isinstance(study, ConvergenceStudy):
        raise TypeError(f"study must be a ConvergenceStudy, got {type(study).__name__}")
    fig, ax = new_figure()
    sizes = study.n_sites.astype(float)
    resolution = sizes + (1.0 if study.ends == "fixed" else 0.0)
    expected = study.expected_coefficient()
    for i, k in enumerate(study.modes):
        line, = ax.loglog(sizes, np.abs(study.errors[:, i]), "o", ms=5,
                          label=f"mode k={k}: fitted order {study.order[i]:.3f}")
        ax.loglog(sizes, study.coefficient[i] * resolution ** -study.order[i], "-", color=line.get_color(),
                  lw=1.0)
        ax.loglog(sizes, expected[i] / resolution**2, "--", color=line.get_color(), lw=1.0, alpha=0.7)
    ax.plot([], [], "k--", lw=1.0, label="prediction (kπ)²/(24 N²)" if study.ends != "periodic"
            else "prediction (2kπ)²/(24 N²)")
    ax.set_xlabel("number of masses N (L fixed)")
    ax.set_ylabel("|ω_chain / ω_continuum − 1| (relative)")
    ax.set_title(title or f"Chain to wave equation, {study.ends} ends ({study.solver})")
    ax.legend(fontsize=9)
    return fig


def plot_chain_mode_shapes(system: System, modes: Modes, indices: Sequence[int] | None = None, *,
                           title: str | None = None) -> Figure:
    """Stacked displacement profiles of a few modes of a 1-D chain against site position.

    Each shape is scaled to a peak of 1 and offset vertically; the legend gives omega.

    Parameters
    ----------
    system : System
        The chain (its site x coordinates are the horizontal axis).
    modes : Modes
        Its modes, with shapes.
    indices : sequence of int, optional
        Which modes (default: the first four).
    title : str, optional
        Figure title.
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    if modes.shapes is None:
        raise ValueError("modes has no shapes; compute them with vectors=True")
    chosen = list(range(min(4, modes.n_modes))) if indices is None else list(indices)
    for position, index in enumerate(chosen):
        _validate.count(index, f"indices[{position}]", low=0, high=modes.n_modes - 1)
    x = np.asarray(system.positions)[system.free_dofs // max(system.dim, 1), 0]
    length, _, omega_unit = _unit_names(modes.units)
    fig, ax = new_figure()
    for offset, index in enumerate(chosen):
        shape = modes.shapes[:, index]
        peak = np.abs(shape).max()
        ax.axhline(2.2 * offset, color="0.6", lw=0.8)
        ax.plot(x, 2.2 * offset + shape / peak, "o-", ms=3,
                label=f"mode {index}: ω = {modes.omega[index]:.4g} {omega_unit}")
    ax.set_yticks([])
    ax.set_xlabel(f"site position x ({length})")
    ax.set_ylabel("displacement (scaled to peak 1, offset per mode)")
    ax.set_title(title or f"Mode shapes: {system.name}")
    ax.legend(fontsize=9, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    return fig


def plot_pulse_spacetime(pulse: PulseResult, *, title: str | None = None) -> Figure:
    """Space-time map of a pulse on the chain and its last snapshot against d'Alembert.

    Left: chain displacement u(x, t) as an image with the characteristic x0 + c t.
    Right: the chain and the continuum at the last time, showing the dispersive tail.
    """
    if not isinstance(pulse, PulseResult):
        raise TypeError(f"pulse must be a PulseResult, got {type(pulse).__name__}")
    fig, (left, right) = new_figure(1, 2, figsize=(12.0, 5.0))
    limit = float(np.abs(pulse.chain).max())
    extent = (0.0, pulse.length, float(pulse.t[0]), float(pulse.t[-1]) if pulse.t.size > 1 else 1.0)
    image = left.imshow(pulse.chain, aspect="auto", origin="lower", extent=extent, cmap="RdBu_r",
                        vmin=-limit, vmax=limit, interpolation="nearest")
    fig.colorbar(image, ax=left, label="displacement u (units of the amplitude)")
    t_line = np.linspace(extent[2], extent[3], 200)
    front = pulse.center + pulse.wave_speed * t_line
    if pulse.ends == "periodic":
        front = np.mod(front, pulse.length)
        front[np.r_[False, np.diff(front) < 0]] = np.nan
    left.plot(front, t_line, "k:", lw=1.2, label="x₀ + c t (d'Alembert)")
    left.set_xlim(0.0, pulse.length)
    left.set_xlabel("position x (length unit)")
    left.set_ylabel("time t (time unit)")
    left.set_title(f"Chain, N = {pulse.n_sites}, σ = {pulse.width:.3g}")
    left.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), fontsize=9, frameon=False)
    right.plot(pulse.x, pulse.continuum[-1], "k-", lw=2.5, alpha=0.5, label="wave equation (d'Alembert)")
    right.plot(pulse.x, pulse.chain[-1], "-", lw=1.2, label="discrete chain (exact modes)")
    peak = float(pulse.x[np.argmax(np.abs(pulse.continuum[-1]))])
    right.set_xlim(max(0.0, peak - 8.0 * pulse.width), min(pulse.length, peak + 8.0 * pulse.width))
    right.set_xlabel("position x (length unit)")
    right.set_ylabel("displacement u (units of the amplitude)")
    right.set_title(f"t = {pulse.t[-1]:.3g}: max error {pulse.error[-1]:.2e}")
    right.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncols=2, fontsize=9, frameon=False)
    if title:
        fig.suptitle(title)
    return fig
