"""Stacked dense Hermitian eigensolves: one LAPACK heevd per matrix of a (n_q, n, n) stack.

The crystals' dynamical matrices D(q) are complex Hermitian, one per wave vector, and many
small ones are solved at once: numpy's stacked ``eigh`` / ``eigvalsh`` loop over the stack in
C (no Python loop per q). It runs the registry's ``hermitian-eigh`` path
(`vibra.solvers.registry`, `runners.hermitian`): the crystals describe their request as a
`problem.bloch_problem` (n branches, n_q wave vectors), plan it and guard it like any other
solve, then hand this function one chunk of D(q) at a time.

Each eigenvalue carries the standard backward-stable bound (n + DENSE_FLOOR) eps ||D||, with
||D||_inf >= ||D||_2 (as `lapack.dense_path`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.budget import BLOCH_CUBE_S, BLOCH_ENTRY_S, BLOCH_Q_S, BLOCH_SQUARE_S, BLOCH_VECTORS
from vibra.solvers.common import EPS
from vibra.solvers.standard.lapack import DENSE_FLOOR

__all__ = ["hermitian_stack", "stack_cost", "BLOCH_EXTRAS"]

#: What the crystals run with the stacked solve, named after it in the result's path ("high"'s
#: re-solve near Gamma through the spring factor, a polar crystal's correction; not costed here).
BLOCH_EXTRAS: tuple[str, ...] = ("spring-svd", "nac-gonze", "nac-wang")


def stack_cost(n: int, n_q: int, entries: int, vectors: bool) -> tuple[float, float]:
    """Bytes and seconds of D(q) at `n_q` wave vectors, n branches, assembled from `entries`
    force-constant entries each (the registry's ``hermitian-eigh`` estimate, from sizes): per q,
    the phases' GEMMs (BLOCH_ENTRY_S per entry) and one stacked heevd (BLOCH_CUBE_S n^3 +
    BLOCH_SQUARE_S n^2 + BLOCH_Q_S, BLOCH_VECTORS times that with vectors); the values and bounds
    held (16 n bytes per q), the vectors (16 n^2 per q), and the chunks (a few MiB)."""
    size, q = float(n), float(n_q)
    solve = BLOCH_CUBE_S * size ** 3 + BLOCH_SQUARE_S * size * size + BLOCH_Q_S
    seconds = q * (BLOCH_ENTRY_S * entries + solve * (BLOCH_VECTORS if vectors else 1.0))
    return q * 16.0 * size * (1.0 + (size if vectors else 0.0)) + 8.0 * 2 ** 20, seconds


def hermitian_stack(matrices: NDArray[np.complex128], *, vectors: bool
                    ) -> tuple[NDArray[np.float64], NDArray[np.complex128] | None, NDArray[np.float64]]:
    """Eigenvalues (ascending), eigenvectors (columns) and eigenvalue error bounds of a Hermitian stack.

    Parameters
    ----------
    matrices : (n_stack, n, n) ndarray of complex
        Hermitian matrices (the lower triangle is read).
    vectors : bool
        Also return the eigenvectors.

    Returns
    -------
    values : (n_stack, n) ndarray
        Eigenvalues, ascending per matrix.
    basis : (n_stack, n, n) ndarray of complex or None
        Orthonormal eigenvectors as columns.
    error : (n_stack, n) ndarray
        |lambda - lambda~| <= error: (n + DENSE_FLOOR) eps ||D||_inf per matrix.
    """
    n = matrices.shape[-1]
    norm = np.abs(matrices).sum(axis=-1).max(axis=-1)
    if vectors:
        values, basis = np.linalg.eigh(matrices)
    else:
        values, basis = np.linalg.eigvalsh(matrices), None
    error = np.broadcast_to(((n + DENSE_FLOOR) * EPS * norm)[:, None], values.shape).copy()
    return values, basis, error
