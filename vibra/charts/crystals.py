"""Charts of crystals: the band structure with the DOS beside it, and thermal properties against T.

The layout is phonopy's familiar one: bands on the left along the path (a vertical line at each
special point, labels under the axis with Greek Gamma, two labels joined as ``U|K`` where the
path breaks), the DOS on the right on the same frequency axis, in THz or cm^-1. Given the
crystal's Gamma modes (`vibra.crystals.irreps.gamma_modes`), each optical level at every Gamma
of the path is labelled with its irreducible representation; in a polar crystal a level that the
long-range field moved (the LO mode, approached along the path) is labelled ``LO``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

from vibra.charts._style import new_figure

if TYPE_CHECKING:
    from vibra.crystals.bands import BandStructure
    from vibra.crystals.dos import DensityOfStates
    from vibra.crystals.irreps import GammaModes
    from vibra.crystals.thermal import ThermalProperties

__all__ = ["plot_bands_dos", "plot_thermal", "path_ticks", "gamma_labels", "FREQUENCY_LABELS", "LEVEL_RTOL"]

#: Axis label of each frequency unit a crystal chart draws in.
FREQUENCY_LABELS = {"THz": "frequency (THz)", "cm^-1": "wavenumber (cm$^{-1}$)"}

_GREEK = {"GAMMA": "Γ", "G": "Γ", "\\Gamma": "Γ", "DELTA": "Δ", "SIGMA": "Σ", "LAMBDA": "Λ"}


def _pretty(label: str) -> str:
    base, _, index = label.partition("_")
    text = _GREEK.get(base, base)
    return f"{text}$_{{{index}}}$" if index else text


def path_ticks(bands: BandStructure) -> tuple[list[float], list[str]]:
    """Tick positions (path length) and labels of the special points; labels at one position joined by ``|``."""
    positions: list[float] = []
    labels: list[str] = []
    for index, label in bands.labels:
        x = float(bands.distances[index])
        text = _pretty(label)
        if positions and abs(x - positions[-1]) <= 1e-9 * max(1.0, abs(x)):
            if labels[-1] != text:
                labels[-1] = f"{labels[-1]}|{text}"
            continue
        positions.append(x)
        labels.append(text)
    return positions, labels


def _in_unit(units: Any, omega: Any, unit: str) -> np.ndarray:
    return np.asarray(units.omega_to_thz(omega) if unit == "THz" else units.omega_to_cm1(omega))


#: Two band values at a Gamma point within this fraction of the spectrum's range are one level
#: on the chart, and a level within it of a Gamma mode of D(0) takes that mode's label (the
#: chart's resolution: 1e-3 of the height is under a pixel of a 5.5-inch axis at 100 dpi).
LEVEL_RTOL = 1e-3


def gamma_labels(bands: BandStructure, gamma: GammaModes, unit: str, *, polar: bool = True
                 ) -> list[tuple[float, float, str]]:
    """(x, frequency in `unit`, label) of each optical level at each Gamma point of the path.

    A level of the bands at Gamma that matches a level of the analytic D(0) (`gamma`, a
    `vibra.crystals.irreps.GammaModes`) within `LEVEL_RTOL` of the spectrum takes its irrep; in a
    `polar` crystal one that matches none is a longitudinal mode lifted by the non-analytic term
    and is labelled ``LO`` (otherwise it is left unlabelled). Acoustic levels (at zero) are not
    labelled.
    """
    values = _in_unit(bands.units, bands.omega, unit)
    reference = _in_unit(gamma.units, gamma.level_frequencies(), unit)
    names = gamma.level_labels()
    scale = max(float(np.ptp(values)), float(np.abs(values).max()), np.finfo(float).tiny)
    qpoints = np.asarray(bands.qpoints)
    found: dict[float, set[float]] = {}
    for index, _ in bands.labels:
        if np.abs(qpoints[index] - np.round(qpoints[index])).max() > 1e-9:
            continue  # not Gamma (nor one of its images)
        x = float(bands.distances[index])
        found.setdefault(x, set()).update(float(v) for v in values[index])
    marks: list[tuple[float, float, str]] = []
    for x, seen in found.items():
        level = -np.inf
        for value in sorted(seen):
            if value - level <= LEVEL_RTOL * scale or abs(value) <= LEVEL_RTOL * scale:
                level = max(level, value)
                continue  # one level already marked, or acoustic
            level = value
            near = np.abs(reference - value)
            k = int(np.argmin(near))
            if near[k] <= LEVEL_RTOL * scale:
                marks.append((x, value, names[k]))
            elif polar:
                marks.append((x, value, "LO"))
    return marks


def plot_bands_dos(bands: BandStructure, dos: DensityOfStates | None, *, unit: str = "THz", title: str = "",
                   gamma: GammaModes | None = None, polar: bool = True) -> Figure:
    """Bands along the path (left) and the DOS (right) on one frequency axis in `unit`.

    Parameters
    ----------
    bands : vibra.crystals.BandStructure
    dos : vibra.crystals.DensityOfStates or None
        Drawn beside the bands, in states per cell per `unit` (it integrates to 3 n_atoms).
    unit : {"THz", "cm^-1"}
    title : str
    gamma : vibra.crystals.irreps.GammaModes, optional
        The crystal's Gamma modes: each optical level at each Gamma of the path is labelled with
        its irrep (`gamma_labels`).
    polar : bool
        The crystal carries the non-analytic correction: a Gamma level of the bands that matches
        no level of D(0) is its LO mode (``False``: left unlabelled).
    """
    if unit not in FREQUENCY_LABELS:
        raise ValueError(f"unit is {unit!r}; expected one of {', '.join(FREQUENCY_LABELS)}")
    if dos is None:
        figure, left = new_figure(1, 1, figsize=(8.0, 5.5))
        right = None
    else:
        figure, (left, right) = new_figure(1, 2, figsize=(10.0, 5.5), sharey=True,
                                           gridspec_kw={"width_ratios": [3.2, 1.0], "wspace": 0.02})
    values = _in_unit(bands.units, bands.omega, unit)
    x = np.asarray(bands.distances)
    cuts = sorted(set(bands.breaks))
    runs = np.split(np.arange(len(x)), cuts)
    for run in runs:  # no line across a break of the path
        left.plot(x[run], values[run], color="C0", linewidth=1.4)
    ticks, labels = path_ticks(bands)
    for position in ticks:
        left.axvline(position, color="0.55", linewidth=0.8)
    for k in cuts:  # a break: a heavier line where two runs meet
        left.axvline(float(x[k]), color="0.2", linewidth=1.4)
    left.axhline(0.0, color="0.4", linewidth=0.6, linestyle=":")
    left.set_xticks(ticks, labels)
    left.set_xlim(float(x[0]), float(x[-1]))
    left.set_ylabel(FREQUENCY_LABELS[unit])
    low = min(0.0, float(values.min()))
    high = float(values.max())
    left.set_ylim(low - 0.02 * (high - low), high + 0.05 * (high - low))
    left.set_title("phonon bands")
    if gamma is not None:
        end = float(x[-1])
        for position, value, label in gamma_labels(bands, gamma, unit, polar=polar):
            at_end = position >= end - 1e-9 * max(1.0, abs(end))
            left.annotate(label, (position, value), xytext=(-3 if at_end else 3, 0), textcoords="offset points",
                          ha="right" if at_end else "left", va="center", fontsize="small", color="0.15",
                          bbox={"boxstyle": "round,pad=0.12", "facecolor": "white", "edgecolor": "none",
                                "alpha": 0.8})
    if right is not None:
        per_unit = float(_in_unit(dos.units, 1.0, unit))  # d(unit) / d(omega)
        axis = _in_unit(dos.units, dos.omega, unit)
        density = np.asarray(dos.dos) / per_unit
        right.fill_betweenx(axis, 0.0, density, color="C0", alpha=0.25, linewidth=0)
        right.plot(density, axis, color="C0", linewidth=1.2)
        right.set_xlim(0.0, 1.08 * float(density.max()))
        right.set_xlabel(f"states / cell / {'THz' if unit == 'THz' else 'cm$^{-1}$'}")
        right.set_title(f"DOS, {'x'.join(str(int(n)) for n in dos.mesh)} mesh", fontsize="medium")
        right.tick_params(axis="y", labelleft=False)
    if title:
        figure.suptitle(title)
    return figure


def plot_thermal(thermal: ThermalProperties, *, title: str = "") -> Figure:
    """Free energy (kJ/mol), entropy and heat capacity (J/K/mol) against temperature, per mole of cells.

    Parameters
    ----------
    thermal : vibra.crystals.ThermalProperties
    title : str
    """
    t = np.asarray(thermal.temperatures)
    figure, axes = new_figure(1, 1, figsize=(8.0, 5.0))
    axes.plot(t, thermal.free_energy_kj_mol(), color="C0", linewidth=1.6, label="free energy F (kJ/mol)")
    axes.plot(t, thermal.entropy_j_k_mol(), color="C1", linewidth=1.6, label="entropy S (J/K/mol)")
    axes.plot(t, thermal.heat_capacity_j_k_mol(), color="C2", linewidth=1.6, label="heat capacity C$_v$ (J/K/mol)")
    axes.axhline(0.0, color="0.4", linewidth=0.6, linestyle=":")
    axes.set_xlabel("temperature (K)")
    axes.set_ylabel("F (kJ/mol), S and C$_v$ (J/K/mol)")
    axes.set_xlim(float(t[0]), float(t[-1]))
    axes.legend(loc="best")
    mesh = "x".join(str(int(n)) for n in thermal.mesh)
    axes.set_title(f"harmonic, per mole of cells; {mesh} mesh; zero-point energy "
                   f"{thermal.zero_point_energy_kj_mol():.3g} kJ/mol", fontsize="medium")
    if title:
        figure.suptitle(title)
    return figure
