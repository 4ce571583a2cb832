"""The equilibrated pencil's solver: the raw solve behind the pencil paths (`pencil_result`)
and the checks of a full mass matrix. The method, its accuracy and its error figure are
described in `vibra.solvers.structured.pencil` (`vibra.modes.pencil_modes` calls it); this
one holds no `Modes` so that the registry's runners can import it."""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.solvers.common import Matrix, SolveResult, selected

__all__ = ["check_mass_matrix", "scaled_condition", "equilibrated_cholesky", "pencil_result"]

EPS = float(np.finfo(float).eps)
# Safety factor of the per-mode error figure (over first-order perturbation theory).
_FACTOR = 4.0


def scaled_condition(matrix: NDArray[np.float64]) -> float:
    """2-norm condition number of D A D, D = diag(A)^-1/2 (inf when a diagonal entry is <= 0).

    Examples
    --------
    >>> round(scaled_condition(np.array([[1000.001, 1.0], [1.0, 1e-3]])) / 4e6, 3)
    1.0
    """
    diagonal = np.diag(matrix)
    if not np.all(diagonal > 0):
        return float("inf")
    scale = 1.0 / np.sqrt(diagonal)
    return float(np.linalg.cond(matrix * scale[:, None] * scale[None, :]))


def check_mass_matrix(M: ArrayLike, n_dof: int | None = None, name: str = "M") -> NDArray[np.float64]:
    """A dense mass matrix, refused only when singular or indefinite to working precision.

    Parameters
    ----------
    M : (n, n) array_like
        Symmetric mass matrix, in the units of the kinetic energy's coefficients.
    n_dof : int, optional
        The size it must have (that of K).
    name : str
        Its name in messages.

    Returns
    -------
    (n, n) ndarray
        A float copy.

    Raises
    ------
    ValueError
        Not square, finite and symmetric; the wrong size; a diagonal entry <= 0; not
        positive definite (the message gives the smallest eigenvalue of the scaled matrix
        and its condition number); singular to working precision (condition number of the
        scaled matrix >= 1 / (n eps)).

    Examples
    --------
    >>> check_mass_matrix([[1000.001, 1.0], [1.0, 1e-3]]).shape   # cond(M) ~ 1e12: accepted
    (2, 2)
    """
    matrix = _validate.real_array(M, name, ndim=2)
    n = matrix.shape[0]
    if matrix.shape[1] != n:
        raise ValueError(f"{name} must be square, got shape {matrix.shape}")
    if n_dof is not None and n != n_dof:
        raise ValueError(f"{name} must be ({n_dof}, {n_dof}) to match K, got shape {matrix.shape}")
    matrix = np.array(_validate.symmetric(matrix, name), dtype=float)
    diagonal = np.diag(matrix)
    if not np.all(diagonal > 0):
        i = int(np.argmin(diagonal))
        raise ValueError(f"{name}[{i},{i}] is {float(diagonal[i])!r}; every diagonal entry of a mass matrix "
                         "(the kinetic energy of one coordinate alone) must be positive")
    scale = 1.0 / np.sqrt(diagonal)
    scaled = matrix * scale[:, None] * scale[None, :]
    condition = float(np.linalg.cond(scaled))
    limit = 1.0 / (n * EPS)
    try:
        np.linalg.cholesky(scaled)
    except np.linalg.LinAlgError:
        smallest = float(np.linalg.eigvalsh(scaled)[0])
        if smallest < -n * EPS * float(np.abs(scaled).sum(axis=0).max()):
            raise ValueError(
                f"{name} is not positive definite: D {name} D (D = diag({name})^-1/2) has smallest eigenvalue "
                f"{smallest:.3g} and condition number {condition:.3g}; a mass matrix must be symmetric "
                "positive definite"
            ) from None
        condition = float("inf") if not np.isfinite(condition) else max(condition, limit)
    if not condition < limit:
        raise ValueError(
            f"{name} is singular to working precision: D {name} D (D = diag({name})^-1/2) has condition "
            f"number {condition:.3g} >= 1 / (n eps) = {limit:.3g}; some combination of coordinates "
            "has no kinetic energy (remove it, or freeze one of its coordinates)"
        )
    return matrix


def equilibrated_cholesky(matrix: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float] | None:
    """(D, L, cond) with D A D = L L^T, D = diag(A)^-1/2, cond = cond(D A D); None unless A is
    positive definite to working precision (cond < 1 / (n eps))."""
    diagonal = np.diag(matrix)
    if not np.all(diagonal > 0):
        return None
    scale = 1.0 / np.sqrt(diagonal)
    scaled = matrix * scale[:, None] * scale[None, :]
    try:
        lower = np.asarray(np.linalg.cholesky(scaled), dtype=np.float64)
    except np.linalg.LinAlgError:
        return None
    condition = float(np.linalg.cond(scaled))
    if not condition < 1.0 / (matrix.shape[0] * EPS):
        return None
    return scale, lower, condition


