"""The lowest modes of a chain, by bisection on its Golub-Kahan form: no shift to choose.

A chain's frequencies are the singular values of its bidiagonal spring factor B~
(`bidiagonal.chain_bidiagonals`). The singular values of an upper bidiagonal
(d, e) are the positive eigenvalues of the Golub-Kahan tridiagonal TGK (zero diagonal,
off-diagonal d1, e1, d2, e2, ..., dn), whose Sturm counts are relatively accurate
(Demmel and Kahan 1990). Bisection (compiled, LANES values at a time, `gk_bisection`; LAPACK
dstebz with vectors where TGK's blocks are not known without it, and wherever it costs less than
loading the kernel, `gk_bisection.compiled_bisection_pays`) therefore finds the lowest
k to a few ulps of themselves however far below ||K~|| they lie, in O(n k) per bit: a disordered chain
whose masses and springs spread over 1e12, where a shift chosen from ||K~|| sees the lowest
eigenvalues as one cluster, costs no more than a uniform one. Vectors come from inverse
iteration on TGK (LAPACK dstein); their accuracy is the residual's.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate.chain.bidiagonal import (
    Segment, certify_modes, chunk, compose, inverse_iteration, neighbour_bounds, chain_bidiagonals,
    segment_scalings, solving_bound, worst_forming,
)
from vibra.solvers.common import EPS, Matrix, MatrixLike, SolveResult, absolute_figures
from vibra.solvers.accurate.gk_bisection import golub_kahan_lowest
from vibra.solvers.accurate.rounding import UNIT, Scalings

__all__ = ["lowest_chain_path", "chain_segments", "certified_lowest", "spring_factor_of_chain", "lowest_chain_modes"]


def chain_segments(weighted: Matrix) -> list[Segment] | None:
    """The chain segments of a spring factor B~ (`chain_bidiagonals`), None if not a chain."""
    return chain_bidiagonals(sp.csr_matrix(weighted))


def certified_lowest(d: NDArray[np.float64], e: NDArray[np.float64], skip: int, k: int, *, vectors: bool,
                     scalings: Scalings | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None,
                                NDArray[np.float64] | None]:
    """Singular values skip..skip+k-1 of the upper bidiagonal (d, e), each with its relative bound.

    Returns (sigma, relative, u, v); u, v as `golub_kahan_lowest` (None unless `vectors`).
    The bound holds against the exact bidiagonal, of which (d, e) is the stored form with the
    forming error `scalings` (the worst case, `worst_forming`, if None).

    - Solving: bisection (or dqds) values, then for each the Rayleigh quotient of its triplet
      in double-double and its Kato-Temple bound, gap to the neighbouring values (one more
      value is found for the gap above the last): `bidiagonal.certify_modes`. The triplets
      are the asked-for vectors (LAPACK dstein), or for values only two steps of inverse
      iteration, dropped after use (O(size) per value, less than finding it). A value whose
      residual leaves no gap (a cluster) keeps the measured size law, `solving_bound`.
    - Forming: `Scalings.weighted` with vectors, `Scalings.bound` without.
    - A zero diagonal entry (a free chain's padding) makes the lowest value exactly zero.
    """
    size = d.shape[0]
    forming = scalings if scalings is not None else Scalings.worst_case(size, worst_forming(d, e))
    zeros = int((d == 0).any())
    a_priori = compose(solving_bound(size), forming.bound())
    extra = 1 if skip + k < size else 0  # one value beyond: the gap above the last
    values, u, v = golub_kahan_lowest(d, e, skip, k + extra, vectors=vectors)
    below, above = neighbour_bounds(values, skip, zeros, 4 * solving_bound(size))
    sigma = values[:k].copy()
    relative = np.full(k, a_priori)
    first = max(zeros - skip, 0)  # exact zeros are not certified
    if zeros and skip == 0:
        sigma[0], relative[0] = 0.0, 0.0
    step = chunk(size)
    for start in range(first, k, step):
        block = slice(start, min(start + step, k))
        if u is not None and v is not None:
            left, right = u[:, block], v[:, block]
        else:
            left, right = inverse_iteration(d, e, sigma[block], steps=2)
        sigma[block], relative[block] = certify_modes(d, e, sigma[block], left, right, below[block],
                                                      above[block], forming)
    if u is not None and v is not None:
        u, v = u[:, :k], v[:, :k]
    return sigma, relative, u, v


def lowest_chain_path(Kt: Matrix, segments: list[Segment], n_modes: int, *, vectors: bool,
                      scalings: list[Scalings] | None = None) -> SolveResult:
    """accurate-bisection: the lowest `n_modes` frequencies of a chain by Golub-Kahan bisection.

    Parameters
    ----------
    Kt : (n, n) sparse or dense
        K~ (for the residual figures of the vectors).
    segments : list
        `chain_segments(B~)`: the chain's bidiagonals.
    n_modes : int
        How many of the lowest modes.
    vectors : bool
        Whether to compute the mass-weighted vectors.
    scalings : list of Scalings, optional
        Each segment's forming error (`bidiagonal.segment_scalings`); the worst case if None.

    Returns
    -------
    SolveResult
        eigenvalues omega^2 ascending, each with the bound of `certified_lowest` (relative
        in omega, about twice that in omega^2); solver ``"accurate-bisection"``.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> B = sp.csr_matrix(np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]]))  # free 3-site chain
    >>> result = lowest_chain_path(B.T @ B, chain_segments(B), 2, vectors=False)
    >>> np.round(result.eigenvalues, 12)
    array([0., 1.])
    """
    n = Kt.shape[0]
    found_sigma = []
    found_bound = []
    found_vectors = []
    for index, (c0, c1, d, e, keep, dofs_are_rows) in enumerate(segments):
        k = min(n_modes, keep)
        skip = d.shape[0] - keep  # padding zeros below the segment's frequencies
        sigma, relative, u, v = certified_lowest(d, e, skip, k, vectors=vectors,
                                                 scalings=None if scalings is None else scalings[index])
        found_sigma.append(sigma)
        found_bound.append(relative)
        if vectors:
            side = u if dofs_are_rows else v
            assert side is not None
            full = np.zeros((n, k))
            block = side[: c1 - c0 + 1]
            full[c0 : c1 + 1] = block / np.maximum(np.linalg.norm(block, axis=0), np.finfo(float).tiny)
            found_vectors.append(full)
    sigma = np.concatenate(found_sigma)
    order = np.argsort(sigma, kind="stable")[:n_modes]
    eigenvalues = sigma[order] ** 2
    # bisection's absolute floor: intervals shrink to the pivot minimum (safe minimum x ||B~||^2)
    scale = max((float(np.abs(np.r_[d, e]).max(initial=0.0)) for _, _, d, e, _, _ in segments), default=0.0)
    floor = 4.0 * np.finfo(float).tiny * max(1.0, scale * scale)
    sigma_error = np.concatenate(found_bound)[order] * sigma[order] + floor
    error = sigma_error * (2.0 * sigma[order] + sigma_error) + UNIT * eigenvalues  # (+ squaring's rounding)
    if not vectors:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-bisection")
    basis = np.hstack(found_vectors)[:, order]
    figures = absolute_figures(sp.csr_matrix(Kt), eigenvalues, basis, "accurate-bisection", floor=4.0)
    return SolveResult(eigenvalues, basis, error, figures.residual, figures.orthogonality, "accurate-bisection")


def _exact_row_sums(K: sp.csr_matrix) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(row sums of a tridiagonal K, their rounding bound): diagonal plus both neighbours, by TwoSum."""
    n = K.shape[0]
    lower = np.r_[0.0, K.diagonal(-1)]
    upper = np.r_[K.diagonal(1), 0.0]
    diagonal = K.diagonal()
    first = diagonal + lower
    err = (diagonal - (first - (first - diagonal))) + (lower - (first - diagonal))  # TwoSum's error
    total = first + upper
    err2 = (first - (total - (total - first))) + (upper - (total - first))
    return total + (err + err2), np.abs(diagonal) * EPS * (n > 0)


