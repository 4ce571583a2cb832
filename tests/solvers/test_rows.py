"""Products with dense blocks (`vibra.solvers.standard.rows`) against scipy's own product.

- Row slabs: each row of the result is computed by scipy's routine from the same stored entries in
  the same order, so the split product must equal scipy's bit for bit (no tolerance), whatever the
  slabs, the dtype or the shape.
- Site blocks (the compiled loop over 3 x 3 blocks) sum each row in another order: each side's
  entry is within gamma_k (|A| |X|)_ij of the exact one (the dot product's rounding bound, Higham
  3.1; k the row's stored entries, gamma_k = k u / (1 - k u)), so they differ by at most twice that.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from helpers.forked import NEEDS_FORK, in_forked_child

from vibra.solvers.standard import rows
from vibra import networks
from vibra.solvers.standard.rows import RowSlabs, SiteBlocks, product_threads, products


def _matrix(n_rows: int, n_cols: int, density: float, seed: int, dtype=np.float64) -> sp.csr_matrix:
    matrix = sp.random(n_rows, n_cols, density=density, random_state=seed, format="csr", dtype=dtype)
    matrix.data -= 0.5
    return matrix


@pytest.mark.parametrize("threads", [1, 2, 3, 5])
@pytest.mark.parametrize("shape, columns", [((400, 400), 7), ((900, 120), 3), ((3, 50), 4), ((60, 60), 1)])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_split_products_equal_scipy_bit_for_bit(monkeypatch, threads, shape, columns, dtype) -> None:
    monkeypatch.setattr(rows, "MIN_WORK", 0)  # split every product, however small
    matrix = _matrix(*shape, density=0.05, seed=threads, dtype=dtype)
    X = np.random.default_rng(threads).standard_normal((shape[1], columns)).astype(dtype)
    split = RowSlabs(matrix, threads=threads)
    assert np.array_equal(split @ X, matrix @ X)
    assert (split @ X).dtype == (matrix @ X).dtype
    assert np.array_equal(split @ X[:, 0], matrix @ X[:, 0])  # a vector


def test_slabs_cover_rows_with_equal_shares_and_share_the_arrays() -> None:
    """Slabs tile the rows in order, hold equal shares of the entries (within one row's worth) and
    are views: no second copy of K~ (2 GB at 10^6 dofs)."""
    matrix = _matrix(1000, 1000, 0.02, seed=1)
    split = RowSlabs(matrix, threads=4)
    bounds = [(start, stop) for start, stop, _ in split._slabs]
    assert bounds[0][0] == 0 and bounds[-1][1] == 1000
    assert all(a[1] == b[0] for a, b in zip(bounds[:-1], bounds[1:]))
    widest_row = int(np.diff(matrix.indptr).max())
    assert all(abs(slab.nnz - matrix.nnz / 4) <= widest_row for _, _, slab in split._slabs)
    assert all(np.shares_memory(slab.data, matrix.data) for _, _, slab in split._slabs)


def test_empty_rows_and_more_threads_than_rows(monkeypatch) -> None:
    monkeypatch.setattr(rows, "MIN_WORK", 0)
    matrix = sp.csr_matrix((np.array([2.0]), (np.array([2]), np.array([0]))), shape=(4, 3))
    split = RowSlabs(matrix, threads=16)
    X = np.arange(6.0).reshape(3, 2)
    assert np.array_equal(split @ X, matrix @ X)
    assert len(split._slabs) <= 4


def test_threads_follow_the_setting(monkeypatch) -> None:
    monkeypatch.setattr(rows, "THREADS", 3)
    assert product_threads() == 3
    monkeypatch.setattr(rows, "THREADS", None)
    from vibra._core.cores import available_cores
    assert product_threads() == available_cores()


def _child(queue) -> None:  # pragma: no cover - runs in the forked child
    matrix = _matrix(300, 300, 0.1, seed=3)
    X = np.ones((300, 5))
    queue.put(bool(np.array_equal(RowSlabs(matrix, threads=2) @ X, matrix @ X)))


@NEEDS_FORK
def test_a_forked_child_gets_its_own_threads(monkeypatch) -> None:
    """A pool's threads do not survive fork: the child must not wait on the parent's (it would hang)."""
    monkeypatch.setattr(rows, "MIN_WORK", 0)
    matrix = _matrix(300, 300, 0.1, seed=3)
    RowSlabs(matrix, threads=2) @ np.ones((300, 5))  # the parent's pool, started
    status, equal = in_forked_child(_child)
    assert status == 0, "the forked child did not finish its product"
    assert equal is True


def _anm(n_sites: int, seed: int) -> sp.csr_matrix:
    positions = np.random.default_rng(seed).uniform(0.0, (n_sites / 0.05) ** (1 / 3), (n_sites, 3))
    return sp.csr_matrix(networks.anm(positions, cutoff=8.5).hessian())


def _within_rounding(ours: np.ndarray, matrix: sp.spmatrix, X: np.ndarray) -> bool:
    unit = np.finfo(ours.dtype).eps / 2
    k = int(np.diff(sp.csr_matrix(matrix).indptr).max())
    gamma = k * unit / (1 - k * unit)
    exact = abs(sp.csr_matrix(matrix)).astype(float) @ np.abs(X.astype(float))
    reference = (matrix @ X).astype(float)
    return bool(np.all(np.abs(ours.astype(float) - reference) <= 2 * gamma * exact))


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_site_blocks_within_the_rounding_of_scipys_product(dtype) -> None:
    K = _anm(400, seed=1).astype(dtype)
    operator = products(K)
    assert isinstance(operator, SiteBlocks)
    X = np.random.default_rng(2).standard_normal((K.shape[0], 9)).astype(dtype)
    ours = operator @ X
    assert ours.dtype == dtype and ours.shape == X.shape
    assert _within_rounding(ours, K, X)
    assert _within_rounding(operator @ X[:, 3], K, X[:, 3])  # a vector
    assert not np.array_equal(ours, np.zeros_like(ours))


def test_site_blocks_of_a_rectangular_prolongator() -> None:
    """A multigrid prolongator maps 3 dofs per aggregate to 3 per site: blocks, not square."""
    rng = np.random.default_rng(3)
    pattern = sp.random(30, 10, density=0.3, random_state=5)
    P = sp.bsr_matrix(sp.kron(pattern, rng.standard_normal((3, 3))), blocksize=(3, 3))  # (90, 30)
    for matrix in (P, P.T):
        operator = products(matrix)
        assert isinstance(operator, SiteBlocks)
        X = rng.standard_normal((matrix.shape[1], 4))
        assert _within_rounding(operator @ X, matrix, X)


def test_products_takes_site_blocks_only_where_the_matrix_has_them() -> None:
    chain = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(30, 30), format="csr")  # 1-D: no 3 x 3 blocks
    scattered = _matrix(300, 300, 0.02, seed=6)                                    # entries anywhere
    odd = _matrix(301, 301, 0.02, seed=7)                                          # not in threes
    assert all(isinstance(products(m), RowSlabs) for m in (chain, scattered, odd))
    X = np.ones((300, 2))
    assert np.array_equal(products(scattered) @ X, scattered @ X)


def test_site_blocks_refuse_a_block_of_the_wrong_height() -> None:
    operator = products(_anm(50, seed=8))
    with pytest.raises(ValueError, match=r"X has shape \(147, 2\); expected \(150,\) or \(150, columns\) for a 150 x 150"):
        operator @ np.ones((147, 2))


def test_products_without_the_compiled_loop() -> None:
    """Where loading numba would cost more than the work (`compiled_pays`), scipy's product serves."""
    K = _anm(50, seed=9)
    assert isinstance(products(K, compiled=False), RowSlabs)
    assert np.array_equal(products(K, compiled=False) @ np.ones((150, 3)), K @ np.ones((150, 3)))


def _site_block_child(queue) -> None:  # pragma: no cover - runs in the forked child
    K = _anm(100, seed=10)
    X = np.random.default_rng(11).standard_normal((300, 4))
    queue.put(bool(_within_rounding(products(K) @ X, K, X)))


@NEEDS_FORK
def test_a_child_forked_after_the_compiled_loop_ran_gets_its_product() -> None:
    """GNU OpenMP (numba's threading layer where libgomp is found) aborts a forked child that uses
    it after its parent did: the child must take scipy's product instead, and finish."""
    K = _anm(100, seed=10)
    products(K) @ np.ones((300, 4))  # the parent runs the compiled loop (and numba's threads) first
    status, within = in_forked_child(_site_block_child)
    assert status == 0, f"the forked child ended with {status}"
    assert within is True
