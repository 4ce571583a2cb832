"""The symmetric pencil K x = omega^2 M x with a dense, possibly ill-conditioned mass matrix.

Generalised coordinates give a full mass matrix M, and mechanisms with very unequal
masses or lengths make it ill-conditioned: seed 000's double pendulum with m = 1e-3,
m' = 1e3, a = 1, b = 1e-3 has cond(M) ~ 1e12. Forming M^-1/2 K M^-1/2 from an
eigendecomposition of M (the path of `vibra.normal_modes`) then loses up to 12 digits of the
lowest frequencies. This module keeps them:

1. Diagonal equilibration. With D = diag(M)^-1/2, M_s = D M D has a unit diagonal; a
   kinetic energy whose conditioning comes from the units or sizes of the coordinates
   (angles of long and short rods) becomes well conditioned. M is accepted when
   the Cholesky factorisation M_s = L L^T succeeds and cond(M_s) < 1 / (n eps): it is refused
   only when singular or indefinite to working precision, with its condition number.
2. When K is positive definite, K_s = D K D is equilibrated and factored the same way,
   K_s = R^T R, and the squared frequencies are the squared singular values of
   G = R L^-T, computed by one-sided Jacobi (LAPACK gejsv) after a pivoted QR that moves
   the grading of K_s to one side (see `_jacobi`): every frequency to a relative accuracy
   of about eps (cond(M_s) + cond(K_s)), the small ones not measured against the large
   ones ("pencil-jacobi"). Pencils graded by diagonal scalings over 1e-6..1e6 on both M and K
   (cond up to 1e24) keep 15 digits.
3. Otherwise (K indefinite or singular) the equilibrated pencil (K_s, M_s) is solved by
   LAPACK sygv ("pencil-cholesky"), accurate to eps * ||L^-1 K_s L^-T|| absolutely.

The error figure reported per mode is first-order perturbation theory for relative
perturbations of the entries of K_s and M_s of a few ulps:
|d(omega^2)| <= c n eps (cond(M_s) + cond(K_s)) omega^2 on the Jacobi path, plus the
absolute term c n eps ||L^-1 K_s L^-T|| on the Cholesky path: honest, and for the double
pendulum above within about 30 times of the true error.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.linalg as la
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import owned_arrays
from vibra.solvers.common import SolveResult, omega_and_error, selected
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

if TYPE_CHECKING:
    from vibra.modes import Modes

__all__ = ["check_mass_matrix", "scaled_condition", "equilibrated_cholesky", "pencil_modes", "pencil_result"]

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


def pencil_modes(
    K: ArrayLike,
    M: ArrayLike,
    *,
    n_modes: int | None = None,
    vectors: bool = True,
    band: tuple[float, float] | None = None,
    units: str | UnitSystem = DIMENSIONLESS,
) -> "Modes":
    """Normal modes of M u'' + K u = 0 for a dense, possibly ill-conditioned M (see the module).

    Parameters
    ----------
    K : (n, n) array_like
        Symmetric stiffness matrix (an indefinite K gives negative omega for its unstable
        modes, as in `vibra.normal_modes`).
    M : (n, n) array_like
        Symmetric positive-definite mass matrix (checked by `check_mass_matrix`).
    n_modes : int, optional
        How many of the lowest modes to return (all by default).
    vectors : bool
        False returns frequencies only.
    band : (float, float), optional
        Only modes with omega in [band[0], band[1]] (signed).
    units : str or UnitSystem
        Unit system carried by the result.

    Returns
    -------
    Modes
        solver ``"pencil-jacobi"`` (K positive definite) or ``"pencil-cholesky"``;
        shapes M-orthonormal, vectors M^1/2 shapes; omega_error from perturbation theory
        (see the module).

    Raises
    ------
    ValueError
        K not square, finite and symmetric; M refused by `check_mass_matrix`; n_modes out
        of range; both n_modes and band.

    Examples
    --------
    >>> modes = pencil_modes([[9810.00981, 0.0], [0.0, 9.81]], [[1000.001, 1.0], [1.0, 1e-3]])
    >>> modes.solver, [float(f"{w:.6e}") for w in modes.omega ** 2]
    ('pencil-jacobi', [9.8002, 9819820000.0])
    """
    K_matrix = _validate.real_array(K, "K", ndim=2)
    if K_matrix.shape[0] != K_matrix.shape[1]:
        raise ValueError(f"K must be square, got shape {K_matrix.shape}")
    K_matrix = np.array(_validate.symmetric(K_matrix, "K"), dtype=float)
    n = K_matrix.shape[0]
    mass = check_mass_matrix(M, n, "M")
    if n_modes is not None:
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n)
        if band is not None:
            raise ValueError("give either n_modes or band, not both")
    result = pencil_result(K_matrix, mass, n_modes=n_modes, vectors=vectors, band=band)
    if (result.eigenvalues < -result.error).any():
        warnings.warn(f"K is not positive semi-definite: {int((result.eigenvalues < -result.error).sum())} "
                      "imaginary mode(s), reported as negative omega", RuntimeWarning, stacklevel=2)
    from vibra.modes import Modes  # (here: vibra.modes routes full mass matrices to this module)

    omega, omega_error = omega_and_error(result.eigenvalues, result.error)
    with owned_arrays():
        return Modes(omega=omega, vectors=result.vectors, shapes=result.shapes, mass=mass,
                     omega_error=omega_error, residual=result.residual, orthogonality=result.orthogonality,
                     solver=result.solver, units=unit_system(units))


def pencil_result(K_matrix: Any, mass: NDArray[np.float64], *, n_modes: int | None, vectors: bool,
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
