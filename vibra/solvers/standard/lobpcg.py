"""LOBPCG for the iterative path (`vibra.solvers.standard.iterative`), on the CPU (numpy) or the GPU (CuPy).

The functions take the array module `xp` (numpy by default, CuPy for ``device="gpu"``): the n-row blocks
live in it, and every product with them runs there; the small matrices of the Rayleigh-Ritz steps (the
block's width, 3 b at most) are brought to the host and solved by LAPACK, where they are cheapest and
their rounding is the CPU path's. Inside the iteration no n-row block crosses: only b x b and 3 b x 3 b
matrices, b-vectors of norms and the indices of columns (the caller uploads the start block and the
constraints once, and brings the returned vectors back once).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["REORTHOGONALISE", "SVQB_CONDITION", "block_lobpcg", "host"]

#: `_outside`'s second Gram-Schmidt pass: for columns that kept under this fraction of their norm (1 / sqrt 2).
REORTHOGONALISE = 0.7071

#: `_orthonormal`'s second SVQB pass: past this Gram condition (one pass leaves ~eps x it: 2e-12 here).
SVQB_CONDITION = 1e4

Block = Any  # an (n, b) array of `xp` (numpy's or CuPy's)


def host(array: Any) -> NDArray[Any]:
    """A small array on the host: CuPy's by its ``get()``, numpy's as it is."""
    return np.asarray(array.get() if hasattr(array, "get") else array)


def block_lobpcg(A: Any, preconditioner: Callable[[Block], Block], constraints: Block, start: Block, wanted: int,
                 tolerance: float, max_iterations: int, *, xp: ModuleType = np) -> tuple[Block, int]:
    """The lowest Ritz vectors of the symmetric A, orthogonal to `constraints`, by LOBPCG (Knyazev 2001).

    The block (`start`'s columns) is wider than the `wanted` lowest columns; the iteration stops as
    soon as those have residuals ||A x - theta x|| <= `tolerance`, whatever the rest of the block
    (scipy's `lobpcg` waits for every column, and the block's last ones, at the edge of a cluster,
    converge slowest: on a 3e4-dof assembly 400 iterations against 33). Converged columns get no new
    search direction (soft locking) but stay in every Rayleigh-Ritz. The basis [X, W, P] is made
    orthonormal each step, W and P against X by Gram-Schmidt (`_outside`: a second pass where a column
    kept less than 1 / sqrt 2 of its norm) and then together by `_orthonormal` (dependent directions dropped), as in the
    robust variant of Duersch, Shao, Yang and Gu (SIAM J. Sci. Comput. 40, 2018); X's own block of the
    Rayleigh-Ritz matrix is its Ritz values. Returns the block's Ritz vectors, ascending, and the
    iterations taken (`max_iterations` at most: the caller judges the residuals). The iteration runs in
    double precision whatever `start`'s and the preconditioner's (a single-precision cycle's output is cast).
    A, the preconditioner, `constraints` and `start` are all of the array module `xp` (numpy or CuPy).
    """
    X = _orthonormal(_outside(start.astype(np.float64), constraints, xp), xp)  # (its own double copy)
    AX = xp.asarray(A @ X)
    values, rotation = np.linalg.eigh(_symmetric(host(X.T @ AX)))
    X, AX = X @ xp.asarray(rotation), AX @ xp.asarray(rotation)
    P = xp.zeros((X.shape[0], 0))
    iterations = 0
    for iterations in range(1, max_iterations + 1):
        R = AX - X * xp.asarray(values)
        norms = host(xp.sqrt(xp.einsum("ij,ij->j", R, R)))
        if wanted <= 0 or norms[:wanted].max() <= tolerance:  # (none wanted: every mode asked for was known)
            break
        active = xp.asarray(np.flatnonzero(norms > tolerance))
        W = _outside(xp.asarray(preconditioner(R[:, active]), dtype=np.float64), constraints, xp)  # (double: in place below)
        del R  # (n x b blocks alive at once kept few: at 10^6 dofs each is 0.45 GB)
        V = xp.concatenate([W, P[:, active]], axis=1) if P.shape[1] else W
        del W
        Q = _orthonormal(_outside(V, X, xp), xp)
        del V
        if Q.shape[1] == 0:
            break
        AQ = xp.asarray(A @ Q)
        XAQ = host(X.T @ AQ)
        S_A = np.block([[np.diag(values), XAQ], [XAQ.T, host(Q.T @ AQ)]])  # (X's own block: its Ritz values)
        values, rotation = np.linalg.eigh(_symmetric(S_A))
        width = X.shape[1]
        values = values[:width]
        top, bottom = xp.asarray(rotation[:width, :width]), xp.asarray(rotation[width:, :width])
        P = Q @ bottom
        del Q
        X = X @ top
        X += P
        AX = AX @ top
        AX += AQ @ bottom
        del AQ
    return X, iterations


def _symmetric(G: NDArray[np.float64]) -> NDArray[np.float64]:
    return 0.5 * (G + G.T)


def _outside(V: Block, basis: Block, xp: ModuleType = np) -> Block:
    """V's columns with their components along the orthonormal `basis` removed, in place (V is overwritten):
    one Gram-Schmidt pass, and a second for the columns that kept less than `REORTHOGONALISE` (1 / sqrt 2) of
    their norm in it (Daniel, Gragg, Kaufman and Stewart 1976: "twice is enough"; a column that kept more
    is orthogonal to rounding after one)."""
    if basis.shape[1] == 0 or V.shape[1] == 0:
        return V
    before = host(xp.einsum("ij,ij->j", V, V))
    V -= basis @ (basis.T @ V)
    lost = np.flatnonzero(host(xp.einsum("ij,ij->j", V, V)) < REORTHOGONALISE ** 2 * before)
    if lost.size:
        lost_columns = xp.asarray(lost)
        V[:, lost_columns] -= basis @ (basis.T @ V[:, lost_columns])
    return V


def _orthonormal(V: Block, xp: ModuleType = np) -> Block:
    """An orthonormal basis of V's columns by SVQB (Stathopoulos and Wu 2002): the Gram matrix's
    eigenvectors scaled by its eigenvalues' inverse square roots, directions under 1e-13 of the largest dropped;
    a second pass where the Gram matrix's condition passed `SVQB_CONDITION` (one pass leaves an error of
    ~eps times that condition). The Gram matrix's eigenproblem is solved on the host (LAPACK)."""
    for _ in range(2):
        if V.shape[1] == 0:
            return V
        scale = host(xp.sqrt(xp.einsum("ij,ij->j", V, V)))
        good = scale > 0  # (a zero or not-a-number column is dropped)
        V = V if good.all() else V[:, xp.asarray(np.flatnonzero(good))]
        V /= xp.asarray(scale[good])  # (in place: V is the caller's scratch, `_outside`'s result)
        gram_values, gram_vectors = np.linalg.eigh(_symmetric(host(V.T @ V)))
        keep = gram_values > 1e-13 * gram_values[-1]
        V = V @ xp.asarray(gram_vectors[:, keep] / np.sqrt(gram_values[keep]))
        if gram_values[keep][0] >= gram_values[-1] / SVQB_CONDITION:
            break
    return V
