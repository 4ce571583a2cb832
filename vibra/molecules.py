"""Molecules: `System` builders from ASE `Atoms`, Hessians, and the vibrational analysis.

Units are ASE's (amu, Angstrom, eV; DESIGN.md "Units"): positions in Angstrom, masses in amu,
force constants in eV / Angstrom^2 (stretches) or eV / rad^2 (bends, torsions); frequencies are
reported in cm^-1.

Where K comes from
------------------
- A **valence force field** (`ValenceModel`): bond stretches, angle bends, linear bends (two
  perpendicular bending coordinates, as CO2 needs) and optional torsions, with potential
  V = 1/2 sum_t w_t (q_t(X) - q_t0)^2. At an equilibrium dV/dq = 0, so the Hessian is exactly
  K = B^T diag(w) B with B the Wilson B matrix (row t = gradient of q_t); `from_atoms` builds
  the `System` with `System.from_terms` so that the accurate solver path stays available.
  `ValenceForceField` is an ASE calculator for the same potential with the exact nonlinear
  coordinates (used by the cross-checks against ASE and phonopy).
- **Any ASE calculator**: `finite_difference_hessian` (2- or 4-point central differences of the
  forces, symmetrised, with a Richardson estimate of its truncation error and a round-off
  estimate) and `from_calculator`.
- A Hessian given directly (`from_hessian`), ASE's `VibrationsData` (`from_vibrations_data`) or
  phonopy force constants (`from_phonopy`).

The vibrational analysis (`vibrational_analysis`) projects out translations and rotations like
the quantum-chemistry codes (Eckart), detects linear molecules from the inertia tensor with a
relative tolerance, reports 3N-6 (3N-5) vibrations, keeps imaginary modes and flags them, and
gives per-mode reduced masses, force constants and the zero-point energy.

`co2` and `h2o` are ready-made models; `substitute_isotopes` changes masses on the same K.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal, Mapping

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra import _validate
from vibra.modes import Modes, normal_modes
from vibra._frozen import _freeze_arrays
from vibra.system import System
from vibra.units import ASE

if TYPE_CHECKING:
    from ase import Atoms

from ase.calculators.calculator import Calculator, all_changes

__all__ = [
    "SoftModeWarning", "ValenceModel", "ValenceForceField", "valence_model", "from_atoms",
    "FiniteDifferenceHessian", "finite_difference_hessian", "from_calculator", "from_hessian",
    "from_vibrations_data", "from_phonopy", "VibrationalAnalysis", "vibrational_analysis",
    "rigid_body_vectors", "is_linear", "isotope_mass", "substitute_isotopes", "co2", "h2o",
    "co2_atoms", "h2o_atoms",
    "CO2_STRETCH", "CO2_BEND", "CO2_BOND_LENGTH", "H2O_STRETCH", "H2O_BEND", "H2O_BOND_LENGTH",
    "H2O_ANGLE_DEG", "MIN_DISTANCE", "ISOTOPE_MASSES",
]

#: Two atoms closer than this (Angstrom) are rejected as overlapping: no chemical bond is
#: shorter than about 0.5 Angstrom (H2: 0.74).
MIN_DISTANCE = 0.1

# --------------------------------------------------------------------------- default models
#: CO2 bond length, Angstrom (seed 003, Example 11: L = 0.116 nm).
CO2_BOND_LENGTH = 1.16
#: CO2 C=O stretch constant kappa, eV/Angstrom^2 (= 15.4 mdyn/Angstrom). Fitted here, in the
#: seed's axial model (eq. 157, masses 15.999 and 12.011 amu), to the experimental
#: fundamentals 1333 and 2349 cm^-1 by least squares on log(omega): one kappa cannot give both
#: (the ratio sqrt(1 + 2 m_O / m_C) = 1.915 of eq. 157 against 1.762 observed), so the model
#: gives 1279 and 2448 cm^-1, each 4 % off. Literature valence force fields give 16 mdyn/A.
CO2_STRETCH = 96.24
#: CO2 linear-bend constant k_delta, eV/rad^2 (k_delta / L^2 = 0.57 mdyn/Angstrom, as in
#: Herzberg's valence force field). Fitted here to the experimental bend 667 cm^-1:
#: omega^2 = k_delta (2 / m_O + 4 / m_C) / L^2 gives 667.0 cm^-1 exactly.
CO2_BEND = 4.806
#: H2O geometry (experimental equilibrium: r_e = 0.9572 Angstrom, angle 104.52 degrees).
H2O_BOND_LENGTH = 0.9572
H2O_ANGLE_DEG = 104.52
#: H2O O-H stretch constant, eV/Angstrom^2, and bend constant, eV/rad^2. Fitted here (simple
#: valence force field, no interaction constants) by least squares on log(omega) to the
#: experimental fundamentals 1595, 3657 and 3756 cm^-1; the model gives 1595, 3680 and
#: 3733 cm^-1 (k_r = 7.67 mdyn/Angstrom; see docs/molecules.md).
H2O_STRETCH = 47.89
H2O_BEND = 4.021

# Isotope masses in amu: NIST "Atomic Weights and Isotopic Compositions" (the AME2016 and
# AME2020 evaluations agree on every digit given here). ase.data has no isotope table offline
# (ase.data.isotopes downloads it), hence this table; vibra.spectra uses the same one.
_ISOTOPES: dict[str, float] = {
    "1H": 1.00782503223, "2H": 2.01410177812, "3H": 3.0160492779,
    "12C": 12.0, "13C": 13.00335483507, "14C": 14.0032419884,
    "14N": 14.00307400443, "15N": 15.00010889888,
    "16O": 15.99491461957, "17O": 16.99913175650, "18O": 17.99915961286,
    "32S": 31.9720711744, "34S": 33.967867004,
    "35Cl": 34.968852682, "37Cl": 36.965902602,
}
_ISOTOPE_ALIASES = {"D": "2H", "T": "3H"}
#: Isotope label -> mass in amu (``"13C"``, ``"18O"``, ``"D"`` = ``"2H"``, ...), read-only; the
#: one table behind `isotope_mass`, `substitute_isotopes` and `vibra.spectra.isotope_shifts`.
ISOTOPE_MASSES: Mapping[str, float] = MappingProxyType(
    {**_ISOTOPES, **{alias: _ISOTOPES[key] for alias, key in _ISOTOPE_ALIASES.items()}})


class SoftModeWarning(UserWarning):
    """The force field leaves more zero-frequency modes than rigid-body motions explain."""


# --------------------------------------------------------------------------- valence model
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
        _freeze_arrays(self)

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
            r, g = _stretch(x, self.bonds)
            d = r - self.bond_r0
            energy += 0.5 * float(np.sum(self.bond_k * d * d))
            _scatter(forces, self.bonds, -(self.bond_k * d)[:, None, None] * g)
        if len(self.angles):
            theta, g = _bend(x, self.angles)
            d = theta - self.angle_theta0
            energy += 0.5 * float(np.sum(self.angle_k * d * d))
            _scatter(forces, self.angles, -(self.angle_k * d)[:, None, None] * g)
        if len(self.linear_angles):
            s, g = _linear_bend_vector(x, self.linear_angles)
            energy += 0.5 * float(np.sum(self.linear_k * np.sum(s * s, axis=1)))
            _scatter(forces, self.linear_angles, -self.linear_k[:, None, None] * g)
        if len(self.torsions):
            phi, g = _torsion(x, self.torsions)
            d = _wrap(phi - self.torsion_phi0)
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
            blocks.append((self.bonds, _stretch(x, self.bonds)[1]))
        if len(self.angles):
            blocks.append((self.angles, _bend(x, self.angles)[1]))
        if len(self.linear_angles):
            first, second = _linear_bend_rows(x, self.linear_angles)
            # interleave: rows (2t, 2t+1) belong to linear triple t
            atoms_ = np.repeat(self.linear_angles, 2, axis=0)
            grads = np.empty((2 * len(self.linear_angles), 3, 3))
            grads[0::2], grads[1::2] = first, second
            blocks.append((atoms_, grads))
        if len(self.torsions):
            blocks.append((self.torsions, _torsion(x, self.torsions)[1]))
        return blocks


def _scatter(forces: NDArray[np.float64], atoms_: NDArray[np.intp], values: NDArray[np.float64]) -> None:
    for a in range(atoms_.shape[1]):
        np.add.at(forces, atoms_[:, a], values[:, a, :])


def _stretch(x: NDArray[np.float64], pairs: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bond lengths (n,) and gradients (n, 2, 3)."""
    v = x[pairs[:, 1]] - x[pairs[:, 0]]
    r = np.linalg.norm(v, axis=1)
    e = v / r[:, None]
    return r, np.stack([-e, e], axis=1)


