"""The spring factor of a spring crystal: D(q) = A(q)^H A(q), frequencies as singular values of A(q).

For a spring model every bond b (atom i in cell 0 to atom j in cell R, unit vector e) gives one
row per stiffness direction d (e itself with k_l; two directions across e with k_t when k_t > 0):

    A_b(q) = sqrt(k) d^T (e^{2 pi i q.R} P_j - P_i) M^-1/2,

P_i picking atom i's three displacements. Then A^H A is D(q) in the ``cell`` phase convention
(`vibra.crystals.dynamical`), and the frequencies are the singular values of A(q): omega itself,
not omega^2. LAPACK's SVD (after a stacked QR when A has more rows than columns) errs by about
eps ||A|| on omega, so an acoustic branch at |q| a keeps a relative accuracy of about eps / (|q| a)
(1e-10 at |q| a = 1e-6) where the eigenvalues of D lose eps / (|q| a)^2 (docs/architecture.md, "Accuracy").
For a bond from an atom to its own image the two terms are one, e^{2 pi i q.R} - 1, formed as
2 i sin(pi q.R) e^{i pi q.R} without cancellation: for a one-atom cell every entry of A is then
O(|q| a) and the acoustic frequencies keep full relative accuracy. Singular values are never
negative: no spring crystal is reported unstable.

Near Gamma (|k| r_max < REFINE_KR, k the wave vector folded to the nearest reciprocal lattice
point, r_max the longest bond) a crystal with a basis loses relative accuracy on its acoustic
branches: their small singular values come from cancelling columns of A (measured 1.3e-10
relative at |q| a = 1e-6 for diamond). There the frequencies are refined one q-point at a
time: A is taken to the basis T = [uniform translations | their orthogonal complement], whose
acoustic columns A t_a = sqrt(k / M) d_a 2 i sin(pi q.R) e^{i pi q.R} are formed without
cancellation (O(|q| a), like a one-atom cell's), and the singular values of A T (a real
embedding [[Re, -Im], [Im, Re]], each value twice) come from LAPACK's preconditioned Jacobi SVD
dgejsv, accurate relative to each value for a matrix that is well conditioned once its columns
are scaled (Demmel and Veselic): measured 2e-16 relative at |q| a = 1e-2 .. 1e-8. Their bound is
(2 n_rows + 32) eps cond(A T D^-1) omega, D the column norms. The eigenvectors there stay the
batched SVD's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.common import EPS
from vibra.solvers.standard.lapack import DENSE_FLOOR

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle
    from vibra.crystals.force_constants import SpringModel

__all__ = ["factor_rows", "factor_matrices", "singular_frequencies", "REFINE_KR"]

#: Complex entries per chunk of the stacked A(q) (~1 MiB; the QR and SVD take a few times that),
#: as `vibra.crystals.dynamical.CHUNK_ENTRIES`: memory bounded by the chunk, not by the q-points.
CHUNK_ENTRIES = 1 << 16
#: q-points with |k| r_max below this (k folded to the nearest reciprocal lattice point) have
#: their frequencies refined by the Jacobi SVD of A T (module docstring).
REFINE_KR = 1e-2


def factor_rows(springs: SpringModel) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """(bond of each row, (n_rows, 3) direction, (n_rows,) sqrt(stiffness)): one row per bond and direction."""
    unit = springs.vectors / np.linalg.norm(springs.vectors, axis=1)[:, None]
    # two directions across each bond: any orthonormal pair, from the axis least aligned with e
    helper = np.eye(3)[np.argmin(np.abs(unit), axis=1)]
    across1 = np.cross(unit, helper)
    across1 /= np.linalg.norm(across1, axis=1)[:, None]
    across2 = np.cross(unit, across1)
    bonds = np.arange(unit.shape[0])
    bending = springs.transverse > 0
    bond = np.concatenate([bonds, bonds[bending], bonds[bending]])
    direction = np.concatenate([unit, across1[bending], across2[bending]])
    root = np.sqrt(np.concatenate([springs.longitudinal, springs.transverse[bending], springs.transverse[bending]]))
    return bond.astype(np.intp), direction, root


def factor_matrices(crystal: Crystal, qpoints: NDArray[np.float64], springs: SpringModel
                    ) -> NDArray[np.complex128]:
    """(n_q, n_rows, 3 n_atoms) A(q) = W^1/2 B(q) M^-1/2 in the ``cell`` phase convention."""
    bond, direction, root = factor_rows(springs)
    i, j = springs.first[bond], springs.second[bond]
    angle = np.pi * (qpoints @ springs.translations[bond].T.astype(float))  # (n_q, n_rows): half the phase
    n_rows = bond.size
    a = np.zeros((qpoints.shape[0], n_rows, crystal.n_branches), dtype=complex)
    rows = np.arange(n_rows)[:, None]
    scaled_i = direction * (root / np.sqrt(crystal.masses[i]))[:, None]
    scaled_j = direction * (root / np.sqrt(crystal.masses[j]))[:, None]
    other = i != j
    half = np.exp(1j * angle)
    if other.any():
        r = rows[other]
        a[:, r, 3 * i[other, None] + np.arange(3)] = -scaled_i[other]
        a[:, r, 3 * j[other, None] + np.arange(3)] = (half[:, other] ** 2)[:, :, None] * scaled_j[other]
    same = ~other
    if same.any():
        r = rows[same]
        coefficient = 2j * np.sin(angle[:, same]) * half[:, same]  # e^{2 i x} - 1 without cancellation
        a[:, r, 3 * i[same, None] + np.arange(3)] = coefficient[:, :, None] * scaled_i[same]
    return a


def singular_frequencies(crystal: Crystal, qpoints: NDArray[np.float64], springs: SpringModel, *,
                         vectors: bool) -> tuple[NDArray[np.float64], NDArray[np.complex128] | None,
                                                 NDArray[np.float64]]:
    """omega ascending (n_q, 3n), eigenvectors of D in the ``cell`` phase (n_q, 3n, 3n) or None, and error bounds.

    The bound is (max(n_rows, 3n) + 32) eps ||A||_F on omega (backward-stable QR and SVD).
    """
    n3 = crystal.n_branches
    n_rows = factor_rows(springs)[0].size
    omega = np.empty((qpoints.shape[0], n3))
    error = np.empty_like(omega)
    basis = np.empty((qpoints.shape[0], n3, n3), dtype=complex) if vectors else None
    size = max(1, CHUNK_ENTRIES // max(1, (n_rows + n3) * n3))
    for start in range(0, qpoints.shape[0], size):
        part = slice(start, start + size)
        a = factor_matrices(crystal, qpoints[part], springs)
        norm = np.sqrt((np.abs(a) ** 2).sum(axis=(1, 2)))
        if n_rows > n3:
            a = np.linalg.qr(a, mode="r")  # (n_q, 3n, 3n), same singular values
        elif n_rows < n3:
            a = np.concatenate([a, np.zeros((a.shape[0], n3 - n_rows, n3), dtype=complex)], axis=1)
        if basis is not None:
            _, sigma, right = np.linalg.svd(a)
            basis[part] = np.conj(np.transpose(right, (0, 2, 1)))[:, :, ::-1]
        else:
            sigma = np.linalg.svd(a, compute_uv=False)
        omega[part] = sigma[:, ::-1]
        error[part] = ((max(n_rows, n3) + DENSE_FLOOR) * EPS * norm)[:, None]
    if crystal.n_atoms > 1:
        folded = qpoints - np.round(qpoints)
        reach = np.linalg.norm(folded @ crystal.reciprocal, axis=1) * float(np.linalg.norm(springs.vectors, axis=1).max())
        for k in np.nonzero(reach < REFINE_KR)[0]:
            refined = _jacobi_frequencies(crystal, folded[k], springs)
            if refined is not None:
                omega[k], error[k] = refined
    return omega, basis, error


def _jacobi_frequencies(crystal: Crystal, q: NDArray[np.float64], springs: SpringModel
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """omega ascending and bounds at one q near Gamma by dgejsv on A T (module docstring); None if it fails."""
    from scipy.linalg import lapack

    n3 = crystal.n_branches
    bond, direction, root = factor_rows(springs)
    total = float(crystal.masses.sum())
    uniform = np.zeros((n3, 3))
    for atom in range(crystal.n_atoms):
        uniform[3 * atom:3 * atom + 3] = np.eye(3) * np.sqrt(crystal.masses[atom] / total)
    basis, _ = np.linalg.qr(np.hstack([uniform, np.eye(n3)]))
    theta = np.pi * (springs.translations[bond] @ q)
    acoustic = (root / np.sqrt(total) * 2j * np.sin(theta) * np.exp(1j * theta))[:, None] * direction
    a = np.hstack([acoustic, factor_matrices(crystal, q[None, :], springs)[0] @ basis[:, 3:n3]])
    if a.shape[0] < n3:
        return None
    embedded = np.block([[a.real, -a.imag], [a.imag, a.real]])
    norms = np.linalg.norm(embedded, axis=0)
    if not (norms > 0).all():
        return None
    values, _, _, work, _, info = lapack.dgejsv(embedded, joba=1, jobu=3, jobv=3)
    if info != 0 or not np.isfinite(values).all() or work[1] == 0:
        return None
    sigma = np.sort(values * (work[0] / work[1]))[::2]
    scaled = np.linalg.svd(embedded / norms, compute_uv=False)
    condition = float(scaled[0] / scaled[-1]) if scaled[-1] > 0 else np.inf
    bound = (2 * a.shape[0] + DENSE_FLOOR) * EPS * condition * sigma
    return sigma, bound
