"""The accurate path of a chain: singular values of the Golub-Kahan bidiagonal by dqds.

When the springs form a chain (possibly anchored at its ends), B~ = W^1/2 B M^-1/2
is, up to ordering, an upper bidiagonal matrix; its singular values (the frequencies) come
from LAPACK dlasq1 (dqds) to high relative accuracy, its vectors from dbdsqr (segments up to
`BDSQR_LIMIT` dofs) or from the standard MRRR tridiagonal solver (longer ones).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any, Callable, TypeVar

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core.lapack import bidiagonal_singular_values, bidiagonal_triplets
from vibra.solvers.common import (
    BDSQR_LIMIT, EPS, SolveResult, absolute_figures, selected, tridiagonal_bands,
)
from vibra.solvers.compiled import compiled_pays
from vibra.solvers.accurate.rounding import (
    UNIT, Scalings, centred, entry_deviation, kato_temple, rayleigh_refinement, scaling_logs,
)

if TYPE_CHECKING:
    from vibra.solvers.common import Matrix, MatrixLike

    #: A relative bound, per value or one for all (`compose` gives the kind it is given).
    _Bound = TypeVar("_Bound", float, NDArray[np.float64])

Segment = tuple[int, int, NDArray[np.float64], NDArray[np.float64], int, bool]

#: Values only: a segment of CERTIFY_FROM < size <= CERTIFY_ALL sites has every value
#: certified by inverse-iteration triplets (`inverse_iteration`, O(size) each: O(size^2) in
#: all); a shorter one keeps the a-priori bound (the measured size law
#: `solving_bound` plus `worst_forming`: under 3e-12 relative there, at dqds' speed), and so
#: does a longer one (certifying it would cost far more than the solve).
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
CERTIFY_FROM = 1200
CERTIFY_ALL = 3000

#: With the compiled kernel, values only: every segment whose a-priori bound exceeds this is
#: certified (smaller ones: ~40 sites or fewer, the bound already within the 1e-13 target).
CERTIFY_ABOVE = 1e-13

#: Seconds per size^2 of a segment's numpy certificates (`inverse_iteration` and `certify_modes`),
#: the compiled ones' counterpart: 3.1e-7 (300 sites) to 5.2e-7 (100) measured, one core (the
#: compiled: ~3e-8 at 300). A segment whose numpy certificates are estimated under
#: `vibra.solvers.compiled.COMPILED_FROM_S` (~500 sites) takes them, not the compiled kernel.
NUMPY_CERTIFY_S = 3.5e-7

#: Entries per block of modes certified together (size x block doubles per temporary).
CHUNK = 1 << 18


def chunk(size: int) -> int:
    """Modes per block for a bidiagonal of `size`: CHUNK entries, 1 to 256 modes."""
    return max(1, min(256, CHUNK // max(size, 1)))


def chain_bidiagonals(weighted: sp.csr_matrix) -> list[Segment] | None:
    """Split B~ into chains of springs; None if the spring graph is not made of chains.

    A chain is a run of consecutive dofs c0..c1 joined by one term per neighbouring pair, with
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


def solving_bound(size: int) -> float:
    """The measured size law of dqds and Golub-Kahan bisection, relative: (8 + size / 4) eps.

    Their errors grow linearly with size only where the chain itself is uniform (its
    roundings all lean one way; measured against closed forms: 34, 257, 1334 eps at size 1e3,
    1e4, 3e4 for dqds, 24,000 eps at 1e6 for bisection) and stay a few eps on disordered
    chains (mpmath, spreads up to 1e12): this law covers both with a margin of 4 or more. It
    is the bound of values that no residual certifies (`certify_modes` replaces it where one does).
    """
    return (8.0 + 0.25 * size) * EPS


def compose(solving: _Bound, forming: _Bound) -> _Bound:
    """The relative bound of two relative errors in a row: s + f + s f, rounded up (not (1+s)(1+f) - 1,
    which rounds the small ones away)."""
    return (solving + forming + solving * forming) * (1 + 4 * UNIT)


def worst_forming(d: NDArray[np.float64], e: NDArray[np.float64]) -> float:
    """The forming error without entry-wise figures: 5 eps per entry, 2 eps for a uniform chain.

    Entry factors (1 + delta_i) move every singular value by a factor within
    prod(1 +- |delta_i|) (Demmel-Kahan): (2 size - 1) 5 eps in all (the hypothesis test over
    ratios 1e-12..1e12 measured up to 3.5 eps per entry); when every entry has the same
    magnitude (a uniform chain) they all round alike, a common factor: 2 eps. Zero entries
    (padding) are exact.
    """
    size = d.shape[0]
    magnitudes = np.abs(np.concatenate([d, e]))
    magnitudes = magnitudes[magnitudes > 0]  # padding zeros are exact
    uniform = magnitudes.size == 0 or float(np.ptp(magnitudes)) == 0.0
    return 2.0 * EPS if uniform else 5.0 * (2 * size - 1) * EPS


