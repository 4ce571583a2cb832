"""A sparse matrix times a block of vectors, compiled: the spring-space Rayleigh-Ritz step's
products B~ V and B~^T E over n x k blocks.

scipy's CSR product (`csr_matvecs`) walks the block row by row with a generic inner loop; on
the (n, k) Fortran-ordered bases ARPACK returns it costs ~4 times a column-by-column pass (a
10^6-site chain, k = 21: 0.39 s against 0.09 s; figures in benchmarks/RESULTS.md, "Figures
formerly in code comments"). Same sums, same order of terms within a row as scipy's: the
results agree bit for bit. Also the triple-double product of `spring_ritz._error_free_product`
(`triple_rows`). Compiled on first call (`vibra.solvers.compiled`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate.count_kernels import FMA, fma, kernel_jit
from vibra.solvers.compiled import compiled_pays, jit

if TYPE_CHECKING:
    from vibra.solvers.common import MatrixLike

__all__ = ["times", "transposed_times", "rayleigh_quotients", "triple_rows", "SCIPY_PRODUCT_S"]

#: Seconds per stored entry of B and column of V of scipy's CSR product, the kernels' counterpart
#: (the same bits): 3e-9 (V C-ordered) to 1.1e-8 (Fortran-ordered) measured, one core. A product
#: estimated under `vibra.solvers.compiled.COMPILED_FROM_S` (~10^7 entries x columns) takes scipy.
SCIPY_PRODUCT_S = 1e-8


@jit(cache=True, nogil=True, error_model="numpy", fastmath=False, aot=True)  # no division: the same code
def _columns(indptr: NDArray[np.int32], indices: NDArray[np.int32], data: NDArray[np.float64],
             V: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover (compiled)
    rows, k = out.shape
    for j in range(k):
        for i in range(rows):
            total = 0.0
            for p in range(indptr[i], indptr[i + 1]):
                total += data[p] * V[indices[p], j]
            out[i, j] = total


@jit(cache=True, nogil=True, error_model="numpy", fastmath=False, aot=True)  # no division: the same code
def _rows(indptr: NDArray[np.int32], indices: NDArray[np.int32], data: NDArray[np.float64],
          V: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover (compiled)
    rows, k = out.shape
    for i in range(rows):
        for j in range(k):
            out[i, j] = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            a = data[p]
            c = indices[p]
            for j in range(k):
                out[i, j] += a * V[c, j]


def times(B: MatrixLike, V: NDArray[np.float64]) -> NDArray[np.float64]:
    """B @ V for a sparse B and a dense (n, k) block, in V's memory order (a dense B: BLAS)."""
    if not sp.issparse(B):
        return np.asarray(B) @ V
    B = sp.csr_matrix(B)
    V = np.asarray(V, dtype=np.float64)
    data = np.asarray(B.data, dtype=np.float64)
    by_rows = V.flags.c_contiguous and not V.flags.f_contiguous
    if not compiled_pays(SCIPY_PRODUCT_S * B.nnz * V.shape[1]):  # scipy's product: the same sums, in order
        product = np.asarray(sp.csr_matrix((data, B.indices, B.indptr), shape=B.shape) @ V)
        return product if by_rows else np.asfortranarray(product)
    if by_rows:
        out = np.empty((B.shape[0], V.shape[1]))
        _rows(B.indptr, B.indices, data, V, out)
        return out
    V = np.asfortranarray(V)
    out = np.empty((B.shape[0], V.shape[1]), order="F")
    _columns(B.indptr, B.indices, data, V, out)
    return out


def transposed_times(B: MatrixLike, E: NDArray[np.float64]) -> NDArray[np.float64]:
    """B^T @ E (B^T formed once in CSR: O(nnz))."""
    if not sp.issparse(B):
        return np.asarray(B).T @ E
    return times(sp.csr_matrix(B).T.tocsr(), E)


@jit(cache=True, nogil=True, inline="always")
def _two_sum(a: float, b: float) -> tuple[float, float]:  # pragma: no cover (compiled)
    s = a + b
    v = s - a
    return s, (a - (s - v)) + (b - v)


