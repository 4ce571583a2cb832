"""The default sparse Cholesky for shift-invert: SuiteSparse CHOLMOD through `cvxopt`.

scipy has no sparse Cholesky: its SuperLU computes an LU of K~ - sigma I, both triangles with
row pivoting, twice the arithmetic and memory of a symmetric factor and without its dense
supernodal kernels. CHOLMOD's supernodal Cholesky in the same nested-dissection order
(`vibra.solvers.standard.ordering`) factorises the 30,000-dof random network about 6 times
faster than SuperLU (figures: benchmarks/RESULTS.md, the corpus's network rows). cvxopt ships
CHOLMOD in its wheels (a well-kept package since 2004, with wheels for the usual platforms);
MKL PARDISO (``vibra[pardiso]``, `vibra.solvers.standard.pardiso`) is used before it where installed.

The factorisation succeeds exactly when K~ - sigma I is positive definite (CHOLMOD reports a
non-positive pivot as an ArithmeticError), which is the inertia the shift needs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.compiled import jit

__all__ = ["cholmod_available", "use_cholmod", "sparse_backend", "CholmodCholesky", "factor_entries"]

_AVAILABLE: bool | None = None


def cholmod_available() -> bool:
    """Whether cvxopt's CHOLMOD imports (checked once)."""
    global _AVAILABLE
    if _AVAILABLE is None:
        try:
            import importlib

            importlib.import_module("cvxopt.cholmod")
            _AVAILABLE = True
        except (ImportError, OSError):
            _AVAILABLE = False
    return _AVAILABLE


def use_cholmod(n: int, minimum: int) -> bool:
    """CHOLMOD for a matrix of `n` dofs (where PARDISO is not used)? From `minimum` dofs when
    cvxopt loads and the backend setting (`pardiso.BACKEND`) is "auto" or "cholmod"; "cholmod"
    without cvxopt is an ImportError."""
    from vibra.solvers.standard import pardiso

    if pardiso.BACKEND not in ("auto", "cholmod") or n < minimum:
        return False
    if pardiso.BACKEND == "cholmod" and not cholmod_available():
        raise ImportError("the sparse backend 'cholmod' needs cvxopt (a dependency of vibra: "
                          "pip install cvxopt), or set VIBRA_SPARSE_BACKEND=auto")
    return cholmod_available()


class CholmodCholesky:
    """The supernodal Cholesky factor P A P^T = L L^T of a symmetric positive definite sparse A.

    `order`: the fill-reducing permutation p (A[p][:, p] is factorised), or None for CHOLMOD's
    own (AMD).

    Raises
    ------
    ValueError
        The matrix is not positive definite.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5), format="csr")
    >>> factor = CholmodCholesky(A, None) if cholmod_available() else None
    >>> factor is None or bool(np.allclose(A @ factor.solve(np.ones(5)), 1.0))
    True
    """

    def __init__(self, matrix: sp.spmatrix, order: NDArray[np.intp] | None) -> None:
        from cvxopt import cholmod, matrix as dense, spmatrix

        self.n = matrix.shape[0]
        lower = sp.tril(sp.csr_matrix(matrix), format="coo")  # CHOLMOD reads one triangle
        A = spmatrix(dense(lower.data.astype(float)), dense(lower.row.astype(np.int64)),
                     dense(lower.col.astype(np.int64)), size=(self.n, self.n))
        options = dict(cholmod.options)
        try:
            cholmod.options["supernodal"] = 2  # always supernodal (dense kernels)
            if order is None:
                self._factor = cholmod.symbolic(A)
            else:
                self._factor = cholmod.symbolic(A, p=dense(np.asarray(order, dtype=np.int64)))
            cholmod.numeric(A, self._factor)
        except ArithmeticError:
            raise ValueError("not positive definite (CHOLMOD: a non-positive pivot)") from None
        finally:
            cholmod.options.clear()
            cholmod.options.update(options)
        self._cholmod, self._dense = cholmod, dense
        # nonzeros in L (cvxopt hands the factor over only by converting it: counted here)
        self.factor_entries = factor_entries(matrix, order)

    def solve(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """A^-1 x for a vector or a block of columns."""
        x = np.asarray(x, dtype=float)
        rhs = self._dense(np.asfortranarray(x.reshape(self.n, -1)))
        self._cholmod.solve(self._factor, rhs)  # in place
        return np.asarray(rhs).reshape(x.shape)


def factor_entries(matrix: sp.spmatrix, order: NDArray[np.intp] | None) -> int:
    """Nonzeros in the Cholesky factor L of A[order][:, order] (symmetric pattern), from its
    elimination tree: row i of L holds the nodes met walking up the tree from each j < i with
    a_ij != 0 (Liu's row subtrees), O(nnz(L)) steps, no factorisation.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> factor_entries(sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(6, 6)), None)  # a chain: no fill
    11
    """
    pattern = sp.csr_matrix(matrix)
    if order is not None:
        pattern = pattern[order][:, order]
    pattern = pattern.tocsr()
    indptr, indices = pattern.indptr.astype(np.int64), pattern.indices.astype(np.int64)
    n = pattern.shape[0]
    return int(_row_counts(indptr, indices, _elimination_tree(indptr, indices, n), n))


@jit(cache=True)
def _elimination_tree(indptr: Any, indices: Any, n: int) -> Any:  # pragma: no cover (compiled)
    parent = np.full(n, -1, dtype=np.int64)
    ancestor = np.full(n, -1, dtype=np.int64)  # path-compressed ancestors
    for i in range(n):
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            while j != -1 and j < i:
                following = ancestor[j]
                ancestor[j] = i
                if following == -1:
                    parent[j] = i
                j = following
    return parent


@jit(cache=True)
def _row_counts(indptr: Any, indices: Any, parent: Any, n: int) -> int:  # pragma: no cover (compiled)
    mark = np.full(n, -1, dtype=np.int64)
    total = 0
    for i in range(n):
        mark[i] = i
        total += 1
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if j >= i:
                continue
            while mark[j] != i:
                mark[j] = i
                total += 1
                j = parent[j]
    return total


def sparse_backend(n: int) -> str:
    """Which factorisation `ShiftedInverse` tries first for a K~ of n dofs (not tridiagonal):
    "pardiso", "cholmod" or "superlu"; from the settings and what is installed, before any work."""
    from vibra.solvers.standard.ordering import CHOLESKY_FROM
    from vibra.solvers.standard.pardiso import use_pardiso

    if use_pardiso(n, CHOLESKY_FROM):
        return "pardiso"
    return "cholmod" if use_cholmod(n, CHOLESKY_FROM) else "superlu"
