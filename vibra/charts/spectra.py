"""Charts of `vibra.spectra` results: stick and broadened spectra, thermochemistry vs T.

Each function takes result objects and returns a matplotlib Figure; save it with
`vibra.charts.save_figure`. IR spectra are drawn with the wavenumber decreasing to
the right, as spectroscopists draw them (and the axis label says so); Raman spectra with the
Raman shift increasing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, Sequence

import numpy as np
from scipy import constants

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vibra.spectra import BroadenedSpectrum, StickSpectrum, Thermochemistry

__all__ = ["plot_stick_spectrum", "plot_broadened_spectrum", "plot_thermo", "plot_molecule_spectra", "species_text",
           "MoleculeSpectraLike"]


class MoleculeSpectraLike(Protocol):
    """What `plot_molecule_spectra` reads of a molecule's spectra (`vibra.pipeline.plan.analysis.MoleculeSpectra`,
    a stage above the charts, which they do not import): for IR and Raman alike the lines, their
    broadened profile (each None where the model gives none), the species of each line and
    where the intensities come from, in words; and how many rigid-body modes were left out."""

    @property
    def ir(self) -> StickSpectrum | None: ...

    @property
    def ir_profile(self) -> BroadenedSpectrum | None: ...

    @property
    def ir_species(self) -> Sequence[str]: ...

    @property
    def ir_model(self) -> str: ...

    @property
    def raman(self) -> StickSpectrum | None: ...

    @property
    def raman_profile(self) -> BroadenedSpectrum | None: ...

    @property
    def raman_species(self) -> Sequence[str]: ...

    @property
    def raman_model(self) -> str: ...

    @property
    def n_rigid(self) -> int: ...


def _decreasing(kind: str, decreasing: bool | None) -> bool:
    return kind.lower() != "raman" if decreasing is None else bool(decreasing)


def _wavenumber_label(kind: str, decreasing: bool) -> str:
    name = "Raman shift" if kind.lower() == "raman" else "wavenumber"
    direction = "decreasing to the right" if decreasing else "increasing to the right"
    return f"{name} (cm$^{{-1}}$), {direction}"


def _level_text(spectrum: Any) -> str:
    """``", RHF/STO-3G"``: the level of theory a spectrum carries, for a title (``""`` for none)."""
    level = getattr(spectrum, "level", "")
    return f", {level}" if level else ""


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
        Figure title (default: "<kind> stick spectrum", with the level of theory where the
        spectrum carries one: "IR stick spectrum, RHF/STO-3G").
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
    ax.set_title(title or f"{sticks.kind} stick spectrum{_level_text(sticks)}")
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
        Figure title (default: "<kind> spectrum", with the level of theory where the spectrum
        carries one).
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
    ax.set_title(title or f"{spectrum.kind} spectrum{_level_text(spectrum)}")
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


_GREEK = {"Sigma": "\\Sigma", "Pi": "\\Pi", "Delta": "\\Delta", "Phi": "\\Phi", "Gamma": "\\Gamma"}


def species_text(label: str) -> str:
    """A Mulliken label (``"A1"``, ``"T2g"``, ``"Sigma_g+"``, ``"E'"``) as matplotlib mathtext.

    >>> print(species_text("Sigma_u+"), species_text("T2"), repr(species_text("")))
    $\\Sigma_{u}^{+}$ $T_{2}$ ''
    """
    if not label:
        return ""
    text = str(label)
    sign = text[-1] if text[-1] in "+-" else ""
    text = text[:-1] if sign else text
    primes = text[len(text.rstrip("'")):]
    text = text.rstrip("'")
    base = next((g for g in _GREEK if text.startswith(g)), text[:1])
    rest = text[len(base):].lstrip("_")
    math = _GREEK.get(base, base) + (f"_{{{rest}}}" if rest else "") + (f"^{{{sign}}}" if sign else "")
    return f"${math}${primes}"


def _spectrum_panel(axes: Axes, sticks: Any, profile: Any, species: tuple[str, ...], what: str,
                    color: str) -> None:
    """One panel: the Lorentzian profile (left axis), the sticks beneath (right axis), species on the peaks."""
    strongest = float(sticks.intensities.max(initial=0.0))
    allowed = sticks.intensities > 1e-8 * strongest if strongest > 0 else np.zeros(len(sticks.intensities), bool)
    axes.plot(profile.grid, profile.values, color=color, linewidth=1.6,
              label=f"Lorentzian, FWHM {profile.width:g} cm$^{{-1}}$")
    axes.fill_between(profile.grid, profile.values, color=color, alpha=0.12)
    axes.set_ylabel(f"{what} density\n({_unit_label(sticks.unit)} per cm$^{{-1}}$)")
    axes.set_ylim(0.0, 1.3 * float(profile.values.max(initial=0.0)) or 1.0)
    twin = axes.twinx()
    twin.grid(False)
    twin.vlines(sticks.wavenumbers[allowed], 0.0, sticks.intensities[allowed], color="0.15", linewidth=2.0,
                label=f"lines (right axis, {_unit_label(sticks.unit)})")
    twin.set_ylim(0.0, 1.3 * strongest if strongest > 0 else 1.0)
    twin.set_ylabel(f"line {what} ({_unit_label(sticks.unit)})")
    silent_drawn = False
    labels = []
    for k, (position, height) in enumerate(zip(sticks.wavenumbers, sticks.intensities)):
        name = species_text(species[k]) if k < len(species) else ""
        if allowed[k]:
            labels.append(twin.annotate(f"{name} {position:.0f}".strip(), (position, height),
                                        textcoords="offset points", xytext=(0, 4), ha="center", fontsize=10))
        else:
            twin.plot([position], [0.0], marker="^", color="0.55", markersize=7, clip_on=False,
                      label=None if silent_drawn else "forbidden (zero intensity)")
            silent_drawn = True
            twin.annotate(f"{name} {position:.0f}".strip(), (position, 0.0), textcoords="offset points",
                          xytext=(0, 9), ha="center", fontsize=9, color="0.45")
    _beside_neighbours(twin, labels, sticks.wavenumbers)
    _lift_overlapping(axes.figure, labels)
    handles = axes.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    axes.legend(handles, [h.get_label() for h in handles], loc="lower left", bbox_to_anchor=(0.0, 1.0),
                ncols=3, frameon=False, fontsize=9)


def _beside_neighbours(axes: Axes, labels: list[Any], positions: np.ndarray) -> None:
    """Set a peak label to the side away from a line closer than half the label's width (H2O's two stretches)."""
    if len(labels) < 2:
        return
    renderer = axes.figure.canvas.get_renderer()
    pixels = axes.transData.transform(np.column_stack([positions, np.zeros(len(positions))]))[:, 0]
    for label in labels:
        x = axes.transData.transform((label.xy[0], 0.0))[0]
        half = 0.5 * label.get_window_extent(renderer).width + 3.0
        right = [p for p in pixels if 0.5 < p - x < half]
        left = [p for p in pixels if 0.5 < x - p < half]
        if right and not left:
            label.set_horizontalalignment("right")
            label.xyann = (-3, label.xyann[1])
        elif left and not right:
            label.set_horizontalalignment("left")
            label.xyann = (3, label.xyann[1])


def _lift_overlapping(figure: Any, labels: list[Any]) -> None:
    """Raise a peak label by one text line (13 points) while it overlaps a label placed before it."""
    if len(labels) < 2:
        return
    renderer = figure.canvas.get_renderer()
    placed: list[Any] = []
    for label in sorted(labels, key=lambda a: a.xy[0]):
        for _ in range(4):
            box = label.get_window_extent(renderer)
            if not any(box.overlaps(other) for other in placed):
                break
            label.xyann = (label.xyann[0], label.xyann[1] + 13)
        placed.append(label.get_window_extent(renderer))


def plot_molecule_spectra(spectra: MoleculeSpectraLike, *, title: str = "") -> Figure:
    """IR (top) and Raman (bottom) spectra of a molecule: broadened lines, sticks beneath, species on the peaks.

    Parameters
    ----------
    spectra : MoleculeSpectra
        From `vibra.pipeline.plan.analysis.molecule_spectra` (or any object with its
        attributes ``ir``, ``ir_profile``, ``ir_species``, ``ir_model`` and the same for Raman,
        and ``n_rigid``): `StickSpectrum` and `BroadenedSpectrum` values, None where the
        model gives none; the reason is then written in the panel.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Wavenumber increasing to the right on both panels (they share the axis, so that a
        line allowed in one and forbidden in the other reads straight down); rigid-body
        modes are not drawn.
    """
    figure, (top, bottom) = new_figure(2, 1, figsize=(9.0, 7.2), sharex=True)
    for axes, sticks, profile, species, model, what, color in (
            (top, spectra.ir, spectra.ir_profile, spectra.ir_species, spectra.ir_model, "IR intensity", "C0"),
            (bottom, spectra.raman, spectra.raman_profile, spectra.raman_species, spectra.raman_model,
             "Raman activity", "C2")):
        if sticks is None or profile is None or not len(sticks.wavenumbers):
            axes.text(0.5, 0.5, model, transform=axes.transAxes, ha="center", va="center", fontsize=11,
                      wrap=True, color="0.3")
            axes.set_yticks([])
            continue
        _spectrum_panel(axes, sticks, profile, species, what, color)
        axes.set_title(model, fontsize=10, loc="right", color="0.3", pad=22)
        axes.set_xlim(float(profile.grid.min()), float(profile.grid.max()))
    bottom.set_xlabel("wavenumber (cm$^{-1}$)")
    rigid = (f" ({spectra.n_rigid} rigid-body mode{'s' if spectra.n_rigid > 1 else ''} left out)"
             if spectra.n_rigid else "")
    figure.suptitle(f"{title}{': ' if title else ''}IR and Raman spectra{rigid}")
    return figure
