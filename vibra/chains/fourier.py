"""Exact normal modes of uniform and diatomic rings by Fourier (Bloch) modes."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra.chains.closed_forms import diatomic_eigenvalues
from vibra.modes import Modes
from vibra.system import System, Vibrating

__all__ = ["periodic_modes"]

EPS = float(np.finfo(float).eps)


def _ring_parameters(system: System) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Masses (n,) and bond stiffnesses (n,), bond i joining i and i + 1 mod n, of a ring."""
    if not isinstance(system, Vibrating):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    if system.is_generalized:
        raise ValueError("system is in generalised coordinates; periodic_modes needs a ring of springs")
    factor = system.spring_factor()
    if factor is None:
        raise ValueError("system must be a ring of springs (K = B^T W B); this one has a Hessian given directly")
    coupling, weights = factor
    n = system.n_dof
    coo = sp.coo_matrix(coupling)
    counts = np.bincount(coo.row, minlength=coupling.shape[0])
    if n < 2 or coupling.shape[0] != n or (counts != 2).any() or not np.allclose(np.abs(coo.data), 1.0, rtol=0, atol=0):
        raise ValueError(
            "system is not a periodic chain: periodic_modes needs n springs, each joining two "
            "degrees of freedom with unit weight and no anchors (build it with ends='periodic')"
        )
    order = np.argsort(coo.row, kind="stable")
    cols = coo.col[order].reshape(-1, 2)
    signs = coo.data[order].reshape(-1, 2)
    low, high = cols.min(axis=1), cols.max(axis=1)
    if (signs.sum(axis=1) != 0).any():
        raise ValueError("system is not a periodic chain: a spring does not measure a difference of two dofs")
    bond = np.where(high == low + 1, low, np.where((low == 0) & (high == n - 1), n - 1, -1))
    if n == 2:
        bond = np.array([0, 1])  # both springs join 0 and 1
    if (bond < 0).any() or np.bincount(bond, minlength=n).max() != 1:
        raise ValueError("system is not a periodic chain: its springs do not join i to i + 1 around a ring")
    stiffness = np.empty(n)
    stiffness[bond] = weights
    free = system.free_dofs
    masses = np.repeat(np.asarray(system.masses), system.dim)[free]
    return masses, stiffness


