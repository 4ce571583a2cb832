"""The irreducible representations of a crystal's modes at Gamma, with their infrared and Raman activity.

The space-group operations of the cell (spglib) act on the Gamma displacements (atom i -> j,
u -> R u); the characters of each degenerate level of D(0) are the traces of that action on the
level's eigenvectors, decomposed on phonopy's character tables (`phonopy.phonon.character_table`)
into Mulliken labels, and compared with the vector representation (χ(R) = tr R: infrared active)
and its symmetric square (χ(R) = (tr(R)² + tr(R²)) / 2: Raman active). The labels are those of
the analytic D(0), as phonopy's ``set_irreps`` at Gamma gives them: in a polar crystal the
non-analytic term lifts an infrared-active level's longitudinal mode to its LO frequency, and that
mode keeps the label of its TO level (`vibra.crystals.infrared` gives the LO frequencies).

`gamma_modes` is used by the infrared response and by band charts (labels at each Gamma).
"""

from __future__ import annotations

from dataclasses import dataclass
import warnings
from typing import TYPE_CHECKING, TypedDict

import numpy as np
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, frequency_span, short_repr
from vibra.crystals.mesh import species_numbers, symmetry_cell
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.crystal import Crystal

__all__ = ["NotPrimitiveError", "GammaModes", "gamma_modes", "DEGENERACY_RTOL", "degenerate_levels", "real_level_vectors",
           "symmetry_operations", "classify_levels"]

#: Two Gamma frequencies within this fraction of the largest |ω| form one degenerate level
#: (phonopy's default is 1e-5 THz absolute, about 1e-6 of a 10 THz spectrum).
DEGENERACY_RTOL = 1e-5


class NotPrimitiveError(ValueError):
    """The cell is not primitive: a pure translation maps it onto itself, so its Gamma modes
    include folded zone-boundary modes and carry no irreps of the point group."""


@dataclass(frozen=True, repr=False)
class GammaModes(Frozen):
    """The modes of a crystal at Gamma with their irreducible representations.

    Attributes
    ----------
    omega : (n_modes,) ndarray
        Signed angular frequencies of the analytic D(0), ascending, in rad per time unit.
    levels : (n_modes,) ndarray of int
        Index of the degenerate level of each mode (0, 1, ... ascending).
    irreps : tuple of str
        Mulliken label of each mode's level from phonopy's character table (``"T1u"``;
        ``"A1+E"`` for an accidental degeneracy, ``"?"`` when the table has no match).
    ir_active, raman_active : (n_modes,) ndarray of bool
        Infrared and Raman activity of each mode's level, from characters.
    point_group : str
        International symbol of the crystal's point group (spglib's).
    units : UnitSystem
        The crystal's units.
    """

    omega: NDArray[np.float64]
    levels: NDArray[np.int64]
    irreps: tuple[str, ...]
    ir_active: NDArray[np.bool_]
    raman_active: NDArray[np.bool_]
    point_group: str
    units: UnitSystem

    def __repr__(self) -> str:
        return short_repr(self, f"point group {self.point_group}", f"{len(self.level_labels())} levels",
                          " ".join(self.level_labels()), frequency_span(self.omega, self.units))

    def __len__(self) -> int:
        return int(self.omega.shape[0])

    def level_labels(self) -> tuple[str, ...]:
        """The label of each degenerate level, ascending."""
        firsts = np.flatnonzero(np.r_[True, np.diff(self.levels) > 0])
        return tuple(self.irreps[k] for k in firsts)

    def level_frequencies(self) -> NDArray[np.float64]:
        """(n_levels,) the frequency of each degenerate level (mean of its modes), rad per time unit."""
        return np.array([self.omega[self.levels == k].mean() for k in np.unique(self.levels)])


