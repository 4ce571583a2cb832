"""Compiled certificates of every singular value of a bidiagonal, O(size) per value (numba).

`bidiagonal.certify_modes` certifies a chain's singular value from a triplet (sigma, u, v):
an inverse-iteration vector, the residuals B v - sigma u and B^T u - sigma v, the Rayleigh
quotient rho and a Kato-Temple bound. In numpy (size x block temporaries, some fifty array
passes) that costs ~100 ns per value and site, 15 times the dqds solve at 3,000 sites.
`triplet_figures` computes the same figures in compiled loops, `LANES` values side by side,
at ~9 ns per value and site: about what dqds itself costs, at every size.

Per block of values:

1. float64 first (`_float_figures`, three passes): v from one step of inverse iteration on
   B^T B - sigma^2 by the stationary qd transform (relatively accurate, no pivoting), u = B v,
   the residuals with a rigorous float64 rounding bound. Kept where the resulting solving bound
   is within `FLOAT_ENOUGH` eps (most values: the rounding of B v is small beside sigma).
2. Otherwise double-double (`_pairs`, `_residuals`, `_rayleigh`): u and v together from the
   Golub-Kahan form (LAPACK dgtsv's pivoted elimination, written branch-free), the residuals
   by Dekker's products and Knuth's sums as `rounding.rayleigh_refinement` forms them, with
   the same rounding analysis (its (2 size + 4) u factors are for recursive summation, the
   order used here).

Either way the figures are rigorous for the vectors used; only their tightness depends on the
vectors' quality. numba compiles without fast-math (IEEE operations, no reassociation), so
the error-free transformations stay exact. `tests/solvers/test_triplets.py` checks the certificates against mpmath Sturm counts.

The first call compiles (~5 s), cached on disk after.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.rounding import SPLIT, UNIT as _UNIT
from vibra.solvers.compiled import jit

__all__ = ["triplet_figures"]

_TINY = float(np.finfo(float).tiny)
_EPS = 2 * _UNIT


def _jit(function: Any) -> Any:
    return jit(cache=True, fastmath=False, nogil=True, error_model="numpy")(function)


@_jit
def _residual(p1: float, e1: float, p2: float, e2: float, p3: float, e3: float) -> tuple[float, float]:
    """The rounded double-double sum of three exact products and its error bound (`rounding._residual`)."""
    s = p1 + p2
    bb = s - p1
    t1 = (p1 - (s - bb)) + (p2 - bb)
    s2 = s + p3
    bb = s2 - s
    t2 = (s - (s2 - bb)) + (p3 - bb)
    result = s2 + (((t1 + t2) + (e1 + e2)) + e3)
    error = _UNIT * abs(result) + 8 * _UNIT * _UNIT * (abs(p1) + abs(p2) + abs(p3))
    return result, error


#: Values solved side by side: independent recurrences that the CPU overlaps (each row's
#: division waits on the previous one).
LANES = 8

#: A value's float64 figures are kept when its solving bound is within this many eps of it;
#: others are recomputed in double-double (the low values: 6% of a uniform chain's, 20% of a
#: disordered one's, at ~3x the cost per value).
FLOAT_ENOUGH = 16


@_jit
def _hi(a: float) -> float:
    """The high half of Dekker's split (the low half is a - high, exactly)."""
    c = SPLIT * a
    return c - (c - a)


