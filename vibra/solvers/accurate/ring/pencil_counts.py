"""A ring's inertia counts of K - x M in double-double, compiled: `ring.counts.count_below` at ~1.5x
the speed of the spring form's counts per site, for the values that an absolute perturbation
of ~1e-30 ||K~|| leaves relatively sharp (every value of a ring whose K~ spans < 1e17).

`ring.counts.count_below` (numpy, the reference) counts the negative pivots of an LDL^T of the
cyclic tridiagonal K - x M, the corner carried as fill g of the last row, whose pivot l carries
a running error bound. This is the same elimination, LANES points at a time in SIMD lanes
(`count_kernels`' layout), with two changes that keep its error analysis:

- K's entries are formed from the springs in double-double here (`pencil_entries`: each a sum
  of at most `terms` products w c^2, every one positive, so within (terms + 1) `dd.UNIT` of
  itself), not in mpmath (~1 s per 10^4 sites): the counts are exact for K within
  `entry_error` R of the given one (Weyl, R the pencil's row-sum bound) on top of
  `ring.counts.RHO_UNIT` (R + |x|);
- sums are double-double's one-two_sum addition (`_sum`), whose error is within `dd.UNIT`
  (|a| + |b|) (~3 2^-106 (|a| + |b|)): a relative perturbation of each operand, which is what
  the analysis attributes to each entry (the diagonal, the squared coupling), 11 operations
  where the correctly rounding addition takes 20.

Per node: the pivot's reciprocal by one Newton step (`count_kernels.scalar_reciprocal`), g / p, g^2 / p,
the next fill and pivot; its rounding within `RHO_UNIT` (R + |x|) as in `count_below` (the
diagonal within 2 units of |a| + x m, the coupling within 2 relatively), the fill's own
rounding within 6 units (3 operations and the coupling's perturbation) of it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.dd import UNIT, add, mul
from vibra.solvers.accurate.rounding import two_product
from vibra.solvers.accurate.ring.counts import RHO_UNIT, RingPencil
from vibra.solvers.accurate.count_kernels import (
    LANES, kernel_jit, values_by_sites, scalar_mul, scalar_reciprocal, scalar_two_product, scalar_two_sum,
)
from vibra.solvers.compiled import prange

__all__ = ["PencilCounts", "pencil_entries", "pencil_width"]

# rows of a block's state (one column per lane)
_X, _PH, _PL, _GH, _GL, _GE, _LH, _LL, _LE, _NEG, _VAN = range(11)


@kernel_jit()
def _sum(ah: float, al: float, bh: float, bl: float) -> tuple[float, float]:
    """a + b in double-double, within `dd.UNIT` (|a| + |b|): one two_sum of the high parts."""
    s, e = scalar_two_sum(ah, bh)
    e = e + (al + bl)
    h = s + e
    return h, e - (h - s)


@kernel_jit()
def _pencil_block(x: NDArray[np.float64], start: int, m: NDArray[np.float64], a_h: NDArray[np.float64],
                  a_l: NDArray[np.float64], b_h: NDArray[np.float64], b_l: NDArray[np.float64],
                  square_h: NDArray[np.float64], square_l: NDArray[np.float64], u: float,
                  count: NDArray[np.int64], certain: NDArray[np.bool_]) -> None:
    """`ring.counts.count_below`'s loop for the points x[start: start + LANES] (the last repeated).
    Each node's lane loop has no branch: the last node also forms a next fill and pivot, unused,
    and the last row's own coupling joins the fill in a loop of its own."""
    k = x.shape[0]
    n = m.shape[0]
    s = np.zeros((11, LANES))
    for p in range(LANES):
        xp = x[min(start + p, k - 1)]
        s[_X, p] = xp
        th, tl = scalar_two_product(xp, m[0])
        s[_PH, p], s[_PL, p] = _sum(a_h[0], a_l[0], -th, -tl)
        s[_GH, p], s[_GL, p] = b_h[n - 1], b_l[n - 1]  # the corner: fill of row 0
        th, tl = scalar_two_product(xp, m[n - 1])
        s[_LH, p], s[_LL, p] = _sum(a_h[n - 1], a_l[n - 1], -th, -tl)
        s[_LE, p] = u * (abs(a_h[n - 1]) + abs(xp) * m[n - 1])
    for i in range(n - 1):
        bh, bl, square, square_low = b_h[i], b_l[i], square_h[i], square_l[i]
        j = min(i + 1, n - 1)
        mass, ah, al = m[j], a_h[j], a_l[j]
        for p in range(LANES):  # node i's pivot eliminated from g and l, then the next fill and pivot
            ph, pl = s[_PH, p], s[_PL, p]
            s[_NEG, p] += 1.0 if ph < 0 else 0.0
            s[_VAN, p] += 1.0 if ph == 0 else 0.0
            rh, rl = scalar_reciprocal(ph, pl)
            gh, gl = s[_GH, p], s[_GL, p]
            qh, ql = scalar_mul(gh, gl, rh, rl)  # g / p
            sh, sl = scalar_mul(gh, gl, qh, ql)  # g^2 / p
            lh, ll = _sum(s[_LH, p], s[_LL, p], -sh, -sl)
            s[_LH, p], s[_LL, p] = lh, ll
            inverse = abs(rh) * (1 + 1e-12)  # 1 / |p|, rounded up
            g_error = s[_GE, p]
            # g^2 / p's error: from g's, its rounding (3 operations), the sum's (|l_old| <= |l| + |g^2 / p|)
            s[_LE, p] = s[_LE, p] + (2 * abs(gh) + g_error) * g_error * inverse + u * (3 * abs(sh) + abs(lh))
            fh, fl = scalar_mul(-bh, -bl, qh, ql)  # the next fill: -b g / p
            s[_GE, p] = abs(bh) * inverse * g_error * (1 + 1e-12) + 6 * u * abs(fh)
            s[_GH, p], s[_GL, p] = fh, fl
            th, tl = scalar_mul(rh, rl, square, square_low)  # b^2 / p
            dh, dl = scalar_two_product(s[_X, p], mass)
            dh, dl = _sum(ah, al, -dh, -dl)  # a - x m
            s[_PH, p], s[_PL, p] = _sum(dh, dl, -th, -tl)
        if i == n - 3:  # the last row's own coupling joins the fill
            ch, cl = b_h[n - 2], b_l[n - 2]
            for p in range(LANES):
                fh, fl = _sum(s[_GH, p], s[_GL, p], ch, cl)
                s[_GE, p] = s[_GE, p] + u * (abs(s[_GH, p]) + abs(ch)) * (1 + 1e-12)
                s[_GH, p], s[_GL, p] = fh, fl
    for p in range(min(LANES, k - start)):
        lh, last_error = s[_LH, p], s[_LE, p]
        finite = np.isfinite(lh) and np.isfinite(last_error)
        certain[start + p] = finite and abs(lh) > 1.01 * last_error + 1e-290 and s[_VAN, p] == 0
        count[start + p] = int(s[_NEG, p]) + (1 if lh < 0 else 0)


