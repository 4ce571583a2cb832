"""A sparse matrix times a block of vectors, compiled: the spring-space Rayleigh-Ritz step's
products B~ V and B~^T E over n x k blocks.

scipy's CSR product (`csr_matvecs`) walks the block row by row with a generic inner loop; on
the (n, k) Fortran-ordered bases ARPACK returns it costs ~4 times a column-by-column pass (a
10^6-site chain, k = 21: 0.39 s against 0.09 s; figures in benchmarks/RESULTS.md, "Figures
formerly in code comments"). Same sums, same order of terms within a row as scipy's: the
results agree bit for bit.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate.ring.kernel import FMA, _fma

__all__ = ["times", "transposed_times", "rayleigh_quotients"]


@numba.njit(cache=True, nogil=True)
def _columns(indptr: NDArray[np.int32], indices: NDArray[np.int32], data: NDArray[np.float64],
             V: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover (compiled)
    rows, k = out.shape
    for j in range(k):
        for i in range(rows):
            total = 0.0
            for p in range(indptr[i], indptr[i + 1]):
                total += data[p] * V[indices[p], j]
            out[i, j] = total


@numba.njit(cache=True, nogil=True)
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


def times(B: Any, V: NDArray[np.float64]) -> NDArray[np.float64]:
    """B @ V for a sparse B and a dense (n, k) block, in V's memory order (a dense B: BLAS)."""
    if not sp.issparse(B):
        return np.asarray(B) @ V
    B = sp.csr_matrix(B)
    V = np.asarray(V, dtype=np.float64)
    data = np.asarray(B.data, dtype=np.float64)
    if V.flags.c_contiguous and not V.flags.f_contiguous:
        out = np.empty((B.shape[0], V.shape[1]))
        _rows(B.indptr, B.indices, data, V, out)
        return out
    V = np.asfortranarray(V)
    out = np.empty((B.shape[0], V.shape[1]), order="F")
    _columns(B.indptr, B.indices, data, V, out)
    return out


def transposed_times(B: Any, E: NDArray[np.float64]) -> NDArray[np.float64]:
    """B^T @ E (B^T formed once in CSR: O(nnz))."""
    if not sp.issparse(B):
        return np.asarray(B).T @ E
    return times(sp.csr_matrix(B).T.tocsr(), E)


@numba.njit(cache=True, nogil=True, inline="always")
def _two_sum(a: float, b: float) -> tuple[float, float]:  # pragma: no cover (compiled)
    s = a + b
    v = s - a
    return s, (a - (s - v)) + (b - v)


@numba.njit(cache=True, nogil=True, inline="always")
def _two_product(a: float, b: float) -> tuple[float, float]:  # pragma: no cover (compiled)
    p = a * b
    if FMA:  # (one fused multiply-add: the same exact error as Dekker's splitting below)
        return p, _fma(a, b, -p)
    t = 134217729.0 * a
    ah = t - (t - a)
    al = a - ah
    t = 134217729.0 * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@numba.njit(cache=True, nogil=True, inline="always")
def _add(xh: float, xl: float, yh: float, yl: float) -> tuple[float, float]:  # pragma: no cover
    s, e = _two_sum(xh, yh)
    e += xl + yl
    h = s + e
    return h, e - (h - s)


@numba.njit(cache=True, nogil=True)
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


def rayleigh_quotients(B: Any, V: NDArray[np.float64]) -> NDArray[np.float64]:
    """||B v||^2 / ||v||^2 for each column v of V, in double-double (every product exact, every
    sum compensated), rounded once: the Rayleigh quotients of B^T B for the vectors as stored,
    right to a few units of 1e-32 relative for a B whose rows have a few terms."""
    B = sp.csr_matrix(B)
    out = np.empty(V.shape[1])
    _rayleigh_columns(B.indptr, B.indices, np.asarray(B.data, dtype=np.float64), np.asfortranarray(V), out)
    return out