@_jit
def _product(a: float, ah: float, b: float, bh: float) -> tuple[float, float]:
    """Dekker's TwoProduct from the high halves: a b = p + q exactly."""
    p = a * b
    al = a - ah
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@_jit
def _residuals(d: NDArray[np.float64], padded: NDArray[np.float64], lanes: NDArray[np.float64],
               u: NDArray[np.float64], v: NDArray[np.float64], r1: NDArray[np.float64],
               r2: NDArray[np.float64], err1: NDArray[np.float64], err2: NDArray[np.float64]) -> None:
    """r1 = B v - sigma u, r2 = B^T u - sigma v per lane, in double-double (`rounding._residual`:
    error u |r| + 8 u^2 sum |p|). u and v hold the vectors at rows 1..s between zero rows 0 and
    s + 1."""
    s = d.shape[0]
    m = lanes.shape[0]
    for i in range(s):
        di = d[i]
        en = padded[i + 1]
        eb = padded[i]
        dh = _hi(di)
        enh = _hi(en)
        ebh = _hi(eb)
        for k in range(m):
            mk = -lanes[k]
            mh = _hi(mk)
            x0 = v[i + 1, k]
            x1 = v[i + 2, k]
            y0 = u[i + 1, k]
            y1 = u[i, k]
            x0h = _hi(x0)
            y0h = _hi(y0)
            p1, q1 = _product(di, dh, x0, x0h)
            p2, q2 = _product(en, enh, x1, _hi(x1))
            p3, q3 = _product(mk, mh, y0, y0h)
            r1[i, k], err1[i, k] = _residual(p1, q1, p2, q2, p3, q3)
            p1, q1 = _product(di, dh, y0, y0h)
            p2, q2 = _product(eb, ebh, y1, _hi(y1))
            p3, q3 = _product(mk, mh, x0, x0h)
            r2[i, k], err2[i, k] = _residual(p1, q1, p2, q2, p3, q3)


@_jit
def _rayleigh(lanes: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64],
              r1: NDArray[np.float64], r2: NDArray[np.float64], err1: NDArray[np.float64],
              err2: NDArray[np.float64], sums: NDArray[np.float64], result: NDArray[np.float64]) -> None:
    """`rounding.rayleigh_refinement`'s rho, uncertainty and residual bound per lane (result rows 0-2)."""
    s = r1.shape[0]
    m = lanes.shape[0]
    sums[:7, :] = 0.0
    for i in range(s):
        for k in range(m):
            y0 = u[i + 1, k]
            x0 = v[i + 1, k]
            x = r1[i, k]
            y = r2[i, k]
            ex = err1[i, k]
            ey = err2[i, k]
            au = abs(y0)
            av = abs(x0)
            sums[0, k] += y0 * y0 + x0 * x0
            sums[1, k] += y0 * x + x0 * y
            sums[2, k] += au * (abs(x) + ex)
            sums[3, k] += au * ex
            sums[4, k] += av * (abs(y) + ey)
            sums[5, k] += av * ey
            sums[6, k] += ex * ex + ey * ey
    for k in range(m):
        sums[7, k] = sums[1, k] / sums[0, k]  # the correction rho - sigma
        sums[8, k] = 0.0
    for i in range(s):
        for k in range(m):
            x = r1[i, k] - sums[7, k] * u[i + 1, k]
            y = r2[i, k] - sums[7, k] * v[i + 1, k]
            sums[8, k] += x * x + y * y
    for k in range(m):
        result[0, k], result[1, k], result[2, k] = _finish(
            lanes[k], s, sums[0, k], sums[7, k], sums[2, k], sums[3, k], sums[4, k], sums[5, k],
            np.sqrt(sums[8, k]), sums[6, k])


@_jit
def _finish(value: float, s: int, norm2: float, shift: float, left_part: float, left_err: float,
            right_part: float, right_err: float, raw: float, rounding2: float) -> tuple[float, float, float]:
    """rho, its uncertainty and the residual bound at rho (`rounding.rayleigh_refinement`'s
    formulas) from one lane's sums: |z|^2, the correction rho - sigma = z^T r / |z|^2 (`shift`),
    sum |u| (|r1| + err1), sum |u| err1, sum |v| (|r2| + err2), sum |v| err2, |r - shift z|
    (`raw`, or a bound on it) and sum err1^2 + err2^2."""
    dot_error = (left_part * (2 * s + 4) * _UNIT + left_err + right_err + right_part * (2 * s + 4) * _UNIT)
    correction_error = dot_error / norm2 + abs(shift) * (2 * s + 8) * _UNIT
    rho = value + shift
    bb = rho - value
    rounding = (value - (rho - bb)) + (shift - bb)
    uncertainty = abs(rounding) + correction_error
    root = np.sqrt(norm2)
    residual = (raw * (1 + (s + 8) * _UNIT) + np.sqrt(rounding2)
                + (uncertainty + 4 * _UNIT * abs(shift)) * root) / (root * (1 - 4 * _UNIT))
    return rho, uncertainty, residual