def _anchor_slack(K: Matrix, coupling: sp.csr_matrix, weights: NDArray[np.float64]) -> NDArray[np.float64]:
    """Relative uncertainty of each weight of `spring_factor_of_chain(K)`: springs are exact; an
    anchor, K's row sum (compensated, ~2 u), also carries the rounding of assembling K[i, i] from
    the springs it sums (2 u |K[i, i]|), as the anchors that code drops for lying within it."""
    rows = sp.csr_matrix(coupling)
    single = np.flatnonzero(np.diff(rows.indptr) == 1)
    slack = np.zeros(weights.shape[0])
    diagonal = np.abs(sp.csr_matrix(K).diagonal())
    column = rows.indices[rows.indptr[single]]
    slack[single] = 4 * UNIT + 4 * UNIT * diagonal[column] / weights[single]
    return slack


def spring_factor_of_chain(K: MatrixLike) -> tuple[sp.csr_matrix, NDArray[np.float64]] | None:
    """The spring factor (B, w) of a chain's stiffness K (tridiagonal), or None if K is not one.

    Springs are -K[i, i+1] (all must be >= 0); each dof's anchor is its row sum, computed
    without cancellation, and taken as zero where it lies within the rounding of K[i, i]
    (K was assembled as a sum of springs). A negative spring or anchor beyond that: None.
    B has one row per spring (-1, +1 on dofs i, i+1) and one per nonzero anchor.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> B, w = spring_factor_of_chain(sp.csr_matrix(np.array([[3.0, -1.0], [-1.0, 1.0]])))
    >>> B.toarray(), w
    (array([[-1.,  1.],
           [ 1.,  0.]]), array([1., 2.]))
    """
    matrix = sp.csr_matrix(K, dtype=float)
    n = matrix.shape[0]
    coo = matrix.tocoo()
    if np.any(np.abs(coo.row - coo.col) > 1) or np.any(matrix.diagonal(1) != matrix.diagonal(-1)):
        return None
    springs = -matrix.diagonal(1)
    if np.any(springs < 0):
        return None
    anchors, rounding = _exact_row_sums(matrix)
    if np.any(anchors < -4.0 * rounding):
        return None
    anchored = np.flatnonzero(anchors > 4.0 * rounding)
    pairs = np.arange(n - 1)
    keep = np.flatnonzero(springs > 0)
    rows = np.r_[np.repeat(np.arange(keep.size), 2), keep.size + np.arange(anchored.size)]
    cols = np.r_[np.ravel(np.c_[pairs[keep], pairs[keep] + 1]), anchored].astype(np.intp)
    values = np.r_[np.tile([-1.0, 1.0], keep.size), np.ones(anchored.size)]
    coupling = sp.csr_matrix((values, (rows, cols)), shape=(keep.size + anchored.size, n))
    return coupling, np.r_[springs[keep], anchors[anchored]]


