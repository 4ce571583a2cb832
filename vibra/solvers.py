"""Solver paths for the mass-weighted eigenproblem K~ d = omega^2 d (seed 003 eqs. 138-143).

`solve` picks a path from the structure of K and from what is asked, unless told:

=================  ==========================================================================
``dense``          LAPACK symmetric eigensolver on the dense K~ (subset by index or value;
                   values only when no vectors are asked). Absolute error ~ eps ||K~||.
``tridiagonal``    K~ tridiagonal (a chain): LAPACK stemr/stebz on its diagonals.
``banded``         K~ banded with a narrow band (a chain in 2-D or 3-D, a ladder): LAPACK
                   sbevd / sbevx on the band storage, O(n b^2) per value.
``sparse``         A few of the lowest modes (or a band) of a large sparse K~: shift-invert
                   Lanczos (ARPACK) with a negative shift chosen from the spectrum's scale, so
                   a singular K (free system) is never hit; tridiagonal K~ is factorised with
                   LAPACK pttrf (O(N)), any other with SuperLU.
``accurate``       The system knows its springs, K = B^T W B: frequencies are the singular
                   values of B~ = W^1/2 B M^-1/2, computed to high *relative* accuracy.
                   - a chain (the springs form a path): dqds on the Golub-Kahan bidiagonal;
                   - few modes of a large system: sparse shift-invert vectors, then a
                     Rayleigh-Ritz step in spring space (H = (B~V)^T (B~V), O(N k));
                   - any other small system: one-sided Jacobi SVD (LAPACK gejsv) of B~.
=================  ==========================================================================

Every path returns a `SolveResult` with an error estimate per eigenvalue, the largest
relative residual and the orthogonality error, which `vibra.modes.Modes` carries.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray

from vibra import _validate
from vibra._lapack import bidiagonal_singular_values, bidiagonal_svd

EPS = float(np.finfo(float).eps)

#: Largest n for which "auto" uses dense LAPACK when a sparse path could serve.
DENSE_LIMIT = 1500
#: Widest half-bandwidth for which "auto" uses the banded solver.
BAND_LIMIT = 16
#: Largest n for which all modes of a general sparse K are computed densely.
DENSE_ALL_LIMIT = 20000
#: Largest chain segment whose vectors come from the bidiagonal SVD (dbdsqr, O(n^3),
#: relatively accurate vectors); longer chains take MRRR vectors (absolute accuracy).
BDSQR_LIMIT = 800
#: Columns sampled for the residual / orthogonality figures of very large results.
SAMPLE = 256


@dataclass
class SolveResult:
    """Raw output of one solver path (internal; `Modes` is the public result).

    eigenvalues : (k,) ascending omega^2; vectors : (n, k) mass-weighted or None;
    error : (k,) absolute error estimate of each eigenvalue; residual, orthogonality: floats.
    """

    eigenvalues: NDArray[np.float64]
    vectors: NDArray[np.float64] | None
    error: NDArray[np.float64]
    residual: float
    orthogonality: float
    solver: str


# ---------------------------------------------------------------------- public helpers
def check_spring_factor(factor: Any, n_dof: int) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    """Validate a spring factor (B, w): B (n_terms, n_dof), w (n_terms,) > 0."""
    if not isinstance(factor, tuple) or len(factor) != 2:
        raise TypeError("spring_factor must be a tuple (B, w)")
    coupling, weights = factor
    b = sp.csr_matrix(coupling, dtype=float)
    if b.shape[1] != n_dof:
        raise ValueError(f"spring_factor B must have {n_dof} columns to match K, got shape {b.shape}")
    _validate.finite(b.data, "spring_factor B")
    w = _validate.real_array(weights, "spring_factor w", ndim=1)
    if w.shape[0] != b.shape[0]:
        raise ValueError(f"spring_factor w must have {b.shape[0]} entries (rows of B), got {w.shape[0]}")
    _validate.positive(w, "spring_factor w", "spring constant")
    return b, w


def physical_shapes(vectors: NDArray[np.float64], mass: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, k) shapes u = M^-1/2 d from mass-weighted vectors d (eq. 151)."""
    if mass.ndim == 1:
        return vectors / np.sqrt(mass)[:, None]
    return _mass_power(mass, -0.5) @ vectors


