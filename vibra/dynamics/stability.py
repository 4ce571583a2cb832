"""The highest normal frequency of a system and the stable time step of each integrator.

`integrate` refuses a time step at or beyond STABLE_OMEGA_DT / omega_max: a cheap upper bound of
omega_max first (Gershgorin's, O(nnz)), then its value only when the bound does not settle it
(dense up to `DENSE_OMEGA_MAX` dofs, LAPACK's bisection of the top eigenvalue of a tridiagonal
K~ (a chain), ARPACK otherwise).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray
from scipy.linalg import eigvalsh_tridiagonal

from vibra._core import validate as _validate
from vibra.dynamics.schemes import INTEGRATORS, STABLE_OMEGA_DT

__all__ = ["highest_omega", "gershgorin_omega", "stable_dt", "check_stable", "DENSE_OMEGA_MAX"]

#: Up to this many dofs the highest frequency comes from a dense eigvalsh of K~; above, from
#: LAPACK's bisection of the one it needs where K~ is tridiagonal (a chain), from ARPACK otherwise.
DENSE_OMEGA_MAX = 1500
#: ARPACK restarts allowed for the highest frequency (issue 44: its work bounded, O(restarts x nnz x
#: 20)); the largest eigenvalue of a stiffness matrix converges in a few, and where it does not
#: the Gershgorin bound (`gershgorin_omega`, an upper bound: a smaller, still stable dt) is taken.
ARPACK_RESTARTS = 300



def highest_omega(K: sp.csr_matrix, masses: NDArray[np.float64]) -> float:
    """The largest normal frequency sqrt(max eig(M^-1/2 K M^-1/2)), in rad per time unit (0 if none is positive)."""
    scale = sp.diags(1.0 / np.sqrt(masses))
    K_tilde = (scale @ K @ scale).tocsr()
    n = K_tilde.shape[0]
    if n <= DENSE_OMEGA_MAX:
        top = float(np.linalg.eigvalsh(K_tilde.toarray())[-1])
    elif _is_tridiagonal(K_tilde):
        top = float(eigvalsh_tridiagonal(K_tilde.diagonal(), K_tilde.diagonal(1), select="i",
                                         select_range=(n - 1, n - 1), lapack_driver="stebz")[0])
    else:  # bounded work: ARPACK_RESTARTS x (~20 products with K~); unconverged, the Gershgorin bound (larger: a safe dt)
        try:
            top = float(sla.eigsh(K_tilde, k=1, which="LA", tol=1e-10, maxiter=ARPACK_RESTARTS,
                                  return_eigenvectors=False)[0])
        except sla.ArpackNoConvergence:
            return gershgorin_omega(K, masses)
    return float(np.sqrt(top)) if top > 0 else 0.0


def _is_tridiagonal(matrix: sp.csr_matrix) -> bool:
    coo = matrix.tocoo()
    return bool(np.all(np.abs(coo.row - coo.col) <= 1))


def gershgorin_omega(K: sp.csr_matrix, masses: NDArray[np.float64]) -> float:
    """An upper bound of `highest_omega`: sqrt of the largest absolute row sum of M^-1/2 K M^-1/2 (O(nnz))."""
    root = np.sqrt(masses)
    coo = K.tocoo()
    rows = np.zeros(K.shape[0])
    np.add.at(rows, coo.row, np.abs(coo.data) / (root[coo.row] * root[coo.col]))
    return float(np.sqrt(rows.max())) if rows.size else 0.0


def stable_dt(omega_max: float, integrator: str = "verlet") -> float:
    """The largest stable time step for a highest frequency omega_max: STABLE_OMEGA_DT / omega_max
    (2 / omega_max for velocity Verlet), in the time unit; inf for omega_max = 0.

    Examples
    --------
    >>> round(stable_dt(2.0, "verlet"), 12)
    1.0
    """
    _validate.choice(integrator, "integrator", INTEGRATORS)
    return float("inf") if omega_max <= 0 else STABLE_OMEGA_DT[integrator] / omega_max


def check_stable(K: sp.csr_matrix, masses: NDArray[np.float64], dt: float, integrator: str) -> None:
    omega_max = highest_omega(K, masses)
    if omega_max * dt >= STABLE_OMEGA_DT[integrator]:
        raise ValueError(
            f"dt is {dt:g}, unstable for the highest normal frequency omega_max = {omega_max:.6g}: "
            f"{integrator} is stable for dt < {STABLE_OMEGA_DT[integrator]:.4g} / omega_max = "
            f"{stable_dt(omega_max, integrator):.6g}")
