"""(K~ - sigma I)^-1 as a factorisation (`ShiftedInverse`), the shift below the spectrum (`lowest_shift`), and the
bound of K~'s rounding that lets its inertia go unread (`semidefinite_rounding`): the factor the shift-invert paths
(`vibra.solvers.standard.sparse`) apply.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray

from vibra.solvers.common import EPS, bandwidth, tridiagonal_bands
from vibra.solvers.standard.inertia import negative_pivots, symmetric_lu
from vibra.solvers.standard.ordering import nested_dissection
from vibra.solvers.standard.cholmod import CholmodCholesky, sparse_backend
from vibra.solvers.standard.pardiso import PardisoCholesky

__all__ = ["NearZero", "ShiftedInverse", "lowest_shift", "lowest_shifts", "semidefinite_rounding"]


class ShiftedInverse:
    """(K~ - sigma I)^-1 as a factorisation, and whether sigma lies below the whole spectrum.

    Tridiagonal K~: LAPACK pttrf (LDL^T, O(N)), which succeeds exactly when K~ - sigma I is
    positive definite. Otherwise SuperLU in symmetric mode without pivoting, whose pivots
    give the inertia (Sylvester): no negative pivot means sigma is below every eigenvalue.
    Larger K~ (`ordering.CHOLESKY_FROM` dofs and up) are factorised by a sparse Cholesky, whose success
    is the inertia: MKL PARDISO's where `pypardiso` is installed (``vibra[pardiso]``,
    `vibra.solvers.standard.pardiso`), else CHOLMOD's (cvxopt, `vibra.solvers.standard.cholmod`)
    in nested-dissection order (`vibra.solvers.standard.ordering`; its own AMD order below
    `ordering.DISSECTION_MIN` dofs); SuperLU, in that order too, where neither loads or the shift is
    not below the spectrum.
    """

    def __init__(self, Kt: sp.csr_matrix, sigma: float, *, need_inertia: bool = True) -> None:
        self.n = Kt.shape[0]
        self.below_spectrum = False
        #: eigenvalues below sigma, where the factorisation read them (0 below the spectrum; else SuperLU's pivots)
        self.negatives: int | None = None
        self._pt: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._projected: NDArray[np.float64] | None = None
        self._order: NDArray[np.intp] | None = None
        self._cholesky: PardisoCholesky | CholmodCholesky | None = None
        self.backend = "lapack pttrf"
        if bandwidth(Kt) <= 1:
            d, e = tridiagonal_bands(Kt)
            pttrf = la.get_lapack_funcs("pttrf", dtype=np.float64)
            d_factor, e_factor, info = pttrf(d - sigma, e)
            if info == 0:
                self._pt = (d_factor, e_factor)
                self._pttrs = la.get_lapack_funcs("pttrs", dtype=np.float64)
                self.below_spectrum, self.negatives = True, 0
                return
        shifted = (Kt - sigma * sp.identity(self.n, format="csr")).tocsr()
        backend = sparse_backend(self.n)  # (the budget's estimate asks the same)
        order = None if backend == "pardiso" else nested_dissection(shifted)  # (PARDISO orders its own)
        if backend != "superlu":
            try:
                self._cholesky = PardisoCholesky(shifted) if backend == "pardiso" else CholmodCholesky(shifted, order)
                self.below_spectrum, self.negatives = True, 0
                self.backend = backend
                return
            except ValueError:  # not positive definite: SuperLU (LU) serves, and reads the inertia
                if order is None:
                    order = nested_dissection(shifted)
        self.backend = "superlu"
        self._order = order
        ordering = "MMD_AT_PLUS_A"
        if self._order is not None:
            shifted = shifted[self._order][:, self._order]
            ordering = "NATURAL"
        shifted = shifted.tocsc()
        if need_inertia:
            lu = symmetric_lu(shifted, ordering)  # (None: a zero pivot, sigma numerically an eigenvalue)
            self.negatives = None if lu is None else negative_pivots(lu)
            if self.negatives == 0:
                self._lu = lu
                self.below_spectrum = True
                return
        self._lu = sla.splu(shifted, permc_spec=ordering)

    @property
    def fill(self) -> float:
        """Factor entries one solve reads per row (L and U, or L twice): its cost in units of n."""
        if self._pt is not None:
            return 2.0
        if self._cholesky is not None:
            return 2.0 * self._cholesky.factor_entries / self.n
        return float(self._lu.nnz) / self.n

    def deflated(self, Z: NDArray[np.float64]) -> ShiftedInverse:
        """This factor with the orthonormal columns of Z projected out: P (K~ - sigma I)^-1 P, P = I - Z Z^T (an
        indefinite K~'s pairs below sigma, `sparse._saddle`); it shares the factorisation."""
        other = copy.copy(self)
        other._projected = Z
        return other

    def solve(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """(K~ - sigma I)^-1 x for a vector or a block of columns (one triangular sweep for all)."""
        Z = self._projected
        if Z is None:
            return self._solve(x)
        y = self._solve(x - Z @ (Z.T @ x))
        return y - Z @ (Z.T @ y)

    def _solve(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        if self._pt is not None:
            solution, info = self._pttrs(*self._pt, x)
            return np.asarray(solution)
        if self._cholesky is not None:
            return self._cholesky.solve(x)
        if self._order is None:
            return np.asarray(self._lu.solve(x))
        result = np.empty_like(x)
        result[self._order] = self._lu.solve(np.ascontiguousarray(x[self._order]))
        return result

    def operator(self) -> sla.LinearOperator:
        def apply(x: NDArray[np.float64]) -> NDArray[np.float64]:
            return self.solve(np.asarray(x, dtype=float).reshape(self.n))

        return sla.LinearOperator((self.n, self.n), matvec=apply, dtype=float)


@dataclass(frozen=True)
class NearZero:
    """An indefinite K~'s factor at the small negative shift `lowest_shift` tried first, and how many eigenvalues lie
    below that shift (its inertia): the rest of the spectrum is F = (K~ - sigma I)^-1's positive part, its largest
    values the lowest eigenvalues above sigma (`sparse.lowest_pairs`)."""

    sigma: float
    factor: ShiftedInverse
    below: int


def lowest_shift(Kt: sp.csr_matrix, *, rounding: float | None = None) -> tuple[float, ShiftedInverse]:
    """A negative shift below the whole spectrum, small next to its scale, and its factorisation (`lowest_shifts`)."""
    sigma, factor, _ = lowest_shifts(Kt, rounding=rounding)
    return sigma, factor


def lowest_shifts(Kt: sp.csr_matrix, *, rounding: float | None = None
                  ) -> tuple[float, ShiftedInverse, NearZero | None]:
    """A negative shift below the whole spectrum, small next to its scale, and its factorisation; and, for an
    indefinite K~, the factor at the small shift with the count of eigenvalues below it (`NearZero`; None otherwise,
    or where a zero pivot left the count unread).

    The shift must be negative (a free system's K is singular), small compared with the
    wanted eigenvalues (else Lanczos converges slowly: a naive -1e-3 ||K~|| takes minutes at
    10^5 sites) and large enough to register in floating point: -1e4 eps ||K~|| is ~1e4 ulps
    of the diagonal and below the lowest nonzero eigenvalue of a free chain of up to ~10^6
    sites (pi^2 ||K~|| / 4 n^2). If the factorisation shows eigenvalues below it (an
    indefinite K~), the shift moves below Gershgorin's bound of the spectrum.

    `rounding`: where K~ is positive semidefinite by construction (springs of nonnegative
    stiffness), a bound of the rounding in forming it (`semidefinite_rounding`); when the shift
    lies below -rounding it lies below the spectrum (Weyl), and the pivot signs need not be
    read (SuperLU hands them over only by copying its whole factor: 1.7 s and 1 GB at 50,000 dofs).
    """
    norm = float(abs(Kt).sum(axis=1).max())  # infinity norm, >= ||K~||_2
    sigma = -1e4 * EPS * norm
    if rounding is not None and rounding < -sigma:
        factor = ShiftedInverse(Kt, sigma, need_inertia=False)
        factor.below_spectrum, factor.negatives = True, 0
        return sigma, factor, None
    factor = ShiftedInverse(Kt, sigma)
    if factor.below_spectrum:
        return sigma, factor, None
    near = None if factor.negatives is None else NearZero(sigma, factor, factor.negatives)
    radius = abs(Kt).sum(axis=1).A1 - np.abs(Kt.diagonal())
    lower = float((Kt.diagonal() - radius).min())
    sigma = min(lower, 0.0) - 1e-3 * norm
    return sigma, ShiftedInverse(Kt, sigma, need_inertia=False), near


def semidefinite_rounding(spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None, norm: float
                          ) -> float | None:
    """A bound of ||K~ - B~^T B~||_2 for K~ assembled from springs (B, w), None if some w < 0.

    Each entry of K is a sum of at most t spring terms (t: the most springs on one dof) and
    the mass weighting rounds twice more, so |E_ij| <= (t + 2) eps sum |terms|, and the row
    sums of |terms| are at most 2 ||K~||_inf (each spring adds k to the diagonal and -k off it).
    """
    if spring_factor is None or np.any(np.asarray(spring_factor[1]) < 0):
        return None
    coupling = sp.csr_matrix(spring_factor[0])  # the most stored entries in one of its columns
    most = float(np.bincount(coupling.indices, minlength=coupling.shape[1]).max(initial=0))
    return 2.0 * (most + 2.0) * EPS * norm