def gamma_modes(crystal: Crystal, *, symprec: float = 1e-5) -> GammaModes:
    """The Gamma modes of `crystal` (its analytic D(0)) labelled by irreducible representation.

    Parameters
    ----------
    crystal : Crystal
        With force constants, a primitive cell.
    symprec : float
        spglib's tolerance as a fraction of the cell's size, dimensionless.

    Raises
    ------
    ValueError
        No force constants; a non-positive `symprec`.
    NotPrimitiveError
        A cell that is not primitive (a `ValueError`).
    """
    if not hasattr(crystal, "require_force_constants") or not hasattr(crystal, "modes_at"):
        raise TypeError(f"crystal must be a vibra.crystals.Crystal, got {type(crystal).__name__}")
    crystal.require_force_constants()
    tolerance = _validate.positive_scalar(symprec, "symprec", "symmetry tolerance")
    symmetry = symmetry_operations(crystal, tolerance)
    omega, vectors, levels = analytic_gamma(crystal)
    labels, ir, raman, point_group = classify_levels(symmetry, vectors, levels)
    return GammaModes(omega=omega, levels=levels, irreps=labels, ir_active=ir, raman_active=raman,
                      point_group=point_group, units=crystal.units)


def analytic_gamma(crystal: Crystal) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """(omega, real orthonormal vectors, levels) of the analytic D(0), without any LO-TO term."""
    phonons = crystal.modes_at([0.0, 0.0, 0.0])
    omega = np.asarray(phonons.omega[0], dtype=float)
    levels = degenerate_levels(omega)
    return omega, real_level_vectors(np.asarray(phonons.vectors[0]), levels), levels


def degenerate_levels(omega: NDArray[np.float64]) -> NDArray[np.int64]:
    """(n_modes,) degenerate-level index of each ascending frequency."""
    scale = max(float(np.abs(omega).max()), np.finfo(float).tiny)
    new = np.ones(omega.size, dtype=bool)
    new[1:] = np.diff(omega) > DEGENERACY_RTOL * scale
    return np.cumsum(new) - 1



def real_level_vectors(vectors: NDArray[np.complex128], levels: NDArray[np.int64]) -> NDArray[np.float64]:
    """Real orthonormal eigenvectors spanning each level's space (D(0) is real: each level's space
    is closed under conjugation, so [Re V, Im V] has its rank)."""
    real = np.empty(vectors.shape)
    for level in np.unique(levels):
        members = np.flatnonzero(levels == level)
        block = np.concatenate([vectors[:, members].real, vectors[:, members].imag], axis=1)
        left, _, _ = np.linalg.svd(block, full_matrices=False)
        real[:, members] = left[:, :members.size]
    return real



class SymmetryOperations(TypedDict):
    """`symmetry_operations`' answer: spglib's operations of a primitive cell."""

    rotations: NDArray[np.int32]           # (n_ops, 3, 3) fractional rotations
    cartesian: NDArray[np.float64]         # (n_ops, 3, 3) the same in Cartesian form
    grounds: NDArray[np.float64]           # (n_ops, 3 n_atoms, 3 n_atoms) their action on the Gamma displacements
    point_group: str                       # its Hermann-Mauguin symbol
    transformation: NDArray[np.float64]    # (3, 3) spglib's transformation matrix


def symmetry_operations(crystal: Crystal, symprec: float) -> SymmetryOperations:
    """spglib's operations of the cell, in fractional and Cartesian form, with their action on the
    Gamma displacements; a cell that is not primitive is refused."""
    import spglib  # at the edge

    numbers = species_numbers(crystal)
    cell = symmetry_cell(crystal)  # spglib's tolerance is a length: the cell scaled to unit size
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # spglib's notice about its error handling
        try:
            dataset = spglib.get_symmetry_dataset((cell, crystal.fractional, numbers), symprec=symprec)
        except Exception as error:  # spglib raises its own SpglibCppError
            raise RuntimeError(f"spglib found no space group for {crystal.name!r} at symprec={symprec:g}: "
                               f"{error}") from None
    if dataset is None:
        raise RuntimeError(f"spglib found no space group for {crystal.name!r} at symprec={symprec:g}")
    rotations = np.asarray(dataset.rotations)
    if len({r.tobytes() for r in rotations}) < len(rotations):
        raise NotPrimitiveError(f"crystal {crystal.name!r} is not a primitive cell (a pure translation maps it onto "
                         "itself); its Gamma modes include folded zone-boundary modes: use the primitive cell")
    lattice = crystal.cell.T  # columns a_i: x_cart = lattice @ x_frac
    cartesian = lattice @ rotations @ np.linalg.inv(lattice)
    grounds = _ground_matrices(crystal, cell, rotations, np.asarray(dataset.translations), cartesian, symprec)
    return {"rotations": rotations, "cartesian": cartesian, "grounds": grounds,
            "point_group": str(dataset.pointgroup).strip(), "transformation": np.asarray(dataset.transformation_matrix)}


