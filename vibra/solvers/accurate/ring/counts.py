"""A ring's frequencies certified by Sturm counts of its pencil (and spring form) in double-double.

A ring (each spring joins two sites, the springs close one cycle through every dof; springs
to a wall are allowed) has a cyclic tridiagonal K once its dofs are taken around the cycle.
The number of eigenvalues of (K, M) below x is the number of negative pivots of an LDL^T of
K - x M (Sylvester's law of inertia; the corner spring is carried as fill in the last column).
`ring_pencil` builds K from the spring constants, couplings and masses themselves (no
float64 rounding of K or of B~ = W^1/2 B M^-1/2 enters: the counts are of the problem as
given); `certify` brackets each computed eigenvalue between two counts.

Rounding. The pivots p_i of the leading tridiagonal are computed in double-double (unit
u = 2^-104, each operation within a few u): as in the classical analysis of the Sturm sequence,
they are the exact pivots of a tridiagonal whose entries differ from the given ones by a
few u relatively, d_i = a_i - x m_i by a few u (|a_i| + x m_i); the counted eigenvalues are
those of a pencil within `RHO_UNIT` (R + |x|) of (K, M) (Weyl, R the largest absolute row
sum of M^-1/2 |K| M^-1/2). The fill g and the last pivot are sums over the whole ring: their
rounding is carried along (a running error bound, in float64) and a count whose last pivot
is not farther from zero than that bound is reported as uncertain, never guessed.

Below omega^2 ~ 1e-17 R that perturbation exceeds 1e-13 omega^2 (rings with masses and
springs over 1e12 reach ||K~|| / omega^2 ~ 1e30). There `count_below_springs` counts the
inertia of the spring form [[W^-1, B], [B^T, x M]], in which no entry is a difference: its
counts are exact for masses and springs within ~1e-27 relatively of the given ones (and one
entry of B~ within as much), which moves omega by ~1e-27 relatively at any x; `certify`
brackets each such value with them and narrows the bracket by multisection.

Cost: O(n) per count, vectorised over the points x: all modes of a 1,600-site ring, two
counts each, in about half a second (the spring form: ~0.5 s per ~900 points). Written here
because no library offers inertia counts of a cyclic tridiagonal in extended precision
(mpmath does, ~1,000 times slower).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.sparse.csgraph import depth_first_order

from vibra.solvers.accurate.counting import LADDER, SECTION_PASSES, multisection, spring_width, stored_factor
from vibra.solvers.accurate.dd import UNIT as _UNIT_DD, add as _add, div as _div, mul as _mul, split_mp
from vibra.solvers.accurate.rounding import dekker_split, split_product

if TYPE_CHECKING:
    from vibra.solvers.common import MatrixLike

__all__ = ["RingPencil", "ring_pencil", "count_below", "count_below_springs", "count_below_mp", "mp_rho", "certify", "RHO_UNIT",
           "MP_WORK"]

#: The counts are exact for a pencil within RHO_UNIT (R + |x|) of (K, M): pivots within
#: 4 operations' rounding of each entry (diagonal, off-diagonal squared), 4 `dd.UNIT` each
#: (dd.UNIT: 16 units of 2^-104, double-double's operations not being correctly rounded).
RHO_UNIT = 16 * _UNIT_DD

@dataclass
class RingPencil:
    """K - x M of a ring, its dofs in cycle order (`order`): diagonal a (double-double, hi
    and lo), off-diagonal b (b[i] couples order[i] and order[i + 1]; b[n - 1] is the corner,
    order[n - 1] with order[0]), masses m (float64, as given) and R, the largest absolute
    row sum of M^-1/2 |K| M^-1/2 (rounded up); `walls` whether a spring ties a site to a
    wall; the inputs themselves, for `count_below_mp`: `terms` (position, w, c) of every entry
    of B (a_i = sum w c^2 over the position's terms), `edges` (w, c1, c2) of each b_i; for
    `count_below_springs`: `ends`, each cycle spring's entries of B on order[i] and on
    order[i + 1], and `wall`, the springs to a wall at each position (sum of w c^2, double-double)."""

    order: NDArray[np.intp]
    m: NDArray[np.float64]
    R: float
    walls: bool
    terms: tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]
    edges: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
    ends: tuple[NDArray[np.float64], NDArray[np.float64]]  # c at order[i], order[i + 1]
    wall_terms: tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]  # the terms of springs to a wall
    built: dict[int, tuple[list[Any], list[Any]]] = field(default_factory=dict)  # digits -> (a, b)
    exact: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(default_factory=dict)

    @property
    def n(self) -> int:
        return int(self.order.shape[0])

    @property
    def a(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """K's diagonal in double-double (formed in mpmath on first use: O(n) mpmath operations,
        ~1 s per 10^4 sites, which `ring.values` does not need)."""
        self._form()
        return self.exact["a"]

    @property
    def b(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        self._form()
        return self.exact["b"]

    @property
    def wall(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The springs to a wall at each position (sum of w c^2, double-double)."""
        if "wall" not in self.exact:
            self.exact["wall"] = split_mp(_entries(self.wall_terms, (np.zeros(0),) * 3, self.n, 40)[0])
        return self.exact["wall"]

    def _form(self) -> None:
        if "a" not in self.exact:
            diagonal, off = _entries(self.terms, self.edges, self.n, 40)
            self.exact["a"], self.exact["b"] = split_mp(diagonal), split_mp(off)


