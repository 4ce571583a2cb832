"""Compiled loops (numba) shared by the ring and chain paths: roots of the spring form's last pivot
and its inertia counts in double-double (`ring.values`, `chain.walled`), a chain's counts
(`chain.sturm_counts`), and the scalar double-double operations they and `ring.pencil_counts`,
`gk_bisection` and `products` are built from (`kernel_jit`, `scalar_mul`, ...).

A ring with its dofs taken around the cycle, cut at its closing spring r
(`ring.counts.count_below_springs` picks it), has the spring form A(x) = [[W^-1, B], [B^T, x M]]
(springs to a wall eliminated into each site's diagonal, x m - wall) with 2n nodes on a chain
(site 0, spring 0, site 1, ..., site n-1, spring n-1 = r) closed by one coupling (spring r to
site 0; a chain on walls, `chain.walled`, is the same chain with that coupling zero). Eliminating the chain
in order, the last pivot l(x) = 1/w_r - y^T A_sub(x)^-1 y is the Schur complement of the
cut chain's spring form A_sub: zero at the ring's eigenvalues, with poles at the chain's, and
increasing in x between them (A_sub' = diag(M, 0) >= 0). By interlacing (the ring is the chain
plus one spring) eigenvalue i of the ring lies between the chain's i and i + 1.

- `pivot_roots`: each root of l between two consecutive poles, by a safeguarded iteration in
  float64 (the pole on the root's side as a rational model, f ~ s + c / (p - x), which the
  secular function l is near a pole; bisection where a step leaves the bracket). The roots
  are not trusted: `spring_counts` certifies them.
- `spring_counts`: `ring.counts.count_below_springs`, the same double-double operations in the same
  order with its running error, per point in compiled loops (numba threads over blocks of
  `LANES` points, each block's points in SIMD lanes), except the reciprocal of each pivot: one
  Newton step (`scalar_reciprocal`, within `dd.UNIT` as `dd.div` is, at a third of its operations).
  2.5 ns per point and node on two cores (15 ns one point at a time: the loop is a chain of
  dependent operations; 8 independent points fill the pipeline and the vector units), where
  the numpy version pays its call overhead on each operation over the vector of points.
- `chain_counts`: the same for a chain's spring form (no closing coupling, no fill), 1.5 ns
  per point and node on two cores (11.6 ns one at a time). `pivot_roots` 4.5x one root at a
  time (`benchmarks/bench_ring_values.py --kernels`; `tests/scalar_kernels.py` keeps the
  one-point loops, which the lanes repeat bit for bit).

numba compiles without fast-math (IEEE operations, no contraction into FMA), so the
error-free transformations stay exact; a product's exact error is one explicit fused
multiply-add where the CPU has it (`FMA`, `scalar_two_product`: the same two numbers as Dekker's
splitting, at a tenth of its operations). The first call compiles (~5 s), cached on disk after;
numba itself is loaded on the first call, not with vibra (`vibra.solvers.compiled`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.compiled import HOST_FMA, batches, intrinsic, jit, prange, threads

if TYPE_CHECKING:
    from typing import ParamSpec, TypeVar

    from numba.core.types import Type
    from numba.core.typing.context import BaseContext
    from numba.core.typing.templates import Signature

    from vibra.solvers.compiled import Kernel

    _P = ParamSpec("_P")
    _R = TypeVar("_R")

__all__ = ["pivot_roots", "spring_counts", "chain_counts", "walled_factor", "kernel_jit", "values_by_sites", "LANES", "FMA", "fma",
           "scalar_two_sum", "scalar_two_product", "scalar_mul", "scalar_reciprocal"]

_SPLIT = 134217729.0  # 2^27 + 1 (Dekker)
_EPS = float(np.finfo(float).eps)
_TINY = float(np.finfo(float).tiny)


def kernel_jit(parallel: bool = False, aot: bool = False,
               work: Callable[..., float] | None = None) -> Callable[[Callable[_P, _R]], Kernel[_P, _R]]:
    """The kernels' numba options: no fast-math (IEEE operations), cached on disk; compiled on
    first call (`vibra.solvers.compiled.jit`; `aot` and `work` as there)."""
    return jit(cache=True, fastmath=False, nogil=True, error_model="numpy", parallel=parallel, aot=aot, work=work)


def values_by_sites(x: NDArray[np.float64], *rest: object) -> float:
    """A parallel count kernel's serial seconds, estimated from sizes (`COUNT_S` per value and site):
    `x` the values, the first array of `rest` the sites' masses."""
    sites = next(a.shape[0] for a in rest if isinstance(a, np.ndarray) and a.dtype == np.float64)
    return COUNT_S * x.shape[0] * sites


