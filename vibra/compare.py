"""Comparing two sets of modes: overlaps, the modal assurance criterion, subspaces, matching.

The first thing a structural dynamicist, a protein modeller or a phonon user does with two
results (two structures, two force fields, an isotope shift, two points of a sweep) is to ask
which mode of one is which mode of the other. Everything here takes `vibra.Modes`,
`vibra.solvers.structured.quadratic.QuadraticModes` (their complex shapes) or plain
(n_dof, n_modes) arrays of vectors in columns:

- `overlap(a, b)`: |cos| of the angle between mode i of a and mode j of b, as a matrix (rows a's
  modes, columns b's). ``weighted=True`` (the default) compares the mass-weighted vectors d_k
  (orthonormal: eq. 143 of Kneller, Mécanique analytique), the inner product of
  normal modes; ``weighted=False`` the physical shapes u_k = M^-1/2 d_k, each normalised (what
  ProDy's ``calcOverlap`` computes on ANM modes, whose masses are all 1). Mode sets of
  different systems are refused: different dof counts always, different masses when weighted.
- `mac(a, b)`: the modal assurance criterion |u_a^H u_b|^2 / (|u_a|^2 |u_b|^2) on physical
  shapes (Allemang and Brown; pyEMA's definition), complex shapes included (`QuadraticModes`).
- `cumulative_overlap(a, b)`: per mode of a, sqrt(sum_j overlap_ij^2): how much of it b's
  modes span (ProDy's ``calcCumulOverlap(a, b, array=True)``).
- `subspace_overlap(a, b)`: the root mean square inner product sqrt(sum overlap^2 / n_a) (RMSIP,
  Amadei et al. 1999: ProDy's ``calcSubspaceOverlap``), which equals sqrt(mean cos^2) of the
  principal angles between the two subspaces: basis-independent, so degenerate modes, whose
  individual vectors are arbitrary within their plane, compare correctly.
- `match_modes(a, b)`: pairs the modes one to one (an assignment maximising the summed squared
  overlaps, `scipy.optimize.linear_sum_assignment`), degenerate groups first compared as
  subspaces, and says where a pairing is ambiguous.

Where a mode is degenerate (its frequency within `DEGENERATE` relative, or within the two
modes' `omega_error`, of its neighbour's), the overlap of a single vector means little: ProDy's
``calcOverlap`` reports whatever basis the eigensolver returned. `match_modes` groups such modes
and reports each pair's group overlap (the cosine of the vector with the other group's
subspace) instead.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, Union

import numpy as np
import scipy.linalg as la
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from vibra._core.frozen import Frozen

__all__ = ["overlap", "mac", "cumulative_overlap", "subspace_overlap", "match_modes", "ModeMatch", "ModeSet",
           "DEGENERATE", "AMBIGUOUS"]

class ShapesLike(Protocol):
    """What is read of a `vibra.Modes` or a `QuadraticModes` (a protocol: `vibra.modes` imports
    this module, so naming its classes would close an import cycle, even for type checkers)."""

    @property
    def shapes(self) -> NDArray[Any] | None: ...


#: What the functions here compare: a `vibra.Modes`, a `QuadraticModes` (complex shapes), or an
#: (n_dof, n_modes) array of vectors in columns (one vector: (n_dof,)).
ModeSet = Union[ShapesLike, ArrayLike]

#: Two neighbouring modes are one degenerate group where their frequencies agree to this
#: relative tolerance (or within their bounds' sum).
DEGENERATE = 1e-8
#: A pairing of `match_modes` is ambiguous where its squared overlap is below this, or where the
#: runner-up (another mode of b for the same mode of a, or of a for the same b) comes within
#: 1 - AMBIGUOUS of it: two candidates, neither clearly the one.
AMBIGUOUS = 0.5


def _columns(modes: Any, name: str, *, weighted: bool) -> tuple[NDArray[Any], NDArray[np.float64] | None]:
    """(vectors in columns, the masses or None) of a mode set or an array."""
    if isinstance(modes, np.ndarray) or isinstance(modes, (list, tuple)):
        array = np.asarray(modes)
        if array.ndim == 1:
            array = array[:, None]
        if array.ndim != 2 or not np.issubdtype(array.dtype, np.number):
            raise ValueError(f"{name} must be a Modes result or an (n_dof, n_modes) array, got shape {array.shape}")
        return array, None
    mass = np.asarray(getattr(modes, "mass", getattr(modes, "masses", None)), dtype=float) \
        if getattr(modes, "mass", getattr(modes, "masses", None)) is not None else None
    if weighted and getattr(modes, "vectors", None) is not None and np.asarray(modes.vectors).ndim == 2 \
            and not np.iscomplexobj(modes.vectors):
        return np.asarray(modes.vectors), mass
    shapes = getattr(modes, "shapes", None)
    if shapes is None:
        raise ValueError(f"{name} has no vectors: compute the modes with vectors=True to compare them")
    shapes = np.asarray(shapes)
    if weighted and mass is not None:  # d = M^1/2 u
        shapes = (np.sqrt(mass)[:, None] * shapes) if mass.ndim == 1 else la.sqrtm(mass).real @ shapes
    return shapes, mass


def _normalised(vectors: NDArray[Any], name: str) -> NDArray[Any]:
    norms = np.linalg.norm(vectors, axis=0)
    if np.any(norms == 0) or not np.all(np.isfinite(norms)):
        bad = int(np.flatnonzero((norms == 0) | ~np.isfinite(norms))[0])
        raise ValueError(f"{name}'s mode {bad} has a zero or non-finite vector; it cannot be compared")
    return vectors / norms


def _pair(a: ModeSet, b: ModeSet, weighted: bool) -> tuple[NDArray[Any], NDArray[Any]]:
    va, ma = _columns(a, "a", weighted=weighted)
    vb, mb = _columns(b, "b", weighted=weighted)
    if va.shape[0] != vb.shape[0]:
        raise ValueError(f"mode sets of different systems: a has {va.shape[0]} dofs, b {vb.shape[0]}")
    if weighted and ma is not None and mb is not None:
        if ma.shape != mb.shape or not np.allclose(ma, mb, rtol=1e-12, atol=0.0):
            raise ValueError("mode sets of different systems: their masses differ (mass-weighted vectors of "
                             "different mass matrices are not comparable); compare the physical shapes with "
                             "weighted=False")
    return _normalised(va, "a"), _normalised(vb, "b")


def overlap(a: ModeSet, b: ModeSet, *, weighted: bool = True) -> NDArray[np.float64]:
    """|cos| of the angle between each mode of `a` (rows) and each of `b` (columns).

    Examples
    --------
    >>> import numpy as np, vibra
    >>> chain = vibra.chains.linear_chain(4, units="dimensionless")
    >>> modes = chain.modes()
    >>> np.allclose(overlap(modes, modes), np.eye(4))
    True
    """
    va, vb = _pair(a, b, weighted)
    return np.abs(va.conj().T @ vb).real


def mac(a: ModeSet, b: ModeSet) -> NDArray[np.float64]:
    """The modal assurance criterion |u_a^H u_b|^2 / ((u_a^H u_a)(u_b^H u_b)) of the physical
    shapes (complex for `QuadraticModes`), rows a's modes, columns b's.

    Examples
    --------
    >>> import numpy as np
    >>> mac(np.array([[1.0], [1.0]]), np.array([[1.0, 1.0], [1.0, -1.0]])).round(12).tolist()
    [[1.0, 0.0]]
    """
    va, vb = _pair(a, b, weighted=False)
    return np.abs(va.conj().T @ vb) ** 2


def cumulative_overlap(a: ModeSet, b: ModeSet, *, weighted: bool = True) -> NDArray[np.float64]:
    """Per mode of `a`: sqrt(sum over b's modes of the squared overlap), 1 when b's modes span it."""
    return np.sqrt(np.sum(overlap(a, b, weighted=weighted) ** 2, axis=1))


def subspace_overlap(a: ModeSet, b: ModeSet, *, weighted: bool = True) -> float:
    """The root mean square inner product of the two sets (RMSIP): sqrt(sum overlap^2 / n_a),
    from the principal angles between the spans (independent of the basis within each span;
    equal to ProDy's ``calcSubspaceOverlap`` for orthonormal sets)."""
    va, vb = _pair(a, b, weighted)
    qa, qb = la.orth(va), la.orth(vb)
    cosines = la.svdvals(qa.conj().T @ qb)
    return float(np.sqrt(np.sum(np.minimum(cosines, 1.0) ** 2) / va.shape[1]))


def _groups(modes: Any, count: int, tolerance: float) -> list[NDArray[np.intp]]:
    """Runs of neighbouring modes whose frequencies agree (relative `tolerance` or their bounds)."""
    omega = getattr(modes, "omega", None)
    if omega is None or np.asarray(omega).shape != (count,) or np.iscomplexobj(omega):
        return [np.array([j]) for j in range(count)]
    omega = np.asarray(omega, dtype=float)
    error = np.asarray(getattr(modes, "omega_error", np.zeros(count)), dtype=float)
    order = np.argsort(omega, kind="stable")
    groups, current = [], [int(order[0])] if count else []
    for previous, j in zip(order[:-1], order[1:]):
        scale = max(abs(omega[previous]), abs(omega[j]))
        if abs(omega[j] - omega[previous]) <= max(tolerance * scale, error[previous] + error[j]):
            current.append(int(j))
        else:
            groups.append(np.array(current))
            current = [int(j)]
    if current:
        groups.append(np.array(current))
    return groups


@dataclass(frozen=True, eq=False)
class ModeMatch(Frozen):
    """What `match_modes` found.

    Attributes
    ----------
    pairs : (n_pairs, 2) int ndarray
        (mode of a, mode of b), one row per pairing, sorted by a's mode.
    overlap : (n_pairs,) ndarray
        |cos| between the two vectors.
    group_overlap : (n_pairs,) ndarray
        |cos| between a's vector and the span of b's degenerate group it was paired into (the
        same as `overlap` where b's mode is not degenerate): the meaningful figure inside a group.
    degenerate : (n_pairs,) bool ndarray
        The pair lies in a degenerate group (of a or b): its one-to-one pairing inside the group
        is arbitrary, its `group_overlap` is not.
    ambiguous : (n_pairs,) bool ndarray
        The pairing is not clear: its squared group overlap is below `AMBIGUOUS`, or a runner-up
        comes within 1 - AMBIGUOUS of it.
    """

    pairs: NDArray[np.intp]
    overlap: NDArray[np.float64]
    group_overlap: NDArray[np.float64]
    degenerate: NDArray[np.bool_]
    ambiguous: NDArray[np.bool_]

    def __len__(self) -> int:
        return int(self.pairs.shape[0])

    def __repr__(self) -> str:
        return (f"ModeMatch({len(self)} pairs, {int(self.ambiguous.sum())} ambiguous, "
                f"{int(self.degenerate.sum())} in degenerate groups, "
                f"smallest group overlap {float(self.group_overlap.min(initial=1.0)):.3g})")


def match_modes(a: ModeSet, b: ModeSet, *, weighted: bool = True, degenerate: float = DEGENERATE) -> ModeMatch:
    """Pair the modes of `a` and `b` one to one (min(n_a, n_b) pairs), maximising the summed
    squared overlaps; degenerate groups (see the module) compared as subspaces.

    Examples
    --------
    >>> import numpy as np, vibra
    >>> light = vibra.chains.linear_chain(5, units="dimensionless").modes()
    >>> heavy = vibra.chains.linear_chain(5, mass=[1, 1, 1.2, 1, 1], units="dimensionless").modes()
    >>> match = match_modes(light, heavy, weighted=False)
    >>> match.pairs[:, 1].tolist(), bool(match.ambiguous.any())
    ([0, 1, 2, 3, 4], False)
    """
    va, vb = _pair(a, b, weighted)
    O = np.abs(va.conj().T @ vb).real
    groups_b = _groups(b, vb.shape[1], degenerate)
    groups_a = _groups(a, va.shape[1], degenerate)
    # a's vector against the span of b's group: sqrt(sum of its squared overlaps with the group
    # (orthonormal within a group: the modes of one result are)
    toward_group = np.empty_like(O)
    group_of_b = np.empty(vb.shape[1], dtype=np.intp)
    for g, members in enumerate(groups_b):
        toward_group[:, members] = np.sqrt(np.sum(O[:, members] ** 2, axis=1))[:, None]
        group_of_b[members] = g
    group_of_a = np.empty(va.shape[1], dtype=np.intp)
    for g, members in enumerate(groups_a):
        group_of_a[members] = g
    size_a, size_b = np.bincount(group_of_a), np.bincount(group_of_b)
    # the assignment on the group overlaps, ties inside a group broken by the single overlaps
    score = toward_group**2 + 1e-6 * O**2
    rows, cols = linear_sum_assignment(-score)
    squared = toward_group[rows, cols] ** 2
    # the best candidate outside the pair's own groups, from either side
    runner_up = np.array([max(float(np.max(toward_group[i, group_of_b != group_of_b[j]] ** 2, initial=0.0)),
                              float(np.max(toward_group[group_of_a != group_of_a[i], j] ** 2, initial=0.0)))
                          for i, j in zip(rows, cols)])
    ambiguous = (squared < AMBIGUOUS) | (runner_up > squared - (1 - AMBIGUOUS))
    order = np.argsort(rows)
    rows, cols = rows[order], cols[order]
    return ModeMatch(np.c_[rows, cols].astype(np.intp), O[rows, cols], toward_group[rows, cols],
                     (size_a[group_of_a[rows]] > 1) | (size_b[group_of_b[cols]] > 1), ambiguous[order])