@_jit
def _solve(off: NDArray[np.float64], shift: NDArray[np.float64], rhs: NDArray[np.float64],
           diag: NDArray[np.float64], up: NDArray[np.float64], fill: NDArray[np.float64]) -> None:
    """(T - shift_k I) x_k = rhs[:, k] in place for each lane k: T the Golub-Kahan form (zero
    diagonal, off-diagonal `off`). LAPACK dgtsv's elimination with partial pivoting, its
    operations written without branches (the pivot row chosen by selects); a zero pivot leaves
    a non-finite column, as dgtsv's INFO > 0 would."""
    n, m = rhs.shape
    for k in range(m):
        diag[0, k] = -shift[k]
        up[0, k] = off[0] if n > 1 else 0.0
    for i in range(n - 1):
        low = off[i]
        after = off[i + 1] if i < n - 2 else 0.0
        for k in range(m):
            here = diag[i, k]
            upper = up[i, k]
            below = -shift[k]  # row i + 1 is untouched until this step: (low, -shift, after)
            swap = abs(here) < abs(low)
            pivot = low if swap else here
            fact = (here if swap else low) / pivot
            first = below if swap else upper
            second = after if swap else 0.0
            diag[i, k] = pivot
            up[i, k] = first
            fill[i, k] = second
            diag[i + 1, k] = (upper if swap else below) - fact * first
            up[i + 1, k] = (0.0 if swap else after) - fact * second
            top = rhs[i, k]
            bottom = rhs[i + 1, k]
            chosen = bottom if swap else top
            rhs[i, k] = chosen
            rhs[i + 1, k] = (top if swap else bottom) - fact * chosen
    for k in range(m):
        rhs[n - 1, k] /= diag[n - 1, k]
    if n > 1:
        for k in range(m):
            rhs[n - 2, k] = (rhs[n - 2, k] - up[n - 2, k] * rhs[n - 1, k]) / diag[n - 2, k]
    for i in range(n - 3, -1, -1):
        for k in range(m):
            rhs[i, k] = (rhs[i, k] - up[i, k] * rhs[i + 1, k] - fill[i, k] * rhs[i + 2, k]) / diag[i, k]


@_jit
def _pairs(off: NDArray[np.float64], start: NDArray[np.float64], lanes: NDArray[np.float64],
           u: NDArray[np.float64], v: NDArray[np.float64], z: NDArray[np.float64], diag: NDArray[np.float64],
           up: NDArray[np.float64], fill: NDArray[np.float64], shift: NDArray[np.float64],
           scale: NDArray[np.float64]) -> None:
    """u and v (unit, per lane) from one inverse-iteration step on the Golub-Kahan form
    [[0, B^T], [B, 0]] (off-diagonal `off`) from `start` (2 s, lanes): both sides consistent to the value's
    own accuracy, which u = B v / sigma is not for a low value (B v magnifies v's error by
    ||B|| / sigma). A lane meeting a zero pivot is solved again at a shift moved by 4 eps
    (three tries). z, diag, up, fill: (2 s, lanes) work space; shift: (lanes,)."""
    s = u.shape[0] - 2
    m = lanes.shape[0]
    done = np.zeros(m, dtype=np.bool_)
    for k in range(m):
        shift[k] = lanes[k]
    for _attempt in range(4):
        for i in range(2 * s):
            for k in range(m):
                z[i, k] = start[i, k]
        _solve(off, shift, z, diag, up, fill)
        for k in range(m):
            if done[k]:
                continue
            total = 0.0
            for i in range(2 * s):
                total += z[i, k] * z[i, k]
            if np.isfinite(total) and total > 0.0:
                for i in range(s):
                    v[i + 1, k] = z[2 * i, k]
                    u[i + 1, k] = z[2 * i + 1, k]
                done[k] = True
            else:
                shift[k] = shift[k] * (1 + 4 * _EPS) + _TINY  # an exact pivot of zero
        if done.all():
            break
    _normalise(u, scale)
    _normalise(v, scale)