def _angle(x: NDArray[np.float64], triples: NDArray[np.intp]) -> NDArray[np.float64]:
    """Angles i-j-k (n,) in rad."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    # arctan2 of |u x v| and u . v keeps full accuracy near 0 and pi (arccos does not)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.sum(u * v, axis=1))


def _bend(x: NDArray[np.float64], triples: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Angles i-j-k (n,) in rad and their Wilson gradients (n, 3, 3) (singular at 0 and pi)."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)
    lv = np.linalg.norm(v, axis=1)
    eu, ev = u / lu[:, None], v / lv[:, None]
    cos = np.sum(eu * ev, axis=1)
    sin = np.linalg.norm(np.cross(eu, ev), axis=1)
    theta = np.arctan2(sin, cos)
    gi = (cos[:, None] * eu - ev) / (lu * sin)[:, None]
    gk = (cos[:, None] * ev - eu) / (lv * sin)[:, None]
    return theta, np.stack([gi, -gi - gk, gk], axis=1)


def _perpendiculars(axis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors perpendicular to each (n, 3) unit axis and to each other."""
    trial = np.zeros_like(axis)
    smallest = np.argmin(np.abs(axis), axis=1)
    trial[np.arange(len(axis)), smallest] = 1.0
    n1 = trial - np.sum(trial * axis, axis=1)[:, None] * axis
    n1 /= np.linalg.norm(n1, axis=1)[:, None]
    return n1, np.cross(axis, n1)


def _linear_bend_rows(x: NDArray[np.float64], triples: NDArray[np.intp]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The two linear-bend B rows (n, 3 atoms, 3) at a straight geometry.

    Coordinate a = n_a . (e_ji + e_jk) (radians of deflection towards n_a); its gradient is
    n_a / |r_ji| on i, n_a / |r_jk| on k and minus their sum on j.
    """
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)[:, None]
    lv = np.linalg.norm(v, axis=1)[:, None]
    axis = (u / lu - v / lv)
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    out = []
    for n in _perpendiculars(axis):
        out.append(np.stack([n / lu, -n / lu - n / lv, n / lv], axis=1))
    return out[0], out[1]


def _linear_bend_vector(x: NDArray[np.float64], triples: NDArray[np.intp]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """s = e_ji + e_jk (n, 3) and the gradient of 1/2 |s|^2 (n, 3 atoms, 3)."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)[:, None]
    lv = np.linalg.norm(v, axis=1)[:, None]
    eu, ev = u / lu, v / lv
    s = eu + ev
    gi = (s - np.sum(s * eu, axis=1)[:, None] * eu) / lu
    gk = (s - np.sum(s * ev, axis=1)[:, None] * ev) / lv
    return s, np.stack([gi, -gi - gk, gk], axis=1)


def _torsion(x: NDArray[np.float64], quads: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Dihedrals i-j-k-l (n,) in rad, IUPAC sign, and their gradients (n, 4, 3).

    Blondel & Karplus, J. Comput. Chem. 17, 1132 (1996): F = r_i - r_j, G = r_j - r_k,
    H = r_l - r_k, A = F x G, B = H x G.
    """
    f = x[quads[:, 0]] - x[quads[:, 1]]
    g = x[quads[:, 1]] - x[quads[:, 2]]
    h = x[quads[:, 3]] - x[quads[:, 2]]
    a = np.cross(f, g)
    b = np.cross(h, g)
    lg = np.linalg.norm(g, axis=1)
    a2 = np.sum(a * a, axis=1)
    b2 = np.sum(b * b, axis=1)
    phi = np.arctan2(np.sum(np.cross(b, a) * g, axis=1) / lg, np.sum(a * b, axis=1))
    fg = np.sum(f * g, axis=1)
    hg = np.sum(h * g, axis=1)
    gi = -(lg / a2)[:, None] * a
    gl = (lg / b2)[:, None] * b
    gj = (lg / a2 + fg / (a2 * lg))[:, None] * a - (hg / (b2 * lg))[:, None] * b
    gk = -(lg / b2 - hg / (b2 * lg))[:, None] * b - (fg / (a2 * lg))[:, None] * a
    return phi, np.stack([gi, gj, gk, gl], axis=1)


def _wrap(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


# --------------------------------------------------------------------------- atoms checks
def _check_atoms(atoms: Any, name: str = "atoms") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
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


def _nonnegative(value: Any, name: str, unit: str) -> float:
    """A finite real number >= 0 (a tolerance), in `unit` (named in the message)."""
    number = _validate.real_scalar(value, name)
    if number < 0:
        raise ValueError(f"{name} is {number!r}; it must be >= 0 ({unit})")
    return number


def _molecule_name(atoms: Any, name: str | None) -> str:
    return name if name is not None else atoms.get_chemical_formula(mode="hill")


def _site_masses(masses: ArrayLike | None, default: NDArray[np.float64]) -> NDArray[np.float64]:
    if masses is None:
        return default
    array = _validate.real_array(masses, "masses", ndim=1)
    if array.shape != default.shape:
        raise ValueError(f"masses must have {default.shape[0]} entries (one per atom), got {array.shape[0]}")
    _validate.positive(array, "masses", "mass")
    return array


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


# --------------------------------------------------------------------------- model builder
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
    """
    from ase.data import covalent_radii

    positions, _ = _check_atoms(atoms)
    bond_scale = _validate.real_scalar(bond_scale, "bond_scale")
    if not bond_scale > 0:
        raise ValueError(f"bond_scale is {bond_scale!r}; it must be positive")
    tolerance = _validate.real_scalar(linear_tolerance_deg, "linear_tolerance_deg")
    if not 0 <= tolerance < 90:
        raise ValueError(f"linear_tolerance_deg is {tolerance!r}; expected 0 <= value < 90")
    n = len(atoms)
    if bonds is None:
        radii = covalent_radii[atoms.get_atomic_numbers()]
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)
                 if np.linalg.norm(positions[j] - positions[i]) < bond_scale * (radii[i] + radii[j])]
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
                    theta = _angle(positions, np.array([[i, j, k]]))[0]
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
        bond_r0=_stretch(positions, bond_array)[0] if len(bond_array) else np.zeros(0),
        angles=angle_array, angle_k=angle_k,
        angle_theta0=_angle(positions, angle_array) if len(angle_array) else np.zeros(0),
        linear_angles=linear_array, linear_k=linear_k,
        torsions=torsion_array, torsion_k=torsion_k,
        torsion_phi0=_torsion(positions, torsion_array)[0] if len(torsion_array) else np.zeros(0),
    )


