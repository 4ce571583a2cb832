"""Any molecule: a `System` from a name of ASE's molecule collection or from an ASE `Atoms`,
at the equilibrium of its valence force field, with optional isotopes.

Where the equilibrium comes from: `valence_model` takes every reference value (bond lengths,
angles, dihedrals) from the geometry it is given, and V = 1/2 sum_t w_t (q_t - q_t0)^2 >= 0,
so that geometry is an exact equilibrium (V = 0, the global minimum) and K = B^T diag(w) B is
its exact Hessian. The one exception is an angle within ``linear_tolerance_deg`` of 180
degrees: it becomes a linear bend whose reference is straight, so a nearly straight input
(acrylonitrile's C-C-N in ASE's collection, 179.3 degrees) carries a force. Only then is the
geometry relaxed (ASE's BFGS on `ValenceForceField`, the model's own energy and forces) until
V = 0 again, and the model is rebuilt there.
"""

from __future__ import annotations

import difflib
import importlib
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from vibra.molecules.checks import check_atoms, masses_or_default
from vibra.molecules.hessians import from_atoms
from vibra.molecules.isotopes import isotope_masses
from vibra.molecules.valence import ValenceModel, valence_model
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["EQUILIBRIUM_FORCE", "COMMON_NAMES", "molecule", "molecule_atoms", "molecule_names"]

#: Everyday names of common molecules -> their name in ASE's collection (a teacher types
#: "water", ASE knows "H2O"); matched without regard to case.
COMMON_NAMES: dict[str, str] = {
    "water": "H2O", "benzene": "C6H6", "ethanol": "CH3CH2OH", "methanol": "CH3OH", "methane": "CH4",
    "ethane": "C2H6", "propane": "C3H8", "ethylene": "C2H4", "ethene": "C2H4", "acetylene": "C2H2",
    "ethyne": "C2H2", "ammonia": "NH3", "carbon dioxide": "CO2", "carbon monoxide": "CO",
    "formaldehyde": "H2CO", "acetaldehyde": "CH3CHO", "acetone": "CH3COCH3", "acetic acid": "CH3COOH",
    "formic acid": "HCOOH", "hydrogen peroxide": "H2O2", "hydrogen cyanide": "HCN", "hydrogen chloride": "HCl",
    "hydrogen": "H2", "nitrogen": "N2", "oxygen": "O2", "ozone": "O3", "sulfur dioxide": "SO2",
    "nitrogen dioxide": "NO2", "acetonitrile": "CH3CN", "phosphine": "PH3", "silane": "SiH4",
    "carbon tetrachloride": "CCl4", "tetrafluoromethane": "CF4",
}

#: Largest force (eV / Angstrom) left on an atom at the returned equilibrium; below it the
#: input geometry is kept as is, above it the geometry is relaxed to this tolerance.
EQUILIBRIUM_FORCE = 1e-8


def molecule_names() -> tuple[str, ...]:
    """Every name `molecule` accepts: ASE's g2 collection and the extra molecules of
    ``ase.build.molecule`` (``"CH4"``, ``"C6H6"``, ``"H2O"``, ``"biphenyl"``, ...), sorted.

    Examples
    --------
    >>> names = molecule_names()
    >>> "CH4" in names and "C6H6" in names and len(names) > 150
    True
    """
    from ase.collections import g2

    # ase.build exports the function under its module's name: import the module by its path
    extra = getattr(importlib.import_module("ase.build.molecule"), "extra", {})
    return tuple(sorted(set(g2.names) | set(extra)))