def pencil_result(K_matrix: Matrix, mass: NDArray[np.float64], *, n_modes: int | None, vectors: bool,
                  band: tuple[float, float] | None, jacobi: bool = True) -> SolveResult:
    """The pencil solved (see the module) as a solver path's raw result, K and M checked by
    the caller: ``pencil-jacobi`` where K is positive definite (and `jacobi`), else
    ``pencil-cholesky``; `shapes` M-orthonormal from the pencil's own factor (not from M^-1/2)."""
    K_matrix = np.asarray(K_matrix.toarray() if hasattr(K_matrix, "toarray") else K_matrix, dtype=float)
    mass_factor = equilibrated_cholesky(mass)
    if mass_factor is None:
        raise ValueError("M is not positive definite to working precision")
    scale, lower, mass_condition = mass_factor
    K_scaled = K_matrix * scale[:, None] * scale[None, :]
    stiffness_factor = equilibrated_cholesky(K_scaled) if jacobi else None
    if stiffness_factor is not None:
        values, basis, error = _jacobi(K_scaled, lower, stiffness_factor, mass_condition)
        solver = "pencil-jacobi"
    else:
        values, basis, error = _cholesky(K_scaled, lower, mass_condition)
        solver = "pencil-cholesky"
    order = np.argsort(values)
    values, basis, error = values[order], basis[:, order], error[order]
    omega = np.sign(values) * np.sqrt(np.abs(values))
    select = selected(omega, n_modes=n_modes, band=band)
    values, basis, error = values[select], basis[:, select], error[select]
    shapes = scale[:, None] * basis                       # x = D y: M-orthonormal
    residual = orthogonality = float("nan")
    mass_weighted: NDArray[np.float64] | None = None
    if vectors:
        gaps = K_matrix @ shapes - (mass @ shapes) * values
        sizes = (np.linalg.norm(K_matrix, 2) + np.abs(values) * np.linalg.norm(mass, 2)) * np.linalg.norm(shapes, axis=0)
        residual = float((np.linalg.norm(gaps, axis=0) / sizes).max(initial=0.0))
        gram = shapes.T @ mass @ shapes - np.eye(shapes.shape[1])
        orthogonality = float(np.abs(gram).max(initial=0.0))
        eigenvalues, eigenbasis = np.linalg.eigh(mass)
        root = (eigenbasis * np.sqrt(np.abs(eigenvalues))) @ eigenbasis.T
        mass_weighted = root @ shapes
    return SolveResult(values, mass_weighted, error, residual, orthogonality, solver,
                       shapes=shapes if vectors else None)


def _jacobi(K_scaled: NDArray[np.float64], lower: NDArray[np.float64],
            stiffness_factor: tuple[NDArray[np.float64], NDArray[np.float64], float], mass_condition: float
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """omega^2 = sigma^2(G^T), G^T = L^-1 E^-1 R0 with K_s = E^-1 R0 R0^T E^-1 (E diagonal).

    The diagonal E sits between two well-conditioned factors, which one-sided Jacobi cannot
    resolve; a QR factorisation with column pivoting of W = R0^T E^-1 (columns graded),
    W P = Q R1, moves it out: G^T = L^-1 P R1^T Q^T, and R1^T = U^T D1 is a well-conditioned
    matrix times a diagonal, so H = L^-1 P R1^T has the singular values of G^T to high
    relative accuracy by gejsv (Demmel and Veselic 1992; Drmac 1999). The left singular
    vectors of H are the eigenvectors z of L^-1 K_s L^-T; y = L^-T z.
    """
    k_scale, k_lower, stiffness_condition = stiffness_factor
    n = K_scaled.shape[0]
    W = k_lower.T / k_scale[None, :]                        # K_s = W^T W, columns graded
    _, R1, pivots = la.qr(W, pivoting=True)
    H = la.solve_triangular(lower, np.eye(n)[:, pivots] @ R1.T, lower=True)   # L^-1 P R1^T
    gejsv = la.get_lapack_funcs("gejsv", dtype=np.float64)
    sva, u, _, work, _, info = gejsv(np.asfortranarray(H), joba=1, jobu=0, jobv=3, jobr=1, jobt=0, jobp=0)
    if info != 0:  # pragma: no cover - gejsv fails only on NaN, refused above
        raise RuntimeError(f"LAPACK gejsv failed with info={info}")
    sigma = (work[0] / work[1] if work[1] != 0 else 1.0) * sva
    basis = la.solve_triangular(lower.T, u[:, :n], lower=False)  # y = L^-T z
    values = sigma**2
    relative = _FACTOR * n * EPS * (mass_condition + stiffness_condition)
    return values, basis, relative * values


def _cholesky(K_scaled: NDArray[np.float64], lower: NDArray[np.float64], mass_condition: float
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The equilibrated pencil by sygv: absolute accuracy eps ||L^-1 K_s L^-T||."""
    n = K_scaled.shape[0]
    reduced: Any = la.solve_triangular(lower, la.solve_triangular(lower, K_scaled, lower=True).T, lower=True)
    reduced = 0.5 * (reduced + reduced.T)
    values, z = np.linalg.eigh(reduced)
    basis = la.solve_triangular(lower.T, z, lower=False)
    norm = float(np.abs(values).max(initial=0.0))
    error = _FACTOR * n * EPS * (norm + mass_condition * np.abs(values))
    return values, basis, error