def lowest_chain_modes(Kt: Matrix, K: Matrix, mass: NDArray[np.float64],
                       spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None, *, n_modes: int,
                       vectors: bool, scale: float = 1.0) -> SolveResult | None:
    """`lowest_chain_path` for a request as `dispatch.solve` holds it, or None if K is not a chain.

    Parameters
    ----------
    Kt : K~ as solved (already multiplied by `scale`); K : the stiffness as given; mass :
    diagonal masses (a dense M: None); spring_factor : (B, w) with w already multiplied by
    `scale`, or None to derive it from K (`spring_factor_of_chain`, then scaled here).
    """
    if mass.ndim != 1:
        return None
    weight_slack = None
    if spring_factor is None:
        derived = spring_factor_of_chain(K)
        if derived is None:
            return None
        spring_factor = (derived[0], derived[1] * scale)
        weight_slack = _anchor_slack(K, *derived)
    coupling, weights = spring_factor
    weighted = sp.csr_matrix(sp.diags(np.sqrt(weights)) @ coupling @ sp.diags(1.0 / np.sqrt(mass)))
    segments = chain_segments(weighted)
    if segments is None:
        return None
    scalings = segment_scalings(weighted, segments, coupling, weights, mass, weight_slack=weight_slack)
    return lowest_chain_path(Kt, segments, n_modes, vectors=vectors, scalings=scalings)
