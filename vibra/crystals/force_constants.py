"""Force constants of a crystal as flat terms Phi(i 0; j R), and the springs of a spring model.

A term is (atom i in cell 0, atom j in cell R, R, the 3x3 block Phi(i 0; j R) in energy / length^2);
the force on atom i is F_i = -sum_{j,R} Phi(i 0; j R) u_j(R) (`vibra.crystals.crystal` states the
conventions). Spring models and phonopy's supercell force constants both take this form.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr, span
from vibra.units import UnitSystem

__all__ = ["CrystalLike", "ForceConstants", "ForceConstantsWarning", "INDEX_SYMMETRY_RTOL", "SpringModel", "SumRuleReport",
           "average_over_space_group", "check_force_constants", "impose_sum_rules", "index_asymmetry"]


class CrystalLike(Protocol):
    """What the modules below `vibra.crystals.crystal` read of a crystal (for type checkers only).

    `Crystal` satisfies it. The lower modules (dynamical, bands, dos, mesh, thermal, elastic,
    factor, springs, phonopy_io) annotate with this protocol instead of importing the `Crystal`
    class, whose methods import them: so no module of the package imports one that imports it
    back, not even for type checking. That is also why `nac`, `assembly` and `nac_parts` are
    `Any` here: their types (`vibra.crystals.nac.NonAnalytic`, `vibra.crystals.dynamical.Assembly`,
    `vibra.crystals.nac.Parts`) live in modules that import this one.
    """

    cell: NDArray[np.float64]
    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    symbols: tuple[str, ...]
    units: UnitSystem
    periodic: tuple[bool, bool, bool]
    force_constants: ForceConstants | None
    springs: SpringModel | None
    name: str
    nac: Any

    @property
    def n_atoms(self) -> int: ...

    @property
    def n_branches(self) -> int: ...

    @property
    def fractional(self) -> NDArray[np.float64]: ...

    @property
    def reciprocal(self) -> NDArray[np.float64]: ...

    @property
    def assembly(self) -> Any: ...

    @property
    def nac_parts(self) -> Any: ...

    def require_force_constants(self) -> ForceConstants: ...

    def with_force_constants(self, force_constants: ForceConstants, springs: SpringModel | None = None
                             ) -> CrystalLike: ...


#: Force constants whose index symmetry is broken by more than this fraction of their largest
#: entry draw a `ForceConstantsWarning`: phonopy writes FORCE_CONSTANTS with 10 decimals, so
#: a file it wrote from symmetric force constants stays ~1e-10 within it, while force constants
#: made from forces without symmetrisation break it by ~1e-4..1e-2 (phonopy's NaCl example: 6.7e-4).
INDEX_SYMMETRY_RTOL = 1e-8


class ForceConstantsWarning(UserWarning):
    """Force constants that break a symmetry they should have (the index symmetry)."""


@dataclass(frozen=True, eq=False)
class ForceConstants(Frozen):
    """Force constants as terms Phi(i 0; j R), in energy / length^2 of the crystal's units.

    Attributes
    ----------
    first : (n_terms,) ndarray of int
        Atom i (in cell 0) of each term.
    second : (n_terms,) ndarray of int
        Atom j (in cell R) of each term.
    translations : (n_terms, 3) ndarray of int
        The lattice translation R of atom j, in units of the lattice vectors.
    blocks : (n_terms, 3, 3) ndarray
        Phi(i 0; j R), Cartesian, in energy / length^2.
    """

    first: NDArray[np.intp]
    second: NDArray[np.intp]
    translations: NDArray[np.int64]
    blocks: NDArray[np.float64]

    def __repr__(self) -> str:
        atoms = int(max(self.first.max(initial=-1), self.second.max(initial=-1))) + 1
        reach = int(np.abs(self.translations).max(initial=0))
        return short_repr(self, f"{self.n_terms} terms", f"{atoms} atom{'s' if atoms > 1 else ''}",
                          f"translations up to {reach} cell{'s' if reach != 1 else ''}")

    @property
    def n_terms(self) -> int:
        return int(self.first.shape[0])


@dataclass(frozen=True, eq=False)
class SpringModel(Frozen):
    """The springs a spring model is made of, each bond once.

    Attributes
    ----------
    first, second : (n_bonds,) ndarray of int
        The atoms joined: `first` in cell 0, `second` in cell `translations`.
    translations : (n_bonds, 3) ndarray of int
        Lattice translation of the second atom.
    vectors : (n_bonds, 3) ndarray
        Bond vectors r_second(R) - r_first(0), Cartesian, in the length unit.
    longitudinal, transverse : (n_bonds,) ndarray
        Stiffness along the bond and across it, in energy / length^2.
    shells : (n_bonds,) ndarray of int
        Neighbour shell of each bond, from 1.
    """

    first: NDArray[np.intp]
    second: NDArray[np.intp]
    translations: NDArray[np.int64]
    vectors: NDArray[np.float64]
    longitudinal: NDArray[np.float64]
    transverse: NDArray[np.float64]
    shells: NDArray[np.int64]

    def __repr__(self) -> str:
        shells = np.unique(self.shells)
        return short_repr(self, f"{self.first.size} springs", f"{shells.size} shell{'s' if shells.size > 1 else ''}",
                          f"longitudinal {span(self.longitudinal)}", f"transverse {span(self.transverse)}")


def check_force_constants(fc: ForceConstants, n_atoms: int, periodic: tuple[bool, bool, bool]) -> None:
    """Shapes, atom indices in range, and no coupling across a vacuum axis."""
    if not isinstance(fc, ForceConstants):
        raise TypeError(f"force_constants must be a ForceConstants, got {type(fc).__name__}")
    n = fc.n_terms
    if fc.second.shape != (n,) or fc.translations.shape != (n, 3) or fc.blocks.shape != (n, 3, 3):
        raise ValueError("force constants must be (n_terms,) first and second, (n_terms, 3) translations and "
                         f"(n_terms, 3, 3) blocks; got {fc.first.shape}, {fc.second.shape}, "
                         f"{fc.translations.shape}, {fc.blocks.shape}")
    for name, index in (("first", fc.first), ("second", fc.second)):
        bad = (index < 0) | (index >= n_atoms)
        if bad.any():
            t = int(np.argmax(bad))
            raise ValueError(f"force constants {name}[{t}] is {int(index[t])}; atoms run from 0 to {n_atoms - 1}")
    _validate.finite(fc.blocks, "force constants blocks")
    for axis in range(3):
        if not periodic[axis] and (fc.translations[:, axis] != 0).any():
            t = int(np.argmax(fc.translations[:, axis] != 0))
            raise ValueError(f"force constants term {t} couples cells along the vacuum axis {axis} "
                             f"(translation {fc.translations[t].tolist()}); widen the vacuum or shorten the cutoff")


#: `impose_sum_rules` stops when the largest violation is below this fraction of the largest block entry.
SUM_RULE_RTOL = 1e-14
#: ... or after this many rounds (each a symmetrisation and a row projection).
SUM_RULE_ROUNDS = 200


@dataclass(frozen=True)
class SumRuleReport:
    """How far supercell force constants were from the sum rules before `impose_sum_rules`.

    Attributes
    ----------
    acoustic : float
        Largest |sum_s Phi(p, s)_ab| before, energy / length^2 (0 for a rigid translation).
    index : float
        Largest |Phi(p, s)_ab - Phi(s, p)_ba| / 2 before, energy / length^2.
    change : float
        Largest change of one entry made by the projection, energy / length^2.
    rounds : int
        Rounds of the alternating projection.
    """

    acoustic: float
    index: float
    change: float
    rounds: int


def impose_sum_rules(full: NDArray[np.float64]) -> tuple[NDArray[np.float64], SumRuleReport]:
    """Supercell force constants with the acoustic sum rule and the index symmetry imposed.

    `full` (n_s, n_s, 3, 3) are phonopy's full supercell force constants Phi(s, t). Two
    orthogonal projections (in the Frobenius sense) are alternated until both rules hold to
    `SUM_RULE_RTOL`: the index symmetry, Phi <- (Phi(s, t) + Phi(t, s)^T) / 2, and the acoustic
    sum rule, each row s minus its mean over t (sum_t Phi(s, t) = 0). Alternating orthogonal
    projections onto two subspaces converges to the orthogonal projection onto their
    intersection (von Neumann), i.e. the nearest force constants, entry by entry in the least
    squares sense, that obey both rules; both steps commute with the supercell's translations,
    so a translation-invariant input stays so (phonopy's force constants from displacements are;
    an input that is not, e.g. independent noise on every supercell entry, gets both rules per
    supercell row, but its D(q) is then not that of one crystal). This is our own projection (phonopy's
    ``symmetrize_force_constants`` does a similar pass in C); it is the one place vibra imposes
    the rules, for finite differences and for phonopy's force constants alike.

    Returns
    -------
    projected : (n_s, n_s, 3, 3) ndarray
        The force constants obeying both rules, in the units of `full`.
    report : SumRuleReport
        The violations before, and the largest change made.
    """
    fc = np.array(full, dtype=float)
    if fc.ndim != 4 or fc.shape[0] != fc.shape[1] or fc.shape[2:] != (3, 3):
        raise ValueError(f"force constants must have shape (n_s, n_s, 3, 3) (full supercell), got {fc.shape}")
    _validate.finite(fc, "force constants")
    acoustic = float(np.abs(fc.sum(axis=1)).max())
    index = float(np.abs(fc - fc.transpose(1, 0, 3, 2)).max()) / 2.0
    scale = float(np.abs(fc).max())
    rounds = 0
    while rounds < SUM_RULE_ROUNDS:
        fc = (fc + fc.transpose(1, 0, 3, 2)) / 2.0
        violation = np.abs(fc.sum(axis=1)).max()
        if violation <= SUM_RULE_RTOL * scale:
            break
        fc -= fc.mean(axis=1, keepdims=True)
        rounds += 1
    change = float(np.abs(fc - full).max())
    return fc, SumRuleReport(acoustic=acoustic, index=index, change=change, rounds=rounds)


def index_asymmetry(fc: ForceConstants) -> float:
    """max |Phi(i 0; j R) - Phi(j 0; i -R)^T| over all terms, relative to the largest entry (0 for none).

    Force constants are second derivatives of one energy, so they obey this index symmetry
    exactly; a term without its partner counts with its whole block. When it is broken, D(q)
    is not Hermitian and its Hermitian part is solved (`vibra.crystals.dynamical.assembly`).
    """
    if fc.n_terms == 0:
        return 0.0
    scale = float(np.abs(fc.blocks).max())
    if scale == 0.0:
        return 0.0
    keys = np.column_stack([fc.first, fc.second, fc.translations]).astype(np.int64)
    partners = np.column_stack([fc.second, fc.first, -fc.translations]).astype(np.int64)
    table, inverse = np.unique(np.vstack([keys, partners]), axis=0, return_inverse=True)
    inverse = inverse.ravel()
    summed = np.zeros((table.shape[0], 3, 3))
    np.add.at(summed, inverse[:fc.n_terms], fc.blocks)  # repeated terms add up, as in D(q)
    gap = summed[inverse[:fc.n_terms]] - np.transpose(summed[inverse[fc.n_terms:]], (0, 2, 1))
    return float(np.abs(gap).max()) / scale


def average_over_space_group(fc: ForceConstants, cell: NDArray[np.float64], fractional: NDArray[np.float64],
                             rotations: NDArray[np.int64], translations: NDArray[np.float64],
                             atol: float = 1e-5) -> ForceConstants:
    """The force constants averaged over a space group's operations: every symmetry of the crystal kept exactly.

    An operation (W, w) maps x -> W x + w (fractional); atom i goes to atom p(i) in cell L_i, so
    the term (i, j, R) goes to (p(i), p(j), W R + L_j - L_i) with the block C Phi C^T, C = cell^T
    W cell^-T the Cartesian rotation. The mean over the group commutes with the acoustic sum rule
    and the index symmetry, so force constants that obey them still do. Used for finite
    differences made without phonopy's symmetry search (`vibra.crystals.finite_difference`,
    ``symmetry="auto"``), whose space-group average costs n_ops x n_terms instead.

    Raises
    ------
    ValueError
        An operation that maps an atom onto no atom (within `atol`, fractional).
    """
    keys_all: list[NDArray[np.int64]] = []
    blocks_all: list[NDArray[np.float64]] = []
    inverse_t = np.linalg.inv(cell).T
    for w_matrix, shift in zip(rotations, translations):
        moved = fractional @ w_matrix.T + shift
        delta = moved[:, None, :] - fractional[None, :, :]
        match = np.abs(delta - np.rint(delta)).max(axis=2) < atol
        if not match.any(axis=1).all():
            raise ValueError("a symmetry operation maps an atom onto no atom; the crystal's symmetry is looser than "
                             f"the tolerance {atol:g}")
        image = np.argmax(match, axis=1)
        lattice = np.rint(moved - fractional[image]).astype(np.int64)
        rotation = cell.T @ w_matrix @ inverse_t
        new_r = fc.translations @ w_matrix.T + lattice[fc.second] - lattice[fc.first]
        keys_all.append(np.column_stack([image[fc.first], image[fc.second], new_r]))
        blocks_all.append(rotation[None] @ fc.blocks @ rotation.T[None])
    keys = np.vstack(keys_all)
    table, inverse = np.unique(keys, axis=0, return_inverse=True)
    summed = np.zeros((table.shape[0], 3, 3))
    np.add.at(summed, inverse.ravel(), np.vstack(blocks_all))
    summed /= len(rotations)
    return ForceConstants(first=table[:, 0].astype(np.intp), second=table[:, 1].astype(np.intp),
                          translations=table[:, 2:].astype(np.int64), blocks=summed)
