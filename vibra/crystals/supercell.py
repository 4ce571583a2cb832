"""One phonon written out on a supercell (what a render animates), and the conventional cube of a cubic lattice.

The displacement of atom j in cell n is u_j(n) = Re[a_j exp(i (2 pi q . n - omega t))] with
a_j = e_j / sqrt(m_j), e the cell-phase eigenvector of D(q) (`vibra.crystals.dynamical`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, frequency_span, short_repr
from vibra.crystals.dynamical import check_qpoints, phonons
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["SupercellMode", "supercell_mode", "conventional_cube", "CUBIC_CENTRINGS"]


@dataclass(frozen=True, eq=False)
class SupercellMode(Frozen):
    """One phonon written out on a supercell: what a render animates.

    The displacement of atom j in cell n is u_j(n) = Re[a_j exp(i (2 pi q . n - omega t))] with
    a_j = e_j / sqrt(m_j) (the cell-phase eigenvector), scaled so that max_j |a_j| = 1.

    Attributes
    ----------
    positions : (n_cells n_atoms, 3) ndarray
        Rest positions of the supercell's atoms, Cartesian, in the length unit; cell by cell.
    amplitudes : (n_cells n_atoms, 3) ndarray of complex
        Complex displacement of each atom (dimensionless, largest modulus 1).
    symbols : tuple of str
        The label of each atom.
    cell : (3, 3) ndarray
        The supercell's lattice vectors as rows, in the length unit.
    q : (3,) ndarray
        The wave vector, fractional coordinates of the reciprocal lattice.
    branch : int
        Branch index, 0 = lowest.
    omega : float
        Angular frequency, rad per time unit (imaginary as -|omega|).
    units : UnitSystem
    """

    positions: NDArray[np.float64]
    amplitudes: NDArray[np.complex128]
    symbols: tuple[str, ...]
    cell: NDArray[np.float64]
    q: NDArray[np.float64]
    branch: int
    omega: float
    units: UnitSystem

    def __repr__(self) -> str:
        q = ", ".join(f"{x:.4g}" for x in self.q)
        return short_repr(self, f"branch {self.branch} at q ({q})", frequency_span([self.omega], self.units),
                          f"{len(self.positions)} atoms", f"{self.units.name} units")

    def displacements(self, phase: float) -> NDArray[np.float64]:
        """(n, 3) real displacements Re[a exp(-i phase)] at the phase omega t = `phase` (radians)."""
        return np.real(self.amplitudes * np.exp(-1j * phase))


#: Integer matrices P that turn a centred cubic lattice's primitive cell into its conventional
#: cube (P @ cell): face-centred (det 4) and body-centred (det 2), in the usual primitive setting.
CUBIC_CENTRINGS: tuple[NDArray[np.int64], ...] = (
    np.array([[-1, 1, 1], [1, -1, 1], [1, 1, -1]], dtype=np.int64),
    np.array([[0, 1, 1], [1, 0, 1], [1, 1, 0]], dtype=np.int64),
)


def conventional_cube(crystal: Crystal) -> NDArray[np.int64] | None:
    """(3, 3) integer P with P @ cell a cube (the conventional cell of an fcc or bcc lattice, or
    the identity for a simple cubic one), or None when the lattice is not cubic in that setting."""
    if not all(crystal.periodic):
        return None
    for matrix in (np.eye(3, dtype=np.int64), *CUBIC_CENTRINGS):
        rows = matrix @ crystal.cell
        lengths = np.linalg.norm(rows, axis=1)
        gram = rows @ rows.T
        if np.allclose(gram, np.diag(np.full(3, lengths[0] ** 2)), rtol=0.0, atol=1e-8 * lengths[0] ** 2):
            return matrix
    return None


def _supercell_matrix(supercell: ArrayLike, crystal: Crystal) -> NDArray[np.int64]:
    """(3, 3) integer supercell matrix from 3 sizes or a 3 x 3 matrix (rows: the supercell's lattice
    vectors in units of the crystal's), checked."""
    size = np.asarray(supercell)
    if size.shape == (3,):
        if not np.issubdtype(size.dtype, np.integer) or (size < 1).any() or (size > 12).any():
            raise ValueError(f"supercell must be 3 integers from 1 to 12 (cells along each lattice vector), "
                             f"got {supercell!r}")
        matrix = np.diag(size).astype(np.int64)
    elif size.shape == (3, 3) and np.issubdtype(size.dtype, np.integer):
        matrix = size.astype(np.int64)
        cells = abs(round(float(np.linalg.det(matrix))))
        if cells < 1 or cells > 12 ** 3:
            raise ValueError(f"supercell matrix {matrix.tolist()} holds {cells} cells; expected 1 to {12 ** 3}")
    else:
        raise ValueError(f"supercell must be 3 integers (cells along each lattice vector) or a 3 x 3 integer "
                         f"matrix, got {supercell!r}")
    for axis in range(3):
        if not crystal.periodic[axis] and (matrix[axis, axis] != 1 or np.count_nonzero(matrix[axis]) != 1
                                           or np.count_nonzero(matrix[:, axis]) != 1):
            raise ValueError(f"supercell[{axis}] is {matrix[axis].tolist()} along a vacuum axis; it must be 1 "
                             "(that axis unmixed)")
    return matrix


def _cells_in(matrix: NDArray[np.int64]) -> NDArray[np.int64]:
    """(|det|, 3) the lattice translations n (in cell units) inside the supercell `matrix` @ cell, ordered."""
    corners = np.array([[a, b, c] for a in (0, 1) for b in (0, 1) for c in (0, 1)]) @ matrix
    low, high = corners.min(axis=0), corners.max(axis=0)
    box = np.stack(np.meshgrid(*[np.arange(lo, hi + 1) for lo, hi in zip(low, high)], indexing="ij"),
                   axis=-1).reshape(-1, 3)
    fractional = box @ np.linalg.inv(matrix.astype(float))
    inside = ((fractional > -1e-9) & (fractional < 1.0 - 1e-9)).all(axis=1)
    return box[inside]


def supercell_mode(crystal: Crystal, q: ArrayLike, branch: int, supercell: ArrayLike) -> SupercellMode:
    """Branch `branch` at `q` written out on a `supercell` of the crystal (see `SupercellMode`).

    `supercell` is 3 sizes (cells along each lattice vector) or a 3 x 3 integer matrix S whose
    rows are the supercell's lattice vectors in the crystal's (S @ cell), e.g.
    ``2 * conventional_cube(crystal)`` for 2 x 2 x 2 conventional cubes of an fcc lattice.

    Raises
    ------
    ValueError
        q not 3 finite numbers; branch outside 0 .. n_branches - 1; a supercell that is not 3
        positive integers (at most 12 each) or an integer matrix of 1 to 12^3 cells, or that is
        not 1 (unmixed) along a vacuum axis.
    """
    point = check_qpoints(np.asarray(q, dtype=float).reshape(1, -1) if np.ndim(q) == 1 else q, "q")
    if point.shape[0] != 1:
        raise ValueError(f"q must be one wave vector (3 fractional coordinates), got shape {np.shape(q)}")
    index = _validate.count(branch, "branch", low=0, high=crystal.n_branches - 1)
    matrix = _supercell_matrix(supercell, crystal)
    result = phonons(crystal, point, vectors=True, phase="cell")
    assert result.vectors is not None
    vector = result.vectors[0][:, index].reshape(crystal.n_atoms, 3) / np.sqrt(crystal.masses)[:, None]
    cells = _cells_in(matrix)
    phase = np.exp(2j * np.pi * cells @ point[0])
    amplitudes = (phase[:, None, None] * vector[None, :, :]).reshape(-1, 3)
    largest = float(np.abs(amplitudes).max())
    if largest > 0:
        amplitudes = amplitudes / largest
    positions = (cells @ crystal.cell)[:, None, :] + crystal.positions[None, :, :]
    return SupercellMode(positions=positions.reshape(-1, 3), amplitudes=amplitudes,
                         symbols=tuple(crystal.symbols) * len(cells), cell=matrix @ crystal.cell,
                         q=point[0], branch=index, omega=float(result.omega[0, index]), units=crystal.units)