@_jit
def _normalise(x: NDArray[np.float64], scale: NDArray[np.float64]) -> None:
    """Each column of x (rows 1..s) to unit length (a zero column stays zero)."""
    s = x.shape[0] - 2
    m = x.shape[1]
    for k in range(m):
        scale[k] = 0.0
    for i in range(1, s + 1):
        for k in range(m):
            scale[k] += x[i, k] * x[i, k]
    for k in range(m):
        scale[k] = 1.0 / max(np.sqrt(scale[k]), _TINY)
    for i in range(1, s + 1):
        for k in range(m):
            x[i, k] *= scale[k]


@_jit
def _float_figures(d: NDArray[np.float64], padded: NDArray[np.float64], e2: NDArray[np.float64],
                   de: NDArray[np.float64], lanes: NDArray[np.float64], start: NDArray[np.float64],
                   a: NDArray[np.float64], b: NDArray[np.float64], rows: NDArray[np.float64],
                   columns: NDArray[np.float64], x: NDArray[np.float64], pivots: NDArray[np.float64],
                   factors: NDArray[np.float64], sums: NDArray[np.float64], result: NDArray[np.float64]) -> None:
    """Every figure of each lane in float64, three passes over the sites (a non-finite lane: a zero pivot).

    v: one inverse-iteration step on B^T B - sigma^2 I from `start`. B^T B = L D L^T with
    D = diag(d^2), L unit lower bidiagonal (l = e / d); the stationary qd transform (dstqds,
    Dhillon and Parlett) gives L+ D+ L+^T = L D L^T - sigma^2 I with D+_i = s_i + d_i^2,
    L+_i = d_i e_i / D+_i, s_(i+1) = e_i^2 s_i / D+_i - sigma^2: relative accuracy in the
    entries, no division by d (a zero d is allowed). u = B v / sigma, about a unit vector (its
    norm enters the figures as it is), formed with the residuals: good where sigma is not far
    below ||B|| (B v magnifies v's error by ||B|| / sigma; those go to double-double). Then
    r1 = B v - sigma u is only u's rounding: 0, within 5 u (|d_i v_i| + |e_i v_(i+1)|);
    r2 = B^T u - sigma v within 4 u sum |p| (three rounded products, two sums: gamma_3 with
    margin). The residual at rho is bounded by |r| + |rho - sigma| |z| (the triangle
    inequality: no pass over stored residuals).
    """
    s = d.shape[0]
    m = lanes.shape[0]
    for k in range(m):
        pivots[0, k] = -(lanes[k] * lanes[k])
        x[0, k] = start[0]
    for i in range(s - 1):  # factor and forward substitution
        di2 = d[i] * d[i]
        for k in range(m):  # one division per row: pivots[i] keeps 1 / D+_i
            shift = lanes[k] * lanes[k]
            inverse = 1.0 / (pivots[i, k] + di2)
            factor = de[i] * inverse
            factors[i, k] = factor
            pivots[i + 1, k] = e2[i] * pivots[i, k] * inverse - shift
            pivots[i, k] = inverse
            x[i + 1, k] = start[i + 1] - factor * x[i, k]
    last = d[s - 1] * d[s - 1]
    for k in range(m):
        x[s - 1, k] /= pivots[s - 1, k] + last
        sums[0, k] = x[s - 1, k] * x[s - 1, k]
    for i in range(s - 2, -1, -1):  # diagonal and back substitution, |x|^2
        for k in range(m):
            value = x[i, k] * pivots[i, k] - factors[i, k] * x[i + 1, k]
            x[i, k] = value
            sums[0, k] += value * value
    for k in range(m):  # B v, the residuals and every sum, one lane at a time (sums in registers)
        sv = 1.0 / max(np.sqrt(sums[0, k]), _TINY)
        inverse = 1.0 / lanes[k]
        minus = -lanes[k]
        s2 = s3 = s4 = s6 = s7 = s8 = s9 = s10 = s11 = 0.0
        before = 0.0  # u_(i - 1)
        after = x[0, k] * sv  # v_i, then v_(i + 1)
        for i in range(s):
            di = d[i]
            en = padded[i + 1]
            x0 = after
            after = x[i + 1, k] * sv if i < s - 1 else 0.0
            p1 = di * x0
            p2 = en * after
            y0 = (p1 + p2) * inverse  # u_i = (B v)_i / sigma
            # r1_i = (B v)_i - sigma u_i: |r1_i| <= 2.01 u (|p1| + |p2|) (the sum) + 2.01 u |p1 + p2|
            # (sigma fl(fl(w / sigma)) = w (1 + d1)(1 + d2)): taken as 0 with error 5 u (|p1| + |p2|)
            err1 = 5 * _UNIT * (abs(p1) + abs(p2))
            q1 = di * y0
            q2 = padded[i] * before
            q3 = minus * x0
            r2 = (q1 + q2) + q3
            err2 = 4 * _UNIT * (abs(q1) + abs(q2) + abs(q3))
            before = y0
            uu = y0 * y0
            vv = x0 * x0
            au = abs(y0)
            av = abs(x0)
            s2 += uu + vv
            s3 += x0 * r2
            s4 += au * err1
            s6 += av * (abs(r2) + err2)
            s7 += av * err2
            s8 += err1 * err1 + err2 * err2
            s9 += r2 * r2
            s10 += a[i] * uu + b[i] * vv
            s11 += rows[i] * uu + columns[i] * vv
        sums[2, k] = s2
        sums[3, k] = s3
        sums[4, k] = s4  # sum |u| (|r1| + err1), |r1| taken as 0
        sums[5, k] = s4  # sum |u| err1
        sums[6, k] = s6
        sums[7, k] = s7
        sums[8, k] = s8
        sums[9, k] = s9
        sums[10, k] = s10
        sums[11, k] = s11
    for k in range(m):
        norm2 = sums[2, k]
        shift = sums[3, k] / norm2
        raw = np.sqrt(sums[9, k]) + abs(shift) * np.sqrt(norm2)  # |r - shift z| <= |r| + |shift| |z|
        result[0, k], result[1, k], result[2, k] = _finish(
            lanes[k], s, norm2, shift, sums[4, k], sums[5, k], sums[6, k], sums[7, k], raw, sums[8, k])
        result[3, k] = abs(sums[10, k]) + sums[11, k]
        result[4, k] = norm2


