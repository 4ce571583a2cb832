"""Compiled loops of the ring's values-only path (numba): roots of the spring form's last pivot,
and its inertia counts in double-double.

A free ring (no spring to a wall) with its dofs taken around the cycle, cut at its closing
spring r (`cycle.count_below_springs` picks it), has the spring form
A(x) = [[W^-1, B], [B^T, x M]] with 2n nodes on a path (site 0, spring 0, site 1, ...,
site n-1, spring n-1 = r) closed by one coupling (spring r to site 0). Eliminating the path
in order, the last pivot l(x) = 1/w_r - y^T A_sub(x)^-1 y is the Schur complement of the
cut chain's spring form A_sub: zero at the ring's eigenvalues, with poles at the chain's, and
increasing in x between them (A_sub' = diag(M, 0) >= 0). By interlacing (the ring is the chain
plus one spring) eigenvalue i of the ring lies between the chain's i and i + 1.

- `pivot_roots`: each root of l between two consecutive poles, by a safeguarded iteration in
  float64 (the pole on the root's side as a rational model, f ~ s + c / (p - x), which the
  secular function l is near a pole; bisection where a step leaves the bracket). The roots
  are not trusted: `spring_counts` certifies them.
- `spring_counts`: `cycle.count_below_springs`, the same double-double operations in the same
  order with its running error, per point in compiled loops (numba threads over the points),
  except the reciprocal of each pivot: one Newton step (`_reciprocal`, within `dd.UNIT` as
  `dd.div` is, at a third of its operations). ~40 ns per point and node on one core, where the
  numpy version pays its call overhead on each operation over the vector of points.

numba compiles without fast-math (IEEE operations, no contraction into FMA), so the
error-free transformations stay exact; the first call compiles (~5 s), cached on disk after.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

try:
    import numba
except ImportError:  # pragma: no cover - numba ships wheels for every Python vibra supports
    numba = None  # type: ignore[assignment]

__all__ = ["AVAILABLE", "pivot_roots", "spring_counts", "path_counts"]

#: Whether the compiled loops can run here.
AVAILABLE = numba is not None

_SPLIT = 134217729.0  # 2^27 + 1 (Dekker)
_EPS = float(np.finfo(float).eps)
_TINY = float(np.finfo(float).tiny)


def _jit(parallel: bool = False) -> Any:
    def wrap(function: Any) -> Any:
        if numba is None:  # pragma: no cover
            return function
        return numba.njit(cache=True, fastmath=False, nogil=True, error_model="numpy", parallel=parallel)(function)
    return wrap


def _range(n: int) -> Any:  # pragma: no cover - replaced by numba.prange when compiled
    return range(n)


prange = numba.prange if numba is not None else _range


# --- double-double, scalar: the operations of `vibra.solvers.dd` and `vibra.solvers.rounding` ---

@_jit()
def _two_sum(a: float, b: float) -> tuple[float, float]:
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@_jit()
def _fast(a: float, b: float) -> tuple[float, float]:
    s = a + b
    return s, b - (s - a)


@_jit()
def _split(a: float) -> tuple[float, float]:
    c = _SPLIT * a
    high = c - (c - a)
    return high, a - high


@_jit()
def _two_product(a: float, b: float) -> tuple[float, float]:
    ah, al = _split(a)
    bh, bl = _split(b)
    p = a * b
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@_jit()
def _add(ah: float, al: float, bh: float, bl: float) -> tuple[float, float]:
    s, e = _two_sum(ah, bh)
    t, f = _two_sum(al, bl)
    s, e = _fast(s, e + t)
    return _fast(s, e + f)


@_jit()
def _mul(ah: float, al: float, bh: float, bl: float) -> tuple[float, float]:
    p, e = _two_product(ah, bh)
    return _fast(p, e + (ah * bl + al * bh))


@_jit()
def _reciprocal(ph: float, pl: float) -> tuple[float, float]:
    """1 / (ph + pl) in double-double by one Newton step: r = fl(1 / ph), e = 1 - (ph + pl) r
    formed from Dekker's exact product (|e| <= 2^-51.9, its own rounding ~2^-104 |r e|
    relatively), r (1 + e) to within e^2 + 3 2^-105 ~ 6 2^-104 relatively: inside `dd.UNIT`
    (16 2^-104), as `dd.div(1, 0, ph, pl)` is, at a third of its operations."""
    r = 1.0 / ph
    p, q = _two_product(ph, r)
    e = ((1.0 - p) - q) - pl * r
    return _fast(r, r * e)


# --- the counts ---

@_jit()
def _count(x: float, m: NDArray[np.float64], compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64],
           off: NDArray[np.float64], square_h: NDArray[np.float64], square_l: NDArray[np.float64],
           closing: float, u: float) -> tuple[int, bool, float]:
    """(count below x, certain, last pivot) for one x: `cycle.count_below_springs`' loop."""
    n = m.shape[0]
    size = 2 * n
    x_high, x_low = _split(x)
    mh, ml = _split(m[0])
    ph = x * m[0]
    pl = ((x_high * mh - ph) + x_high * ml + x_low * mh) + x_low * ml
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
        rh, rl = _reciprocal(ph, pl)
        qh, ql = _mul(gh, gl, rh, rl)
        sh, sl = _mul(gh, gl, qh, ql)
        lh, ll = _add(lh, ll, -sh, -sl)
        inverse = abs(rh) * (1 + 1e-12)  # 1 / |p|, rounded up (float64 bookkeeping)
        last_error = last_error + (2 * abs(gh) + g_error) * g_error * inverse + u * (2 * abs(sh) + abs(lh))
        if j == size - 2:
            break
        fh, fl = _mul(-off[j], 0.0, qh, ql)
        g_error = abs(off[j]) * inverse * g_error * (1 + 1e-12) + 4 * u * abs(fh)
        if j == size - 3:
            fh, fl = _add(fh, fl, off[size - 2], 0.0)
            g_error = g_error + u * (abs(fh) + abs(off[size - 2]))
        th, tl = _mul(rh, rl, square_h[j], square_l[j])
        if j % 2:  # node j + 1 is a site
            i = (j + 1) // 2
            mh, ml = _split(m[i])
            dh = x * m[i]
            dl = ((x_high * mh - dh) + x_high * ml + x_low * mh) + x_low * ml
        else:  # node j + 1 is spring j // 2
            dh, dl = compliance_h[j // 2], compliance_l[j // 2]
        ph, pl = _add(dh, dl, -th, -tl)
        gh, gl = fh, fl
    finite = np.isfinite(lh) and np.isfinite(last_error)
    certain = finite and abs(lh) > 1.01 * last_error + 1e-290 and not vanished
    if lh < 0:
        negative += 1
    return n - negative, certain, lh


@_jit(parallel=True)
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


def spring_counts(x: NDArray[np.float64], m: NDArray[np.float64], compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                  off: NDArray[np.float64], squares: tuple[NDArray[np.float64], NDArray[np.float64]],
                  closing: float, u: float) -> tuple[NDArray[np.intp], NDArray[np.bool_], NDArray[np.float64]]:
    """(count, certain, last pivot's high part) at each x: the inertia counts of the spring form
    (path order: m per site, compliance 1/w per spring as double-double, off the 2n - 1 path
    couplings and squares their squares as double-double, closing the coupling of spring n - 1
    to site 0), exactly as `cycle.count_below_springs` computes them (per-node unit u)."""
    count, certain, last = _counts(np.ascontiguousarray(x, dtype=float), m, compliance[0], compliance[1], off,
                                   squares[0], squares[1], float(closing), float(u))
    return count.astype(np.intp), certain, last


# --- the roots, float64 ---

@_jit()
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


#: A root within this relative distance of a pole is taken to be at the pole: there float64's
#: l(x) carries noise ~eps / distance (terms ~1 / distance that cancel), as large as l itself
#: (~distance) near 1e-8; at 1e-6 the sign of l is still sure.
NEAR = 1e-6


@_jit()
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


@_jit(parallel=True)
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


def pivot_roots(low: NDArray[np.float64], high: NDArray[np.float64], pole_low: NDArray[np.float64],
                pole_high: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
                off: NDArray[np.float64], closing: float
                ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
    """(root, evaluations of l, side) of the last pivot in each bracket (low, high), float64: side
    -1 or +1 where the root was taken at the lower or upper pole (within NEAR), 0 inside."""
    roots, evaluations, side = _roots(*(np.ascontiguousarray(a, dtype=float) for a in (low, high, pole_low, pole_high)),
                                m, np.ascontiguousarray(compliance, dtype=float), off, float(closing))
    return roots, evaluations.astype(np.intp), side.astype(np.intp)


# --- a path's counts (chains: no closing coupling, no fill) ---

@_jit()
def _path_count(x: float, site: NDArray[np.bool_], m: NDArray[np.float64], compliance_h: NDArray[np.float64],
                compliance_l: NDArray[np.float64], square_h: NDArray[np.float64], square_l: NDArray[np.float64]
                ) -> tuple[int, bool]:
    """(negative pivots, certain) of the spring form of a path at x: node k is a site (mass
    m[k]) or a spring (compliance 1 / w, double-double), coupled to node k + 1 by c_k (its
    square given, 0 between separate paths). No fill: every pivot is exact for couplings,
    masses and springs perturbed by a few units of double-double; a vanished pivot makes the
    count uncertain."""
    x_high, x_low = _split(x)
    negative = 0
    ph, pl = 0.0, 0.0
    for k in range(site.shape[0]):
        if site[k]:
            mh, ml = _split(m[k])
            dh = x * m[k]
            dl = ((x_high * mh - dh) + x_high * ml + x_low * mh) + x_low * ml
        else:
            dh, dl = compliance_h[k], compliance_l[k]
        if k > 0 and square_h[k - 1] != 0.0:
            rh, rl = _reciprocal(ph, pl)
            th, tl = _mul(rh, rl, square_h[k - 1], square_l[k - 1])  # c^2 / p
            ph, pl = _add(dh, dl, -th, -tl)
        else:
            ph, pl = dh, dl
        if ph == 0.0:
            return negative, False
        if ph < 0:
            negative += 1
    return negative, True


@_jit(parallel=True)
def _path_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                 compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64], square_h: NDArray[np.float64],
                 square_l: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    k = x.shape[0]
    negative = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    for t in prange(k):
        negative[t], certain[t] = _path_count(x[t], site, m, compliance_h, compliance_l, square_h, square_l)
    return negative, certain


def path_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                squares: tuple[NDArray[np.float64], NDArray[np.float64]]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """(count below x, certain) of the eigenvalues of paths of sites and springs (`_path_count`:
    node k a site with mass m[k] or a spring with compliance 1 / w, squares[k] the square of the
    coupling of nodes k and k + 1, 0 where two paths meet): sites less negative pivots, the
    spring form's Schur complement being x M - K."""
    negative, certain = _path_counts(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(site), m,
                                     compliance[0], compliance[1], squares[0], squares[1])
    return int(np.count_nonzero(site)) - negative.astype(np.intp), certain
