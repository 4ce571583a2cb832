"""A chain with springs to a wall at its sites, its frequencies to high relative accuracy: ``accurate-walled``.

A chain of pendulums, a string on an elastic foundation, a chain pinned at a few sites: springs
join neighbours i, i + 1 along a path, the others tie single sites to a wall. B~ is then no
bidiagonal (`bidiagonal.chain_bidiagonals` declines it, so the chain paths do not apply) and
before, "high" took the checked dense solve (O(n^3): 15.7 s at 5,000 sites, refused past
~20,000). Here:

- values: the squared singular values of the chain's bidiagonal Cholesky factor, formed from
  the springs without cancellation (`counting.cut_chain`: relatively accurate entries), by
  dqds for all (O(n^2)), or by compiled Golub-Kahan bisection for the lowest k (O(n k));
- bounds: each value certified by two double-double inertia counts of the spring form
  [[W^-1, B], [B^T, x M - walls]] (`count_kernels.spring_counts`: the ring's counts with a
  closing coupling of zero, through a spring of no length in the ring's place), at the
  tightest of `counting.LEVELS` that proves it, else by multisection; widened by the counts'
  own perturbation (2 (2n + 1) u relatively, as `ring.counts.spring_widening` without the closing
  term): rigorous for the masses and springs as given;
- the lowest modes' vectors by Golub-Kahan inverse iteration on B~ (`golub_kahan.singular_vectors`).

None (the caller goes on) where the springs do not form such a chain, or the compiled loops
are unavailable. All modes with vectors: the checked dense solve up to DENSE_LIMIT; above,
these certified values with LAPACK stemr's vectors of K~, paired by rank (a chain's
eigenvalues are simple; `runners.accurate_walled`), where the Rayleigh path's dense solve took
O(n^3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core.lapack import bidiagonal_singular_values
from vibra.solvers.common import Matrix, MatrixLike, SolveResult
from vibra.solvers.accurate.dd import UNIT as _UNIT_DD, add as _add, div as _div, mul as _mul
from vibra.solvers.accurate.golub_kahan import singular_vectors
from vibra.solvers.accurate.gk_bisection import golub_kahan_lowest
from vibra.solvers.accurate.count_kernels import spring_counts
from vibra.solvers.accurate.counting import (
    LEVELS, certify_at_levels, cut_chain, proven_multisection, sorted_bounds, spring_width,
)
from vibra.solvers.accurate.spring_ritz import spring_figures

__all__ = ["WalledChain", "walled_chain", "walled_values", "walled_result", "has_inner_walls"]


@dataclass
class WalledChain:
    """A chain with walls in site order: m (n), w, c_in, c_out (its n - 1 springs' constants and
    entries of B on sites i and i + 1), wall (per site, sum of w c^2 of its springs to a wall,
    double-double)."""

    m: NDArray[np.float64]
    w: NDArray[np.float64]
    c_in: NDArray[np.float64]
    c_out: NDArray[np.float64]
    wall: tuple[NDArray[np.float64], NDArray[np.float64]]

    @property
    def n(self) -> int:
        return int(self.m.shape[0])


def walled_chain(coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> WalledChain | None:
    """The chain, if B's rows are one spring per neighbouring pair (i, i + 1), i = 0..n-2, and
    at least one spring to a wall (one entry); None otherwise (a chain without walls between its
    ends is a chain for `bidiagonal`; a cycle a ring; parallel springs, a branch: neither)."""
    if np.ndim(mass) != 1:
        return None
    B = sp.csr_matrix(coupling, dtype=float)
    B.sort_indices()
    n_terms, n = B.shape
    w = np.asarray(weights, dtype=float)
    count = np.diff(B.indptr)
    if n < 2 or n_terms == 0 or count.min() < 1 or count.max() > 2:
        return None
    pairs, singles = np.flatnonzero(count == 2), np.flatnonzero(count == 1)
    if singles.shape[0] == 0 or pairs.shape[0] != n - 1:
        return None
    first = B.indices[B.indptr[pairs]]
    if not np.array_equal(np.sort(first), np.arange(n - 1)) or np.any(B.indices[B.indptr[pairs] + 1] != first + 1):
        return None
    order = np.argsort(first)
    rows = pairs[order]
    c_in, c_out = B.data[B.indptr[rows]], B.data[B.indptr[rows] + 1]
    site, c = B.indices[B.indptr[singles]], B.data[B.indptr[singles]]
    if np.any(c == 0) or np.any(c_in == 0) or np.any(c_out == 0):
        return None
    if not inner_walls(site, n):
        return None  # walls at its two ends only: a plain chain (`bidiagonal`)
    # each wall spring's w c^2 in double-double, summed per site (a few per site at most)
    square = _mul(c, np.zeros_like(c), c, np.zeros_like(c))
    term = _mul(w[singles], np.zeros_like(c), *square)
    high, low = np.zeros(n), np.zeros(n)
    left = np.arange(singles.shape[0])
    while left.shape[0]:  # one wall spring per site per pass
        _, take = np.unique(site[left], return_index=True)
        chosen = left[take]
        high[site[chosen]], low[site[chosen]] = _add(high[site[chosen]], low[site[chosen]], term[0][chosen],
                                                     term[1][chosen])
        left = np.delete(left, take)
    return WalledChain(np.asarray(mass, dtype=float), w[rows], c_in, c_out, (high, low))


def inner_walls(site: NDArray[np.intp], n: int) -> bool:
    """Whether springs to a wall at these sites make a chain of n sites more than a plain chain (one
    at each end at most, as `bidiagonal.chain_bidiagonals` takes it)."""
    per_site = np.bincount(site, minlength=n)
    return bool(per_site[1:-1].any() or per_site[0] > 1 or per_site[-1] > 1)


def has_inner_walls(coupling: MatrixLike) -> bool:
    """`inner_walls` from B's rows with one entry (O(nnz), no values): for the cost estimate."""
    B = sp.csr_matrix(coupling)
    single = np.flatnonzero(np.diff(B.indptr) == 1)
    return single.shape[0] > 0 and inner_walls(B.indices[B.indptr[single]], B.shape[1])


