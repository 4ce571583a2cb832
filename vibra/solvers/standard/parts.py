"""A K~ of several parts solved part by part (`by_parts`), for the shift-invert paths (`sparse.lowest_pairs`).

A K~ whose graph has several connected components (`topology.components`) is the direct sum of their matrices, so its lowest pairs
are the lowest of theirs; a Krylov iteration on the whole sees the copies of a value repeated across parts only
through rounding. Eleven isolated sites are a 33-fold zero beside a protein's six rigid motions; 5 isolated sites
beside a 300-site network, plus I, a 21-fold value 1 of which ARPACK returned 10 copies (RESULTS.md "Decoupled dofs set
apart"); 40 stiff clusters joined by springs six decades softer into 7 parts, 42 zero modes among 87 under
1e-8 ||K~||: ARPACK's restarted Lanczos took 49,179 solves and 7.5 s for the lowest 20 (RESULTS.md "A network of parts,
part by part"). Parts of at most `SMALL_PART` dofs, or of no more than the modes asked, are LAPACK's, stacked by size
(`_dense_parts`; a decoupled dof is a part of one); larger ones are the caller's shift-invert's (`_large_parts`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

__all__ = ["by_parts", "SMALL_PART", "Solver"]

#: Parts of at most this many dofs are solved by LAPACK's eigh: 2.7 ms at 300 dofs, under one shift-invert run's start
#: (a factorisation, a probe) on a part of that size.
SMALL_PART = 300

#: Entries of one stack of small parts' dense matrices (`_dense_parts`): 16 MB.
STACK_ENTRIES = 2_000_000

Found = tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]
Solver = Callable[[int], tuple[NDArray[np.float64], NDArray[np.float64]]]


def by_parts(Kt: sp.csr_matrix, k: int, count: int, label: NDArray[np.int32],
             connected: Callable[[sp.csr_matrix], Solver], *, probe: int
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k lowest pairs of K~, ascending, from those of its `count` parts (`label`: each dof's part). `connected`
    makes a shift-invert solver of one large part (its k lowest given a count, on one factor); `probe`: the fewest
    modes one is asked (a zero-mode probe's)."""
    n = Kt.shape[0]
    sizes = np.bincount(label, minlength=count)
    members = np.argsort(label, kind="stable")  # each part's dofs, ascending, one part after another
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    position = np.empty(n, dtype=np.intp)  # each dof's place in its part
    position[members] = np.arange(n) - starts[label[members]]
    dense = (sizes <= SMALL_PART) | (np.minimum(k, sizes) >= sizes - 1)
    found: list[Found] = []
    for size in np.unique(sizes[dense]):
        labels = np.flatnonzero(dense & (sizes == size))
        for chunk in np.array_split(labels, -(-labels.size * int(size) ** 2 // STACK_ENTRIES)):
            found.append(_dense_parts(Kt, members[starts[chunk][:, None] + np.arange(size)], position,
                                      min(k, int(size))))
    large = [members[starts[p]:starts[p] + sizes[p]] for p in np.flatnonzero(~dense)]
    found += _large_parts(Kt, large, k, found, connected, probe)
    values = np.concatenate([v.ravel() for v, _, _ in found])
    order = np.argsort(values, kind="stable")[:k]
    basis = np.zeros((n, order.size))
    offsets = np.cumsum([0] + [v.size for v, _, _ in found])
    for column, index in enumerate(order):
        batch = int(np.searchsorted(offsets, index, side="right")) - 1
        batch_values, dofs, vectors = found[batch]
        part, which = divmod(int(index - offsets[batch]), batch_values.shape[1])
        basis[dofs[part], column] = vectors[part, :, which]
    return values[order], basis


def _dense_parts(Kt: sp.csr_matrix, dofs: NDArray[np.intp], position: NDArray[np.intp], wanted: int) -> Found:
    """The `wanted` lowest pairs of m parts of s dofs each (`dofs`, (m, s)): their matrices scattered into one (m, s, s)
    stack and solved by LAPACK in one call (numpy's stacked eigh): values (m, wanted), the dofs, vectors (m, s, wanted).
    (10^4 parts of 10 dofs: one call, where a loop over the parts took ~1 s.)"""
    m, size = dofs.shape
    rows = sp.coo_matrix(Kt[dofs.ravel()])
    stack = np.zeros((m, size, size))
    np.add.at(stack, (rows.row // size, rows.row % size, position[rows.col]), rows.data)
    values, vectors = np.linalg.eigh(stack)
    return values[:, :wanted], dofs, vectors[:, :, :wanted]


def _large_parts(Kt: sp.csr_matrix, large: list[NDArray[np.intp]], k: int, small: list[Found],
                 connected: Callable[[sp.csr_matrix], Solver], probe: int) -> list[Found]:
    """The lowest pairs of the parts over `SMALL_PART` dofs (`large`, each part's dofs): each first asked its share of
    the k (twice k over the parts, at least `probe`), then, where its highest value is not above the k-th lowest of
    everything found, all min(k, size) of its own (on its factor): every value below that k-th is then found. (Ten far
    copies of a 300-site network, 60 modes: 12 asked of each, not 60.)"""
    if not large:
        return []
    share = max(probe, -(-2 * k // len(large)))
    solved = []
    for dofs in large:
        solve = connected(sp.csr_matrix(Kt[dofs][:, dofs]))
        wanted = min(k, dofs.size)
        values, vectors = solve(min(wanted, share))
        solved.append([values, vectors, dofs, solve, wanted])
    every = np.concatenate([v.ravel() for v, _, _ in small] + [entry[0] for entry in solved])
    kth = np.partition(every, k - 1)[k - 1] if every.size >= k else np.inf
    for entry in solved:
        values, _, dofs, solve, wanted = entry
        if values.size < wanted and values[-1] <= kth:  # (values of its own may lie below the k-th: all it may hold)
            entry[0], entry[1] = solve(wanted)
    return [(values[None, :], dofs[None, :], vectors[None, :, :]) for values, vectors, dofs, *_ in solved]