def segment_scalings(weighted: sp.csr_matrix, segments: list[Segment], coupling: MatrixLike,
                     weights: NDArray[np.float64], mass: NDArray[np.float64], *, weight_slack: NDArray[np.float64] | None = None
                     ) -> list[Scalings]:
    """Each segment's forming error as diagonal scalings, from every entry's actual rounding.

    Parameters
    ----------
    weighted : B~ = diag(sqrt w) B diag(1 / sqrt m) as stored; segments : its `chain_bidiagonals`.
    coupling, weights, mass : the B, w and diagonal masses it was formed from (exact).
    weight_slack : (n_terms,) ndarray, optional
        A relative uncertainty of each w (a spring read back from K's row sums), 0 if None.

    Returns
    -------
    list of `vibra.solvers.accurate.rounding.Scalings`, one per segment (in order).
    """
    b = sp.csr_matrix(weighted)
    b.sort_indices()
    rows = np.repeat(np.arange(b.shape[0]), np.diff(b.indptr))
    cols = b.indices
    couplings = np.asarray(sp.csr_matrix(coupling)[rows, cols]).ravel() if rows.size else np.zeros(0)
    delta, slack = entry_deviation(b.data, np.asarray(weights, dtype=float)[rows], couplings,
                                   np.asarray(mass, dtype=float)[cols])
    own = np.zeros_like(slack)  # each entry's share of its weight's uncertainty (sqrt halves it)
    if weight_slack is not None:
        own = 0.5 * np.asarray(weight_slack, dtype=float)[rows]
    index = sp.csr_matrix((np.arange(1, b.nnz + 1, dtype=float), b.indices, b.indptr), shape=b.shape)
    located = chain_bidiagonals(index)
    assert located is not None and len(located) == len(segments)
    padded_delta, padded_slack, padded_own = np.r_[0.0, delta], np.r_[0.0, slack], np.r_[0.0, own]  # 0: padding
    result = []
    for (_, _, d, _, _, _), (_, _, d_index, e_index, _, _) in zip(segments, located):
        di, ei = d_index.astype(np.intp), e_index.astype(np.intp)
        a, bb = scaling_logs(padded_delta[di], padded_delta[ei], d)
        total = float(padded_slack[di].sum() + padded_slack[ei].sum())
        row_slack, column_slack = np.zeros(di.shape[0]), np.zeros(di.shape[0])
        # an entry alone in its row (column) carries its weight's uncertainty in that row's (column's) scaling
        e_in_row = np.r_[ei > 0, False]
        e_in_column = np.r_[False, ei > 0]
        alone_row = (di > 0) & ~e_in_row
        alone_column = (di > 0) & ~e_in_column & ~alone_row
        row_slack[alone_row] += padded_own[di[alone_row]]
        column_slack[alone_column] += padded_own[di[alone_column]]
        e_alone_row = (ei > 0) & (di[:-1] == 0)
        e_alone_column = (ei > 0) & (di[1:] == 0) & ~e_alone_row
        row_slack[:-1][e_alone_row] += padded_own[ei[e_alone_row]]
        column_slack[1:][e_alone_column] += padded_own[ei[e_alone_column]]
        shared = (di > 0) & ~alone_row & ~alone_column
        e_shared = (ei > 0) & ~e_alone_row & ~e_alone_column
        total += float(padded_own[di[shared]].sum() + padded_own[ei[e_shared]].sum())
        result.append(Scalings(a, bb, total, row_slack, column_slack))
    return result


