"""The accurate path of a chain: singular values of the Golub-Kahan bidiagonal by dqds.

When the springs form a path (a chain, possibly anchored at its ends), B~ = W^1/2 B M^-1/2
is, up to ordering, an upper bidiagonal matrix; its singular values (the frequencies) come
from LAPACK dlasq1 (dqds) to high relative accuracy, its vectors from dbdsqr (segments up to
`BDSQR_LIMIT` dofs) or from the standard MRRR tridiagonal solver (longer ones).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._lapack import bidiagonal_singular_values, bidiagonal_svd
from vibra.solvers.common import (
    BDSQR_LIMIT, EPS, SolveResult, absolute_figures, selected, tridiagonal_bands,
)


Segment = tuple[int, int, NDArray[np.float64], NDArray[np.float64], int, bool]


def path_bidiagonals(weighted: sp.csr_matrix) -> list[Segment] | None:
    """Split B~ into chains whose springs form a path; None if the spring graph is not one.

    A path is a run of consecutive dofs c0..c1 joined by one term per neighbouring pair, with
    at most one single-dof term (an anchor) at each end. Its Golub-Kahan bidiagonal is
    returned as (c0, c1, d, e, n_keep, dofs_are_rows): the singular values of the square
    upper bidiagonal (d, e), of which the largest n_keep = c1 - c0 + 1 are the segment's
    frequencies; its dof-space vectors are the left singular vectors when dofs_are_rows.
    """
    b = sp.csr_matrix(weighted)
    b.sort_indices()
    n_terms, n = b.shape
    nnz = np.diff(b.indptr)
    if n_terms and (nnz.min() < 1 or nnz.max() > 2):
        return None
    pair_rows = np.flatnonzero(nnz == 2)
    single_rows = np.flatnonzero(nnz == 1)
    first = b.indices[b.indptr[pair_rows]]
    second = b.indices[b.indptr[pair_rows] + 1]
    if (second != first + 1).any():
        return None
    left_value = np.zeros(n)  # B~[pair(c, c+1), c]
    right_value = np.zeros(n)  # B~[pair(c, c+1), c+1]
    has_pair = np.zeros(n, dtype=bool)
    if np.bincount(first, minlength=n).max(initial=0) > 1:
        return None  # parallel springs between one pair: a cycle
    has_pair[first] = True
    left_value[first] = b.data[b.indptr[pair_rows]]
    right_value[first] = b.data[b.indptr[pair_rows] + 1]
    single_col = b.indices[b.indptr[single_rows]]
    single_val = b.data[b.indptr[single_rows]]
    degree = np.bincount(first, minlength=n) + np.bincount(second, minlength=n) + np.bincount(single_col, minlength=n)
    if degree.max(initial=0) > 2:
        return None
    anchors: dict[int, list[float]] = {}
    for column, value in zip(single_col.tolist(), single_val.tolist()):
        anchors.setdefault(column, []).append(value)
    starts = np.flatnonzero(np.r_[True, ~has_pair[:-1]])
    ends = np.r_[starts[1:] - 1, n - 1]
    segments = []
    for c0, c1 in zip(starts.tolist(), ends.tolist()):
        at_start = anchors.get(c0, [])
        at_end = anchors.get(c1, []) if c1 != c0 else at_start[1:]
        at_start = at_start[:1]
        inner_left = left_value[c0:c1]  # pair c -> value at c
        inner_right = right_value[c0:c1]  # pair c -> value at c+1
        if not at_start:
            # rows = terms, columns = dofs: d_i = value(pair_i, c_i), e_i = value(pair_i, c_i+1)
            d = np.r_[inner_left, at_end[:1] if at_end else [0.0]]
            e = inner_right
        else:
            # rows = dofs, columns = terms (anchor first): transpose of a lower bidiagonal
            d = np.r_[at_start, inner_right]
            e = inner_left
            if at_end:
                d = np.r_[d, 0.0]
                e = np.r_[e, at_end[:1]]
        segments.append((c0, c1, d, e, c1 - c0 + 1, bool(at_start)))
    return segments


def relative_bound(d: NDArray[np.float64], e: NDArray[np.float64]) -> float:
    """Relative error bound of each singular value of the bidiagonal (d, e) formed from B~.

    Two parts. Solving: the errors of dqds and of Golub-Kahan bisection grow linearly with
    size only where the chain itself is uniform (measured against closed forms: 34, 257,
    1334 eps at size 1e3, 1e4, 3e4, i.e. ~0.045 size eps) and stay a few eps on disordered
    chains (mpmath, spreads up to 1e12): (8 + size / 4) eps covers both with a margin of 4 or
    more. Forming: each entry of the bidiagonal (from sqrt(w), 1 / sqrt(m) and the path's
    products) carries a few eps of rounding, and entry factors (1 + delta_i) move every
    singular value by a factor within prod(1 +- |delta_i|) (Demmel-Kahan): 5 eps per entry,
    (2 size - 1) 5 eps in all (the hypothesis test over ratios 1e-12..1e12 against mpmath
    measured up to 3.5 eps per entry); when every entry has the same magnitude (a uniform
    chain) they all round alike, a common factor that moves each singular value by 2 eps
    only. Zero entries (padding) are exact.
    """
    size = d.shape[0]
    magnitudes = np.abs(np.concatenate([d, e]))
    magnitudes = magnitudes[magnitudes > 0]  # padding zeros are exact
    uniform = magnitudes.size == 0 or float(np.ptp(magnitudes)) == 0.0
    forming = 2.0 if uniform else 5.0 * (2 * size - 1)
    return (8.0 + 0.25 * size + forming) * EPS


def _path_values(segments: list[Segment]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(omega ascending, relative error bound) of all path segments by dqds."""
    omegas = []
    bounds = []
    for _, _, d, e, keep, _ in segments:
        sigma = bidiagonal_singular_values(d, e)[-keep:]
        omegas.append(sigma)
        bounds.append(np.full(keep, relative_bound(d, e)))
    omega = np.concatenate(omegas)
    bound = np.concatenate(bounds)
    order = np.argsort(omega)
    return omega[order], bound[order]