def periodic_modes(system: System, n_modes: int | None = None, *, vectors: bool = True) -> Modes:
    """Exact normal modes of a uniform or diatomic ring by Fourier (Bloch) modes.

    The ring's masses and spring constants must repeat with period 1 (monatomic) or 2
    (diatomic, n even). For each allowed wavenumber q a = 2 pi j / n_cells the Bloch problem
    (1x1 or 2x2) is solved in closed form; the complex Bloch mode and its conjugate give two
    real, degenerate modes (the cos and sin parts). Frequencies cost O(N log N) (a sort);
    each requested mode vector costs O(N), so the lowest few modes of a 10^6-site ring are
    cheap.

    Parameters
    ----------
    system : System
        A periodic chain, e.g. ``linear_chain(n, ends="periodic")``, ``diatomic_chain(...,
        ends="periodic")`` or ``beaded_string(n, ends="periodic")``.
    n_modes : int, optional
        Number of lowest modes (all by default). A cut through a degenerate pair keeps the
        cos member.
    vectors : bool
        False returns frequencies only.

    Returns
    -------
    Modes
        solver ``"fourier"``; omega_error = 4 eps |omega|; residual and orthogonality
        measured on the returned vectors; mass = the masses.

    Raises
    ------
    TypeError
        system not a System.
    ValueError
        system not a periodic spring ring, or its masses / springs repeat with a period
        other than 1 or 2; n_modes out of range.

    Examples
    --------
    >>> from vibra.chains import linear_chain
    >>> modes = periodic_modes(linear_chain(4, ends="periodic"), n_modes=3)
    >>> np.round(modes.omega ** 2, 12)
    array([0., 2., 2.])
    """
    vectors = _validate.boolean(vectors, "vectors")
    masses, stiffness = _ring_parameters(system)
    n = masses.shape[0]
    if n_modes is not None:
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n)
    if (masses == masses[0]).all() and (stiffness == stiffness[0]).all():
        m1 = m2 = float(masses[0])
        k1 = k2 = float(stiffness[0])
        period = 1
    elif n % 2 == 0 and (masses[0::2] == masses[0]).all() and (masses[1::2] == masses[1]).all() and (
            stiffness[0::2] == stiffness[0]).all() and (stiffness[1::2] == stiffness[1]).all():
        m1, m2 = float(masses[0]), float(masses[1])
        k1, k2 = float(stiffness[0]), float(stiffness[1])
        period = 2
    else:
        raise ValueError(
            "system's masses and springs must repeat with period 1 or 2 for Fourier modes; "
            "use system.modes() for other rings"
        )
    n_cells = n // period
    j = np.arange(n_cells // 2 + 1)
    parts = np.where((j == 0) | (2 * j == n_cells), 1, 2)
    phase = 2.0 * np.pi * j / n_cells
    if period == 1:
        branches = [4.0 * (k1 / m1) * np.sin(0.5 * phase) ** 2]
    else:
        branches = list(diatomic_eigenvalues(phase, m1, m2, k1, k2))
    # One row per real mode: (lambda, branch, j, part).
    lam = np.concatenate([np.repeat(b, parts) for b in branches])
    branch = np.concatenate([np.full(parts.sum(), b) for b in range(period)])
    jj = np.tile(np.repeat(j, parts), period)
    starts = np.cumsum(parts) - parts
    part = np.tile(np.arange(parts.sum()) - np.repeat(starts, parts), period)
    if n_modes is not None and n_modes < n:
        # O(N) preselection: every mode at or below the n_modes-th smallest value (ties kept).
        cutoff = np.partition(lam, n_modes - 1)[n_modes - 1]
        candidates = np.flatnonzero(lam <= cutoff)
        order = candidates[np.lexsort((part[candidates], jj[candidates], branch[candidates],
                                       lam[candidates]))][:n_modes]
    else:
        order = np.lexsort((part, jj, branch, lam))
    lam_max = float(max(b.max() for b in branches))
    lam, branch, jj, part = lam[order], branch[order], jj[order], part[order]
    omega = np.sqrt(lam)
    omega_error = 4.0 * EPS * omega
    if not vectors:
        return Modes(omega=omega, vectors=None, shapes=None, mass=masses, omega_error=omega_error,
                     residual=float("nan"), orthogonality=float("nan"), solver="fourier", units=system.units)
    cell = np.arange(n_cells)[:, None]
    angle = 2.0 * np.pi * ((jj[None, :] * cell) % n_cells) / n_cells  # (n_cells, k)
    wave = np.exp(1j * angle)
    scale = np.where((jj == 0) | (2 * jj == n_cells), 1.0, np.sqrt(2.0)) / np.sqrt(n_cells)
    if period == 1:
        amplitude = np.ones((1, len(order)), dtype=complex)
    else:
        theta = 2.0 * np.pi * jj / n_cells
        d1, d2 = (k1 + k2) / m1, (k1 + k2) / m2
        h = (k1 + k2 * np.exp(-1j * theta)) / np.sqrt(m1 * m2)
        first = np.stack([h, d1 - lam])
        second = np.stack([d2 - lam + 0j, np.conj(h)])
        use_first = np.linalg.norm(first, axis=0) >= np.linalg.norm(second, axis=0)
        amplitude = np.where(use_first[None, :], first, second)
        amplitude /= np.linalg.norm(amplitude, axis=0)
    d = np.empty((n, len(order)))
    for site in range(period):
        bloch = wave * amplitude[site][None, :]
        d[site::period] = np.where(part[None, :] == 0, bloch.real, bloch.imag) * scale[None, :]
    # Re / Im of a Bloch mode at j = 0 or n_cells / 2 is real already; normalise exactly.
    d /= np.linalg.norm(d, axis=0)
    root_mass = np.sqrt(masses)[:, None]
    K = system.hessian()
    applied = (K @ (d / root_mass)) / root_mass
    residual = float(np.max(np.linalg.norm(applied - d * lam[None, :], axis=0)) / lam_max)
    gram = d.T @ d
    orthogonality = float(np.max(np.abs(gram - np.eye(gram.shape[0]))))
    return Modes(omega=omega, vectors=d, shapes=d / root_mass, mass=masses, omega_error=omega_error,
                 residual=residual, orthogonality=orthogonality, solver="fourier", units=system.units)
