"""Double-double arithmetic on numpy arrays: a value is a pair (hi, lo), hi = fl(hi + lo),
about 32 digits (unit ~2^-104 per operation, each within a few units; not correctly rounded).

The ring counts (`vibra.solvers.accurate.ring.counts`) and the refinement of the accurate paths' loosest
bounds (`vibra.solvers.accurate.spring_ritz.refine_modes`) use it: a dense LU with partial pivoting,
its solves, and sums by pairwise reduction. Written here: numpy has no extended type beyond
x87's 80-bit longdouble (~19 digits), and the packages that have one (mpmath, ~1,000 times
slower per operation; python-flint, gmpy2) are not vectorised over arrays or not installed.
"""

from __future__ import annotations

from typing import Union

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.rounding import two_product, two_sum

__all__ = ["UNIT", "fast", "add", "mul", "div", "split_mp", "tree_sum", "lu", "lu_solve"]

#: Unit roundoff of one double-double operation, generously (16 units of 2^-104).
UNIT = 16 * 2.0**-104

Pair = tuple[NDArray[np.float64], NDArray[np.float64]]
#: One half of an operand: an array, or a float broadcast against the other operand's (``0.0``: an
#: operand exact in double).
Part = Union[NDArray[np.float64], float]


def fast(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    s = a + b
    return s, b - (s - a)


def add(ah: Part, al: Part, bh: Part, bl: Part) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    s, e = two_sum(ah, bh)
    t, f = two_sum(al, bl)
    s, e = fast(s, e + t)
    return fast(s, e + f)


def mul(ah: Part, al: Part, bh: Part, bl: Part) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    p, e = two_product(ah, bh)
    return fast(p, e + (ah * bl + al * bh))


def div(ah: Part, al: Part, bh: Part, bl: Part) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    q1 = ah / bh
    ph, pl = mul(bh, bl, q1, 0.0)
    rh, rl = add(ah, al, -ph, -pl)
    q2 = rh / bh
    ph, pl = mul(bh, bl, q2, 0.0)
    rh, _ = add(rh, rl, -ph, -pl)
    q3 = rh / bh
    s, e = fast(q1, q2)
    return add(s, e, q3, 0.0)


def split_mp(values: object) -> Pair:
    """mpmath numbers (any shape of nested lists, or an mpmath matrix's rows) as (hi, lo) arrays."""
    import mpmath

    flat = np.asarray(values, dtype=object)
    hi = np.vectorize(float, otypes=[float])(flat)
    # (v - h rounded once; mpf(v) itself would first round v to the working precision)
    lo = np.vectorize(lambda v, h: float(v - mpmath.mpf(h)), otypes=[float])(flat, hi)
    return hi, lo


def tree_sum(hi: NDArray[np.float64], lo: NDArray[np.float64], axis: int = -1) -> Pair:
    """Sum along `axis` by pairwise double-double additions (error ~ log2(m) units of the sum
    of magnitudes)."""
    hi, lo = np.moveaxis(hi, axis, -1), np.moveaxis(lo, axis, -1)
    while hi.shape[-1] > 1:
        if hi.shape[-1] % 2:
            pad = [(0, 0)] * (hi.ndim - 1) + [(0, 1)]
            hi, lo = np.pad(hi, pad), np.pad(lo, pad)
        hi, lo = add(hi[..., 0::2], lo[..., 0::2], hi[..., 1::2], lo[..., 1::2])
    return hi[..., 0], lo[..., 0]


def lu(hi: NDArray[np.float64], lo: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                                  NDArray[np.intp]]:
    """LU with partial pivoting of a square (hi, lo), in place of copies: (LU hi, LU lo, row order)."""
    hi, lo = hi.copy(), lo.copy()
    n = hi.shape[0]
    order = np.arange(n)
    for k in range(n - 1):
        p = k + int(np.argmax(np.abs(hi[k:, k])))
        if p != k:
            for matrix in (hi, lo):
                matrix[[k, p]] = matrix[[p, k]]
            order[[k, p]] = order[[p, k]]
        if hi[k, k] == 0:
            continue
        lh, ll = div(hi[k + 1:, k], lo[k + 1:, k], hi[k, k], lo[k, k])
        hi[k + 1:, k], lo[k + 1:, k] = lh, ll
        ph, pl = mul(lh[:, None], ll[:, None], hi[k, k + 1:][None, :], lo[k, k + 1:][None, :])
        hi[k + 1:, k + 1:], lo[k + 1:, k + 1:] = add(hi[k + 1:, k + 1:], lo[k + 1:, k + 1:], -ph, -pl)
    return hi, lo, order


def lu_solve(hi: NDArray[np.float64], lo: NDArray[np.float64], order: NDArray[np.intp],
             bh: NDArray[np.float64], bl: NDArray[np.float64]) -> Pair:
    """Solve with the factors of `lu` (forward, then back substitution, row by row)."""
    n = hi.shape[0]
    yh, yl = bh[order].copy(), bl[order].copy()
    for i in range(1, n):
        ph, pl = mul(hi[i, :i], lo[i, :i], yh[:i], yl[:i])
        sh, sl = tree_sum(ph, pl)
        yh[i], yl[i] = add(yh[i], yl[i], -sh, -sl)
    xh, xl = np.zeros(n), np.zeros(n)
    for i in range(n - 1, -1, -1):
        ph, pl = mul(hi[i, i + 1:], lo[i, i + 1:], xh[i + 1:], xl[i + 1:])
        sh, sl = tree_sum(ph, pl) if i + 1 < n else (np.zeros(()), np.zeros(()))
        rh, rl = add(yh[i], yl[i], -sh, -sl)
        xh[i], xl[i] = div(rh, rl, hi[i, i], lo[i, i]) if hi[i, i] != 0 else (np.inf, 0.0)
    return xh, xl
