"""Counting eigenvalues below a point (Sylvester's law of inertia), to certify that none was missed.

A Krylov iteration from one start vector (ARPACK's Lanczos) holds one copy of a multiple eigenvalue in
exact arithmetic; rounding seeds the others, but where F = (K~ - sigma I)^-1 barely favours them they
may not have grown when the wanted pairs converge. A block of b columns holds b copies (`krylov`), and
widens where a cluster as wide as the block shows. Neither is certain: every returned pair has a small
residual, and yet the k values are not the k lowest. A star of 200 identical 10-site arms on one hub
(a 199-fold value per arm mode) came back with its lowest 250 values (0 to 0.41) off by up to 0.38.

The count is certain: K~ - tau I = L D L^T has as many negative pivots in D as K~ has eigenvalues below
tau, whatever the order of elimination. `missed` places tau just below the highest cluster of the
values found (in a gap of the found spectrum, `SPLIT` away from any of them) and compares. The
factorisation is PARDISO's LDL^T where PARDISO serves the shifts (`pardiso.negative_eigenvalues`: its
inertia, unless it perturbed a pivot), else SuperLU's in symmetric mode without pivoting (the pivot signs are
the signs of ratios of leading minors, which a positive scaling keeps), in nested-dissection order where
`ordering.nested_dissection` gives one.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray

from vibra.solvers.common import EPS
from vibra.solvers.standard.krylov import CLUSTER
from vibra.solvers.standard.cholmod import sparse_backend
from vibra.solvers.standard.ordering import nested_dissection
from vibra.solvers.standard.pardiso import negative_eigenvalues

__all__ = ["below", "missed", "negative_pivots", "repeats", "symmetric_lu"]

#: Relative distance (to |lambda| + `FLOOR` ||K~||_inf) at which tau sits below the highest cluster found:
#: found values closer than this count as one value (`krylov.CLUSTER`), and a missing copy closer than this
#: to the highest value is that value to this accuracy.
SPLIT = 1e-8

#: Absolute floor of the split, relative to ||K~||_inf: the rounding of the factorisation (~n eps ||K~||
#: at worst for the pivots' signs near tau) stays below it.
FLOOR = 1e4 * EPS

#: |lambda| / ||K~||_inf at or under which a found value is a zero mode, not a repeated value (`repeats`).
ZERO = 1e-8


def below(Kt: sp.csr_matrix, tau: float) -> int | None:
    """How many eigenvalues of the symmetric K~ lie below tau: the negative pivots of K~ - tau I.

    None where the factorisation meets a zero pivot (tau an eigenvalue, to rounding).

    >>> K = sp.diags([[2.0] * 5, [-1.0] * 4, [-1.0] * 4], [0, 1, -1], format="csr")
    >>> [below(K, t) for t in (0.1, 0.9, 1.0, 2.5, 4.0)]  # eigenvalues 2 - 2 cos(j pi / 6): 0.27, 1, 2, 3, 3.73
    [0, 1, None, 3, 5]
    """
    n = Kt.shape[0]
    shifted = (sp.csr_matrix(Kt) - tau * sp.identity(n, format="csr")).tocsr()
    if sparse_backend(n) == "pardiso":  # its LDL^T, where it serves the shifts: a supernodal factor, not SuperLU's LU
        count = negative_eigenvalues(shifted)
        if count is not None:
            return count
    order = nested_dissection(shifted)
    ordering = "MMD_AT_PLUS_A"
    if order is not None:
        shifted, ordering = shifted[order][:, order], "NATURAL"
    lu = symmetric_lu(shifted.tocsc(), ordering)
    return None if lu is None else negative_pivots(lu)


def symmetric_lu(shifted: sp.csc_matrix, ordering: str) -> sla.SuperLU | None:
    """SuperLU's LU of a symmetric matrix in symmetric mode without pivoting (its U's diagonal then D of an LDL^T,
    up to a positive scaling); None where a pivot is exactly zero."""
    try:
        return sla.splu(shifted, permc_spec=ordering, diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError:  # an exactly singular pivot
        return None


def negative_pivots(lu: sla.SuperLU) -> int | None:
    """How many of `symmetric_lu`'s pivots are negative (None where one is zero or not finite): by Sylvester's law the
    eigenvalues below the shift. (SuperLU hands its pivots over only by copying U: 1.7 s and 1 GB at 50,000 dofs.)"""
    pivots = lu.U.diagonal()
    if not np.all(np.isfinite(pivots)) or np.any(pivots == 0.0):
        return None
    return int(np.count_nonzero(pivots < 0.0))


def repeats(values: NDArray[np.float64], scale: float) -> bool:
    """Whether a nonzero value among `values` shows more than one copy (within `krylov.CLUSTER`): the sign that
    a multiple value may have copies the iteration did not find. Zero modes do not count (every free network has
    them, and the iteration finds them first, `sparse.shift_invert`'s probe)."""
    nonzero = np.sort(values[np.abs(values) > ZERO * scale])  # (signed: -1 and 1 of an indefinite K~ are not one value)
    return bool(np.any(np.diff(nonzero) <= CLUSTER * np.abs(nonzero[1:])))


def missed(Kt: sp.csr_matrix, values: NDArray[np.float64], scale: float, *, under: int = 0) -> tuple[int, int]:
    """How many eigenvalues below the highest cluster of `values` (ascending, the lowest found) were not found,
    and how many of `values` lie below the point counted at. `under`: eigenvalues known to lie below every one of
    `values` and not among them (an indefinite K~'s, counted apart: `sparse._saddle`).

    tau lies `SPLIT` below the lowest member of the highest cluster (a chain of values each within `SPLIT`
    of the next), or halfway to the next lower value where that is nearer, so it lies in a gap of the found
    values; the count below tau less the found values below it is what was missed (0 where the count
    agrees, or cannot be read there nor halfway down the gap).

    >>> K = sp.diags(np.r_[1.0, 2.0, 2.0, 3.0, 5.0], format="csr")
    >>> missed(K, np.array([1.0, 2.0, 3.0]), 5.0)  # a copy of 2 not found: below 3, 3 eigenvalues, 2 found
    (1, 2)
    """
    if values.shape[0] < 2:
        return 0, 0
    split = SPLIT * (np.abs(values) + FLOOR / SPLIT * scale)
    apart = np.diff(values) > split[1:]  # a gap between neighbours i and i + 1
    gaps = np.flatnonzero(apart)
    start = int(gaps[-1]) + 1 if gaps.size else 0  # the highest cluster's lowest member
    gap = float(values[start] - values[start - 1]) if start else float(split[start])  # (one cluster: below it, none)
    for tau in (float(values[start]) - min(float(split[start]), 0.5 * gap), float(values[start]) - 0.5 * gap):
        count = below(Kt, tau)
        if count is not None:
            return max(count - under - start, 0), start
    return 0, start
