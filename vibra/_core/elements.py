"""Chemistry of sites given only masses and positions: element symbols and covalent bonds.

Tables from ``ase.data`` (standard atomic masses, covalent radii of Cordero et al. 2008),
imported inside the functions so that ``import vibra.molecules`` does not load ASE. Here, below
the results, because two layers draw on it: the molecules (`vibra.molecules` exports both
functions) and the 3-D view of a molecule whose Hessian came without bond terms (an engine's:
`vibra._results.display.system_view`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from vibra._core import validate as _validate

__all__ = ["BOND_SCALE", "symbols_from_masses", "bonds_from_distances"]

#: Two atoms are bonded when closer than this factor times the sum of their covalent radii.
BOND_SCALE = 1.25


def symbols_from_masses(masses: ArrayLike) -> tuple[str, ...]:
    """Chemical symbol of the element whose standard atomic mass is nearest each mass.

    Parameters
    ----------
    masses : (n_atoms,) array_like
        Masses, in amu (positive and finite).

    Returns
    -------
    tuple of str
        One symbol per mass, from ``ase.data.chemical_symbols`` (the element of nearest
        ``ase.data.atomic_masses``; a deuterium mass 2.014 gives ``"H"``). A heavy isotope
        can lie nearer the next element: 18O (17.999 amu) gives ``"F"`` (18.998); pass symbols
        explicitly for isotopically substituted molecules.

    Raises
    ------
    ValueError
        `masses` not 1-D, or a mass that is not positive and finite.

    Examples
    --------
    >>> symbols_from_masses([15.999, 12.011, 15.999])
    ('O', 'C', 'O')
    >>> symbols_from_masses([15.995, 2.014, 1.008])
    ('O', 'H', 'H')
    """
    from ase.data import atomic_masses, chemical_symbols

    values = _validate.real_array(masses, "masses", ndim=1)
    _validate.positive(values, "masses", "mass")
    # atomic_masses[0] is the dummy element X (mass 1.0): search the real elements only
    numbers = np.argmin(np.abs(atomic_masses[None, 1:] - values[:, None]), axis=1) + 1
    return tuple(chemical_symbols[int(z)] for z in numbers)


def bonds_from_distances(
    positions: ArrayLike,
    symbols: list[str] | tuple[str, ...],
    *,
    scale: float = BOND_SCALE,
) -> tuple[tuple[int, int], ...]:
    """Atom pairs (i < j) closer than `scale` times the sum of their covalent radii.

    Parameters
    ----------
    positions : (n_atoms, 3) array_like
        Positions, in Angstrom (1-D or 2-D positions, (n_atoms, 1) or (n_atoms, 2), are padded
        with zeros).
    symbols : sequence of str
        Chemical symbols, one per atom (``ase.data.chemical_symbols``).
    scale : float
        Factor on the sum of covalent radii (``ase.data.covalent_radii``), dimensionless (> 0).

    Returns
    -------
    tuple of (int, int)
        Bonded pairs, sorted (i ascending, then j).

    Raises
    ------
    TypeError
        A symbol that is not a str.
    ValueError
        `positions` not (n_atoms, 1 to 3) or not finite; `symbols` of another length; an
        unknown symbol (named); `scale` not positive and finite.

    Examples
    --------
    >>> bonds_from_distances([[-1.16, 0, 0], [0, 0, 0], [1.16, 0, 0]], ["O", "C", "O"])
    ((0, 1), (1, 2))
    """
    from ase.data import atomic_numbers, covalent_radii
    from scipy.spatial import cKDTree

    x = _validate.real_array(positions, "positions", ndim=2)
    if not 1 <= x.shape[1] <= 3:
        raise ValueError(f"positions must have shape (n_atoms, 3) (or 1 or 2 columns), got {x.shape}")
    names = list(symbols) if not isinstance(symbols, str) else [symbols]
    if len(names) != x.shape[0]:
        raise ValueError(f"symbols must name {x.shape[0]} atoms (one per position), got {len(names)}")
    numbers = np.empty(len(names), dtype=np.intp)
    for i, name in enumerate(names):
        if not isinstance(name, str):
            raise TypeError(f"symbols[{i}] must be a chemical symbol (str), got {type(name).__name__}")
        if name not in atomic_numbers or atomic_numbers[name] == 0:
            raise ValueError(f"symbols[{i}] is {name!r}; expected a chemical symbol such as 'H', 'C' or 'O'")
        numbers[i] = atomic_numbers[name]
    factor = _validate.positive_scalar(scale, "scale")
    x3 = np.zeros((x.shape[0], 3))
    x3[:, : x.shape[1]] = x
    radii = covalent_radii[numbers]
    if len(radii) < 2:
        return ()
    # candidates within the largest possible bond length (a k-d tree: no n x n matrix for a
    # large network), then the per-pair limit scale * (r_i + r_j)
    candidates = cKDTree(x3).query_pairs(factor * 2.0 * float(radii.max()), output_type="ndarray")
    if candidates.size == 0:
        return ()
    first, second = candidates[:, 0], candidates[:, 1]
    distance = np.linalg.norm(x3[first] - x3[second], axis=1)
    keep = distance < factor * (radii[first] + radii[second])
    pairs = np.sort(np.stack([first[keep], second[keep]], axis=1), axis=1)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    return tuple((int(i), int(j)) for i, j in pairs)
