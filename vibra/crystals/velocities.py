"""Group velocities: the slopes of D(q)'s eigenvalues along a direction, degenerate levels resolved.

d omega / dk = (d lambda / dk) / (2 omega), with d lambda / dk the diagonal of V^H (dD/dk) V
(`vibra.crystals.dynamical.derivative_matrices`: analytic for force constants, central
differences for a polar crystal's correction), first-order degenerate perturbation theory within
a degenerate level. The band structure (`vibra.crystals.bands`) uses the slopes to connect its
branches through crossings.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra.crystals.dynamical import check_qpoints, derivative_matrices, phonons, unit_direction

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["eigenvalue_slopes", "group_velocities", "DEGENERACY_BOUNDS"]

#: Two eigenvalues within this many of their error bounds are one degenerate level.
DEGENERACY_BOUNDS = 1e4


def eigenvalue_slopes(derivative: NDArray[np.complex128], values: NDArray[np.float64],
                      basis: NDArray[np.complex128], error: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """(n_q, n) d lambda / dk from dD/dk, with degenerate levels resolved, and the basis that goes with it.

    Within a degenerate level (eigenvalues within DEGENERACY_BOUNDS times their bounds) the
    slopes are the eigenvalues of V_g^H dD V_g (first-order degenerate perturbation theory),
    ascending, and the returned basis is rotated to diagonalise it: its columns are the
    branches that leave the degeneracy with those slopes.
    """
    projected = np.einsum("qia,qij,qjb->qab", basis.conj(), derivative, basis, optimize=True)
    slopes = np.einsum("qaa->qa", projected).real.copy()
    rotated = basis.copy()
    gap = np.diff(values, axis=1) <= DEGENERACY_BOUNDS * (error[:, 1:] + error[:, :-1])
    n = values.shape[1]
    for k in np.nonzero(gap.any(axis=1))[0]:
        start = 0
        while start < n:
            stop = start + 1
            while stop < n and gap[k, stop - 1]:
                stop += 1
            if stop - start > 1:
                block = projected[k, start:stop, start:stop]
                slopes[k, start:stop], turn = np.linalg.eigh(0.5 * (block + block.conj().T))
                rotated[k, :, start:stop] = basis[k, :, start:stop] @ turn
            start = stop
    return slopes, rotated


def group_velocities(crystal: Crystal, qpoints: ArrayLike, direction: ArrayLike) -> NDArray[np.float64]:
    """(n_q, n_branches) group velocities d omega / dk along a Cartesian `direction`, in length / time unit.

    Analytic: d omega / dk = (d lambda / dk) / (2 omega) with d lambda / dk from dD/dk
    (`eigenvalue_slopes`); where |omega| is within its error bound (the acoustic branches at
    Gamma) the velocity is reported as 0 (the slope there depends on the direction of approach:
    see `vibra.crystals.elastic.sound_velocities`).
    """
    q = check_qpoints(qpoints)
    n = unit_direction(direction)
    result = phonons(crystal, q, vectors=True)
    derivative = derivative_matrices(crystal, q, n)
    values = np.sign(result.omega) * result.omega ** 2
    error = 2.0 * np.abs(result.omega) * result.omega_error + result.omega_error ** 2
    slopes, _ = eigenvalue_slopes(derivative, values, cast(NDArray[np.complex128], result.vectors), error)
    zero = np.abs(result.omega) <= result.omega_error
    return np.where(zero, 0.0, slopes / np.where(zero, 1.0, 2.0 * result.omega))