# --- double-double, scalar: the operations of `vibra.solvers.accurate.dd` and `vibra.solvers.accurate.rounding` ---

@kernel_jit()
def scalar_two_sum(a: float, b: float) -> tuple[float, float]:
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@kernel_jit()
def _fast(a: float, b: float) -> tuple[float, float]:
    s = a + b
    return s, b - (s - a)


@kernel_jit()
def _split(a: float) -> tuple[float, float]:
    c = _SPLIT * a
    high = c - (c - a)
    return high, a - high


#: Whether this CPU fuses a multiply and an add in one rounding (x86-64 since 2013, every ARM64):
#: then a product's exact error is one instruction (`scalar_two_product`), else Dekker's splitting.
#: (LLVM's host features, read when a kernel is first compiled or FMA is first tested.)
FMA = HOST_FMA


@intrinsic
def fma(typingctx: BaseContext, a: Type, b: Type, c: Type) -> tuple[Signature, Callable[..., object]]:
    """a b + c with one rounding (LLVM's llvm.fma: the FMA instruction; numba offers no fma)."""
    from llvmlite import ir as _ir
    from numba import types

    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        double = _ir.DoubleType()
        fused = builder.module.declare_intrinsic("llvm.fma", [double], _ir.FunctionType(double, [double] * 3))
        return builder.call(fused, args)

    return signature, codegen


@kernel_jit()
def scalar_two_product(a: float, b: float) -> tuple[float, float]:
    """(p, e): p = fl(a b), e = a b - p exactly (the same two numbers either way: e is unique)."""
    p = a * b
    if FMA:
        return p, fma(a, b, -p)
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@kernel_jit()
def _add(ah: float, al: float, bh: float, bl: float) -> tuple[float, float]:
    s, e = scalar_two_sum(ah, bh)
    t, f = scalar_two_sum(al, bl)
    s, e = _fast(s, e + t)
    return _fast(s, e + f)


@kernel_jit()
def scalar_mul(ah: float, al: float, bh: float, bl: float) -> tuple[float, float]:
    p, e = scalar_two_product(ah, bh)
    return _fast(p, e + (ah * bl + al * bh))


@kernel_jit()
def scalar_reciprocal(ph: float, pl: float) -> tuple[float, float]:
    """1 / (ph + pl) in double-double by one Newton step: r = fl(1 / ph), e = 1 - (ph + pl) r
    formed from Dekker's exact product (|e| <= 2^-51.9, its own rounding ~2^-104 |r e|
    relatively), r (1 + e) to within e^2 + 3 2^-105 ~ 6 2^-104 relatively: inside `dd.UNIT`
    (16 2^-104), as `dd.div(1, 0, ph, pl)` is, at a third of its operations."""
    r = 1.0 / ph
    p, q = scalar_two_product(ph, r)
    e = ((1.0 - p) - q) - pl * r
    return _fast(r, r * e)


# --- the counts ---

#: Points counted together by one thread: the same operations on LANES independent points in an
#: inner loop with no branch, which LLVM turns into SIMD instructions (~8x one point at a time here).
LANES = 8

# rows of a block's state (one column per lane)
_X, _PH, _PL, _GH, _GL, _GE, _LH, _LL, _LE, _RH, _RL, _QH, _QL, _INV, _NEG, _VAN = range(16)


