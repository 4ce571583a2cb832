"""A sparse matrix's products with dense blocks on every core (`products`): one operator, two kernels.

- **`SiteBlocks`**, a matrix in 3 x 3 blocks (a 3-D network's K~, its multigrid levels and their
  prolongators): a compiled loop (numba, `prange` over block rows) that reads each neighbour's
  three rows of the block once per block, where scipy's CSR product reads them once per stored
  entry. Measured at 10^5 dofs (1.65e7 entries) times 68 columns, 2 cores: 0.14 s against scipy's
  0.40 s and `RowSlabs`' 0.31 s in double precision; 0.11 s against 0.21 and 0.13 s in single.
  Each row's sum is taken block by block, so it is not scipy's to the bit: within the dot product's
  rounding bound, gamma_k sum |a_ij x_j| (tests/solvers/test_rows.py).
- **`RowSlabs`**, any other CSR matrix: scipy's product releases the interpreter lock while it
  runs, so slabs of rows (views of the matrix's arrays, equal shares of its entries) are multiplied
  on a pool of threads at once, each writing its own rows: scipy's bits. 30,000 dofs (4.95e6
  entries) times 68 columns on 2 cores: 0.159 s on one thread, 0.088 s on two.

The iterative path (`vibra.solvers.standard.iterative`) multiplies K~ and its multigrid levels
through `products`. Threads: `THREADS` for the slabs (None: `vibra._core.cores.available_cores`);
the compiled loop runs on numba's threads (``NUMBA_NUM_THREADS``), as vibra's other parallel kernels.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core.cores import available_cores
from vibra.solvers.compiled import forked_with_numba, jit, prange
from vibra.solvers.standard.ordering import blocked

__all__ = ["MIN_WORK", "THREADS", "RowSlabs", "SiteBlocks", "Unshifted", "product_threads", "products"]

#: Threads for the products (None: the cores this process may use).
THREADS: int | None = None

#: Stored entries times columns under which a product runs on one thread: handing a slab to a
#: thread costs ~0.1 ms, the work of ~10^6 entry-columns at scipy's rate (~5e-11 s per entry-column).
MIN_WORK = 2_000_000

_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}
_LOCK = threading.Lock()
_KERNEL_LOCK = threading.Lock()

def product_threads() -> int:
    """The threads `RowSlabs` splits a product over: `THREADS`, or the cores this process may use."""
    return max(1, int(THREADS)) if THREADS is not None else available_cores()


def _pool(threads: int) -> ThreadPoolExecutor:
    """A pool of `threads` threads for this process, one per count (`product_threads`; a forked
    child makes its own: the parent's threads do not exist there)."""
    key = (os.getpid(), threads)
    with _LOCK:
        pool = _POOLS.get(key)
        if pool is None:
            pool = _POOLS[key] = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="vibra-rows")
        return pool