def ring_pencil(coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> RingPencil | None:
    """The ring's pencil from its spring factor (B, w) and diagonal masses, or None when the
    springs do not close one cycle through all dofs (n >= 3; a row of B with one entry, a
    spring to a wall, is allowed)."""
    if np.ndim(mass) != 1:
        return None
    B, per_row = stored_factor(coupling)
    n = B.shape[1]
    if n < 3 or per_row.max(initial=0) > 2:
        return None
    pairs = np.flatnonzero(per_row == 2)
    if pairs.shape[0] != n:
        return None
    columns = B.indices[B.indptr[pairs][:, None] + np.arange(2)]  # (n, 2) sites of each spring
    if np.any(np.bincount(columns.ravel(), minlength=n) != 2) or np.any(columns[:, 0] == columns[:, 1]):
        return None
    # walk the cycle (every site has two springs): a depth-first order from site 0 follows it,
    # and reaches every site only if the springs close one cycle, not several
    label = np.arange(1, n + 1, dtype=float)  # (spring j of `columns` stored as j + 1: 0 is "none")
    graph = sp.csr_matrix((np.r_[label, label], (np.r_[columns[:, 0], columns[:, 1]],
                                                 np.r_[columns[:, 1], columns[:, 0]])), shape=(n, n))
    walk = depth_first_order(graph, 0, directed=False, return_predecessors=False)
    if walk.shape[0] != n:
        return None  # more than one cycle
    found = np.asarray(graph[walk, np.roll(walk, -1)]).ravel()
    if np.any(found < 1) or np.any(found != np.round(found)):
        return None
    order = walk.tolist()
    edges = (found.astype(np.intp) - 1).tolist()
    position = np.empty(n, dtype=np.intp)
    position[np.array(order)] = np.arange(n)
    rows_of = np.repeat(np.arange(B.shape[0]), per_row)
    terms = (position[B.indices], np.asarray(weights, dtype=float)[rows_of], B.data.copy())
    first = B.indptr[pairs[np.array(edges)]]
    edge_terms = (np.asarray(weights, dtype=float)[pairs[np.array(edges)]], B.data[first], B.data[first + 1])
    # R from float64 entries: sum |w| c^2 >= |a_i| and |w c1 c2| = |b_i|, each within a few eps of
    # the exact one, inside the 1e-12 (the exact entries are formed in mpmath only if counted)
    a = np.bincount(terms[0], weights=np.abs(terms[1]) * terms[2] ** 2, minlength=n)
    b = edge_terms[0] * edge_terms[1] * edge_terms[2]
    m = np.asarray(mass, dtype=float)[np.array(order)]
    root = np.sqrt(m)
    rows = np.abs(a) / m + np.abs(b) / (root * np.roll(root, -1)) + np.abs(np.roll(b, 1)) / (root * np.roll(root, 1))
    here = B.indices[first] == np.array(order)
    ends = (np.where(here, B.data[first], B.data[first + 1]), np.where(here, B.data[first + 1], B.data[first]))
    walls = per_row[rows_of] == 1
    return RingPencil(np.array(order), m, float(rows.max()) * (1 + 1e-12), bool(np.any(per_row == 1)),
                      terms, edge_terms, ends, (terms[0][walls], terms[1][walls], terms[2][walls]))


def _entries(terms: tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]],
             edges: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], n: int, digits: int
             ) -> tuple[list[Any], list[Any]]:
    """K's diagonal a and cycle couplings b in mpmath at `digits` digits, from the inputs."""
    import mpmath  # here only: `import vibra` loads no mpmath

    with mpmath.workdps(digits):
        a = [mpmath.mpf(0)] * n
        for i, w, c in zip(*(t.tolist() for t in terms)):
            a[i] += mpmath.mpf(w) * mpmath.mpf(c) ** 2
        b = [mpmath.mpf(w) * mpmath.mpf(c1) * mpmath.mpf(c2) for w, c1, c2 in zip(*(t.tolist() for t in edges))]
    return a, b


