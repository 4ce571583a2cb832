"""The shape of a system's springs, classified once per request from the pattern of B alone.

K = B^T W B: each row of B is one spring (two entries: the sites it joins; one entry: a spring
to a wall, an anchor). What the accurate paths can exploit depends only on which dofs the
springs join, never on their values, so the plan decides it here, in O(nnz) with no
allocation beyond B's pattern, and every path trusts it:

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

from typing import Any, Literal

import numpy as np
import scipy.sparse as sp

from vibra.solvers.accurate.ring.kernel import _jit

__all__ = ["Topology", "classify", "KINDS"]

Topology = Literal["chain", "walled-chain", "ring", "walled-ring", "network", "none"]
KINDS: tuple[str, ...] = ("chain", "walled-chain", "ring", "walled-ring", "network", "none")


def classify(coupling: Any, *, diagonal_mass: bool = True) -> Topology:
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


@_jit()
def _pattern_kind(indptr: Any, indices: Any, n: int) -> int:  # pragma: no cover - compiled
    """One pass over B's pattern (rows with sorted column indices): chain (springs (c, c + 1),
    one per pair, walls only at the ends of each run, one each), walled chain (one run through
    all n dofs, walls anywhere), a ring candidate (n springs, every dof in two: the cycle is
    checked by the caller), or a network."""
    joined = np.zeros(n, dtype=np.int32)   # springs (c, c + 1)
    degree = np.zeros(n, dtype=np.int32)   # springs at each dof
    walls = np.zeros(n, dtype=np.int32)
    consecutive = True
    pairs = 0
    for row in range(indptr.shape[0] - 1):
        count = indptr[row + 1] - indptr[row]
        if count == 1:
            walls[indices[indptr[row]]] += 1
        elif count == 2:
            a, b = indices[indptr[row]], indices[indptr[row] + 1]
            if a == b:
                return 0
            degree[a] += 1
            degree[b] += 1
            pairs += 1
            if b == a + 1:
                joined[a] += 1
            else:
                consecutive = False
        else:
            return 0
    if consecutive:
        unbranched = True
        for c in range(n):
            if joined[c] > 1:
                unbranched = False
                break
        if unbranched:
            chain = True
            for c in range(n):
                start = c == 0 or joined[c - 1] == 0
                end = joined[c] == 0
                allowed = (1 if start else 0) + (1 if end else 0)
                if walls[c] > allowed:
                    chain = False
                    break
            if chain:
                return 1
            if pairs == n - 1:  # one run through all dofs (no pair repeated): walls inside it
                return 2
        return 0
    if n >= 3 and pairs == n:
        for c in range(n):
            if degree[c] != 2:
                return 0
        return 3
    return 0


def _one_cycle(first: np.ndarray, second: np.ndarray, n: int) -> bool:
    """Whether n springs between distinct sites close one cycle through all n sites (every
    site in exactly two springs, and the walk from site 0 returns after n steps)."""
    ends = np.c_[first, second]
    if np.any(first == second) or np.any(np.bincount(ends.ravel(), minlength=n) != 2):
        return False
    graph = sp.csr_matrix((np.ones(2 * n), (np.r_[first, second], np.r_[second, first])), shape=(n, n))
    components, _ = sp.csgraph.connected_components(graph, directed=False)
    return bool(components == 1)
