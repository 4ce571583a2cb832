"""Spring-space Rayleigh-Ritz with quadratic residual bounds, for the problem as given.

The accurate paths (`vibra.solvers.accurate.springs`) hand their vectors here: `cluster_bounds`
groups the values into clusters, does Rayleigh-Ritz per cluster in spring space (H =
(B~V)^T (B~V), whose small eigenvalues keep their relative accuracy) and bounds each mode
from its residual against the gap to its neighbours (Kato-Temple; Weyl where no gap serves).
`residual_bounds` gives the plain residual of each vector. Both count the rounding of their
own products and that of B~ = W^1/2 B M^-1/2 itself (`forming_deviation`: each entry's
rounding, computed), so that every bound is for the exact B~ of the inputs.
"""

from __future__ import annotations

from typing import Any, Optional, Tuple

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra.solvers.accurate.dd import (
    UNIT as DD_UNIT, add as dd_add, div as dd_div, lu as dd_lu, lu_solve as dd_lu_solve,
)
from vibra.solvers.accurate.dd import mul as dd_mul, split_mp, tree_sum
from vibra.solvers.accuracy import HIGH_TARGET
from vibra.solvers.common import EPS, Matrix, SolveResult, sample_columns, small_pencil
from vibra.solvers.accurate.rounding import WORST_ENTRY, entry_deviation
from vibra.solvers.compiled import compiled_pays

__all__ = ["TARGET", "BLOCK", "FORMING", "REFINE_WORK", "Deviation", "forming_deviation", "zero_level",
           "most_terms", "cluster_bounds", "residual_bounds", "refine_modes"]

#: Relative accuracy of omega^2 that `accurate.springs.checked_dense` asks of each requested mode before it
#: accepts the fast solve's result for it (omega then to ~TARGET / 2).
TARGET = HIGH_TARGET

#: Columns per block in `cluster_bounds` (memory n_terms x BLOCK).
BLOCK = 128

#: Relative rounding of each entry of B~ = W^1/2 B M^-1/2 as formed in float64 (two square
#: roots, a reciprocal, two products: `vibra.solvers.accurate.rounding.WORST_ENTRY`). Every bound is for
#: the exact B~ of the inputs: K~ exact - K~ stored = Delta with |Delta| <= (2 eta + eta^2)
#: |B~|^T |B~| entry-wise, which moves a unit vector's Rayleigh quotient by at most
#: 2 eta |B~ v|^T |B~| |v| + eta^2 || |B~| |v| ||^2 and its residual by || Delta v ||.
FORMING = WORST_ENTRY


#: B~'s rounding entry by entry, (D, S): exact B~ = stored - D, each entry of D known to within
#: S (sparse, B~'s pattern); None where it cannot be computed (a full mass matrix).
Deviation = Optional[Tuple[sp.csr_matrix, sp.csr_matrix]]


def forming_deviation(weighted: Matrix, coupling: sp.csr_matrix, weights: NDArray[np.float64],
                      mass: NDArray[np.float64]) -> Deviation:
    """(D, S) of the stored B~ = W^1/2 B M^-1/2 (`vibra.solvers.accurate.rounding.entry_deviation`: each
    entry x = (1 + delta) sqrt(w) c / sqrt(m), delta to ~eps^2): D = x delta / (1 + delta), S
    bounds D's own error (WORST_ENTRY |x| where an entry's deviation is not available)."""
    if np.ndim(mass) != 1 or not sp.issparse(weighted):
        return None
    stored = sp.csr_matrix(weighted, dtype=float, copy=True)
    stored.sort_indices()
    source = sp.csr_matrix(coupling, dtype=float, copy=True)
    source.sort_indices()
    source.eliminate_zeros()
    stored.eliminate_zeros()
    if stored.nnz != source.nnz or not (np.array_equal(stored.indptr, source.indptr)
                                        and np.array_equal(stored.indices, source.indices)):
        return None
    rows = np.repeat(np.arange(stored.shape[0]), np.diff(stored.indptr))
    x = stored.data
    delta, slack = entry_deviation(x, np.asarray(weights, dtype=float)[rows], source.data,
                                   np.asarray(mass, dtype=float)[stored.indices])
    D = sp.csr_matrix((x * delta / (1.0 + delta), stored.indices, stored.indptr), shape=stored.shape)
    S = sp.csr_matrix((np.abs(x) * (slack * (1.0 + 4 * EPS) + 4 * EPS * np.abs(delta) ** 2) + 1e-300,
                       stored.indices, stored.indptr), shape=stored.shape)
    return D, S


