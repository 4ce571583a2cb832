"""The direct and state-space frequency responses (no modal truncation).

``direct``: one factorisation of K - w^2 M + i w C per frequency, tridiagonal (LAPACK
zgtsv) or banded (zgbsv) when K, M and C are, sparse LU otherwise, dense LU for small dense
input. ``state space``: complex modes of the first-order form (dense; all modes).

Both take the matrix of the velocity term as `C`: a symmetric damping matrix, or C + G with a
skew gyroscopic G (`vibra.response.matrices.velocity_matrix`). Neither method assumes
symmetry (general LU; left and right eigenvectors), so G needs nothing else; `gyroscopic`
only changes the wording of a singular-frequency error.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from scipy.linalg import lapack

from vibra.response.matrices import (
    Matrix, as_operator, dense_matrix, diagonal_band, half_bandwidth, singular_frequency_error,
)


#: Largest half-bandwidth for which the direct method uses the banded LAPACK solver
#: (cost n * b^2 per frequency); wider matrices go to sparse (or dense) LU.
BANDED_MAX_HALF_WIDTH = 16


EPS = float(np.finfo(float).eps)


def _singular(pivots: NDArray[Any], scale: float, n_dof: int) -> bool:
    # An exactly singular matrix (undamped resonance, rigid-body modes at w = 0) leaves an
    # LU pivot of round-off size, about eps * ||A||; n_dof * eps * ||A|| is well above that
    # and far below the smallest pivot of a lightly damped system at resonance (~ w c).
    return bool(np.min(np.abs(pivots)) <= 8.0 * n_dof * EPS * scale)


def direct_response(K: Matrix, mass: NDArray[np.float64], C: Matrix | None, omegas: NDArray[np.float64],
            force: NDArray[np.float64], *, gyroscopic: bool = False) -> tuple[NDArray[np.complex128], str]:
    """(n_freq, n_dof) response by one LU per frequency, and the solver that ran.

    `C` is the velocity matrix (C, or C + G); `gyroscopic` says it holds a G (error wording).
    """
    def singular(i: int, w: float) -> ValueError:
        return singular_frequency_error(i, w, gyroscopic=gyroscopic)

    n_dof = K.shape[0]
    width = max(half_bandwidth(K), half_bandwidth(mass), half_bandwidth(C))
    response = np.empty((omegas.size, n_dof), dtype=complex)
    scale_base = (_max_abs(K), _max_abs(mass), _max_abs(C))
    rhs = force.astype(complex)
    if n_dof >= 3 and width <= 1:  # scipy's tridiagonal wrappers reject n = 2
        # One LAPACK zgtsv per frequency (LU with partial pivoting, then the solve); on exit
        # its `d` holds the diagonal of U, which gives the singularity check for free. The
        # diagonals of A(w) are written straight into the real and imaginary parts of fresh
        # complex buffers (three passes, no temporaries): assembly costs ~10 % of the solve.
        parts = {
            offset: [diagonal_band(A, n_dof, offset) for A in (K, mass, C)]
            for offset in (-1, 0, 1)
        }
        gtsv = lapack.zgtsv
        for i, w in enumerate(omegas):
            w2 = w * w
            bands = []
            for offset in (-1, 0, 1):
                k_part, m_part, c_part = parts[offset]
                band = np.empty(n_dof - abs(offset), dtype=complex)
                pair = band.view(float).reshape(-1, 2)
                if m_part.any():
                    np.multiply(m_part, -w2, out=pair[:, 0])
                    pair[:, 0] += k_part
                else:
                    pair[:, 0] = k_part
                np.multiply(c_part, w, out=pair[:, 1])
                bands.append(band)
            _, pivots, _, x, info = gtsv(bands[0], bands[1], bands[2], rhs.copy(),
                                         overwrite_dl=1, overwrite_d=1, overwrite_du=1, overwrite_b=1)
            if info > 0 or _singular(pivots, _scale(scale_base, w), n_dof):
                raise singular(i, float(w))
            response[i] = x.ravel()
        return response, "tridiagonal"
    if n_dof >= 2 and width <= BANDED_MAX_HALF_WIDTH:
        kl = ku = width
        storage = [_band_storage(A, n_dof, width) for A in (K, mass, C)]
        gbsv = lapack.zgbsv
        for i, w in enumerate(omegas):
            ab = np.zeros((2 * kl + ku + 1, n_dof), dtype=complex, order="F")
            ab[kl:] = storage[0] - (w * w) * storage[1] + (1j * w) * storage[2]
            lu, _, x, info = gbsv(kl, ku, ab, rhs.copy(), overwrite_ab=1, overwrite_b=1)
            if info > 0 or _singular(lu[kl + ku], _scale(scale_base, w), n_dof):
                raise singular(i, float(w))
            response[i] = x.ravel()
        return response, "banded"
    if sp.issparse(K) or sp.issparse(C) or n_dof > 1000:
        K_op, M_op, C_op = (sp.csc_matrix(as_operator(A, n_dof)) for A in (K, mass, C))
        for i, w in enumerate(omegas):
            A = sp.csc_matrix(K_op - (w * w) * M_op + (1j * w) * C_op)
            try:
                lu = spla.splu(A)
            except RuntimeError:  # "Factor is exactly singular"
                raise singular(i, float(w)) from None
            if _singular(lu.U.diagonal(), _scale(scale_base, w), n_dof):
                raise singular(i, float(w))
            response[i] = lu.solve(rhs)
        return response, "sparse LU"
    K_dense = dense_matrix(K, n_dof)
    M_dense = dense_matrix(mass, n_dof)
    C_dense = dense_matrix(C, n_dof)
    for i, w in enumerate(omegas):
        A = K_dense - (w * w) * M_dense + (1j * w) * C_dense
        lu, piv = la.lu_factor(A, check_finite=False)
        if _singular(np.diagonal(lu), _scale(scale_base, w), n_dof):
            raise singular(i, float(w))
        response[i] = la.lu_solve((lu, piv), rhs, check_finite=False)
    return response, "dense LU"


def _max_abs(matrix: Any) -> float:
    if matrix is None:
        return 0.0
    if sp.issparse(matrix):
        return float(abs(matrix).max()) if matrix.nnz else 0.0
    return float(np.max(np.abs(matrix))) if matrix.size else 0.0


def _scale(base: tuple[float, float, float], w: float) -> float:
    return max(base[0], w * w * base[1], w * base[2], 1e-300)


def _band_storage(matrix: Any, n_dof: int, width: int) -> NDArray[np.float64]:
    """LAPACK band storage (2 width + 1, n_dof): row width + i - j holds A[i, j]."""
    band = np.zeros((2 * width + 1, n_dof))
    for offset in range(-width, width + 1):
        diagonal = diagonal_band(matrix, n_dof, offset)
        row = width - offset
        if offset >= 0:
            band[row, offset:] = diagonal
        else:
            band[row, :offset] = diagonal
    return band


def state_space_response(K: Matrix, mass: NDArray[np.float64], C: Matrix | None, omegas: NDArray[np.float64],
                 force: NDArray[np.float64], *, gyroscopic: bool = False,
                 ) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
    """(n_freq, n_dof) response from the complex modes of the first-order form, and |Im s|.

    `C` is the velocity matrix (C, or C + G); the first-order pencil is then not symmetric,
    which the left eigenvectors take care of.
    """
    n_dof = K.shape[0]
    if n_dof > 2000:
        raise ValueError(f"method='state_space' is dense (2 n_dof = {2 * n_dof}); use method='direct' for n_dof > 2000")
    K_dense, M_dense, C_dense = dense_matrix(K, n_dof), dense_matrix(mass, n_dof), dense_matrix(C, n_dof)
    zero = np.zeros((n_dof, n_dof))
    # First-order form with z = (u, u'): A z' + B z = (f, 0), both symmetric when C is (with G,
    # A is not: the modal weights below use the left eigenvectors y_r, which hold either way).
    A = np.block([[C_dense, M_dense], [M_dense, zero]])
    B = np.block([[K_dense, zero], [zero, -M_dense]])
    eigenvalues, left, right = la.eig(-B, A, left=True, right=True)
    if not np.all(np.isfinite(eigenvalues)):
        raise RuntimeError("the state-space eigenproblem returned infinite eigenvalues")
    loads = np.concatenate([force, np.zeros(n_dof)])
    modal_mass = np.einsum("ir,ij,jr->r", left.conj(), A, right)       # y_r^H A x_r
    participation = (left.conj().T @ loads) / modal_mass               # y_r^H F / (y_r^H A x_r)
    denominators = 1j * omegas[:, None] - eigenvalues[None, :]
    if (denominators == 0).any():
        i = int(np.argwhere(denominators == 0)[0, 0])
        raise singular_frequency_error(i, float(omegas[i]), gyroscopic=gyroscopic)
    response = (participation / denominators) @ right[:n_dof].T
    natural = np.sort(np.abs(eigenvalues.imag))[::2]
    return response, natural

