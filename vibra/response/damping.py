"""Damping models: friction C = eta M (Kneller, Mécanique analytique, eqs. 64-66), Rayleigh C = a M + b K,
modal damping.

`modal_damping` turns any of them (or modal damping ratios) into the damping c_k of each
modal equation q'' + c_k q' + omega_k^2 q = phi_k^T f, refusing a C that the normal modes
do not diagonalise.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.response.matrices import Matrix, as_operator


def friction_damping(M: ArrayLike, eta: float) -> NDArray[np.float64] | sp.csr_matrix:
    """Kneller's friction damping C = eta M (eqs. 64-66), in mass per time unit.

    Parameters
    ----------
    M : (n_dof,) or (n_dof, n_dof) array_like
        Diagonal masses (gives a sparse diagonal C) or a dense SPD mass matrix.
    eta : float
        Friction rate >= 0, in 1 / time unit. Each mode's damping ratio is eta / (2 omega_k).

    Raises
    ------
    ValueError
        eta negative or not finite; M not positive.

    Examples
    --------
    >>> friction_damping([1.0, 2.0], 0.1).toarray()
    array([[0.1, 0. ],
           [0. , 0.2]])
    """
    rate = _validate.real_scalar(eta, "eta")
    if rate < 0:
        raise ValueError(f"eta is {rate!r}; the friction rate must be >= 0 (no negative damping)")
    mass = _validate.real_array(M, "M", ndim=(1, 2))
    mass = _validate.mass_argument(mass, mass.shape[0], "M")
    if mass.ndim == 1:
        return sp.diags(rate * mass, format="csr")
    return rate * mass


def rayleigh_damping(K: ArrayLike | sp.spmatrix, M: ArrayLike, a: float, b: float,
                     ) -> NDArray[np.float64] | sp.csr_matrix:
    """Rayleigh damping C = a M + b K, in mass per time unit.

    Parameters
    ----------
    K : (n_dof, n_dof) array_like or scipy.sparse matrix
        Stiffness, in force per length.
    M : (n_dof,) or (n_dof, n_dof) array_like
        Masses or mass matrix.
    a : float
        Mass-proportional coefficient >= 0, in 1 / time unit.
    b : float
        Stiffness-proportional coefficient >= 0, in time unit.

    Returns
    -------
    (n_dof, n_dof) CSR matrix when K is sparse or M a vector, dense ndarray otherwise. The
    damping ratio of a mode of angular frequency w is `rayleigh_damping_ratio` (w, a, b).

    Raises
    ------
    ValueError
        a or b negative or not finite; K not square; M not matching K.

    Examples
    --------
    >>> import numpy as np
    >>> rayleigh_damping(np.array([[2.0, -1.0], [-1.0, 2.0]]), [1.0, 1.0], 0.1, 0.01).toarray()
    array([[ 0.12, -0.01],
           [-0.01,  0.12]])
    """
    alpha = _validate.real_scalar(a, "a")
    beta = _validate.real_scalar(b, "b")
    for name, value in (("a", alpha), ("b", beta)):
        if value < 0:
            raise ValueError(f"{name} is {value!r}; Rayleigh coefficients must be >= 0 (no negative damping)")
    stiffness = _validate.square_matrix(K, "K")
    mass = _validate.mass_argument(M, stiffness.shape[0], "M")
    if sp.issparse(stiffness) or mass.ndim == 1:
        mass_matrix = sp.diags(mass) if mass.ndim == 1 else sp.csr_matrix(mass)
        return sp.csr_matrix(alpha * mass_matrix + beta * sp.csr_matrix(stiffness))
    return alpha * mass + beta * stiffness


def rayleigh_damping_ratio(omega: ArrayLike, a: float, b: float) -> NDArray[np.float64]:
    """zeta(w) = a / (2 w) + b w / 2 of Rayleigh damping C = a M + b K (dimensionless).

    The mode of angular frequency w_k has exactly this damping ratio, since
    phi_k^T C phi_k = a + b w_k^2 = 2 zeta_k w_k.

    Parameters
    ----------
    omega : float or (n,) array_like
        Angular frequencies > 0, in rad per time unit.
    a, b : float
        Rayleigh coefficients >= 0 (1 / time unit, time unit).

    Examples
    --------
    >>> float(rayleigh_damping_ratio(2.0, 0.4, 0.1))   # 0.4 / 4 + 0.1 * 2 / 2
    0.2
    """
    w = _validate.real_array(omega, "omega", ndim=(0, 1))
    _validate.positive(np.atleast_1d(w), "omega", "angular frequency")
    alpha = _validate.real_scalar(a, "a")
    beta = _validate.real_scalar(b, "b")
    for name, coefficient in (("a", alpha), ("b", beta)):
        if coefficient < 0:
            raise ValueError(f"{name} is {coefficient!r}; Rayleigh coefficients must be >= 0 (no negative damping)")
    ratio = alpha / (2.0 * w) + 0.5 * beta * w
    return ratio[()] if np.ndim(ratio) == 0 else ratio


def rayleigh_coefficients(omega_1: float, omega_2: float, zeta_1: float, zeta_2: float,
                          ) -> tuple[float, float]:
    """(a, b) of the Rayleigh damping with ratio zeta_1 at omega_1 and zeta_2 at omega_2.

    Solves a / (2 w_i) + b w_i / 2 = zeta_i for i = 1, 2 (a in 1/time unit, b in time unit).

    Raises
    ------
    ValueError
        Frequencies not positive or equal; ratios negative; a solution with a < 0 or b < 0
        (no Rayleigh damping passes through those two points).

    Examples
    --------
    >>> a, b = rayleigh_coefficients(1.0, 10.0, 0.05, 0.05)
    >>> round(a, 12), round(b, 12)
    (0.090909090909, 0.009090909091)
    """
    w1, w2 = _validate.real_scalar(omega_1, "omega_1"), _validate.real_scalar(omega_2, "omega_2")
    z1, z2 = _validate.real_scalar(zeta_1, "zeta_1"), _validate.real_scalar(zeta_2, "zeta_2")
    for name, value in (("omega_1", w1), ("omega_2", w2)):
        if value <= 0:
            raise ValueError(f"{name} is {value!r}; it must be positive")
    for name, value in (("zeta_1", z1), ("zeta_2", z2)):
        if value < 0:
            raise ValueError(f"{name} is {value!r}; a damping ratio must be >= 0")
    if w1 == w2:
        raise ValueError(f"omega_1 and omega_2 are both {w1!r}; they must differ")
    # [1/(2w1), w1/2; 1/(2w2), w2/2] [a; b] = [z1; z2]
    determinant = 0.25 * (w2 / w1 - w1 / w2)
    a = (0.5 * w2 * z1 - 0.5 * w1 * z2) / determinant
    b = (z2 / (2.0 * w1) - z1 / (2.0 * w2)) / determinant
    if a < 0 or b < 0:
        raise ValueError(
            f"the Rayleigh coefficients through (omega_1, zeta_1) = ({w1!r}, {z1!r}) and "
            f"(omega_2, zeta_2) = ({w2!r}, {z2!r}) are a = {a:.6g}, b = {b:.6g}: one is negative"
        )
    return float(a), float(b)


#: Relative size of the off-diagonal part of Phi^T C Phi up to which damping counts as
#: diagonal in the modal basis (proportional damping leaves round-off of a few ulps there).
MODAL_DIAGONAL_RTOL = 1e-8


def modal_projection(shapes: NDArray[np.float64], C: Matrix | None) -> NDArray[np.float64]:
    """(n_modes, n_modes) Phi^T C Phi of a damping matrix C (dense, sparse) on the mode shapes Phi."""
    return np.asarray(shapes.T @ (as_operator(C, shapes.shape[0]) @ shapes), dtype=float)


def is_modal(projected: NDArray[np.float64]) -> bool:
    """Whether Phi^T C Phi is diagonal within MODAL_DIAGONAL_RTOL (C proportional on these modes)."""
    off = projected - np.diag(np.diagonal(projected))
    size = float(np.max(np.abs(projected))) if projected.size else 0.0
    return not (off.size and float(np.max(np.abs(off))) > MODAL_DIAGONAL_RTOL * size)


def modal_damping(shapes: NDArray[np.float64], omega: NDArray[np.float64], C: Matrix | None,
                  damping_ratios: ArrayLike | None, remedy: str, projected: NDArray[np.float64] | None = None
                  ) -> NDArray[np.float64]:
    """(n_modes,) modal damping c_k (q'' + c_k q' + omega_k^2 q = phi_k^T f), in 1 / time unit.

    2 zeta_k |omega_k| from `damping_ratios`, else diag(Phi^T C Phi) when C is diagonal in
    the modal basis (within MODAL_DIAGONAL_RTOL), zero without C; `remedy` ends the error.
    `projected` is Phi^T C Phi when the caller has it already (`modal_projection`).
    """
    n_dof, wanted = shapes.shape
    if damping_ratios is not None:
        ratios = _validate.real_array(damping_ratios, "damping_ratios", ndim=(0, 1))
        ratios = np.broadcast_to(ratios, (wanted,)) if ratios.ndim == 0 else ratios
        if ratios.shape != (wanted,):
            raise ValueError(f"damping_ratios must have {wanted} entries (one per mode), got shape {ratios.shape}")
        _validate.nonnegative(ratios, "damping_ratios", "damping ratio")
        return 2.0 * ratios * np.abs(omega)
    if C is None:
        return np.zeros(wanted)
    if projected is None:
        projected = modal_projection(shapes, C)
    modal_c = np.diagonal(projected).copy()
    if not is_modal(projected):
        off = projected - np.diag(modal_c)
        size, gap = float(np.max(np.abs(projected))), float(np.max(np.abs(off)))
        i, j = np.unravel_index(int(np.argmax(np.abs(off))), off.shape)
        raise ValueError(
            f"C is not diagonal in the modal basis (non-proportional damping): "
            f"|Phi^T C Phi|[{i},{j}] = {gap:.3g} > {MODAL_DIAGONAL_RTOL:g} * {size:.3g}; {remedy}"
        )
    return modal_c