@jit(cache=True, nogil=True, inline="always")
def _two_product(a: float, b: float) -> tuple[float, float]:  # pragma: no cover (compiled)
    p = a * b
    if FMA:  # (one fused multiply-add: the same exact error as Dekker's splitting below)
        return p, fma(a, b, -p)
    t = 134217729.0 * a
    ah = t - (t - a)
    al = a - ah
    t = 134217729.0 * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@jit(cache=True, nogil=True, inline="always")
def _add(xh: float, xl: float, yh: float, yl: float) -> tuple[float, float]:  # pragma: no cover
    s, e = _two_sum(xh, yh)
    e += xl + yl
    h = s + e
    return h, e - (h - s)


@jit(cache=True, nogil=True)
def _rayleigh_columns(indptr: NDArray[np.int32], indices: NDArray[np.int32], data: NDArray[np.float64],
                      V: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover
    rows = indptr.shape[0] - 1
    n, k = V.shape
    for j in range(k):
        nh, nl = 0.0, 0.0
        for i in range(rows):
            rh, rl = 0.0, 0.0
            for p in range(indptr[i], indptr[i + 1]):
                ph, pl = _two_product(data[p], V[indices[p], j])
                rh, rl = _add(rh, rl, ph, pl)
            sh, sl = _two_product(rh, rh)
            sl += 2.0 * rh * rl
            nh, nl = _add(nh, nl, sh, sl)
        dh, dl = 0.0, 0.0
        for i in range(n):
            sh, sl = _two_product(V[i, j], V[i, j])
            dh, dl = _add(dh, dl, sh, sl)
        q = nh / dh  # (nh + nl) / (dh + dl) in double-double, rounded once
        ph, pl = _two_product(q, dh)
        out[j] = q + ((nh - ph) - pl + nl - q * dl) / dh


def rayleigh_quotients(B: MatrixLike, V: NDArray[np.float64]) -> NDArray[np.float64]:
    """||B v||^2 / ||v||^2 for each column v of V, in double-double (every product exact, every
    sum compensated), rounded once: the Rayleigh quotients of B^T B for the vectors as stored,
    right to a few units of 1e-32 relative for a B whose rows have a few terms."""
    B = sp.csr_matrix(B)
    out = np.empty(V.shape[1])
    _rayleigh_columns(B.indptr, B.indices, np.asarray(B.data, dtype=np.float64), np.asfortranarray(V), out)
    return out


@kernel_jit()
def triple_rows(indptr: NDArray[np.int64], indices: NDArray[np.int64], data: NDArray[np.float64],
                V: NDArray[np.float64], parts: NDArray[np.float64]) -> None:  # pragma: no cover - compiled
    """parts[0] + parts[1] + parts[2] = B V row by row (`spring_ritz._error_free_product`):
    Dekker's two-product of every entry (split at 2^27 + 1; no FMA), the high parts summed by
    two-sum into parts[0], their errors and the products' low parts by two-sum into parts[1],
    what those leave into parts[2]."""
    splitter = 134217729.0
    columns = V.shape[1]
    for i in range(indptr.shape[0] - 1):
        for p in range(indptr[i], indptr[i + 1]):
            a = data[p]
            c = splitter * a
            a_high = c - (c - a)
            a_low = a - a_high
            row = indices[p]
            for j in range(columns):
                b = V[row, j]
                product = a * b
                d = splitter * b
                b_high = d - (d - b)
                b_low = b - b_high
                error = ((a_high * b_high - product) + a_high * b_low + a_low * b_high) + a_low * b_low
                high = parts[0, i, j]
                total = high + product
                back = total - high
                carry = (high - (total - back)) + (product - back)
                parts[0, i, j] = total
                for term in (carry, error):
                    low = parts[1, i, j]
                    sum_low = low + term
                    back_low = sum_low - low
                    parts[2, i, j] += (low - (sum_low - back_low)) + (term - back_low)
                    parts[1, i, j] = sum_low
