"""Transient motion in first-order (state-space) form, by exact exponential integration.

For damping that the normal modes do not diagonalise (non-proportional C) and for gyroscopic
systems (a skew G), `transient_response` cannot move each normal coordinate alone. It writes
M u'' + (C + G) u' + K u = f cos(w t) with the state z = (u, u') as

    z' = A z + b cos(w t),   A = [[0, 1], [-M^-1 K, -M^-1 (C + G)]],   b = (0, M^-1 f),

and makes the force part of the state (Van Loan's construction): with (c, s) = alpha
(cos w t, sin w t), which obey c' = -w s, s' = w c (for w = 0 a single constant c' = 0),

    y = (z, c, s),   y' = B y,   B = [[A, b / alpha, 0], [0, 0, -w], [0, w, 0]],

so that y(t) = exp(B t) y(0) holds exactly: at a resonance, for rigid-body modes under a
constant force, through critical damping (where the eigenvectors of A merge and a modal sum
loses digits) and for an unstable system alike. alpha = ||b||_1 / ||A||_1 balances the force
column against A.

The times are visited in increasing order, each step t_k - t_(k-1) applied as exp(B h) to the
state reached (one matrix exponential per distinct step: a uniform grid needs a handful):
``"dense"`` (scipy.linalg.expm of the (2 n + 2)-square B) up to `DENSE_STATE_MAX` states,
``"sparse"`` (scipy.sparse.linalg.expm_multiply, B sparse, one product sequence per step)
above it when M is diagonal. The rounding of each step is a few ulps of the state; over n_t
steps it adds up to about n_t eps relative.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from vibra.response.matrices import Matrix, as_operator, dense_matrix

#: Largest state size 2 n_dof (+ the force states) for which the dense exponential runs;
#: larger systems with diagonal masses go to the sparse one (expm_multiply).
DENSE_STATE_MAX = 400

#: Largest n_dof with a dense (non-diagonal) M that the state-space path takes (dense 2 n_dof).
DENSE_MASS_MAX = 2000


def state_space_motion(K: Matrix, mass: NDArray[np.float64], D: Matrix | None, times: NDArray[np.float64],
                       force: NDArray[np.float64], omega: float, u0: NDArray[np.float64],
                       v0: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], str]:
    """u(t), u'(t) of M u'' + D u' + K u = f cos(omega t) (D = C + G or None), and the path.

    Exact exponential integration of the augmented first-order system (see the module);
    returns ((n_t, n_dof) displacement, (n_t, n_dof) velocity, ``"dense"`` or ``"sparse"``).
    """
    n_dof = K.shape[0]
    sparse = 2 * n_dof + 2 > DENSE_STATE_MAX and mass.ndim == 1
    if not sparse and n_dof > DENSE_MASS_MAX:
        raise ValueError(f"the state-space transient with a dense mass matrix is dense (2 n_dof = {2 * n_dof}); "
                         f"it takes n_dof <= {DENSE_MASS_MAX}, or diagonal masses")
    A = _first_order(K, mass, D, sparse)
    load = _mass_solve(mass, force)
    n_force = 0 if not load.any() else (1 if omega == 0 else 2)
    state = np.concatenate([u0, v0, np.zeros(n_force)])
    if n_force:
        alpha = float(np.abs(load).sum()) / max(_norm_1(A), 1e-300)
        column = np.concatenate([np.zeros(n_dof), load / alpha])
        state[2 * n_dof] = alpha
        A = _with_force(A, column, omega, n_force, sparse)
    states = _exponential_steps(A, state, times, sparse)
    return states[:, :n_dof], states[:, n_dof:2 * n_dof], "sparse" if sparse else "dense"


def _mass_solve(mass: NDArray[np.float64], x: NDArray[np.float64]) -> NDArray[np.float64]:
    """M^-1 x (x a vector or a matrix) for diagonal masses or a dense SPD M (Cholesky)."""
    if mass.ndim == 1:
        return x / mass[:, None] if x.ndim == 2 else x / mass
    return np.asarray(la.cho_solve(la.cho_factor(mass), x), dtype=float)


def _first_order(K: Any, mass: NDArray[np.float64], D: Any, sparse: bool) -> Any:
    """A = [[0, 1], [-M^-1 K, -M^-1 D]]: dense ndarray, or CSR when `sparse` (M diagonal)."""
    n_dof = K.shape[0]
    if sparse:
        inverse = sp.diags(1.0 / mass)
        lower = [-(inverse @ sp.csr_matrix(as_operator(K, n_dof))),
                 -(inverse @ sp.csr_matrix(as_operator(D, n_dof)))]
        return sp.bmat([[None, sp.identity(n_dof)], lower], format="csr")
    top = np.hstack([np.zeros((n_dof, n_dof)), np.eye(n_dof)])
    blocks = -_mass_solve(mass, np.hstack([dense_matrix(K, n_dof), dense_matrix(D, n_dof)]))
    return np.vstack([top, blocks])


def _with_force(A: Any, column: NDArray[np.float64], omega: float, n_force: int, sparse: bool) -> Any:
    """B = [[A, column, 0], [0, 0, -omega], [0, omega, 0]] (n_force = 2), or [[A, column], [0, 0]] (1)."""
    rotation = np.array([[0.0, -omega], [omega, 0.0]])[:n_force, :n_force]
    feed = np.zeros((column.size, n_force))
    feed[:, 0] = column
    if sparse:
        return sp.bmat([[A, sp.csr_matrix(feed)], [None, sp.csr_matrix(rotation)]], format="csr")
    return np.block([[A, feed], [np.zeros((n_force, column.size)), rotation]])


def _norm_1(A: Any) -> float:
    """||A||_1, the largest column sum of |A|."""
    if sp.issparse(A):
        return float(abs(A).sum(axis=0).max()) if A.nnz else 0.0
    return float(np.abs(A).sum(axis=0).max()) if A.size else 0.0


def _exponential_steps(B: Any, start: NDArray[np.float64], times: NDArray[np.float64], sparse: bool,
                       ) -> NDArray[np.float64]:
    """(n_t, size) y(t_k) = exp(B t_k) y(0), marching through the sorted times.

    Steps of equal length (exactly, as floats) share one dense exponential.
    """
    order = np.argsort(times, kind="stable")
    states = np.empty((times.size, start.size))
    current, now = start.astype(float), 0.0
    cache: dict[float, NDArray[np.float64]] = {}
    for k in order:
        step = float(times[k]) - now
        if step > 0:
            if sparse:
                current = np.asarray(spla.expm_multiply(B * step, current), dtype=float)
            else:
                propagator = cache.get(step)
                if propagator is None:
                    propagator = np.asarray(la.expm(B * step), dtype=float)
                    if len(cache) < 64:
                        cache[step] = propagator
                current = propagator @ current
            now = float(times[k])
        states[k] = current
    return states