def neighbour_bounds(sigma: NDArray[np.float64], first: int, zeros: int, eta: float
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(below, above): bounds on the Golub-Kahan eigenvalues next to each of consecutive singular values.

    `sigma` holds the singular values first, first + 1, ... (ascending, 0-based) of one
    bidiagonal, each within relative `eta`; the lowest `zeros` of all are exactly zero. below[j]
    bounds from above the eigenvalue just under sigma[j] (the previous value, or -sigma[0]
    itself, its Golub-Kahan partner, when it is the lowest of all; nan when unknown), above[j]
    bounds from below the one just over it (inf past the last value of the bidiagonal: pass
    sigma up to one beyond the modes to certify).
    """
    k = sigma.shape[0]
    index = first + np.arange(k)
    widened_up = np.where(index < zeros, 0.0, sigma * (1 + eta))
    widened_down = np.where(index < zeros, 0.0, sigma * (1 - eta))
    start = -widened_down[:1] if first == 0 else [0.0 if first <= zeros else np.nan]  # nan: unknown, no gap
    below = np.r_[start, widened_up[:-1]]
    above = np.r_[widened_down[1:], np.inf]
    return below, above


def certify_modes(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64],
                  left: NDArray[np.float64], right: NDArray[np.float64], below: NDArray[np.float64],
                  above: NDArray[np.float64], scalings: Scalings
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Refined singular values and their relative bounds from the vectors of the stored bidiagonal.

    Solving: the Rayleigh quotient rho of each triplet in double-double and its Kato-Temple
    bound ||r||^2 / gap (`vibra.solvers.accurate.rounding.kato_temple`), gap to `below` / `above`;
    where no gap serves (a cluster), the value stays as given with `solving_bound`. Forming:
    `Scalings.weighted`, the scalings weighted by each certified mode's vectors (their angle
    error residual / gap counted), `Scalings.bound` for the others. Returns (values,
    relative bound of each against the exact bidiagonal).
    """
    rho, uncertainty, residual = rayleigh_refinement(d, e, sigma, left, right)
    return _certified(d, e, sigma, rho, uncertainty, residual, *scalings.sums(left, right), below, above, scalings)


def _certified(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64],
               rho: NDArray[np.float64], uncertainty: NDArray[np.float64], residual: NDArray[np.float64],
               first: NDArray[np.float64], norms: NDArray[np.float64], below: NDArray[np.float64],
               above: NDArray[np.float64], scalings: Scalings) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`certify_modes` from the triplets' figures: `rayleigh_refinement`'s (rho, uncertainty,
    residual) and the vectors' sums for the forming bound (`Scalings.sums`: first, norms)."""
    size = d.shape[0]
    bound = kato_temple(rho, residual, below, above) + uncertainty
    a_priori = solving_bound(size)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = bound / rho
        good = np.isfinite(relative) & (rho > 0) & (relative < a_priori)
    value = np.where(good, rho, sigma)
    solving = np.where(good, relative, a_priori)
    with np.errstate(divide="ignore", invalid="ignore"):
        low = 1.0 - np.maximum(below, 0.0) / value
        high = np.where(np.isinf(above), 1.0, (above - value) / above)
        gap = np.minimum(low, high)  # relative gap; nan (unknown) counts as none
        angle = residual / np.minimum(rho - below, above - rho)  # sin of each pair's angle (Davis-Kahan)
    angle = np.where(good & (angle < 1), angle, 1.0)
    weighted = scalings.from_sums(first, norms, np.where(np.isnan(gap), 0.0, np.maximum(gap, 0.0)), angle)
    # A value without a certificate keeps the whole a-priori bound, worst-case forming included:
    # the size law alone missed a dqds value of a 6-site chain with masses 1e12 apart by 4x
    # (40 eps against 9.5 eps), which the worst-case forming term (55 eps there) covers.
    forming = np.where(good, weighted, max(scalings.bound(), worst_forming(d, e)))
    return value, compose(solving, forming)


