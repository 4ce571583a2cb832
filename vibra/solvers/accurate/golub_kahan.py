"""Tight bounds for the lowest modes of an ill-conditioned spring system, from singular triplets.

The checked dense solve and one-sided Jacobi bound a mode from the residual of K~ v - theta v:
its rounding alone, eps |B~|^T |B~| |v| ~ eps ||K~||, squared over the gap, is up to 1e-4
relative on 3-D networks whose omega span 1e8 (springs over 1e12), where the values
themselves are good to ~1e-15. `refine_modes` (double-double LU of K~ per mode) fixes that
on systems up to ~60 dofs. Here, for any size the dense paths reach: the singular triplet
(sigma, u, v) of B~ = W^1/2 B M^-1/2 (sigma = omega), whose residuals B~ v - sigma u and
B~^T u - sigma v round to eps ||B~||, not eps ||B~||^2:

1. Inverse iteration on the Golub-Kahan matrix H = [[0, B~], [B~^T, 0]] shifted by sigma
   (sparse LU, SuperLU, in float64), two solves from a fixed start. The float64 solve is
   backward stable for H (entries ~ ||B~||): the vector is a singular pair of a B~ within
   ~eps ||B~||, so its true residual is of that size.
2. In extended precision (np.longdouble) with B~'s exact entries (the stored B~ less its
   rounding, `spring_ritz.forming_deviation`): E = B~ v, F = B~^T u, the Rayleigh quotient
   rho = 2 u.E / (|u|^2 + |v|^2) of H at x = (u; v), the residual |Hx - rho x| / |x|, and
   margins for every rounding and for the deviations' own uncertainty.
3. Kato-Temple for H: sigma lies within r^2 / (rho - a) below... above rho, with a and b the
   neighbouring omega's bounds (their values and bounds as they stand: an eigenvalue of H
   in (a, b) is then sigma alone; the -sigma and the zero eigenvalues of H lie below 0 <= a).
   The bound on sigma, r^2 / gap, is ~ (eps ||B~||)^2 / gap: relative (eps ||B~|| / omega)^2
   for a well-separated mode, ~1e-16 where omega / ||B~|| ~ 1e-8.

Cost: one sparse LU of the (n_terms + n) square H per mode refined (~2-20 ms on 3-D networks
of 180 to 900 dofs, ~9 ms on a ring of 8,000 sites; far more on a protein's network, whose
factors fill in); only the modes whose bound exceeds `wanted` relative and whose neighbours'
bounds leave a gap are refined, within a budget of `work` units counted from the factors'
sizes (never from the clock: the same input refines the same modes on every machine).
``accuracy="high"`` runs the step on systems of at most `HIGH_ROWS` rows for the bounds over
1e-10 relative, within `HIGH_WORK`; ``"certified"`` on any, for every bound over `WANTED`, with
no cap (its cost, `triplet_seconds` per mode, was estimated and guarded before the solve). Written here: no package bounds
singular triplets of a sparse matrix (the chains' compiled kernel, `triplets`, is for
bidiagonals).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import reverse_cuthill_mckee
from numpy.typing import NDArray

from vibra.solvers.accurate.spring_ritz import Deviation

__all__ = ["refine_triplets", "singular_vectors", "Refiner", "loose_modes", "WANTED",
           "HIGH_ROWS", "HIGH_WORK", "triplet_seconds"]

#: Bounds above this, relative to omega^2, are refined.
WANTED = 2e-13

#: ``accuracy="high"`` runs the step only where H has at most this many rows (n_terms + n: a
#: network of ~1,000 dofs with ~8 springs per site), for the bounds still over 1e-10 relative:
#: there one LU is cheap, while on a protein's network (47,000 rows for 3o21's 1,489
#: residues) one LU cost more than ProDy's whole solve (COLAMD's fill).
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
HIGH_ROWS = 10_000

#: ...and within this much work, in entries of the LU factors plus 8 per row of H per mode
#: (SuperLU's fixed cost). Modes beyond it keep their bounds, and `modes.refinement` says how many.
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
HIGH_WORK = 5e7


def triplet_seconds(n: int, n_terms: int, *, one_dimensional: bool = False) -> float:
    """Seconds one mode of the step is estimated to take, from sizes: SuperLU's fixed cost per
    row of H (28 units of 3.6e-8 s), and its factorisation, taken as 7e-11 F^1.5 s for a fill
    of F entries: ~10 per row of H for a chain or a ring (`one_dimensional`: a band), ~8 n^(2/3)
    per row for a network (the fill of a 3-D graph's factor), and no more than 0.75 n per row
    on a small one (its dof block fills in: 170 per row measured on ubiquitin's 228 dofs). Fitted to one LU per mode measured
    with one BLAS thread (fill, time): ubiquitin's network (228 dofs, 1,428 springs) 2.8e5,
    0.016 s; 900-dof networks 2.1e6, 0.27 s; 1,500 dofs with 19,443 springs 1.9e7, 3.3 s; 3o21
    (4,467 dofs, 42,482 springs) 1e8, 24-115 s; 6,000-dof networks 8.6e7 to 3.6e8, 65-217 s:
    within ~3x of these. An estimate, not a bound: the corpus checks it."""
    rows = float(n + n_terms)
    fill = rows * (10.0 if one_dimensional else min(8.0 * float(n) ** (2.0 / 3.0), 0.75 * n))
    return 3.6e-8 * 28.0 * rows + 7e-11 * fill ** 1.5


_UNIT = float(np.finfo(np.longdouble).eps)

#: Newton steps of `Refiner.refine` per cluster.
REFINE_STEPS = 2


def refine_triplets(weighted: sp.csr_matrix, deviation: Deviation, values: NDArray[np.float64],
                    error: NDArray[np.float64], *, complete: bool, work: float, wanted: float = WANTED
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Tighter (values, error) for the modes whose bound exceeds `wanted` |value| (see above),
    within `work` units of fill (see `HIGH_WORK`; ``float("inf")``: no cap).

    `weighted`: the stored B~ (n_terms, n), sparse; `deviation`: its (D, S), or None (no exact
    entries known: nothing is refined). `values` ascending omega^2 with absolute bounds
    `error`, the lowest of the system (`complete`: all of them; else the last has no upper
    neighbour and is left as it is). Returns (values, error, how many refined).
    """
    values = np.asarray(values, dtype=float).copy()
    error = np.asarray(error, dtype=float).copy()
    if deviation is None or not sp.issparse(weighted):
        return values, error, 0
    k = values.shape[0]
    loose = np.flatnonzero(loose_modes(values, error, wanted))
    if not complete:
        loose = loose[loose < k - 1]
    if loose.size == 0:
        return values, error, 0
    B = sp.csr_matrix(weighted, dtype=float)
    D, S = deviation
    rows, n = B.shape
    terms = float(max(np.diff(B.indptr).max(initial=1), np.bincount(B.indices, minlength=n).max(initial=1)))
    exact = (B.astype(np.longdouble) - D.astype(np.longdouble)).tocsr()  # B~ from the inputs, within S
    exact_T = exact.T.tocsr()
    A = abs(B) * (1 + 1e-12) + S  # bounds |exact B~| entry by entry
    A_T = A.T.tocsr()
    S_T = S.T.tocsr()
    start = np.random.default_rng(2025).standard_normal(rows + n)
    refined, spent = 0, 0.0
    for j in loose.tolist():
        if spent >= work:
            break
        if not _isolated(values, error, j):  # no gap to bound it by: no factorisation spent
            continue
        sigma = float(np.sqrt(values[j]))
        pair, fill = _inverse_iteration(B, sigma, start)
        spent += fill
        if pair is None:
            continue
        u, v = pair
        bound = _kato_temple(exact, exact_T, A, A_T, S, S_T, terms, u, v, values, error, j, complete)
        if bound is None:
            continue
        rho, low, high = bound
        width = max(high**2 - rho**2, rho**2 - low**2) * (1 + 1e-12)
        if width < error[j]:
            values[j], error[j] = rho**2, width
            refined += 1
    return values, error, refined


def singular_vectors(weighted: sp.csr_matrix, values: NDArray[np.float64], mass: NDArray[np.float64]
                     ) -> NDArray[np.float64]:
    """Mass-weighted vectors of a free system's lowest modes, given their omega^2 (ascending,
    certified elsewhere): the rigid translation M^1/2 1 for a zero, then each mode's right
    singular vector of B~ by `_inverse_iteration` at omega (no K~ - omega^2 formed, whose
    rounding, eps ||K~||, would swamp omega^2 down to ~1e-16 ||K~||); a cluster of values within
    1e-9 relative (a uniform ring's pairs) from as many starts, orthonormalised."""
    n = weighted.shape[1]
    basis = np.zeros((n, values.shape[0]))
    rng = np.random.default_rng(2026)
    for j, end in _clusters(values):
        if values[j] <= 0.0:  # (a zero cluster holds zeros only: each the rigid translation)
            basis[:, j:end] = (np.sqrt(mass) / np.linalg.norm(np.sqrt(mass)))[:, None]
            continue
        sigma = float(np.sqrt(values[j:end].mean())) * (1 + 1e-13)  # (beside it: H - sigma stays regular)
        block = []
        for _ in range(end - j):
            pair, _ = _inverse_iteration(weighted, sigma, rng.standard_normal(weighted.shape[0] + n))
            block.append(pair[1] if pair is not None else rng.standard_normal(n))
        basis[:, j:end] = np.linalg.qr(np.column_stack(block))[0]
    return basis


def _clusters(values: NDArray[np.float64]) -> list[tuple[int, int]]:
    """(start, stop) of each run of ascending values within 1e-9 relative of the one before."""
    k = values.shape[0]
    runs, j = [], 0
    while j < k:
        end = j + 1
        while end < k and values[end] - values[end - 1] <= 1e-9 * values[end]:
            end += 1
        runs.append((j, end))
        j = end
    return runs


def loose_modes(values: NDArray[np.float64], error: NDArray[np.float64], wanted: float = WANTED
                ) -> NDArray[np.bool_]:
    """The modes this step would refine: bound over `wanted` |value|, yet clear of zero."""
    return (error > wanted * np.abs(values)) & (values > error)


def _isolated(values: NDArray[np.float64], error: NDArray[np.float64], j: int) -> bool:
    """Whether value j lies clear of its neighbours' bounds (a Kato-Temple gap may exist)."""
    k = values.shape[0]
    below = j == 0 or values[j - 1] + error[j - 1] < values[j]
    above = j + 1 >= k or values[j + 1] - error[j + 1] > values[j]
    return bool(below and above)


def _inverse_iteration(B: sp.csr_matrix, sigma: float, start: NDArray[np.float64]
                       ) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64]] | None, float]:
    """((u, v), unit vectors, or None where the LU fails; the factors' entries) from two solves
    with H - sigma I: LU with partial pivoting, columns ordered by COLAMD (on 3-D networks
    ~15 times faster than the minimum-degree orderings, whose factors fill 5 times more; a
    symmetric minimum-degree order with a pivot threshold of 0.1 filled 3o21's H as much for a
    low sigma, and 3-D networks of 6,000 dofs more: measured, kept out)."""
    rows, n = B.shape
    H = sp.bmat([[-sigma * sp.identity(rows), B], [B.T, -sigma * sp.identity(n)]], format="csc")
    try:
        factor = spla.splu(H, permc_spec="COLAMD")
    except RuntimeError:  # exactly singular (sigma an exact singular value in float64)
        return None, float(H.nnz) + 8.0 * (rows + n)
    fill = float(factor.L.nnz + factor.U.nnz) + 8.0 * (rows + n)
    x = start
    for _ in range(2):
        with np.errstate(all="ignore"):
            x = factor.solve(x)
            x = x / np.linalg.norm(x)
        if not np.all(np.isfinite(x)):
            return None, fill
    u, v = x[:rows], x[rows:]
    if not (np.linalg.norm(u) > 0 and np.linalg.norm(v) > 0):
        return None, fill
    return (u / np.linalg.norm(u), v / np.linalg.norm(v)), fill


