"""Analyses the plan runs for its drawings: what the renderer and the charts then only draw.

- `molecule_symmetry`: point group, symmetry species, IR/Raman activity by symmetry and the
  observed fundamentals of a molecule's modes (`vibra.molecules`).
- `symmetry_hints`: per-mode symmetry and IR-activity text of a molecule (species and
  activity from the character table, and the point-charge IR intensities of `vibra.spectra`).
- `chain_dispersion`: `vibra.continuum.dispersion_curves` for a chain scene's parameters (its
  finite chain's modes placed on the branches), for the dispersion chart.
- `network_fluctuations`: predicted against crystallographic B-factors of a network scene.
- `molecule_structure`: elements and bonds of a molecule scene, for its renders and spectra.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra.continuum import DispersionCurves

if TYPE_CHECKING:
    from vibra.modes import Modes
    from vibra.molecules.symmetry import PointGroup
    from vibra.networks import Structure
    from vibra.pipeline.render import MoleculeStructure
    from vibra.pipeline.scene import Scene
    from vibra.system import System

__all__ = ["MoleculeSymmetry", "molecule_symmetry", "MoleculeSpectra", "molecule_spectra", "symmetry_hints", "NetworkFluctuations", "network_fluctuations", "DispersionCurves", "chain_dispersion",
           "molecule_structure"]

#: A mode whose point-charge IR intensity is below this fraction of the strongest is IR-inactive.
IR_INACTIVE_FRACTION = 1e-8


@dataclass(frozen=True)
class MoleculeSymmetry:
    """Point group, symmetry species and observed fundamentals of a molecule scene's modes.

    Attributes
    ----------
    group : str
        Schoenflies symbol (`vibra.molecules.point_group`), e.g. ``"Dinfh"``, ``"C2v"``, ``"Td"``.
    species : tuple of str
        Per computed mode its Mulliken label (`VibrationalAnalysis.species`), ``""`` for a
        rigid-body (zero) mode.
    ir_active, raman_active : tuple of (bool or None)
        Per mode the activity by symmetry (the character table), None for a rigid mode.
    experimental : tuple of (Fundamental or None)
        Per mode the observed fundamental it corresponds to (`vibra.molecules.experimental`).
    source : str or None
        The source of the observed values (None when the molecule has none bundled).
    numbers : tuple of int
        Per mode its number in Herzberg's convention (`vibra.molecules.numbering`; 2 for nu2,
        shared by a degenerate set), 0 for a rigid mode; by decreasing frequency alone in C1.
    """

    group: str
    species: tuple[str, ...]
    ir_active: tuple[bool | None, ...]
    raman_active: tuple[bool | None, ...]
    experimental: tuple[Any, ...]
    source: str | None
    numbers: tuple[int, ...] = ()


def molecule_symmetry(system: System, modes: Modes) -> MoleculeSymmetry | None:
    """Species, symmetry-based IR/Raman activity and observed fundamentals of `modes` of a 3-D molecule.

    The vibrational analysis (`vibra.molecules.vibrational_analysis`, rigid motions projected
    out) labels each vibration; each computed mode takes the label of the vibration of the
    same frequency (within 1e-4 relative), a rigid (zero) mode none. None when the system is
    not 3-D sites or its point group cannot be found.
    """
    from vibra.molecules import experimental_fundamentals, match_fundamentals, vibrational_analysis
    from vibra.molecules.numbering import herzberg_numbers

    if getattr(system, "n_sites", 0) < 2 or system.frozen.any():
        return None
    omega = np.asarray(modes.omega)
    try:
        if system.dim != 3:
            found = _lifted_species(system, modes)
            if found is None:
                return None
            group, species = found
        else:
            analysis = vibrational_analysis(system)
            group = analysis.point_group
            labels = analysis.species
            vib_omega = np.asarray(analysis.modes.omega)[analysis.vibrations]
            scale = max(float(np.abs(omega).max(initial=0.0)), float(np.abs(vib_omega).max(initial=0.0)), 1e-300)
            species = []
            for value in omega:
                distance = np.abs(vib_omega - value)
                j = int(np.argmin(distance)) if len(distance) else -1
                near = j >= 0 and distance[j] <= 1e-4 * scale and abs(value) > 1e-6 * scale
                species.append(labels[j] if near else "")
    except (ValueError, RuntimeError, TypeError):
        return None
    table = group.table
    ir = tuple(None if not s else table.is_ir_active(s) for s in species)
    raman = tuple(None if not s else table.is_raman_active(s) for s in species)
    entry = experimental_fundamentals(system.symbols or (), system.masses) if system.symbols else None
    observed: list[Any] = [None] * len(species)
    if entry is not None:
        observed = match_fundamentals(entry, species, modes.wavenumbers_cm1())
    numbers = herzberg_numbers(table.labels, species, modes.wavenumbers_cm1(), linear=group.name in ("Cinfv", "Dinfh"),
                               n_atoms=system.n_sites)
    return MoleculeSymmetry(group=group.name, species=tuple(species), ir_active=ir, raman_active=raman,
                            experimental=tuple(observed), source=None if entry is None else entry.source,
                            numbers=numbers)


def _site_displacements(system: System, shape: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_sites, 3) displacement of every site (zeros at frozen dofs and unused axes)."""
    full = np.asarray(system.expand(shape)).reshape(system.n_sites, system.dim)
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = full
    return out