@dataclass
class WalledValues:
    """values (omega^2 ascending), bound (absolute, per value), certified, counts spent."""

    values: NDArray[np.float64]
    bound: NDArray[np.float64]
    certified: NDArray[np.bool_]
    counts: int


def walled_values(chain: WalledChain, count: int | None = None) -> WalledValues:
    """All eigenvalues (the lowest `count`), each certified by counts (see above)."""
    n = chain.n
    wanted = n if count is None else max(1, min(int(count), n))
    # the ring's arrays with a spring of no length in the closing place: w = 1, no couplings
    w = np.r_[chain.w, 1.0]
    c_in, c_out = np.r_[chain.c_in, 0.0], np.r_[chain.c_out, 0.0]
    d, e = cut_chain(chain.m, w, c_in, c_out, chain.wall[0])
    if wanted < n:
        values = golub_kahan_lowest(d, e, 0, wanted, vectors=False)[0] ** 2
    else:
        values = np.sort(bidiagonal_singular_values(d, e)) ** 2
    compliance = _div(np.ones(n), np.zeros(n), w, np.zeros(n))
    off = np.empty(2 * n - 1)
    off[0::2], off[1::2] = c_in, c_out[: n - 1]
    squares = _mul(off, np.zeros_like(off), off, np.zeros_like(off))
    u = 4 * _UNIT_DD
    # the counts' perturbation: phi per node as for a ring, and the walls' own double-double
    # rounding (w c^2 and their sum, a few units); no closing coupling, no shift
    widening = np.array([2 * (2 * n + 1) * u + 8 * _UNIT_DD, 0.0])

    def counts(x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        found, certain, _ = spring_counts(x, chain.m, compliance, off, squares, 0.0, u, chain.wall)
        return found, certain

    index = np.arange(wanted)
    bound = np.full(wanted, np.inf)
    spent = certify_at_levels(counts, values, bound, index, LEVELS, widening)
    for reach in (1e-9, 1e-6):  # values no level proved: multisection inside a proven bracket
        todo = np.flatnonzero(~np.isfinite(bound))
        if todo.shape[0] == 0:
            break
        lo, hi, used = proven_multisection(counts, values[todo] * (1 - reach), values[todo] * (1 + reach),
                                           index[todo])
        spent += used
        proven = lo < hi
        middle = 0.5 * (lo + hi)
        values[todo[proven]] = middle[proven]
        bound[todo[proven]] = spring_width(lo[proven], hi[proven], middle[proven], widening)
    certified = np.isfinite(bound)
    bound = np.where(certified, bound, np.abs(values))  # (not seen) the widest honest bound
    order = np.argsort(values, kind="stable")
    values = values[order]
    return WalledValues(values, sorted_bounds(values, bound[order], order), certified[order], spent)


def walled_result(coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64], weighted: Matrix,
                  n_modes: int | None, vectors: bool) -> SolveResult | None:
    """``accurate-walled``: the chain's frequencies (the lowest n_modes when given), with the
    lowest modes' vectors when asked; None where it does not apply (the caller goes on)."""
    chain = walled_chain(coupling, weights, mass)
    if chain is None:
        return None
    found = walled_values(chain, n_modes)
    k = found.values.shape[0]
    if vectors:
        B = sp.csr_matrix(weighted)
        result = spring_figures(B, found.values, singular_vectors(B, found.values, mass), True, "accurate-walled")
        result.error = found.bound
    else:
        result = SolveResult(found.values, None, found.bound, float("nan"), float("nan"), "accurate-walled")
    result.refined = np.ones(k, dtype=bool)
    worst = float(np.max(found.bound / found.values))
    which = f"the lowest {k} modes" if n_modes is not None and k < chain.n else f"all {k} modes"
    how = "bisection" if n_modes is not None and k < chain.n else "dqds"
    result.refinement = (f"{which} of the chain on walls from its bidiagonal Cholesky factor ({how}), "
                         f"{int(found.certified.sum())} of {k} bounds certified by Sturm counts of the spring form "
                         f"in double-double, error/omega^2 up to {worst:.1g}"
                         + ("; vectors by Golub-Kahan inverse iteration" if vectors else ""))
    return result
