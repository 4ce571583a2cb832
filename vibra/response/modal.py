"""The modal frequency response: superposition of the lowest normal modes.

For damping that the modes diagonalise (friction, Rayleigh, modal damping ratios), with an
estimate of the error of the dropped modes and an optional residual (static) correction.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import ArrayLike, NDArray

from vibra.modes import Modes, normal_modes
from vibra.response.damping import modal_damping
from vibra.response.matrices import Matrix, as_operator, dense_matrix, mass_times, singular_frequency_error


def _m_norm_rows(mass: NDArray[np.float64], rows: NDArray[np.complex128]) -> NDArray[np.float64]:
    """sqrt(x^H M x) of each row x of `rows`."""
    if mass.ndim == 1:
        return np.sqrt(np.einsum("fi,i,fi->f", rows.conj(), mass, rows).real)
    return np.sqrt(np.einsum("fi,fi->f", rows.conj(), rows @ mass).real.clip(min=0.0))


def _static_flexible(K: Any, mass: NDArray[np.float64], rigid: NDArray[np.float64],
                     force: NDArray[np.float64]) -> NDArray[np.float64]:
    """x with K x = f - M R R^T f and R^T M x = 0 (R: M-orthonormal rigid-body modes).

    The bordered system [[K, M R], [R^T M, 0]] is solved; without rigid-body modes it is K x = f.
    This is K's pseudo-inverse on the flexible subspace: sum over flexible modes of
    phi_k phi_k^T f / omega_k^2.
    """
    n_dof = K.shape[0]
    n_rigid = rigid.shape[1]
    MR = mass_times(mass, rigid) if n_rigid else np.zeros((n_dof, 0))
    if sp.issparse(K) or n_dof > 2000:
        border = sp.csr_matrix(MR)
        system = sp.bmat([[sp.csr_matrix(K), border], [border.T, None]], format="csc")
        rhs = np.concatenate([force, np.zeros(n_rigid)])
        try:
            solution = spla.splu(system).solve(rhs)
        except RuntimeError:
            raise ValueError(
                "K is singular beyond its computed rigid-body modes: the static (residual) "
                "correction needs every zero mode among the kept ones; raise n_modes"
            ) from None
    else:
        system = np.block([[dense_matrix(K, n_dof), MR], [MR.T, np.zeros((n_rigid, n_rigid))]])
        rhs = np.concatenate([force, np.zeros(n_rigid)])
        solution = la.solve(system, rhs, assume_a="sym")
    if not np.all(np.isfinite(solution)):
        raise ValueError("the static (residual) correction failed: K is singular beyond its rigid-body modes")
    return solution[:n_dof]


def modal_response(K: Matrix, mass: NDArray[np.float64], C: Matrix | None, omegas: NDArray[np.float64],
           force: NDArray[np.float64], n_modes: int | None, damping_ratios: ArrayLike | None,
           residual_correction: bool, modes: Modes | None,
           ) -> tuple[NDArray[np.complex128], NDArray[np.float64], int, NDArray[np.float64]]:
    """Modal superposition: (response, truncation error, modes used, their omega)."""
    n_dof = K.shape[0]
    wanted = n_dof if n_modes is None else n_modes
    if modes is None:
        # One extra mode, when there is one, tells how far the first dropped mode lies.
        modes = normal_modes(K, mass, n_modes=min(wanted + 1, n_dof))
    else:
        if not isinstance(modes, Modes):
            raise TypeError(f"modes must be a vibra.Modes, got {type(modes).__name__}")
        if modes.shapes is None:
            raise ValueError("modes has no shapes (computed with vectors=False); the modal method needs them")
        if modes.n_dof != n_dof:
            raise ValueError(f"modes has {modes.n_dof} dofs; K has {n_dof}")
        if modes.n_modes < wanted:
            raise ValueError(f"modes holds {modes.n_modes} modes; n_modes asks for {wanted}")
    shapes_all = np.asarray(modes.shapes)
    omega_all = np.asarray(modes.omega)
    shapes = shapes_all[:, :wanted]
    # Rigid-body modes come out of the eigensolver as round-off (~1e-8 omega_max); they are
    # exactly 0, so that w = 0 is refused for them rather than answered with ~1e16 f.
    rigid_mask = np.asarray(modes.zero_modes())[:wanted]
    omega = np.where(rigid_mask, 0.0, omega_all[:wanted])
    dropped = wanted < n_dof

    # Modal damping c_k (the modal equations are q'' + c_k q' + omega_k^2 q = phi_k^T f).
    modal_c = modal_damping(shapes, omega, C, damping_ratios, "use method='direct' or method='state_space'")
    if damping_ratios is not None:
        next_c = modal_c[-1] * abs(omega_all[wanted]) / max(abs(omega[-1]), 1e-300) if (
            dropped and omega_all.size > wanted) else (modal_c[-1] if modal_c.size else 0.0)
    elif C is None:
        next_c = 0.0
    else:
        if dropped and omega_all.size > wanted:
            extra = shapes_all[:, wanted]
            next_c = float(extra @ (as_operator(C, n_dof) @ extra))
        else:
            next_c = float(modal_c[-1]) if modal_c.size else 0.0

    loads = shapes.T @ force                                           # phi_k^T f
    w = omegas[:, None]
    stable = omega >= 0
    stiffness_term = np.where(stable, (np.abs(omega) - w) * (np.abs(omega) + w), -(omega**2) - w * w)
    denominators = stiffness_term + 1j * w * modal_c
    zero = denominators == 0
    if (zero & (loads != 0)).any():
        first = int(np.argwhere(zero & (loads != 0))[0, 0])
        raise singular_frequency_error(first, float(omegas[first]))
    with np.errstate(divide="ignore", invalid="ignore"):
        coefficients = np.where(zero, 0.0, loads / np.where(zero, 1.0, denominators))
    response = coefficients.real @ shapes.T + 1j * (coefficients.imag @ shapes.T)

    error = np.zeros(omegas.size)
    if dropped:
        rigid = shapes[:, rigid_mask]
        flexible = ~rigid_mask
        static = _static_flexible(K, mass, rigid, force)
        kept_static = shapes[:, flexible] @ (loads[flexible] / omega[flexible] ** 2 * np.sign(omega[flexible]))
        residual = static - kept_static                                # sum over dropped modes
        if residual_correction:
            response = response + residual[None, :]
        lam = float(omega_all[wanted] * abs(omega_all[wanted])) if omega_all.size > wanted else float(
            omega[-1] * abs(omega[-1]))
        factor = _dropped_factor(omegas, lam, next_c, residual_correction)
        residual_norm = float(np.sqrt(residual @ mass_times(mass, residual)))
        norms = _m_norm_rows(mass, response)
        with np.errstate(divide="ignore", invalid="ignore"):
            error = np.where(norms > 0, factor * residual_norm / norms,
                             np.where(factor * residual_norm > 0, np.inf, 0.0))
    return response, error, wanted, omega


def _dropped_factor(omegas: NDArray[np.float64], lam: float, c: float, corrected: bool,
                    ) -> NDArray[np.float64]:
    """sup over dropped modes (lambda_k = omega_k^2 >= lam, damping c) of |g(lambda, w)|.

    The error of the modal sum is sum_dropped phi_k (phi_k^T f / lambda_k) g_k with
    g = lambda / (lambda - w^2 + i w c) (no correction) or (w^2 - i w c) / (lambda - w^2 + i w c)
    (with the static correction), so ||error||_M <= sup |g| * ||r||_M. The sup is taken over a
    geometric grid of lambda >= lam, plus lambda = w^2 when a dropped mode may resonate there.
    """
    grid = lam * np.geomspace(1.0, 1e8, 80)
    w2 = omegas * omegas
    candidates = np.broadcast_to(grid, (omegas.size, grid.size))
    candidates = np.concatenate([candidates, np.maximum(w2, lam)[:, None]], axis=1)
    w = omegas[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        near = candidates - w * w + 1j * w * c
        if corrected:
            values = np.abs((w * w - 1j * w * c) / near)
        else:
            values = np.abs(candidates / near)
    values = np.where(np.isnan(values), np.inf, values)
    return values.max(axis=1)

