"""Spring force constants between periodic images: `springs(crystal, cutoff= or shells=, ...)`.

Every bond is found between an atom of cell 0 and an image of an atom in cell R, and its
vector is r_j + R @ cell - r_i: the image's own position, never a raw position across the cell.
A bond with unit vector e, longitudinal stiffness k_l and transverse k_t contributes the block

    Phi(i 0; j R) = -(k_l e e^T + k_t (1 - e e^T))

(and its mirror Phi(j 0; i -R)), and the opposite to the self blocks Phi(i 0; i 0), Phi(j 0; j 0):
the acoustic sum rule sum_{j,R} Phi(i 0; j R) = 0 holds term by term. Neighbour shells are the
distinct bond lengths in ascending order (to a relative 1e-8), counted over the whole crystal.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.crystals.force_constants import ForceConstants, SpringModel

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["springs", "neighbour_pairs", "SHELL_RTOL"]

#: Two bond lengths within this relative distance are one neighbour shell.
SHELL_RTOL = 1e-8
#: Most neighbour shells `springs` takes (a bound before any allocation).
MAX_SHELLS = 64


def _plane_spacings(cell: NDArray[np.float64]) -> NDArray[np.float64]:
    """(3,) distance between neighbouring lattice planes spanned by the other two vectors."""
    return 1.0 / np.linalg.norm(np.linalg.inv(cell), axis=0)


def neighbour_pairs(crystal: Crystal, radius: float
                    ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.int64], NDArray[np.float64]]:
    """Every ordered pair (i in cell 0, j in cell R) closer than `radius`, self excluded.

    Returns (first, second, translations, vectors), vectors Cartesian r_j + R @ cell - r_i.
    Translations run only along periodic axes. A bond vector has fractional component
    R_k + x_jk - x_ik with |x_jk - x_ik| < 1, so |R_k| <= radius / spacing_k + 1 suffices.
    """
    cell = crystal.cell
    reach = [int(math.floor(radius / s)) + 1 if p else 0 for s, p in zip(_plane_spacings(cell), crystal.periodic)]
    grids = np.meshgrid(*[np.arange(-r, r + 1) for r in reach], indexing="ij")
    translations = np.stack([g.ravel() for g in grids], axis=1).astype(np.int64)
    frac = crystal.fractional
    # (n_i, n_j, n_R, 3) fractional vectors
    delta = (frac[None, :, None, :] - frac[:, None, None, :]) + translations[None, None, :, :]
    vectors = delta @ cell
    length = np.linalg.norm(vectors, axis=-1)
    keep = (length <= radius * (1.0 + SHELL_RTOL)) & (length > 0.0)
    i, j, r = np.nonzero(keep)
    return i.astype(np.intp), j.astype(np.intp), translations[r], vectors[i, j, r]


def springs(
    crystal: Crystal,
    *,
    cutoff: float | None = None,
    shells: int | None = None,
    stiffness: ArrayLike = 1.0,
    transverse: ArrayLike = 0.0,
) -> Crystal:
    """The crystal with spring force constants to its neighbours (within `cutoff`, or `shells`).

    Parameters
    ----------
    crystal : Crystal
        The structure (any force constants it has are replaced).
    cutoff : float, optional
        Join every pair of atoms (images included) closer than this, in the length unit.
    shells : int, optional
        Join the first `shells` neighbour shells (default 1 when `cutoff` is not given).
    stiffness : float or (n_shells,) array_like
        Longitudinal spring constant, one for all shells or one per shell, in energy / length^2.
    transverse : float or (n_shells,) array_like
        Transverse (bond-bending) stiffness per shell, >= 0, in energy / length^2 (default 0:
        central springs).

    Returns
    -------
    Crystal
        With `force_constants` and `springs` (the bonds, each once).

    Examples
    --------
    >>> from vibra.crystals import Crystal
    >>> cube = Crystal.from_cell(np.eye(3), [[0.0, 0.0, 0.0]], 1.0)
    >>> sc = springs(cube, shells=2, stiffness=[1.0, 0.5])   # 6 neighbours at 1, 12 at sqrt(2)
    >>> int(sc.springs.first.size), sorted(set(np.round(np.linalg.norm(sc.springs.vectors, axis=1), 6)))
    (9, [np.float64(1.0), np.float64(1.414214)])

    Raises
    ------
    ValueError
        Both or neither of cutoff and shells out of range, a cutoff that reaches no neighbour,
        a stiffness list whose length is not the number of shells, a non-positive stiffness or a
        negative transverse one.
    """
    if cutoff is not None and shells is not None:
        raise ValueError("give cutoff or shells, not both")
    if cutoff is not None:
        radius = _validate.positive_scalar(cutoff, "cutoff", "cutoff distance")
        first, second, translations, vectors = neighbour_pairs(crystal, radius)
        if first.size == 0:
            raise ValueError(f"cutoff is {radius!r}; no two atoms are that close (the shortest lattice vector is "
                             f"{float(np.linalg.norm(crystal.cell, axis=1).min()):.6g})")
        levels = _shell_levels(np.linalg.norm(vectors, axis=1))
    else:
        wanted = 1 if shells is None else _validate.count(shells, "shells", low=1, high=MAX_SHELLS)
        radius = float(_plane_spacings(crystal.cell).min())
        while True:
            first, second, translations, vectors = neighbour_pairs(crystal, radius)
            levels = _shell_levels(np.linalg.norm(vectors, axis=1)) if first.size else np.zeros(0)
            if first.size and levels.max() >= wanted:
                # every shell up to `wanted` is complete: all pairs up to its length are in
                keep = levels <= wanted
                first, second, translations, vectors, levels = (
                    first[keep], second[keep], translations[keep], vectors[keep], levels[keep])
                break
            if not any(crystal.periodic) and radius > float(np.linalg.norm(crystal.cell, axis=1).sum()):
                found = int(levels.max()) if first.size else 0
                raise ValueError(f"shells is {wanted}, but the atoms of {crystal.name!r} (no periodic axis) have only "
                                 f"{found} neighbour shell{'s' if found != 1 else ''}")
            radius *= 1.5
    n_shells = int(levels.max())
    k_long = _per_shell(stiffness, n_shells, "stiffness", positive=True)
    k_trans = _per_shell(transverse, n_shells, "transverse", positive=False)
    # each bond once: first < second, or the same atom with R > 0 lexicographically
    sign = np.sign(translations @ np.array([1 << 20, 1 << 10, 1]))
    once = (first < second) | ((first == second) & (sign > 0))
    bonds = SpringModel(first=first[once], second=second[once], translations=translations[once],
                        vectors=vectors[once], longitudinal=k_long[levels[once] - 1],
                        transverse=k_trans[levels[once] - 1], shells=levels[once].astype(np.int64))
    return crystal.with_force_constants(spring_force_constants(bonds, crystal.n_atoms), springs=bonds)


def spring_force_constants(bonds: SpringModel, n_atoms: int) -> ForceConstants:
    """Terms Phi of a set of bonds (each once): two off-diagonal terms per bond, one self term per atom."""
    unit = bonds.vectors / np.linalg.norm(bonds.vectors, axis=1)[:, None]
    outer = unit[:, :, None] * unit[:, None, :]
    block = bonds.longitudinal[:, None, None] * outer + bonds.transverse[:, None, None] * (np.eye(3) - outer)
    self_blocks = np.zeros((n_atoms, 3, 3))
    np.add.at(self_blocks, bonds.first, block)
    np.add.at(self_blocks, bonds.second, block)
    atoms = np.arange(n_atoms)
    first = np.concatenate([atoms, bonds.first, bonds.second])
    second = np.concatenate([atoms, bonds.second, bonds.first])
    translations = np.concatenate([np.zeros((n_atoms, 3), dtype=np.int64), bonds.translations, -bonds.translations])
    blocks = np.concatenate([self_blocks, -block, -block])
    return ForceConstants(first=first.astype(np.intp), second=second.astype(np.intp),
                          translations=translations, blocks=blocks)


def _shell_levels(length: NDArray[np.float64]) -> NDArray[np.int64]:
    """(n,) shell number (from 1) of each bond length; lengths within SHELL_RTOL are one shell."""
    order = np.argsort(length)
    sorted_length = length[order]
    new = np.ones(len(length), dtype=bool)
    new[1:] = np.diff(sorted_length) > SHELL_RTOL * sorted_length[1:]
    levels = np.empty(len(length), dtype=np.int64)
    levels[order] = np.cumsum(new)
    return levels


def _per_shell(value: ArrayLike, n_shells: int, name: str, *, positive: bool) -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    if array.ndim == 0:
        array = np.full(n_shells, float(array))
    elif array.shape[0] != n_shells:
        raise ValueError(f"{name} has {array.shape[0]} entries but the springs join {n_shells} neighbour "
                         f"shell{'s' if n_shells != 1 else ''}; give one value, or one per shell")
    if positive:
        _validate.positive(array, name, "spring constant")
    else:
        _validate.nonnegative(array, name, "transverse stiffness")
    return array