def zero_level(terms: float, n: int, norm: float) -> float:
    """omega^2 below which a mode is zero within rounding: ((t + 4 eta / eps) n eps)^2 ||K~||, t
    the most terms in a row or column of B~ (its products' rounding), eta = `FORMING` (B~'s own:
    a rigid mode's bound, (2 eta ||K~||)^2 / omega_1^2 with omega_1^2 ~ ||K~|| / n^2 on a chain
    or ring, reaches ~16 (eta n)^2 ||K~||)."""
    return ((terms + 4 * FORMING / EPS) * n * EPS) ** 2 * norm


def most_terms(B: sp.csr_matrix) -> float:
    """The most stored entries in a row or a column of B~ (the length of its dot products)."""
    return float(max(np.diff(B.indptr).max(initial=1), np.bincount(B.indices, minlength=B.shape[1]).max(initial=1)))


def residual_bounds(B: sp.csr_matrix, values: NDArray[np.float64], basis: NDArray[np.float64], terms: float
                     ) -> NDArray[np.float64]:
    """||B~^T B~ v - theta v|| per column, in extended precision, plus the margin for its own
    rounding (2 t eps_ext || |B~|^T |B~| |v| ||) and for B~'s (`FORMING`): each column has an
    eigenvalue of the exact K~ within it of theta, in blocks of BLOCK columns."""
    unit = float(np.finfo(np.longdouble).eps)
    precise = B.astype(np.longdouble)
    absolute = abs(B)
    bounds = np.empty(values.shape[0])
    for start in range(0, values.shape[0], BLOCK):
        V = basis[:, start:start + BLOCK]
        product = np.asarray(precise.T @ (precise @ V.astype(np.longdouble)))
        residual = np.linalg.norm((product - V * values[start:start + BLOCK]).astype(float), axis=0)
        spread = np.asarray(absolute @ np.abs(V))  # |B~| |v|
        margin = (2 * terms * unit + FORMING * (2 + FORMING)) * np.linalg.norm(np.asarray(absolute.T @ spread), axis=0)
        # B~'s own rounding moves the Rayleigh quotient too (`FORMING`)
        moved = 2 * FORMING * np.einsum("ij,ij->j", np.abs(np.asarray(B @ V)), spread) + FORMING**2 * np.einsum(
            "ij,ij->j", spread, spread)
        norms = np.linalg.norm(V, axis=0)
        bounds[start:start + BLOCK] = (residual + margin) / norms + moved / norms**2
    return bounds