def bidiagonal_path(Kt: Any, weighted: sp.csr_matrix, segments: Any, *, n_modes: int | None, vectors: bool,
                   band: tuple[float, float] | None, on_stage: Callable[[float, str], None] | None = None
                   ) -> SolveResult:
    """accurate-bidiagonal: dqds values of each path segment, dbdsqr or MRRR vectors.

    `on_stage(fraction, message)` hears when the frequencies are done and the vectors start.
    """
    omega, relative = _path_values(segments)
    if on_stage is not None and vectors:
        on_stage(0.5, "frequencies done (dqds); computing the vectors")
    n = omega.shape[0]
    select = selected(omega, n_modes=n_modes, band=band)
    eigenvalues = omega[select] ** 2
    error = 2.0 * relative[select] * eigenvalues
    if not vectors:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-bidiagonal")
    if all(d.shape[0] <= BDSQR_LIMIT for _, _, d, _, _, _ in segments):
        basis = _path_vectors(segments, Kt.shape[0], omega)[:, select]
    else:
        # Vectors from the standard tridiagonal solver (angle error ~ eps ||K~|| / gap),
        # values from dqds: each column is re-paired with the dqds value of the same rank.
        d, e = tridiagonal_bands(Kt)
        if select.size == n:
            _, basis = la.eigh_tridiagonal(d, e, check_finite=False)  # MRRR, O(n^2)
        elif select.size:
            _, basis = la.eigh_tridiagonal(d, e, select="i", select_range=(int(select[0]), int(select[-1])),
                                           check_finite=False)
            basis = basis[:, select - select[0]]
        else:
            basis = np.zeros((Kt.shape[0], 0))
    figures = absolute_figures(sp.csr_matrix(Kt), eigenvalues, basis, "accurate-bidiagonal", floor=4.0)
    return SolveResult(eigenvalues, basis, error, figures.residual, figures.orthogonality, "accurate-bidiagonal")


def _path_vectors(segments: list[Segment], n: int, omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, n) dof-space vectors of every segment from dbdsqr, columns ordered like `omega`."""
    sigmas = []
    blocks = []
    for c0, c1, d, e, keep, dofs_are_rows in segments:
        sigma, vectors = bidiagonal_svd(d, e, left=dofs_are_rows)
        sigma, vectors = sigma[-keep:], vectors[: c1 - c0 + 1, -keep:]  # drop the padding
        full = np.zeros((n, keep))
        full[c0 : c1 + 1] = vectors / np.linalg.norm(vectors, axis=0)
        sigmas.append(sigma)
        blocks.append(full)
    order = np.argsort(np.concatenate(sigmas), kind="stable")
    return np.hstack(blocks)[:, order]