@_jit
def _enough(result: NDArray[np.float64], gaps: NDArray[np.float64], first_mode: int, count: int) -> bool:
    """Whether every lane's solving bound (Kato-Temple with the nearest neighbour's distance,
    `gaps` relative, plus rho's uncertainty) is within `FLOAT_ENOUGH` eps (a nan fails)."""
    for k in range(count):
        rho = result[0, k]
        r = result[2, k]
        gap = gaps[first_mode + k] * rho
        solving = (r * r / gap + result[1, k]) / rho if gap > r and rho > 0 else np.inf
        if not solving <= FLOAT_ENOUGH * _EPS:
            return False
    return True


@jit(cache=True, fastmath=False, nogil=True, error_model="numpy", aot=True)  # compiled ahead of time too
def _figures(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64],
             start: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
             rows: NDArray[np.float64], columns: NDArray[np.float64], gaps: NDArray[np.float64],
             out: NDArray[np.float64]) -> None:
    s = d.shape[0]
    padded = np.zeros(s + 1)  # padded[i + 1] = e_i, zero at both ends
    e2 = np.zeros(max(s - 1, 1))
    de = np.zeros(max(s - 1, 1))
    for i in range(s - 1):
        padded[i + 1] = e[i]
        e2[i] = e[i] * e[i]
        de[i] = d[i] * e[i]
    off = np.zeros(max(2 * s - 1, 1))  # the Golub-Kahan form's off-diagonal
    for i in range(s):
        off[2 * i] = d[i]
    for i in range(s - 1):
        off[2 * i + 1] = e[i]
    m = LANES
    z = np.empty((2 * s, m))
    begin = np.empty((2 * s, m))
    diag = np.empty((2 * s, m))
    up = np.empty((2 * s, m))
    fill = np.empty((2 * s, m))
    x = np.empty((s, m))
    pivots = np.empty((s, m))
    factors = np.empty((s, m))
    # u, v at rows 1..s, zero rows 0 and s + 1 (the neighbours past the ends)
    u = np.zeros((s + 2, m))
    v = np.zeros((s + 2, m))
    r1 = np.empty((s, m))
    r2 = np.empty((s, m))
    err1 = np.empty((s, m))
    err2 = np.empty((s, m))
    lanes = np.empty(m)
    shift = np.empty(m)
    scale = np.empty(m)
    sums = np.empty((13, m))
    result = np.empty((5, m))
    k_all = sigma.shape[0]
    for first_mode in range(0, k_all, m):
        count = min(m, k_all - first_mode)
        for k in range(m):
            lanes[k] = sigma[first_mode + min(k, count - 1)]  # a short last block repeats its last value
        _float_figures(d, padded, e2, de, lanes, start, a, b, rows, columns, x, pivots, factors, sums, result)
        exact = not _enough(result, gaps, first_mode, count)
        if exact:  # both sides from the Golub-Kahan form, the residuals in double-double
            for i in range(2 * s):
                for k in range(m):
                    begin[i, k] = start[i]
            for step in range(2):
                _pairs(off, begin, lanes, u, v, z, diag, up, fill, shift, scale)
                _residuals(d, padded, lanes, u, v, r1, r2, err1, err2)
                _rayleigh(lanes, u, v, r1, r2, err1, err2, sums, result)
                if step == 1 or _enough(result, gaps, first_mode, count):
                    break
                for i in range(s):  # a second step from the first's vectors (near-degenerate values)
                    for k in range(m):
                        begin[2 * i, k] = v[i + 1, k]
                        begin[2 * i + 1, k] = u[i + 1, k]
            for k in range(m):
                sums[0, k] = 0.0
                sums[1, k] = 0.0
                sums[2, k] = 0.0
            for i in range(s):
                for k in range(m):
                    uu = u[i + 1, k] * u[i + 1, k]
                    vv = v[i + 1, k] * v[i + 1, k]
                    sums[0, k] += a[i] * uu + b[i] * vv
                    sums[1, k] += rows[i] * uu + columns[i] * vv
                    sums[2, k] += uu + vv
            for k in range(m):
                result[3, k] = abs(sums[0, k]) + sums[1, k]
                result[4, k] = sums[2, k]
        for k in range(count):
            j = first_mode + k
            for column in range(5):
                out[j, column] = result[column, k]
            out[j, 5] = 1.0 if exact else 0.0


