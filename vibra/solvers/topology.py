"""The shape of a system's springs, classified once per request from the pattern of B alone.

K = B^T W B: each row of B is one spring (two entries: the sites it joins; one entry: a spring
to a wall, an anchor). What the accurate paths can exploit depends only on which dofs the
springs join, never on their values, so the plan decides it here, in O(nnz) numpy operations
(no compiled kernel: this runs on every call), and every path trusts it:

- ``"chain"``: the springs form chains of consecutive dofs (c, c + 1), one spring per pair,
  with at most one anchor at each end of a chain: K~ tridiagonal, a bidiagonal spring factor
  (`bidiagonal`, `lowest`);
- ``"walled-chain"``: one chain through all dofs, (i, i + 1) for i = 0..n-2, with springs to a
  wall inside it (a chain of pendulums): a bidiagonal Cholesky factor (`chain.walled`);
- ``"ring"`` / ``"walled-ring"``: the springs close one cycle through all n >= 3 dofs, without
  or with springs to a wall (`ring.values`, `ring.counts`);
- ``"network"``: anything else (3-D networks, molecules, ladders, parallel springs);
- ``"none"``: no spring factor (the standard paths only).

Diagonal masses are required for all but "network" (a full M keeps the springs' pattern but
not the bidiagonal forms).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

if TYPE_CHECKING:
    from vibra.solvers.common import MatrixLike

__all__ = ["Topology", "classify", "KINDS", "separator_width", "level_structure", "components"]

Topology = Literal["chain", "walled-chain", "ring", "walled-ring", "network", "none"]
KINDS: tuple[str, ...] = ("chain", "walled-chain", "ring", "walled-ring", "network", "none")


def classify(coupling: MatrixLike | None, *, diagonal_mass: bool = True) -> Topology:
    """The kind of spring pattern `coupling` (B, (n_terms, n_dof), any sparse or dense array) forms.

    Examples
    --------
    >>> import numpy as np
    >>> B = np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])          # 3 sites in a row
    >>> classify(B), classify(np.r_[B, [[1.0, 0.0, -1.0]]])        # closed into a ring
    ('chain', 'ring')
    >>> classify(np.r_[B, [[0.0, 1.0, 0.0]]])                       # a wall at the middle site
    'walled-chain'
    """
    if coupling is None:
        return "none"
    pattern = coupling if sp.isspmatrix_csr(coupling) else sp.csr_matrix(coupling)
    if np.count_nonzero(pattern.data) != pattern.data.shape[0] or not pattern.has_sorted_indices:
        pattern = sp.csr_matrix(pattern, copy=True)  # (the caller's B is left as it is)
        pattern.eliminate_zeros()
        pattern.sort_indices()
    n_terms, n = pattern.shape
    if not diagonal_mass or n_terms == 0:
        return "network"
    code = _pattern_kind(pattern.indptr, pattern.indices, n)
    if code == _RING_CANDIDATE:
        per_row = np.diff(pattern.indptr)
        pairs = np.flatnonzero(per_row == 2)
        first = pattern.indices[pattern.indptr[pairs]]
        second = pattern.indices[pattern.indptr[pairs] + 1]
        if not _one_cycle(first, second, n):
            return "network"
        return "walled-ring" if pairs.shape[0] < n_terms else "ring"
    return _CODES[code]


_NETWORK, _CHAIN, _WALLED_CHAIN, _RING_CANDIDATE = 0, 1, 2, 3
_CODES: dict[int, Topology] = {_NETWORK: "network", _CHAIN: "chain", _WALLED_CHAIN: "walled-chain"}


def _pattern_kind(indptr: NDArray[np.integer], indices: NDArray[np.integer], n: int) -> int:
    """One vectorised pass over B's pattern (rows with sorted column indices, no explicit zeros):
    chain (springs (c, c + 1), one per pair, walls only at the ends of each run, one each), walled
    chain (one run through all n dofs, walls anywhere), a ring candidate (n springs, every dof in
    two: the cycle is checked by the caller), or a network. numpy, O(nnz): a few array operations
    on every call, no compiled kernel to load (`vibra.solvers.common.COMPILED_FROM_S`)."""
    per_row = np.diff(indptr)
    if np.any((per_row != 1) & (per_row != 2)):
        return _NETWORK
    starts = indptr[:-1]
    paired = per_row == 2
    a, b = indices[starts[paired]], indices[starts[paired] + 1]
    if np.any(a == b):
        return _NETWORK
    pairs = a.shape[0]
    walls = np.bincount(indices[starts[~paired]], minlength=n)
    if np.all(b == a + 1):  # every spring joins consecutive dofs
        joined = np.bincount(a, minlength=n)  # springs (c, c + 1)
        if np.any(joined > 1):
            return _NETWORK
        start = np.r_[True, joined[:-1] == 0]  # c begins a run
        end = joined == 0                      # c ends one
        if np.all(walls <= start.astype(np.intp) + end):
            return _CHAIN
        # one run through all dofs (no pair repeated): walls inside it
        return _WALLED_CHAIN if pairs == n - 1 else _NETWORK
    if n >= 3 and pairs == n and np.all(np.bincount(np.r_[a, b], minlength=n) == 2):
        return _RING_CANDIDATE
    return _NETWORK


def _one_cycle(first: np.ndarray, second: np.ndarray, n: int) -> bool:
    """Whether n springs between distinct sites close one cycle through all n sites (every
    site in exactly two springs, and the walk from site 0 returns after n steps)."""
    ends = np.c_[first, second]
    if np.any(first == second) or np.any(np.bincount(ends.ravel(), minlength=n) != 2):
        return False
    graph = sp.csr_matrix((np.ones(2 * n), (np.r_[first, second], np.r_[second, first])), shape=(n, n))
    components, _ = sp.csgraph.connected_components(graph, directed=False)
    return bool(components == 1)


def components(pattern: sp.csr_matrix) -> tuple[int, NDArray[np.int32]]:
    """The connected components of a symmetric pattern's graph (every stored entry an edge, an explicit zero too):
    their count and each vertex's label. One compiled breadth-first search from vertex 0 first, on the pattern as it
    is (a symmetric pattern needs no transpose), and scipy's component search only where it does not reach every
    vertex: 0.4 against 1.6 ms on 3HSY's network, 4.7 against 14.7 ms on a 10^6-site chain."""
    n = pattern.shape[0]
    if n == 0:
        return 0, np.zeros(0, dtype=np.int32)
    graph = _graph(pattern)
    if sp.csgraph.breadth_first_order(graph, 0, directed=True, return_predecessors=False).shape[0] == n:
        return 1, np.zeros(n, dtype=np.int32)
    count, labels = sp.csgraph.connected_components(graph, directed=False)
    return int(count), labels