def count_below(pencil: RingPencil, x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """(count, certain): how many eigenvalues of a pencil within RHO_UNIT (R + |x|) of (K, M)
    lie below each x; `certain` False where the last pivot's sign is not decided (or a pivot
    vanished), and the count must not be used."""
    x = np.asarray(x, dtype=float)
    n = pencil.n
    (ah, al), (bh, bl), m = pencil.a, pencil.b, pencil.m
    u = _UNIT_DD

    x_high, x_low = dekker_split(x)  # (Dekker halves of x, shared by every product x m_i)
    zero = np.zeros_like(x)

    def diagonal(i: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        mh, ml = dekker_split(m[i])
        ph, pl = split_product(x, m[i], x_high, x_low, mh, ml)
        return _add(ah[i], al[i], -ph, -pl)

    ph, pl = diagonal(0)
    gh, gl = bh[n - 1] + zero, bl[n - 1] + zero  # the corner: fill of row 0
    g_error = zero.copy()  # |computed g - g of the perturbed tridiagonal|
    lh, ll = diagonal(n - 1)
    last_error = u * (np.abs(ah[n - 1]) + np.abs(x) * m[n - 1])
    negative = np.zeros(x.shape, dtype=np.intp)
    squares = [_mul(bh[i], bl[i], bh[i], bl[i]) for i in range(n - 1)]  # b_i^2, once
    with np.errstate(all="ignore"):
        for i in range(n - 1):
            negative += ph < 0
            qh, ql = _div(gh, gl, ph, pl)  # g / p
            sh, sl = _mul(gh, gl, qh, ql)  # g^2 / p
            lh, ll = _add(lh, ll, -sh, -sl)
            # g^2/p's error: from g's own, 2 |g| dg / |p| + dg^2 / |p|, and its rounding
            last_error = last_error + (2 * np.abs(gh) + g_error) * g_error / np.abs(ph) + u * (
                np.abs(sh) + np.abs(lh))
            if i == n - 2:
                break
            # the next fill: -b_i g / p (+ b_{n-2}, the last row's own coupling, at i = n - 3)
            fh, fl = _mul(-bh[i], -bl[i], qh, ql)
            g_error = np.abs(bh[i] / ph) * g_error * (1 + 1e-12) + 4 * u * np.abs(fh)
            if i == n - 3:
                fh, fl = _add(fh, fl, bh[n - 2], bl[n - 2])
                g_error = g_error + u * np.abs(fh)
            # the next pivot: d_{i+1} - b_i^2 / p_i
            th, tl = _div(squares[i][0], squares[i][1], ph, pl)
            dh, dl = diagonal(i + 1)
            ph, pl = _add(dh, dl, -th, -tl)
            gh, gl = fh, fl
        certain = np.isfinite(lh) & np.isfinite(last_error) & (np.abs(lh) > 1.01 * last_error) & (ph != 0)
    return negative + (lh < 0), certain


def count_below_springs(pencil: RingPencil, x: NDArray[np.float64]
                        ) -> tuple[NDArray[np.intp], NDArray[np.bool_], NDArray[np.float64]]:
    """(count, certain, widening): counts of eigenvalues below x, relatively accurate at every x.

    Where `count_below` perturbs K - x M absolutely (by RHO_UNIT R: blind to omega^2 below
    ~1e-17 R), this counts the inertia of the spring form
    A(x) = [[W^-1, B], [B^T, x M]] (walls eliminated into x M - sum w c^2), whose Schur
    complement is x M - K: the eigenvalues above x are A(x)'s negative pivots. Its 2n nodes
    (site, spring, site, ...) form a cycle; no entry is a difference of K's entries, so the
    pivots along the chain are exact for A with each coupling c relatively perturbed by a few
    units of double-double. Along a chain such perturbations are a diagonal scaling of A: a
    multiplicative change of w and m (omega within `phi` relatively), except for the cycle's
    closing coupling, whose relative change (`theta`) moves omega by at most theta |b~| (Weyl,
    b~ = sqrt(w) c / sqrt(m) that entry of B~). The cycle is closed at the spring with the
    smallest such entry. The fill and the last pivot carry a running error bound, as in
    `count_below`; a count whose last pivot is within it is uncertain.

    Per-node unit u = 4 `dd.UNIT` (an operation's rounding and its attribution to a coupling):
    phi = 2 (2n + 1) u, theta = 4 n u. `widening` (`spring_widening`, the same for every x):
    (phi, theta |b~|); where the count is exact for omega'^2 = x, the true omega lies within
    omega' (1 +- phi) +- theta |b~|."""
    x = np.asarray(x, dtype=float)
    n = pencil.n
    w = pencil.edges[0]
    c_in, c_out = pencil.ends
    m = pencil.m
    turn = (int(np.argmin(_closing(pencil))) + 1) % n  # the cut chain starts at site r + 1, ends at spring r
    w, c_in, c_out = np.roll(w, -turn), np.roll(c_in, -turn), np.roll(c_out, -turn)
    m = np.roll(m, -turn)
    wall_h, wall_l = np.roll(pencil.wall[0], -turn), np.roll(pencil.wall[1], -turn)
    size = 2 * n
    u = 4 * _UNIT_DD  # each operation's rounding, and its attribution to a coupling (see above)
    off = np.empty(size - 1)
    off[0::2], off[1::2] = c_in, c_out[: n - 1]
    square_h, square_l = _mul(off, np.zeros_like(off), off, np.zeros_like(off))
    x_high, x_low = dekker_split(x)
    zero, one = np.zeros_like(x), np.ones_like(x)

    compliance = _div(np.ones(n), np.zeros(n), w, np.zeros(n))  # 1 / w, once

    def diagonal(j: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        i = j // 2
        if j % 2:  # spring i: 1 / w_i
            return compliance[0][i] + zero, compliance[1][i] + zero
        mh, ml = dekker_split(m[i])
        ph, pl = split_product(x, m[i], x_high, x_low, mh, ml)
        return _add(ph, pl, -wall_h[i] + zero, -wall_l[i] + zero)

    ph, pl = diagonal(0)
    gh, gl = c_out[n - 1] + zero, zero.copy()  # the closing coupling: fill of the last row
    g_error = zero.copy()
    lh, ll = diagonal(size - 1)
    last_error = u * np.abs(lh)
    negative = np.zeros(x.shape, dtype=np.intp)
    vanished = np.zeros(x.shape, dtype=bool)
    with np.errstate(all="ignore"):
        for j in range(size - 1):
            negative += ph < 0
            vanished |= ph == 0
            rh, rl = _div(one, zero, ph, pl)  # 1 / p, then g / p and c_j^2 / p as products
            qh, ql = _mul(gh, gl, rh, rl)
            sh, sl = _mul(gh, gl, qh, ql)  # g^2 / p
            lh, ll = _add(lh, ll, -sh, -sl)
            last_error = last_error + (2 * np.abs(gh) + g_error) * g_error / np.abs(ph) + u * (
                2 * np.abs(sh) + np.abs(lh))
            if j == size - 2:
                break
            fh, fl = _mul(-off[j] + zero, zero, qh, ql)  # the next fill: -c_j g / p
            g_error = np.abs(off[j] / ph) * g_error * (1 + 1e-12) + 4 * u * np.abs(fh)
            if j == size - 3:  # the last row's own coupling
                fh, fl = _add(fh, fl, off[size - 2] + zero, zero)
                g_error = g_error + u * (np.abs(fh) + abs(off[size - 2]))
            th, tl = _mul(rh, rl, square_h[j], square_l[j])  # c_j^2 / p
            dh, dl = diagonal(j + 1)
            ph, pl = _add(dh, dl, -th, -tl)
            gh, gl = fh, fl
        certain = (np.isfinite(lh) & np.isfinite(last_error) & (np.abs(lh) > 1.01 * last_error + 1e-290)
                   & ~vanished)
    return n - (negative + (lh < 0)), certain, spring_widening(pencil)


def spring_widening(pencil: RingPencil) -> NDArray[np.float64]:
    """(phi, theta |b~|) of `count_below_springs`: where its counts are exact for omega', the
    true omega lies within omega' (1 +- phi) +- theta |b~|."""
    n = pencil.n
    u = 4 * _UNIT_DD
    phi = 2 * (2 * n + 1) * u
    return np.array([phi, 4 * n * u * float(_closing(pencil).min()) * (1 + phi)])


def _closing(pencil: RingPencil) -> NDArray[np.float64]:
    """|b~| of each cycle spring's entry on the next site, sqrt(w_i) |c| / sqrt(m_{i+1}): the
    spring form closes its cycle at the smallest."""
    return np.sqrt(pencil.edges[0]) * np.abs(pencil.ends[1]) / np.sqrt(np.roll(pencil.m, -1))


def count_below_mp(pencil: RingPencil, x: float, digits: int) -> tuple[int, bool]:
    """`count_below` at one x in mpmath with `digits` digits (pivots within a few units of
    10^-digits of each entry: a pencil within `mp_rho` of (K, M)); for the values that
    double-double cannot resolve (||K~|| / omega^2 beyond ~1e16)."""
    import mpmath  # here only: `import vibra` loads no mpmath

    n = pencil.n
    if digits not in pencil.built:
        pencil.built[digits] = _entries(pencil.terms, pencil.edges, n, digits)
    diagonal, b = pencil.built[digits]
    with mpmath.workdps(digits):
        xm = mpmath.mpf(float(x))
        a = [diagonal[i] - xm * mpmath.mpf(float(pencil.m[i])) for i in range(n)]
        pivot, fill, last = a[0], b[n - 1], a[n - 1]
        total = abs(last)
        negative = 0
        for i in range(n - 1):
            if pivot == 0:
                return 0, False
            negative += pivot < 0
            square = fill * fill / pivot
            last -= square
            total += abs(square)
            if i == n - 2:
                break
            fill = -b[i] * fill / pivot + (b[n - 2] if i == n - 3 else 0)
            pivot = a[i + 1] - b[i] ** 2 / pivot
        certain = abs(last) > 16 * n * mpmath.mpf(10) ** (-digits) * total
        return negative + int(last < 0), bool(certain)


def mp_rho(pencil: RingPencil, x: float, digits: int) -> float:
    """The perturbation `count_below_mp` allows for (Weyl, as `RHO_UNIT` for double-double)."""
    return 64 * 10.0 ** (-digits) * (pencil.R + abs(x))


#: Most pivots computed in mpmath per certificate (a mode's two counts cost 2 n): beyond
#: it, the values double-double cannot certify keep their residual bound.
MP_WORK = 100_000


def _spring_brackets(pencil: RingPencil, values: NDArray[np.float64], index: NDArray[np.intp],
                     error: NDArray[np.float64], best: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For each value still wider than 1e-13 relative: a bracket [lo, hi] that two
    `count_below_springs` counts prove holds its eigenvalue (the `LADDER` around it, then its
    own `error`), narrowed by multisection (SECTIONS - 1 counts per bracket and pass) to
    LADDER[0] relative (8 eps) or for SECTION_PASSES passes; the value becomes the bracket's middle where
    that certifies it more tightly than before. Returns (values, best), updated."""
    todo = np.flatnonzero((best > 1e-13 * values) & (values > 0))
    if todo.shape[0] == 0:
        return values, best
    v, j = values[todo], index[todo]
    lo, hi = np.full(v.shape, np.nan), np.full(v.shape, np.nan)
    # the tightest level first (most values need no other), then every other at once
    for levels in (LADDER[:1], (*LADDER[1:], None)):
        open_ = np.flatnonzero(np.isnan(lo))
        if open_.shape[0] == 0:
            break
        t = np.array([level * v[open_] if level is not None else np.minimum(error[todo][open_], 0.5 * v[open_])
                      for level in levels])  # (levels, k), tightest first
        a, b = v[open_] - t, v[open_] + t
        counts, sure, _ = count_below_springs(pencil, np.r_[a.ravel(), b.ravel()])
        below, above = counts[: a.size].reshape(a.shape), counts[a.size:].reshape(a.shape)
        good = sure[: a.size].reshape(a.shape) & sure[a.size:].reshape(a.shape) & (below <= j[open_]) & (
            j[open_] < above)
        first = np.argmax(good, axis=0)  # the tightest proven level of each value
        some = good.any(axis=0)
        columns = np.flatnonzero(some)
        lo[open_[some]], hi[open_[some]] = a[first[some], columns], b[first[some], columns]
    found = np.flatnonzero(~np.isnan(lo))
    lo[found], hi[found], _ = multisection(lambda x: count_below_springs(pencil, x)[:2], lo[found], hi[found],
                                           j[found], SECTION_PASSES)
    if found.shape[0] == 0:
        return values, best
    middle = 0.5 * (lo[found] + hi[found])
    width = spring_width(lo[found], hi[found], middle, spring_widening(pencil))
    better = width < best[todo[found]]
    values, best = values.copy(), best.copy()
    values[todo[found[better]]], best[todo[found[better]]] = middle[better], width[better]
    return values, best


def certify(pencil: RingPencil, values: NDArray[np.float64], index: NDArray[np.intp], error: NDArray[np.float64]
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Per value (an approximation of the eigenvalue number `index`, 0-based ascending), the
    tightest `LADDER` bracket [v - t, v + t] that two counts prove holds that eigenvalue,
    widened by the counts' own perturbation: (values, bound, certified). Double-double counts
    of K - x M first; a value they leave wider than 1e-13 relative gets the spring form's
    counts (`count_below_springs`), which may narrow it (the value returned is then the
    narrowed bracket's middle); one still wider is tried in mpmath with the digits its ratio
    ||K~|| / v needs (within `MP_WORK`). Each value keeps `error` where that is smaller (or
    where the counts certify nothing)."""
    values = np.asarray(values, dtype=float)
    k = values.shape[0]
    best = np.full(k, np.inf)
    floor = 4 * RHO_UNIT * pencil.R
    for level in LADDER:
        t = np.maximum(level * np.abs(values), floor)
        width = (t + RHO_UNIT * (pencil.R + np.abs(values) + t)) * (1 + 1e-12)
        todo = np.flatnonzero(width < best)
        if todo.shape[0] == 0:
            continue
        low, high = values[todo] - t[todo], values[todo] + t[todo]
        positive = low > 0  # K is positive semi-definite (w > 0): no eigenvalue below 0
        counts, sure = count_below(pencil, np.r_[low[positive], high])
        below = np.zeros(todo.shape[0], dtype=np.intp)
        sure_low = np.ones(todo.shape[0], dtype=bool)
        split = int(positive.sum())
        below[positive], sure_low[positive] = counts[:split], sure[:split]
        above, sure_high = counts[split:], sure[split:]
        good = sure_low & sure_high & (below <= index[todo]) & (index[todo] < above)
        best[todo[good]] = width[todo[good]]
    if not pencil.walls:  # a free ring: exactly one zero eigenvalue, the rigid rotation
        zero = index == 0
        best[zero] = np.minimum(best[zero], np.abs(values[zero]) * (1 + 1e-12) + np.finfo(float).tiny)
    # below omega^2 ~ 1e-17 R double-double's perturbation of K exceeds 1e-13 omega^2: the
    # spring form's counts, relatively accurate at every x, bracket the value and narrow it
    values, best = _spring_brackets(pencil, values, index, error, best)
    # where double-double's perturbation is too large (||K~|| / omega^2 over ~1e16): mpmath,
    # with as many digits as the ratio needs, while the work stays within MP_WORK
    budget = MP_WORK
    for j in np.flatnonzero((best > 1e-13 * values) & (values > 0)).tolist():
        digits = 24 + int(np.ceil(np.log10(max(pencil.R / values[j], 1.0))))
        for level in LADDER:
            t = level * values[j]
            rho = max(mp_rho(pencil, values[j] - t, digits), mp_rho(pencil, values[j] + t, digits))
            width = (t + rho) * (1 + 1e-12)
            if width >= best[j]:
                break
            if budget < 2 * pencil.n:
                break
            budget -= 2 * pencil.n
            under, low_sure = count_below_mp(pencil, values[j] - t, digits)
            over, high_sure = count_below_mp(pencil, values[j] + t, digits)
            if low_sure and high_sure and under <= index[j] < over:
                best[j] = width
                break
    certified = np.isfinite(best)
    return values, np.minimum(best, error), certified
