"""Shared pieces of the solver paths: the result record, mass weighting, accuracy figures.

Every path (`vibra.solvers.standard`, `.sparse`, `.bidiagonal`, `.accurate`) returns a
`SolveResult`; `absolute_figures` gives the residual, orthogonality and error estimate of a
backward-stable (absolute-accuracy) path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra import _validate

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)

#: Largest n for which "auto" uses dense LAPACK when a sparse path could serve.
DENSE_LIMIT = 1500

#: Widest half-bandwidth for which "auto" uses the banded solver.
BAND_LIMIT = 16

#: Largest n for which all modes of a general sparse K are computed densely.
DENSE_ALL_LIMIT = 20000

#: Largest chain segment whose vectors come from the bidiagonal SVD (dbdsqr, O(n^3),
#: relatively accurate vectors); longer chains take MRRR vectors (absolute accuracy).
BDSQR_LIMIT = 800

#: Columns sampled for the residual / orthogonality figures of very large results.
SAMPLE = 256


@dataclass
class SolveResult:
    """Raw output of one solver path (internal; `Modes` is the public result).

    eigenvalues : (k,) ascending omega^2; vectors : (n, k) mass-weighted or None;
    error : (k,) absolute error estimate of each eigenvalue; residual, orthogonality: floats.
    """

    eigenvalues: NDArray[np.float64]
    vectors: NDArray[np.float64] | None
    error: NDArray[np.float64]
    residual: float
    orthogonality: float
    solver: str


def check_spring_factor(factor: Any, n_dof: int) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    """Validate a spring factor (B, w): B (n_terms, n_dof), w (n_terms,) > 0."""
    if not isinstance(factor, tuple) or len(factor) != 2:
        raise TypeError("spring_factor must be a tuple (B, w)")
    coupling, weights = factor
    b = sp.csr_matrix(coupling, dtype=float)
    if b.shape[1] != n_dof:
        raise ValueError(f"spring_factor B must have {n_dof} columns to match K, got shape {b.shape}")
    _validate.finite(b.data, "spring_factor B")
    w = _validate.real_array(weights, "spring_factor w", ndim=1)
    if w.shape[0] != b.shape[0]:
        raise ValueError(f"spring_factor w must have {b.shape[0]} entries (rows of B), got {w.shape[0]}")
    _validate.positive(w, "spring_factor w", "spring constant")
    return b, w


def physical_shapes(vectors: NDArray[np.float64], mass: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, k) shapes u = M^-1/2 d from mass-weighted vectors d (eq. 151)."""
    if mass.ndim == 1:
        return vectors / np.sqrt(mass)[:, None]
    return mass_power(mass, -0.5) @ vectors


def mass_power(mass: NDArray[np.float64], power: float) -> NDArray[np.float64]:
    """(n, n) M^power of a dense symmetric positive-definite mass matrix M."""
    values, basis = np.linalg.eigh(mass)
    return (basis * values**power) @ basis.T


def mass_weighted(K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64]
                  ) -> NDArray[np.float64] | sp.csr_matrix:
    """K~ = M^-1/2 K M^-1/2 (eq. 139): sparse stays sparse for diagonal M."""
    if mass.ndim == 1:
        scale = 1.0 / np.sqrt(mass)
        if sp.issparse(K):
            return sp.csr_matrix(sp.diags(scale) @ K @ sp.diags(scale))
        return K * scale[:, None] * scale[None, :]
    root = mass_power(mass, -0.5)
    dense = K if isinstance(K, np.ndarray) else np.asarray(K.toarray())
    weighted = root @ dense @ root
    return 0.5 * (weighted + weighted.T)


def _norm_estimate(Kt: NDArray[np.float64] | sp.csr_matrix, eigenvalues: NDArray[np.float64]) -> float:
    """A lower bound of ||K~||_2: max of |computed eigenvalues| and |diagonal| (Rayleigh quotients)."""
    diagonal = Kt.diagonal()
    scale = float(np.abs(diagonal).max()) if diagonal.size else 0.0
    if eigenvalues.size:
        scale = max(scale, float(np.abs(eigenvalues).max()))
    return scale if scale > 0 else 1.0


def absolute_figures(Kt: Any, eigenvalues: NDArray[np.float64], vectors: NDArray[np.float64] | None,
             solver: str, floor: float) -> SolveResult:
    """Residual, orthogonality and error estimates of a standard (absolute-accuracy) path."""
    n = Kt.shape[0]
    norm = _norm_estimate(Kt, eigenvalues)
    # Eigenvalues of a backward-stable symmetric solver are exact for K~ + E, ||E|| ~ eps ||K~||.
    error = np.full(eigenvalues.shape, floor * EPS * norm)
    if vectors is None:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), solver)
    columns = sample_columns(vectors.shape[1])
    sample = vectors[:, columns]
    residuals = np.linalg.norm(Kt @ sample - sample * eigenvalues[columns], axis=0)
    error[columns] = np.maximum(error[columns], residuals)
    gram = vectors.T @ sample
    gram[columns, np.arange(len(columns))] -= 1.0
    return SolveResult(eigenvalues, vectors, error, float(residuals.max(initial=0.0) / norm),
                       float(np.abs(gram).max(initial=0.0)), solver)


def sample_columns(k: int) -> NDArray[np.intp]:
    """Indices of the columns whose residuals are measured: all up to SAMPLE, else a sample."""
    if k <= SAMPLE:
        return np.arange(k)
    # The lowest modes (most at risk) and an even spread of the rest.
    return np.unique(np.concatenate([np.arange(SAMPLE // 2), np.linspace(0, k - 1, SAMPLE // 2).astype(int)]))


def squared_range(band: tuple[float, float]) -> tuple[float, float]:
    """A signed omega band (low, high) as the eigenvalue range (low|low|, high|high|)."""
    low, high = band
    return float(np.sign(low) * low * low), float(np.sign(high) * high * high)


def selected(omega: NDArray[np.float64], *, n_modes: int | None, band: tuple[float, float] | None
             ) -> NDArray[np.intp]:
    """Indices into the ascending `omega` of the lowest `n_modes`, or of those inside `band`, or all."""
    select = np.arange(omega.shape[0])
    if n_modes is not None:
        return select[:n_modes]
    if band is not None:
        return select[(omega >= band[0]) & (omega <= band[1])]
    return select


def tridiagonal_bands(Kt: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(diagonal, superdiagonal) of a tridiagonal K~, dense or sparse."""
    if sp.issparse(Kt):
        return np.asarray(Kt.diagonal()), np.asarray(Kt.diagonal(1))
    return np.diag(Kt).copy(), np.diag(Kt, 1).copy()


def bandwidth(Kt: Any) -> int:
    """Half-bandwidth max |i - j| over the stored nonzeros of K~ (0 for a diagonal)."""
    if sp.issparse(Kt):
        coo = Kt.tocoo()
        return int(np.abs(coo.row - coo.col).max()) if coo.nnz else 0
    rows, cols = np.nonzero(Kt)
    return int(np.abs(rows - cols).max()) if rows.size else 0


def small_pencil(H: NDArray[np.float64], S: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenpairs of the k x k pencil (H, S), S the Gram matrix of a nearly orthonormal basis."""
    return la.eigh(0.5 * (H + H.T), 0.5 * (S + S.T))

