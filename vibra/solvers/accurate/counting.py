"""Certifying eigenvalues by inertia counts, shared by the ring and chain paths: the ladder of
brackets tried around each value, multisection of a bracket, the width a proven bracket gives.

A count is any function x -> (count below x, certain) (`Counts`): the spring form's of a ring
or a chain on walls (`count_kernels.spring_counts`, through `ring.values`, `ring.counted` and
`chain.walled`), or of chains (`count_kernels.chain_counts`, `chain.sturm_counts`). Value j is
certified where two certain counts at v (1 -+ t) are <= j and > j (`certify_at_levels`, the
tightest t of `LEVELS`); a value no level proves is narrowed inside a proven bracket
(`proven_multisection`, `multisection`). `spring_width` turns a proven bracket into a bound,
widened by the counts' own perturbation. `cut_chain` forms the relatively accurate bidiagonal
factor of a chain on walls (a ring cut at one spring), whose values the counts certify.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate.count_kernels import walled_factor

if TYPE_CHECKING:
    from vibra.solvers.common import MatrixLike

__all__ = ["LADDER", "LEVELS", "SECTIONS", "SECTION_PASSES", "PASSES", "Counts", "stored_factor", "spring_width",
           "multisection", "certify_at_levels", "proven_multisection", "sorted_bounds", "cut_chain"]

#: Half-widths of the brackets tried, relative to each eigenvalue, tightest first; a mode
#: certified at one level is not tried again.
LADDER = (8 * 2.0**-53, 64 * 2.0**-53, 1e-13, 1e-12, 1e-11)

#: Half-widths of the brackets tried around each root, relative, tightest first (`LADDER`
#: with steps between: a root at a pole, a double eigenvalue of a uniform ring or a mode
#: localised far from the cut, has counts uncertain within ~sqrt(n) 1e-15 of it).
LEVELS = (8 * 2.0**-53, 64 * 2.0**-53, 3e-14, 1e-13, 1.4e-13, 1.9e-13, 3e-13, 1e-12, 1e-11)

#: Multisection of the spring form's brackets: points per bracket and pass, and passes (14
#: narrow a bracket as wide as the value itself, 16^14 ~ 7e16, to 8 eps; a value the LADDER
#: brackets needs one or two).
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
SECTIONS = 16
SECTION_PASSES = 14

#: Passes of `multisection` for the roots the LEVELS do not prove (`proven_multisection`) (16^16 ~ 2e19: an
#: interlacing bracket as wide as its value to 8 eps, or a full range to ~1e-19).
PASSES = 16

Counts = Callable[[NDArray[np.float64]], tuple[NDArray[np.intp], NDArray[np.bool_]]]


def stored_factor(coupling: MatrixLike) -> tuple[sp.csr_matrix, NDArray[np.intp]]:
    """B as a float CSR copy, indices sorted, explicit zeros dropped, and its entries per row."""
    B = sp.csr_matrix(coupling, dtype=float, copy=True)
    B.sort_indices()
    B.eliminate_zeros()
    return B, np.diff(B.indptr)


def spring_width(lo: NDArray[np.float64], hi: NDArray[np.float64], middle: NDArray[np.float64],
                 widening: NDArray[np.float64]) -> NDArray[np.float64]:
    """Half-width about `middle` of the omega^2 that a bracket [lo, hi] of spring-form counts
    (`ring.counts.count_below_springs`, `count_kernels.spring_counts`) proves (its `widening` (phi,
    theta |b~|)): omega within sqrt(lo) (1 - phi) - s .. sqrt(hi) (1 + phi) + s, squared. Each side is formed as a sum of nonnegative terms (the
    difference hi - middle exact by Sterbenz, the widening's terms tiny beside it): squaring
    sqrt(hi) (1 + phi) in float64 would round by more than phi ~ 1e-26 and could leave the
    width at zero."""
    phi, shift = float(widening[0]), float(widening[1])
    root_hi, root_lo = np.sqrt(hi) * (1 + 1e-15), np.sqrt(np.maximum(lo, 0.0)) * (1 + 1e-15)
    above = (hi - middle) + hi * (2 * phi + phi * phi) + shift * (2 * root_hi * (1 + phi) + shift)
    below = np.minimum(middle, (middle - lo) + 2 * phi * lo + 2 * shift * root_lo)
    return np.maximum(above, below) * (1 + 1e-12)


def multisection(count_at: Callable[[NDArray[np.float64]], tuple[NDArray[np.intp], NDArray[np.bool_]]],
                 lo: NDArray[np.float64], hi: NDArray[np.float64], index: NDArray[np.intp], passes: int
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Narrow each bracket [lo, hi] that holds eigenvalue `index` (proven by two counts) by
    SECTIONS - 1 counts (`count_at` gives (count, certain) per point) per pass, to the tightest
    proven sub-bracket, until 2 LADDER[0] relative (8 eps either side) or `passes` passes.
    Returns (lo, hi, counts spent)."""
    lo, hi = lo.copy(), hi.copy()
    fractions = np.arange(1, SECTIONS) / SECTIONS
    used = 0
    for _ in range(passes):
        wide = np.flatnonzero(hi - lo > 2 * LADDER[0] * hi)
        if wide.shape[0] == 0:
            break
        points = lo[wide, None] + (hi[wide] - lo[wide])[:, None] * fractions  # (k, SECTIONS - 1)
        count, certain = count_at(points.ravel())
        used += count.shape[0]
        count, certain = count.reshape(points.shape), certain.reshape(points.shape)
        below = certain & (count <= index[wide, None])
        over = certain & (count > index[wide, None])
        has_below, has_over = below.any(axis=1), over.any(axis=1)
        last_below = points.shape[1] - 1 - np.argmax(below[:, ::-1], axis=1)
        first_over = np.argmax(over, axis=1)
        rows = np.arange(wide.shape[0])
        lo[wide[has_below]] = np.maximum(lo[wide[has_below]], points[rows[has_below], last_below[has_below]])
        hi[wide[has_over]] = np.minimum(hi[wide[has_over]], points[rows[has_over], first_over[has_over]])
    return lo, hi, used


def certify_at_levels(counts: Counts, values: NDArray[np.float64], bound: NDArray[np.float64],
                      modes: NDArray[np.intp], levels: tuple[float, ...], widening: NDArray[np.float64]) -> int:
    """Certify value j (eigenvalue j) of `modes` at the tightest of `levels` that proves it: the
    counts at v (1 -+ t) are <= j and > j; its bound (in place, where still infinite) is that
    bracket widened by the counts' perturbation (`spring_width`). Returns the counts spent."""
    used = 0
    for level in levels:
        todo = modes[~np.isfinite(bound[modes])]
        if todo.shape[0] == 0:
            break
        v = values[todo]
        lo, hi = v * (1 - level), v * (1 + level)
        count, certain = counts(np.r_[lo, hi])
        used += count.shape[0]
        k = todo.shape[0]
        good = certain[:k] & certain[k:] & (count[:k] <= todo) & (todo < count[k:])
        bound[todo[good]] = spring_width(lo[good], hi[good], v[good], widening)
    return used


def proven_multisection(counts: Counts, lo: NDArray[np.float64], hi: NDArray[np.float64], index: NDArray[np.intp]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """`multisection` for up to PASSES passes, the ends first proven by two counts
    (lo = hi = nan where they fail)."""
    k = lo.shape[0]
    count, certain = counts(np.r_[lo, hi])
    ok = certain[:k] & certain[k:] & (count[:k] <= index) & (index < count[k:])
    lo, hi = np.where(ok, lo, np.nan), np.where(ok, hi, np.nan)
    lo[ok], hi[ok], used = multisection(counts, lo[ok], hi[ok], index[ok], PASSES)
    return lo, hi, used + 2 * k


def sorted_bounds(values: NDArray[np.float64], bound: NDArray[np.float64], order: NDArray[np.intp]
                  ) -> NDArray[np.float64]:
    """Bounds for the eigenvalues in ascending order, given values sorted by `order` (value k
    was bounded for eigenvalue order[k]): unchanged where the order is the identity. Within a
    block of positions that `order` maps onto itself (indices a..b), the first j values hold j of
    the eigenvalues a..b below max (v + bound), so eigenvalue a + j - 1 does too; likewise from
    the top with min (v - bound)."""
    k = values.shape[0]
    if k == 0 or np.array_equal(order, np.arange(k)):
        return bound
    bound = bound.copy()
    ends = np.flatnonzero(np.maximum.accumulate(order) == np.arange(k))
    start = 0
    for end in ends.tolist():
        if end > start:
            v, b = values[start: end + 1], bound[start: end + 1]
            with np.errstate(invalid="ignore"):
                upper = np.maximum.accumulate(v + b)
                lower = np.minimum.accumulate((v - b)[::-1])[::-1]
                # (+ 4 eps |v|: the rounding of v +- bound and of the differences)
                widest = np.maximum(upper - v, v - lower) * (1 + 1e-12) + 4 * np.finfo(float).eps * np.abs(v)
                bound[start: end + 1] = np.maximum(b, widest)
        start = end + 1
    return bound


def cut_chain(m: NDArray[np.float64], w: NDArray[np.float64], c_in: NDArray[np.float64], c_out: NDArray[np.float64],
              wall: NDArray[np.float64] | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(d, e): a lower bidiagonal L (diagonal d, subdiagonal e) with L L^T = K~ of the chain that
    the ring is cut into (springs 0..n-2 of `spring_arrays`, site i's springs to a wall summing
    to wall[i]), every entry relatively accurate: its squared singular values are the chain's
    eigenvalues to a few ulps (dqds, or bisection).

    Free (`wall` None): L is B~ itself (n x (n - 1), a zero column added). With walls, K~ =
    B~ B~^T + D^2 (D_i^2 = wall_i / m_i) is not a product of one bidiagonal; its Cholesky factor
    is, and with a_i, b_i spring i's entries of B~ on sites i and i + 1 (signs dropped: a
    diagonal +-1 similarity) its entries come from sums of positive terms only:
    s_0 = D_0^2, d_i^2 = a_i^2 + s_i, e_i = a_i b_i / d_i, s_i+1 = D_i+1^2 + b_i^2 s_i / d_i^2
    (s_i = d_i^2 - a_i^2: what the sites up to i keep of their walls), so no cancellation: the
    factor is as accurate as its inputs, where forming K~ and factoring it would lose the
    lowest eigenvalues to ||K~|| eps."""
    root_w, root_m = np.sqrt(w[:-1]), np.sqrt(m)
    a = np.abs(root_w * c_in[:-1] / root_m[:-1])
    b = np.abs(root_w * c_out[:-1] / root_m[1:])
    if wall is None:
        return np.r_[a, 0.0], b
    return walled_factor(np.r_[a, 0.0], b, wall / m)