class ValenceForceField(Calculator):  # type: ignore[misc]
    """ASE calculator for a `ValenceModel`: energy (eV) and forces (eV / Angstrom).

    Evaluates the exact nonlinear internal coordinates, so finite differences of its forces
    (ASE `Vibrations`, phonopy) converge to the analytic Hessian B^T diag(w) B at an
    equilibrium. Periodic boundaries are ignored (positions are used as given).

    Parameters
    ----------
    model : ValenceModel
        The force field.
    """

    implemented_properties = ["energy", "forces"]

    def __init__(self, model: ValenceModel, **kwargs: Any) -> None:
        if not isinstance(model, ValenceModel):
            raise TypeError(f"model must be a ValenceModel, got {type(model).__name__}")
        super().__init__(**kwargs)
        self.model = model

    def calculate(self, atoms: Atoms | None = None, properties: Any = ("energy",),
                  system_changes: Any = all_changes) -> None:
        super().calculate(atoms, properties, system_changes)
        positions = self.atoms.get_positions()
        if len(positions) != self.model.n_atoms:
            raise ValueError(f"atoms has {len(positions)} atoms; this force field is for {self.model.n_atoms}")
        energy, forces = self.model.energy_and_forces(positions)
        self.results = {"energy": energy, "free_energy": energy, "forces": forces}


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


def _expected_rigid(positions: NDArray[np.float64], masses: NDArray[np.float64], linear_rtol: float) -> int:
    dim = positions.shape[1]
    if len(positions) == 1:
        return dim
    if dim == 1:
        return 1
    if dim == 2:
        return 3
    return 5 if is_linear(positions, masses, rtol=linear_rtol) else 6