def molecule_atoms(
    name_or_atoms: str | Atoms,
    *,
    isotopes: Sequence[str | None] | Mapping[int, str] | None = None,
    masses: ArrayLike | None = None,
) -> Atoms:
    """A copy of the molecule as ASE `Atoms`, symbols and masses set (isotopes applied).

    Useful as the geometry of `vibra.spectra.ideal_gas_thermochemistry`, or wherever ASE
    `Atoms` are wanted; the `System` of `molecule` carries the same symbols (`System.symbols`).

    Parameters
    ----------
    name_or_atoms : str or ase.Atoms
        A name from `molecule_names` (case-sensitive, as ASE spells it) or a molecule.
    isotopes : sequence of (str or None) or mapping of int to str, optional
        Isotope labels per atom (``"D"``, ``"T"``, ``"13C"``, ``"18O"``, ...; see `isotope_masses`).
    masses : (n_atoms,) array_like, optional
        Masses in amu instead (not together with `isotopes`).

    Raises
    ------
    TypeError
        `name_or_atoms` neither a str nor an ase.Atoms.
    ValueError
        An unknown name (the message lists close matches), an unknown isotope label (the
        message lists the valid ones), both `isotopes` and `masses`, bad masses.

    Examples
    --------
    >>> atoms = molecule_atoms("H2O", isotopes={1: "D", 2: "D"})
    >>> atoms.get_chemical_symbols(), atoms.get_masses().round(3).tolist()
    (['O', 'H', 'H'], [15.999, 2.014, 2.014])
    """
    from ase import Atoms as _Atoms
    from ase.build import molecule as _ase_molecule

    if isinstance(name_or_atoms, str):
        names = molecule_names()
        if name_or_atoms not in names and name_or_atoms.strip().lower() in COMMON_NAMES:
            name_or_atoms = COMMON_NAMES[name_or_atoms.strip().lower()]
        if name_or_atoms not in names:
            folded = {name.lower(): name for name in names}
            folded.update({common: f"{common} ({formula})" for common, formula in COMMON_NAMES.items()})
            close = difflib.get_close_matches(name_or_atoms.lower(), list(folded), n=5, cutoff=0.6)
            hint = f"; close matches: {', '.join(folded[c] for c in close)}" if close else ""
            raise ValueError(f"molecule name {name_or_atoms!r} is not in ASE's molecule collection "
                             f"(g2 and extras, {len(names)} names: vibra.molecules.molecule_names()){hint}")
        atoms = _ase_molecule(name_or_atoms)
    elif isinstance(name_or_atoms, _Atoms):
        atoms = name_or_atoms.copy()
        atoms.calc = None
    else:
        raise TypeError(f"name_or_atoms must be a molecule name (str) or an ase.Atoms, "
                        f"got {type(name_or_atoms).__name__}")
    _, default_masses = check_atoms(atoms, "name_or_atoms")
    if isotopes is not None and masses is not None:
        raise ValueError("give isotopes (labels) or masses (amu), not both")
    if masses is not None:
        atoms.set_masses(masses_or_default(masses, default_masses))
    else:
        atoms.set_masses(isotope_masses(atoms.get_chemical_symbols(), default_masses, isotopes=isotopes))
    return atoms