def _lifted_species(system: System, modes: Modes) -> tuple[PointGroup, list[str]] | None:
    """Point group and species of the modes of a 1-D or 2-D molecule (the axial CO2), set in 3-D space.

    The sites are placed in 3-D (missing axes zero) and each mode's shape padded likewise, so
    the labels are those of the full molecule's group for motions along the modelled axes.
    None without symbols or shapes.
    """
    from ase import Atoms

    from vibra.molecules import mode_species, point_group

    if not system.symbols or getattr(modes, "shapes", None) is None:
        return None
    positions = np.zeros((system.n_sites, 3))
    positions[:, : system.dim] = np.asarray(system.positions, dtype=float).reshape(system.n_sites, system.dim)
    group = point_group(Atoms(list(system.symbols), positions=positions, masses=np.asarray(system.masses)))
    omega = np.asarray(modes.omega)
    moving = np.flatnonzero(~modes.zero_modes(1e-6))
    shapes = np.stack([_site_displacements(system, np.asarray(modes.shapes)[:, k]).ravel() for k in moving], axis=1)
    species = [""] * len(omega)
    for k, label in zip(moving, mode_species(group, shapes, omega[moving])):
        species[int(k)] = label
    return group, species


def _activity_text(symmetry: MoleculeSymmetry, k: int) -> str | None:
    label = symmetry.species[k]
    if not label:
        return None
    ir = "IR active" if symmetry.ir_active[k] else "IR inactive"
    raman = "Raman active" if symmetry.raman_active[k] else "Raman inactive"
    return f"{label} ({symmetry.group}): {ir}, {raman} by symmetry"


def symmetry_hints(system: System, modes: Modes, indices: Sequence[int], symbols: Sequence[str],
                   bonds: Sequence[tuple[int, int]], symmetry: MoleculeSymmetry | None = None) -> dict[int, str]:
    """Symmetry and IR-activity text of the modes `indices` of a molecule, for captions.

    Each text is the mode's symmetry species in the molecule's point group with its IR and
    Raman activity from the character table (`molecule_symmetry`; computed here when
    `symmetry` is not given) and, for a 3-D molecule with bonds, the point-charge IR
    intensity of `vibra.spectra.ir_spectrum` (charges from Pauling electronegativities over
    `bonds`) relative to the strongest mode; parts are joined by ``"; "``.
    """
    if symmetry is None:
        symmetry = molecule_symmetry(system, modes)
    intensity: dict[int, str] = {}
    if system.dim == 3 and bonds:
        from vibra import spectra

        charges = spectra.electronegativity_charges(list(symbols), list(bonds))
        ir = spectra.ir_spectrum(system, modes, charges=charges)
        strongest = float(np.max(ir.intensities)) if len(ir.intensities) else 0.0
        for k, value in zip(ir.mode_indices, ir.intensities):
            active = strongest > 0 and value > IR_INACTIVE_FRACTION * strongest
            intensity[int(k)] = (f"IR {'active' if active else 'inactive'} "
                                 f"(point charges: {value / strongest if strongest else 0.0:.2f} of strongest)")
    hints = {}
    for k in indices:
        parts = []
        text = None if symmetry is None else _activity_text(symmetry, int(k))
        if text is not None:
            parts.append(text)
        if int(k) in intensity:
            parts.append(intensity[int(k)])
        hints[int(k)] = "; ".join(parts)
    return hints


