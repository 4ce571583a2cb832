"""The first-order forms of M q'' + (G + C) q' + K q = 0 and their eigensolvers: the runners of the
quadratic paths of the solver registry (`vibra.solvers.registry`: ``skew-symmetric``,
``hamiltonian``, ``companion``).

Each takes the problem with M made the identity (`Reduced`: q = P y, P^T M P = I) and returns
the eigenvalues, the position parts of their right eigenvectors, the eigenvalue condition
numbers, and where K~ is positive definite the same of A^-1 (whose eigenvalues 1/lambda give the
small ones to high relative accuracy). `vibra.solvers.structured.quadratic` turns them into
`QuadraticModes` (see that module for the methods).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np
import scipy.linalg as la
from numpy.typing import NDArray

__all__ = ["EPS", "FACTOR", "Reduced", "Solved", "companion_solve", "skew_solve", "hamiltonian_solve",
           "skew_eigen", "general_eigen", "onto_axis"]

EPS = float(np.finfo(float).eps)
#: Safety factor of the error figures over eps ||A|| cond(lambda).
FACTOR = 8.0


@dataclass(frozen=True)
class Reduced:
    """The quadratic eigenproblem with M made the identity (q = P y): K~, G~, C~ and K~'s
    equilibrated Cholesky factor (None where K~ is not positive definite)."""

    K_t: NDArray[np.float64]
    G_t: NDArray[np.float64]
    C_t: NDArray[np.float64]
    stiffness: tuple[NDArray[np.float64], NDArray[np.float64], float] | None


Solved = Tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64],
               Optional[Tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64]]]]


def companion_solve(r: Reduced) -> Solved:
    """``companion``: geev of A = [[0, I], [-K~, -(G~ + C~)]]; with K~ positive definite also of
    A^-1 = [[-K~^-1 D~, -K~^-1], [I, 0]] (K~^-1 from its Cholesky factor), whose eigenvalues
    1/lambda give the small ones to high relative accuracy."""
    n = r.K_t.shape[0]
    D_t = r.G_t + r.C_t
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-r.K_t, -D_t]])
    values, right, condition = general_eigen(A)
    inverse = None
    if r.stiffness is not None:
        k_scale, k_lower, _ = r.stiffness

        def solve_K(X: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.asarray(k_scale[:, None] * la.cho_solve((k_lower, True), k_scale[:, None] * X))
        inverse_A = np.block([[-solve_K(D_t), -solve_K(np.eye(n))], [np.eye(n), np.zeros((n, n))]])
        inverse_values, inverse_right, inverse_condition = general_eigen(inverse_A)
        inverse = (1.0 / inverse_values, inverse_right[:n], inverse_condition)
    return values, right[:n], condition, inverse


def skew_solve(r: Reduced) -> Solved:
    """``skew-symmetric``: `skew_eigen` (K~ positive definite, no C)."""
    assert r.stiffness is not None
    return skew_eigen(r.K_t, r.G_t, r.stiffness)


def hamiltonian_solve(r: Reduced) -> Solved:
    """``hamiltonian``: geev of A = [[-G~/2, I], [G~^2/4 - K~, -G~/2]], eigenvalues within their
    error of the imaginary axis put on it (`onto_axis`)."""
    n = r.K_t.shape[0]
    A = np.block([[-0.5 * r.G_t, np.eye(n)], [0.25 * r.G_t @ r.G_t - r.K_t, -0.5 * r.G_t]])
    values, right, condition = general_eigen(A)
    norm = float(np.abs(A).sum(axis=0).max())
    values = onto_axis(values, FACTOR * EPS * norm * condition)
    return values, right[:n], condition, None


def skew_eigen(K_t: NDArray[np.float64], G_t: NDArray[np.float64],
               stiffness: tuple[NDArray[np.float64], NDArray[np.float64], float]
                    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64],
                          tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64]]]:
    """Eigenpairs of the real skew-symmetric A = [[0, F^T], [-F, -G~]] through eigh(i A).

    Also those of A^-1 = [[-F^-1 G~ F^-T, -F^-1], [F^-T, 0]], skew-symmetric too, whose
    eigenvalues 1/lambda give the small frequencies to high relative accuracy.
    """
    n = K_t.shape[0]
    k_scale, k_lower, _ = stiffness
    F = k_lower / k_scale[:, None]                     # K~ = F F^T
    F_inverse = la.solve_triangular(k_lower, np.eye(n), lower=True) * k_scale[None, :]
    A = np.block([[np.zeros((n, n)), F.T], [-F, -G_t]])
    inverse_A = np.block([[-F_inverse @ G_t @ F_inverse.T, -F_inverse], [F_inverse.T, np.zeros((n, n))]])
    out = []
    for matrix, invert in ((A, False), (0.5 * (inverse_A - inverse_A.T), True)):
        mu, Z = la.eigh(1j * matrix)                   # matrix z = -i mu z, exactly imaginary
        values = -1j * mu
        if invert:
            values = 1.0 / np.where(values == 0, np.inf, values)
        positions = Z[n:] / np.where(values == 0, 1.0, values)[None, :]   # v = lambda y
        out.append((values.astype(complex), positions, np.ones(2 * n)))  # normal: condition 1
    return out[0][0], out[0][1], out[0][2], out[1]


def general_eigen(A: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.float64]]:
    """Eigenvalues, right eigenvectors and eigenvalue condition numbers 1 / |y^H x| of A."""
    values, left, right = la.eig(A, left=True, right=True)
    right = (right / np.linalg.norm(right, axis=0)).astype(complex)
    left = left / np.linalg.norm(left, axis=0)
    overlap = np.abs(np.einsum("ij,ij->j", left.conj(), right))
    return values, right, 1.0 / np.maximum(overlap, EPS)


def onto_axis(values: NDArray[np.complex128], tolerance: NDArray[np.float64]) -> NDArray[np.complex128]:
    """Hamiltonian spectra: put a simple eigenvalue within `tolerance` of the axis onto it.

    The spectrum is symmetric under lambda -> -conj(lambda). If no other computed eigenvalue
    lies within 2 tolerance of the mirror of lambda, lambda is its own mirror: Re lambda = 0.
    """
    out = values.copy()
    for j, value in enumerate(values):
        if abs(value.real) > tolerance[j]:
            continue
        others = np.delete(values, j)
        if not np.any(np.abs(others + np.conj(value)) <= 2.0 * tolerance[j]):
            out[j] = complex(0.0, value.imag)
    return out