def inverse_iteration(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64], *,
                      steps: int = 1) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(u, v) of the upper bidiagonal (d, e) at each sigma: `steps` of inverse iteration on the
    Golub-Kahan form (LAPACK gtsv), unit columns. Not orthogonalised: for the bounds only.

    With sigma from dqds or bisection (relative error delta ~ size eps), one step leaves an
    angle ~ sqrt(size) delta / relative gap, a residual whose square over the gap is far below
    eps: enough for `certify_modes`, which falls back to the size law where it is not."""
    s = d.shape[0]
    off = np.empty(2 * s - 1)
    off[0::2] = d
    off[1::2] = e
    gtsv = la.get_lapack_funcs("gtsv", dtype=np.float64)
    start = np.random.default_rng(2024).standard_normal(2 * s)
    left = np.empty((s, sigma.shape[0]))
    right = np.empty((s, sigma.shape[0]))
    for j, value in enumerate(sigma.tolist()):
        z = start.copy()
        for _ in range(steps):
            shift = value
            for _attempt in range(3):
                _, _, _, solved, info = gtsv(off, np.full(2 * s, -shift), off, z)
                if info == 0 and np.all(np.isfinite(solved)):
                    break
                shift = shift * (1 + 4 * EPS) + np.finfo(float).tiny  # an exact pivot of zero
            with np.errstate(over="ignore"):
                norm = np.linalg.norm(solved)
            if not np.isfinite(norm):  # (a solve past 1e154: scaled first, its norm overflowed)
                solved = solved / np.abs(solved).max()
                norm = np.linalg.norm(solved)
            z = solved / norm
        right[:, j], left[:, j] = z[0::2], z[1::2]
    left /= np.maximum(np.linalg.norm(left, axis=0), np.finfo(float).tiny)
    right /= np.maximum(np.linalg.norm(right, axis=0), np.finfo(float).tiny)
    return left, right


def _segment_scalings(weighted: sp.csr_matrix, segments: list[Segment], factor: Any,
                      mass: NDArray[np.float64] | None) -> list[Scalings]:
    """`segment_scalings` where the spring factor and diagonal masses are known, else the worst case."""
    if factor is not None and mass is not None and np.ndim(mass) == 1:
        return segment_scalings(weighted, segments, factor[0], factor[1], mass)
    return [Scalings.worst_case(d.shape[0], worst_forming(d, e)) for _, _, d, e, _, _ in segments]


def certify_all(size: int, a_priori: float) -> bool:
    """Whether every value of a segment of `size` sites is certified (values only).

    With the compiled kernel (`triplets`, about dqds' own cost): wherever the a-priori bound
    exceeds `CERTIFY_ABOVE` (below it, it is tight enough), by the numpy certificates where
    they cost less than loading the kernel (`certified_values`: ~500 sites or fewer). Without
    it (`_compiled` None, ~15x dqds): only from `CERTIFY_FROM` to `CERTIFY_ALL` sites.
    """
    if _compiled() is not None:
        return a_priori > CERTIFY_ABOVE
    return CERTIFY_FROM < size <= CERTIFY_ALL


def _compiled() -> Any:
    """The compiled certificates, `triplets` (compiled on first use, cached on disk); None takes
    the numpy route (what tests compare them with)."""
    return importlib.import_module("vibra.solvers.accurate.chain.triplets")


def certified_values(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64],
                     forming: Scalings, triplets: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """All singular values of (d, e) (ascending, `sigma`) refined and certified by `certify_modes`.

    The triplets' vectors are `triplets` (left, right), or inverse iteration's, in blocks of
    `chunk(size)`. A zero diagonal entry makes the lowest value exactly zero.
    """
    size = d.shape[0]
    zeros = int((d == 0).any())
    value = sigma.copy()
    relative = np.full(size, compose(solving_bound(size), forming.bound()))
    if zeros:
        value[0], relative[0] = 0.0, 0.0
    below, above = neighbour_bounds(sigma, 0, zeros, 4 * solving_bound(size))
    compiled = _compiled() if compiled_pays(NUMPY_CERTIFY_S * size * size) else None
    if triplets is None and compiled is not None:
        block = slice(zeros, size)
        start = np.random.default_rng(2024).standard_normal(2 * size)
        a, b = centred(forming.a, forming.b)
        with np.errstate(divide="ignore", invalid="ignore"):
            gaps = np.minimum(sigma - below, above - sigma)[block] / sigma[block]  # nan: none known
        figures = compiled.triplet_figures(d, e, sigma[block], start, a, b,
                                           forming.row_slack, forming.column_slack, np.nan_to_num(gaps, nan=0.0))
        rho, uncertainty, residual, first, norms, _ = figures.T
        value[block], relative[block] = _certified(d, e, sigma[block], rho, uncertainty, residual, first, norms,
                                                   below[block], above[block], forming)
        return value, relative
    step = chunk(size)
    for start in range(zeros, size, step):
        block = slice(start, min(start + step, size))
        if triplets is not None:
            left, right = triplets[0][:, block], triplets[1][:, block]
        else:
            left, right = inverse_iteration(d, e, sigma[block])
        value[block], relative[block] = certify_modes(d, e, sigma[block], left, right, below[block],
                                                      above[block], forming)
    return value, relative


def _chain_values(segments: list[Segment], scalings: list[Scalings]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(omega ascending, relative error bound) of all chain segments by dqds, certified in CERTIFY_FROM..CERTIFY_ALL."""
    omegas = []
    bounds = []
    for (_, _, d, e, keep, _), forming in zip(segments, scalings):
        sigma = bidiagonal_singular_values(d, e)
        a_priori = compose(solving_bound(d.shape[0]), max(forming.bound(), worst_forming(d, e)))
        if certify_all(keep, a_priori):
            sigma, relative = certified_values(d, e, sigma, forming)
        else:
            # no certificate: the size law with the worst-case forming term, which covers what
            # the law alone misses on tiny extreme chains (see `certify_modes`)
            relative = np.full(d.shape[0], a_priori)
            if (d == 0).any():
                sigma[0] = 0.0  # a zero diagonal entry: singular, exactly (the stored and the exact B~)
        omegas.append(sigma[-keep:])
        bounds.append(relative[-keep:])
    omega = np.concatenate(omegas)
    bound = np.concatenate(bounds)
    order = np.argsort(omega)
    return omega[order], bound[order]


def bidiagonal_path(Kt: Matrix, weighted: sp.csr_matrix, segments: list[Segment], *, n_modes: int | None, vectors: bool,
                   band: tuple[float, float] | None, on_stage: Callable[[float, str], None] | None = None,
                   factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None = None,
                   mass: NDArray[np.float64] | None = None) -> SolveResult:
    """accurate-bidiagonal: dqds values of each chain segment, dbdsqr or MRRR vectors.

    `on_stage(fraction, message)` hears when the frequencies are done and the vectors start.
    `factor` (B, w) and `mass` (diagonal), the spring factor and masses B~ was formed from:
    with them the forming error comes from each entry's actual rounding (`segment_scalings`),
    without them from the worst case (`worst_forming`). Solving: every value of a segment
    refined to the Rayleigh quotient of its triplet and certified by `certify_modes`
    (Kato-Temple) where that is cheap beside the solve: with vectors up to `BDSQR_LIMIT`
    (dbdsqr's triplets), and from `CERTIFY_FROM` to `CERTIFY_ALL` sites (inverse iteration);
    other values keep the measured size law, `solving_bound`, with the worst-case forming
    term, which covers what the law alone misses on tiny extreme chains (10 size eps in all:
    below 3e-12 under CERTIFY_FROM; certifying all values of a longer segment would cost
    O(size^2) beyond dqds').
    """
    scalings = _segment_scalings(weighted, segments, factor, mass)
    if vectors and all(d.shape[0] <= BDSQR_LIMIT for _, _, d, _, _, _ in segments):
        return _certified_path(Kt, segments, scalings, n_modes=n_modes, band=band, on_stage=on_stage)
    omega, relative = _chain_values(segments, scalings)
    if on_stage is not None and vectors:
        on_stage(0.5, "frequencies done (dqds); computing the vectors")
    n = omega.shape[0]
    select = selected(omega, n_modes=n_modes, band=band)
    eigenvalues = omega[select] ** 2
    error = (relative[select] * (2.0 + relative[select]) + UNIT) * eigenvalues  # (+ squaring's rounding)
    if not vectors:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-bidiagonal")
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


def _certified_path(Kt: Any, segments: list[Segment], scalings: list[Scalings], *, n_modes: int | None,
                    band: tuple[float, float] | None, on_stage: Callable[[float, str], None] | None
                    ) -> SolveResult:
    """Every segment by dbdsqr (both sides' vectors), each value certified by `certify_modes`."""
    n = Kt.shape[0]
    values, bounds, blocks = [], [], []
    triplets = [bidiagonal_triplets(d, e) for _, _, d, e, _, _ in segments]
    if on_stage is not None:
        on_stage(0.5, "frequencies done with their vectors (dbdsqr); certifying each by its residual")
    for (c0, c1, d, e, keep, dofs_are_rows), forming, (sigma, left, right) in zip(segments, scalings, triplets):
        value, relative = certified_values(d, e, sigma, forming, (left, right))
        side = (left if dofs_are_rows else right)[: c1 - c0 + 1, -keep:]  # drop the padding
        full = np.zeros((n, keep))
        full[c0 : c1 + 1] = side / np.maximum(np.linalg.norm(side, axis=0), np.finfo(float).tiny)
        values.append(value[-keep:])
        bounds.append(relative[-keep:])
        blocks.append(full)
    omega = np.concatenate(values)
    order = np.argsort(omega, kind="stable")
    omega, relative = omega[order], np.concatenate(bounds)[order]
    select = selected(omega, n_modes=n_modes, band=band)
    eigenvalues = omega[select] ** 2
    error = (relative[select] * (2.0 + relative[select]) + UNIT) * eigenvalues  # (+ squaring's rounding)
    basis = np.hstack(blocks)[:, order][:, select]
    figures = absolute_figures(sp.csr_matrix(Kt), eigenvalues, basis, "accurate-bidiagonal", floor=4.0)
    return SolveResult(eigenvalues, basis, error, figures.residual, figures.orthogonality, "accurate-bidiagonal")
