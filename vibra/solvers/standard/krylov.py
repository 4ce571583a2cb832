"""Block Krylov iteration for the largest eigenvalues of a symmetric operator F = (K~ - sigma I)^-1.

ARPACK applies F to one vector at a time and restarts; where F is an expensive factor's solve,
a basis kept whole (no restarts) needs fewer of them, and a block of columns shows a multiple
eigenvalue's copies (the width is the caller's: where a block's solve costs about as many
single ones, the narrowest safe block is the cheapest, `sparse.BLOCK_LOWEST`). So the
shift-invert path runs a block Arnoldi iteration with full reorthogonalisation (classical
Gram-Schmidt twice), which is Lanczos in exact arithmetic and stays orthogonal to working
precision in floating point, and stops on the Ritz residuals that its own relation gives:

    F V_m = V_m H_m + Q R E_m^T,    ||F y - mu y|| = ||R s_last||  for a Ritz pair (mu, V_m s).

Directions `deflate` (a free network's zero modes, found by a first small run) are projected
out before and after every application of F, so that their huge 1 / |sigma| does not swamp
the rest. No restarts: the basis grows to at most `max_dim` columns (the caller sizes it).

A block of b columns holds at most b copies of a multiple eigenvalue in exact arithmetic;
rounding seeds the others, but where F barely favours them they may not have grown when
the wanted pairs converge (one column: a fifth copy lost in 42 of 80 synthetic spectra
with values up to 8-fold; two: 6 of 80). A run that converges with a cluster of equal Ritz
values as wide as its block is therefore done again with a wider block (`widen`: afresh,
since the converged pairs would pass the stopping test before a missing copy had grown),
until every cluster it finds is narrower than its block: a narrow first block (fewer
applications of F: 88 at b = 2 against 124 at b = 4 on a protein's network) stays safe.

An operator of few distinct values (a star of identical arms) closes its Krylov space after a few
steps: the new block's remainder is then rounding, and is replaced by fresh random directions
(`_remainders`, `LOST`); where more Ritz values tie with the k-th than fit, the converged ones are
taken (`_wanted`). What the block iteration may still miss, `sparse.shift_invert` counts.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["block_eigs", "BLOCK"]

#: Columns per block where the caller names none (the sparse path names its own).
BLOCK = 8

#: The stopping test (the Ritz step: an eigh of the m x m projection, ~9 m^3) runs again once the basis has grown by
#: 1 / SPACING since it last failed, at most, not after every block: tested after every block of 2 it cost more than
#: the solves (0.58 of 1.43 s for 114 modes of a 3,000-dof network, a basis of 356 columns); spaced, the tests' cost
#: is ~2 M^3 for a final basis of M columns (a geometric series of ratio 1.25^-3). Where the residuals fall, the
#: next test comes sooner, where a straight line through the last two tests (in log) says they pass (`_next_test`),
#: so that the columns applied past convergence stay few.
SPACING = 4

#: The fraction of the extrapolated columns to the pass after which the next test runs: the fall speeds up as it
#: goes (a protein's network: 2x per block of 2, then 4x), so a test placed at the whole estimate lands past it.
PREDICT = 0.75

#: A fall of the worst ratio by more than this (natural log: 10x) since the last test, whose extrapolation still
#: reaches past m / SPACING, halves the wait (`_next_test`).
FALLEN = float(np.log(10.0))


#: Ritz values within this relative distance of one another count as one multiple value
#: (`widen`): two values split by more are resolved by the stopping test itself (a Ritz vector
#: mixing their eigenvectors keeps a residual ~ the split, far above the tolerances asked).
CLUSTER = 1e-8


def _project(x: NDArray[np.float64], deflate: NDArray[np.float64] | None) -> NDArray[np.float64]:
    if deflate is None or deflate.shape[1] == 0:
        return x
    return x - deflate @ (deflate.T @ x)


def _orthonormal_against(W: NDArray[np.float64], basis: NDArray[np.float64], deflate: NDArray[np.float64] | None
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """W = basis C + Q R with Q orthonormal and orthogonal to basis (CGS2); returns (C, Q, R).

    The remainder is projected off `deflate` once more: subtracting basis C (|C| ~ |W|) leaves
    eps |W| along the deflated directions, large next to a small remainder, and F would
    multiply it by 1 / |sigma| at the next step.
    """
    size = np.linalg.norm(W, axis=0)
    C = basis.T @ W
    W = W - basis @ C
    C2 = basis.T @ W
    W = _project(W - basis @ C2, deflate)
    Q, R = np.linalg.qr(W)
    if np.any(np.abs(np.diagonal(R)) <= CANCEL * size):  # (rare: a Krylov space (nearly) invariant, a symmetric K~)
        Q, R = _remainders(W, size, basis, deflate)
    return C + C2, Q, R


#: A remainder under this fraction of its column's norm before the basis was taken off is orthogonalised once
#: more (the rounding of the first two passes, ~eps of the column, is no longer small beside it: "twice is enough"
#: holds where the remainder is not itself at rounding level).
CANCEL = 1e-8

#: A remainder under this fraction after that is rounding alone: the Krylov space is invariant there (a star of
#: identical arms, whose operator holds few directions), and a fresh random direction continues it; normalising
#: the rounding instead made columns that were not orthogonal to the basis (2e-3, then 0.4, then 0.99).
LOST = 1e-12


def _remainders(W: NDArray[np.float64], size: NDArray[np.float64], basis: NDArray[np.float64],
                deflate: NDArray[np.float64] | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """W = Q R column by column (`_orthonormal_against` where a remainder cancelled): a third pass where one fell under
    `CANCEL` times `size`, a fresh direction (R's diagonal 0 there) where under `LOST`."""
    n, b = W.shape
    rng = np.random.default_rng(basis.shape[1])
    Q, R = np.empty_like(W), np.zeros((b, b))
    for j in range(b):
        w = W[:, j].copy()
        for _ in range(2):
            c = Q[:, :j].T @ w
            w -= Q[:, :j] @ c
            R[:j, j] += c
        r = float(np.linalg.norm(w))
        if r <= CANCEL * size[j]:
            w = _project(w - basis @ (basis.T @ w), deflate)
            c = Q[:, :j].T @ w
            w -= Q[:, :j] @ c
            R[:j, j] += c
            r = float(np.linalg.norm(w))
        if r <= LOST * size[j]:
            w = rng.standard_normal(n)
            for _ in range(2):
                w = _project(w - basis @ (basis.T @ w), deflate)
                w -= Q[:, :j] @ (Q[:, :j].T @ w)
            Q[:, j], R[j, j] = w / np.linalg.norm(w), 0.0
        else:
            Q[:, j], R[j, j] = w / r, r
    return Q, R


def block_eigs(apply: Callable[[NDArray[np.float64]], NDArray[np.float64]], n: int, k: int, *,
               tol: float = 1e-12, max_dim: int | None = None, block: int = BLOCK,
               deflate: NDArray[np.float64] | None = None, seed: int = 0,
               enough: Callable[[NDArray[np.float64], NDArray[np.float64]], bool] | None = None,
               start: NDArray[np.float64] | None = None, widen: bool = False,
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], int, bool]:
    """The k largest eigenpairs of the symmetric operator `apply` (n x n), by block Arnoldi.

    Parameters
    ----------
    apply : callable
        F X for a block X (n, b).
    k : int
        How many of the largest eigenvalues (those of F are 1 / (lambda - sigma) on the sparse
        path: the lowest lambda).
    tol : float
        Stop when every wanted Ritz pair has ||F y - mu y|| <= tol |mu| (relative residual).
    max_dim : int, optional
        Largest basis (default max(10 k, 200) columns; at most n less the deflated directions).
    deflate : (n, z) orthonormal, optional
        Directions kept out of the iteration (projected out before and after F).
    enough : callable, optional
        enough(mu, residual) -> bool on the current Ritz values (descending) and their residuals:
        another stopping test (the probe for zero modes uses it).
    start : (n, j) array, optional
        Starting directions (e.g. Ritz vectors of an earlier run); random columns fill the
        first block up to its width.
    widen : bool
        On convergence with a cluster of equal Ritz values (`CLUSTER`) as wide as the block,
        run again with a block one wider than the cluster (see above).

    Returns
    -------
    (mu, Y, applied, converged)
        mu (k,) descending, Y (n, k) orthonormal Ritz vectors, applied: columns F was applied
        to; converged: False when the basis reached `max_dim` first.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.diag(np.arange(1.0, 201.0))
    >>> mu, Y, _, _ = block_eigs(lambda X: A @ X, 200, 3)
    >>> np.round(mu, 10)
    array([200., 199., 198.])
    """
    limit = min(n - (0 if deflate is None else deflate.shape[1]), max_dim or max(10 * k, 200))
    b = max(1, min(block, limit // 2))
    rng = np.random.default_rng(seed)
    first = rng.standard_normal((n, b))
    if start is not None:
        given = np.asarray(start, dtype=float).reshape(n, -1)[:, :b]
        first[:, : given.shape[1]] = given
    X, _ = np.linalg.qr(_project(first, deflate))
    # the basis grows inside one array (its first m columns in use), not by hstack's copies
    space = np.empty((n, limit + b), order="F")  # (columns contiguous: the projections against it 1.3-1.7x faster)
    space[:, : X.shape[1]] = X
    m = X.shape[1]
    H = np.zeros((b, b))  # the block Hessenberg matrix of the Arnoldi relation, grown as it goes
    applied, due = 0, 0
    history: list[tuple[int, float]] = []  # (columns, log of the worst residual's ratio to its tolerance) per test
    while True:
        W = _project(apply(X), deflate)
        applied += X.shape[1]
        basis = space[:, :m]
        C, Q, R = _orthonormal_against(W, basis, deflate)
        H[:, m - X.shape[1]:] = C
        room = limit - m
        if room > 0 and (m < due or (m < k and enough is None)):  # too few columns to hold k Ritz pairs yet, or
            done = False                                           # too few new ones since the last test (`SPACING`)
        else:
            mu, S = np.linalg.eigh(0.5 * (H + H.T))
            wanted = _wanted(mu, S[m - X.shape[1]:], R, min(k, m))
            residual = np.linalg.norm(R @ S[m - X.shape[1]:, wanted], axis=0)
            done = m >= k and bool(np.all(residual <= tol * np.abs(mu[wanted])))
            if enough is not None:
                done = enough(mu[wanted], residual)
            cluster = largest_cluster(mu[wanted]) if done and widen else 0
            if cluster >= b and b < limit // 2:
                wider = min(cluster + 1, limit // 2)
                mu, Y, more, done = block_eigs(apply, n, k, tol=tol, max_dim=max_dim, block=wider, deflate=deflate,
                                               seed=seed + 1, enough=enough, widen=True)
                return mu, Y, applied + more, done
            if done or room <= 0:
                return mu[wanted], basis @ S[:, wanted], applied, done
            with np.errstate(divide="ignore", invalid="ignore"):
                ratios = residual / (tol * np.abs(mu[wanted]))
            due = m + _next_test(history, m, ratios, X.shape[1])
        width = X.shape[1]
        X = Q[:, : min(b, room)]
        grown = np.zeros((m + X.shape[1], m + X.shape[1]))
        grown[:m, :m] = H
        grown[m:, m - width : m] = R[: X.shape[1]]
        H = grown
        space[:, m : m + X.shape[1]] = X
        m += X.shape[1]


def _next_test(history: list[tuple[int, float]], m: int, ratios: NDArray[np.float64], width: int) -> int:
    """Columns to add before the next stopping test, after a test at m columns whose wanted residuals were
    `ratios` times their tolerance: m / `SPACING`, or fewer where the worst ratio fell since the last test,
    `PREDICT` times the columns a straight line through the two tests (in log) gives to reach 1, or m / (2
    `SPACING`) where it fell more than `FALLEN` and the line still reaches past m / `SPACING`; a block (`width`)
    at least. A worst ratio that is not finite (a tolerance of 0, a Ritz value of 0) restarts `history`."""
    worst = float(ratios.max()) if ratios.size else np.inf
    step = m // SPACING
    if not np.isfinite(worst) or worst <= 0:
        history.clear()
        return max(width, step)
    history.append((m, float(np.log(worst))))
    if len(history) >= 2:
        (m1, e1), (m2, e2) = history[-2:]
        fall = (e1 - e2) / (m2 - m1)
        if fall > 0 and e2 > 0:
            predicted = int(PREDICT * e2 / fall)
            # a fall begun since the last test, from its plateau: the line through the two is flatter than the fall
            # (3o21, 300 modes: tests at 582 and 728 columns predicted 405 more where 80 passed), so wait half as long
            step = predicted if predicted < step else (m // (2 * SPACING) if e1 - e2 > FALLEN else step)
    return max(width, step)


def _wanted(mu: NDArray[np.float64], last: NDArray[np.float64], R: NDArray[np.float64], k: int) -> NDArray[np.intp]:
    """The k largest Ritz values' indices, descending; where more Ritz values than fit tie with the k-th (within
    `CLUSTER`: a value more multiple than the k asked), the tied ones with the smallest residuals (`last`: the rows
    of the Ritz vectors in the last block). Among equal values the choice is free, and the converged copies are the
    answer: taken by position, fresh unconverged copies kept a 999-fold value from ever passing the test."""
    order = np.argsort(mu)[::-1]
    edge = mu[order[k - 1]]
    tied = np.abs(mu[order] - edge) <= CLUSTER * abs(edge)
    if k == order.shape[0] or not tied[k]:
        return order[:k]
    group = order[tied]
    residual = np.linalg.norm(R @ last[:, group], axis=0)
    chosen = group[np.argsort(residual, kind="stable")[: int(np.count_nonzero(tied[:k]))]]
    keep = np.r_[order[:k][~tied[:k]], chosen]
    return keep[np.argsort(mu[keep], kind="stable")[::-1]]


def largest_cluster(mu: NDArray[np.float64]) -> int:
    """The most values of `mu` that form one chain of neighbours within `CLUSTER` (relative).

    >>> largest_cluster(np.array([3.0, 2.0, 2.0 * (1 + 1e-12), 2.0, 1.0]))
    3
    """
    if mu.shape[0] == 0:
        return 0
    values = np.sort(np.abs(mu))
    apart = np.diff(values) > CLUSTER * values[1:]
    return int(np.diff(np.flatnonzero(np.r_[True, apart, True])).max())
