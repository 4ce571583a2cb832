"""Singular values of a bidiagonal by bisection on its Golub-Kahan form, compiled, LANES at a time.

The singular values of an upper bidiagonal (d, e) (size s) are the non-negative eigenvalues of
the Golub-Kahan tridiagonal TGK: zero diagonal, off-diagonal b = d1, e1, d2, e2, ..., ds. Its
Sturm count at x, the number of eigenvalues below x, is the number of negative q_i in
q_0 = -x, q_i = -x - b_(i-1)^2 / q_(i-1) (a q within `pivmin` of zero taken as -pivmin, as
LAPACK dstebz does); with a zero diagonal each q_i is exact for b and x perturbed by a few ulps
relatively (Demmel and Kahan 1990), so bisection finds every singular value to a few ulps of
itself, however far below ||B|| it lies. For x > 0 the count is s + #(sigma < x).

LAPACK dstebz runs these counts one point at a time (~20 ns per node and count here, ~2.2e-6 n s
per value of a chain of n sites: 28 s of the lowest 13 of 10^6 sites). Here `count_kernels.LANES`
values are bisected together, one point each, in SIMD lanes (a lane that has converged takes the
next value), and the bisection homes in on the exponent first: from a lower end of 0 the next
point is hi 2^-32, then the geometric mean while hi > 2 lo, then the midpoint, to 2 ulps
(hi - lo <= 2 eps hi) or to twice the underflow threshold, dstebz's ABSTOL here (an interval
from 0 that never left it: the value is 0, a free chain's padding).
With vectors, dstein takes these values where the Golub-Kahan matrix's block structure is
known without dstebz (`_compiled_with_blocks`).

Where dstebz is estimated under `vibra.solvers.compiled.COMPILED_FROM_S` (`compiled_bisection_pays`:
a chain of 2,000 sites, its lowest 10 modes), `golub_kahan_lowest` takes it instead: the
same promise (each value to about two ulps of itself), without loading numba.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra._core.lapack import bidiagonal_singular_values, tridiagonal_eigenvalues_by_index, tridiagonal_vectors
from vibra.solvers.accurate.count_kernels import LANES, kernel_jit
from vibra.solvers.common import EPS
from vibra.solvers.compiled import batches, compiled_pays, prange, threads as _threads

__all__ = ["golub_kahan_lowest", "bidiagonal_values_by_bisection", "compiled_bisection_pays", "DSTEBZ_S", "DQDS_FACTOR"]

_EPS = float(np.finfo(float).eps)
_SAFE_MIN = float(np.finfo(float).tiny)

#: Most values one thread bisects together (`LANES` at a time, a finished lane taking the next);
#: fewer where that leaves a thread idle.
CHUNK = 4 * LANES

#: Seconds per site and value of LAPACK dstebz on a bidiagonal's Golub-Kahan form, the compiled
#: bisection's counterpart: 1.5e-6 (2,000 sites, 11 values) to 2.7e-6 (100,000 sites, 21 values)
#: measured, one core (the compiled bisection: 3-6e-7 warm).
DSTEBZ_S = 2e-6
#: The compiled bisection's own rate, seconds per site and value on one thread (3-6e-7 measured
#: warm): sizes its `batches`.
BISECTION_S = 5e-7


def compiled_bisection_pays(size: int, k: int) -> bool:
    """Whether k singular values of a bidiagonal of `size` take the compiled bisection rather
    than dstebz (`vibra.solvers.compiled.compiled_pays`, from dstebz's estimate); decided by
    `golub_kahan_lowest`, the caller that has both."""
    return compiled_pays(DSTEBZ_S * size * k)


@kernel_jit()
def _counts(x: NDArray[np.float64], squares: NDArray[np.float64], pivmin: float, below: NDArray[np.int64]) -> None:
    """Sturm counts of TGK - x I (zero diagonal, `squares` its off-diagonal squared) at the LANES
    points x, into below."""
    s = np.zeros((2, LANES))  # rows: q, count (as a float: exact to 2^53)
    for p in range(LANES):
        q = -x[p]
        q = -pivmin if abs(q) < pivmin else q
        s[0, p] = q
        s[1, p] = 1.0 if q < 0 else 0.0
    for i in range(squares.shape[0]):
        b2 = squares[i]
        for p in range(LANES):
            q = -x[p] - b2 / s[0, p]
            q = -pivmin if abs(q) < pivmin else q
            s[0, p] = q
            s[1, p] += 1.0 if q < 0 else 0.0
    for p in range(LANES):
        below[p] = int(s[1, p])


@kernel_jit()
def _next_point(low: float, high: float) -> float:
    if low == 0.0:
        return high * 2.0**-32 if high > 2.0**32 * _SAFE_MIN else 0.5 * high
    if high > 2.0 * low:
        return np.sqrt(low) * np.sqrt(high)
    return 0.5 * (low + high)


@kernel_jit()
def _bisect_chunk(first: int, stop: int, base: int, size: int, squares: NDArray[np.float64], top: float,
                  pivmin: float, out: NDArray[np.float64]) -> None:
    """Singular values first..stop-1 (0-based ascending) of the bidiagonal of `size`, into
    out[j - base]."""
    x = np.zeros(LANES)
    low, high = np.zeros(LANES), np.zeros(LANES)
    target = np.full(LANES, -1, dtype=np.int64)
    below = np.zeros(LANES, dtype=np.int64)
    following = first
    busy = 0
    for p in range(LANES):
        if following < stop:
            target[p], low[p], high[p] = following, 0.0, top
            x[p] = _next_point(0.0, top)
            following += 1
            busy += 1
    while busy:
        _counts(x, squares, pivmin, below)
        for p in range(LANES):
            j = target[p]
            if j < 0:
                continue
            if below[p] - size > j:  # more than j singular values below x: sigma_j < x
                high[p] = x[p]
            else:
                low[p] = x[p]
            if high[p] - low[p] <= 2 * _EPS * high[p] or high[p] <= 2 * _SAFE_MIN:
                # (an upper end at the underflow threshold with no point below: the value is 0)
                out[j - base] = 0.5 * (low[p] + high[p]) if low[p] > 0 else 0.0
                if following < stop:
                    target[p], low[p], high[p] = following, 0.0, top
                    following += 1
                else:
                    target[p] = -1
                    busy -= 1
                    continue
            x[p] = _next_point(low[p], high[p])


@kernel_jit(parallel=True)
def _bisect(skip: int, k: int, size: int, squares: NDArray[np.float64], top: float, pivmin: float, chunk: int
            ) -> NDArray[np.float64]:
    out = np.zeros(k)
    for c in prange((k + chunk - 1) // chunk):
        _bisect_chunk(skip + c * chunk, skip + min(k, (c + 1) * chunk), skip, size, squares, top, pivmin, out)
    return out


def bidiagonal_values_by_bisection(d: NDArray[np.float64], e: NDArray[np.float64], skip: int, k: int
                                   ) -> NDArray[np.float64]:
    """Singular values skip..skip+k-1 (0-based, ascending) of the upper bidiagonal (d, e), each
    to about two ulps of itself (see the module docstring). O(s k) per bit."""
    d = np.ascontiguousarray(d, dtype=float)
    e = np.ascontiguousarray(e, dtype=float)
    size = d.shape[0]
    if skip < 0 or k < 0 or skip + k > size:
        raise ValueError(f"singular value indices must lie in 0..{size - 1}, got {skip}..{skip + k - 1}")
    b = np.empty(2 * size - 1)
    b[0::2], b[1::2] = np.abs(d), np.abs(e[: size - 1])
    squares = b * b
    largest = float(squares.max(initial=0.0))
    pivmin = _SAFE_MIN * max(1.0, largest)
    edges = np.abs(np.r_[0.0, b]) + np.abs(np.r_[b, 0.0])  # Gershgorin: |b_(i-1)| + |b_i|
    top = float(edges.max(initial=0.0)) * (1 + 4 * _EPS) + pivmin
    if k <= 0:
        return np.zeros(0)
    threads = _threads()
    per_value = BISECTION_S * size / threads  # batches of ~1 s: Ctrl-C is seen between them
    parts = []
    for first, stop in batches(int(k), per_value, LANES * threads):
        count = stop - first
        chunk = int(min(CHUNK, max(LANES, LANES * -(-count // (LANES * threads)))))  # (every thread busy)
        parts.append(_bisect(int(skip) + first, count, size, squares, top, pivmin, chunk))
    values: NDArray[np.float64] = parts[0] if len(parts) == 1 else np.concatenate(parts)
    return values


#: Values only: a bidiagonal of size s <= DQDS_FACTOR * k takes dqds on all its values (O(s^2))
#: rather than bisection for k of them (compiled, `gk_bisection`: O(s k)), whichever is cheaper.
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
DQDS_FACTOR = 10


def golub_kahan_lowest(d: NDArray[np.float64], e: NDArray[np.float64], skip: int, k: int, *, vectors: bool
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None]:
    """Singular values skip..skip+k-1 (ascending, 0-based) of the upper bidiagonal (d, e).

    Returns (sigma, u, v): u (s, k) left and v (s, k) right singular vectors when `vectors`
    (None otherwise), from the Golub-Kahan eigenvectors z = [v1, u1, v2, u2, ...] / sqrt 2.
    """
    s = d.shape[0]
    off = np.empty(2 * s - 1)
    off[0::2] = d
    off[1::2] = e
    zero = np.zeros(2 * s)
    first = s + skip
    lower = first - 1 if vectors else first  # the -sigma partner of the lowest: a zero pair needs both
    if not vectors and s <= DQDS_FACTOR * k:
        # dqds on all s values (O(s^2)) beats bisection for k of them (O(s k) per bit) here
        return bidiagonal_singular_values(d, e)[skip : skip + k], None, None
    if not vectors and compiled_bisection_pays(s, k):  # the same counts, LANES values at a time
        return bidiagonal_values_by_bisection(d, e[: s - 1], skip, k), None, None
    known = _compiled_with_blocks(d, e, off, lower, first, k)  # (None: dstebz, cheaper for few values)
    values, block, split = known if known is not None else tridiagonal_eigenvalues_by_index(zero, off, lower,
                                                                                            first + k - 1)
    order = np.argsort(values, kind="stable")  # dstebz groups the values by split-off block
    sigma = np.abs(values[order][first - lower:])
    if not vectors:
        return sigma, None, None
    z = tridiagonal_vectors(zero, off, values, block, split)[:, order]
    right, left = z[0::2], z[1::2]
    u = left[:, first - lower:].copy()
    v = right[:, first - lower:].copy()
    if sigma.size and sigma[0] <= 4.0 * EPS * float(np.abs(off).max(initial=0.0)):
        # sigma ~ 0 (a free chain's translation): TGK's null space mixes [v; 0] and [0; u];
        # each side's null vector is the dominant direction of that side's parts of the pair.
        u[:, 0] = _dominant(left[:, :2])
        v[:, 0] = _dominant(right[:, :2])
    u /= np.maximum(np.linalg.norm(u, axis=0), np.finfo(float).tiny)
    v /= np.maximum(np.linalg.norm(v, axis=0), np.finfo(float).tiny)
    return sigma, u, v


def _compiled_with_blocks(d: NDArray[np.float64], e: NDArray[np.float64], off: NDArray[np.float64], lower: int,
                          first: int, k: int) -> tuple[NDArray[np.float64], NDArray[np.intc], NDArray[np.intc]] | None:
    """(values, block, split) as dstebz returns them for TGK's eigenvalues lower..first+k-1, the
    values from the compiled bisection (`gk_bisection`), for dstein: where TGK's blocks are
    known without it, none (no off-diagonal with a square below the safe minimum, dstebz's
    split with a zero diagonal) or only a free chain's padding (d[-1] exactly 0: a last 1 x 1
    block, whose eigenvalue 0 is one of TGK's two zeros). Else None (dstebz decides), as where
    dstebz is the cheaper for these k values (`gk_bisection.compiled_bisection_pays`)."""
    size = d.shape[0]
    if not compiled_bisection_pays(size, k):
        return None
    n = 2 * size
    splits = np.flatnonzero(off * off < np.finfo(float).tiny)
    padded = splits.shape[0] == 1 and splits[0] == n - 2 and d[size - 1] == 0.0
    if splits.shape[0] and not padded:
        return None
    sigma = bidiagonal_values_by_bisection(d, e[: size - 1], first - size, k)
    values = np.r_[-sigma[0], sigma] if lower < first else sigma  # (-sigma_skip: the lower partner)
    block = np.ones(values.shape[0], dtype=np.intc)
    if not padded:
        return values, block, np.array([n], dtype=np.intc)
    zeros = np.flatnonzero(values == 0.0)
    if zeros.shape[0] >= 2:  # one zero is the padding block's: grouped by block, it comes last
        values = np.r_[np.delete(values, zeros[-1]), 0.0]
        block[-1] = 2
    return values, block, np.array([n - 1, n], dtype=np.intc)


def _dominant(parts: NDArray[np.float64]) -> NDArray[np.float64]:
    """The leading left singular vector of a (s, 2) block."""
    basis, _, _ = np.linalg.svd(parts, full_matrices=False)
    column: NDArray[np.float64] = basis[:, 0]
    return column