class RowSlabs:
    """`matrix @ X` for a dense block X on `threads` slabs of `matrix`'s rows at once.

    Parameters
    ----------
    matrix : sparse matrix
        Kept as CSR (converted once if it is not); the slabs are views of its arrays.
    threads : int, optional
        Slabs (default `product_threads`).
    """

    def __init__(self, matrix: sp.spmatrix, threads: int | None = None) -> None:
        self.matrix = matrix if isinstance(matrix, sp.csr_matrix) else sp.csr_matrix(matrix)
        self.shape = self.matrix.shape
        self.dtype = self.matrix.dtype
        count = max(1, min(product_threads() if threads is None else int(threads), self.shape[0]))
        indptr = self.matrix.indptr
        cuts = np.unique(np.searchsorted(indptr, np.linspace(0, self.matrix.nnz, count + 1)[1:-1]))
        bounds = [0, *[int(c) for c in cuts if 0 < c < self.shape[0]], self.shape[0]]
        self._slabs: list[tuple[int, int, sp.csr_matrix]] = []
        for start, stop in zip(bounds[:-1], bounds[1:]):
            first, last = int(indptr[start]), int(indptr[stop])
            slab = sp.csr_matrix((stop - start, self.shape[1]), dtype=self.dtype)
            # (set in place: scipy's constructor from (data, indices, indptr) copies them)
            slab.data, slab.indices = self.matrix.data[first:last], self.matrix.indices[first:last]
            slab.indptr = indptr[start:stop + 1] - indptr.dtype.type(first)
            self._slabs.append((start, stop, slab))

    @property
    def nnz(self) -> int:
        return int(self.matrix.nnz)

    def __matmul__(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        X = np.asarray(X)
        columns = 1 if X.ndim == 1 else X.shape[1]
        if len(self._slabs) == 1 or self.matrix.nnz * columns < MIN_WORK:
            return np.asarray(self.matrix @ X)
        out = np.empty((self.shape[0],) + X.shape[1:], dtype=np.result_type(self.dtype, X.dtype))

        def fill(start: int, stop: int, slab: sp.csr_matrix) -> None:
            out[start:stop] = slab @ X

        pool = _pool(product_threads())
        for future in [pool.submit(fill, *item) for item in self._slabs]:
            future.result()
        return out


class SiteBlocks:
    """`matrix @ X` for a matrix stored in 3 x 3 blocks (`scipy.sparse.bsr_matrix`, blocksize (3, 3)),
    by the compiled loop `_site_block_product` over block rows on numba's threads."""

    def __init__(self, matrix: sp.bsr_matrix) -> None:
        matrix = sp.bsr_matrix(matrix, blocksize=(3, 3))
        self.shape = matrix.shape
        self.dtype = matrix.dtype
        self.indptr = np.ascontiguousarray(matrix.indptr, dtype=np.int64)
        self.indices = np.ascontiguousarray(matrix.indices, dtype=np.int64)
        self.blocks = np.ascontiguousarray(matrix.data)
        self.nnz = int(matrix.nnz)
        self._slabs: RowSlabs | None = None

    def __matmul__(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        X = np.asarray(X)
        if X.ndim not in (1, 2) or X.shape[0] != self.shape[1]:
            raise ValueError(f"X has shape {X.shape}; expected ({self.shape[1]},) or ({self.shape[1]}, columns) "
                             f"for a {self.shape[0]} x {self.shape[1]} matrix")
        if forked_with_numba():
            # a child forked from a process that had loaded numba (`compiled.forked_with_numba`): scipy's
            # product (the same numbers within rounding) rather than compiling a serial copy of the kernel
            if self._slabs is None:
                self._slabs = RowSlabs(sp.bsr_matrix((self.blocks, self.indices, self.indptr), shape=self.shape).tocsr())
            return self._slabs @ X
        vector = X.ndim == 1
        dtype = np.result_type(self.dtype, X.dtype)
        block = np.ascontiguousarray((X[:, None] if vector else X).astype(dtype, copy=False))
        blocks = self.blocks if self.blocks.dtype == dtype else self.blocks.astype(dtype)
        out = np.empty((self.shape[0], block.shape[1]), dtype=dtype)
        with _KERNEL_LOCK:  # (one product at a time: numba's workqueue layer aborts on concurrent parallel calls)
            _site_block_product(self.indptr, self.indices, blocks, block, out)
        return out[:, 0] if vector else out


class Unshifted:
    """X -> A X - shift X: K~'s product from the product of A = K~ + shift I (`iterative.shifted_blocks`),
    so that the iterative path keeps one copy of K~'s entries for its multigrid and its products; in double
    precision (`shifted_blocks` makes A so) the rounding is that of K~'s own product (shift ~1e-4 ||K~||)."""

    def __init__(self, product: SiteBlocks | RowSlabs, shift: float) -> None:
        self.product, self.shift = product, float(shift)
        self.shape, self.dtype, self.nnz = product.shape, product.dtype, product.nnz

    def __matmul__(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        out = self.product @ X
        out -= self.shift * np.asarray(X)
        return out


def products(matrix: sp.spmatrix, *, compiled: bool = True) -> SiteBlocks | RowSlabs:
    """The product operator for `matrix`: `SiteBlocks` where its rows and columns come in groups of
    three coupled blockwise (`ordering.blocked`, the rule `ordering.site_block` applies: the 3 x 3
    blocks hold at most 1.5 times its stored entries; a spring along an axis leaves zeros in its block) and `compiled` (the
    caller's `vibra.solvers.compiled.compiled_pays`: loading numba costs ~0.5 s), `RowSlabs` otherwise. A matrix
    already in 3 x 3 blocks (`scipy.sparse.bsr_matrix`) is taken as it is, its arrays shared, not copied."""
    if compiled and matrix.shape[0] % 3 == 0 and matrix.shape[1] % 3 == 0 and matrix.shape[0] >= 6:
        if isinstance(matrix, sp.bsr_matrix) and matrix.blocksize == (3, 3) or blocked(matrix, 3):
            return SiteBlocks(sp.bsr_matrix(matrix, blocksize=(3, 3)))
    return RowSlabs(matrix)


@jit(cache=True, parallel=True, nogil=True, error_model="numpy", fastmath=False)
def _site_block_product(indptr, indices, blocks, X, out):  # type: ignore[no-untyped-def]  # pragma: no cover (compiled)
    """out = A X for A in 3 x 3 blocks (block row i: blocks[indptr[i]:indptr[i + 1]] at block
    columns indices[...]); each block row's three rows summed in registers, block by block."""
    columns = X.shape[1]
    for i in prange(indptr.shape[0] - 1):
        first = np.zeros(columns, dtype=out.dtype)
        second = np.zeros(columns, dtype=out.dtype)
        third = np.zeros(columns, dtype=out.dtype)
        for entry in range(indptr[i], indptr[i + 1]):
            j = 3 * indices[entry]
            b = blocks[entry]
            for c in range(columns):
                x0, x1, x2 = X[j, c], X[j + 1, c], X[j + 2, c]
                first[c] += b[0, 0] * x0 + b[0, 1] * x1 + b[0, 2] * x2
                second[c] += b[1, 0] * x0 + b[1, 1] * x1 + b[1, 2] * x2
                third[c] += b[2, 0] * x0 + b[2, 1] * x1 + b[2, 2] * x2
        for c in range(columns):
            out[3 * i, c] = first[c]
            out[3 * i + 1, c] = second[c]
            out[3 * i + 2, c] = third[c]
