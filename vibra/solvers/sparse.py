"""The sparse path: a few of the lowest modes (or a band) by shift-invert Lanczos (ARPACK).

The shift is chosen below the spectrum from its scale (`lowest_shift`), so a singular K (a
free system) is never hit; a tridiagonal K~ is factorised with LAPACK pttrf (O(N)), any
other with SuperLU (symmetric mode, minimum-degree ordering of K~ + K~^T). Zero modes are
deflated and the rest rerun (`shift_invert`), and the Lanczos vectors get one Rayleigh-Ritz step.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray

from vibra.solvers.common import (
    DENSE_ALL_LIMIT, EPS, SolveResult, absolute_figures, bandwidth, small_pencil, squared_range,
    tridiagonal_bands,
)
from vibra.solvers.standard import dense_path


class ShiftedInverse:
    """(K~ - sigma I)^-1 as a factorisation, and whether sigma lies below the whole spectrum.

    Tridiagonal K~: LAPACK pttrf (LDL^T, O(N)), which succeeds exactly when K~ - sigma I is
    positive definite. Otherwise SuperLU in symmetric mode without pivoting, whose pivots
    give the inertia (Sylvester): no negative pivot means sigma is below every eigenvalue.
    """

    def __init__(self, Kt: sp.csr_matrix, sigma: float, *, need_inertia: bool = True) -> None:
        self.n = Kt.shape[0]
        self.below_spectrum = False
        self._pt: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        if bandwidth(Kt) <= 1:
            d, e = tridiagonal_bands(Kt)
            pttrf = la.get_lapack_funcs("pttrf", dtype=np.float64)
            d_factor, e_factor, info = pttrf(d - sigma, e)
            if info == 0:
                self._pt = (d_factor, e_factor)
                self._pttrs = la.get_lapack_funcs("pttrs", dtype=np.float64)
                self.below_spectrum = True
                return
        shifted = (Kt - sigma * sp.identity(self.n, format="csr")).tocsc()
        if need_inertia:
            try:
                lu = sla.splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                              options={"SymmetricMode": True})
                pivots = lu.U.diagonal()
                if (pivots > 0).all():
                    self._lu = lu
                    self.below_spectrum = True
                    return
            except RuntimeError:  # a zero pivot: sigma is (numerically) an eigenvalue
                pass
        self._lu = sla.splu(shifted, permc_spec="MMD_AT_PLUS_A")

    def operator(self) -> sla.LinearOperator:
        def apply(x: NDArray[np.float64]) -> NDArray[np.float64]:
            x = np.asarray(x, dtype=float).reshape(self.n)
            if self._pt is not None:
                solution, info = self._pttrs(*self._pt, x)
                return solution
            return self._lu.solve(x)

        return sla.LinearOperator((self.n, self.n), matvec=apply, dtype=float)


def lowest_shift(Kt: sp.csr_matrix) -> tuple[float, ShiftedInverse]:
    """A negative shift below the whole spectrum, small next to its scale, and its factorisation.

    The shift must be negative (a free system's K is singular), small compared with the
    wanted eigenvalues (else Lanczos converges slowly: a naive -1e-3 ||K~|| takes minutes at
    10^5 sites) and large enough to register in floating point: -1e4 eps ||K~|| is ~1e4 ulps
    of the diagonal and below the lowest nonzero eigenvalue of a free chain of up to ~10^6
    sites (pi^2 ||K~|| / 4 n^2). If the factorisation shows eigenvalues below it (an
    indefinite K~), the shift moves below Gershgorin's bound of the spectrum.
    """
    norm = float(abs(Kt).sum(axis=1).max())  # infinity norm, >= ||K~||_2
    sigma = -1e4 * EPS * norm
    factor = ShiftedInverse(Kt, sigma)
    if factor.below_spectrum:
        return sigma, factor
    radius = abs(Kt).sum(axis=1).A1 - np.abs(Kt.diagonal())
    lower = float((Kt.diagonal() - radius).min())
    sigma = min(lower, 0.0) - 1e-3 * norm
    return sigma, ShiftedInverse(Kt, sigma, need_inertia=False)


#: Modes asked of the first shift-invert run, which finds a free system's zero modes (doubled
#: while every one it returns is zero).
PROBE = 8


def _lanczos(Kt: sp.csr_matrix, k: int, sigma: float, inverse: sla.LinearOperator, start: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    values, basis = sla.eigsh(Kt, k=k, sigma=sigma, which="LM", OPinv=inverse, tol=0.0,
                              ncv=min(Kt.shape[0], max(2 * k + 1, 20)), v0=start)
    order = np.argsort(values)
    return values[order], basis[:, order]


def shift_invert(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse | None = None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k eigenpairs of K~ nearest `sigma` by ARPACK shift-invert, ascending.

    Zero modes (a free system) dominate (K~ - sigma I)^-1 by ||K~|| / |sigma| ~ 1e12, and
    ARPACK's stopping test is relative to that dominant value: asked together, the other
    vectors stop with residuals ~1e-4 (eigenvalues fine, second order). So a first small run
    (`PROBE` modes) finds the zero modes (they converge at once), and the rest are computed
    with the zero modes deflated, whose dominant value is then 1 / (lambda_1 - sigma): full
    accuracy. Solves stay accurate once projected (their error lies in the near-null space).
    """
    if factor is None:
        factor = ShiftedInverse(Kt, sigma, need_inertia=False)
    start = np.random.default_rng(0).standard_normal(Kt.shape[0])  # reproducible runs
    inverse = factor.operator()
    scale = float(abs(Kt).sum(axis=1).max())
    probe = min(k, PROBE)
    while True:
        values, basis = _lanczos(Kt, probe, sigma, inverse, start)
        zero = np.abs(values) <= 1e-8 * scale
        if not zero.all() or probe == k:
            break
        probe = min(2 * probe, k)
    if zero.all() or (probe == k and not zero.any()):
        return values, basis
    if not zero.any() or sigma >= 0:
        return _lanczos(Kt, k, sigma, inverse, start)
    Z = np.linalg.qr(basis[:, zero])[0]

    def deflated(x: NDArray[np.float64]) -> NDArray[np.float64]:
        x = np.asarray(x).reshape(-1)
        y = inverse.matvec(x - Z @ (Z.T @ x))
        return y - Z @ (Z.T @ y)

    rest, rest_basis = _lanczos(Kt, k - Z.shape[1], sigma, sla.LinearOperator(Kt.shape, matvec=deflated, dtype=float),
                                start - Z @ (Z.T @ start))
    return np.r_[values[zero], rest], np.column_stack([Z, rest_basis])


def sparse_path(Kt: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None) -> SolveResult:
    """The lowest `n_modes` (or those in `band`) of a sparse K~ by shift-invert Lanczos."""
    Kt = sp.csr_matrix(Kt)
    n = Kt.shape[0]
    if band is not None:
        return _sparse_band(Kt, band, vectors)
    k = int(n_modes)  # type: ignore[arg-type]
    if k >= n - 1:
        return dense_path(Kt, n_modes=n_modes, vectors=vectors, band=None)
    sigma, factor = lowest_shift(Kt)
    values, basis = shift_invert(Kt, k, sigma, factor)
    values, basis = _ritz(Kt, basis)
    result = absolute_figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _sparse_band(Kt: sp.csr_matrix, band: tuple[float, float], vectors: bool) -> SolveResult:
    low, high = squared_range(band)
    n = Kt.shape[0]
    if bandwidth(Kt) <= 1:
        d, e = tridiagonal_bands(Kt)
        inside = la.eigvalsh_tridiagonal(d, e, select="v", select_range=(low, high))
        count = inside.shape[0]
    else:
        count = None
    if count == 0:
        return SolveResult(np.zeros(0), np.zeros((n, 0)) if vectors else None, np.zeros(0), 0.0, 0.0, "sparse")
    if count is None or count > n // 4:
        if n > DENSE_ALL_LIMIT:
            raise ValueError("band selection on a large non-tridiagonal K is not supported; give n_modes")
        return dense_path(Kt, n_modes=None, vectors=vectors, band=band)
    centre = 0.5 * (low + high)
    values, basis = shift_invert(Kt, min(count + 2, n - 2), centre - 1e-9 * (high - low + abs(centre)))
    keep = (values >= low) & (values <= high)
    values, basis = _ritz(Kt, basis[:, keep])
    result = absolute_figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _ritz(Kt: sp.csr_matrix, basis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rayleigh-Ritz on span(basis): diagonalise V^T K~ V against the Gram matrix V^T V."""
    small = basis.T @ (Kt @ basis)
    values, rotation = small_pencil(small, basis.T @ basis)
    return values, basis @ rotation

