"""Checks shared by the molecule builders: ASE Atoms, tolerances, masses and names."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["MIN_DISTANCE", "check_atoms", "nonnegative_scalar", "molecule_name", "masses_or_default"]

#: Two atoms closer than this (Angstrom) are rejected as overlapping: no chemical bond is
#: shorter than about 0.5 Angstrom (H2: 0.74).
MIN_DISTANCE = 0.1


def check_atoms(atoms: object, name: str = "atoms") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions and masses of an ASE Atoms, after checking elements and overlaps."""
    from ase import Atoms as _Atoms
    from ase.data import chemical_symbols

    if not isinstance(atoms, _Atoms):
        raise TypeError(f"{name} must be an ase.Atoms, got {type(atoms).__name__}")
    if len(atoms) == 0:
        raise ValueError(f"{name} holds no atoms")
    numbers = atoms.get_atomic_numbers()
    bad = (numbers < 1) | (numbers >= len(chemical_symbols))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"{name}.numbers[{i}] is {numbers[i]} ({atoms.get_chemical_symbols()[i]!r}); every atom "
            "must be a chemical element (atomic number 1 to 118)"
        )
    positions = _validate.real_array(atoms.get_positions(), f"{name}.positions", ndim=2)
    masses = _validate.real_array(atoms.get_masses(), f"{name}.masses", ndim=1)
    _validate.positive(masses, f"{name}.masses", "mass")
    if len(atoms) > 1:
        from scipy.spatial.distance import pdist, squareform

        distance = squareform(pdist(positions))
        np.fill_diagonal(distance, np.inf)
        first, second = (int(x) for x in np.unravel_index(np.argmin(distance), distance.shape))
        i, j = min(first, second), max(first, second)
        if distance[i, j] < MIN_DISTANCE:
            raise ValueError(
                f"{name}: atoms {i} and {j} overlap (distance {distance[i, j]:.3g} Angstrom < "
                f"{MIN_DISTANCE} Angstrom)"
            )
    return positions, masses


def nonnegative_scalar(value: object, name: str, unit: str) -> float:
    """A finite real number >= 0 (a tolerance), in `unit` (named in the message)."""
    number = _validate.real_scalar(value, name)
    if number < 0:
        raise ValueError(f"{name} is {number!r}; it must be >= 0 ({unit})")
    return number


def molecule_name(atoms: Atoms, name: str | None) -> str:
    if name is not None:
        return _validate.text(name, "name")
    return str(atoms.get_chemical_formula(mode="hill"))


def masses_or_default(masses: ArrayLike | None, default: NDArray[np.float64]) -> NDArray[np.float64]:
    if masses is None:
        return default
    array = _validate.real_array(masses, "masses", ndim=1)
    if array.shape != default.shape:
        raise ValueError(f"masses must have {default.shape[0]} entries (one per atom), got {array.shape[0]}")
    _validate.positive(array, "masses", "mass")
    return array