def _warn_soft(n_zero: int, n_rigid: int, name: str, stacklevel: int = 3) -> None:
    if n_zero > n_rigid:
        warnings.warn(
            f"{name}: the force field leaves {n_zero} zero-frequency modes but the geometry allows only "
            f"{n_rigid} rigid-body ones; {n_zero - n_rigid} motion(s) have no restoring force (central "
            "springs cannot hold the bend of a linear molecule, nor bends a planar one's out-of-plane "
            "motion: add bends, linear bends or torsions)",
            SoftModeWarning, stacklevel=stacklevel,
        )


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
    **guess: Any,
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
    """
    positions, default_masses = _check_atoms(atoms)
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
    site_masses = _site_masses(masses, default_masses)
    tolerance = _nonnegative(force_tolerance, "force_tolerance", "eV/Angstrom")
    _residual_force_check(model, positions, tolerance)
    b = model.wilson_b(positions)
    label = _molecule_name(atoms, name)
    _warn_soft(_zero_count_of_factor(b, site_masses, 3), _expected_rigid(positions, site_masses, 1e-6), label)
    return System.from_terms(positions, site_masses, coupling=b, weights=model.weights(), units="ASE", name=label)


# --------------------------------------------------------------------------- finite differences
@dataclass(frozen=True, eq=False)
class FiniteDifferenceHessian:
    """A Hessian from central differences of forces, with its own error estimate.

    Attributes
    ----------
    hessian : (3 n_atoms, 3 n_atoms) ndarray
        Symmetrised (D + D^T) / 2 of the difference quotients D, in eV / Angstrom^2.
    error : (3 n_atoms, 3 n_atoms) ndarray
        Estimated absolute error of each entry (truncation + round-off), eV / Angstrom^2.
    truncation : (3 n_atoms, 3 n_atoms) ndarray
        Truncation part: Richardson estimate from a second step 2h (or, without it, the
        asymmetry |D - D^T| / 2, a weaker indicator), eV / Angstrom^2.
    roundoff : float
        Round-off part, ~ force_noise / step, eV / Angstrom^2.
    asymmetry : float
        Largest |D_ij - D_ji| / 2 before symmetrisation, eV / Angstrom^2.
    residual_force : float
        Largest force norm at the reference geometry, eV / Angstrom.
    positions : (n_atoms, 3) ndarray
        Reference geometry, Angstrom.
    masses : (n_atoms,) ndarray
        Masses, amu.
    numbers : (n_atoms,) ndarray of int
        Atomic numbers.
    step : float
        Displacement h, Angstrom.
    stencil : int
        2 (+-h) or 4 (+-h, +-2h) points per degree of freedom.
    error_method : str
        ``"richardson"`` or ``"asymmetry"``.
    n_force_calls : int
        Calculator force evaluations spent, including the reference geometry.
    """

    hessian: NDArray[np.float64]
    error: NDArray[np.float64]
    truncation: NDArray[np.float64]
    roundoff: float
    asymmetry: float
    residual_force: float
    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    numbers: NDArray[np.int_]
    step: float
    stencil: int
    error_method: str
    n_force_calls: int

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def system(self, *, masses: ArrayLike | None = None, name: str = "molecule") -> System:
        """The `System` with this Hessian (ASE units), optionally with other masses (amu)."""
        return System.from_hessian(self.positions, _site_masses(masses, self.masses), self.hessian,
                                   units="ASE", name=name)

    def omega_errors(self, modes: Modes) -> NDArray[np.float64]:
        """(n_modes,) first-order bound on how far each omega moves under `error`.

        |delta omega_k^2| <= sum_ij |d_ki| E_ij / sqrt(m_i m_j) |d_kj| with d_k the mass-weighted
        vectors of `modes`; delta omega = min(delta omega^2 / (2 |omega|), sqrt(delta omega^2)),
        in rad per ASE time unit.

        First order only: where modes lie closer together (in omega^2) than the error couples
        them, second-order mixing dominates and this underestimates. Measured on a 300-atom
        valence-force-field chain (h = 0.01 Angstrom, bench_hessian.py): 19 of 894 vibrations,
        the soft torsions at 7-70 cm^-1 and two near 190 cm^-1, moved up to 4 times further.
        CO2 and H2O stay well within it.
        """
        return _omega_bound(self.error, self.masses, modes)


def _omega_bound(error: NDArray[np.float64], masses: NDArray[np.float64], modes: Modes) -> NDArray[np.float64]:
    if modes.vectors is None:
        raise ValueError("modes has no vectors; compute the modes with vectors=True")
    scale = 1.0 / np.sqrt(np.repeat(masses, 3))
    weighted = np.abs(error) * scale[:, None] * scale[None, :]
    d = np.abs(modes.vectors)
    if d.shape[0] != weighted.shape[0]:
        raise ValueError(f"modes has {d.shape[0]} dofs; the Hessian has {weighted.shape[0]}")
    lam = np.sum(d * (weighted @ d), axis=0)      # d_k^T W d_k for every k, one matrix product
    return np.minimum(lam / np.maximum(2.0 * np.abs(modes.omega), 1e-300), np.sqrt(lam))


def finite_difference_hessian(
    atoms: Atoms,
    calculator: Any = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    estimate_error: bool = True,
    force_noise: float | None = None,
    force_tolerance: float | None = None,
) -> FiniteDifferenceHessian:
    """Hessian of any ASE calculator by central differences of its forces.

    H_ij = -dF_j/dx_i; 2-point: D(h) = (F(-h) - F(+h)) / 2h, error O(h^2); 4-point:
    (4 D(h) - D(2h)) / 3, error O(h^4); the result is symmetrised, (D + D^T) / 2. With
    `estimate_error` one more step size is evaluated (2h for the 2-point stencil, 4h for the
    4-point one) and the truncation error is estimated by Richardson extrapolation:
    |D(h) - D(2h)| / 3, or |R(h) - R(2h)| / 15 for the 4-point result R. The round-off error is
    ~ force_noise / h. Everything stays in memory (no cache files).

    Parameters
    ----------
    atoms : ase.Atoms
        Reference geometry, Angstrom; masses (amu) are read from it. Not modified.
    calculator : ase Calculator, optional
        Evaluates the forces; ``atoms.calc`` by default.
    step : float
        Displacement h, Angstrom.
    stencil : {2, 4}
        Points per degree of freedom.
    estimate_error : bool
        Spend 6 n_atoms extra force calls on the Richardson truncation estimate.
    force_noise : float, optional
        Absolute noise of one force component, eV / Angstrom (e.g. the SCF convergence of a
        quantum-chemistry calculator). Default: 8 machine epsilons of the largest force seen.
    force_tolerance : float, optional
        Raise if the largest force at the reference geometry exceeds this (eV / Angstrom): the
        Hessian of a non-equilibrium geometry gives meaningless frequencies. None: no check.

    Returns
    -------
    FiniteDifferenceHessian

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms, or no calculator.
    ValueError
        Bad step, stencil or noise; unknown elements or overlapping atoms; a residual force
        above `force_tolerance` (reported).
    RuntimeError
        The calculator returned forces that are not finite or of the wrong shape (the
        displacement is named); nothing is written anywhere.
    """
    positions, masses = _check_atoms(atoms)
    calc = calculator if calculator is not None else atoms.calc
    if calc is None:
        raise TypeError("calculator is None and atoms has no calculator attached; pass calculator=")
    if not hasattr(calc, "get_forces") and not hasattr(calc, "get_property"):
        raise TypeError(f"calculator must be an ASE calculator, got {type(calc).__name__}")
    h = _validate.real_scalar(step, "step")
    if not h > 0:
        raise ValueError(f"step is {h!r}; the displacement must be positive (Angstrom)")
    if isinstance(stencil, bool) or stencil not in (2, 4):
        raise ValueError(f"stencil is {stencil!r}; expected 2 or 4 (points per degree of freedom)")
    noise = None if force_noise is None else _nonnegative(force_noise, "force_noise", "eV/Angstrom")
    tolerance = None if force_tolerance is None else _nonnegative(force_tolerance, "force_tolerance",
                                                                   "eV/Angstrom")
    work = atoms.copy()
    work.calc = calc
    n = len(work)
    n_dof = 3 * n
    calls = 0
    largest = 0.0

    def forces_at(shift: NDArray[np.float64] | None, where: str) -> NDArray[np.float64]:
        nonlocal calls, largest
        work.set_positions(positions if shift is None else positions + shift)
        calls += 1
        values = np.asarray(work.get_forces(), dtype=float)
        if values.shape != (n, 3):
            raise RuntimeError(f"calculator returned forces of shape {values.shape} at {where}; expected ({n}, 3)")
        bad = ~np.isfinite(values)
        if bad.any():
            a, c = (int(v) for v in np.argwhere(bad)[0])
            raise RuntimeError(
                f"calculator returned non-finite forces at {where}: forces[{a},{c}] = {values[a, c]!r}"
            )
        largest = max(largest, float(np.abs(values).max()))
        return values.ravel()

    reference = forces_at(None, "the reference geometry").reshape(n, 3)
    residual = float(np.linalg.norm(reference, axis=1).max())
    if tolerance is not None:
        if residual > tolerance:
            worst = int(np.argmax(np.linalg.norm(reference, axis=1)))
            raise ValueError(
                f"atoms is not an equilibrium of the calculator: residual force {residual:.3g} eV/Angstrom "
                f"on atom {worst} (force_tolerance={tolerance:g}); relax the geometry first"
            )
    # step multiples evaluated: the stencil's own, plus one coarser for the Richardson estimate
    multiples = [1] if stencil == 2 else [1, 2]
    if estimate_error:
        multiples.append(2 if stencil == 2 else 4)
    quotient = {m: np.empty((n_dof, n_dof)) for m in multiples}
    axes = "xyz"
    for i in range(n_dof):
        for m in multiples:
            shift = np.zeros((n, 3))
            shift.flat[i] = m * h
            where = f"atom {i // 3} displaced by {{}}{m}h along {axes[i % 3]}"
            plus = forces_at(shift, where.format("+"))
            minus = forces_at(-shift, where.format("-"))
            quotient[m][i] = (minus - plus) / (2.0 * m * h)
    if stencil == 2:
        raw = quotient[1]
        truncation_raw = np.abs(quotient[1] - quotient[2]) / 3.0 if estimate_error else None
        noise_gain = np.sqrt(2.0) / 2.0
    else:
        raw = (4.0 * quotient[1] - quotient[2]) / 3.0
        truncation_raw = None
        if estimate_error:
            coarse = (4.0 * quotient[2] - quotient[4]) / 3.0
            truncation_raw = np.abs(raw - coarse) / 15.0
        noise_gain = np.sqrt(2.0 * 64.0 + 2.0) / 12.0
    asymmetry_matrix = np.abs(raw - raw.T) / 2.0
    hessian = (raw + raw.T) / 2.0
    if truncation_raw is not None:
        truncation = (truncation_raw + truncation_raw.T) / 2.0 + asymmetry_matrix
        method = "richardson"
    else:
        truncation = asymmetry_matrix
        method = "asymmetry"
    sigma = noise if noise is not None else 8.0 * np.finfo(float).eps * largest
    roundoff = float(noise_gain * sigma / h)
    return FiniteDifferenceHessian(
        hessian=hessian, error=truncation + roundoff, truncation=truncation, roundoff=roundoff,
        asymmetry=float(asymmetry_matrix.max()), residual_force=residual, positions=positions,
        masses=masses, numbers=atoms.get_atomic_numbers(), step=h, stencil=int(stencil),
        error_method=method, n_force_calls=calls,
    )


def from_calculator(
    atoms: Atoms,
    calculator: Any = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    force_tolerance: float | None = 1e-3,
    masses: ArrayLike | None = None,
    name: str | None = None,
) -> System:
    """A molecule whose Hessian is a finite difference of any ASE calculator's forces.

    See `finite_difference_hessian` (which also returns the error estimate); this runs it
    without the extra Richardson step and returns the `System` (ASE units).
    """
    result = finite_difference_hessian(atoms, calculator, step=step, stencil=stencil,
                                       estimate_error=False, force_tolerance=force_tolerance)
    return result.system(masses=masses, name=_molecule_name(atoms, name))


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
    """
    positions, default_masses = _check_atoms(atoms)
    return System.from_hessian(positions, _site_masses(masses, default_masses), hessian,
                               symmetrize=symmetrize, units="ASE", name=_molecule_name(atoms, name))


