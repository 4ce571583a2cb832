"""Stacked dense Hermitian eigensolves: one LAPACK heevd per matrix of a (n_q, n, n) stack.

The crystals' dynamical matrices D(q) are complex Hermitian, one per wave vector, and many
small ones are solved at once: numpy's stacked ``eigh`` / ``eigvalsh`` loop over the stack in
C (no Python loop per q). This is not a registry path (`vibra.solvers.registry`): a `Problem`
describes one real symmetric K~ with its masses, springs and sparsity, and a batch of complex
Hermitian matrices fits none of its fields without changing the other paths; the crystals call
this function directly.

Each eigenvalue carries the standard backward-stable bound (n + DENSE_FLOOR) eps ||D||, with
||D||_inf >= ||D||_2 (as `lapack.dense_path`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.common import EPS
from vibra.solvers.standard.lapack import DENSE_FLOOR

__all__ = ["hermitian_stack"]


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
