"""Branches of a sweep: each mode followed from point to point by its overlap, not by its rank.

Frequencies listed in ascending order swap labels where two branches cross. `BranchTracker`
connects them instead: along each line of the grid (the points that share the values of every
swept key but the first, in the order of the first key's values) the modes of a point are paired
one to one with those of the line's previous point by `vibra.compare.match_modes` on the
mass-weighted vectors d_k (an assignment maximising the summed squared overlaps), and each mode
takes the branch of its partner. So a true crossing keeps its labels (the branches pass through
each other) and an avoided crossing gives two smooth branches whose shapes exchange character.

Branch numbers: at the first point of each line, branch b is the (b + 1)-th lowest mode (0 is the
lowest); a mode left unpaired (a later point holds more modes, as with a ``band``) takes the next
unused number. Where the number of dofs changes between points of a line (a swept ``n``), there
is no overlap to take and the branches start again as ranks. An ensemble has no order between
members: its branches are the ranks.

A point where two modes meet (frequencies within `vibra.compare.DEGENERATE`, exactly at a
crossing) has no preferred basis in their plane: its modes are labelled from the previous point
as well as the subspace allows, and the next point is matched against the last point before the
meeting, whose vectors are well defined (its neighbours carry the labels through). Degeneracies
present all along a line (a symmetric molecule's E or Pi pairs) and rigid modes do not count.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Hashable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra.compare import DEGENERATE, match_modes

__all__ = ["BranchTracker", "degenerate_pairs", "RIGID"]


@dataclass(frozen=True, eq=False)
class _Point:
    """The mode set of one point as `match_modes` reads it (vectors without masses: the masses may
    change along a sweep, and consecutive points are compared as near neighbours)."""

    omega: NDArray[np.float64]
    vectors: NDArray[np.float64]
    omega_error: NDArray[np.float64]


#: Modes with |omega| at most this fraction of the largest are rigid: their (always degenerate)
#: group does not make a point degenerate for tracking.
RIGID = 1e-6


def degenerate_pairs(omega: ArrayLike, omega_error: ArrayLike | None = None) -> int:
    """How many neighbouring vibrating frequencies agree within `DEGENERATE` (relative) or their error
    bounds (rigid modes, |omega| <= `RIGID` max|omega|, left out).

    >>> degenerate_pairs([0.0, 1e-12, 1.0, 2.0]), degenerate_pairs([1.0, 1.0, 2.0])
    (0, 1)
    """
    omega = np.asarray(omega, dtype=float)
    error = np.zeros(omega.size) if omega_error is None else np.asarray(omega_error, dtype=float)
    order = np.argsort(omega)
    omega, error = omega[order], error[order]
    moving = np.abs(omega) > RIGID * float(np.max(np.abs(omega), initial=0.0))
    omega, error = omega[moving], error[moving]
    if omega.size < 2:
        return 0
    scale = np.maximum(np.abs(omega[1:]), np.abs(omega[:-1]))
    return int(np.sum(np.diff(omega) <= np.maximum(DEGENERATE * scale, error[1:] + error[:-1])))


class BranchTracker:
    """Assigns branch numbers point by point; points of a line must come in the line's order.

    >>> tracker = BranchTracker()
    >>> tracker.add(("line",), [1.0, 2.0], np.eye(2)).tolist()
    [0, 1]
    >>> tracker.add(("line",), [1.5, 1.8], np.eye(2)[:, ::-1]).tolist()   # the shapes swapped ranks
    [1, 0]
    """

    def __init__(self) -> None:
        self._reference: dict[Hashable, tuple[_Point, NDArray[np.intp]]] = {}
        self._next: dict[Hashable, int] = {}

    def add(self, line: Hashable, omega: ArrayLike, vectors: ArrayLike, omega_error: ArrayLike | None = None) -> NDArray[np.intp]:
        """(n_modes,) the branch of each mode of this point (mode k: the k-th column of `vectors`).

        Parameters
        ----------
        line : hashable
            Which line of the grid the point is on (the values of the other swept keys).
        omega : (n_modes,) array_like
            Frequencies, in the system's units.
        vectors : (n_dof, n_modes) array_like
            Mass-weighted mode vectors d_k, in columns.
        omega_error : (n_modes,) array_like, optional
            Error bounds of omega, in its units (modes within them count as degenerate).
        """
        omega = np.asarray(omega, dtype=float)
        error = np.zeros(omega.size) if omega_error is None else np.asarray(omega_error, dtype=float)
        point = _Point(omega=omega, vectors=np.asarray(vectors, dtype=float), omega_error=error)
        previous = self._reference.get(line)
        if previous is not None and previous[0].vectors.shape[0] != point.vectors.shape[0]:
            previous = None  # another system size (a swept n): no overlap between them, ranks again
        if previous is None or omega.size == 0 or previous[0].omega.size == 0:
            branches = np.arange(omega.size, dtype=np.intp)
            self._next[line] = omega.size
        else:
            reference, labels = previous
            match = match_modes(reference, point, weighted=True)
            branches = np.full(omega.size, -1, dtype=np.intp)
            branches[match.pairs[:, 1]] = labels[match.pairs[:, 0]]
            for k in np.flatnonzero(branches < 0):  # modes with no partner at the reference point
                branches[k] = self._next[line]
                self._next[line] += 1
        # a point where modes meet that were apart at the reference (a crossing) has no preferred
        # basis in their plane: the next point is matched against the reference instead; a
        # degeneracy the reference shares (by symmetry, all along the line) is no reason to wait
        if previous is None or degenerate_pairs(omega, error) <= degenerate_pairs(previous[0].omega,
                                                                                   previous[0].omega_error):
            self._reference[line] = (point, branches)
        return branches