def from_vibrations_data(data: Any, *, name: str | None = None) -> System:
    """A molecule from ASE's `VibrationsData` (its Hessian, atoms and masses).

    Atoms left out of the data's ``indices`` are frozen.
    """
    from ase.vibrations import VibrationsData

    if not isinstance(data, VibrationsData):
        raise TypeError(f"data must be an ase.vibrations.VibrationsData, got {type(data).__name__}")
    atoms = data.get_atoms()
    positions, masses = _check_atoms(atoms, "data.atoms")
    indices = np.asarray(data.get_indices(), dtype=np.intp)
    n = len(atoms)
    full = np.zeros((3 * n, 3 * n))
    dofs = (indices[:, None] * 3 + np.arange(3)).ravel()
    full[np.ix_(dofs, dofs)] = data.get_hessian_2d()
    frozen = np.setdiff1d(np.arange(n), indices)
    return System.from_hessian(positions, masses, full, frozen_sites=frozen if len(frozen) else None,
                               units="ASE", name=_molecule_name(atoms, name))


def from_phonopy(phonon: Any, *, name: str = "molecule") -> System:
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
    return System.from_hessian(np.asarray(cell.positions), np.asarray(cell.masses), hessian,
                               symmetrize=True, units="ASE", name=name)


# --------------------------------------------------------------------------- analysis
def is_linear(positions: ArrayLike, masses: ArrayLike, *, rtol: float = 1e-6) -> bool:
    """True when the smallest principal moment of inertia is <= rtol times the largest.

    Relative, so it does not depend on the size or the units of the molecule. A single atom
    is not linear (it has no rotations at all).
    """
    x = _validate.real_array(positions, "positions", ndim=2)
    m = _validate.real_array(masses, "masses", ndim=1)
    if len(x) < 2:
        return False
    moments = _principal_moments(x, m)[0]
    return bool(moments[0] <= rtol * moments[-1])


