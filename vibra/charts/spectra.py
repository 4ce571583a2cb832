"""Charts of `vibra.spectra` results: stick and broadened spectra, thermochemistry vs T.

Each function takes result objects and returns a matplotlib Figure; save it with
`vibra.charts.save_figure`. IR spectra are drawn with the wavenumber decreasing to
the right, as spectroscopists draw them (and the axis label says so); Raman spectra with the
Raman shift increasing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy import constants

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vibra.spectra import BroadenedSpectrum, StickSpectrum, Thermochemistry

__all__ = ["plot_stick_spectrum", "plot_broadened_spectrum", "plot_thermo"]


def _decreasing(kind: str, decreasing: bool | None) -> bool:
    return kind.lower() != "raman" if decreasing is None else bool(decreasing)


def _wavenumber_label(kind: str, decreasing: bool) -> str:
    name = "Raman shift" if kind.lower() == "raman" else "wavenumber"
    direction = "decreasing to the right" if decreasing else "increasing to the right"
    return f"{name} (cm$^{{-1}}$), {direction}"


def _unit_label(unit: str) -> str:
    return unit.replace("^2", "$^2$").replace("^4", "$^4$").replace("Angstrom", "Å")


def plot_stick_spectrum(sticks: StickSpectrum, *, title: str | None = None,
                        decreasing: bool | None = None) -> Figure:
    """Vertical lines at the line positions, heights = intensities.

    Parameters
    ----------
    sticks : StickSpectrum
        From ``IRSpectrum.sticks()`` or ``RamanSpectrum.sticks()``.
    title : str, optional
        Figure title (default: "<kind> stick spectrum").
    decreasing : bool, optional
        Wavenumber axis decreasing to the right (default: True for IR, False for Raman).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from vibra.spectra import StickSpectrum

    if not isinstance(sticks, StickSpectrum):
        raise TypeError(f"sticks must be a StickSpectrum, got {type(sticks).__name__}")
    down = _decreasing(sticks.kind, decreasing)
    fig, ax = new_figure()
    ax.vlines(sticks.wavenumbers, 0.0, sticks.intensities, color="C0", linewidth=2.5)
    ax.plot(sticks.wavenumbers, sticks.intensities, "o", color="C0", markersize=4)
    for position, height in zip(sticks.wavenumbers, sticks.intensities):
        ax.annotate(f"{position:.0f}", (position, height), textcoords="offset points",
                    xytext=(0, 6), ha="center", fontsize=9)
    _wavenumber_axis(ax, sticks.wavenumbers, down, sticks.kind)
    top = float(sticks.intensities.max()) if sticks.intensities.size else 1.0
    ax.set_ylim(0.0, 1.15 * top if top > 0 else 1.0)
    what = "Raman activity" if sticks.kind.lower() == "raman" else f"{sticks.kind} intensity"
    ax.set_ylabel(f"{what} ({_unit_label(sticks.unit)})")
    ax.set_title(title or f"{sticks.kind} stick spectrum")
    return fig