def separator_width(pattern: MatrixLike) -> int:
    """`level_structure`'s width: the cost of a nested-dissection factor of `pattern`, from sizes."""
    return level_structure(pattern)[0]


def level_structure(pattern: MatrixLike) -> tuple[int, int]:
    """(width, parts): the widest level of a breadth-first level structure of `pattern`'s graph (a square sparse
    matrix with a symmetric pattern, as K is: an edge per stored off-diagonal entry) rooted at a pseudo-peripheral vertex: a bound
    from sizes on the top separator a nested-dissection order finds, which is what a sparse
    Cholesky factor of that matrix costs (~width^3 work: n^2 for a 3-D solid, n^1.5 for a shell or
    a sheet, a cross-section's cube for a filament). Two sweeps from the largest component's
    first vertex (George and Liu's pseudo-peripheral search), O(nnz) each; the other components
    counted by size (width (n_c / n_max)^(2/3) each, so that the cube sums as their factors do),
    returned as the one width whose cube is the sum; and the number of connected components."""
    given = pattern if sp.isspmatrix_csr(pattern) else sp.csr_matrix(pattern)
    n = given.shape[0]
    if n == 0:
        return 0, 0
    graph = _graph(given)
    levels = _levels(graph, 0)
    if sum(level.shape[0] for level in levels) == n:  # connected (most networks): no component search
        sizes, largest = np.array([n]), 0
    else:
        count, labels = sp.csgraph.connected_components(graph, directed=False)
        sizes = np.bincount(labels, minlength=count)
        largest = int(np.argmax(sizes))
        levels = _levels(graph, int(np.flatnonzero(labels == largest)[0]))
    for _ in range(2):  # a far vertex of least degree (the first such by index), then its levels (at most two sweeps)
        last = np.sort(levels[-1])
        degree = np.diff(graph.indptr)[last]
        again = _levels(graph, int(last[np.argmin(degree)]))
        if len(again) <= len(levels):
            break
        levels = again
    width = max(level.shape[0] for level in levels)
    share = float(np.sum((sizes / sizes[largest]) ** 2))
    return int(round(width * share ** (1.0 / 3.0))), int(sizes.shape[0])


def _graph(pattern: sp.csr_matrix) -> sp.csr_matrix:
    """A CSR pattern's graph: every stored entry an edge (an explicit zero too), whatever scipy's graph routines make of
    zeros."""
    return sp.csr_matrix((np.ones(pattern.indices.shape[0]), pattern.indices, pattern.indptr), shape=pattern.shape)


def _levels(graph: sp.csr_matrix, root: int) -> list[NDArray[np.intp]]:
    """The breadth-first levels from `root` (its component only): scipy's compiled search, then the
    levels read off its order, in which the parents' positions never decrease: level L + 1 is the
    run of vertices whose parent lies in level L (one binary search per level)."""
    order, parent = sp.csgraph.breadth_first_order(graph, root, directed=True, return_predecessors=True)
    position = np.empty(graph.shape[0], dtype=np.intp)
    position[order] = np.arange(order.shape[0])
    parents = position[parent[order[1:]]]
    ends = [1]
    while ends[-1] < order.shape[0]:
        ends.append(1 + int(np.searchsorted(parents, ends[-1], side="left")))
    return [order[start:stop].astype(np.intp) for start, stop in zip([0] + ends[:-1], ends)]