def _kato_temple(exact: Any, exact_T: Any, A: sp.csr_matrix, A_T: sp.csr_matrix, S: sp.csr_matrix,
                 S_T: sp.csr_matrix, terms: float, u: NDArray[np.float64], v: NDArray[np.float64],
                 values: NDArray[np.float64], error: NDArray[np.float64], j: int, complete: bool
                 ) -> tuple[float, float, float] | None:
    """(rho, low, high): omega_j within [low, high] (Kato-Temple on H at x = (u; v)); None where
    the neighbours leave no room (their bounds reach rho, or the residual exceeds the gap)."""
    k = values.shape[0]
    ul, vl = u.astype(np.longdouble), v.astype(np.longdouble)
    E = np.asarray(exact @ vl).ravel()    # B~ v
    F = np.asarray(exact_T @ ul).ravel()  # B~^T u
    # each product's rounding (t terms) and the deviations' uncertainty S: entry by entry
    E_margin = terms * 2 * _UNIT * np.asarray(A @ np.abs(v)).ravel() + np.asarray(S @ np.abs(v)).ravel()
    F_margin = terms * 2 * _UNIT * np.asarray(A_T @ np.abs(u)).ravel() + np.asarray(S_T @ np.abs(u)).ravel()
    size = u.shape[0] + v.shape[0]
    length_ld = np.dot(ul, ul) + np.dot(vl, vl)  # |x|^2, x = (u; v)
    rho_ld = 2 * np.dot(ul, E) / length_ld
    rho, length = float(rho_ld), float(length_ld)
    # the exact Rayleigh quotient theta = 2 u.B~v / |x|^2 differs from rho by E's margins, the
    # rounding of the dot products and the quotient (extended precision), and rho's to float64
    shift = ((2 * float(np.dot(np.abs(u), E_margin))
              + 4 * (size + 2) * _UNIT * float(np.dot(np.abs(u), np.abs(E.astype(float))))) / length * (1 + 1e-10)
             + (size + 4) * _UNIT * abs(rho) + abs(float(rho_ld - rho)))
    residual = np.sqrt(float(np.sum((E - rho * ul) ** 2) + np.sum((F - rho * vl) ** 2)) / length)
    margin = np.sqrt(float(np.sum((E_margin + 4 * _UNIT * np.abs(E.astype(float))) ** 2)
                           + np.sum((F_margin + 4 * _UNIT * np.abs(F.astype(float))) ** 2)) / length)
    r = (residual * (1 + 1e-10) + margin + shift)  # |H x - theta x| / |x| for the exact H and theta
    lower = np.sqrt(values[j - 1] + error[j - 1]) if j > 0 else 0.0
    if j + 1 < k:
        upper = np.sqrt(max(values[j + 1] - error[j + 1], 0.0))
    elif complete:
        upper = np.inf
    else:
        return None
    lo_theta, hi_theta = rho - shift, rho + shift
    if not (lower < lo_theta and hi_theta < upper):
        return None
    below, above = lo_theta - lower, upper - hi_theta  # from theta (anywhere in its interval) to a, b
    if r * r >= below * above:
        return None
    low = lo_theta - r * r / above
    high = hi_theta + r * r / below
    return rho, float(low) * (1 - 1e-15), float(high) * (1 + 1e-15)