def chain_dispersion(parameters: Mapping[str, Any], modes: Modes | None = None, *, n_q: int = 400) -> DispersionCurves:
    """`vibra.continuum.dispersion_curves` for a ``linear_chain`` / ``diatomic_chain`` scene's parameters.

    Parameters
    ----------
    parameters : Mapping
        The scene's system parameters: ``mass`` (a number) or ``masses`` (a pair),
        ``stiffness`` (a number or a pair), ``spacing`` and ``ends``.
    modes : Modes, optional
        The finite chain's modes, placed at their wavenumbers (`vibra.continuum.assign_wavenumbers`).
    n_q : int
        Points along q (2: the zone's ends, a cheap check).
    """
    from vibra.continuum import dispersion_curves

    masses = parameters["mass"] if "mass" in parameters else tuple(parameters["masses"])
    stiffness = parameters["stiffness"]
    stiffness = tuple(stiffness) if isinstance(stiffness, (tuple, list)) else stiffness
    return dispersion_curves(masses=masses, stiffness=stiffness, spacing=parameters["spacing"], modes=modes,
                             ends=parameters["ends"], n_q=n_q)


@dataclass(frozen=True, eq=False)
class NetworkFluctuations:
    """Predicted and crystallographic B-factors of a network scene (`network_fluctuations`).

    Attributes
    ----------
    labels : tuple of str
        One ``"chain:RESNAMEnumber:CA"`` label per site (`vibra.networks.Structure.labels`).
    experimental : (n_sites,) ndarray
        B-factors of the structure file, in Å^2.
    predicted : (n_sites,) ndarray
        8 pi^2/3 <u^2> from the computed non-rigid modes (kT = 1 in gamma's energy unit), in Å^2.
    correlation : float
        Pearson correlation of the two (`vibra.networks.b_factor_correlation`).
    n_modes : int
        Modes computed (the rigid ones among them are left out of the sum).
    fit : BFactorFit
        The same fluctuations scaled onto the crystallographic B-factors by
        `vibra.networks.fit_bfactors` (ProDy's convention by default: the ratio of the sums),
        in Å^2; None when the file's B column is flat.
    cross_correlations : (n_sites, n_sites) ndarray
        Normalised residue cross-correlations of the same modes (`vibra.networks.cross_correlations`),
        dimensionless in [-1, 1].
    """

    labels: tuple[str, ...]
    experimental: NDArray[np.float64]
    predicted: NDArray[np.float64]
    correlation: float
    n_modes: int
    fit: Any = None
    cross_correlations: Any = None


def network_fluctuations(structure: Structure, system: System, modes: Modes, *, fit: str = "sum") -> NetworkFluctuations:
    """B-factors predicted from `modes` of an elastic network, against those of its `structure`,
    fitted onto them by `vibra.networks.fit_bfactors` (`fit`: its ``method``, ProDy's ratio of
    the sums by default, or ``"least_squares"``), and the residue cross-correlations of the
    same modes."""
    from vibra.networks import (b_factor_correlation, cross_correlations, fit_bfactors, predicted_b_factors,
                                square_fluctuations)

    dim = int(system.dim)  # 1 for a GNM: its scalar fluctuation taken as isotropic (predicted_b_factors)
    predicted = predicted_b_factors(square_fluctuations(system, modes), dofs_per_site=dim)
    experimental = np.asarray(structure.b_factors, dtype=float)
    fitted = fit_bfactors(modes, experimental, method=fit, dim=dim) if np.ptp(experimental) > 0 else None
    return NetworkFluctuations(labels=tuple(structure.labels), experimental=experimental, predicted=predicted,
                               correlation=float(b_factor_correlation(predicted, experimental)),
                               n_modes=int(modes.n_modes), fit=fitted,
                               cross_correlations=cross_correlations(modes, dim=dim))


#: Full width at half maximum of the Lorentzian lines of a molecule's drawn spectra, in cm^-1.
LINE_WIDTH_CM1 = 20.0


@dataclass(frozen=True, eq=False)
class MoleculeSpectra:
    """IR and Raman lines of a molecule scene's vibrations, with their Lorentzian profiles (`molecule_spectra`).

    Attributes
    ----------
    ir, raman : StickSpectrum or None
        Lines (degenerate modes merged): IR in km/mol, Raman activities in Å^4/amu; None when
        the model gives none (no dipole change at all, no bonds).
    ir_profile, raman_profile : BroadenedSpectrum or None
        The lines broadened by Lorentzians of FWHM `LINE_WIDTH_CM1`, in the lines' unit per cm^-1.
    ir_species, raman_species : tuple of str
        Per line, the symmetry species of its modes (``""`` when not known).
    ir_model, raman_model : str
        Where the intensities come from, in words (for the chart and its caption).
    n_rigid : int
        Rigid-body modes left out.
    """

    ir: Any
    ir_profile: Any
    ir_species: tuple[str, ...]
    ir_model: str
    raman: Any
    raman_profile: Any
    raman_species: tuple[str, ...]
    raman_model: str
    n_rigid: int


