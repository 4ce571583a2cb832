"""Molecules as `System`s from a Hessian: a valence force field (analytic), a matrix, ASE's
`VibrationsData` or phonopy force constants."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.molecules.checks import check_atoms, masses_or_default, molecule_name, nonnegative_scalar
from vibra.molecules.internal_terms import internal_terms
from vibra.molecules.rigid_body import expected_rigid_count, warn_soft_modes
from vibra.molecules.valence import ValenceModel, valence_model
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms
    from ase.vibrations import VibrationsData
    from phonopy import Phonopy

__all__ = ["from_atoms", "from_hessian", "from_vibrations_data", "from_phonopy"]


def _residual_force_check(model: ValenceModel, positions: NDArray[np.float64], tolerance: float) -> None:
    _, forces = model.energy_and_forces(positions)
    size = np.linalg.norm(forces, axis=1)
    worst = int(np.argmax(size))
    if size[worst] > tolerance:
        raise ValueError(
            f"atoms is not an equilibrium of the force field: residual force {size[worst]:.3g} eV/Angstrom "
            f"on atom {worst} (force_tolerance={tolerance:g}); K = B^T W B holds only where all forces "
            "vanish, so relax the geometry or use reference values taken from it"
        )



def _remedy(model: ValenceModel, positions: NDArray[np.float64]) -> str:
    """What to pass to `valence_model` (or `molecule`) for the kinds of terms the model lacks."""
    terms = internal_terms(positions, model.bonds, linear_tolerance_deg=1.0)
    missing = []
    if not len(model.angles) + len(model.linear_angles) and len(terms.angles) + len(terms.linear_angles):
        missing.append('no bends: pass bend="typed" (the default) or a constant in eV/rad^2; central springs '
                       "cannot hold the bends of a linear or planar molecule")
    if not len(model.torsions) and len(terms.torsions):
        missing.append(f"no torsions ({len(terms.torsions)} dihedrals would hold the twists about its bonds): "
                       'pass torsion="typed" (the default) or a constant in eV/rad^2, not torsion=None')
    if not len(model.out_of_plane) and len(terms.out_of_plane):
        missing.append("no out-of-plane terms (its planar centres fold freely): pass "
                       'out_of_plane="typed" (the default) or a constant in eV/rad^2, not out_of_plane=None')
    if not missing:
        return ("add the terms that hold them: a missing bond (bonds= or a larger bond_scale), or bend=, "
                "torsion= and out_of_plane= constants (valence_model)")
    return "the force field has " + "; ".join(missing)


def _zero_count_of_factor(b: sp.csr_matrix, masses: NDArray[np.float64], dim: int, rtol: float = 1e-8) -> int:
    """Zero modes of K = B^T W B: n_dof minus the numerical rank of B M^-1/2."""
    n_dof = b.shape[1]
    if b.shape[0] == 0:
        return n_dof
    weighted = b.toarray() / np.sqrt(np.repeat(masses, dim))[None, :]
    singular = np.linalg.svd(weighted, compute_uv=False)
    return n_dof - int(np.sum(singular > rtol * singular[0]))


def from_atoms(
    atoms: Atoms,
    model: ValenceModel | None = None,
    *,
    masses: ArrayLike | None = None,
    force_tolerance: float = 1e-4,
    name: str | None = None,
    **guess: ArrayLike | None,
) -> System:
    """A molecule with a valence force field, K = B^T diag(w) B (analytic Hessian).

    Parameters
    ----------
    atoms : ase.Atoms
        Equilibrium geometry (Angstrom); masses from ``atoms.get_masses()`` (amu) unless given.
    model : ValenceModel, optional
        The force field; by default ``valence_model(atoms, **guess)``.
    masses : (n_atoms,) array_like, optional
        Masses in amu, set explicitly.
    force_tolerance : float
        Largest residual force (eV / Angstrom) accepted at `atoms`: B^T W B is the Hessian
        only at an equilibrium.
    name : str, optional
        Name of the system (the Hill formula by default).
    **guess
        Keyword arguments of `valence_model` when `model` is None.

    Returns
    -------
    System
        Sites in 3-D, ASE units, K factorised as B^T diag(w) B.

    Warns
    -----
    SoftModeWarning
        When K has more zero modes than the rigid-body motions of the geometry (5 or 6).

    Raises
    ------
    ValueError
        Unknown elements, overlapping atoms, a model for another atom count, a model with no
        terms, or a geometry that is not an equilibrium (the residual force is reported).

    Examples
    --------
    >>> from vibra.molecules import h2o_atoms
    >>> system = from_atoms(h2o_atoms(), stretch=47.89, bend=4.021)
    >>> system.n_dof, system.units.name
    (9, 'ASE')
    """
    positions, default_masses = check_atoms(atoms)
    if model is None:
        model = valence_model(atoms, **guess)
    elif guess:
        raise TypeError(f"give either model or valence_model keywords, not both (got {sorted(guess)})")
    if not isinstance(model, ValenceModel):
        raise TypeError(f"model must be a ValenceModel, got {type(model).__name__}")
    if model.n_atoms != len(atoms):
        raise ValueError(f"model is for {model.n_atoms} atoms but atoms has {len(atoms)}")
    if model.n_terms == 0:
        raise ValueError("model has no terms (no bonds were found); pass bonds= or a larger bond_scale")
    site_masses = masses_or_default(masses, default_masses)
    tolerance = nonnegative_scalar(force_tolerance, "force_tolerance", "eV/Angstrom")
    _residual_force_check(model, positions, tolerance)
    b = model.wilson_b(positions)
    label = molecule_name(atoms, name)
    n_zero = _zero_count_of_factor(b, site_masses, 3)
    n_rigid = expected_rigid_count(positions, site_masses, 1e-6)
    if n_zero > n_rigid:
        warn_soft_modes(n_zero, n_rigid, label, _remedy(model, positions))
    system = System.from_terms(positions, site_masses, coupling=b, weights=model.weights(), units="ASE", name=label)
    return system.with_symbols(atoms.get_chemical_symbols())



def from_hessian(
    atoms: Atoms,
    hessian: ArrayLike,
    *,
    masses: ArrayLike | None = None,
    symmetrize: bool = False,
    name: str | None = None,
) -> System:
    """A molecule with a Hessian given by the user.

    Parameters
    ----------
    atoms : ase.Atoms
        Geometry (Angstrom) and masses (amu).
    hessian : (3 n_atoms, 3 n_atoms) array_like
        Second derivatives of the energy, eV / Angstrom^2, atom-major (x0, y0, z0, x1, ...).
    masses : (n_atoms,) array_like, optional
        Masses in amu instead of the atoms' own.
    symmetrize : bool
        Use (H + H^T) / 2 instead of raising on an asymmetric Hessian.
    name : str, optional
        Name of the system.

    Examples
    --------
    >>> from vibra.molecules import h2o, h2o_atoms
    >>> system = from_hessian(h2o_atoms(), h2o().hessian().toarray(), name="H2O")
    >>> system.n_dof, system.name
    (9, 'H2O')
    """
    positions, default_masses = check_atoms(atoms)
    site_masses = masses_or_default(masses, default_masses)
    symmetrize = _validate.boolean(symmetrize, "symmetrize")
    system = System.from_hessian(positions, site_masses, hessian,
                                 symmetrize=symmetrize, units="ASE", name=molecule_name(atoms, name))
    return system.with_symbols(atoms.get_chemical_symbols())


def from_vibrations_data(data: VibrationsData, *, name: str | None = None) -> System:
    """A molecule from ASE's `VibrationsData` (its Hessian, atoms and masses).

    Atoms left out of the data's ``indices`` are frozen.

    Examples
    --------
    >>> from ase.vibrations import VibrationsData
    >>> from vibra.molecules import h2o, h2o_atoms
    >>> data = VibrationsData.from_2d(h2o_atoms(), h2o().hessian().toarray())
    >>> from_vibrations_data(data).n_dof
    9
    """
    from ase.vibrations import VibrationsData

    if not isinstance(data, VibrationsData):
        raise TypeError(f"data must be an ase.vibrations.VibrationsData, got {type(data).__name__}")
    atoms = data.get_atoms()
    positions, masses = check_atoms(atoms, "data.atoms")
    indices = np.asarray(data.get_indices(), dtype=np.intp)
    n = len(atoms)
    full = np.zeros((3 * n, 3 * n))
    dofs = (indices[:, None] * 3 + np.arange(3)).ravel()
    full[np.ix_(dofs, dofs)] = data.get_hessian_2d()
    frozen = np.setdiff1d(np.arange(n), indices)
    system = System.from_hessian(positions, masses, full, frozen_sites=frozen if len(frozen) else None,
                                 units="ASE", name=molecule_name(atoms, name))
    return system.with_symbols(atoms.get_chemical_symbols())


def from_phonopy(phonon: Phonopy, *, name: str = "molecule") -> System:
    """A molecule from phonopy force constants (the molecule in a box as a 1x1x1 supercell).

    The Hessian is fc[i, j, a, b] -> K[3i + a, 3j + b] in eV / Angstrom^2 (phonopy's default
    units with an ASE-like calculator); masses are the supercell's (amu); positions are the
    supercell's Cartesian positions (the molecule must not be wrapped across the box).

    Raises
    ------
    TypeError
        `phonon` is not a phonopy.Phonopy.
    ValueError
        No force constants yet, or compact force constants of a supercell larger than the cell.
    """
    from phonopy import Phonopy

    if not isinstance(phonon, Phonopy):
        raise TypeError(f"phonon must be a phonopy.Phonopy, got {type(phonon).__name__}")
    fc = phonon.force_constants
    if fc is None:
        raise ValueError("phonon has no force constants; call produce_force_constants() first")
    cell = phonon.supercell
    n = len(cell.masses)
    if fc.shape != (n, n, 3, 3):
        raise ValueError(f"phonon.force_constants must be full, shape ({n}, {n}, 3, 3), got {fc.shape}")
    hessian = np.asarray(fc).transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    system = System.from_hessian(np.asarray(cell.positions), np.asarray(cell.masses), hessian,
                                 symmetrize=True, units="ASE", name=name)
    return system.with_symbols(list(cell.symbols))
