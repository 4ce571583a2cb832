"""The valence force field: `ValenceModel` (V = 1/2 sum_t w_t (q_t - q_t0)^2) and its builder.

At an equilibrium the Hessian is exactly K = B^T diag(w) B with B the Wilson B matrix; stretches,
angle bends, linear bends (two perpendicular coordinates, as CO2 needs), torsions and
out-of-plane impropers, found by `internal_terms` and by default typed by `force_constants`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.molecules.checks import check_atoms
from vibra.molecules.coordinates import (angle_bend, bond_angle, bond_stretch, dihedral, linear_bend_rows,
                                         linear_bend_vector, wrap_angle)
from vibra._core.elements import BOND_SCALE, bonds_from_distances
from vibra.molecules.force_constants import (bend_constants, linear_bend_constants, out_of_plane_constants,
                                             stretch_constants, torsion_constants)
from vibra.molecules.internal_terms import internal_terms

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["ValenceModel", "valence_model"]


@dataclass(frozen=True, eq=False)
class ValenceModel(Frozen):
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
    out_of_plane : (n_out_of_plane, 4) ndarray of int
        Improper dihedrals (centre, a, b, c) holding a planar centre in the plane of its three
        neighbours; q = dihedral angle between the planes centre-a-b and a-b-c, in rad.
    out_of_plane_k : (n_out_of_plane,) ndarray
        Out-of-plane constants, in eV / rad^2.
    out_of_plane_phi0 : (n_out_of_plane,) ndarray
        Reference improper dihedrals, in rad (0 or pi for a planar centre).
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
    out_of_plane: NDArray[np.intp] = field(default_factory=lambda: np.zeros((0, 4), dtype=np.intp))
    out_of_plane_k: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    out_of_plane_phi0: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    @property
    def n_terms(self) -> int:
        """Number of rows of the B matrix (a linear bend counts twice)."""
        return (len(self.bonds) + len(self.angles) + 2 * len(self.linear_angles) + len(self.torsions)
                + len(self.out_of_plane))

    def weights(self) -> NDArray[np.float64]:
        """(n_terms,) force constants w in the row order of `wilson_b`."""
        return np.concatenate([self.bond_k, self.angle_k, np.repeat(self.linear_k, 2), self.torsion_k,
                               self.out_of_plane_k])

    def wilson_b(self, positions: ArrayLike) -> sp.csr_matrix:
        """(n_terms, 3 n_atoms) Wilson B matrix: row t is the gradient of q_t, at `positions`.

        Stretch rows are dimensionless; bend, linear-bend and torsion rows are in rad / Angstrom.
        Rows come in the order bonds, angles, linear bends (two per triple), torsions, out-of-plane terms.
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
        if len(self.out_of_plane):
            phi, g = dihedral(x, self.out_of_plane)
            d = wrap_angle(phi - self.out_of_plane_phi0)
            energy += 0.5 * float(np.sum(self.out_of_plane_k * d * d))
            _scatter(forces, self.out_of_plane, -(self.out_of_plane_k * d)[:, None, None] * g)
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
        if len(self.out_of_plane):
            blocks.append((self.out_of_plane, dihedral(x, self.out_of_plane)[1]))
        return blocks


def _scatter(forces: NDArray[np.float64], atoms_: NDArray[np.intp], values: NDArray[np.float64]) -> None:
    for a in range(atoms_.shape[1]):
        np.add.at(forces, atoms_[:, a], values[:, a, :])



def _per_term(value: ArrayLike | float, n: int, name: str) -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    if array.ndim == 0 and float(array) == 0.0 and name != "stretch":
        raise ValueError(f"{name} is 0; a force constant must be positive (pass {name}=None to leave these terms out)")
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



Typed = Literal["typed"]


