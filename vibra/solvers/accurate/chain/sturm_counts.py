"""Sturm counts of a chain's spring form: certificates for the values its triplets cannot bound.

`bidiagonal.certified_values` bounds each chain value from its singular triplet (Kato-Temple),
which needs a gap: a value in a cluster narrower than its a-priori bound, (8 + n/4) eps plus
B~'s forming, keeps that bound (2.3e-11 at 10,000 sites), far above its true error (~1e-15).
Two identical disordered chains joined by a weak spring are such a case: every mode comes in a
pair split by ~the weak spring.

Here the chain's spring form [[W^-1, B], [B^T, x M]], built from the springs, couplings and
masses as given, is a path of sites and springs (several paths for several chains, joined by
zero couplings): its pivots, in double-double (`count_kernels.chain_counts`, compiled), have no
fill and are exact for couplings, masses and springs perturbed by a few units of
double-double, so a count is exact for an omega within phi = 2 (N + 1) u relatively (N nodes,
u = 4 dd.UNIT; as `ring.counts.spring_widening` for a ring, without its closing term). A value whose
bound exceeds `golub_kahan.WANTED` is bracketed at the tightest of `counting.LEVELS` whose two
counts hold its index: a cluster's values are certified together, whatever their spacing.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.accurate.count_kernels import chain_counts
from vibra.solvers.common import MatrixLike, SolveResult
from vibra.solvers.accurate.counting import LEVELS, spring_width, stored_factor
from vibra.solvers.accurate.dd import UNIT as _UNIT_DD, div as _div, mul as _mul
from vibra.solvers.accurate.golub_kahan import WANTED

__all__ = ["ChainForm", "chain_form", "certify_chain_values", "chain_counted"]


class ChainForm:
    """The spring form of chains as one chain of nodes: `site` (per node), `m` (its mass; 0 for
    a spring), `compliance` (1 / w for a spring, double-double), `squares` (c^2 of the coupling
    of nodes k and k + 1, double-double; 0 between chains), `widening` (phi, 0)."""

    def __init__(self, site: NDArray[np.bool_], m: NDArray[np.float64], weights: NDArray[np.float64],
                 couplings: NDArray[np.float64]) -> None:
        k = site.shape[0]
        w = np.where(site, 1.0, weights)
        self.site, self.m = site, m
        spring = ~site  # (a site's entry is 1 / 1, exact)
        high, low = np.ones(k), np.zeros(k)
        high[spring], low[spring] = _div(np.ones(int(spring.sum())), 0.0, w[spring], 0.0)
        self.compliance = (high, low)
        self.squares = _mul(couplings, np.zeros_like(couplings), couplings, np.zeros_like(couplings))
        self.widening = np.array([2.0 * (k + 1) * 4 * _UNIT_DD, 0.0])

    def counts(self, x: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        return chain_counts(x, self.site, self.m, self.compliance, self.squares)


def chain_form(coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> ChainForm | None:
    """The spring form of a system whose springs join dofs c and c + 1 only, with at most one
    spring to a wall at each end of each chain (`bidiagonal.chain_bidiagonals`' structure), from
    the inputs themselves; None for any other system."""
    if np.ndim(mass) != 1:
        return None
    B, per_row = stored_factor(coupling)
    if per_row.min(initial=1) < 1 or per_row.max(initial=0) > 2:
        return None
    weights = np.asarray(weights, dtype=float)
    if per_row.min(initial=2) == 2:  # no spring to a wall: the whole form at once
        return _free_form(B, weights, np.asarray(mass, dtype=float))
    return _walked_form(B, per_row, weights, mass)


def _walked_form(B: Any, per_row: NDArray[np.intp], weights: NDArray[np.float64], mass: NDArray[np.float64]
                 ) -> ChainForm | None:
    """`chain_form` node by node: the general case, springs to a wall at chains' ends included."""
    n = B.shape[1]
    pair: dict[int, int] = {}
    anchors: dict[int, list[int]] = {}
    for row in range(B.shape[0]):
        start = B.indptr[row]
        if per_row[row] == 2:
            c, d = int(B.indices[start]), int(B.indices[start + 1])
            if d != c + 1 or c in pair:
                return None
            pair[c] = row
        else:
            anchors.setdefault(int(B.indices[start]), []).append(row)

    def entry(row: int, column: int) -> float:
        start, stop = B.indptr[row], B.indptr[row + 1]
        return float(B.data[start:stop][B.indices[start:stop] == column][0])

    site: list[bool] = []
    m: list[float] = []
    w: list[float] = []
    off: list[float] = []  # off[k]: coupling of node k and k + 1

    def node(is_site: bool, value: float, coupling_before: float) -> None:
        if site:
            off.append(coupling_before)
        site.append(is_site)
        m.append(value if is_site else 0.0)
        w.append(0.0 if is_site else value)

    previous_pair = None
    for c in range(n):
        walls = anchors.get(c, [])
        inner = (c - 1) in pair
        if len(walls) + inner + (c in pair) > 2:
            return None
        if not inner and walls:  # a chain's start: its wall spring before the site
            row = walls.pop(0)
            node(False, weights[row], 0.0)
            node(True, float(mass[c]), entry(row, c))
        else:
            node(True, float(mass[c]), entry(previous_pair, c) if inner and previous_pair is not None else 0.0)
        if c in pair:
            previous_pair = pair[c]
            node(False, weights[previous_pair], entry(previous_pair, c))
        else:
            previous_pair = None
            for row in walls:  # a chain's end: its wall spring after the site
                node(False, weights[row], entry(row, c))
    return ChainForm(np.array(site), np.array(m), np.array(w), np.array(off))


def _free_form(B: Any, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> ChainForm | None:
    """`chain_form` where every spring joins two sites c and c + 1 (free chains), in array
    operations: site c's node, then its spring's to c + 1 where it has one."""
    n = B.shape[1]
    first = B.indices[B.indptr[:-1]]
    second = B.indices[B.indptr[:-1] + 1]
    if np.any(second != first + 1) or np.bincount(first, minlength=n).max(initial=0) > 1:
        return None
    has = np.zeros(n, dtype=bool)
    has[first] = True
    before = np.cumsum(has) - has  # springs placed before site c
    at = np.arange(n) + before  # site c's node
    size = n + first.shape[0]
    site = np.zeros(size, dtype=bool)
    site[at] = True
    m = np.zeros(size)
    m[at] = mass
    w = np.zeros(size)
    spring = at[first] + 1
    w[spring] = weights
    off = np.zeros(size)
    off[at[first]] = B.data[B.indptr[:-1]]  # site c to its spring
    off[spring] = B.data[B.indptr[:-1] + 1]  # the spring to site c + 1
    return ChainForm(site, m, w, off[:-1])


def certify_chain_values(form: ChainForm, values: NDArray[np.float64], error: NDArray[np.float64] | None,
                         levels: tuple[float, ...] = LEVELS, floor: float = 0.0) -> tuple[NDArray[np.float64], int]:
    """Tighter `error` for the values (ascending omega^2, the lowest of the system, index =
    position) whose bound exceeds WANTED relative: the tightest of `levels` whose bracket two
    counts prove holds the value's index, widened by the counts' perturbation. Returns (error,
    how many). `error` None: no bound yet (every value above `floor` is tried; one no bracket
    certifies is left at inf)."""
    if error is None:
        error = np.full(values.shape, np.inf)
        loose = np.flatnonzero(values > floor)
    else:
        error = np.asarray(error, dtype=float).copy()
        loose = np.flatnonzero((error > WANTED * values) & (values > error))
    certified = 0
    for level in levels:
        if loose.shape[0] == 0:
            break
        v = values[loose]
        lo, hi = v * (1 - level), v * (1 + level)
        count, certain = form.counts(np.r_[lo, hi])
        k = loose.shape[0]
        good = certain[:k] & certain[k:] & (count[:k] <= loose) & (loose < count[k:])
        width = spring_width(lo[good], hi[good], v[good], form.widening)
        tighter = width < error[loose[good]]
        error[loose[good][tighter]] = width[tighter]
        certified += int(np.count_nonzero(tighter))
        loose = loose[~good]
    return error, certified


def chain_counted(result: SolveResult, coupling: MatrixLike, weights: NDArray[np.float64], mass: NDArray[np.float64],
                  band: tuple[float, float] | None) -> SolveResult:
    """A chain's result (``accurate-bidiagonal``, the lowest modes) with the bounds its triplets
    left above WANTED (values in a cluster) certified by `certify_chain_values`; as it is with a
    band, or where no bound needs it, or for no chain form."""
    values, error = result.eigenvalues, result.error
    if band is not None or not np.any((error > WANTED * values) & (values > error)):
        return result
    form = chain_form(coupling, weights, mass)
    if form is None:
        return result
    result.error, count = certify_chain_values(form, values, error)
    if count:
        finite = result.eigenvalues > result.error
        worst = float(np.max(result.error[finite] / result.eigenvalues[finite])) if finite.any() else 0.0
        note = (f"{count} bounds certified by Sturm counts of the chain's spring form (values in clusters), "
                f"error/omega^2 now up to {worst:.1g}")
        result.refinement = f"{result.refinement}; {note}" if result.refinement else note
    return result