def molecule(
    name_or_atoms: str | Atoms,
    *,
    isotopes: Sequence[str | None] | Mapping[int, str] | None = None,
    masses: ArrayLike | None = None,
    name: str | None = None,
    **valence_model_options: ArrayLike | None,
) -> System:
    """A molecule by name (ASE's collection) or from `Atoms`, at its valence-force-field equilibrium.

    The force field is ``valence_model(atoms, **valence_model_options)`` (same defaults:
    bonds from covalent radii; stretches, bends, torsions and out-of-plane terms with the typed
    constants of `vibra.molecules.force_constants`, by element pair and bond order, bend
    centre, torsion axis and planar centre, fitted to observed fundamentals; docs/molecules.md
    gives their errors against experiment). Its reference values are the input geometry, which
    is therefore the equilibrium (module docstring); a nearly straight angle treated as a
    linear bend is straightened by relaxation first. ``torsion=None`` or ``out_of_plane=None``
    leave chains and planar molecules free to twist or fold; the one `SoftModeWarning` of
    `from_atoms` then names the zero modes and the keyword that holds them.

    Parameters
    ----------
    name_or_atoms : str or ase.Atoms
        A name from `molecule_names` (``"CH4"``, ``"C6H6"``, ``"NH3"``), an everyday name of
        `COMMON_NAMES` (``"water"``, ``"benzene"``, ``"ethanol"``), or any molecule.
    isotopes : sequence of (str or None) or mapping of int to str, optional
        Isotope labels per atom (``["C", "D", "D", "D", "D"]`` is not a label list: use
        ``[None, "D", "D", "D", "D"]`` or ``{1: "D"}``); the force field is unchanged.
    masses : (n_atoms,) array_like, optional
        Masses in amu instead of `isotopes`.
    name : str, optional
        Name of the system (the given molecule name, or the Hill formula of `Atoms`).
    **valence_model_options
        Keyword arguments of `valence_model` (``stretch``, ``bend``, ``torsion``,
        ``out_of_plane``, ``bonds``, ...): ``"typed"`` (the default), a number, one number per
        term, or None to leave out a kind of term.

    Returns
    -------
    System
        3-D sites in ASE units (amu, Angstrom, eV), K = B^T diag(w) B. Atom order and
        positions are those of the input (or of ``ase.build.molecule(name)``); the chemical
        symbols are those of `molecule_atoms` with the same arguments.

    Raises
    ------
    TypeError
        `name_or_atoms` of the wrong kind; an unknown valence-model keyword.
    ValueError
        An unknown name (with close matches), an unknown isotope label (with the valid ones), a
        single atom (nothing vibrates), a molecule in which no bonds are found.

    Examples
    --------
    >>> from vibra.molecules import vibrational_analysis
    >>> methane = molecule("CH4")
    >>> analysis = vibrational_analysis(methane)
    >>> analysis.n_vibrations, analysis.n_rigid
    (9, 6)
    >>> heavy = vibrational_analysis(molecule("CH4", isotopes=[None, "D", "D", "D", "D"]))
    >>> bool(heavy.vibration_wavenumbers_cm1().max() < analysis.vibration_wavenumbers_cm1().max())
    True
    """
    atoms = molecule_atoms(name_or_atoms, isotopes=isotopes, masses=masses)
    label = name if name is not None else (
        name_or_atoms if isinstance(name_or_atoms, str) else atoms.get_chemical_formula(mode="hill"))
    if len(atoms) < 2:
        raise ValueError(f"molecule {label!r} is a single atom: it has no bonds and no vibrations")
    model = valence_model(atoms, **valence_model_options)
    if model.n_terms and _largest_force(model, atoms.get_positions()) > EQUILIBRIUM_FORCE:
        atoms = _relaxed(atoms, model)
        model = valence_model(atoms, **valence_model_options)
    return from_atoms(atoms, model, force_tolerance=EQUILIBRIUM_FORCE, name=label)


def _largest_force(model: ValenceModel, positions: np.ndarray) -> float:
    return float(np.linalg.norm(model.energy_and_forces(positions)[1], axis=1).max())


def _relaxed(atoms: Atoms, model: ValenceModel) -> Atoms:
    """`atoms` moved to a minimum of `model` (forces below EQUILIBRIUM_FORCE) with ASE's BFGS."""
    from ase.optimize import BFGS

    from vibra.molecules.calculator import ValenceForceField

    moving = atoms.copy()
    moving.calc = ValenceForceField(model)
    optimizer = BFGS(moving, logfile=None)
    if not optimizer.run(fmax=EQUILIBRIUM_FORCE, steps=2000):
        raise RuntimeError(
            f"the valence force field of {atoms.get_chemical_formula(mode='hill')} did not relax to "
            f"forces below {EQUILIBRIUM_FORCE:g} eV/Angstrom in 2000 BFGS steps (largest force "
            f"{_largest_force(model, moving.get_positions()):.3g} eV/Angstrom)")
    relaxed = atoms.copy()
    relaxed.set_positions(moving.get_positions())
    return relaxed
