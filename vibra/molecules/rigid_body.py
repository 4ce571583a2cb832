"""Rigid-body motions of a molecule: linearity, translation and rotation vectors, soft modes."""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate

__all__ = ["SoftModeWarning", "is_linear", "rigid_body_vectors", "expected_rigid_count", "warn_soft_modes",
           "principal_moments"]


class SoftModeWarning(UserWarning):
    """The force field leaves more zero-frequency modes than rigid-body motions explain."""


def is_linear(positions: ArrayLike, masses: ArrayLike, *, rtol: float = 1e-6) -> bool:
    """True when the smallest principal moment of inertia is <= rtol times the largest.

    Relative, so it does not depend on the size or the units of the molecule. A single atom
    is not linear (it has no rotations at all).

    Examples
    --------
    >>> is_linear([[-1.16, 0, 0], [0, 0, 0], [1.16, 0, 0]], [16.0, 12.0, 16.0])
    True
    >>> is_linear([[0, 0, 0], [0.76, 0.59, 0], [-0.76, 0.59, 0]], [16.0, 1.0, 1.0])
    False
    """
    x = _validate.real_array(positions, "positions", ndim=2)
    m = _validate.real_array(masses, "masses", ndim=1)
    if len(x) < 2:
        return False
    moments = _principal_moments(x, m)[0]
    return bool(moments[0] <= rtol * moments[-1])


def _principal_moments(x: NDArray[np.float64], m: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    centred = x - (m[:, None] * x).sum(0) / m.sum()
    if x.shape[1] < 3:
        centred = np.pad(centred, ((0, 0), (0, 3 - x.shape[1])))
    r2 = np.sum(centred**2, axis=1)
    inertia = np.sum(m * r2) * np.eye(3) - np.einsum("i,ia,ib->ab", m, centred, centred)
    return np.linalg.eigh(inertia)


def rigid_body_vectors(positions: ArrayLike, masses: ArrayLike, *, linear_rtol: float = 1e-6) -> NDArray[np.float64]:
    """(n_sites * dim, n_rigid) orthonormal mass-weighted translations and rotations.

    Translations sqrt(m_i) e_a; rotations sqrt(m_i) (n_a x (r_i - r_com)) about the principal
    axes with a non-zero moment (the molecular axis of a linear molecule is left out, as is
    every rotation of a single atom). In 2-D the one in-plane rotation, in 1-D none.

    Examples
    --------
    >>> import numpy as np
    >>> t = rigid_body_vectors([[-1.16, 0, 0], [0, 0, 0], [1.16, 0, 0]], [16.0, 12.0, 16.0])
    >>> t.shape, bool(np.allclose(t.T @ t, np.eye(5)))     # 3 translations, 2 rotations
    ((9, 5), True)
    """
    x = _validate.real_array(positions, "positions", ndim=2)
    m = _validate.real_array(masses, "masses", ndim=1)
    n, dim = x.shape
    sqrt_m = np.sqrt(m)
    columns = []
    for a in range(dim):
        t = np.zeros((n, dim))
        t[:, a] = sqrt_m
        columns.append(t.ravel())
    if n > 1 and dim > 1:
        centred = x - (m[:, None] * x).sum(0) / m.sum()
        if dim == 2:
            rotation = np.stack([-centred[:, 1], centred[:, 0]], axis=1) * sqrt_m[:, None]
            columns.append(rotation.ravel())
        else:
            moments, axes = _principal_moments(x, m)
            for k in range(3):
                if moments[k] <= linear_rtol * moments[-1]:
                    continue
                columns.append((np.cross(axes[:, k], centred) * sqrt_m[:, None]).ravel())
    vectors = np.array(columns).T
    q, _ = np.linalg.qr(vectors)
    return q



def expected_rigid_count(positions: NDArray[np.float64], masses: NDArray[np.float64], linear_rtol: float) -> int:
    dim = positions.shape[1]
    if len(positions) == 1:
        return dim
    if dim == 1:
        return 1
    if dim == 2:
        return 3
    return 5 if is_linear(positions, masses, rtol=linear_rtol) else 6


def warn_soft_modes(n_zero: int, n_rigid: int, name: str, remedy: str, stacklevel: int = 3) -> None:
    """One `SoftModeWarning` when `n_zero` zero-frequency modes exceed the `n_rigid` rigid-body
    motions; `remedy` says what to pass or change."""
    if n_zero > n_rigid:
        warnings.warn(
            f"{name}: {n_zero - n_rigid} motion(s) have no restoring force: the force field leaves {n_zero} "
            f"zero-frequency modes but the geometry allows only {n_rigid} rigid-body ones; {remedy}",
            SoftModeWarning, stacklevel=stacklevel,
        )


def principal_moments(positions: ArrayLike, masses: ArrayLike) -> NDArray[np.float64]:
    """(3,) principal moments of inertia about the centre of mass, ascending, in mass * length^2.

    Amu Angstrom^2 for a molecule in ASE units; 1-D and 2-D positions are padded with zeros.

    Examples
    --------
    >>> principal_moments([[-1.0, 0, 0], [0, 0, 0], [1.0, 0, 0]], [16.0, 12.0, 16.0]).tolist()
    [0.0, 32.0, 32.0]
    """
    x = _validate.real_array(positions, "positions", ndim=2)
    m = _validate.real_array(masses, "masses", ndim=1)
    if m.shape[0] != x.shape[0]:
        raise ValueError(f"masses must have {x.shape[0]} entries (one per position), got {m.shape[0]}")
    return np.clip(_principal_moments(x, m)[0], 0.0, None)
