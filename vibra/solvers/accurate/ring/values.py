"""Every frequency of a ring to high relative accuracy, values only, in O(n^2): ``accurate-ring``.

A ring is a chain closed by one spring. Cut there (at the spring whose entry of B~ is smallest,
as `ring.counts.count_below_springs` closes its cycle), the chain's eigenvalues p_0 < p_1 < ...
come from dqds on a bidiagonal factor of its K~ (relatively accurate): its spring factor for a
free ring (p_0 = 0), and for a ring with springs to a wall the Cholesky factor that
`cut_chain` forms from the springs without cancellation. The ring's eigenvalue i
lies in [p_i, p_i+1] (interlacing: the ring is the chain plus a positive rank-one term), where
it is the root of the spring form's last pivot (`count_kernels.pivot_roots`, float64, a few
O(n) evaluations each). Each root is then certified by two double-double inertia counts of
the spring form (`count_kernels.spring_counts`, the arithmetic and error analysis of
`ring.counts.count_below_springs`): [v (1 - t), v (1 + t)] holds eigenvalue i when the counts there
are <= i and > i, for the tightest t of `LEVELS` that proves it; a root no level proves
is bracketed by multisection from its interlacing interval. The bound is that bracket widened
by the counts' own perturbation (`ring.counts.spring_widening`, ~1e-27 relatively): every bound is
rigorous for the masses and springs as given, whatever the float64 roots' accuracy.

The lowest k only (`ring_values(pencil, count=k)`): the cut chain's lowest k + 1 eigenvalues by
bisection on its Golub-Kahan form (`lowest.golub_kahan_lowest`, O(n k)) instead of dqds of all
of them, so that a ring of any length costs O(n k) (5.6 s for 10 of 10^6 sites on two cores).

Cost: per mode ~1.5 float64 evaluations of l and ~2.5 double-double counts of 2n nodes, both
compiled 8 points at a time (SIMD lanes, `count_kernels.LANES`), and the cut chain's dqds: in all
~2.4e-8 n^2 s on two cores (68 s at 50,000 sites, 240 s at 100,000, dqds 40% of it), where the
dense Jacobi route of the smaller rings would take minutes and the band solver gives absolute
accuracy only. There is no length limit: the budget (`budget.TIME_LIMIT_S`) refuses what
would take too long.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core.lapack import bidiagonal_singular_values
from vibra.solvers.accurate.count_kernels import NEAR, pivot_roots, spring_counts
from vibra.solvers.common import Matrix, MatrixLike, SolveResult
from vibra.solvers.accurate.counting import (
    LEVELS, certify_at_levels, cut_chain, proven_multisection, sorted_bounds, spring_width,
)
from vibra.solvers.accurate.golub_kahan import Refiner, singular_vectors
from vibra.solvers.accurate.gk_bisection import golub_kahan_lowest
from vibra.solvers.accurate.spring_ritz import Deviation, cluster_bounds, most_terms, spring_figures
from vibra.solvers.accurate.ring.counts import RingPencil, _closing, count_below_mp, mp_rho, ring_pencil, spring_widening
from vibra.solvers.accurate.dd import UNIT as _UNIT_DD, div as _div, mul as _mul

__all__ = ["ring_values", "ring_result", "RingValues", "SpringForm", "spring_arrays", "pair_step", "ring_vectors",
           "spring_walls"]

#: The levels tried first for a root taken at a pole.
SNAPPED_LEVELS = LEVELS[1:3]

#: Most regula falsi steps for a root taken at a pole (`_polish`).
POLISH = 12

#: Bounds above this (omega^2 relative, 1e-13 in omega) get mpmath counts, at most MP_COUNTS
#: per solve, at MP_LEVELS around the value.
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
MP_WANTED = 1.95e-13
MP_COUNTS = 24

#: And at most this many sites counted in mpmath per solve: fewer counts on a longer
#: ring (5 at 10^5 sites, none at 10^6, whose bounds stay double-double's).
#: (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
MP_WORK = 5e5
MP_LEVELS = (64 * 2.0**-53, 3e-14, 1e-13)

@dataclass
class RingValues:
    """What `ring_values` found: values (omega^2 ascending), bound (absolute, per value),
    certified (per value: proven by counts), evaluations (float64 pivots per root, summed),
    counts (double-double counts spent), tightened (bounds of the first `needed` the caller's
    `tighten` step narrowed)."""

    values: NDArray[np.float64]
    bound: NDArray[np.float64]
    certified: NDArray[np.bool_]
    evaluations: int
    counts: int
    tightened: int = 0


def spring_arrays(pencil: RingPencil) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                                               NDArray[np.float64]]:
    """(m, w, c_in, c_out) in chain order: `ring.counts.count_below_springs`' rotation, the cycle cut
    after its smallest closing entry (c_in, c_out: each spring's entries of B on its two sites)."""
    turn = (int(np.argmin(_closing(pencil))) + 1) % pencil.n
    w = np.roll(pencil.edges[0], -turn)
    c_in, c_out = np.roll(pencil.ends[0], -turn), np.roll(pencil.ends[1], -turn)
    return np.roll(pencil.m, -turn), w, c_in, c_out


def spring_walls(pencil: RingPencil) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The springs to a wall at each site (sum of w c^2, double-double) in `spring_arrays`' order."""
    turn = (int(np.argmin(_closing(pencil))) + 1) % pencil.n
    return np.roll(pencil.wall[0], -turn), np.roll(pencil.wall[1], -turn)


Tighten = Callable[[NDArray[np.float64], NDArray[np.float64]], None]


class SpringForm:
    """A ring's spring form as the compiled counts take it (`kernel.spring_counts`): masses, springs,
    couplings, double-double compliances and squared couplings, the closing coupling, walls, unit u."""

    def __init__(self, pencil: RingPencil) -> None:
        n = pencil.n
        self.m, self.w, self.c_in, self.c_out = spring_arrays(pencil)
        self.wall = spring_walls(pencil) if pencil.walls else None
        self.compliance = _div(np.ones(n), np.zeros(n), self.w, np.zeros(n))
        self.off = np.empty(2 * n - 1)
        self.off[0::2], self.off[1::2] = self.c_in, self.c_out[: n - 1]
        self.squares = _mul(self.off, np.zeros_like(self.off), self.off, np.zeros_like(self.off))
        self.closing = float(self.c_out[n - 1])
        self.u = 4 * _UNIT_DD

    def counts(self, x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        count, certain, _ = spring_counts(x, self.m, self.compliance, self.off, self.squares, self.closing,
                                          self.u, self.wall)
        return count, certain


def ring_values(pencil: RingPencil, count: int | None = None, *, tighten: Tighten | None = None,
                needed: int | None = None, aim: float = MP_WANTED) -> RingValues:
    """All eigenvalues of a ring's pencil (the lowest `count` of them when given: O(count n),
    the cut chain's lowest by bisection), each with a count-certified bound (see above). `tighten`
    (values, bound): the caller's step on the bounds still over MP_WANTED
    (values and bounds per eigenvalue index, changed in place) before mpmath counts the loosest
    of the first `needed` (default: all; the rest only bound their neighbours' gaps)."""
    n = pencil.n
    wanted = n if count is None else max(1, min(int(count), n))
    form = SpringForm(pencil)
    m, w, c_in, c_out, wall = form.m, form.w, form.c_in, form.c_out, form.wall
    compliance, off, squares, closing, u = form.compliance, form.off, form.squares, form.closing, form.u
    free = wall is None
    tie = None if wall is None else wall[0]  # float64 walls: the cut chain's factor, the pivot roots
    first = 1 if free else 0  # a free ring's eigenvalue 0 is its rigid rotation, exactly

    # the cut chain's eigenvalues: the squared singular values of its bidiagonal spring factor
    d, e = cut_chain(m, w, c_in, c_out, tie)
    if wanted < n:  # the lowest wanted + 1 only: bisection on the Golub-Kahan form, O(n k)
        poles = golub_kahan_lowest(d, e, 0, wanted + 1, vectors=False)[0] ** 2
    else:
        poles = bidiagonal_singular_values(d, e) ** 2
    if free:
        poles[0] = 0.0
    top = pencil.R * (1 + 1e-12)
    # eigenvalue i lies between the chain's i and i + 1 (the ring is the chain plus one spring)
    low = poles[first:wanted]
    high = np.r_[poles[first + 1:], max(top, poles[-1])][: wanted - first]
    roots, evaluations, side = pivot_roots(low, high, low, np.r_[poles[first + 1:], np.inf][: wanted - first], m,
                                           compliance[0], off, closing, tie)

    def counts(x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        count, certain, _ = spring_counts(x, m, compliance, off, squares, closing, u, wall)
        return count, certain

    def pivots(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return spring_counts(x, m, compliance, off, squares, closing, u, wall)[2]

    inside = np.flatnonzero((side == 0) & (roots > 0))
    roots[inside], spent = _secant(pivots, roots[inside])
    values = np.r_[0.0, roots] if free else roots
    index = np.arange(wanted)
    bound = np.full(wanted, np.inf)
    if free:
        bound[0] = 0.0  # the free ring's rigid rotation: exactly zero (B 1 = 0), as the chains report it

    widening = spring_widening(pencil)

    def widened(lo: NDArray[np.float64], hi: NDArray[np.float64], middle: NDArray[np.float64]) -> NDArray[np.float64]:
        return spring_width(lo, hi, middle, widening)

    def ladder(modes: NDArray[np.intp], levels: tuple[float, ...]) -> int:
        return certify_at_levels(counts, values, bound, modes, levels, widening)

    # a root taken at a pole: mostly a mode localised far from the cut (or a double eigenvalue),
    # the pole itself but for the pole's own error (dqds of the cut chain's float64 B~: ~sqrt(n)
    # eps from forming it), so its brackets start at SNAPPED_LEVELS; those they do not prove
    # are refined in double-double (`_polish`) and go through every level
    spent += ladder(np.flatnonzero(side == 0) + first, LEVELS)
    snapped = np.flatnonzero(side != 0) + first
    spent += ladder(snapped, SNAPPED_LEVELS)
    left = snapped[~np.isfinite(bound[snapped])]
    if left.shape[0]:
        pole = np.where(side[left - first] < 0, low[left - first], high[left - first])
        values[left], used = _polish(pivots, pole, side[left - first])
        # a root 1e-8..1e-6 from its pole: the model's neglected smooth part matters there,
        # and l is smooth enough for `_secant`'s step of 1e-10
        far = left[np.abs(values[left] - pole) > 1e-8 * pole]
        values[far], more = _secant(pivots, values[far])
        spent += used + more + ladder(left, LEVELS)

    todo = np.flatnonzero(~np.isfinite(bound))
    if todo.shape[0]:
        lo = poles[todo] * (1 - 1e-9)  # (a free ring's poles[0] is 0)
        hi = np.r_[poles[1:], top][todo] * (1 + 1e-9)
        lo, hi, used = proven_multisection(counts, lo, hi, index[todo])
        spent += used
        proven = lo < hi
        middle = 0.5 * (lo + hi)
        values[todo[proven]] = middle[proven]
        bound[todo[proven]] = widened(lo[proven], hi[proven], middle[proven])
    tightened = 0
    if tighten is not None:
        before = bound.copy()
        tighten(values, bound)
        tightened = int(np.count_nonzero(bound[:needed] < before[:needed]))
    spent += _mp_counts(pencil, values[:needed], bound[:needed], aim)
    certified = np.isfinite(bound)
    order = np.argsort(values, kind="stable")
    values = values[order]
    bound = sorted_bounds(values, bound[order], order)
    return RingValues(values, bound, certified[order] & np.isfinite(bound), int(evaluations.sum()), spent, tightened)


def ring_result(coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64], n_modes: int | None,
                *, tighten: Tighten | None = None, lowest: bool = False, aim: float = MP_WANTED
                ) -> SolveResult | None:
    """``accurate-ring``: a ring's frequencies by `ring_values` (the lowest n_modes of them
    when given) as a result without vectors, or None (not one ring: the caller goes on).
    `lowest` (n_modes well below n): two more values are found, so that the last mode's pair, if
    it has one, has a gap above it for `tighten` (`pair_step`), and then dropped. `aim`: the
    relative bound the mpmath counts tighten to (accuracy="high": 1e-10, rarely any count)."""
    pencil = ring_pencil(coupling, weights, mass)
    if pencil is None:
        return None
    count = int(n_modes) + 2 if lowest and n_modes is not None else n_modes
    found = ring_values(pencil, count, tighten=tighten, needed=n_modes, aim=aim)
    k = found.values.shape[0] if count == n_modes or n_modes is None else int(n_modes)
    values, bound, certified = found.values[:k], found.bound[:k], found.certified[:k]
    if not certified.all():  # (not seen: the multisection proves every root) keep the widest honest bound
        bound = np.where(certified, bound, np.maximum(np.abs(values), pencil.R))
    result = SolveResult(values, None, bound, float("nan"), float("nan"), "accurate-ring")
    finite = values > 0
    worst = float(np.max(bound[finite] / values[finite])) if finite.any() else 0.0
    result.refined = np.ones(k, dtype=bool)
    which = (f"the lowest {k} modes" if count != n_modes else f"all {k} modes") + " from roots of the ring's spring form"
    cut = "its weakest spring" + (", its lowest eigenvalues by bisection" if count != n_modes else "")
    result.refinement = (f"{which} (interlacing with the chain cut at {cut}), {int(certified.sum())} of {k} bounds "
                         f"certified by Sturm counts of the spring form in double-double, error/omega^2 up to "
                         f"{worst:.1g}")
    if found.tightened:
        result.refinement += (f"; {found.tightened} bounds (double eigenvalues) tightened by spring-space Rayleigh-Ritz "
                              "on their Golub-Kahan singular vectors")
    return result


def _mp_counts(pencil: RingPencil, values: NDArray[np.float64], bound: NDArray[np.float64],
               wanted: float = MP_WANTED) -> int:
    """Tighten, in place, the bounds still above `wanted` relative (the lowest modes of a long
    uniform ring: double eigenvalues, where double-double's counts stay uncertain within a few
    1e-13) by `ring.counts.count_below_mp` counts of K - x M with 40 digits more than R / value needs,
    loosest first, at most MP_COUNTS counts (and MP_WORK sites). Returns the counts spent."""
    loose = np.flatnonzero((bound > wanted * values) & (values > 0))
    loose = loose[np.argsort(-(bound[loose] / values[loose]), kind="stable")]
    used = 0
    most = min(MP_COUNTS, int(MP_WORK // pencil.n))
    for j in loose.tolist():
        if used + 2 > most:
            break
        v = float(values[j])
        digits = 40 + int(np.ceil(np.log10(max(pencil.R / v, 1.0))))
        for level in MP_LEVELS:
            t = level * v
            width = (t + max(mp_rho(pencil, v - t, digits), mp_rho(pencil, v + t, digits))) * (1 + 1e-12)
            if width >= bound[j] or used + 2 > most:
                break
            under, low_sure = count_below_mp(pencil, v - t, digits)
            over, high_sure = count_below_mp(pencil, v + t, digits)
            used += 2
            if low_sure and high_sure and under <= j < over:
                bound[j] = width
                break
    return used


Pivots = Callable[[NDArray[np.float64]], NDArray[np.float64]]


def _secant(pivots: Pivots, roots: NDArray[np.float64]) -> tuple[NDArray[np.float64], int]:
    """One secant step on double-double values of l at each float64 root x and at x (1 + 1e-10):
    the float64 roots carry l's float64 noise (~n eps relatively, 1e-14 at 1,600 sites); l is
    smooth there (no pole within `NEAR`), so the step leaves ~1e-4 of that error.
    Returns (roots, pivots evaluated)."""
    k = roots.shape[0]
    if k == 0:
        return roots.copy(), 0
    other = roots * (1 + 1e-10)
    both = pivots(np.r_[roots, other])
    la, lb = both[:k], both[k:]
    with np.errstate(all="ignore"):
        new = roots - la * (other - roots) / (lb - la)
    fine = np.isfinite(new) & (np.abs(new - roots) <= 1e-8 * roots)
    return np.where(fine, new, roots), 2 * k


def _polish(pivots: Pivots, pole: NDArray[np.float64], side: NDArray[np.intp]
            ) -> tuple[NDArray[np.float64], int]:
    """Roots taken at a pole (`count_kernels.NEAR`; side -1: just above it, +1: just below),
    each refined on double-double values of l, whose noise (~1e-31 over the distance to the
    pole) float64's (~1e-16 over it) would swamp.

    l at y = 2 NEAR, 1e-7, 1e-9, 1e-11, 1e-13 times p from the pole p, on the root's side: l is
    increasing between poles, so where two samples differ in sign they bracket the root (near
    the pole l ~ s + g y - c / y, c the pole's residue: tiny for a mode localised away from the
    cut, s ~ 0 for a pair split by the pole). The bracket is narrowed on q = y l(y), which has
    l's sign there and no pole: first the root of that model through three samples
    (`_model_root`), then the secant through the last two points while it stays inside the
    bracket, regula falsi (Illinois) where it does not. No sign change: the root lies within
    1e-13 p of the pole, or the pole is none (a double eigenvalue, a uniform ring's: l is
    linear through its zero there, on either side of the computed pole, whose float64 error
    it is): the secant of the two nearest samples where their slopes agree with the next,
    else the pole itself. Returns (roots, pivots evaluated)."""
    k = pole.shape[0]
    if k == 0:
        return pole.copy(), 0
    direction = -side.astype(float)  # the root's side of the pole
    steps = np.array([2 * NEAR, 1e-7, 1e-9, 1e-11, 1e-13])
    y = pole[:, None] * direction[:, None] * steps
    values = pivots((pole[:, None] + y).ravel()).reshape(y.shape)
    used = y.size
    # l increases with x, so along |y| it rises for direction +1 and falls for -1
    rising = values * direction[:, None]
    change = (rising[:, :-1] > 0) & (rising[:, 1:] < 0)  # a root between samples i and i + 1
    bracketed = change.any(axis=1)
    rows = np.arange(k)
    first = change.argmax(axis=1)
    # regula falsi on q = y l(y), of l's sign along the bracket (y keeps its sign) and with no
    # pole: ~ s y + g y^2 - c, smooth through a localised mode's root (~c / s) and a split pair's
    ya, la = y[rows, first + 1].copy(), (y * values)[rows, first + 1].copy()  # the end nearer the pole
    yb, lb = y[rows, first].copy(), (y * values)[rows, first].copy()
    kept_a, kept_b = np.zeros(k, dtype=int), np.zeros(k, dtype=int)  # Illinois: how often each end was kept

    def interpolate() -> NDArray[np.float64]:
        with np.errstate(all="ignore"):
            new = ya + la / (la - lb) * (yb - ya)  # the zero of q, taken linear between the ends
        low, high = np.minimum(ya * direction, yb * direction), np.maximum(ya * direction, yb * direction)
        inside = np.isfinite(new) & (new * direction > low) & (new * direction < high)
        return np.where(inside, new, 0.5 * (ya + yb))

    # the first step: the model's root (`_model_root`); then the secant through the last two
    # points where it stays inside the bracket, regula falsi (Illinois) where it does not
    guess = _model_root(y, values, first, rows, direction)
    y1, q1, y2, q2 = yb.copy(), lb.copy(), ya.copy(), la.copy()
    active = bracketed.copy()
    previous = np.full(k, np.nan)
    for _ in range(POLISH):
        with np.errstate(all="ignore"):
            secant = y2 - q2 * (y2 - y1) / (q2 - q1)
        guess = np.where(np.isfinite(guess), guess, secant)
        low, high = np.minimum(ya * direction, yb * direction), np.maximum(ya * direction, yb * direction)
        inside = np.isfinite(guess) & (guess * direction > low) & (guess * direction < high)
        estimate = np.where(inside, guess, interpolate())
        guess = np.full(k, np.nan)
        # done: a bracket within 4 eps, or an estimate that moved by under 2 eps since the last
        active &= (np.abs(yb - ya) > 4 * np.finfo(float).eps * pole) & ~(
            np.abs(estimate - previous) <= 2 * np.finfo(float).eps * pole)
        previous = estimate
        todo = np.flatnonzero(active)
        if todo.shape[0] == 0:
            break
        root = estimate[todo]
        fresh = root * pivots(pole[todo] + root)
        used += todo.shape[0]
        y1[todo], q1[todo], y2[todo], q2[todo] = y2[todo], q2[todo], root, fresh
        same = np.sign(fresh) == np.sign(la[todo])  # replaces the end of its sign
        ya[todo], la[todo] = np.where(same, root, ya[todo]), np.where(same, fresh, la[todo])
        yb[todo], lb[todo] = np.where(same, yb[todo], root), np.where(same, lb[todo], fresh)
        kept_a[todo], kept_b[todo] = np.where(same, 0, kept_a[todo] + 1), np.where(same, kept_b[todo] + 1, 0)
        la[todo] = np.where(kept_a[todo] > 1, 0.5 * la[todo], la[todo])  # an end kept again: its value halved
        lb[todo] = np.where(kept_b[todo] > 1, 0.5 * lb[todo], lb[todo])
    # no bracket: a double eigenvalue (linear through its zero) or a root within 1e-13 p
    with np.errstate(all="ignore"):
        slope_far = (values[:, 2] - values[:, 3]) / (y[:, 2] - y[:, 3])
        slope_near = (values[:, 3] - values[:, 4]) / (y[:, 3] - y[:, 4])
        linear = np.isfinite(slope_far) & (np.abs(slope_near - slope_far) <= 1e-2 * np.abs(slope_far))
        secant = y[:, 4] - values[:, 4] / slope_near
    linear &= ~bracketed & np.isfinite(secant) & (np.abs(secant) <= 1e-9 * pole)
    root = np.where(bracketed, interpolate(), np.where(linear, secant, 0.0))
    return pole + root, used


def _model_root(y: NDArray[np.float64], values: NDArray[np.float64], first: NDArray[np.intp],
                rows: NDArray[np.intp], direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """A first guess for `_polish`'s regula falsi: l ~ s + g y - c / y through the bracket's two
    samples and the next one (a pole's residue c, the smooth part s + g y; exact for a split pair
    of a nearly uniform ring, where regula falsi alone creeps from the far end), its root
    g y^2 + s y - c = 0 on the root's side nearest the pole (nan where none)."""
    third = np.where(first + 2 < y.shape[1], first + 2, first - 1)
    Y = np.stack([y[rows, first], y[rows, first + 1], y[rows, third]], axis=1)
    L = np.stack([values[rows, first], values[rows, first + 1], values[rows, third]], axis=1)
    scale = np.abs(Y).max(axis=1, keepdims=True)
    small = np.abs(Y).min(axis=1, keepdims=True)
    system = np.stack([np.ones_like(Y), Y / scale, -small / Y], axis=2)
    with np.errstate(all="ignore"):
        fine = np.isfinite(system).all(axis=(1, 2)) & np.isfinite(L).all(axis=1) & (
            np.abs(np.linalg.det(np.where(np.isfinite(system), system, 0.0))) > 1e-300)
        guess = np.full(y.shape[0], np.nan)
        if fine.any():
            solved = np.linalg.solve(system[fine], L[fine][:, :, None])[:, :, 0]
            s, g, c = solved[:, 0], solved[:, 1] / scale[fine, 0], solved[:, 2] * small[fine, 0]
            disc = np.sqrt(np.maximum(s * s + 4 * g * c, 0.0))
            q = -0.5 * (s + np.copysign(disc, s))
            candidates = np.stack([q / g, -c / q], axis=1)
            on_side = np.isfinite(candidates) & (candidates * direction[fine, None] > 0)
            nearest = np.where(on_side, np.abs(candidates), np.inf).argmin(axis=1)
            chosen = candidates[np.arange(candidates.shape[0]), nearest]
            guess[fine] = np.where(on_side.any(axis=1), chosen, np.nan)
    return guess


def pair_step(weighted: Matrix, deviation: Deviation, mass: NDArray[np.float64], aim: float = MP_WANTED) -> Tighten:
    """`ring_values`' `tighten` step: each cluster of values whose count bound stays over
    `aim` relative (`MP_WANTED`, "certified"; accuracy="high" passes 1e-10, which the
    counts' own bounds, ~sqrt(n) 1e-15, meet: the step then costs nothing)
    (a double eigenvalue: counts uncertain within ~sqrt(n) 1e-15 of it;
    a ring's eigenvalues are at most double) gets spring-space Rayleigh-Ritz on its singular
    vectors of B~ (Golub-Kahan inverse iteration, refined to extended precision:
    `golub_kahan.Refiner`), with quadratic residual bounds
    (`cluster_bounds`, extended precision, B~'s exact entries) whose gaps are the neighbours'
    certified bounds; each value keeps the tighter bound. A cluster at the end of a partial set
    (no value above it) is left as it is."""
    B = sp.csr_matrix(weighted)
    terms = most_terms(B)
    refiners: list[Refiner] = []  # formed on the first cluster that needs one, then reused

    def tighten(values: NDArray[np.float64], bound: NDArray[np.float64]) -> None:
        k = values.shape[0]
        base = 1 if k and values[0] == 0.0 and bound[0] == 0.0 else 0  # a free ring's rigid rotation: exact
        loose = np.flatnonzero((bound > aim * values) & (values > 0) & np.isfinite(bound))
        runs: list[list[int]] = []  # clusters holding a loose value, adjacent ones joined (one Ritz step each)
        for j in loose.tolist():
            if runs and j < runs[-1][1]:
                continue
            a, b = j, j + 1
            while a > base and values[a] - bound[a] <= values[a - 1] + bound[a - 1] + MP_WANTED * values[a]:
                a -= 1
            while b < k and values[b] - bound[b] <= values[b - 1] + bound[b - 1] + MP_WANTED * values[b]:
                b += 1
            if b == k and k < B.shape[1]:  # the top of a partial set: no gap above it known
                break
            if runs and a <= runs[-1][1]:
                runs[-1][1] = b
            else:
                runs.append([a, b])
        for a, b in runs:
            complete = b == k
            if not np.all(np.isfinite(bound[max(a - 1, 0): b + 1])):
                continue
            if not refiners:
                refiners.append(Refiner(B, deviation))
            basis = refiners[0].refine(singular_vectors(B, values[a:b], mass), values[a:b])
            ceiling = None if complete else float(values[b] - bound[b])
            theta, _, error = cluster_bounds(B, values[a:b], basis, bound[a:b], terms, complete=complete,
                                             precise=True, floor=float(values[a - 1] + bound[a - 1]) if a else -np.inf,
                                             ceiling=ceiling, deviation=deviation)
            better = error < bound[a:b]
            values[a:b][better], bound[a:b][better] = theta[better], error[better]

    return tighten


def ring_vectors(weighted: Matrix, mass: NDArray[np.float64], ring: SolveResult) -> SolveResult:
    """`ring` (the lowest modes, certified) with each mode's singular vector of B~ (Golub-Kahan
    inverse iteration), their residuals and orthogonality; the bounds stay the counts'."""
    B = sp.csr_matrix(weighted)
    result = spring_figures(B, ring.eigenvalues, singular_vectors(B, ring.eigenvalues, mass), True, "accurate-ring")
    result.error, result.refined = ring.error, ring.refined
    result.refinement = f"{ring.refinement}; vectors by Golub-Kahan inverse iteration"
    return result