def plot_broadened_spectrum(spectrum: BroadenedSpectrum, *, sticks: StickSpectrum | None = None,
                            title: str | None = None, decreasing: bool | None = None) -> Figure:
    """The spectral density on its grid, optionally with the sticks on a second axis.

    Parameters
    ----------
    spectrum : BroadenedSpectrum
        From `vibra.spectra.broadened_spectrum` or ``StickSpectrum.broadened``.
    sticks : StickSpectrum, optional
        Lines drawn on a right-hand axis in their own unit.
    title : str, optional
        Figure title.
    decreasing : bool, optional
        Wavenumber axis decreasing to the right (default: True for IR, False for Raman).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from vibra.spectra import BroadenedSpectrum, StickSpectrum

    if not isinstance(spectrum, BroadenedSpectrum):
        raise TypeError(f"spectrum must be a BroadenedSpectrum, got {type(spectrum).__name__}")
    if sticks is not None and not isinstance(sticks, StickSpectrum):
        raise TypeError(f"sticks must be a StickSpectrum or None, got {type(sticks).__name__}")
    down = _decreasing(spectrum.kind, decreasing)
    fig, ax = new_figure()
    ax.plot(spectrum.grid, spectrum.values, color="C0",
            label=f"{spectrum.shape}, FWHM {spectrum.width:g} cm$^{{-1}}$")
    ax.fill_between(spectrum.grid, spectrum.values, color="C0", alpha=0.15)
    ax.set_ylabel(f"spectral density ({_unit_label(spectrum.unit)} per cm$^{{-1}}$)")
    ax.set_ylim(bottom=0.0)
    handles, labels = ax.get_legend_handles_labels()
    if sticks is not None:
        inside = (sticks.wavenumbers >= spectrum.grid.min()) & (sticks.wavenumbers <= spectrum.grid.max())
        twin = ax.twinx()
        twin.grid(False)
        twin.vlines(sticks.wavenumbers[inside], 0.0, sticks.intensities[inside], color="C3",
                    linewidth=1.5, alpha=0.8, label="sticks (right axis)")
        top = float(sticks.intensities[inside].max()) if inside.any() else 1.0
        twin.set_ylim(0.0, 1.1 * top if top > 0 else 1.0)
        twin.set_ylabel(f"line intensity ({_unit_label(sticks.unit)})", color="C3")
        more_handles, more_labels = twin.get_legend_handles_labels()
        handles, labels = handles + more_handles, labels + more_labels
    ax.set_xlim(float(spectrum.grid.min()), float(spectrum.grid.max()))
    if down:
        ax.invert_xaxis()
    ax.set_xlabel(_wavenumber_label(spectrum.kind, down))
    ax.legend(handles, labels, loc="upper left" if down else "upper right")
    ax.set_title(title or f"{spectrum.kind} spectrum")
    return fig


def plot_thermo(thermo: Thermochemistry, *, title: str | None = None) -> Figure:
    """Heat capacity C_v and entropy S of the vibrations against temperature, per mole.

    The C_v panel shows the classical limit n_vib R as a dashed line.

    Parameters
    ----------
    thermo : Thermochemistry
        From `vibra.spectra.thermochemistry` (several temperatures).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from vibra.spectra import Thermochemistry

    if not isinstance(thermo, Thermochemistry):
        raise TypeError(f"thermo must be a Thermochemistry, got {type(thermo).__name__}")
    fig, (left, right) = new_figure(1, 2, figsize=(10.0, 4.5))
    t = thermo.temperatures
    left.plot(t, thermo.heat_capacity_j_per_mol_k(), color="C0", label="harmonic $C_v$")
    limit = len(thermo.wavenumbers) * constants.R
    left.axhline(limit, color="0.4", linestyle="--", linewidth=1.2,
                 label=f"classical limit {len(thermo.wavenumbers)} R")
    left.set_xlabel("temperature (K)")
    left.set_ylabel("$C_v$ (J mol$^{-1}$ K$^{-1}$)")
    left.set_ylim(0.0, 1.08 * limit if limit > 0 else 1.0)
    left.legend(loc="lower right")
    left.set_title("vibrational heat capacity")
    right.plot(t, thermo.entropy_j_per_mol_k(), color="C1")
    right.set_xlabel("temperature (K)")
    right.set_ylabel("$S$ (J mol$^{-1}$ K$^{-1}$)")
    right.set_ylim(bottom=0.0)
    right.set_title("vibrational entropy")
    fig.suptitle(title or f"harmonic thermochemistry, ZPE = {thermo.zero_point_energy:.4f} eV")
    return fig


def _wavenumber_axis(ax: Axes, positions: np.ndarray, decreasing: bool, kind: str) -> None:
    if positions.size:
        low, high = float(positions.min()), float(positions.max())
        pad = max(0.08 * (high - low), 50.0)
        ax.set_xlim(low - pad, high + pad)
    if decreasing:
        ax.invert_xaxis()
    ax.set_xlabel(_wavenumber_label(kind, decreasing))