def valence_model(
    atoms: Atoms,
    *,
    bonds: ArrayLike | None = None,
    stretch: ArrayLike | float | Typed = "typed",
    bend: ArrayLike | float | Typed | None = "typed",
    linear_bend: ArrayLike | float | Typed | None = None,
    torsion: ArrayLike | float | Typed | None = "typed",
    out_of_plane: ArrayLike | float | Typed | None = "typed",
    bond_scale: float = BOND_SCALE,
    linear_tolerance_deg: float = 1.0,
) -> ValenceModel:
    """A valence force field for `atoms`, with reference values taken from its geometry.

    Bonds join atoms closer than `bond_scale` times the sum of their covalent radii
    (``ase.data.covalent_radii``) unless given. Every pair of bonds sharing an atom makes an angle
    (except inside a three-membered ring, which its bonds hold); an angle within
    `linear_tolerance_deg` of 180 degrees becomes a linear bend (two perpendicular bending
    coordinates). Torsions: a dihedral i-j-k-l about every bond j-k (or straight chain j-...-k, as
    in allene and 2-butyne) for each pair of neighbours off the axis. Out-of-plane terms: improper
    dihedrals (up to three) at every planar atom with three bonds
    (`vibra.molecules.internal_terms`). Each kind of term takes its constants from the typed table
    of `vibra.molecules.force_constants` (``"typed"``, the default: by element pair and bond order,
    bend centre, torsion-axis order and planar centre), from one number for all terms of the kind,
    or from one number per term; None leaves the kind out.

    Parameters
    ----------
    atoms : ase.Atoms
        The molecule at its equilibrium geometry, positions in Angstrom.
    bonds : (n_bonds, 2) array_like of int, optional
        Bonded atom pairs; detected from covalent radii by default.
    stretch : "typed" or float or (n_bonds,) array_like
        Stretch constants, in eV / Angstrom^2.
    bend : "typed" or float or (n_angles,) array_like or None
        Bend constants for the (non-linear) angles, in eV / rad^2, in the order the angles are
        found (by vertex atom, then bond pairs). None leaves out angles and linear bends
        (central springs only).
    linear_bend : "typed" or float or (n_linear,) array_like, optional
        Linear-bend constants, in eV / rad^2; by default those of `bend` (typed, or its number).
    torsion : "typed" or float or (n_torsions,) array_like or None
        Torsion constants, in eV / rad^2: a number is given to every dihedral; None leaves
        torsions out (chains then twist freely).
    out_of_plane : "typed" or float or (n_out_of_plane,) array_like or None
        Out-of-plane constants of the improper dihedrals, in eV / rad^2; None leaves them out
        (a planar molecule then folds freely).
    bond_scale : float
        Factor on the sum of covalent radii below which two atoms are bonded (1.25, as
        `bonds_from_distances` and ASE's ``natural_cutoffs(atoms, mult=1.25)``).
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
        An unknown element, overlapping atoms, ``stretch=None``, a string other than "typed",
        bad indices or non-positive constants.

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
    if stretch is None:
        raise ValueError("stretch is None; every bond needs a stretch constant (\"typed\", a number or one per bond)")
    for value, name in ((stretch, "stretch"), (bend, "bend"), (linear_bend, "linear_bend"), (torsion, "torsion"),
                        (out_of_plane, "out_of_plane")):
        if isinstance(value, str) and value != "typed":
            raise ValueError(f"{name} is {value!r}; expected \"typed\", a number, one number per term or None")
    bond_scale = _validate.real_scalar(bond_scale, "bond_scale")
    if not bond_scale > 0:
        raise ValueError(f"bond_scale is {bond_scale!r}; it must be positive")
    tolerance = _validate.real_scalar(linear_tolerance_deg, "linear_tolerance_deg")
    if not 0 <= tolerance < 90:
        raise ValueError(f"linear_tolerance_deg is {tolerance!r}; expected 0 <= value < 90")
    n = len(atoms)
    symbols = atoms.get_chemical_symbols()
    if bonds is None:
        pairs = bonds_from_distances(positions, symbols, scale=bond_scale)
        bond_array = np.array(pairs, dtype=np.intp).reshape(-1, 2)
    else:
        bond_array = _index_list(bonds, "bonds", 2, n)
    lengths = bond_stretch(positions, bond_array)[0] if len(bond_array) else np.zeros(0)
    typed_k, orders = stretch_constants(symbols, lengths, bond_array)
    bond_k = typed_k if _is_typed(stretch) else _per_term(stretch, len(bond_array), "stretch")
    n_bonds = np.bincount(bond_array.ravel(), minlength=n)
    terms = internal_terms(positions, bond_array, linear_tolerance_deg=tolerance)
    none3, none4 = np.zeros((0, 3), dtype=np.intp), np.zeros((0, 4), dtype=np.intp)
    angle_array = terms.angles if bend is not None else none3
    linear_array = terms.linear_angles if bend is not None else none3
    if bend is None:
        angle_k = np.zeros(0)
    else:
        angle_k = (bend_constants(symbols, angle_array, n_bonds) if _is_typed(bend)
                   else _per_term(bend, len(angle_array), "bend"))
    if linear_bend is None:
        linear_bend = bend if bend is not None and (_is_typed(bend) or np.ndim(bend) == 0) else None
        if linear_bend is None and len(linear_array):
            raise ValueError("linear_bend is required when bend is given per angle and the molecule "
                             f"has {len(linear_array)} linear angle(s)")
    if not len(linear_array):
        linear_k = np.zeros(0)
    else:
        linear_k = (linear_bend_constants(symbols, linear_array) if _is_typed(linear_bend)
                    else _per_term(linear_bend, len(linear_array), "linear_bend"))  # type: ignore[arg-type]
    torsion_array = terms.torsions if torsion is not None else none4
    if torsion is None:
        torsion_k = np.zeros(0)
    elif _is_typed(torsion):
        order_of = {(int(min(i, j)), int(max(i, j))): float(o) for (i, j), o in zip(bond_array, orders)}
        torsion_k = torsion_constants(symbols, n_bonds, terms.torsion_axis, terms.axes, order_of)
    else:
        torsion_k = _per_term(torsion, len(torsion_array), "torsion")
    wag_array = terms.out_of_plane if out_of_plane is not None else none4
    if out_of_plane is None:
        wag_k = np.zeros(0)
    else:
        wag_k = (out_of_plane_constants(terms.out_of_plane_centre_count) if _is_typed(out_of_plane)
                 else _per_term(out_of_plane, len(wag_array), "out_of_plane"))
    return ValenceModel(
        n_atoms=n, bonds=bond_array, bond_k=bond_k, bond_r0=lengths,
        angles=angle_array, angle_k=angle_k,
        angle_theta0=bond_angle(positions, angle_array) if len(angle_array) else np.zeros(0),
        linear_angles=linear_array, linear_k=linear_k,
        torsions=torsion_array, torsion_k=torsion_k,
        torsion_phi0=dihedral(positions, torsion_array)[0] if len(torsion_array) else np.zeros(0),
        out_of_plane=wag_array, out_of_plane_k=wag_k,
        out_of_plane_phi0=dihedral(positions, wag_array)[0] if len(wag_array) else np.zeros(0),
    )


def _is_typed(value: object) -> bool:
    return isinstance(value, str) and value == "typed"