@kernel_jit(parallel=True, aot=True, work=values_by_sites)
def _counts(x: NDArray[np.float64], m: NDArray[np.float64], a_h: NDArray[np.float64], a_l: NDArray[np.float64],
            b_h: NDArray[np.float64], b_l: NDArray[np.float64], square_h: NDArray[np.float64],
            square_l: NDArray[np.float64], u: float) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    k = x.shape[0]
    count = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    for b in prange((k + LANES - 1) // LANES):
        _pencil_block(x, b * LANES, m, a_h, a_l, b_h, b_l, square_h, square_l, u, count, certain)
    return count, certain


class PencilCounts:
    """The counts of one ring's K - x M: its entries formed once (`pencil_entries`), then
    `counts(x)` -> (count below x, certain) and `width(x)`, the pencil perturbation the counts
    are exact within at x (eigenvalues move by at most that, Weyl)."""

    def __init__(self, pencil: RingPencil) -> None:
        (self.a, self.b), self.entry_error = pencil_entries(pencil)
        self.squares = mul(self.b[0], self.b[1], self.b[0], self.b[1])
        self.m = np.ascontiguousarray(pencil.m, dtype=float)
        self.R = float(pencil.R)

    def counts(self, x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        count, certain = _counts(np.ascontiguousarray(x, dtype=float), self.m, self.a[0], self.a[1], self.b[0],
                                 self.b[1], self.squares[0], self.squares[1], UNIT)
        return count.astype(np.intp), certain

    def width(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return pencil_width(self.R, self.entry_error, x)


def pencil_width(R: float, entry_error: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """How far the eigenvalues of the pencil the counts at x are exact for may lie from (K, M)'s:
    RHO_UNIT (R + |x|) for the elimination, entry_error R for forming K (rounded up)."""
    return (RHO_UNIT * (R + np.abs(x)) + entry_error * R) * (1 + 1e-12)


def pencil_entries(pencil: RingPencil) -> tuple[tuple[tuple[NDArray[np.float64], NDArray[np.float64]],
                                                      tuple[NDArray[np.float64], NDArray[np.float64]]], float]:
    """((a, b), error): K's diagonal a (each position's sum of w c^2 over its terms) and cycle
    couplings b (w c1 c2) in double-double from the springs, and their relative error bound:
    each product within `dd.UNIT` (two_product, then one double-double product), each of a's
    sums of positive terms within one more per term."""
    n = pencil.n
    position, w, c = pencil.terms
    ph, pl = two_product(np.asarray(w, dtype=float), np.asarray(c, dtype=float))
    th, tl = mul(ph, pl, np.asarray(c, dtype=float), np.zeros(c.shape))  # w c^2
    order = np.argsort(position, kind="stable")
    position, th, tl = position[order], th[order], tl[order]
    first = np.searchsorted(position, np.arange(n))
    rank = np.arange(position.shape[0]) - first[position]
    ah, al = np.zeros(n), np.zeros(n)
    most = int(rank.max(initial=0)) + 1
    for r in range(most):
        pick = rank == r
        ah[position[pick]], al[position[pick]] = add(ah[position[pick]], al[position[pick]], th[pick], tl[pick])
    ew, e1, e2 = (np.asarray(v, dtype=float) for v in pencil.edges)
    qh, ql = two_product(ew, e1)
    bh, bl = mul(qh, ql, e2, np.zeros(n))
    return ((ah, al), (bh, bl)), (most + 1) * UNIT
