"""The valence force field: `ValenceModel` (V = 1/2 sum_t w_t (q_t - q_t0)^2) and its builder.

At an equilibrium the Hessian is exactly K = B^T diag(w) B with B the Wilson B matrix; stretches,
angle bends, linear bends (two perpendicular coordinates, as CO2 needs) and torsions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import freeze_arrays
from vibra.molecules.checks import check_atoms
from vibra.molecules.coordinates import (angle_bend, bond_angle, bond_stretch, dihedral, linear_bend_rows,
                                         linear_bend_vector, wrap_angle)
from vibra.molecules.elements import bonds_from_distances

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["ValenceModel", "valence_model"]


@dataclass(frozen=True, eq=False)
class ValenceModel:
    """A harmonic valence force field V = 1/2 sum_t w_t (q_t - q_t0)^2 on n_atoms atoms.

    Attributes
    ----------
    n_atoms : int
        Number of atoms the indices refer to.
    bonds : (n_bonds, 2) ndarray of int
        Atom pairs (i, j); q = |r_j - r_i|, in Angstrom.
    bond_k : (n_bonds,) ndarray
        Stretch constants, in eV / Angstrom^2.
    bond_r0 : (n_bonds,) ndarray
        Reference lengths, in Angstrom.
    angles : (n_angles, 3) ndarray of int
        Triples (i, j, k) with vertex j; q = angle i-j-k, in rad (0 < angle < pi).
    angle_k : (n_angles,) ndarray
        Bend constants, in eV / rad^2.
    angle_theta0 : (n_angles,) ndarray
        Reference angles, in rad.
    linear_angles : (n_linear, 3) ndarray of int
        Triples (i, j, k) with vertex j whose reference is straight (180 degrees). Energy
        1/2 k |e_ji + e_jk|^2 = k (1 + cos angle) ~ 1/2 k (pi - angle)^2 (rotation invariant);
        at the straight geometry it has two perpendicular bending coordinates (B rows).
    linear_k : (n_linear,) ndarray
        Linear-bend constants, in eV / rad^2.
    torsions : (n_torsions, 4) ndarray of int
        Quadruples (i, j, k, l); q = dihedral angle, in rad.
    torsion_k : (n_torsions,) ndarray
        Torsion constants, in eV / rad^2.
    torsion_phi0 : (n_torsions,) ndarray
        Reference dihedrals, in rad (the difference is wrapped into (-pi, pi]).
    """

    n_atoms: int
    bonds: NDArray[np.intp]
    bond_k: NDArray[np.float64]
    bond_r0: NDArray[np.float64]
    angles: NDArray[np.intp]
    angle_k: NDArray[np.float64]
    angle_theta0: NDArray[np.float64]
    linear_angles: NDArray[np.intp]
    linear_k: NDArray[np.float64]
    torsions: NDArray[np.intp]
    torsion_k: NDArray[np.float64]
    torsion_phi0: NDArray[np.float64]

    def __post_init__(self) -> None:
        freeze_arrays(self)

    @property
    def n_terms(self) -> int:
        """Number of rows of the B matrix (a linear bend counts twice)."""
        return len(self.bonds) + len(self.angles) + 2 * len(self.linear_angles) + len(self.torsions)

    def weights(self) -> NDArray[np.float64]:
        """(n_terms,) force constants w in the row order of `wilson_b`."""
        return np.concatenate([self.bond_k, self.angle_k, np.repeat(self.linear_k, 2), self.torsion_k])

    def wilson_b(self, positions: ArrayLike) -> sp.csr_matrix:
        """(n_terms, 3 n_atoms) Wilson B matrix: row t is the gradient of q_t, at `positions`.

        Stretch rows are dimensionless; bend, linear-bend and torsion rows are in rad / Angstrom.
        Rows come in the order bonds, angles, linear bends (two per triple), torsions.
        """
        x = self._positions(positions)
        rows: list[NDArray[np.float64]] = []
        cols: list[NDArray[np.intp]] = []
        data: list[NDArray[np.float64]] = []
        row = 0
        for atoms_, grads in self._gradient_blocks(x):
            n = atoms_.shape[0]
            for a in range(atoms_.shape[1]):
                rows.append(np.repeat(np.arange(row, row + n), 3))
                cols.append((atoms_[:, a, None] * 3 + np.arange(3)).ravel())
                data.append(grads[:, a, :].ravel())
            row += n
        if not rows:
            return sp.csr_matrix((0, 3 * self.n_atoms))
        b = sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(row, 3 * self.n_atoms))
        b.sum_duplicates()
        b.eliminate_zeros()
        return b

    def energy_and_forces(self, positions: ArrayLike) -> tuple[float, NDArray[np.float64]]:
        """Energy (eV) and forces ((n_atoms, 3), eV / Angstrom) at `positions` (Angstrom)."""
        x = self._positions(positions)
        energy = 0.0
        forces = np.zeros_like(x)
        if len(self.bonds):
            r, g = bond_stretch(x, self.bonds)
            d = r - self.bond_r0
            energy += 0.5 * float(np.sum(self.bond_k * d * d))
            _scatter(forces, self.bonds, -(self.bond_k * d)[:, None, None] * g)
        if len(self.angles):
            theta, g = angle_bend(x, self.angles)
            d = theta - self.angle_theta0
            energy += 0.5 * float(np.sum(self.angle_k * d * d))
            _scatter(forces, self.angles, -(self.angle_k * d)[:, None, None] * g)
        if len(self.linear_angles):
            s, g = linear_bend_vector(x, self.linear_angles)
            energy += 0.5 * float(np.sum(self.linear_k * np.sum(s * s, axis=1)))
            _scatter(forces, self.linear_angles, -self.linear_k[:, None, None] * g)
        if len(self.torsions):
            phi, g = dihedral(x, self.torsions)
            d = wrap_angle(phi - self.torsion_phi0)
            energy += 0.5 * float(np.sum(self.torsion_k * d * d))
            _scatter(forces, self.torsions, -(self.torsion_k * d)[:, None, None] * g)
        return energy, forces

    def _positions(self, positions: ArrayLike) -> NDArray[np.float64]:
        x = _validate.real_array(positions, "positions", ndim=2)
        if x.shape != (self.n_atoms, 3):
            raise ValueError(f"positions must have shape ({self.n_atoms}, 3), got {x.shape}")
        return x

    def _gradient_blocks(self, x: NDArray[np.float64]) -> list[tuple[NDArray[np.intp], NDArray[np.float64]]]:
        blocks = []
        if len(self.bonds):
            blocks.append((self.bonds, bond_stretch(x, self.bonds)[1]))
        if len(self.angles):
            blocks.append((self.angles, angle_bend(x, self.angles)[1]))
        if len(self.linear_angles):
            first, second = linear_bend_rows(x, self.linear_angles)
            # interleave: rows (2t, 2t+1) belong to linear triple t
            atoms_ = np.repeat(self.linear_angles, 2, axis=0)
            grads = np.empty((2 * len(self.linear_angles), 3, 3))
            grads[0::2], grads[1::2] = first, second
            blocks.append((atoms_, grads))
        if len(self.torsions):
            blocks.append((self.torsions, dihedral(x, self.torsions)[1]))
        return blocks


def _scatter(forces: NDArray[np.float64], atoms_: NDArray[np.intp], values: NDArray[np.float64]) -> None:
    for a in range(atoms_.shape[1]):
        np.add.at(forces, atoms_[:, a], values[:, a, :])



def _per_term(value: ArrayLike | float, n: int, name: str) -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    if array.ndim == 0:
        array = np.full(n, float(array))
    if array.shape[0] != n:
        raise ValueError(f"{name} must be a number or have {n} entries (one per term), got {array.shape[0]}")
    _validate.positive(array, name, "force constant")
    return array


def _index_list(value: ArrayLike | None, name: str, width: int, n_atoms: int) -> NDArray[np.intp]:
    if value is None:
        return np.zeros((0, width), dtype=np.intp)
    array = np.asarray(value)
    if array.size == 0:
        return np.zeros((0, width), dtype=np.intp)
    if not np.issubdtype(array.dtype, np.integer):
        raise TypeError(f"{name} must hold integer atom indices, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != width:
        raise ValueError(f"{name} must have shape (n, {width}), got {array.shape}")
    bad = (array < 0) | (array >= n_atoms)
    if bad.any():
        t, a = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(f"{name}[{t},{a}] is {array[t, a]}; atom indices run from 0 to {n_atoms - 1}")
    for t, row in enumerate(array):
        if len(set(row.tolist())) != width:
            raise ValueError(f"{name}[{t}] is {row.tolist()}; its atoms must be distinct")
    return array.astype(np.intp)



def valence_model(
    atoms: Atoms,
    *,
    bonds: ArrayLike | None = None,
    stretch: ArrayLike | float = 30.0,
    bend: ArrayLike | float | None = 3.0,
    linear_bend: ArrayLike | float | None = None,
    torsion: ArrayLike | float | None = None,
    bond_scale: float = 1.2,
    linear_tolerance_deg: float = 1.0,
) -> ValenceModel:
    """A valence force field for `atoms`, with reference values taken from its geometry.

    Bonds join atoms closer than `bond_scale` times the sum of their covalent radii
    (``ase.data.covalent_radii``) unless given. Every pair of bonds sharing an atom makes an
    angle; an angle within `linear_tolerance_deg` of 180 degrees becomes a linear bend (two
    perpendicular bending coordinates). Torsions (i-j-k-l along bonded chains, skipping
    linear angles) are added only when `torsion` is given.

    Parameters
    ----------
    atoms : ase.Atoms
        The molecule at its equilibrium geometry, positions in Angstrom.
    bonds : (n_bonds, 2) array_like of int, optional
        Bonded atom pairs; detected from covalent radii by default.
    stretch : float or (n_bonds,) array_like
        Stretch constants, in eV / Angstrom^2.
    bend : float or (n_angles,) array_like or None
        Bend constants for the (non-linear) angles, in eV / rad^2, in the order the angles are
        found (by vertex atom, then bond pairs). None leaves out angles and linear bends
        (central springs only).
    linear_bend : float or (n_linear,) array_like, optional
        Linear-bend constants, in eV / rad^2; `bend` (a scalar) by default.
    torsion : float or (n_torsions,) array_like, optional
        Torsion constants, in eV / rad^2; no torsions by default.
    bond_scale : float
        Factor on the sum of covalent radii below which two atoms are bonded.
    linear_tolerance_deg : float
        Angles within this many degrees of 180 are treated as linear.

    Returns
    -------
    ValenceModel

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms; bond indices are not integers.
    ValueError
        An unknown element, overlapping atoms, bad indices or non-positive constants.

    Examples
    --------
    >>> from vibra.molecules import co2_atoms
    >>> model = valence_model(co2_atoms())          # bonds from covalent radii, CO2 is straight
    >>> len(model.bonds), len(model.angles), len(model.linear_angles), model.n_terms
    (2, 0, 1, 4)
    >>> model.bond_r0.tolist()
    [1.16, 1.16]
    """
    positions, _ = check_atoms(atoms)
    bond_scale = _validate.real_scalar(bond_scale, "bond_scale")
    if not bond_scale > 0:
        raise ValueError(f"bond_scale is {bond_scale!r}; it must be positive")
    tolerance = _validate.real_scalar(linear_tolerance_deg, "linear_tolerance_deg")
    if not 0 <= tolerance < 90:
        raise ValueError(f"linear_tolerance_deg is {tolerance!r}; expected 0 <= value < 90")
    n = len(atoms)
    if bonds is None:
        pairs = bonds_from_distances(positions, atoms.get_chemical_symbols(), scale=bond_scale)
        bond_array = np.array(pairs, dtype=np.intp).reshape(-1, 2)
    else:
        bond_array = _index_list(bonds, "bonds", 2, n)
    bond_k = _per_term(stretch, len(bond_array), "stretch")
    neighbours: list[list[int]] = [[] for _ in range(n)]
    for i, j in bond_array:
        neighbours[i].append(int(j))
        neighbours[j].append(int(i))
    angles: list[tuple[int, int, int]] = []
    linear: list[tuple[int, int, int]] = []
    if bend is not None:
        for j in range(n):
            for p, i in enumerate(neighbours[j]):
                for k in neighbours[j][p + 1:]:
                    theta = bond_angle(positions, np.array([[i, j, k]]))[0]
                    (linear if np.degrees(np.pi - theta) < tolerance else angles).append((i, j, k))
    angle_array = np.array(angles, dtype=np.intp).reshape(-1, 3)
    linear_array = np.array(linear, dtype=np.intp).reshape(-1, 3)
    angle_k = _per_term(bend, len(angle_array), "bend") if bend is not None else np.zeros(0)
    if linear_bend is None:
        linear_bend = bend if bend is not None and np.ndim(bend) == 0 else None
        if linear_bend is None and len(linear_array):
            raise ValueError("linear_bend is required when bend is given per angle and the molecule "
                             f"has {len(linear_array)} linear angle(s)")
    linear_k = (_per_term(linear_bend, len(linear_array), "linear_bend")  # type: ignore[arg-type]
                if len(linear_array) else np.zeros(0))
    quads = []
    if torsion is not None:
        straight = {tuple(t) for t in linear_array.tolist()} | {tuple(t[::-1]) for t in linear_array.tolist()}
        for j, k in bond_array:
            for i in neighbours[j]:
                for m in neighbours[k]:
                    if i in (j, k) or m in (j, k) or i == m:
                        continue
                    if (i, j, k) in straight or (j, k, m) in straight:
                        continue
                    quads.append((i, int(j), int(k), m))
    torsion_array = np.array(quads, dtype=np.intp).reshape(-1, 4)
    torsion_k = _per_term(torsion, len(torsion_array), "torsion") if torsion is not None else np.zeros(0)
    return ValenceModel(
        n_atoms=n, bonds=bond_array, bond_k=bond_k,
        bond_r0=bond_stretch(positions, bond_array)[0] if len(bond_array) else np.zeros(0),
        angles=angle_array, angle_k=angle_k,
        angle_theta0=bond_angle(positions, angle_array) if len(angle_array) else np.zeros(0),
        linear_angles=linear_array, linear_k=linear_k,
        torsions=torsion_array, torsion_k=torsion_k,
        torsion_phi0=dihedral(positions, torsion_array)[0] if len(torsion_array) else np.zeros(0),
    )
