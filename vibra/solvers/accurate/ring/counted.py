"""A ring's values from a standard solver, each certified by two Sturm counts: accuracy="high"'s
route where a standard solver's values already meet its promise (~1e-10 relative).

The few lowest modes of a long ring come from shift-invert (`ring_counted`), all of a ring's
values from the band solver (`ring_band_counted`, LAPACK sbevd on the ring reordered to
half-bandwidth 2: O(n^2), what accuracy="fast" runs). Each value v of eigenvalue j is then
bracketed, [v (1 - t), v (1 + t)] for the tightest t of `HIGH_LEVELS` that two counts prove:
count below the lower end <= j < count below the upper end. Values whose brackets overlap (a
double eigenvalue, a uniform ring's) share one bracket, two counts for the cluster. The counts
are K - x M's in double-double (`ring.pencil_counts`: exact within ~1e-30 (R + x), R ~ ||K~||),
or the spring form's (`count_kernels.spring_counts`, relatively accurate at any x, twice the
cost per site) for a value that perturbation would blur (below ~1e-19 R). Each bound is the
bracket widened by the counts' own perturbation: a certificate for the masses and springs as
given, whatever the standard solver's accuracy; a value no level proves is not guessed.

What no level proves (the band solver's smallest values of a long or spread ring, its error
~eps R absolute) takes the ring's own values path: the lowest k of them by bisection on the
cut chain (`ring.values.ring_values`, O(n k)) while k stays within `LOWEST_SHARE` of the ring;
else the caller runs that path for every value.

Cost: the band solve, then ~n to 2n counts of O(n) (~2.3 ns per point and site on two cores):
about a quarter of the band solve's time at 2,000 sites, against ~3x for the ring's own path
(dqds of the cut chain, roots, their counts in the spring form).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.counting import multisection, sorted_bounds, spring_width
from vibra.solvers.accurate.ring.counts import RingPencil, spring_widening
from vibra.solvers.accurate.ring.pencil_counts import PencilCounts
from vibra.solvers.accurate.ring.values import SpringForm, ring_values
from vibra.solvers.accuracy import HIGH_TARGET
from vibra.solvers.common import SolveResult

__all__ = ["HIGH_LEVELS", "LOWEST_SHARE", "AIM", "NARROWING", "certify_values", "ring_counted", "ring_band_counted"]

#: The brackets tried around a standard solver's values, tightest first (1e-10 is "high"'s promise).
HIGH_LEVELS = (1e-13, 1e-12, 1e-11, HIGH_TARGET)

#: The largest share of a ring's values that the ring's own path takes over when no level proves
#: them (bisection for the lowest k costs ~5e-7 n k s, dqds of all ~1e-8 n^2 s: even near 1/16).
LOWEST_SHARE = 1.0 / 16

#: "high"'s promise, relative to omega^2: a bound over a quarter of it is narrowed (`NARROWING` passes of
#: multisection, `counting.SECTIONS` - 1 counts each: 16^2 = 256 times narrower).
AIM = HIGH_TARGET
NARROWING = 2

_EPS = float(np.finfo(float).eps)


def certify_values(pencil: RingPencil, values: NDArray[np.float64], bound: NDArray[np.float64], expected: float,
                   levels: tuple[float, ...] = HIGH_LEVELS, aim: float = AIM) -> None:
    """Bound (in place, where still infinite) each positive value j of `values` (ascending,
    approximations of eigenvalues 0, 1, ...) by the tightest of `levels` that two counts prove,
    widened by the counts' perturbation. `expected`: the values' likely absolute error (the first
    level tried for v is the tightest >= expected / v). A bound still over a quarter of `aim`
    relative (the loosest level's, or a cluster's bracket spanning its values' spread) is narrowed by `NARROWING` passes of
    multisection, the value moved to its middle; values and bounds are left in ascending order."""
    form = PencilCounts(pencil)
    spring = SpringForm(pencil)
    widening = spring_widening(pencil)
    positive = values > 0
    with np.errstate(divide="ignore"):
        likely = np.where(positive, expected / np.where(positive, values, 1.0), np.inf)
    start = np.searchsorted(np.asarray(levels), likely)  # the first level at or above the likely error
    start = np.minimum(start, len(levels) - 1)
    bracket = np.full((2, values.shape[0]), np.nan)  # each proven value's bracket
    by_pencil = np.zeros(values.shape[0], dtype=bool)
    for at, t in enumerate(levels):
        todo = np.flatnonzero(~np.isfinite(bound) & positive & (start <= at))
        if todo.shape[0] == 0:
            continue
        v = values[todo]
        lo, hi = v * (1 - t), v * (1 + t)
        # consecutive values whose brackets overlap share one: count below its lower end <= the
        # first's index, below its upper end > the last's
        joined = (todo[1:] == todo[:-1] + 1) & (lo[1:] <= hi[:-1])
        first = np.r_[0, np.flatnonzero(~joined) + 1]
        last = np.r_[first[1:], todo.shape[0]] - 1
        low, high = lo[first], np.maximum.reduceat(hi, first)
        # K - x M's counts where their perturbation stays within an eighth of the bracket
        sharp = form.width(high) <= 0.125 * t * v[first]
        good = np.zeros(first.shape[0], dtype=bool)
        for use_pencil, counts in ((True, form.counts), (False, spring.counts)):
            group = np.flatnonzero(sharp == use_pencil)
            if group.shape[0] == 0:
                continue
            count, certain = counts(np.r_[low[group], high[group]])
            g = group.shape[0]
            good[group] = (certain[:g] & certain[g:] & (count[:g] <= todo[first[group]])
                           & (todo[last[group]] < count[g:]))
        cluster = np.repeat(np.arange(first.shape[0]), last - first + 1)
        proven = good[cluster]
        members, c = todo[proven], cluster[proven]
        bracket[0, members], bracket[1, members], by_pencil[members] = low[c], high[c], sharp[c]
        bound[members] = _width(form, widening, low[c], high[c], values[members], sharp[c])
        start[todo[~proven]] = at + 1
    loose = np.flatnonzero(np.isfinite(bound) & (bound > 0.25 * aim * values))
    for use_pencil, counts in ((True, form.counts), (False, spring.counts)):
        group = loose[by_pencil[loose] == use_pencil]
        if group.shape[0] == 0:
            continue
        lo, hi, _ = multisection(counts, bracket[0, group], bracket[1, group], group, NARROWING)
        middle = 0.5 * (lo + hi)
        width = _width(form, widening, lo, hi, middle, np.full(group.shape[0], use_pencil))
        better = width < bound[group]
        values[group[better]], bound[group[better]] = middle[better], width[better]
    _in_order(values, bound)  # (a narrowed pair's two middles may cross)


def _in_order(values: NDArray[np.float64], bound: NDArray[np.float64]) -> None:
    """Values sorted in place, each bound then for the eigenvalue of its new index
    (`counting.sorted_bounds`)."""
    order = np.argsort(values, kind="stable")
    values[:], bound[:] = values[order], sorted_bounds(values[order], bound[order], order)


def _width(form: PencilCounts, widening: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64],
           middle: NDArray[np.float64], by_pencil: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Half-width about `middle` of what a proven bracket [lo, hi] bounds: widened by K - x M's
    perturbation (`by_pencil`) or the spring form's."""
    return np.where(by_pencil, (np.maximum(middle - lo, hi - middle) + form.width(hi)) * (1 + 1e-12),
                    spring_width(lo, hi, middle, widening))


def _free_rotation(pencil: RingPencil, values: NDArray[np.float64], bound: NDArray[np.float64]) -> int:
    """A free ring's eigenvalue 0, its rigid rotation: exactly 0 (B 1 = 0). Returns 1 (or 0 with walls)."""
    if pencil.walls or values.shape[0] == 0:
        return 0
    values[0], bound[0] = 0.0, 0.0
    return 1


def ring_counted(pencil: RingPencil, result: SolveResult, levels: tuple[float, ...] = HIGH_LEVELS) -> SolveResult | None:
    """The lowest modes of a ring from shift-invert (`result`: the lowest k, ascending), each
    value certified by `certify_values` at the tightest of `levels` (the counts prove the index
    too: a mode the solver missed fails them); None where some value is not certified (the
    ring's own values path takes over). ~2 k counts of O(n)."""
    k = result.eigenvalues.shape[0]
    values = result.eigenvalues.copy()
    bound = np.full(k, np.inf)
    first = _free_rotation(pencil, values, bound)
    if np.any(values[first:] <= 0):
        return None
    certify_values(pencil, values, bound, 0.0, levels)
    if not np.all(np.isfinite(bound)):
        return None
    return _counted(result, values, bound, first, f"the lowest {k} values from {result.solver}'s shift-invert")


def ring_band_counted(pencil: RingPencil, result: SolveResult) -> SolveResult | None:
    """Every value of a ring (or the lowest n_modes) from the band solver (`result`, ascending),
    each certified by `certify_values` from the level its absolute error (~eps R) suggests;
    the lowest that no level proves from the ring's own values path (`ring_values`, their
    count within `LOWEST_SHARE` of the ring). None where more are left (the caller runs that
    path for all)."""
    k = result.eigenvalues.shape[0]
    values = result.eigenvalues.copy()
    bound = np.full(k, np.inf)
    first = _free_rotation(pencil, values, bound)
    certify_values(pencil, values, bound, _EPS * pencil.R)
    left = np.flatnonzero(~np.isfinite(bound))
    lowest = int(left.max()) + 1 if left.shape[0] else 0
    if lowest > LOWEST_SHARE * pencil.n:
        return None
    note = ""
    if lowest:
        own = ring_values(pencil, lowest, aim=AIM)
        if not own.certified.all():
            return None
        values[:lowest], bound[:lowest] = own.values, own.bound
        _in_order(values, bound)
        note = f"; the lowest {lowest} from the ring's own values path (bisection on the cut chain, roots, counts)"
    which = f"{'all ' if k == pencil.n else 'the lowest '}{k} values from the band solver (LAPACK)"
    return _counted(result, values, bound, first, which, note)


def _counted(result: SolveResult, values: NDArray[np.float64], bound: NDArray[np.float64], first: int, which: str,
             note: str = "") -> SolveResult:
    """The certified values as ``accurate-ring``'s result (`result`'s vectors and figures kept)."""
    k = values.shape[0]
    counted = SolveResult(values, result.vectors, bound, result.residual, result.orthogonality, "accurate-ring")
    counted.refined = np.zeros(k, dtype=bool)
    worst = float(np.max(bound[first:] / values[first:])) if k > first else 0.0
    counted.refinement = (f"{which}, each certified by two Sturm counts in double-double (a cluster's values by "
                          f"the same two), error/omega^2 up to {worst:.1g}{note}")
    return counted