class Refiner:
    """Newton refinement of clustered singular vectors of B~ to extended precision, its operators
    formed once per B~ (several clusters, several calls: a ring's pairs).

    Float64 vectors leave a residual ~eps ||K~|| (their own rounding), so a quadratic residual
    bound r^2 / gap on a double eigenvalue omega^2 ~ ||K~|| / n^2 grows as n^4 relative. Per
    cluster (values within 1e-9 relative, as `singular_vectors` groups them), with V
    orthonormal: R = K~ V - V (V^T K~ V) in extended precision with B~'s exact entries (the
    stored B~ less its rounding D), then the Newton correction X = (K~ - theta I)^-1 R (sparse
    LU, float64: K~ - theta I is nearly singular only along the cluster, whose part of X is
    projected out; elsewhere its error is eps relative, and X itself ~eps long; LU in reverse
    Cuthill-McKee order, a ring's band), V - X, orthonormalised in extended precision;
    `REFINE_STEPS` times. The bounds computed from the result stay rigorous whatever its
    quality."""

    def __init__(self, weighted: sp.csr_matrix, deviation: Deviation) -> None:
        B = sp.csr_matrix(weighted, dtype=float)
        exact = B.astype(np.longdouble)
        if deviation is not None:
            exact = (exact - deviation[0].astype(np.longdouble)).tocsr()
        self.exact, self.exact_T = exact, exact.T.tocsr()
        K = (B.T @ B).tocsr()
        self.order = reverse_cuthill_mckee(K, symmetric_mode=True)  # a ring: a band of half-width 2
        self.K = K[self.order][:, self.order].tocsc()
        self.identity = sp.identity(B.shape[1], format="csc")

    def refine(self, basis: NDArray[np.float64], values: NDArray[np.float64]) -> NDArray[np.longdouble]:
        """`basis` (columns for `values`, ascending), each cluster refined (see the class)."""
        n = self.K.shape[0]
        result = np.asarray(basis, dtype=np.longdouble).copy()
        for j, end in _clusters(values):
            if values[j] <= 0:
                continue
            V = _orthonormal(result[:, j:end])
            for _ in range(REFINE_STEPS):
                KV = np.asarray(self.exact_T @ np.asarray(self.exact @ V))
                R = KV - V @ (V.T @ KV)
                shift = float(np.trace((V.T @ KV).astype(float))) / (end - j)
                try:  # (in band order, natural: LU fill O(n b); the minimum-degree orders stalled on rings)
                    X = np.empty((n, end - j))
                    X[self.order] = spla.splu((self.K - shift * self.identity).tocsc(), permc_spec="NATURAL").solve(
                        R.astype(float)[self.order])
                except RuntimeError:  # exactly singular in float64
                    break
                if not np.all(np.isfinite(X)):
                    break
                X = X.astype(np.longdouble)
                X -= V @ (V.T @ X)  # the correction lies outside the cluster's span
                V = _orthonormal(V - X)
            result[:, j:end] = V
        return result


def _orthonormal(V: NDArray[Any]) -> NDArray[Any]:
    """Modified Gram-Schmidt, twice, in V's own precision (np.linalg.qr has no long double)."""
    V = np.array(V, copy=True)
    for _ in range(2):
        for i in range(V.shape[1]):
            for p in range(i):
                V[:, i] -= (V[:, p] @ V[:, i]) * V[:, p]
            V[:, i] /= np.sqrt(V[:, i] @ V[:, i])
    return V