def triplet_figures(d: NDArray[np.float64], e: NDArray[np.float64], sigma: NDArray[np.float64],
                    start: NDArray[np.float64], a: NDArray[np.float64], b: NDArray[np.float64],
                    rows: NDArray[np.float64], columns: NDArray[np.float64],
                    gaps: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Per value of `sigma`, the figures `certify_modes` needs, from one inverse-iteration step.

    Parameters
    ----------
    d, e : the upper bidiagonal (sizes s and s - 1).
    sigma : (k,) its approximate singular values; start : (2 s,) the iteration's start.
    a, b, rows, columns : (s,) the forming scalings' centred logs and slacks (`rounding.Scalings`).

    Returns
    -------
    (k, 6) ndarray
        Columns: rho, its uncertainty, the residual bound (as `rounding.rayleigh_refinement`);
        |a . u^2 + b . v^2| + rows . u^2 + columns . v^2 and |u|^2 + |v|^2 (as
        `rounding.weighted_forming` forms them from the vectors); 1 where the residuals were
        formed in double-double, 0 where float64 sufficed.
    """
    out = np.empty((sigma.shape[0], 6))
    _figures(np.ascontiguousarray(d, dtype=np.float64), np.ascontiguousarray(e, dtype=np.float64),
             np.ascontiguousarray(sigma, dtype=np.float64), np.ascontiguousarray(start, dtype=np.float64),
             np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64),
             np.ascontiguousarray(rows, dtype=np.float64), np.ascontiguousarray(columns, dtype=np.float64),
             np.zeros(sigma.shape[0]) if gaps is None else np.ascontiguousarray(gaps, dtype=np.float64), out)
    return out
