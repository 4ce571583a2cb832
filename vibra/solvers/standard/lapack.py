"""Standard (absolute-accuracy) paths: dense, tridiagonal and banded LAPACK eigensolvers.

Each gives eigenvalues of K~ to an absolute error of about n eps ||K~|| (backward stable).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.common import Matrix, SolveResult, absolute_figures, norm_upper, squared_range, tridiagonal_bands

#: Added to n in the dense path's eigenvalue bound (n + DENSE_FLOOR) eps ||K~||: forming K~
#: (k_i + k_j, then two scalings by 1/sqrt(m)) costs ~4 eps relative per entry, and syevr's own
#: error is a small multiple of eps ||K~|| even for n = 2..8 (measured up to 18 eps ||K~||_inf
#: in all, chains with mass and spring spreads of 1e24, against 60-digit mpmath).
DENSE_FLOOR = 32


def dense_path(Kt: Matrix, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
               overwrite: bool = False) -> SolveResult:
    """Dense LAPACK eigh (syevr) on K~, a subset by index or value when asked.

    `overwrite` lets LAPACK reduce a K~ that the caller owns in place when only values are
    asked (saves one n x n copy; the figures then need only the diagonal, saved beforehand).
    """
    dense = Kt.toarray() if sp.issparse(Kt) else np.asarray(Kt)
    n = dense.shape[0]
    overwrite = overwrite or sp.issparse(Kt)  # toarray() made a private copy
    kwargs: dict[str, Any] = {"eigvals_only": not vectors, "check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs["subset_by_index"] = (0, n_modes - 1)
    elif band is not None:
        kwargs["subset_by_value"] = squared_range(band)
    reference: Any = dense
    upper = norm_upper(dense)  # before LAPACK may overwrite it
    if overwrite and not vectors:
        # values only: the figures need just K~'s diagonal, so LAPACK may reduce K~ in place
        reference = sp.diags(np.diag(dense).copy())
        kwargs["overwrite_a"] = True
    try:
        if vectors:
            values, basis = la.eigh(dense, **kwargs)
        else:
            values, basis = la.eigh(dense, **kwargs), None
    except la.LinAlgError:
        # syevr (MRRR) can stop with "Internal Error" on a strongly graded K~ (masses and springs
        # over 1e24, a subset asked); divide and conquer (syevd) on all of it does not
        if kwargs.get("overwrite_a"):
            raise
        values, basis = _all_then_selected(dense, vectors, n_modes, band)
    return absolute_figures(reference, np.asarray(values), basis, "dense", floor=float(n + DENSE_FLOOR),
                            norm=upper)


def _all_then_selected(dense: NDArray[np.float64], vectors: bool, n_modes: int | None,
                       band: tuple[float, float] | None) -> tuple[Any, Any]:
    """Every eigenpair by LAPACK syevd, then the ones asked (lowest n_modes, or those in band)."""
    values, basis = la.eigh(dense, driver="evd", check_finite=False)
    if n_modes is not None and n_modes < values.shape[0]:
        keep = np.arange(n_modes)
    elif band is not None:
        low, high = squared_range(band)
        keep = np.flatnonzero((values >= low) & (values <= high))
    else:
        keep = np.arange(values.shape[0])
    return values[keep], (basis[:, keep] if vectors else None)


def tridiagonal_path(Kt: Matrix, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None
                     ) -> SolveResult:
    """LAPACK stemr / stebz on the diagonals of a tridiagonal K~."""
    d, e = tridiagonal_bands(Kt)
    n = d.shape[0]
    kwargs: dict[str, Any] = {"check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs.update(select="i", select_range=(0, n_modes - 1))
    elif band is not None:
        kwargs.update(select="v", select_range=squared_range(band))
    if vectors:
        values, basis = la.eigh_tridiagonal(d, e, **kwargs)
    else:
        values, basis = la.eigvalsh_tridiagonal(d, e, **kwargs), None
    # MRRR / bisection: absolute eigenvalue error O(n eps ||T||).
    return absolute_figures(sp.csr_matrix(Kt), np.asarray(values), basis, "tridiagonal", floor=float(n))


def banded_path(Kt: Matrix, width: int, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
                ordering: NDArray[np.intp] | None = None) -> SolveResult:
    """LAPACK sbevd / sbevx on the lower band storage of K~ (half-bandwidth `width`).

    With `ordering` (a ring's bandwidth-reducing permutation, `common.ring_ordering`), the
    solve runs on K~[ordering][:, ordering] and the vectors are put back in dof order.
    """
    if ordering is not None:
        matrix = sp.csr_matrix(Kt)
        result = banded_path(matrix[ordering][:, ordering], width, n_modes=n_modes, vectors=vectors, band=band)
        if result.vectors is not None:
            in_dof_order = np.empty_like(result.vectors)
            in_dof_order[ordering] = result.vectors
            result.vectors = in_dof_order
        return result
    matrix = sp.csr_matrix(Kt)
    n = matrix.shape[0]
    storage = np.zeros((width + 1, n))  # lower band storage: storage[i, j] = K~[j + i, j]
    for offset in range(width + 1):
        storage[offset, : n - offset] = matrix.diagonal(-offset)
    kwargs: dict[str, Any] = {"lower": True, "check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs.update(select="i", select_range=(0, n_modes - 1))
    elif band is not None:
        kwargs.update(select="v", select_range=squared_range(band))
    basis: NDArray[np.float64] | None = None
    if vectors:
        values, basis = la.eig_banded(storage, **kwargs)
    else:
        values = la.eigvals_banded(storage, **kwargs)
    return absolute_figures(matrix, np.asarray(values), basis, "banded", floor=float(n))