def _principal_moments(x: NDArray[np.float64], m: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    centred = x - (m[:, None] * x).sum(0) / m.sum()
    if x.shape[1] < 3:
        centred = np.pad(centred, ((0, 0), (0, 3 - x.shape[1])))
    r2 = np.sum(centred**2, axis=1)
    inertia = np.sum(m * r2) * np.eye(3) - np.einsum("i,ia,ib->ab", m, centred, centred)
    return np.linalg.eigh(inertia)


def rigid_body_vectors(positions: ArrayLike, masses: ArrayLike, *, linear_rtol: float = 1e-6) -> NDArray[np.float64]:
    """(n_sites * dim, n_rigid) orthonormal mass-weighted translations and rotations.

    Translations sqrt(m_i) e_a; rotations sqrt(m_i) (n_a x (r_i - r_com)) about the principal
    axes with a non-zero moment (the molecular axis of a linear molecule is left out, as is
    every rotation of a single atom). In 2-D the one in-plane rotation, in 1-D none.
    """
    x = _validate.real_array(positions, "positions", ndim=2)
    m = _validate.real_array(masses, "masses", ndim=1)
    n, dim = x.shape
    sqrt_m = np.sqrt(m)
    columns = []
    for a in range(dim):
        t = np.zeros((n, dim))
        t[:, a] = sqrt_m
        columns.append(t.ravel())
    if n > 1 and dim > 1:
        centred = x - (m[:, None] * x).sum(0) / m.sum()
        if dim == 2:
            rotation = np.stack([-centred[:, 1], centred[:, 0]], axis=1) * sqrt_m[:, None]
            columns.append(rotation.ravel())
        else:
            moments, axes = _principal_moments(x, m)
            for k in range(3):
                if moments[k] <= linear_rtol * moments[-1]:
                    continue
                columns.append((np.cross(axes[:, k], centred) * sqrt_m[:, None]).ravel())
    vectors = np.array(columns).T
    q, _ = np.linalg.qr(vectors)
    return q


@dataclass(frozen=True, eq=False)
class VibrationalAnalysis:
    """Normal modes of a molecule split into rigid-body motions and vibrations.

    Attributes
    ----------
    modes : Modes
        All n_dof modes, ascending omega (imaginary ones first, as -|omega|), in ASE units
        (rad per Angstrom sqrt(amu/eV)). With projection the rigid-body modes have omega = 0
        exactly and the rigid-body vectors as their vectors.
    rigid : (n_dof,) ndarray of bool
        True for a translation or rotation (matched by overlap with the rigid-body subspace).
    imaginary : (n_dof,) ndarray of bool
        True for an imaginary vibration (omega < 0, not rigid).
    rigid_overlap : (n_dof,) ndarray
        |T^T d_k|^2: weight of each mass-weighted vector in the rigid-body subspace (0 to 1).
    reduced_mass : (n_dof,) ndarray
        mu_k = 1 / sum_i (d_ki^2 / m_i), amu: the quantum-chemistry reduced mass (the Cartesian
        displacement M^-1/2 d_k normalised to 1).
    force_constant : (n_dof,) ndarray
        k_k = mu_k omega_k |omega_k|, eV / Angstrom^2 (negative for imaginary modes).
    linear : bool
        The geometry is linear (inertia tensor, relative tolerance).
    n_rigid : int
        Number of rigid-body modes (3N-6 or 3N-5 vibrations remain in 3-D).
    projected : bool
        Translations and rotations were projected out of K~ (Eckart) before solving.
    name : str
        Name of the system.
    """

    modes: Modes
    rigid: NDArray[np.bool_]
    imaginary: NDArray[np.bool_]
    rigid_overlap: NDArray[np.float64]
    reduced_mass: NDArray[np.float64]
    force_constant: NDArray[np.float64]
    linear: bool
    n_rigid: int
    projected: bool
    name: str = "molecule"

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    @property
    def vibrations(self) -> NDArray[np.intp]:
        """Indices of the vibrational (non-rigid) modes, ascending omega."""
        return np.flatnonzero(~self.rigid)

    @property
    def n_vibrations(self) -> int:
        """Number of vibrations (3N-6, 3N-5, or n_dof - n_rigid)."""
        return int((~self.rigid).sum())

    def wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_dof,) signed wavenumbers of all modes, in cm^-1 (imaginary as negative)."""
        return self.modes.wavenumbers_cm1()

    def vibration_wavenumbers_cm1(self) -> NDArray[np.float64]:
        """(n_vibrations,) signed wavenumbers of the vibrations, ascending, in cm^-1."""
        return self.modes.wavenumbers_cm1()[~self.rigid]

    def force_constants_mdyn_per_angstrom(self) -> NDArray[np.float64]:
        """(n_dof,) force constants in mdyn / Angstrom (Gaussian's unit; 1 mdyn/A = 100 N/m)."""
        si = self.force_constant * constants.electron_volt / constants.angstrom**2  # N/m
        return si / 100.0

    def zero_point_energy_ev(self) -> float:
        """Zero-point energy sum 1/2 hbar omega over real vibrations, in eV."""
        real = (~self.rigid) & (self.modes.omega > 0)
        return float(0.5 * np.sum(self.modes.energies_mev()[real]) / 1000.0)

    def table(self) -> str:
        """Plain-text table: mode, kind, wavenumber, reduced mass, force constant."""
        lines = [f"{self.name}: {self.n_vibrations} vibrations, {self.n_rigid} rigid-body modes"
                 f"{' (linear)' if self.linear else ''}",
                 f"{'mode':>4}  {'kind':<10} {'cm^-1':>11} {'mu (amu)':>9} {'k (mdyn/A)':>11}"]
        k_mdyn = self.force_constants_mdyn_per_angstrom()
        for i, wave in enumerate(self.wavenumbers_cm1()):
            kind = "rigid" if self.rigid[i] else ("imaginary" if self.imaginary[i] else "vibration")
            text = f"{abs(wave):10.2f}{'i' if wave < 0 else ' '}"
            lines.append(f"{i:>4}  {kind:<10} {text} {self.reduced_mass[i]:9.4f} {k_mdyn[i]:11.4f}")
        lines.append(f"zero-point energy: {self.zero_point_energy_ev():.6f} eV")
        return "\n".join(lines)


def vibrational_analysis(
    system: System,
    *,
    project: bool = True,
    accuracy: Literal["high", "fast"] = "high",
    linear_rtol: float = 1e-6,
    zero_rtol: float = 1e-6,
) -> VibrationalAnalysis:
    """Vibrations of a molecule, rigid-body motions handled like quantum-chemistry codes.

    With `project` the mass-weighted Hessian K~ = M^-1/2 K M^-1/2 is restricted to the
    orthogonal complement Q of the rigid-body vectors T (`rigid_body_vectors`, Eckart
    conditions): Q^T K~ Q is solved for exactly n_dof - n_rigid vibrations, and the rigid modes
    get omega = 0. Without it K~ is solved as is and the n_rigid modes with the largest overlap
    |T^T d_k|^2 are labelled rigid (matched, not picked by position).

    Parameters
    ----------
    system : System
        A molecule (sites, no frozen dofs); any dimension 1 to 3.
    project : bool
        Project out translations and rotations before solving.
    accuracy : {"high", "fast"}
        "high" hands the projected spring factor (B M^-1/2 Q, w) to the solver for high relative
        accuracy when K is factorised; "fast" solves the dense projected K~ directly.
    linear_rtol : float
        Relative tolerance on the smallest principal moment of inertia for linearity.
    zero_rtol : float
        A vibration with |omega| <= zero_rtol * max|omega| counts as a soft (zero) mode: more
        of them than allowed raise a `SoftModeWarning`.

    Returns
    -------
    VibrationalAnalysis

    Warns
    -----
    SoftModeWarning
        Vibrations with zero frequency (the force field does not hold some motion).
    RuntimeWarning
        Imaginary vibrations (from `normal_modes`); they are kept and flagged.

    Raises
    ------
    TypeError
        `system` is not a System, or is in generalised coordinates.
    ValueError
        A system with frozen degrees of freedom (rigid-body motions are then not free); an
        unknown `accuracy`; a negative `linear_rtol` or `zero_rtol`.
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError("system is in generalised coordinates; a vibrational analysis needs sites")
    if system.frozen.any():
        raise ValueError(
            f"system has {int(system.frozen.sum())} frozen degree(s) of freedom; translations and "
            "rotations are not free, so there are no rigid-body modes to separate"
        )
    _validate.choice(accuracy, "accuracy", ("high", "fast"))
    linear_rtol = _nonnegative(linear_rtol, "linear_rtol", "relative")
    zero_rtol = _nonnegative(zero_rtol, "zero_rtol", "relative")
    positions = np.asarray(system.positions)
    masses = np.asarray(system.masses)
    dim = system.dim
    n_dof = system.n_dof
    t = rigid_body_vectors(positions, masses, linear_rtol=linear_rtol)
    n_rigid = t.shape[1]
    linear = dim == 3 and is_linear(positions, masses, rtol=linear_rtol)
    mass_dof = np.repeat(masses, dim)
    inv_sqrt = 1.0 / np.sqrt(mass_dof)
    K = system.hessian()
    if project:
        full, _ = np.linalg.qr(np.hstack([t, np.eye(n_dof)]))
        q = full[:, n_rigid:n_dof]
        # Q spans the complement of T: QR of [T, I] gives T's span first, then the rest.
        K_tilde = (K.multiply(inv_sqrt[:, None]).multiply(inv_sqrt[None, :])).toarray() if sp.issparse(K) else (
            inv_sqrt[:, None] * K * inv_sqrt[None, :])
        K_internal = q.T @ K_tilde @ q
        K_internal = (K_internal + K_internal.T) / 2.0
        factor = system.spring_factor() if accuracy == "high" else None
        spring = None
        if factor is not None and factor[0].shape[0]:
            b = factor[0].toarray() * inv_sqrt[None, :] @ q
            spring = (b, factor[1])
        inner = normal_modes(K_internal, np.ones(n_dof - n_rigid), spring_factor=spring, units=system.units)
        vectors_internal = q @ inner.vectors
        omega = np.concatenate([np.zeros(n_rigid), inner.omega])
        vectors = np.hstack([t, vectors_internal])
        errors = np.concatenate([np.zeros(n_rigid), inner.omega_error])
        order = np.argsort(omega, kind="stable")
        omega, vectors, errors = omega[order], vectors[:, order], errors[order]
        rigid = np.concatenate([np.ones(n_rigid, bool), np.zeros(n_dof - n_rigid, bool)])[order]
        orthogonality = float(np.abs(vectors.T @ vectors - np.eye(n_dof)).max())
        modes = Modes(omega=omega, vectors=vectors, shapes=vectors * inv_sqrt[:, None], mass=mass_dof,
                      omega_error=errors, residual=inner.residual, orthogonality=orthogonality,
                      solver=f"eckart+{inner.solver}", units=system.units)
        overlap = np.sum((t.T @ vectors) ** 2, axis=0)
    else:
        modes = system.modes(accuracy=accuracy)
        overlap = np.sum((t.T @ np.asarray(modes.vectors)) ** 2, axis=0)
        rigid = np.zeros(n_dof, bool)
        rigid[np.argsort(-overlap, kind="stable")[:n_rigid]] = True
    scale = float(np.abs(modes.omega).max()) if n_dof else 0.0
    soft = (~rigid) & (np.abs(modes.omega) <= zero_rtol * scale)
    _warn_soft(int(soft.sum()) + n_rigid, n_rigid, system.name)
    d = np.asarray(modes.vectors)
    reduced_mass = 1.0 / np.sum(d**2 / mass_dof[:, None], axis=0)
    return VibrationalAnalysis(
        modes=modes, rigid=rigid, imaginary=(~rigid) & (modes.omega < 0), rigid_overlap=overlap,
        reduced_mass=reduced_mass, force_constant=reduced_mass * modes.omega * np.abs(modes.omega),
        linear=bool(linear), n_rigid=n_rigid, projected=bool(project), name=system.name,
    )


# --------------------------------------------------------------------------- isotopes
def isotope_mass(label: str) -> float:
    """Mass in amu of an isotope label such as ``"13C"``, ``"18O"``, ``"D"`` or ``"2H"``.

    Masses from NIST's "Atomic Weights and Isotopic Compositions" (table in this module).
    """
    if not isinstance(label, str):
        raise TypeError(f"label must be a str such as '13C', got {type(label).__name__}")
    key = _ISOTOPE_ALIASES.get(label, label)
    if key not in _ISOTOPES:
        match = re.fullmatch(r"(\d+)([A-Z][a-z]?)", key)
        from ase.data import chemical_symbols

        if match is None or match.group(2) not in chemical_symbols[1:]:
            raise ValueError(f"label is {label!r}; expected an isotope like '13C', '18O', 'D' or '2H'")
        known = ", ".join(sorted(_ISOTOPES) + sorted(_ISOTOPE_ALIASES))
        raise ValueError(f"label is {label!r}: isotope not in vibra's table (known: {known}); pass a mass in amu")
    return _ISOTOPES[key]


def _isotope_element(label: str) -> str:
    key = _ISOTOPE_ALIASES.get(label, label)
    return re.fullmatch(r"\d+([A-Z][a-z]?)", key).group(1)  # type: ignore[union-attr]


def substitute_isotopes(
    system: System,
    substitutions: Mapping[int, float | str],
    *,
    symbols: list[str] | tuple[str, ...] | None = None,
) -> System:
    """The same force field with some atoms replaced by isotopes (K is not recomputed).

    Parameters
    ----------
    system : System
        A molecule in ASE units (masses in amu).
    substitutions : mapping of int to float or str
        Atom index -> new mass in amu, or an isotope label (``"13C"``, ``"18O"``, ``"D"``).
    symbols : sequence of str, optional
        Chemical symbols of the atoms; when given, a label must name the atom's element.

    Raises
    ------
    TypeError
        Not a System of sites in ASE units, or a substitution of the wrong kind.
    ValueError
        An index out of range, a non-positive mass, an unknown label, or a label of another
        element than `symbols` gives.
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra System, got {type(system).__name__}")
    if system.units is not ASE and system.units.name != "ASE":
        raise TypeError(f"system must be in ASE units (amu) for isotope masses, got {system.units.name!r}")
    if not isinstance(substitutions, Mapping):
        raise TypeError(f"substitutions must be a mapping index -> mass or label, got {type(substitutions).__name__}")
    if symbols is not None and len(symbols) != system.n_sites:
        raise ValueError(f"symbols must name {system.n_sites} atoms, got {len(symbols)}")
    masses = np.array(system.masses)
    for index, value in substitutions.items():
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise TypeError(f"substitutions key {index!r} must be an int atom index")
        if not 0 <= index < system.n_sites:
            raise ValueError(f"substitutions[{index}]: atom index out of range 0..{system.n_sites - 1}")
        if isinstance(value, str):
            mass = isotope_mass(value)
            if symbols is not None and _isotope_element(value) != symbols[index]:
                raise ValueError(f"substitutions[{index}] is {value!r} but atom {index} is {symbols[index]!r}")
        elif isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool):
            mass = float(value)
            if not (np.isfinite(mass) and mass > 0):
                raise ValueError(f"substitutions[{index}] is {value!r}; a mass must be positive and finite (amu)")
        else:
            raise TypeError(f"substitutions[{index}] must be a mass in amu or an isotope label, got {type(value).__name__}")
        masses[index] = mass
    return system.with_masses(masses)