def _mass_power(mass: NDArray[np.float64], power: float) -> NDArray[np.float64]:
    values, basis = np.linalg.eigh(mass)
    return (basis * values**power) @ basis.T


def mass_weighted(K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64]
                  ) -> NDArray[np.float64] | sp.csr_matrix:
    """K~ = M^-1/2 K M^-1/2 (eq. 139): sparse stays sparse for diagonal M."""
    if mass.ndim == 1:
        scale = 1.0 / np.sqrt(mass)
        if sp.issparse(K):
            return sp.csr_matrix(sp.diags(scale) @ K @ sp.diags(scale))
        return K * scale[:, None] * scale[None, :]
    root = _mass_power(mass, -0.5)
    dense = K if isinstance(K, np.ndarray) else np.asarray(K.toarray())
    weighted = root @ dense @ root
    return 0.5 * (weighted + weighted.T)


# ---------------------------------------------------------------------- dispatch
def solve(
    K: NDArray[np.float64] | sp.csr_matrix,
    mass: NDArray[np.float64],
    *,
    n_modes: int | None,
    vectors: bool,
    band: tuple[float, float] | None,
    solver: str,
    spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None,
) -> SolveResult:
    """Run the solver path `solver` ("auto" chooses) on K~ and return a `SolveResult`."""
    n = K.shape[0]
    Kt = mass_weighted(K, mass)
    width = _bandwidth(Kt) if mass.ndim == 1 else n
    tridiagonal = width <= 1
    partial = n_modes is not None and n_modes < n
    if solver == "auto":
        if spring_factor is not None:
            solver = "accurate"
        elif n <= DENSE_LIMIT:
            solver = "dense"
        elif width <= BAND_LIMIT and not (vectors and (partial or band is not None)):
            # (LAPACK's banded and tridiagonal drivers allocate n x n vectors even for a subset)
            solver = "tridiagonal" if tridiagonal else "banded"
        elif partial or band is not None:
            solver = "sparse"
        else:
            solver = "dense"
    if solver == "dense" and n > DENSE_ALL_LIMIT:
        raise ValueError(
            f"K has {n} dofs: a dense solve would need {8 * n * n / 2**30:.1f} GiB; ask for "
            "n_modes (a partial sparse solve) or use the accurate path of a spring system"
        )
    if solver == "tridiagonal" and not tridiagonal:
        raise ValueError("solver='tridiagonal' needs a tridiagonal K and diagonal masses")
    if solver == "banded" and mass.ndim != 1:
        raise ValueError("solver='banded' needs diagonal masses")
    if solver == "sparse" and n_modes is None and band is None:
        raise ValueError("solver='sparse' computes a few modes: give n_modes or band")
    if solver == "accurate":
        if spring_factor is None:
            raise ValueError("solver='accurate' needs the spring factor (B, w) of K")
        return _accurate(Kt, mass, spring_factor, n_modes=n_modes, vectors=vectors, band=band)
    if solver == "tridiagonal":
        result = _tridiagonal(Kt, n_modes=n_modes, vectors=vectors, band=band)
    elif solver == "banded":
        result = _banded(Kt, width, n_modes=n_modes, vectors=vectors, band=band)
    elif solver == "sparse":
        result = _sparse(Kt, n_modes=n_modes, vectors=vectors, band=band)
    else:
        result = _dense(Kt, n_modes=n_modes, vectors=vectors, band=band)
    return result


# ---------------------------------------------------------------------- standard paths
def _norm_estimate(Kt: NDArray[np.float64] | sp.csr_matrix, eigenvalues: NDArray[np.float64]) -> float:
    """A lower bound of ||K~||_2: max of |computed eigenvalues| and |diagonal| (Rayleigh quotients)."""
    diagonal = Kt.diagonal()
    scale = float(np.abs(diagonal).max()) if diagonal.size else 0.0
    if eigenvalues.size:
        scale = max(scale, float(np.abs(eigenvalues).max()))
    return scale if scale > 0 else 1.0