@kernel_jit()
def _count_block(x: NDArray[np.float64], start: int, m: NDArray[np.float64], compliance_h: NDArray[np.float64],
                 compliance_l: NDArray[np.float64], off: NDArray[np.float64], square_h: NDArray[np.float64],
                 square_l: NDArray[np.float64], wall_h: NDArray[np.float64], wall_l: NDArray[np.float64],
                 walls: bool, closing: float, u: float, count: NDArray[np.int64], certain: NDArray[np.bool_],
                 last: NDArray[np.float64]) -> None:
    """`ring.counts.count_below_springs`' loop for points x[start: start + LANES] (the last repeated to
    fill the block), written into count, certain and last (the last pivot). Per point the
    operations and their order are those of one point at a time; the branches on the node are
    taken once per node, those on the point's values become selects. `walls`: each site's
    diagonal is x m - wall (double-double, `ring.counts.count_below_springs`' subtraction); a free
    ring skips it (the same bits: subtracting a zero changes no double-double)."""
    k = x.shape[0]
    n = m.shape[0]
    size = 2 * n
    s = np.zeros((16, LANES))  # one array, so that LLVM sees the rows do not overlap
    for p in range(LANES):
        xp = x[min(start + p, k - 1)]
        s[_X, p] = xp
        s[_PH, p], s[_PL, p] = scalar_two_product(xp, m[0])
        if walls:
            s[_PH, p], s[_PL, p] = _add(s[_PH, p], s[_PL, p], -wall_h[0], -wall_l[0])
        s[_GH, p] = closing
        s[_LH, p], s[_LL, p] = compliance_h[n - 1], compliance_l[n - 1]
        s[_LE, p] = u * abs(s[_LH, p])
    for j in range(size - 1):
        for p in range(LANES):  # node j's pivot p eliminated from the closing coupling g and the last pivot l
            ph = s[_PH, p]
            s[_NEG, p] += 1.0 if ph < 0 else 0.0
            s[_VAN, p] += 1.0 if ph == 0 else 0.0
            rh, rl = scalar_reciprocal(ph, s[_PL, p])
            s[_RH, p], s[_RL, p] = rh, rl
            gh, gl = s[_GH, p], s[_GL, p]
            qh, ql = scalar_mul(gh, gl, rh, rl)
            s[_QH, p], s[_QL, p] = qh, ql
            sh, sl = scalar_mul(gh, gl, qh, ql)
            lh, ll = _add(s[_LH, p], s[_LL, p], -sh, -sl)
            s[_LH, p], s[_LL, p] = lh, ll
            inverse = abs(rh) * (1 + 1e-12)  # 1 / |p|, rounded up (float64 bookkeeping)
            s[_INV, p] = inverse
            g_error = s[_GE, p]
            s[_LE, p] = s[_LE, p] + (2 * abs(gh) + g_error) * g_error * inverse + u * (2 * abs(sh) + abs(lh))
        if j == size - 2:
            break
        c = off[j]
        closes = j == size - 3  # the closing coupling joins g at the last spring
        c_last = off[size - 2]
        square, square_low = square_h[j], square_l[j]
        site = j % 2 == 1  # node j + 1 is a site (else spring j // 2)
        mass = m[(j + 1) // 2]
        ch, cl = compliance_h[j // 2], compliance_l[j // 2]
        walled = walls and site
        wh, wl = -wall_h[(j + 1) // 2], -wall_l[(j + 1) // 2]
        for p in range(LANES):
            fh, fl = scalar_mul(-c, 0.0, s[_QH, p], s[_QL, p])
            g_error = abs(c) * s[_INV, p] * s[_GE, p] * (1 + 1e-12) + 4 * u * abs(fh)
            jh, jl = _add(fh, fl, c_last, 0.0)
            joined = g_error + u * (abs(jh) + abs(c_last))
            s[_GE, p] = joined if closes else g_error
            s[_GH, p] = jh if closes else fh
            s[_GL, p] = jl if closes else fl
            th, tl = scalar_mul(s[_RH, p], s[_RL, p], square, square_low)
            dh, dl = scalar_two_product(s[_X, p], mass)
            if walled:
                dh, dl = _add(dh, dl, wh, wl)
            s[_PH, p], s[_PL, p] = _add(dh if site else ch, dl if site else cl, -th, -tl)
    for p in range(min(LANES, k - start)):
        lh, last_error = s[_LH, p], s[_LE, p]
        finite = np.isfinite(lh) and np.isfinite(last_error)
        certain[start + p] = finite and abs(lh) > 1.01 * last_error + 1e-290 and s[_VAN, p] == 0
        count[start + p] = n - int(s[_NEG, p]) - (1 if lh < 0 else 0)
        last[start + p] = lh


@kernel_jit(parallel=True)
def _counts(x: NDArray[np.float64], m: NDArray[np.float64], compliance_h: NDArray[np.float64],
            compliance_l: NDArray[np.float64], off: NDArray[np.float64], square_h: NDArray[np.float64],
            square_l: NDArray[np.float64], wall_h: NDArray[np.float64], wall_l: NDArray[np.float64], walls: bool,
            closing: float, u: float) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.float64]]:
    k = x.shape[0]
    count = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    last = np.zeros(k)
    for b in prange((k + LANES - 1) // LANES):
        _count_block(x, b * LANES, m, compliance_h, compliance_l, off, square_h, square_l, wall_h, wall_l, walls, closing,
                     u, count, certain, last)
    return count, certain, last


def spring_counts(x: NDArray[np.float64], m: NDArray[np.float64], compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                  off: NDArray[np.float64], squares: tuple[NDArray[np.float64], NDArray[np.float64]],
                  closing: float, u: float, wall: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                  ) -> tuple[NDArray[np.intp], NDArray[np.bool_], NDArray[np.float64]]:
    """(count, certain, last pivot's high part) at each x: the inertia counts of the spring form
    (chain order: m per site, compliance 1/w per spring as double-double, off the 2n - 1 chain
    couplings and squares their squares as double-double, closing the coupling of spring n - 1
    to site 0, `wall` the springs to a wall per site as double-double, None for a free ring),
    exactly as `ring.counts.count_below_springs` computes them (per-node unit u)."""
    walls = wall is not None
    wall_h, wall_l = (np.zeros(m.shape[0]), np.zeros(m.shape[0])) if wall is None else \
        (np.ascontiguousarray(wall[0], dtype=float), np.ascontiguousarray(wall[1], dtype=float))
    x = np.ascontiguousarray(x, dtype=float)
    parts = [_counts(x[first:stop], m, compliance[0], compliance[1], off, squares[0], squares[1], wall_h, wall_l,
                     walls, float(closing), float(u))  # batches of ~1 s: Ctrl-C is seen between them
             for first, stop in batches(x.shape[0], COUNT_S * m.shape[0] / threads(), LANES * threads())]
    if not parts:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.bool_), np.zeros(0)
    count, certain, last = (np.concatenate(column) for column in zip(*parts))
    return count.astype(np.intp), certain, last


# --- the roots, float64 ---

#: A root within this relative distance of a pole is taken to be at the pole: there float64's
#: l(x) carries noise ~eps / distance (terms ~1 / distance that cancel), as large as l itself
#: (~distance) near 1e-8; at 1e-6 the sign of l is still sure.
NEAR = 1e-6


#: Roots one thread finds together (`LANES` at a time, a finished lane taking the next root).
CHUNK = 16 * LANES

#: Seconds per site of one value's double-double inertia count (`spring_counts`) and of one
#: root's ~20 evaluations of l(x) (`pivot_roots`), one thread: they size the kernels'
#: `batches` (Ctrl-C is seen between them), nothing else.
COUNT_S = 1e-8
ROOT_S = 20 * 2e-9


@kernel_jit()
def _pivot_block(x: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
                 off: NDArray[np.float64], wall: NDArray[np.float64], closing: float, f: NDArray[np.float64],
                 fp: NDArray[np.float64]) -> None:
    """(l(x), l'(x)) into f and fp at the LANES points x: the last pivot of the spring form and its
    derivative, float64 (the lanes as `_count_block`'s; a site's diagonal x m - wall, the same
    bits as x m where wall is 0)."""
    n = m.shape[0]
    size = 2 * n
    s = np.zeros((7, LANES))  # rows: x, p, p', g, g', l, l'
    for q in range(LANES):
        s[0, q] = x[q]
        s[1, q], s[2, q] = x[q] * m[0] - wall[0], m[0]
        s[3, q] = closing
        s[5, q] = compliance[n - 1]
    c, closes, c_last, site, mass, spring, tie = 0.0, False, 0.0, False, 0.0, 0.0, 0.0
    for j in range(size - 1):
        if j < size - 2:
            c = off[j]
            closes = j == size - 3
            c_last = off[size - 2]
            site = j % 2 == 1
            mass = m[(j + 1) // 2]
            tie = wall[(j + 1) // 2]
            spring = compliance[j // 2]
        for q in range(LANES):
            p, dp, g, dg = s[1, q], s[2, q], s[3, q], s[4, q]
            p = _TINY if p == 0.0 else p
            r = 1.0 / p
            h = g * r
            dh = (dg - h * dp) * r  # (g / p)'
            s[5, q] -= g * h
            s[6, q] -= dg * h + g * dh
            if j < size - 2:
                e = -c * h
                de = -c * dh
                e = e + c_last if closes else e
                t = c * c * r  # c^2 / p
                dt = -t * dp * r
                d = s[0, q] * mass - tie if site else spring
                dd = mass if site else 0.0
                s[1, q], s[2, q] = d - t, dd - dt
                s[3, q], s[4, q] = e, de
    for q in range(LANES):
        f[q], fp[q] = s[5, q], s[6, q]


@kernel_jit()
def _middle(a: float, b: float) -> float:
    """Bisection's next point in (a, b): geometric where b > 64 a > 0."""
    return np.sqrt(a) * np.sqrt(b) if a > 0 and b > 64 * a else 0.5 * (a + b)


@kernel_jit()
def _roots_chunk(first: int, stop: int, low: NDArray[np.float64], high: NDArray[np.float64],
                 pole_low: NDArray[np.float64], pole_high: NDArray[np.float64], m: NDArray[np.float64],
                 compliance: NDArray[np.float64], off: NDArray[np.float64], wall: NDArray[np.float64], closing: float,
                 out: NDArray[np.float64], evaluations: NDArray[np.int64], side: NDArray[np.int64]) -> None:
    """The roots first..stop-1 of l, each in (low, high), LANES at a time: the rational step on
    the pole on the root's side (Newton's step where that pole is infinite), bisection where it
    leaves the bracket, at most 200 steps. First l's sign just inside each finite pole: side -1
    (+1) where it puts the root within NEAR of the lower (upper) pole, returned as the root;
    0: a root inside. Each lane is a state machine: stage 0 (1) the lower (upper) pole's check,
    2 the iteration."""
    x, f, fp = np.zeros(LANES), np.zeros(LANES), np.zeros(LANES)
    a, b = np.zeros(LANES), np.zeros(LANES)
    root = np.full(LANES, -1, dtype=np.int64)
    stage = np.zeros(LANES, dtype=np.int64)
    steps = np.zeros(LANES, dtype=np.int64)
    count = np.zeros(LANES, dtype=np.int64)
    following = first
    busy = 0
    for q in range(LANES):
        following = _begin(q, following, stop, low, high, pole_low, pole_high, x, a, b, root, stage, steps, count, out,
                           evaluations, side)
        busy += root[q] >= 0
    while busy:
        _pivot_block(x, m, compliance, off, wall, closing, f, fp)
        for q in range(LANES):
            t = root[q]
            if t < 0:
                continue
            count[q] += 1
            done, value, where = _advance(q, f[q], fp[q], pole_low[t], pole_high[t], x, a, b, stage, steps)
            if done:
                out[t], evaluations[t], side[t] = value, count[q], where
                following = _begin(q, following, stop, low, high, pole_low, pole_high, x, a, b, root, stage, steps,
                                   count, out, evaluations, side)
                busy -= root[q] < 0


@kernel_jit()
def _begin(q: int, following: int, stop: int, low: NDArray[np.float64], high: NDArray[np.float64],
           pole_low: NDArray[np.float64], pole_high: NDArray[np.float64], x: NDArray[np.float64],
           a: NDArray[np.float64], b: NDArray[np.float64], root: NDArray[np.int64], stage: NDArray[np.int64],
           steps: NDArray[np.int64], count: NDArray[np.int64], out: NDArray[np.float64],
           evaluations: NDArray[np.int64], side: NDArray[np.int64]) -> int:
    """Lane q takes the next root that needs an evaluation (root -1: none left); returns the
    index after it. An empty bracket is its lower end, with no evaluation."""
    root[q] = -1
    while following < stop:
        t = following
        following += 1
        if not high[t] > low[t]:
            out[t], evaluations[t], side[t] = low[t], 0, -1
            continue
        root[q], a[q], b[q], count[q], steps[q] = t, low[t], high[t], 0, 0
        _next_stage(q, 0, pole_low[t], pole_high[t], x, a, b, stage)
        break
    return following


@kernel_jit()
def _next_stage(q: int, first: int, pole_low: float, pole_high: float, x: NDArray[np.float64],
                a: NDArray[np.float64], b: NDArray[np.float64], stage: NDArray[np.int64]) -> None:
    """The first of the stages from `first` on that evaluates l, with its point."""
    if first == 0 and np.isfinite(pole_low) and pole_low > 0 and pole_low * (1 + NEAR) < b[q]:
        stage[q], x[q] = 0, pole_low * (1 + NEAR)
    elif first <= 1 and np.isfinite(pole_high) and pole_high * (1 - NEAR) > a[q]:
        stage[q], x[q] = 1, pole_high * (1 - NEAR)
    else:
        stage[q], x[q] = 2, _middle(a[q], b[q])


@kernel_jit()
def _advance(q: int, f: float, fp: float, pole_low: float, pole_high: float, x: NDArray[np.float64],
             a: NDArray[np.float64], b: NDArray[np.float64], stage: NDArray[np.int64], steps: NDArray[np.int64]
             ) -> tuple[bool, float, int]:
    """Lane q's step on l(x) = f, l'(x) = fp: (done, root, side), or the next x set."""
    here = x[q]
    if stage[q] == 0:
        if f >= 0:
            return True, pole_low, -1
        a[q] = here
        _next_stage(q, 1, pole_low, pole_high, x, a, b, stage)
        return False, 0.0, 0
    if stage[q] == 1:
        if f <= 0:
            return True, pole_high, 1
        b[q] = here
        _next_stage(q, 2, pole_low, pole_high, x, a, b, stage)
        return False, 0.0, 0
    steps[q] += 1
    if f == 0.0:
        return True, here, 0
    if f < 0:
        a[q] = here
        pole = pole_high
    else:
        b[q] = here
        pole = pole_low
    if not (fp > 0 and np.isfinite(f) and np.isfinite(fp)):
        step = np.nan
    elif np.isfinite(pole):
        step = (pole - here) * f / (f - fp * (pole - here))
    else:
        step = -f / fp
    new = here + step
    if not (a[q] < new < b[q]):
        new = _middle(a[q], b[q])
    if abs(new - here) <= 2 * _EPS * abs(here) or b[q] - a[q] <= 4 * _EPS * b[q] or steps[q] >= 200:
        return True, new, 0
    x[q] = new
    return False, 0.0, 0


@kernel_jit(parallel=True)
def _roots(low: NDArray[np.float64], high: NDArray[np.float64], pole_low: NDArray[np.float64],
           pole_high: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
           off: NDArray[np.float64], wall: NDArray[np.float64], closing: float
           ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    k = low.shape[0]
    out = np.zeros(k)
    evaluations = np.zeros(k, dtype=np.int64)
    side = np.zeros(k, dtype=np.int64)
    for c in prange((k + CHUNK - 1) // CHUNK):
        _roots_chunk(c * CHUNK, min(k, (c + 1) * CHUNK), low, high, pole_low, pole_high, m, compliance, off, wall,
                     closing, out, evaluations, side)
    return out, evaluations, side


def pivot_roots(low: NDArray[np.float64], high: NDArray[np.float64], pole_low: NDArray[np.float64],
                pole_high: NDArray[np.float64], m: NDArray[np.float64], compliance: NDArray[np.float64],
                off: NDArray[np.float64], closing: float, wall: NDArray[np.float64] | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
    """(root, evaluations of l, side) of the last pivot in each bracket (low, high), float64: side
    -1 or +1 where the root was taken at the lower or upper pole (within NEAR), 0 inside.
    `wall`: the springs to a wall per site (float64), None for a free ring."""
    tie = np.zeros(m.shape[0]) if wall is None else np.ascontiguousarray(wall, dtype=float)
    brackets = [np.ascontiguousarray(a, dtype=float) for a in (low, high, pole_low, pole_high)]
    compliance = np.ascontiguousarray(compliance, dtype=float)
    parts = [_roots(*(a[first:stop] for a in brackets), m, compliance, off, tie, float(closing))
             for first, stop in batches(brackets[0].shape[0], ROOT_S * m.shape[0] / threads(), CHUNK * threads())]
    if not parts:
        return np.zeros(0), np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    roots, evaluations, side = (np.concatenate(column) for column in zip(*parts))
    return roots, evaluations.astype(np.intp), side.astype(np.intp)


# --- a chain's counts (no closing coupling, no fill) ---

@kernel_jit()
def _chain_block(x: NDArray[np.float64], start: int, site: NDArray[np.bool_], m: NDArray[np.float64],
                 compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64], square_h: NDArray[np.float64],
                 square_l: NDArray[np.float64], negative: NDArray[np.int64], certain: NDArray[np.bool_]) -> None:
    """(negative pivots, certain) of the spring form of a chain at each of the points
    x[start: start + LANES] (together, as `_count_block`), into negative and certain: node j is a
    site (mass m[j]) or a spring (compliance 1 / w, double-double), coupled to node j + 1 by c_j
    (its square given, 0 between separate paths). No fill: every pivot is exact for couplings,
    masses and springs perturbed by a few units of double-double; a vanished pivot makes the
    count uncertain (and the point keeps the count it had there)."""
    k = x.shape[0]
    s = np.zeros((5, LANES))  # rows: x, the pivot (high, low), negatives, vanished
    for p in range(LANES):
        s[0, p] = x[min(start + p, k - 1)]
    for j in range(site.shape[0]):
        is_site = site[j]
        mass = m[j]
        ch, cl = compliance_h[j], compliance_l[j]
        coupled = j > 0 and square_h[j - 1] != 0.0
        square, square_low = (square_h[j - 1], square_l[j - 1]) if j > 0 else (0.0, 0.0)
        for p in range(LANES):
            dh, dl = scalar_two_product(s[0, p], mass)
            dh, dl = (dh, dl) if is_site else (ch, cl)
            rh, rl = scalar_reciprocal(s[1, p], s[2, p])
            th, tl = scalar_mul(rh, rl, square, square_low)  # c^2 / p
            eh, el = _add(dh, dl, -th, -tl)
            ph = eh if coupled else dh
            s[1, p], s[2, p] = ph, (el if coupled else dl)
            gone = 1.0 if ph == 0.0 else s[4, p]
            s[3, p] += 1.0 if ph < 0 and gone == 0.0 else 0.0
            s[4, p] = gone
    for p in range(min(LANES, k - start)):
        negative[start + p], certain[start + p] = int(s[3, p]), s[4, p] == 0.0


@kernel_jit(parallel=True, aot=True, work=values_by_sites)
def _chain_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                  compliance_h: NDArray[np.float64], compliance_l: NDArray[np.float64], square_h: NDArray[np.float64],
                  square_l: NDArray[np.float64]) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    k = x.shape[0]
    negative = np.zeros(k, dtype=np.int64)
    certain = np.zeros(k, dtype=np.bool_)
    for b in prange((k + LANES - 1) // LANES):
        _chain_block(x, b * LANES, site, m, compliance_h, compliance_l, square_h, square_l, negative, certain)
    return negative, certain


def chain_counts(x: NDArray[np.float64], site: NDArray[np.bool_], m: NDArray[np.float64],
                 compliance: tuple[NDArray[np.float64], NDArray[np.float64]],
                 squares: tuple[NDArray[np.float64], NDArray[np.float64]]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """(count below x, certain) of the eigenvalues of chains of sites and springs (`_chain_block`:
    node k a site with mass m[k] or a spring with compliance 1 / w, squares[k] the square of the
    coupling of nodes k and k + 1, 0 where two paths meet): sites less negative pivots, the
    spring form's Schur complement being x M - K."""
    negative, certain = _chain_counts(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(site), m,
                                      compliance[0], compliance[1], squares[0], squares[1])
    return int(np.count_nonzero(site)) - negative.astype(np.intp), certain


# --- the cut chain's factor with walls ---

@kernel_jit()
def _walled(a: NDArray[np.float64], b: NDArray[np.float64], tie: NDArray[np.float64]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    n = a.shape[0]
    d, e = np.empty(n), np.empty(n - 1)
    s = tie[0]
    for i in range(n):
        square = a[i] * a[i] + s
        d[i] = np.sqrt(square)
        if i < n - 1:
            e[i] = b[i] * (a[i] / d[i])
            s = tie[i + 1] + b[i] * b[i] * (s / square)
    return d, e


def walled_factor(a: NDArray[np.float64], b: NDArray[np.float64], tie: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(d, e) of the lower bidiagonal Cholesky factor of B~ B~^T + diag(tie), B~ lower bidiagonal
    with diagonal a and subdiagonal b, all nonnegative (`counting.cut_chain`'s recurrence, every
    step a sum, product or quotient of nonnegative numbers: relatively accurate)."""
    return _walled(*(np.ascontiguousarray(v, dtype=float) for v in (a, b, tie)))