# --------------------------------------------------------------------------- ready-made models
def co2(
    dims: Literal[1, 3] = 3,
    *,
    bond_length: float = CO2_BOND_LENGTH,
    stretch: float = CO2_STRETCH,
    bend: float = CO2_BEND,
) -> System:
    """Carbon dioxide O=C=O with a valence force field (ASE units).

    ``dims=1``: the seed's axial model (seed 003, Example 11, eqs. 152-158): three sites at
    (0, L, 2L) on a line, two springs kappa = `stretch`; 3 degrees of freedom, frequencies
    0, sqrt(kappa/m_O), sqrt(kappa (1/m_O + 2/m_C)). ``dims=3`` (default): the full model along
    the x axis, the same two stretches plus a linear bend (two perpendicular coordinates,
    constant `bend`); 9 degrees of freedom: symmetric stretch, asymmetric stretch, a doubly
    degenerate bend and 5 rigid-body modes. Masses: ``ase.data.atomic_masses`` (12.011, 15.999).

    Parameters
    ----------
    dims : {1, 3}
        Axial (1-D) or full (3-D) model.
    bond_length : float
        C=O length L, Angstrom (seed: 0.116 nm).
    stretch : float
        kappa, eV / Angstrom^2; default `CO2_STRETCH` (fitted to 1333 and 2349 cm^-1).
    bend : float
        Linear-bend constant, eV / rad^2; default `CO2_BEND` (fitted to 667 cm^-1).
    """
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    if isinstance(dims, bool) or dims not in (1, 3):
        raise ValueError(f"dims is {dims!r}; expected 1 (axial model) or 3 (full model)")
    length = _validate.real_scalar(bond_length, "bond_length")
    if not length > 0:
        raise ValueError(f"bond_length is {length!r}; it must be positive (Angstrom)")
    masses = atomic_masses[[atomic_numbers["O"], atomic_numbers["C"], atomic_numbers["O"]]]
    if dims == 1:
        return System.from_springs(np.array([0.0, length, 2.0 * length]), masses,
                                   springs=np.array([[0, 1], [1, 2]]), stiffness=stretch,
                                   units="ASE", name="CO2 (axial)")
    atoms = _Atoms("OCO", positions=[(-length, 0, 0), (0, 0, 0), (length, 0, 0)], masses=masses)
    model = valence_model(atoms, bonds=np.array([[0, 1], [1, 2]]), stretch=stretch, bend=bend)
    return from_atoms(atoms, model, name="CO2")