def _figures(Kt: Any, eigenvalues: NDArray[np.float64], vectors: NDArray[np.float64] | None,
             solver: str, floor: float) -> SolveResult:
    """Residual, orthogonality and error estimates of a standard (absolute-accuracy) path."""
    n = Kt.shape[0]
    norm = _norm_estimate(Kt, eigenvalues)
    # Eigenvalues of a backward-stable symmetric solver are exact for K~ + E, ||E|| ~ eps ||K~||.
    error = np.full(eigenvalues.shape, floor * EPS * norm)
    if vectors is None:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), solver)
    columns = _sample_columns(vectors.shape[1])
    sample = vectors[:, columns]
    residuals = np.linalg.norm(Kt @ sample - sample * eigenvalues[columns], axis=0)
    error[columns] = np.maximum(error[columns], residuals)
    gram = vectors.T @ sample
    gram[columns, np.arange(len(columns))] -= 1.0
    return SolveResult(eigenvalues, vectors, error, float(residuals.max(initial=0.0) / norm),
                       float(np.abs(gram).max(initial=0.0)), solver)


def _sample_columns(k: int) -> NDArray[np.intp]:
    if k <= SAMPLE:
        return np.arange(k)
    # The lowest modes (most at risk) and an even spread of the rest.
    return np.unique(np.concatenate([np.arange(SAMPLE // 2), np.linspace(0, k - 1, SAMPLE // 2).astype(int)]))


def _value_range(band: tuple[float, float]) -> tuple[float, float]:
    low, high = band
    return float(np.sign(low) * low * low), float(np.sign(high) * high * high)


def _dense(Kt: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None) -> SolveResult:
    dense = Kt.toarray() if sp.issparse(Kt) else np.asarray(Kt)
    n = dense.shape[0]
    kwargs: dict[str, Any] = {"eigvals_only": not vectors, "check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs["subset_by_index"] = (0, n_modes - 1)
    elif band is not None:
        kwargs["subset_by_value"] = _value_range(band)
    if vectors:
        values, basis = la.eigh(dense, **kwargs)
    else:
        values, basis = la.eigh(dense, **kwargs), None
    return _figures(dense, np.asarray(values), basis, "dense", floor=float(n))


def _diagonals(Kt: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if sp.issparse(Kt):
        return np.asarray(Kt.diagonal()), np.asarray(Kt.diagonal(1))
    return np.diag(Kt).copy(), np.diag(Kt, 1).copy()


def _tridiagonal(Kt: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None) -> SolveResult:
    d, e = _diagonals(Kt)
    n = d.shape[0]
    kwargs: dict[str, Any] = {"check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs.update(select="i", select_range=(0, n_modes - 1))
    elif band is not None:
        kwargs.update(select="v", select_range=_value_range(band))
    if vectors:
        values, basis = la.eigh_tridiagonal(d, e, **kwargs)
    else:
        values, basis = la.eigvalsh_tridiagonal(d, e, **kwargs), None
    # MRRR / bisection: absolute eigenvalue error O(n eps ||T||).
    return _figures(sp.csr_matrix(Kt), np.asarray(values), basis, "tridiagonal", floor=float(n))


def _banded(Kt: Any, width: int, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None
            ) -> SolveResult:
    matrix = sp.csr_matrix(Kt)
    n = matrix.shape[0]
    storage = np.zeros((width + 1, n))  # lower band storage: storage[i, j] = K~[j + i, j]
    for offset in range(width + 1):
        storage[offset, : n - offset] = matrix.diagonal(-offset)
    kwargs: dict[str, Any] = {"lower": True, "check_finite": False}
    if n_modes is not None and n_modes < n:
        kwargs.update(select="i", select_range=(0, n_modes - 1))
    elif band is not None:
        kwargs.update(select="v", select_range=_value_range(band))
    if vectors:
        values, basis = la.eig_banded(storage, **kwargs)
    else:
        values, basis = la.eigvals_banded(storage, **kwargs), None
    return _figures(matrix, np.asarray(values), basis, "banded", floor=float(n))


def _bandwidth(Kt: Any) -> int:
    if sp.issparse(Kt):
        coo = Kt.tocoo()
        return int(np.abs(coo.row - coo.col).max()) if coo.nnz else 0
    rows, cols = np.nonzero(Kt)
    return int(np.abs(rows - cols).max()) if rows.size else 0


class _ShiftedInverse:
    """(K~ - sigma I)^-1 as a factorisation, and whether sigma lies below the whole spectrum.

    Tridiagonal K~: LAPACK pttrf (LDL^T, O(N)), which succeeds exactly when K~ - sigma I is
    positive definite. Otherwise SuperLU in symmetric mode without pivoting, whose pivots
    give the inertia (Sylvester): no negative pivot means sigma is below every eigenvalue.
    """

    def __init__(self, Kt: sp.csr_matrix, sigma: float, *, need_inertia: bool = True) -> None:
        self.n = Kt.shape[0]
        self.below_spectrum = False
        self._pt: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        if _bandwidth(Kt) <= 1:
            d, e = _diagonals(Kt)
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
                lu = sla.splu(shifted, diag_pivot_thresh=0.0, options={"SymmetricMode": True})
                pivots = lu.U.diagonal()
                if (pivots > 0).all():
                    self._lu = lu
                    self.below_spectrum = True
                    return
            except RuntimeError:  # a zero pivot: sigma is (numerically) an eigenvalue
                pass
        self._lu = sla.splu(shifted)

    def operator(self) -> sla.LinearOperator:
        def apply(x: NDArray[np.float64]) -> NDArray[np.float64]:
            x = np.asarray(x, dtype=float).reshape(self.n)
            if self._pt is not None:
                solution, info = self._pttrs(*self._pt, x)
                return solution
            return self._lu.solve(x)

        return sla.LinearOperator((self.n, self.n), matvec=apply, dtype=float)


def _lowest_shift(Kt: sp.csr_matrix) -> tuple[float, _ShiftedInverse]:
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
    factor = _ShiftedInverse(Kt, sigma)
    if factor.below_spectrum:
        return sigma, factor
    radius = abs(Kt).sum(axis=1).A1 - np.abs(Kt.diagonal())
    lower = float((Kt.diagonal() - radius).min())
    sigma = min(lower, 0.0) - 1e-3 * norm
    return sigma, _ShiftedInverse(Kt, sigma, need_inertia=False)


def _shift_invert(Kt: sp.csr_matrix, k: int, sigma: float, factor: _ShiftedInverse | None = None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if factor is None:
        factor = _ShiftedInverse(Kt, sigma, need_inertia=False)
    start = np.random.default_rng(0).standard_normal(Kt.shape[0])  # reproducible runs
    values, basis = sla.eigsh(Kt, k=k, sigma=sigma, which="LM", OPinv=factor.operator(), tol=0.0,
                              ncv=min(Kt.shape[0], max(2 * k + 1, 20)), v0=start)
    order = np.argsort(values)
    return values[order], basis[:, order]


def _sparse(Kt: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None) -> SolveResult:
    Kt = sp.csr_matrix(Kt)
    n = Kt.shape[0]
    if band is not None:
        return _sparse_band(Kt, band, vectors)
    k = int(n_modes)  # type: ignore[arg-type]
    if k >= n - 1:
        return _dense(Kt, n_modes=n_modes, vectors=vectors, band=None)
    sigma, factor = _lowest_shift(Kt)
    values, basis = _shift_invert(Kt, k, sigma, factor)
    values, basis = _ritz(Kt, basis)
    result = _figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _sparse_band(Kt: sp.csr_matrix, band: tuple[float, float], vectors: bool) -> SolveResult:
    low, high = _value_range(band)
    n = Kt.shape[0]
    if _bandwidth(Kt) <= 1:
        d, e = _diagonals(Kt)
        inside = la.eigvalsh_tridiagonal(d, e, select="v", select_range=(low, high))
        count = inside.shape[0]
    else:
        count = None
    if count == 0:
        return SolveResult(np.zeros(0), np.zeros((n, 0)) if vectors else None, np.zeros(0), 0.0, 0.0, "sparse")
    if count is None or count > n // 4:
        if n > DENSE_ALL_LIMIT:
            raise ValueError("band selection on a large non-tridiagonal K is not supported; give n_modes")
        return _dense(Kt, n_modes=None, vectors=vectors, band=band)
    centre = 0.5 * (low + high)
    values, basis = _shift_invert(Kt, min(count + 2, n - 2), centre - 1e-9 * (high - low + abs(centre)))
    keep = (values >= low) & (values <= high)
    values, basis = _ritz(Kt, basis[:, keep])
    result = _figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _ritz(Kt: sp.csr_matrix, basis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rayleigh-Ritz on span(basis): diagonalise V^T K~ V against the Gram matrix V^T V."""
    small = basis.T @ (Kt @ basis)
    values, rotation = _small_pencil(small, basis.T @ basis)
    return values, basis @ rotation


def _small_pencil(H: NDArray[np.float64], S: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenpairs of the k x k pencil (H, S), S the Gram matrix of a nearly orthonormal basis."""
    return la.eigh(0.5 * (H + H.T), 0.5 * (S + S.T))


# ---------------------------------------------------------------------- accurate paths
def _accurate(Kt: Any, mass: NDArray[np.float64], factor: tuple[sp.csr_matrix, NDArray[np.float64]], *,
              n_modes: int | None, vectors: bool, band: tuple[float, float] | None) -> SolveResult:
    coupling, weights = factor
    n = Kt.shape[0]
    weighted = _weighted_factor(coupling, weights, mass)  # B~ (n_terms, n)
    few = (n_modes is not None and n_modes < n - 1 or band is not None) and n > DENSE_LIMIT
    path = _path_bidiagonals(weighted) if mass.ndim == 1 and not few else None
    if path is not None:
        return _accurate_path(Kt, weighted, path, n_modes=n_modes, vectors=vectors, band=band)
    if few and band is None:
        sigma, shifted = _lowest_shift(sp.csr_matrix(Kt))
        _, basis = _shift_invert(sp.csr_matrix(Kt), int(n_modes), sigma, shifted)  # type: ignore[arg-type]
        return _spring_ritz(weighted, basis, vectors=vectors)
    if few:
        standard = _sparse(Kt, n_modes=None, vectors=True, band=band)
        return _spring_ritz(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    if n > DENSE_LIMIT:
        standard = _dense(Kt, n_modes=None, vectors=True, band=band)
        return _spring_rayleigh(weighted, standard.vectors, vectors=vectors)  # type: ignore[arg-type]
    return _accurate_jacobi(weighted, n_modes=n_modes, vectors=vectors, band=band)


def _weighted_factor(coupling: sp.csr_matrix, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> Any:
    left = sp.diags(np.sqrt(weights))
    if mass.ndim == 1:
        return sp.csr_matrix(left @ coupling @ sp.diags(1.0 / np.sqrt(mass)))
    return np.asarray((left @ coupling).toarray() @ _mass_power(mass, -0.5))


Segment = tuple[int, int, NDArray[np.float64], NDArray[np.float64], int, bool]


def _path_bidiagonals(weighted: sp.csr_matrix) -> list[Segment] | None:
    """Split B~ into chains whose springs form a path; None if the spring graph is not one.

    A path is a run of consecutive dofs c0..c1 joined by one term per neighbouring pair, with
    at most one single-dof term (an anchor) at each end. Its Golub-Kahan bidiagonal is
    returned as (c0, c1, d, e, n_keep, dofs_are_rows): the singular values of the square
    upper bidiagonal (d, e), of which the largest n_keep = c1 - c0 + 1 are the segment's
    frequencies; its dof-space vectors are the left singular vectors when dofs_are_rows.
    """
    b = sp.csr_matrix(weighted)
    b.sort_indices()
    n_terms, n = b.shape
    nnz = np.diff(b.indptr)
    if n_terms and (nnz.min() < 1 or nnz.max() > 2):
        return None
    pair_rows = np.flatnonzero(nnz == 2)
    single_rows = np.flatnonzero(nnz == 1)
    first = b.indices[b.indptr[pair_rows]]
    second = b.indices[b.indptr[pair_rows] + 1]
    if (second != first + 1).any():
        return None
    left_value = np.zeros(n)  # B~[pair(c, c+1), c]
    right_value = np.zeros(n)  # B~[pair(c, c+1), c+1]
    has_pair = np.zeros(n, dtype=bool)
    if np.bincount(first, minlength=n).max(initial=0) > 1:
        return None  # parallel springs between one pair: a cycle
    has_pair[first] = True
    left_value[first] = b.data[b.indptr[pair_rows]]
    right_value[first] = b.data[b.indptr[pair_rows] + 1]
    single_col = b.indices[b.indptr[single_rows]]
    single_val = b.data[b.indptr[single_rows]]
    degree = np.bincount(first, minlength=n) + np.bincount(second, minlength=n) + np.bincount(single_col, minlength=n)
    if degree.max(initial=0) > 2:
        return None
    anchors: dict[int, list[float]] = {}
    for column, value in zip(single_col.tolist(), single_val.tolist()):
        anchors.setdefault(column, []).append(value)
    starts = np.flatnonzero(np.r_[True, ~has_pair[:-1]])
    ends = np.r_[starts[1:] - 1, n - 1]
    segments = []
    for c0, c1 in zip(starts.tolist(), ends.tolist()):
        at_start = anchors.get(c0, [])
        at_end = anchors.get(c1, []) if c1 != c0 else at_start[1:]
        at_start = at_start[:1]
        inner_left = left_value[c0:c1]  # pair c -> value at c
        inner_right = right_value[c0:c1]  # pair c -> value at c+1
        if not at_start:
            # rows = terms, columns = dofs: d_i = value(pair_i, c_i), e_i = value(pair_i, c_i+1)
            d = np.r_[inner_left, at_end[:1] if at_end else [0.0]]
            e = inner_right
        else:
            # rows = dofs, columns = terms (anchor first): transpose of a lower bidiagonal
            d = np.r_[at_start, inner_right]
            e = inner_left
            if at_end:
                d = np.r_[d, 0.0]
                e = np.r_[e, at_end[:1]]
        segments.append((c0, c1, d, e, c1 - c0 + 1, bool(at_start)))
    return segments


def _path_values(segments: list[Segment]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(omega ascending, relative error bound) of all path segments by dqds."""
    omegas = []
    bounds = []
    for _, _, d, e, keep, _ in segments:
        sigma = bidiagonal_singular_values(d, e)[-keep:]
        omegas.append(sigma)
        # Demmel-Kahan: relative entry errors eta perturb each singular value by at most
        # (2 size - 1) eta relative; forming B~ (sqrt, divide) gives eta ~ 3 eps, and dqds's
        # own rounding adds a few eps per step of a size-long sweep: 10 size eps in all.
        bounds.append(np.full(keep, 10 * d.shape[0] * EPS))
    omega = np.concatenate(omegas)
    bound = np.concatenate(bounds)
    order = np.argsort(omega)
    return omega[order], bound[order]


def _accurate_path(Kt: Any, weighted: sp.csr_matrix, segments: Any, *, n_modes: int | None, vectors: bool,
                   band: tuple[float, float] | None) -> SolveResult:
    omega, relative = _path_values(segments)
    n = omega.shape[0]
    select = np.arange(n)
    if n_modes is not None:
        select = select[:n_modes]
    elif band is not None:
        select = select[(omega >= band[0]) & (omega <= band[1])]
    eigenvalues = omega[select] ** 2
    error = 2.0 * relative[select] * eigenvalues
    if not vectors:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-bidiagonal")
    if all(d.shape[0] <= BDSQR_LIMIT for _, _, d, _, _, _ in segments):
        basis = _path_vectors(segments, Kt.shape[0], omega)[:, select]
    else:
        # Vectors from the standard tridiagonal solver (angle error ~ eps ||K~|| / gap),
        # values from dqds: each column is re-paired with the dqds value of the same rank.
        d, e = _diagonals(Kt)
        if select.size == n:
            _, basis = la.eigh_tridiagonal(d, e, check_finite=False)  # MRRR, O(n^2)
        elif select.size:
            _, basis = la.eigh_tridiagonal(d, e, select="i", select_range=(int(select[0]), int(select[-1])),
                                           check_finite=False)
            basis = basis[:, select - select[0]]
        else:
            basis = np.zeros((Kt.shape[0], 0))
    figures = _figures(sp.csr_matrix(Kt), eigenvalues, basis, "accurate-bidiagonal", floor=4.0)
    return SolveResult(eigenvalues, basis, error, figures.residual, figures.orthogonality, "accurate-bidiagonal")


def _path_vectors(segments: list[Segment], n: int, omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, n) dof-space vectors of every segment from dbdsqr, columns ordered like `omega`."""
    sigmas = []
    blocks = []
    for c0, c1, d, e, keep, dofs_are_rows in segments:
        sigma, vectors = bidiagonal_svd(d, e, left=dofs_are_rows)
        sigma, vectors = sigma[-keep:], vectors[: c1 - c0 + 1, -keep:]  # drop the padding
        full = np.zeros((n, keep))
        full[c0 : c1 + 1] = vectors / np.linalg.norm(vectors, axis=0)
        sigmas.append(sigma)
        blocks.append(full)
    order = np.argsort(np.concatenate(sigmas), kind="stable")
    return np.hstack(blocks)[:, order]


def _spring_products(weighted: Any, basis: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray(weighted @ basis)


def _spring_ritz(weighted: Any, basis: NDArray[np.float64], *, vectors: bool) -> SolveResult:
    """Rayleigh-Ritz in spring space: H = (B~V)^T (B~V) keeps small eigenvalues' relative accuracy."""
    elongations = _spring_products(weighted, basis)
    values, rotation = _small_pencil(elongations.T @ elongations, basis.T @ basis)
    values = np.maximum(values, 0.0)  # H is a Gram matrix: positive semi-definite
    return _spring_figures(weighted, values, basis @ rotation, vectors, "accurate-ritz")


def _spring_rayleigh(weighted: Any, basis: NDArray[np.float64], *, vectors: bool) -> SolveResult:
    """Per-vector Rayleigh quotients ||B~ v||^2 (all modes of a large non-path system)."""
    elongations = _spring_products(weighted, basis)
    values = np.sum(elongations**2, axis=0) / np.sum(basis**2, axis=0)
    order = np.argsort(values)
    return _spring_figures(weighted, values[order], basis[:, order], vectors, "accurate-rayleigh")


def _spring_figures(weighted: Any, values: NDArray[np.float64], basis: NDArray[np.float64], vectors: bool,
                    solver: str) -> SolveResult:
    columns = _sample_columns(basis.shape[1])
    sample = basis[:, columns]
    product = np.asarray(weighted.T @ (weighted @ sample))
    residuals = np.linalg.norm(product - sample * values[columns], axis=0)
    squares = weighted.multiply(weighted) if sp.issparse(weighted) else np.asarray(weighted) ** 2
    norm = max(float(values.max(initial=0.0)), float(np.asarray(squares.sum(axis=0)).max()))  # max diag of K~
    # Kato-Temple: |lambda - theta| <= r^2 / gap, gap to the nearest other Ritz value;
    # plus the rounding of the Gram sums (a few eps relative).
    gaps = np.full(values.shape, norm)
    if values.shape[0] > 1:
        spacing = np.diff(values)
        gaps = np.minimum(np.r_[spacing, np.inf], np.r_[np.inf, spacing])
        gaps = np.where(gaps > 0, gaps, norm)
    error = 4 * EPS * np.abs(values)
    error[columns] += residuals**2 / gaps[columns]
    gram = basis.T @ sample
    gram[columns, np.arange(len(columns))] -= 1.0
    return SolveResult(values, basis if vectors else None, error, float(residuals.max(initial=0.0) / norm),
                       float(np.abs(gram).max(initial=0.0)), solver)


def _accurate_jacobi(weighted: Any, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None
                     ) -> SolveResult:
    """One-sided Jacobi SVD (LAPACK gejsv) of the dense B~: relative accuracy for scaled B."""
    dense = weighted.toarray() if sp.issparse(weighted) else np.asarray(weighted)
    n_terms, n = dense.shape
    padded = np.zeros((max(n_terms, n), n))  # gejsv needs rows >= columns; zero rows add null space
    padded[:n_terms] = dense
    gejsv = la.get_lapack_funcs("gejsv", dtype=np.float64)
    sva, u, v, work, iwork, info = gejsv(padded, joba=1, jobu=3, jobv=0 if vectors else 3, jobr=1,
                                         jobt=0, jobp=0)
    if info != 0:
        raise RuntimeError(f"LAPACK gejsv failed with info={info}")
    scale = work[0] / work[1] if work[1] != 0 else 1.0  # sigma = scale * sva (LAPACK convention)
    sigma = scale * sva
    order = np.argsort(sigma)
    omega = sigma[order]
    select = np.arange(n)
    if n_modes is not None:
        select = select[:n_modes]
    elif band is not None:
        select = select[(omega >= band[0]) & (omega <= band[1])]
    eigenvalues = omega[select] ** 2
    # Jacobi: relative error ~ eps * cond(B~ with columns scaled to unit norm) per value;
    # reported with the residual of the Gram form below.
    if not vectors:
        error = 2.0 * 4 * n * EPS * eigenvalues
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-jacobi")
    basis = v[:, order][:, select]
    result = _spring_figures(sp.csr_matrix(dense), eigenvalues, basis, True, "accurate-jacobi")
    return result