def _line_species(positions: NDArray[np.float64], wavenumbers: NDArray[np.float64], indices: NDArray[np.intp],
                  species: Sequence[str], merge_cm1: float) -> tuple[str, ...]:
    out = []
    for position in positions:
        near = [species[int(k)] for k, w in zip(indices, wavenumbers) if abs(w - position) <= merge_cm1]
        out.append("+".join(dict.fromkeys(s for s in near if s)))
    return tuple(out)


def molecule_spectra(system: System, modes: Modes, symbols: Sequence[str], bonds: Sequence[tuple[int, int]],
                     symmetry: MoleculeSymmetry | None = None, *, merge_cm1: float = 0.5) -> MoleculeSpectra:
    """IR and Raman spectra of a molecule scene's modes, from the models `vibra.spectra` has for it.

    The scene's force field gives no dipole, so the IR intensities come from point charges
    (`vibra.spectra.electronegativity_charges` over `bonds`: mu = sum q_i r_i); the Raman
    activities from the bond-polarisability model with generic bond values
    (`vibra.spectra.raman_spectrum`). Both rank lines and tell allowed from forbidden ones;
    neither is quantitative. Rigid-body (zero) modes are left out. Lines closer than
    `merge_cm1` (cm^-1) are one line.
    """
    from vibra import spectra

    species = symmetry.species if symmetry is not None else ("",) * modes.n_modes
    grid_top = float(np.max(np.abs(modes.wavenumbers_cm1()), initial=0.0))
    grid = np.linspace(0.0, 1.1 * grid_top + 4 * LINE_WIDTH_CM1, 2400)
    n_rigid = int(np.sum(modes.zero_modes(1e-6)))
    ir = ir_profile = raman = raman_profile = None
    ir_species: tuple[str, ...] = ()
    raman_species: tuple[str, ...] = ()
    ir_model = "no IR model: the molecule has no bonds between different elements (no point charges)"
    raman_model = "no Raman model: the molecule has no bonds"
    if bonds:
        charges = spectra.electronegativity_charges(list(symbols), list(bonds))
        if np.any(np.abs(charges) > 0):
            result = spectra.ir_spectrum(system, modes, charges=charges)
            ir = result.sticks(merge_cm1=merge_cm1)
            ir_profile = ir.broadened(grid, LINE_WIDTH_CM1, "lorentzian")
            ir_species = _line_species(ir.wavenumbers, result.wavenumbers, result.mode_indices, species, merge_cm1)
            ir_model = ("IR intensities from point charges (Pauling electronegativities); "
                        "the force field itself gives no dipole")
        result_r = spectra.raman_spectrum(system, modes, bonds=list(bonds))
        raman = result_r.sticks(merge_cm1=merge_cm1)
        raman_profile = raman.broadened(grid, LINE_WIDTH_CM1, "lorentzian")
        raman_species = _line_species(raman.wavenumbers, result_r.wavenumbers, result_r.mode_indices, species,
                                      merge_cm1)
        raman_model = "Raman activities from bond polarisabilities (generic bond values)"
    return MoleculeSpectra(ir=ir, ir_profile=ir_profile, ir_species=ir_species, ir_model=ir_model, raman=raman,
                           raman_profile=raman_profile, raman_species=raman_species, raman_model=raman_model,
                           n_rigid=n_rigid)


def molecule_structure(scene: Scene, system: System) -> MoleculeStructure:
    """Elements and bonds of a molecule scene: the scene's symbols and springs, else guessed.

    Without symbols, each site is the element of nearest standard mass; without springs,
    bonds join atoms closer than 1.25 x the sum of their covalent radii.
    """
    from vibra.molecules import bonds_from_distances, symbols_from_masses
    from vibra.pipeline.render import MoleculeStructure
    from vibra.pipeline.scene.values import element_symbol

    params = scene.system.parameters
    symbols = params.get("symbols") or system.symbols
    if symbols is not None:
        symbols = [element_symbol(s) for s in symbols]  # D and T are drawn as hydrogen
    else:
        symbols = symbols_from_masses(system.masses)
    bonds = params.get("springs")
    if bonds is None:
        bonds = bonds_from_distances(system.positions, symbols)
    return MoleculeStructure(tuple(symbols), tuple((int(i), int(j)) for i, j in bonds))