def co2_atoms(bond_length: float = CO2_BOND_LENGTH) -> Atoms:
    """ase.Atoms of linear CO2 along x (O, C, O), masses set explicitly from ase.data."""
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    masses = atomic_masses[[atomic_numbers["O"], atomic_numbers["C"], atomic_numbers["O"]]]
    return _Atoms("OCO", positions=[(-bond_length, 0, 0), (0, 0, 0), (bond_length, 0, 0)], masses=masses)


def h2o_atoms(bond_length: float = H2O_BOND_LENGTH, angle_deg: float = H2O_ANGLE_DEG) -> Atoms:
    """ase.Atoms of H2O in the xy plane (O, H, H), masses set explicitly from ase.data."""
    from ase import Atoms as _Atoms
    from ase.data import atomic_masses, atomic_numbers

    half = np.radians(angle_deg) / 2.0
    positions = [(0, 0, 0), (bond_length * np.sin(half), bond_length * np.cos(half), 0),
                 (-bond_length * np.sin(half), bond_length * np.cos(half), 0)]
    masses = atomic_masses[[atomic_numbers["O"], atomic_numbers["H"], atomic_numbers["H"]]]
    return _Atoms("OHH", positions=positions, masses=masses)


def h2o(*, stretch: float = H2O_STRETCH, bend: float = H2O_BEND) -> System:
    """Water with a simple valence force field (two stretches, one bend), ASE units.

    Geometry: r = 0.9572 Angstrom, angle 104.52 degrees; constants `H2O_STRETCH` (eV/A^2) and
    `H2O_BEND` (eV/rad^2), fitted to the experimental fundamentals (see the module constants).
    9 degrees of freedom: 3 vibrations and 6 rigid-body modes.
    """
    atoms = h2o_atoms()
    model = valence_model(atoms, bonds=np.array([[0, 1], [0, 2]]), stretch=stretch, bend=bend)
    return from_atoms(atoms, model, name="H2O")
