"""The compiled kernels of `vibra.solvers.accurate.count_kernels` one point at a time, as they were before
the kernels took `count_kernels.LANES` points together (commit eabb4f5): a reference whose
arithmetic, in the same order, the lane kernels must reproduce bit for bit (a regression
guard of the restructuring, not an independent truth: the counts' truth is mpmath and the
dense solves of the tests that call this), and the peer of `bench_ring_values.py --kernels`."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.count_kernels import (
    NEAR, _EPS, _TINY, _add, kernel_jit, scalar_mul, scalar_reciprocal, scalar_two_product,
)
from vibra.solvers.compiled import prange


@kernel_jit()
def _count(x: float, m: NDArray[np.float64], compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64],
           off: NDArray[np.float64], square_h: NDArray[np.float64], square_l: NDArray[np.float64],
           closing: float, u: float) -> tuple[int, bool, float]:
    """(count below x, certain, last pivot) for one x: `ring.counts.count_below_springs`' loop."""
    n = m.shape[0]
    size = 2 * n
    ph, pl = scalar_two_product(x, m[0])
    gh, gl = closing, 0.0
    g_error = 0.0
    lh, ll = compliance_h[n - 1], compliance_l[n - 1]
    last_error = u * abs(lh)
    negative = 0
    vanished = False
    for j in range(size - 1):
        if ph < 0:
            negative += 1
        if ph == 0:
            vanished = True
        rh, rl = scalar_reciprocal(ph, pl)
        qh, ql = scalar_mul(gh, gl, rh, rl)
        sh, sl = scalar_mul(gh, gl, qh, ql)
        lh, ll = _add(lh, ll, -sh, -sl)
        inverse = abs(rh) * (1 + 1e-12)  # 1 / |p|, rounded up (float64 bookkeeping)
        last_error = last_error + (2 * abs(gh) + g_error) * g_error * inverse + u * (2 * abs(sh) + abs(lh))
        if j == size - 2:
            break
        fh, fl = scalar_mul(-off[j], 0.0, qh, ql)
        g_error = abs(off[j]) * inverse * g_error * (1 + 1e-12) + 4 * u * abs(fh)
        if j == size - 3:
            fh, fl = _add(fh, fl, off[size - 2], 0.0)
            g_error = g_error + u * (abs(fh) + abs(off[size - 2]))
        th, tl = scalar_mul(rh, rl, square_h[j], square_l[j])
        if j % 2:  # node j + 1 is a site
            dh, dl = scalar_two_product(x, m[(j + 1) // 2])
        else:  # node j + 1 is spring j // 2
            dh, dl = compliance_h[j // 2], compliance_l[j // 2]
        ph, pl = _add(dh, dl, -th, -tl)
        gh, gl = fh, fl
    finite = np.isfinite(lh) and np.isfinite(last_error)
    certain = finite and abs(lh) > 1.01 * last_error + 1e-290 and not vanished
    if lh < 0:
        negative += 1
    return n - negative, certain, lh


@kernel_jit(parallel=True)
def _counts(x: NDArray[np.float64], m: NDArray[np.float64], compliance_h: NDArray[np.float64],
            compliance_l: NDArray[np.float64], off: NDArray[np.float64], square_h: NDArray[np.float64],
            square_l: NDArray[np.float64], closing: float, u: float
            ) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64]]:
    k = x.shape[0]
    count = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    last = np.zeros(k)
    for t in prange(k):
        c, s, lh = _count(x[t], m, compliance_h, compliance_l, off, square_h, square_l, closing, u)
        count[t], certain[t], last[t] = c, s, lh
    return count, certain, last


@kernel_jit()
def _pivot(x: float, m: NDArray[np.float64], compliance: NDArray[np.float64], off: NDArray[np.float64],
           closing: float) -> tuple[float, float]:
    """(l(x), l'(x)): the last pivot of the spring form at x and its derivative, float64."""
    n = m.shape[0]
    size = 2 * n
    p = x * m[0]
    dp = m[0]
    g, dg = closing, 0.0
    last, dlast = compliance[n - 1], 0.0
    for j in range(size - 1):
        if p == 0.0:
            p = _TINY
        r = 1.0 / p
        q = g * r
        dq = (dg - q * dp) * r  # (g / p)'
        last -= g * q
        dlast -= dg * q + g * dq
        if j == size - 2:
            break
        c = off[j]
        f = -c * q
        df = -c * dq
        if j == size - 3:
            f += off[size - 2]
        t = c * c * r  # c^2 / p
        dt = -t * dp * r
        if j % 2:
            d, dd = x * m[(j + 1) // 2], m[(j + 1) // 2]
        else:
            d, dd = compliance[j // 2], 0.0
        p, dp = d - t, dd - dt
        g, dg = f, df
    return last, dlast


@kernel_jit()
def _root(low: float, high: float, pole_low: float, pole_high: float, m: NDArray[np.float64],
          compliance: NDArray[np.float64], off: NDArray[np.float64], closing: float) -> tuple[float, int, int]:
    """(root of l in (low, high), evaluations, side): the rational step on the pole on the
    root's side (Newton's step where that pole is infinite), bisection where it leaves the
    bracket. side -1 (+1): l's sign puts the root within NEAR of the lower (upper) pole,
    returned as the root; 0: a root inside."""
    a, b = low, high
    if not b > a:
        return a, 0, -1
    count = 0
    if np.isfinite(pole_low) and pole_low > 0:
        x = pole_low * (1 + NEAR)
        if x < b:
            f, fp = _pivot(x, m, compliance, off, closing)
            count += 1
            if f >= 0:
                return pole_low, count, -1
            a = x
    if np.isfinite(pole_high):
        x = pole_high * (1 - NEAR)
        if x > a:
            f, fp = _pivot(x, m, compliance, off, closing)
            count += 1
            if f <= 0:
                return pole_high, count, 1
            b = x
    x = 0.5 * (a + b)
    if a > 0 and b > 64 * a:
        x = np.sqrt(a) * np.sqrt(b)
    for _ in range(200):
        f, fp = _pivot(x, m, compliance, off, closing)
        count += 1
        if f == 0.0:
            return x, count, 0
        if f < 0:
            a = x
            pole = pole_high
        else:
            b = x
            pole = pole_low
        if not (fp > 0 and np.isfinite(f) and np.isfinite(fp)):
            step = np.nan
        elif np.isfinite(pole):
            step = (pole - x) * f / (f - fp * (pole - x))
        else:
            step = -f / fp
        new = x + step
        if not (a < new < b):
            new = 0.5 * (a + b)
            if a > 0 and b > 64 * a:
                new = np.sqrt(a) * np.sqrt(b)
        if abs(new - x) <= 2 * _EPS * abs(x) or b - a <= 4 * _EPS * b:
            return new, count, 0
        x = new
    return x, count, 0


@kernel_jit(parallel=True)
def _roots(low: NDArray[np.float64], high: NDArray[np.float64], pole_low: NDArray[np.float64],
           pole_high: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
           off: NDArray[np.float64], closing: float
           ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    k = low.shape[0]
    out = np.zeros(k)
    evaluations = np.zeros(k, dtype=np.int64)
    side = np.zeros(k, dtype=np.int64)
    for t in prange(k):
        out[t], evaluations[t], side[t] = _root(low[t], high[t], pole_low[t], pole_high[t], m, compliance, off,
                                                closing)
    return out, evaluations, side


@kernel_jit()
def _path_count(x: float, site: NDArray[np.bool_], m: NDArray[np.float64], compliance_h: NDArray[np.float64],
                compliance_l: NDArray[np.float64], square_h: NDArray[np.float64], square_l: NDArray[np.float64]
                ) -> tuple[int, bool]:
    """(negative pivots, certain) of the spring form of a path at x: node k is a site (mass
    m[k]) or a spring (compliance 1 / w, double-double), coupled to node k + 1 by c_k (its
    square given, 0 between separate paths). No fill: every pivot is exact for couplings,
    masses and springs perturbed by a few units of double-double; a vanished pivot makes the
    count uncertain."""
    negative = 0
    ph, pl = 0.0, 0.0
    for k in range(site.shape[0]):
        if site[k]:
            dh, dl = scalar_two_product(x, m[k])
        else:
            dh, dl = compliance_h[k], compliance_l[k]
        if k > 0 and square_h[k - 1] != 0.0:
            rh, rl = scalar_reciprocal(ph, pl)
            th, tl = scalar_mul(rh, rl, square_h[k - 1], square_l[k - 1])  # c^2 / p
            ph, pl = _add(dh, dl, -th, -tl)
        else:
            ph, pl = dh, dl
        if ph == 0.0:
            return negative, False
        if ph < 0:
            negative += 1
    return negative, True


@kernel_jit(parallel=True)
def _chain_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                  compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64], square_h: NDArray[np.float64],
                  square_l: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    k = x.shape[0]
    negative = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    for t in prange(k):
        negative[t], certain[t] = _path_count(x[t], site, m, compliance_h, compliance_l, square_h, square_l)
    return negative, certain


def spring_counts(x: NDArray[np.float64], m: NDArray[np.float64], compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                  off: NDArray[np.float64], squares: tuple[NDArray[np.float64], NDArray[np.float64]],
                  closing: float, u: float) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64]]:
    """`count_kernels.spring_counts`, one point at a time."""
    return _counts(np.ascontiguousarray(x, dtype=float), m, compliance[0], compliance[1], off, squares[0], squares[1],
                   float(closing), float(u))


def pivot_roots(low: NDArray[np.float64], high: NDArray[np.float64], pole_low: NDArray[np.float64],
                pole_high: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
                off: NDArray[np.float64], closing: float) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """`count_kernels.pivot_roots`, one root at a time."""
    return _roots(*(np.ascontiguousarray(a, dtype=float) for a in (low, high, pole_low, pole_high)), m,
                  np.ascontiguousarray(compliance, dtype=float), off, float(closing))


def chain_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                 compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                 squares: tuple[NDArray[np.float64], NDArray[np.float64]]) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """`count_kernels._chain_counts` (negative pivots, certain), one point at a time."""
    return _chain_counts(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(site), m, compliance[0],
                         compliance[1], squares[0], squares[1])