def cluster_bounds(B: sp.csr_matrix, values: NDArray[np.float64], basis: NDArray[np.float64], delta: ArrayLike,
                    terms: float, *, complete: bool, precise: bool = False, cheap_from: int | None = None,
                    floor: float = -np.inf, ceiling: float | None = None, deviation: Deviation = None,
                    split: bool = False) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Spring-space Ritz values, vectors and quadratic residual bounds per cluster (see `springs.checked_dense`).

    Works through blocks of whole clusters (~BLOCK columns): O(nnz(B~) k) in all, n_terms x BLOCK memory.
    The rounding of B~^T (B~ V) is bounded by 2 t unit || |B~|^T |B~| |v| || per column.
    `floor` / `ceiling`: no eigenvalue outside `values` lies above floor (below the first) or
    below ceiling (above the last); default: none below, and none above when `complete`
    (else the last cluster has no gap above).
    `precise`: products in extended precision (np.longdouble), whose rounding margin is ~2000
    times smaller; the bound, quadratic in the residual, then stays near the true error where
    stiff springs make the float64 margin (eps |B~|^T |B~| |v|) dominate.
    `split`: the columns from `cheap_from` on always take the cheap margins (by default a block
    that starts before `cheap_from` works exactly throughout, tighter for the columns past it).
    `deviation` (`forming_deviation`): B~'s own rounding, entry by entry; the Ritz step then
    works with the exact B~ = stored - D (B~ v - D v), so values and bounds are the exact
    problem's, up to the deviations' own uncertainty S. Without it, the worst case `FORMING`
    per entry: the residual grows by || Delta v || and the Rayleigh quotient may move by
    2 eta |B~ v|^T |B~| |v| (first order, far above the true effect on the lowest modes of a
    long chain, whose entry roundings act as diagonal scalings).
    """
    unit = float(np.finfo(np.longdouble).eps) if precise else EPS
    D = S = None
    if deviation is not None:
        D, S = deviation
    if precise:
        B = B.astype(np.longdouble)
        D = None if D is None else D.astype(np.longdouble)
    k = values.shape[0]
    cheap_from = k if cheap_from is None else cheap_from
    delta = np.broadcast_to(np.asarray(delta, dtype=float), values.shape)  # each value's absolute error
    breaks = np.flatnonzero(np.diff(values) > delta[:-1] + delta[1:] + TARGET * np.abs(values[1:]))
    starts, stops = np.r_[0, breaks + 1], np.r_[breaks + 1, k]
    theta, error = np.empty(k), np.empty(k)
    vectors = np.empty_like(basis)
    B_T = B.T.tocsr()  # (a row-major product: faster than the transposed view)
    D_T = None if D is None else D.T.tocsr()
    A = abs(B)
    A_T = A.T.tocsr()
    S_T = None if S is None else S.T.tocsr()
    # from column `cheap_from` on: || |B~|^T |B~| |v| || <= || |B~|^T |B~| ||_2 ||v||, that norm
    # <= its largest row sum (non-negative, symmetric): no products per block, and a margin
    # that only matters where omega^2 is far below ||K~|| (the columns before cheap_from)
    # (the row sums of |B~|^T |B~|, non-negative: |B~|^T (|B~| 1), two products, no sparse product)
    reach = float(np.max(A_T @ (A @ np.ones(A.shape[1])), initial=0.0)) if cheap_from < k else 0.0
    eta = FORMING if S is None else float(np.max(S.data / np.maximum(np.abs(A.data.astype(float)), 1e-300),
                                                initial=0.0))
    first = 0
    while first < len(starts):
        last = int(np.searchsorted(stops, stops[first] + BLOCK - 1, side="right")) if first < len(starts) else first
        last = max(last, first + 1)
        if split and starts[first] < cheap_from:  # a block of exact columns ends where the cheap ones begin
            last = min(last, max(first + 1, int(np.searchsorted(stops, cheap_from, side="right"))))
        columns = slice(int(starts[first]), int(stops[last - 1]))
        V = basis[:, columns].astype(B.dtype)
        # precise: B~ v to within unit of each entry, not of |B~| |v| (error-free products and
        # sums, `_error_free_product`), where the Rayleigh quotient's rounding would otherwise
        # grow as 1 / omega relative (a uniform ring of 10^6 sites: 1.4e-13 on its lowest pair,
        # 1.5e-15 now)
        E = _error_free_product(B, V) if precise else np.asarray(B @ V)
        # the exact B~ v where it matters (below cheap_from); above, the worst case, which
        # costs no products and stays below those modes' own a-priori bound
        exact = D is not None and columns.start < cheap_from
        if exact:
            E = E - np.asarray(D @ V)
        # single-mode clusters: Rayleigh quotients ||B~ v||^2 / ||v||^2, all at once
        # (numpy's pairwise sums along each contiguous column: within ~40 unit of the sum, inside
        # the EPS w allowed below, where a plain running sum of 10^6 terms may lose 10^6 unit)
        w = (_pairwise_squares(E) / _pairwise_squares(V)).astype(float)
        for start, stop in zip(starts[first:last] - columns.start, stops[first:last] - columns.start):
            if stop - start == 1:
                continue
            part, rotation = small_pencil((E[:, start:stop].T @ E[:, start:stop]).astype(float),
                                          (V[:, start:stop].T @ V[:, start:stop]).astype(float))
            w[start:stop] = part
            V[:, start:stop] = V[:, start:stop] @ rotation
            E[:, start:stop] = E[:, start:stop] @ rotation
        w = np.maximum(w, 0.0)  # H is a Gram matrix
        product = np.asarray(B_T @ E)
        if exact:
            product = product - np.asarray(D_T @ E)
        squares = np.sum((product - V * w) ** 2, axis=0)
        # rounding of B~^T (B~ V) (sums of <= `terms` products; D's, eta times smaller, alike),
        # and what is left of B~'s own rounding: Delta v added to the residual, the Rayleigh
        # quotient moved by `moved` (per unit column)
        lengths = np.linalg.norm(V, axis=0).astype(float)
        grow = 2 * eta + eta * eta if exact else FORMING * (2 + FORMING)
        if columns.start >= cheap_from:
            margins = 2 * terms * unit * reach * lengths * (1 + 4 * FORMING)
            shifts = grow * reach * lengths
            moved = grow * reach * np.ones_like(lengths)
        else:
            spread = np.asarray(A @ np.abs(V))  # |B~| |v|
            products = np.linalg.norm(np.asarray(A_T @ spread), axis=0).astype(float)
            margins = 2 * terms * unit * products * (1 + 4 * eta)
            if not exact:
                shifts = grow * products
                moved = ((2 * FORMING * np.einsum("ij,ij->j", np.abs(E), spread)
                          + FORMING**2 * np.einsum("ij,ij->j", spread, spread)).astype(float) / lengths**2)
            else:  # only the deviations' uncertainty S (|S| <= eta |B~|) is left
                assert S is not None
                unsure = np.asarray(S @ np.abs(V).astype(float))
                shifts = (np.linalg.norm(np.asarray(A_T @ unsure), axis=0)
                          + np.linalg.norm(np.asarray(S_T @ np.abs(E).astype(float)), axis=0)) * (1 + 4 * eta) \
                    + eta * eta * products
                moved = (2 * np.einsum("ij,ij->j", np.abs(E).astype(float), unsure)
                         + np.einsum("ij,ij->j", unsure, unsure)) / lengths**2
        # the Rayleigh quotients' own rounding: B~ v summed with cancellation (a low mode's
        # elongations are far smaller than |B~| |v|), each entry within (t + 2) unit of
        # (|B~| |v|)_i: ||B~ v||^2 / ||v||^2 within (2 ||E|| ||dE|| + ||dE||^2) / ||v||^2
        if columns.start >= cheap_from:
            slip = (terms + 2) * unit * np.sqrt(reach) * lengths
        elif precise:  # each entry within unit of itself, (t + 2) unit^2 of (|B~| |v|)_i and the
            # rounding of D v and of its subtraction (t + 2) unit eta (|B~| |v|)_i, + unit |E_i|
            beside = (terms + 2) * unit * (unit + (eta if exact else 0.0))
            slip = 2 * (2 * unit * np.linalg.norm(E, axis=0).astype(float)
                        + beside * np.linalg.norm(spread, axis=0).astype(float))
        else:
            slip = (terms + 2) * unit * np.linalg.norm(spread, axis=0).astype(float)
        elongation = np.sqrt(np.maximum(w, 0.0)) * lengths
        moved = moved + (2 * elongation * slip + slip**2) / lengths**2 * (1 + 1e-10)
        vectors[:, columns], theta[columns] = V, w
        for start, stop in zip(starts[first:last], stops[first:last]):
            local = slice(start - columns.start, stop - columns.start)
            residual = float(np.sqrt(squares[local].sum())) + float(margins[local].max()) + float(
                np.sqrt(np.sum(shifts[local] ** 2)))  # (to float64)
            shift = float(moved[local].max())
            lower = values[start - 1] + delta[start - 1] if start > 0 else floor
            upper = values[stop] - delta[stop] if stop < k else (
                ceiling if ceiling is not None else (np.inf if complete else -np.inf))
            gap = min(float(w[local].min()) - lower, upper - float(w[local].max())) - shift
            bound = (residual**2 / gap if gap > residual else residual) + shift
            # (+ the c x c pencil's own rounding, c eps ||H||, for a cluster of c > 1 modes)
            pencil = (stop - start) * EPS * float(w[local].max()) if stop - start > 1 else 0.0
            error[start:stop] = bound + (2 * terms * unit + EPS) * w[local] + pencil
        first = last
    return theta, vectors, error


#: Entries of B V that `_error_free_product` forms at once.
EFT_ELEMENTS = 2**20

#: Seconds per stored entry of B and column of V of `_numpy_product` in long double, the compiled
#: product's counterpart: 1.7e-7 (6e6 entries x columns) to 7e-7 (3e3) measured, one core (the
#: compiled: 5e-9).
NUMPY_PRODUCT_S = 2e-7


def _pairwise_squares(X: NDArray[Any]) -> NDArray[Any]:
    """The squared norm of each column of X, by numpy's pairwise summation (a contiguous row per
    column: numpy sums pairwise only along a contiguous run)."""
    rows = np.ascontiguousarray(X.T)
    total: NDArray[Any] = np.sum(rows * rows, axis=1)
    return total


def _error_free_product(B: sp.csr_matrix, V: NDArray[Any]) -> NDArray[Any]:
    """B V in long double, each entry within one unit of itself.

    Where every entry of B and V is a float64 (the stored B~ and a float64 basis, cast: the
    usual case), compiled (`_compiled_product`): each product split exactly by Dekker's
    two-product and all of them summed by two-sum into a triple-double (hi, lo, lower) per
    entry, left over below 2^-150 (|B| |V|)_i, then rounded once to long double; ~40 times the
    numpy loop below, which serves any other input (`_numpy_product`), and float64 ones in long
    double where it is estimated under `vibra.solvers.compiled.COMPILED_FROM_S` (`NUMPY_PRODUCT_S`)."""
    if _float64_exact(B.data) and _float64_exact(V):
        if compiled_pays(NUMPY_PRODUCT_S * B.nnz * V.shape[1]):
            return _compiled_product(B, V)
        return _numpy_product(sp.csr_matrix(B, dtype=np.longdouble), np.asarray(V, dtype=np.longdouble))
    return _numpy_product(B, V)


def _float64_exact(values: NDArray[Any]) -> bool:
    """Whether every entry of `values` is a float64 (cast exactly)."""
    return bool(values.dtype == np.float64 or np.array_equal(values.astype(np.float64).astype(values.dtype), values))


def _compiled_product(B: sp.csr_matrix, V: NDArray[Any]) -> NDArray[Any]:
    """`_error_free_product` for float64 entries: the compiled triple-double sums, in long double."""
    V64 = np.ascontiguousarray(V, dtype=np.float64)
    rows, columns = B.shape[0], V64.shape[1]
    rows_per_block = max(1, 4 * EFT_ELEMENTS // max(1, columns))
    if rows > rows_per_block:  # (three float64 parts and the long double result per block)
        return np.concatenate([_compiled_product(B[start: start + rows_per_block], V64)
                               for start in range(0, rows, rows_per_block)])
    from vibra.solvers.accurate.products import triple_rows  # compiled: loaded on first use

    parts = np.zeros((3, rows, columns))
    triple_rows(np.asarray(B.indptr, dtype=np.int64), np.asarray(B.indices, dtype=np.int64),
                np.asarray(B.data, dtype=np.float64), V64, parts)
    result: NDArray[Any] = (parts[0].astype(np.longdouble) + parts[1].astype(np.longdouble)) + parts[2].astype(
        np.longdouble)
    return result


def _numpy_product(B: sp.csr_matrix, V: NDArray[Any]) -> NDArray[Any]:
    """B V in B's precision (long double), each entry within one unit of itself: every product
    b v split exactly into p + e (Dekker's two-product, split at half the significand), the
    p summed by two-sum per row, the errors e and the sums' own errors gathered beside and added
    last. What is left: (t + 2) unit^2 (|B| |V|)_i from gathering them, and the final rounding.
    Rows in blocks of ~`EFT_ELEMENTS` entries of the result: its dozen temporaries stay ~16 MiB
    each (a network's 350,000 springs by 26 modes would take ~2 GiB at once)."""
    rows_per_block = max(1, EFT_ELEMENTS // max(1, V.shape[1]))
    if B.shape[0] > rows_per_block:
        return np.concatenate([_numpy_product(B[start: start + rows_per_block], V)
                               for start in range(0, B.shape[0], rows_per_block)])
    dtype = B.dtype
    digits = np.finfo(dtype).nmant + 1
    splitter = dtype.type(2.0 ** ((digits + 1) // 2) + 1.0)
    rows, columns = B.shape[0], V.shape[1]
    high = np.zeros((rows, columns), dtype=dtype)
    low = np.zeros((rows, columns), dtype=dtype)
    counts = np.diff(B.indptr)
    for j in range(int(counts.max(initial=0))):
        row = np.flatnonzero(counts > j)
        at = B.indptr[row] + j
        a, b = B.data[at][:, None], V[B.indices[at]]
        product = a * b
        c, d = splitter * a, splitter * b
        a_high, b_high = c - (c - a), d - (d - b)
        a_low, b_low = a - a_high, b - b_high
        error = ((a_high * b_high - product) + a_high * b_low + a_low * b_high) + a_low * b_low
        total = high[row] + product
        back = total - high[row]
        low[row] += ((high[row] - (total - back)) + (product - back)) + error
        high[row] = total
    result: NDArray[Any] = high + low
    return result


#: Most multiply-adds (n^3 / 3 per mode's LU, summed) that `refine_modes` may spend.
REFINE_WORK = 3_000_000


def refine_modes(coupling: sp.csr_matrix, weights: NDArray[np.float64], mass: NDArray[np.float64],
                 values: NDArray[np.float64], error: NDArray[np.float64], *, complete: bool,
                 wanted: float = 2e-13) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Tighter bounds for the modes whose bound exceeds `wanted` |lambda|, in double-double.

    Two steps of inverse iteration on K~ - theta I (K~ formed from the inputs in mpmath, then
    LU in double-double, `vibra.solvers.accurate.dd`); then, in spring space, E = B~ y (B~ from the
    inputs, to ~2^-104), the Rayleigh quotient rho = |E|^2 / |y|^2, the residual B~^T E - rho y
    and the Kato-Temple bound r^2 / gap, the gap to the neighbours' values moved by their own
    bounds; every rounding counted. Where double precision leaves a normwise residual
    eps ||K~|| that, squared over the gap, still exceeds the target (one-sided Jacobi on a
    network with springs over 1e12: bounds of 1e-8 for true errors of 2e-16).

    For small systems (an LU per mode, n^3 / 3: `REFINE_WORK` in all, ~25 modes at 60 dofs).
    `values` ascending, the lowest ones of the system (`complete`: all). Returns (values,
    error, how many refined).
    """
    values = np.asarray(values, dtype=float).copy()
    error = np.asarray(error, dtype=float).copy()
    n = coupling.shape[1]
    k = values.shape[0]
    loose = np.flatnonzero((error > wanted * np.abs(values)) & (values > error))
    if loose.size == 0 or np.ndim(mass) != 1 or n**3 / 3 > REFINE_WORK:
        return values, error, 0
    B = sp.csr_matrix(coupling, dtype=float, copy=True)
    B.sum_duplicates()
    B.eliminate_zeros()
    import mpmath  # here only: `import vibra` loads no mpmath

    with mpmath.workdps(40):  # B~'s entries from the inputs, and K~ = B~^T B~ from them
        rows = _mp_rows(B, weights, mass)
        Kh, Kl = split_mp(_mp_stiffness(rows, B, n).tolist())
        Bh, Bl = split_mp([entry for row in rows for entry in row])
    # B~ and B~^T padded to their longest row, for row sums in double-double
    slots, ph, pl = _padded(B.indptr, B.indices, Bh, Bl)
    position = sp.csr_matrix((np.arange(B.nnz, dtype=float), B.indices, B.indptr), shape=B.shape).T.tocsr()
    order = position.data.astype(np.intp)  # B~^T's entries in B~'s storage order
    t_slots, t_ph, t_pl = _padded(position.indptr, position.indices, Bh[order], Bl[order])
    absolute = sp.csr_matrix((np.abs(Bh), B.indices, B.indptr), shape=B.shape)
    terms = float(max(slots.shape[1], t_slots.shape[1]))
    u = DD_UNIT
    start = np.random.default_rng(2024).standard_normal(n)
    budget, refined = REFINE_WORK, 0
    for j in loose.tolist():
        if (j == k - 1 and not complete) or budget < n**3 / 3:
            continue
        budget -= n**3 / 3
        Ah, Al = dd_add(Kh, Kl, -values[j] * np.eye(n), np.zeros((n, n)))
        factors = dd_lu(Ah, Al)
        yh, yl = start.copy(), np.zeros(n)
        for _ in range(2):
            yh, yl = dd_lu_solve(*factors, yh, yl)
            if not np.all(np.isfinite(yh)):
                break
            scale = 2.0 ** -np.round(np.log2(np.linalg.norm(yh)))  # exact: a power of two
            yh, yl = yh * scale, yl * scale
        if not np.all(np.isfinite(yh)):
            continue
        # E = B~ y, per row over its padded entries
        Eh, El = _row_sums(slots, ph, pl, yh, yl)
        spread = np.asarray(absolute @ np.abs(yh)) * (1 + 1e-12) + 1e-300
        E_error = 2 * terms * u * spread  # (row sums of <= t products, each within a few units)
        norm_y = tree_sum(*dd_mul(yh, yl, yh, yl))
        norm_E = tree_sum(*dd_mul(Eh, El, Eh, El))
        rho_h, rho_l = dd_div(norm_E[0], norm_E[1], norm_y[0], norm_y[1])
        length = float(np.sqrt(norm_y[0]))
        rho_error = ((2 * float(np.sqrt(norm_E[0])) * float(np.linalg.norm(E_error)) + float(np.sum(E_error**2)))
                     / norm_y[0] + 8 * u * abs(float(rho_h))) * (1 + 1e-10)
        # residual B~^T E - rho y
        Rh, Rl = _row_sums(t_slots, t_ph, t_pl, Eh, El)
        Rh, Rl = dd_add(Rh, Rl, *dd_mul(yh, yl, np.full(n, -float(rho_h)), np.full(n, -float(rho_l))))
        R_error = (np.asarray(absolute.T @ (np.abs(Eh) + E_error)) * 2 * terms * u
                   + np.asarray(absolute.T @ E_error) + rho_error * np.abs(yh)) * (1 + 1e-10)
        r = (float(np.linalg.norm(Rh)) * (1 + 4 * n * 2.0**-53) + float(np.linalg.norm(R_error))) / length
        value = float(rho_h)
        lower = values[j - 1] + error[j - 1] if j > 0 else -np.inf
        upper = values[j + 1] - error[j + 1] if j + 1 < k else np.inf
        gap = min(value - lower, upper - value) - rho_error - abs(float(rho_l))
        if not gap > r:
            continue
        # Kato-Temple for the exact rho (within rho_error of rho_h + rho_l), then rho to a double
        bound = (r * r / gap + rho_error + abs(float(rho_l))) * (1 + 1e-6)
        if bound < error[j]:
            values[j], error[j] = value, bound
            refined += 1
    return values, error, refined


def _mp_rows(B: sp.csr_matrix, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> list[list[Any]]:
    """Each row's entries sqrt(w) c / sqrt(m) of B~, in mpmath at the current precision."""
    import mpmath  # (as in `refine_modes`)

    roots = [1 / mpmath.sqrt(mpmath.mpf(float(m))) for m in mass]
    return [[mpmath.sqrt(mpmath.mpf(float(weights[r]))) * mpmath.mpf(float(c)) * roots[j]
             for j, c in zip(B.indices[B.indptr[r]:B.indptr[r + 1]].tolist(), B.data[B.indptr[r]:B.indptr[r + 1]].tolist())]
            for r in range(B.shape[0])]


def _mp_stiffness(rows: list[list[Any]], B: sp.csr_matrix, n: int) -> Any:
    """K~ = B~^T B~ in mpmath from `_mp_rows`, spring by spring."""
    import mpmath  # (as in `refine_modes`)

    K = mpmath.zeros(n, n)
    for r, scaled in enumerate(rows):
        columns = B.indices[B.indptr[r]:B.indptr[r + 1]].tolist()
        for a, ja in zip(scaled, columns):
            for b, jb in zip(scaled, columns):
                K[ja, jb] += a * b
    return K


def _padded(indptr: NDArray[np.intp], indices: NDArray[np.intp], hi: NDArray[np.float64], lo: NDArray[np.float64]
            ) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """A CSR matrix's rows padded to the longest: (columns, hi, lo), padding column 0 and value 0."""
    counts = np.diff(indptr)
    width = int(counts.max(initial=1))
    inside = np.arange(width)[None, :] < counts[:, None]
    slots = np.zeros((counts.shape[0], width), dtype=np.intp)
    ph, pl = np.zeros(slots.shape), np.zeros(slots.shape)
    slots[inside], ph[inside], pl[inside] = indices, hi, lo
    return slots, ph, pl


def _row_sums(slots: NDArray[np.intp], ph: NDArray[np.float64], pl: NDArray[np.float64],
              xh: NDArray[np.float64], xl: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The padded matrix times x, in double-double."""
    return tree_sum(*dd_mul(ph, pl, xh[slots], xl[slots]), axis=-1)


def spring_figures(weighted: Matrix, values: NDArray[np.float64], basis: NDArray[np.float64], vectors: bool,
                   solver: str) -> SolveResult:
    """A result from spring-space values and (mass-weighted) vectors: residuals of K~ = B~^T B~ on a
    sample of columns, the orthogonality of the basis, and a Kato-Temple error per sampled mode."""
    columns = sample_columns(basis.shape[1])
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
