"""Checks and storage helpers shared by the multi-dof response methods.

`check_structure` validates (K, M, C, f) and a gyroscopic G for `frequency_response` and
`transient_response`; `velocity_matrix` adds C and G into the matrix of the velocity term;
the rest read diagonals, bands and dense copies of a matrix that may be dense, sparse, a
mass vector or None (no damping).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.solvers.structured.quadratic import SKEW_RTOL, check_gyroscopic
from vibra.solvers.budget import Estimate
from vibra.solvers.common import Matrix, MatrixLike, bandwidth


def check_structure(K: MatrixLike, M: MatrixLike, C: MatrixLike | None, force: ArrayLike, *,
                    complex_force: bool = False
                    ) -> tuple[Matrix, NDArray[np.float64], Matrix | None,
                               NDArray[np.float64] | NDArray[np.complex128]]:
    """Validate (K, M, C, f) in argument order; return K, the mass argument, C or None, f.

    C must be symmetric positive semi-definite (an indefinite C has a mode with negative
    damping, which gains energy). With `complex_force`, f may be complex (a phase per dof).
    A gyroscopic G is checked after them by `check_skew`.
    """
    stiffness = _validate.square_matrix(K, "K")
    stiffness = _validate.symmetric(stiffness, "K")
    n_dof = stiffness.shape[0]
    mass = _validate.mass_argument(M, n_dof, "M")
    damping = None
    if C is not None:
        damping = _validate.square_matrix(C, "C")
        if damping.shape[0] != n_dof:
            raise ValueError(f"C must be ({n_dof}, {n_dof}) to match K, got shape {damping.shape}")
        damping = _validate.symmetric(damping, "C")
        _validate.positive_semidefinite(damping, "C")  # the diagonal first, then the eigenvalues
    if complex_force:
        loads: NDArray[Any] = _validate.complex_array(force, "force", ndim=1)
    else:
        loads = _validate.real_array(force, "force", ndim=1)
    if loads.shape[0] != n_dof:
        raise ValueError(f"force must have {n_dof} entries to match K, got shape {loads.shape}")
    return stiffness, mass, damping, loads


def check_skew(G: MatrixLike | None, n_dof: int, name: str = "G") -> Matrix | None:
    """G as a skew-symmetric (n_dof, n_dof) matrix (dense or CSR), or None when G is None or zero.

    Skew within `vibra.solvers.structured.quadratic.SKEW_RTOL` * max|G|, as `System.generalized` checks it (a
    dense G goes through `vibra.solvers.structured.quadratic.check_gyroscopic`, the same message). A zero G is
    returned as None, so that the undamped or proportionally damped fast paths still apply.

    Raises
    ------
    ValueError
        G not square, not (n_dof, n_dof), not finite, or not skew-symmetric (the message names
        the worst pair of entries and the measured asymmetry |G[i,j] + G[j,i]|).
    TypeError
        G not a matrix of real numbers.
    """
    if G is None:
        return None
    matrix = _validate.square_matrix(G, name)
    if matrix.shape[0] != n_dof:
        raise ValueError(f"{name} must be ({n_dof}, {n_dof}) to match K, got shape {matrix.shape}")
    if not sp.issparse(matrix):
        dense = check_gyroscopic(matrix, n_dof, name)
        return dense if dense.any() else None
    sparse_matrix: Any = matrix
    if not sparse_matrix.nnz or not sparse_matrix.data.any():
        return None
    gap_matrix = (sparse_matrix + sparse_matrix.T).tocoo()
    scale = float(abs(sparse_matrix).max())
    gap, i, j = 0.0, 0, 0
    if gap_matrix.nnz:
        k = int(np.argmax(np.abs(gap_matrix.data)))
        gap, i, j = float(abs(gap_matrix.data[k])), int(gap_matrix.row[k]), int(gap_matrix.col[k])
    atol = SKEW_RTOL * scale
    if gap > atol:
        raise ValueError(
            f"{name} is not skew-symmetric: |{name}[{i},{j}] + {name}[{j},{i}]| = {gap:.3g} > "
            f"atol={atol:.3g} ({SKEW_RTOL:g} * max|{name}|); a gyroscopic matrix satisfies "
            f"{name}^T = -{name} (its symmetric part belongs in C)"
        )
    return sparse_matrix


def velocity_matrix(C: Matrix | None, G: Matrix | None) -> Matrix | None:
    """C + G, the matrix of the velocity term M u'' + (C + G) u' + K u (None when both are None).

    Sparse when either is sparse, dense otherwise.
    """
    if G is None:
        return C
    if C is None:
        return G
    if sp.issparse(C) or sp.issparse(G):
        return sp.csr_matrix(sp.csr_matrix(C) + sp.csr_matrix(G))
    return np.asarray(C, dtype=float) + np.asarray(G, dtype=float)


def half_bandwidth(matrix: Matrix | None) -> int:
    """max |i - j| over the nonzeros of a dense/sparse matrix; 0 for a mass vector or None."""
    if matrix is None:
        return 0
    if sp.issparse(matrix):
        coo = sp.coo_matrix(matrix)
        nonzero = coo.data != 0
        if not nonzero.any():
            return 0
        return int(np.max(np.abs(coo.row[nonzero] - coo.col[nonzero])))
    if matrix.ndim == 1:
        return 0
    return bandwidth(matrix)  # in row blocks: no n^2 index arrays


def diagonal_band(matrix: Matrix | None, n_dof: int, offset: int) -> NDArray[np.float64]:
    """Diagonal `offset` (>= 0 above, < 0 below) of a dense/sparse matrix or mass vector."""
    length = n_dof - abs(offset)
    if matrix is None:
        return np.zeros(length)
    if not sp.issparse(matrix) and matrix.ndim == 1:
        return matrix.astype(float) if offset == 0 else np.zeros(length)
    return np.asarray(matrix.diagonal(offset), dtype=float)


def as_operator(matrix: Matrix | None, n_dof: int) -> Matrix:
    """A matrix usable in products: sparse diagonal for a mass vector, zero for None."""
    if matrix is None:
        return sp.csr_matrix((n_dof, n_dof))
    if not sp.issparse(matrix) and matrix.ndim == 1:
        return sp.diags(matrix, format="csr")
    return matrix


def dense_matrix(matrix: Matrix | None, n_dof: int) -> NDArray[np.float64]:
    """(n_dof, n_dof) dense copy of a dense/sparse matrix, a mass vector or None (zeros)."""
    if matrix is None:
        return np.zeros((n_dof, n_dof))
    if sp.issparse(matrix):
        return matrix.toarray()
    if matrix.ndim == 1:
        return np.diag(matrix)
    return np.asarray(matrix, dtype=float)


def mass_times(mass: NDArray[np.float64], x: NDArray[np.float64] | NDArray[np.complex128]
               ) -> NDArray[np.float64] | NDArray[np.complex128]:
    """M x for diagonal masses (a vector) or a dense M; x (n_dof,) or (n_dof, k)."""
    if mass.ndim == 1:
        return mass[:, None] * x if x.ndim == 2 else mass * x
    return mass @ x


def singular_frequency_error(i: int, w: float, *, gyroscopic: bool = False) -> ValueError:
    """The ValueError naming omegas[i] where K - w^2 M + i w C (+ i w G) is singular."""
    matrix = "K - w^2 M + i w (C + G)" if gyroscopic else "K - w^2 M + i w C"
    return ValueError(
        f"omegas[{i}] is {w!r}: {matrix} is singular there (an undamped resonance, "
        "or w = 0 for a free structure whose rigid-body modes have an unbounded static "
        "response); add damping or leave out that frequency"
    )



def response_cost(method: str, n_dof: int, n_freq: int, width: int, stored: int, *, parts: int = 1) -> Estimate:
    """Memory (bytes) and time (s) of `frequency_response`, from operation counts.

    The (n_freq, n_dof) complex result, plus per method: tridiagonal / banded LU per frequency
    (O(n b^2)), sparse LU (fill taken as 20 nnz), dense LU (n^3 / 3 complex multiply-adds),
    state space (a dense 2n x 2n complex eigenproblem, ~30 (2n)^3 flops at 1e9 flop/s).
    A complex force (`parts` = 2) is solved as its real and imaginary parts: twice the time,
    three results held.
    """
    single = response_cost(method, n_dof, n_freq, width, stored) if parts > 1 else None
    if single is not None:
        output = 16.0 * n_freq * n_dof
        return Estimate(single.path, single.memory + 2 * output, 2 * single.seconds, single.what)
    output = 16.0 * n_freq * n_dof
    what = f"{n_freq} frequencies x {n_dof} dofs"
    if method == "state_space":
        size = 2.0 * n_dof
        return Estimate("state-space", output + 16.0 * size * size * 5, 3e-8 * size**3, what)
    if method == "modal":
        return Estimate("modal", output * 2, 1e-8 * n_freq * n_dof, what)
    if width <= 16:
        return Estimate("direct", output + 16.0 * n_dof * (3 * width + 2), 2e-8 * n_freq * n_dof * (width + 1) ** 2,
                        what)
    if n_dof > 1000 or stored < n_dof * n_dof:
        return Estimate("direct", output + 16.0 * 20 * stored, 4e-7 * n_freq * stored, what)
    return Estimate("direct", output + 16.0 * n_dof * n_dof * 4, 1e-9 * n_freq * n_dof**3, what)