def classify_levels(symmetry: SymmetryOperations, vectors: NDArray[np.float64], levels: NDArray[np.int64]
              ) -> tuple[tuple[str, ...], NDArray[np.bool_], NDArray[np.bool_], str]:
    """Irrep labels and infrared / Raman activity of each mode from the characters of its level."""
    cartesian = symmetry["cartesian"]
    vector_chars = np.trace(cartesian, axis1=1, axis2=2)
    square_chars = 0.5 * (vector_chars ** 2 + np.trace(cartesian @ cartesian, axis1=1, axis2=2))
    table = _character_table(symmetry["point_group"], symmetry["rotations"], symmetry["transformation"])
    order = float(len(cartesian))
    labels: list[str] = [""] * vectors.shape[1]
    ir = np.zeros(vectors.shape[1], dtype=bool)
    raman = np.zeros(vectors.shape[1], dtype=bool)
    for level in np.unique(levels):
        members = np.flatnonzero(levels == level)
        block = vectors[:, members]
        chars = np.einsum("km,rkl,lm->r", block, symmetry["grounds"], block)
        ir[members] = np.dot(chars, vector_chars) / order > 0.5
        raman[members] = np.dot(chars, square_chars) / order > 0.5
        label = _decompose(chars, table)
        for m in members:
            labels[m] = label
    return tuple(labels), ir, raman, symmetry["point_group"]


def _ground_matrices(crystal: Crystal, cell: NDArray[np.float64], rotations: NDArray[np.int32],
                     translations: NDArray[np.float64], cartesian: NDArray[np.float64], symprec: float
                     ) -> NDArray[np.float64]:
    """(n_ops, 3n, 3n) action of each operation on Gamma displacements: atom i -> j, u -> R u."""
    frac = crystal.fractional
    n = crystal.n_atoms
    grounds = np.zeros((len(rotations), 3 * n, 3 * n))
    for k, (rotation, translation) in enumerate(zip(rotations, translations)):
        moved = frac @ rotation.T + translation
        delta = moved[:, None, :] - frac[None, :, :]
        delta -= np.round(delta)
        distance = np.linalg.norm(delta @ cell, axis=2)
        images = np.argmin(distance, axis=1)
        if (distance[np.arange(n), images] > symprec).any() or len(set(images.tolist())) != n:
            raise RuntimeError(f"symmetry operation {k} of spglib does not map the atoms of {crystal.name!r} onto "
                               f"each other within symprec={symprec:g}")
        for i, j in enumerate(images):
            grounds[k, 3 * j:3 * j + 3, 3 * i:3 * i + 3] = cartesian[k]
    return grounds


def _character_table(point_group: str, rotations: NDArray[np.int32], transformation: NDArray[np.float64]
                     ) -> dict[str, NDArray[np.float64]] | None:
    """{irrep label: (n_ops,) character of each operation}, from phonopy's table for the point group
    (conventional rotations T r T^-1 matched against its mapping table); None when it has none."""
    from phonopy.phonon.character_table import character_table  # at the edge

    conventional = [np.rint(transformation @ r @ np.linalg.inv(transformation)).astype(int) for r in rotations]
    for entry in character_table.get(point_group) or []:
        classes = []
        for rotation in conventional:
            found = [name for name, members in entry["mapping_table"].items()
                     if any((np.array(member) == rotation).all() for member in members)]
            classes.append(found[0] if found else None)
        if None in classes:
            continue
        columns = [entry["rotation_list"].index(name) for name in classes]
        return {label: np.real(np.asarray(chars, dtype=complex)[columns])
                for label, chars in entry["character_table"].items()}
    return None


def _decompose(chars: NDArray[np.float64], table: dict[str, NDArray[np.float64]] | None) -> str:
    """The irreps in a level's characters, ``"Eg"`` or ``"A1+E"`` (``"2A1"`` twice), ``"?"`` when none fit."""
    if table is None:
        return "?"
    parts = []
    rebuilt = np.zeros_like(chars)
    for label, irrep in table.items():
        count = float(np.dot(irrep, chars) / np.dot(irrep, irrep))
        n = int(round(count))
        if n > 0:
            parts.append(label if n == 1 else f"{n}{label}")
            rebuilt += n * irrep
    if not parts or np.abs(rebuilt - chars).max() > 1e-3:
        return "?"
    return "+".join(parts)
