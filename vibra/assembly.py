"""Sparse assembly of the factor B of K = B^T diag(w) B, and of user Hessian blocks (pure).

Each row of B is the gradient of one internal coordinate with respect to the displacements
(n_sites * dim columns, site-major): a spring's row holds -e and +e on its two sites (e the
unit vector along it), an anchor's row the anchor direction on its site. `vibra.system`
stacks these into the `System`'s coupling; nothing here reads files or keeps state.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra import _validate


def pair_rows(pairs: NDArray[np.intp], unit: NDArray[np.float64], n_sites: int, dim: int) -> sp.coo_matrix:
    """(n_pairs, n_sites * dim) rows of B for springs `pairs` along the unit vectors `unit`."""
    n = len(pairs)
    axis = np.arange(dim)
    rows = np.repeat(np.arange(n), 2 * dim)
    cols = np.concatenate([pairs[:, :1] * dim + axis, pairs[:, 1:] * dim + axis], axis=1).ravel()
    data = np.concatenate([-unit, unit], axis=1).ravel()
    return sp.coo_matrix((data, (rows, cols)), shape=(n, n_sites * dim))


def single_rows(sites: NDArray[np.intp], direction: NDArray[np.float64], n_sites: int, dim: int) -> sp.coo_matrix:
    """(n_sites_anchored, n_sites * dim) rows of B for anchors on `sites` along `direction`."""
    n = len(sites)
    rows = np.repeat(np.arange(n), dim)
    cols = (sites[:, None] * dim + np.arange(dim)).ravel()
    return sp.coo_matrix((direction.ravel(), (rows, cols)), shape=(n, n_sites * dim))


def stack_terms(rows: list[sp.coo_matrix], weights: list[NDArray[np.float64]], n_full: int
                ) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    """B (CSR, explicit zeros dropped) and w from lists of row blocks and their weights."""
    if not rows:
        return sp.csr_matrix((0, n_full)), np.zeros(0)
    b = sp.vstack(rows, format="csr")
    b.eliminate_zeros()  # axis-aligned springs have zero components
    return b, np.concatenate(weights)


def hessian_blocks(blocks: Sequence[tuple[ArrayLike, ArrayLike]], n_sites: int, dim: int) -> sp.csr_matrix:
    """Sum user Hessian blocks into one sparse (n_sites * dim)^2 matrix."""
    rows: list[NDArray[np.intp]] = []
    cols: list[NDArray[np.intp]] = []
    data: list[NDArray[np.float64]] = []
    for b, block in enumerate(blocks):
        try:
            sites, matrix = block
        except (TypeError, ValueError):
            raise TypeError(f"blocks[{b}] must be a pair (sites, H)") from None
        index = _validate.indices(sites, f"blocks[{b}] sites", n_sites, shape=(-1,))
        dofs = (index[:, None] * dim + np.arange(dim)).ravel()
        H = _validate.real_array(matrix, f"blocks[{b}] H", ndim=2)
        if H.shape != (dofs.size, dofs.size):
            raise ValueError(f"blocks[{b}] H must be ({dofs.size}, {dofs.size}) for {index.size} sites in {dim}-D, "
                             f"got {H.shape}")
        _validate.symmetric(H, f"blocks[{b}] H")
        rows.append(np.repeat(dofs, dofs.size))
        cols.append(np.tile(dofs, dofs.size))
        data.append(H.ravel())
    size = n_sites * dim
    if not data:
        return sp.csr_matrix((size, size))
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))
