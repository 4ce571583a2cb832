"""`topology.separator_width`: the widest breadth-first level of K's graph, what the sparse
path's cost model reads for a nested-dissection factor (issue 45 item 4, issue 47).

Truth: counts made apart from the code under test. On a grid the levels from a corner are the
diagonal hyperplanes, so the widest level is the largest number of lattice points with
x + y (+ z) = s, counted here by brute force over the grid; a path has levels of one vertex, a
cycle of two; disconnected copies add as their factors do (cubes add). The cost model's point,
that a shell costs far less than a solid of as many sites, is checked on sites placed on a
sphere and in a ball.
"""

from __future__ import annotations

import collections
import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from vibra import networks
from vibra.solvers import registry
from vibra.solvers.topology import _levels, separator_width


def grid(shape: tuple[int, ...]) -> sp.csr_matrix:
    """The pattern of nearest-neighbour springs on a grid of `shape` sites, one dof per site."""
    index = np.arange(int(np.prod(shape))).reshape(shape)
    rows, cols = [], []
    for axis, size in enumerate(shape):
        a = np.take(index, range(size - 1), axis=axis).ravel()
        b = np.take(index, range(1, size), axis=axis).ravel()
        rows += [a, b]
        cols += [b, a]
    r, c = np.concatenate(rows), np.concatenate(cols)
    n = index.size
    return sp.csr_matrix((np.ones(r.size + n), (np.r_[r, np.arange(n)], np.r_[c, np.arange(n)])), shape=(n, n))


def widest_diagonal(shape: tuple[int, ...]) -> int:
    """The most grid points on one hyperplane x_1 + ... + x_d = s (brute force)."""
    sums = [sum(point) for point in itertools.product(*(range(size) for size in shape))]
    return int(np.bincount(sums).max())


@pytest.mark.parametrize("shape", [(7, 7), (12, 5), (6, 6, 6), (9, 4, 7), (3, 3, 3, 3)])
def test_a_grid_s_widest_level_is_its_widest_diagonal(shape: tuple[int, ...]) -> None:
    # (a corner is pseudo-peripheral: the search starts inside and finds the far corner)
    assert separator_width(grid(shape)) == widest_diagonal(shape)


def _hop_levels(A: sp.csr_matrix, root: int) -> list[set[int]]:
    """The vertices by hop distance from `root`, by a plain queue over the stored entries (explicit zeros too)."""
    distance = {root: 0}
    queue = collections.deque([root])
    while queue:
        vertex = queue.popleft()
        for other in A.indices[A.indptr[vertex]:A.indptr[vertex + 1]]:
            if int(other) not in distance:
                distance[int(other)] = distance[vertex] + 1
                queue.append(int(other))
    return [{v for v, d in distance.items() if d == level} for level in range(max(distance.values()) + 1)]


@pytest.mark.parametrize("seed", range(6))
def test_the_levels_are_the_hop_distances(seed: int) -> None:
    """`_levels` reads the levels off scipy's breadth-first order: the same sets as a plain queue's hop
    distances, on random symmetric patterns of several components, with explicit zeros stored."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(20, 400))
    A = sp.random(n, n, density=float(rng.uniform(0.002, 0.03)), random_state=seed, format="csr")
    A = (A + A.T).tocsr()
    A.data[::4] = 0.0  # stored zeros are still edges (K's pattern)
    root = int(rng.integers(n))
    graph = sp.csr_matrix((np.ones(A.indices.shape[0]), A.indices, A.indptr), shape=A.shape)
    assert [set(level.tolist()) for level in _levels(graph, root)] == _hop_levels(A, root)


def test_a_path_and_a_cycle() -> None:
    n = 50
    path = grid((n,))
    assert separator_width(path) == 1
    cycle = (path + sp.csr_matrix((np.ones(2), ([0, n - 1], [n - 1, 0])), shape=(n, n))).tocsr()
    assert separator_width(cycle) == 2


def test_copies_add_as_their_factors_do() -> None:
    """Two disconnected copies of a grid: width^3 doubles (each copy its own factor); a copy
    half the size adds (1/2)^2 of the largest's cube (its width scaled as n^(2/3))."""
    one = grid((8, 8, 8))
    w = widest_diagonal((8, 8, 8))
    assert separator_width(sp.block_diag([one, one], format="csr")) == round(w * 2 ** (1 / 3))
    half = grid((8, 8, 4))
    assert separator_width(sp.block_diag([one, half], format="csr")) == round(w * (1 + 0.25) ** (1 / 3))
    assert separator_width(sp.csr_matrix((0, 0))) == 0


def test_a_shell_is_costed_below_a_solid_of_as_many_sites() -> None:
    """4,000 sites on a sphere's surface (a capsid) against 4,000 in a ball at the same density
    of contacts: the shell's widest level is far narrower, so the sparse path's estimate of its
    factor is lower (the n^2 model costed both alike)."""
    rng = np.random.default_rng(0)
    n = 4000
    sphere = rng.normal(size=(n, 3))
    sphere *= (np.sqrt(n / (4 * np.pi)) * 3.8 / np.linalg.norm(sphere, axis=1))[:, None]  # ~3.8 A apart
    ball = rng.uniform(-1.0, 1.0, size=(3 * n, 3))
    ball = ball[np.linalg.norm(ball, axis=1) <= 1.0][:n] * (n * 3.8 ** 3 * 3 / (4 * np.pi)) ** (1 / 3)
    widths = {}
    for name, sites in (("shell", sphere), ("solid", ball)):
        K = networks.anm(sites, cutoff=10.0).hessian().tocsr()
        widths[name] = separator_width(K)
        assert 0 < widths[name] < K.shape[0]
    assert widths["shell"] < 0.6 * widths["solid"]
    cost = {name: registry.estimate("sparse", 3 * n, k=20, vectors=True, width=3 * n - 1, nnz=3 * n * 100,
                                    accuracy="fast", separator=w).seconds for name, w in widths.items()}
    assert cost["shell"] < cost["solid"]


def test_the_plan_measures_it_for_a_large_sparse_network() -> None:
    """`describe` fills `Problem.separator` where the factorisation could be chosen (a sparse K
    over DENSE_LIMIT dofs, wider than a band), and leaves 0 for a chain."""
    from vibra.solvers.dispatch import describe

    rng = np.random.default_rng(1)
    system = networks.anm(rng.uniform(0.0, 30.0, size=(700, 3)), cutoff=8.0)
    K = system.hessian().tocsr()
    problem = describe(K, np.ones(K.shape[0]), n_modes=6, vectors=True, band=None, solver="auto", spring_factor=None)
    assert problem.separator == separator_width(K) > 0
    chain = grid((2000,))
    assert describe(chain, np.ones(2000), n_modes=6, vectors=True, band=None, solver="auto",
                    spring_factor=None).separator == 0
