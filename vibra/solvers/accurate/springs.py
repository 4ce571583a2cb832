"""The pieces of the accurate paths for a system that knows its springs, K = B^T W B.

The frequencies are the singular values of B~ = W^1/2 B M^-1/2, computed to high relative
accuracy where the structure allows. Which path runs is the registry's choice
(`vibra.solvers.registry`); the runners (`vibra.solvers.runners`) assemble these pieces:

- `checked_dense` (``accurate-checked`` / ``accurate-jacobi`` / ``accurate-rayleigh``): the
  fast dense solve first (with vectors, also for values only), which the a-priori bound
  n eps ||K~|| certifies to `TARGET` relative for every omega^2 above ~n eps ||K~|| / TARGET;
  every mode then gets a bound from its own residual; the modes below that (and their
  clusters) get spring-space Rayleigh-Ritz per cluster and a gap-based (Kato-Temple) bound
  each; only when some requested mode's bound still misses `TARGET` does one-sided Jacobi SVD
  (LAPACK gejsv) of B~ run (``accurate-jacobi``, where the registry allows it:
  `common.JACOBI_WORK`; ``accurate-rayleigh`` runs without it);
- `checked_ritz` and `spring_ritz_band` (``accurate-ritz``): Rayleigh-Ritz in spring space
  (H = (B~V)^T (B~V), O(N k)) on shift-invert vectors, or on the sparse path's in a band;
- `spring_rayleigh`: spring-space Rayleigh quotients of another solver's vectors (a long
  ring's band vectors, ``accurate-ring-band``);
- `ring_certified`: a ring's bounds replaced by Sturm-count certificates (`ring.counts`);
- `tightened`: bounds tightened as far as the accuracy level asks (singular triplets,
  `golub_kahan`; double-double inverse iteration, `spring_ritz.refine_modes`).

Every path fills `SolveResult.refined` (which modes' values come from the accurate machinery)
and `refinement` (how many, and why).
"""

from __future__ import annotations

import functools
from typing import Any, Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.accurate.chain.sturm_counts import ChainForm, certify_chain_values
from vibra.solvers.accurate.products import rayleigh_quotients, times, transposed_times
from vibra.solvers.accurate.ring.counts import RingPencil, certify, count_below
from vibra.solvers.accurate.counting import LEVELS
from vibra.solvers.accurate.golub_kahan import HIGH_ROWS, HIGH_WORK, WANTED, loose_modes, refine_triplets
from vibra.solvers.accurate.spring_ritz import (
    FORMING, TARGET, Deviation, cluster_bounds, most_terms, refine_modes, residual_bounds,
    spring_figures, zero_level,
)
from vibra.solvers.common import (
    EPS, JACOBI_WORK, Matrix, SolveResult, mass_power, selected, small_pencil, squared_range,
)
from vibra.solvers.standard.lapack import DENSE_FLOOR



def tightened(result: SolveResult, weighted: Matrix, deviation: Deviation,
               factor: tuple[sp.csr_matrix, NDArray[np.float64]], mass: NDArray[np.float64], *,
               accuracy: str) -> SolveResult:
    """`result` with its loose bounds tightened as far as `accuracy` asks, no further.

    "certified": every bound over `golub_kahan.WANTED` (2e-13) relative, by singular triplets
    (`refine_triplets`, every loose mode: its cost was estimated and guarded up front) and, on small systems, double-double inverse
    iteration (`refine_modes`). "high": only the bounds over `TARGET` (1e-10) relative, and the
    triplet step only where its factorisations are cheap (H of at most `HIGH_ROWS` rows); a
    bound still over TARGET is named with what "certified" would do. No step looks at the clock.
    """
    coupling, weights = factor
    n = weighted.shape[1]
    complete = result.eigenvalues.shape[0] == n
    certified = accuracy == "certified"
    wanted = WANTED if certified else TARGET
    rows = weighted.shape[0] + n
    if certified or rows <= HIGH_ROWS:
        values, error, count = refine_triplets(weighted, deviation, result.eigenvalues, result.error,
                                               complete=complete, wanted=wanted,
                                               work=float("inf") if certified else HIGH_WORK)
        if count:
            result.eigenvalues, result.error = values, error
            loose = int(np.count_nonzero(loose_modes(values, error, wanted)))
            note = (f"{count} bounds tightened by singular triplets (Golub-Kahan inverse iteration)"
                    + (f", {loose} still above {wanted:g} omega^2" if loose else ""))
            result.refinement = f"{result.refinement}; {note}" if result.refinement else note
    values, error, count = refine_modes(coupling, weights, mass, result.eigenvalues, result.error,
                                        complete=complete, wanted=wanted)
    if count:
        result.eigenvalues, result.error = values, error
        note = f"{count} bounds tightened by inverse iteration in double-double"
        result.refinement = f"{result.refinement}; {note}" if result.refinement else note
    loose = int(np.count_nonzero(loose_modes(result.eigenvalues, result.error, TARGET)))
    if loose and not certified:
        note = (f"{loose} bounds above {TARGET:g} omega^2 (the values are usually far closer); "
                'accuracy="certified" tightens them by singular triplets')
        result.refinement = f"{result.refinement}; {note}" if result.refinement else note
    return result


def ring_certified(result: SolveResult, pencil: RingPencil, band: tuple[float, float] | None) -> SolveResult:
    """A ring's result with each bound replaced by its Sturm-count certificate (`vibra.solvers.accurate.ring.counts`)
    where that is tighter: the counts are of K - x M built from the springs and masses as
    given. A mode the counts cannot certify keeps its residual bound (also for the exact B~)."""
    values = result.eigenvalues
    offset = 0
    if band is not None:
        low, _ = squared_range(band)
        if low > 0:
            counts, certain = count_below(pencil, np.array([low]))
            offset = int(counts[0]) if certain[0] else -1
    if offset < 0:
        return result
    before = values
    values, bound, certified = certify(pencil, values, offset + np.arange(values.shape[0]), result.error)
    moved = int(np.count_nonzero(values != before))
    order = np.argsort(values, kind="stable")  # a narrowed value may pass a neighbour left as it was
    result.eigenvalues, result.error = values[order], bound[order]
    if result.vectors is not None:
        result.vectors = result.vectors[:, order]
    if result.refined is not None:
        result.refined = result.refined[order] | (values != before)[order]
    count = int(certified.sum())
    note = (f"{count} of {values.shape[0]} bounds certified by Sturm counts of the ring's pencil "
            "(double-double; for the lowest, of its spring form; mpmath where neither resolves them)"
            + (f", {moved} values narrowed by them" if moved else ""))
    result.refinement = f"{result.refinement}; {note}" if result.refinement else note
    return result


def relative_account(result: SolveResult, how: str) -> SolveResult:
    """Fill `refined` (every mode) and `refinement` ("all k modes <how>, ...") of a path whose
    every value comes from the spring factor, with no fast value kept; unless already filled."""
    if result.refined is None:
        k = result.eigenvalues.shape[0]
        result.refined = np.ones(k, dtype=bool)
        magnitude = np.abs(result.eigenvalues)
        finite = magnitude > result.error  # zero modes (bound above the value) left out
        worst = (f", error/omega^2 up to {float(np.max(result.error[finite] / magnitude[finite])):.1g}"
                 if finite.any() else "")
        result.refinement = f"all {k} modes {how}{worst}"
    return result


def weighted_factor(coupling: sp.csr_matrix, weights: NDArray[np.float64], mass: NDArray[np.float64]) -> Matrix:
    left = sp.diags(np.sqrt(weights))
    if mass.ndim == 1:
        return sp.csr_matrix(left @ coupling @ sp.diags(1.0 / np.sqrt(mass)))
    return np.asarray((left @ coupling).toarray() @ mass_power(mass, -0.5))


def spring_ritz_band(weighted: Matrix, standard: SolveResult, band: tuple[float, float], *, vectors: bool,
                 deviation: Deviation = None) -> SolveResult:
    """Rayleigh-Ritz in spring space on every vector the sparse path found in `band`, per
    cluster (`cluster_bounds`): H = (B~V)^T (B~V) keeps small eigenvalues' relative accuracy;
    each mode bounded from its residual, the gaps to the modes outside the band taken at the
    band's edges (the sparse path returns every mode inside it)."""
    B = sp.csr_matrix(weighted)
    low, high = squared_range(band)
    if standard.eigenvalues.shape[0] == 0:  # no mode in the band: nothing to refine
        standard.solver = "accurate-ritz"
        return standard
    theta, basis, error = cluster_bounds(B, standard.eigenvalues, standard.vectors,  # type: ignore[arg-type]
                                          np.maximum(standard.error, 0.0), most_terms(B), complete=False,
                                          floor=low if low > 0 else -np.inf, ceiling=high, deviation=deviation)
    order = np.argsort(theta, kind="stable")
    result = spring_figures(B, theta[order], basis[:, order], vectors, "accurate-ritz")
    result.error = error[order]
    return result


def checked_ritz(weighted: Matrix, basis: NDArray[np.float64], k: int, *, vectors: bool,
                  deviation: Deviation | Callable[[], Deviation] = None, form: ChainForm | None = None,
                  precise: bool = False) -> SolveResult:
    """Spring-space Rayleigh-Ritz on k + 1 shift-invert vectors; the lowest k kept, each with the
    quadratic residual bound of `cluster_bounds` (the (k+1)-th value, less its residual, bounds
    the gap of the k-th from above).

    `form` (a chain's spring form, `sturm_counts.chain_form`): each value is first certified by
    two Sturm counts of it (`sturm_counts.certify_chain_values`, O(n) each, no gap and no
    residual needed: the counts prove the value's index too); where every nonzero value then
    meets TARGET, the residuals are measured on a sample of columns only (`sample_columns`, for
    the result's figure) and the full residual bounds (a dozen passes over n x k arrays, the
    costliest step at 10^6 sites) are left out. With `precise` ("certified"), the values are
    the kept vectors' Rayleigh quotients in double-double (`products.rayleigh_quotients`) and
    the brackets go down to 8 eps (`LEVELS`): each bound must meet WANTED, else the
    extended-precision residual bounds take over.
    `deviation` may be given as a function that computes it: it is called only where the
    residual bounds need it (no counts, or a count that did not certify).
    (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
    """
    B = sp.csr_matrix(weighted)
    elongations = times(B, basis)
    gram = basis.T @ basis
    values, rotation = small_pencil(elongations.T @ elongations, gram)
    values = np.maximum(values, 0.0)
    terms = most_terms(B)
    norm = float(np.asarray(B.multiply(B).sum(axis=0)).max(initial=0.0))  # max diagonal of K~
    if form is not None:
        counted = _counted(B, form, values, basis, elongations, rotation, gram, k, vectors, terms, norm, precise)
        if counted is not None:
            return counted
    exact = functools.cache(deviation) if callable(deviation) else (lambda: deviation)  # formed once, if at all
    basis = basis @ rotation
    residuals = np.linalg.norm(transposed_times(B, elongations @ rotation) - basis * values, axis=0)
    del elongations  # (springs x (k + 1) doubles: 1.5 GB at 10^6 dofs, not kept through the bounds)
    # "high" first tries B~'s rounding at its worst case (`FORMING` per entry: no entry
    # deviations formed), and the modes whose worst-case margins already meet TARGET take the
    # cheap ones (no products of |B~|: `cluster_bounds`'s cheap columns; a protein's network:
    # every nonzero mode, the rigid ones then within `zero_level` from their products); if
    # some bound then misses TARGET, every mode again with the exact margins and deviations
    cheap_from = values.shape[0] if precise else cheap_columns(B, values, terms)
    theta, ritz, error = cluster_bounds(B, values, basis, 2 * residuals, terms, complete=False, cheap_from=cheap_from,
                                        deviation=exact() if precise else None, split=True)
    zero = theta + error <= zero_level(terms, B.shape[1], norm)
    missed = (error > TARGET * theta) & ~zero
    if not precise and np.any(missed[:k]):
        deviation = exact()
        theta, ritz, error = cluster_bounds(B, values, basis, 2 * residuals, terms, complete=False, deviation=deviation)
        missed = (error > TARGET * theta) & ~zero
    # float64 products first; extended precision (4 products of B~ in np.longdouble, costly at
    # 50,000 dofs) only if a mode's bound then misses TARGET (stiff springs: the float64
    # rounding margin of B~^T B~ v dominates the residual)
    # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
    # the float64 vectors' own residual, ~eps ||K~||, squared over a gap ~theta: a relative
    # floor (eps ||K~|| / theta)^2 no product precision lowers (a 10^6-site chain's lowest
    # modes: ~8e-9, where the extended-precision pass gained nothing); where every
    # missed mode sits above TARGET by that floor, the pass is left out (a value, not the clock)
    # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
    floor = np.square(np.minimum(EPS * norm / np.maximum(theta, np.finfo(float).tiny), 1e150))  # (zero modes: huge, finite)
    if np.any((missed & (floor <= TARGET))[:k]):  # (the (k+1)-th column only bounds the k-th's gap)
        theta, ritz, error = cluster_bounds(B, values, basis, 2 * residuals, terms, complete=False, precise=True,
                                            deviation=exact())
    basis = ritz
    result = spring_figures(B, theta[:k], basis[:, :k], vectors, "accurate-ritz")
    result.error = np.maximum(error[:k], 4 * EPS * theta[:k])
    return result


def cheap_columns(B: sp.csr_matrix, values: NDArray[np.float64], terms: float, margin: float = 0.5) -> int:
    """The first of the ascending `values` from which `cluster_bounds`'s worst-case margins
    (its `cheap_from` columns: B~'s rounding as `FORMING` per entry, || |B~|^T |B~| || bounded
    by its largest row sum) stay below `margin` x TARGET of each value, predicted from sizes:
    2 eta R + 2 sqrt(omega^2 R) (t + 2) eps + (2 t + 1) eps omega^2, with R the largest row sum
    of |B~|^T |B~| (>= its norm), as `cluster_bounds` takes it."""
    A = abs(B)
    reach = float(np.max(A.T @ (A @ np.ones(A.shape[1])), initial=0.0))
    slip = (terms + 2) * EPS * np.sqrt(reach)
    worst = (FORMING * (2 + FORMING) * reach + 2 * np.sqrt(np.maximum(values, 0.0)) * slip + slip**2
             + (2 * terms + 1) * EPS * values)
    fine = worst <= margin * TARGET * values
    # from the first value on which every later one is fine (values ascend)
    failing = np.flatnonzero(~fine)
    return int(failing[-1] + 1) if failing.shape[0] else 0


def _counted(B: sp.csr_matrix, form: ChainForm, values: NDArray[np.float64], basis: NDArray[np.float64],
             elongations: NDArray[np.float64], rotation: NDArray[np.float64], gram: NDArray[np.float64],
             k: int, vectors: bool, terms: int, norm: float, precise: bool = False) -> SolveResult | None:
    """`checked_ritz` on a chain: every Ritz value bracketed by two Sturm counts of the chain's
    spring form at the tightest of COUNT_LEVELS that holds its index (float64 Rayleigh
    quotients: ~1e-14 relative rounding at 10^6 sites, so brackets from 3e-14 up; "certified"
    takes the chain's own paths, down to 8 eps), zero modes counted within +-level / 2 of 0.
    None where some nonzero value's bracket misses TARGET: the residual bounds take over."""
    level = zero_level(terms, B.shape[1], norm)
    kept = basis @ rotation[:, :k] if vectors or precise else None
    wanted = TARGET
    if precise:
        assert kept is not None
        values = np.r_[np.maximum(rayleigh_quotients(B, kept), 0.0), values[k:]]
        wanted = WANTED
    error, _ = certify_chain_values(form, values, None, levels=LEVELS if precise else COUNT_LEVELS, floor=level)
    small = np.flatnonzero(values <= error)
    if small.shape[0]:
        count, certain = form.counts(np.array([-level / 2, level / 2]))
        if certain.all() and count[0] == 0 and count[1] > small.max():
            error[small] = np.minimum(error[small], level / 2 + values[small])
    zero = values + error <= level
    if not np.all((zero | (error <= wanted * values))[:k]):
        return None
    # the result's figures: residuals of three columns (the lowest, middle and highest mode:
    # each fresh n x k array costs ~0.1 s at 10^6 sites), the rotated Gram matrix
    columns = np.unique(np.array([0, k // 2, k - 1]))
    sample = basis @ rotation[:, columns]
    product = transposed_times(B, elongations @ rotation[:, columns])
    residuals = np.linalg.norm(product - sample * values[columns], axis=0)
    deviation = rotation.T @ gram @ rotation - np.eye(values.shape[0])
    return SolveResult(values[:k], kept if vectors else None, np.maximum(error[:k], 4 * EPS * values[:k]),
                       float(residuals.max(initial=0.0) / max(norm, float(values[:k].max(initial=0.0)))),
                       float(np.abs(deviation[:k, :k]).max(initial=0.0)), "accurate-ritz")


def spring_rayleigh(weighted: Matrix, ring: SolveResult, *, vectors: bool, deviation: Deviation = None,
                    name: str = "accurate-rayleigh") -> SolveResult:
    """All modes of a long ring: spring-space Rayleigh-Ritz per cluster of the banded solver's
    vectors (Rayleigh quotients ||B~ v||^2 for single modes), each bounded from its residual
    (`cluster_bounds`, gaps from the banded values' absolute bounds)."""
    B = sp.csr_matrix(weighted)
    theta, basis, error = cluster_bounds(B, ring.eigenvalues, ring.vectors,  # type: ignore[arg-type]
                                          np.maximum(ring.error, 0.0), most_terms(B), complete=True, deviation=deviation)
    order = np.argsort(theta, kind="stable")
    result = spring_figures(B, theta[order], basis[:, order], vectors, name)
    result.error = error[order]
    return result


def _accurate_jacobi(weighted: Matrix, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None
                     ) -> SolveResult:
    """One-sided Jacobi SVD (LAPACK gejsv) of the dense B~: relative accuracy for scaled B."""
    dense = weighted.toarray() if sp.issparse(weighted) else np.asarray(weighted)
    n_terms, n = dense.shape
    padded = np.zeros((max(n_terms, n), n))  # gejsv needs rows >= columns; zero rows add null space
    padded[:n_terms] = dense
    gejsv = la.get_lapack_funcs("gejsv", dtype=np.float64)
    sva, u, v, work, iwork, info = gejsv(padded, joba=1, jobu=3, jobv=0 if vectors else 3, jobr=1,
                                         jobt=0, jobp=0)
    if info != 0:
        raise RuntimeError(f"LAPACK gejsv failed with info={info}")
    scale = work[0] / work[1] if work[1] != 0 else 1.0  # sigma = scale * sva (LAPACK convention)
    sigma = scale * sva
    order = np.argsort(sigma)
    omega = sigma[order]
    select = selected(omega, n_modes=n_modes, band=band)
    eigenvalues = omega[select] ** 2
    # Jacobi: relative error ~ eps * cond(B~ with columns scaled to unit norm) per value;
    # reported with the residual of the Gram form below.
    if not vectors:
        error = 2.0 * 4 * n * EPS * eigenvalues
        return SolveResult(eigenvalues, None, error, float("nan"), float("nan"), "accurate-jacobi")
    basis = v[:, order][:, select]
    result = spring_figures(sp.csr_matrix(dense), eigenvalues, basis, True, "accurate-jacobi")
    return result



def checked_dense(weighted: Matrix, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
                  jacobi: bool = True, deviation: Deviation | Callable[[], Deviation] = None) -> SolveResult:
    """The fast dense solve, checked mode by mode; refinement only for the modes that need it.

    1. K~ = B~^T B~ formed from the spring factor, then one dense solve of it: LAPACK eigh with
       vectors (one mode beyond a requested subset, for the gap), also for values only (step 3
       needs them). Each value is then within the a-priori bound `delta` =
       (n + DENSE_FLOOR) eps ||K~|| + gamma_t || |B~|^T |B~| || (backward stable solve, and
       the rounding of forming K~ in sums of t terms), ||.|| the largest absolute row sum.
    2. A mode with lambda - delta >= delta / TARGET is certified by that bound alone (its
       relative error is <= TARGET): it keeps the fast value. Only the lowest modes, those
       below the threshold, and the rest of their cluster (values closer than 2 delta +
       TARGET |value|) are refined: Rayleigh-Ritz in spring space per cluster,
       H = (B~V)^T (B~V), whose small eigenvalues keep their relative accuracy.
    3. Per cluster, the quadratic residual bound |lambda_i - theta_i| <= ||R||_F^2 / gap (Kato-
       Temple for one vector), gap from the cluster's Ritz values to the neighbouring eigenvalues
       (each moved by delta towards it); ||R||_F with a margin for its own rounding. A cluster
       with no valid gap is bounded by ||R||_F (Weyl). The certified modes get the same
       a-posteriori bound too (|lambda - theta| plus theta's bound, when below delta): it
       follows the true error, where the a-priori bound can be ~n times above it (and above
       1e-13 relative for every mode once n passes ~900: delta / omega^2 >= n eps).
    4. If a requested mode's bound exceeds TARGET theta, and it is not a zero mode within rounding
       (theta + bound <= `zero_level`, ((t + 12) n eps)^2 ||K~||, t the most terms in a row or
       column of B~: omega below ~1e-11 of the largest, where B~'s own rounding leaves no
       relative digit), the
       result is gejsv's on B~ (``accurate-jacobi``); else the checked fast result
       (``accurate-checked``), its bounds as `error`. `refined` marks the modes whose values
       come from step 2 (all of them after Jacobi), `refinement` says how many and why.

    `jacobi` False (all modes of a system over DENSE_LIMIT dofs, where gejsv on the
    n_terms x n B~ would cost many times the dense solve: `registry`'s accurate-rayleigh): no step 4, the
    bounds stand as they are, and the path is ``accurate-rayleigh`` (its single-mode clusters
    are Rayleigh quotients ||B~ v||^2).

    B~'s own rounding is first taken at its worst case (`FORMING` per entry, as `checked_ritz` does: no
    deviations formed, no products of them) where `cheap_columns` predicts that it holds the refined modes
    asked; where a requested mode's bound then misses TARGET, the refined clusters again with the exact
    deviations (`deviation`, which may be given as a function that computes it: called only where needed),
    and the fallbacks below work with them. (1AKE, 642 dofs: ~4-7 of 35 ms a call, RESULTS.md, "The dense
    path's checks, and per-call costs".)
    """
    B = sp.csr_matrix(weighted)
    n = B.shape[1]
    deviations = functools.cache(deviation) if callable(deviation) else (lambda: deviation)
    terms = most_terms(B)
    dense, delta, norm = _spring_gram(B, terms)
    subset = n_modes is not None and n_modes < n
    last = min(int(n_modes), n - 1) if subset else n - 1  # type: ignore[arg-type]  # one beyond, for the gap
    # every vector, also for values only: each bound from its own residual follows the true
    # error, where the a-priori delta is up to ~n times above it (see `checked_dense`, step 3)
    # all modes: divide and conquer (evd; 1.5-2.7 times the values alone, n = 650-3,000, where
    # MRRR, evr, takes 2-4.7 times; its 2 n^2 work space is in `budget`); a subset: MRRR
    kwargs: dict[str, Any] = {"check_finite": False, "overwrite_a": True}
    if subset:
        kwargs["subset_by_index"] = (0, last)
    else:
        kwargs["driver"] = "evd"
    values, basis = la.eigh(dense, **kwargs)
    k = values.shape[0]
    keep = np.zeros(k, dtype=bool)
    keep[selected(np.sqrt(np.maximum(values, 0.0)), n_modes=n_modes, band=band)] = True
    threshold = delta * (1.0 + 1.0 / TARGET)  # lambda >= threshold: delta <= TARGET (lambda - delta)
    low = _cluster_end(values, delta, keep & (values < threshold))  # modes [0, low) are refined
    error = np.full(k, delta)
    count = min(low + 1, k)  # the refined modes and one beyond, for the gap
    fast_values = values
    fast_basis = basis[:, :count].copy() if low else basis
    refined = np.arange(k) < low
    # the worst case first where it is predicted to hold every refined mode asked to TARGET (`cheap_columns`, from
    # sizes; values within delta of zero aside: a free network's rigid motions, which end as zero modes); where it
    # is not (springs over decades), the exact deviations at once, as a second pass would need them anyway
    asked = values[:low][keep[:low] & (values[:low] > delta)]
    first = None if cheap_columns(B, asked, terms) == 0 else deviations()
    theta, ritz, bound = cluster_bounds(B, values, basis, delta, terms, complete=not subset, cheap_from=low,
                                        deviation=first)
    # certified modes keep the fast value; theta's bound plus |lambda - theta| also bounds it
    error = np.minimum(delta, np.abs(values - theta) + bound)
    values = values.copy()
    values[:low], error[:low] = theta[:low], bound[:low]
    zero = values + error <= zero_level(terms, n, norm)
    missed = keep & refined & (error > TARGET * np.abs(values)) & ~zero
    if missed.any() and first is None and deviations() is not None:
        # the refined clusters again with the exact deviations (and the mode beyond, for the gap: the columns
        # from `low` on take the worst case either way)
        theta, ritz, bound = cluster_bounds(B, fast_values[:count], fast_basis, delta, terms, complete=count == n,
                                            cheap_from=low, deviation=deviations())
        values[:low], error[:low] = theta[:low], bound[:low]
        zero = values + error <= zero_level(terms, n, norm)
        missed = keep & refined & (error > TARGET * np.abs(values)) & ~zero
    basis[:, :low] = ritz[:, :low]
    if missed.any() and _largest_cluster(fast_values[:count], delta) <= PRECISE_CLUSTER:
        # the refined clusters again with extended-precision products (their float64 rounding
        # margin, eps |B~|^T |B~| |v|, can dominate a residual: a ring's rigid mode, stiff
        # springs), before any Jacobi SVD; not where the fast values merge into large clusters
        # (their rotation in np.longdouble costs n c^2 without BLAS), which only Jacobi resolves
        # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
        theta, ritz, bound = cluster_bounds(B, fast_values[:count], fast_basis, delta, terms,
                                             complete=count == n, precise=True, deviation=deviations())
        values[:low], error[:low], basis[:, :low] = theta[:low], bound[:low], ritz[:, :low]
        zero = values + error <= zero_level(terms, n, norm)
        missed = keep & refined & (error > TARGET * np.abs(values)) & ~zero
    solver = "accurate-checked" if jacobi else "accurate-rayleigh"
    text = _checked_text(values[keep], error[keep], refined[keep], zero[keep])
    if missed.any() and not jacobi:
        with np.errstate(divide="ignore"):
            worst = float(np.max(error[missed] / np.abs(values[missed])))
        text += (f"; {int(missed.sum())} of them miss {TARGET:g} relative (error/omega^2 up to {worst:.1g}), "
                 f"no Jacobi SVD (its cost, n_terms n^2, over {JACOBI_WORK:.1e})")
    elif missed.any():
        # One-sided Jacobi on B~ (gejsv reduces the tall B~ by a pivoted QR first). Its vectors
        # are taken for every mode (mixing them with the fast vectors would cost orthogonality)
        # and checked the same way: its own estimate (eps times a condition number it cannot
        # see) is not a bound, a ring's 1e12 springs beat it by 1e4.
        with np.errstate(divide="ignore"):  # (a value of 0 with a bound above rounding: inf)
            worst = float(np.max(error[missed] / np.abs(values[missed])))
        text = (f"{int(missed.sum())} of {int(keep.sum())} modes missed {TARGET:g} relative after "
                f"spring-space Rayleigh-Ritz (error/omega^2 up to {worst:.1g}): one-sided Jacobi SVD "
                "(gejsv) of B~ on all")
        exact = _accurate_jacobi(B, n_modes=None, vectors=True, band=None)
        # Jacobi's values are relatively accurate: their neighbours' places (for the gaps and
        # the clusters) from each vector's own residual, not from the dense solve's delta,
        # which would merge every omega^2 below it into one cluster with no gap.
        located = np.minimum(delta, 2 * residual_bounds(B, exact.eigenvalues, exact.vectors, terms))  # type: ignore[arg-type]
        values, basis, error = cluster_bounds(B, exact.eigenvalues, exact.vectors,  # type: ignore[arg-type]
                                               located, terms, complete=True, precise=True, deviation=deviations())
        keep = np.zeros(values.shape[0], dtype=bool)
        keep[selected(np.sqrt(np.maximum(values, 0.0)), n_modes=n_modes, band=band)] = True
        refined = np.ones(values.shape[0], dtype=bool)
        solver = "accurate-jacobi"
    order = np.flatnonzero(keep)
    order = order[np.argsort(values[order], kind="stable")]  # a refined value may cross its neighbour
    values, error, refined = values[order], error[order], refined[order]
    if vectors:
        result = spring_figures(B, values, basis[:, order], True, solver)
        result.error = error
    else:
        result = SolveResult(values, None, error, float("nan"), float("nan"), solver)
    result.refined, result.refinement = refined, text
    return result


def _spring_gram(B: sp.csr_matrix, terms: float) -> tuple[NDArray[np.float64], float, float]:
    """K~ = B~^T B~ dense (Fortran order, for LAPACK), the a-priori bound `delta` of a backward
    stable solve of it (see checked_dense) and the upper bound ||K~|| it uses.

    ||K~||_2 <= || |B~|^T |B~| ||_2 <= the largest row sum of |B~|^T |B~| (sparse, O(nnz)); each
    entry of K~ is a sum of at most t products, formed within gamma_t of that absolute sum;
    B~'s own rounding (`FORMING`) moves K~ by at most (2 eta + eta^2) that norm.
    """
    n = B.shape[1]
    absolute = abs(B)
    # (the row sums of |B~|^T |B~|, non-negative: |B~|^T (|B~| 1), two products, no sparse product)
    norm = max(float(np.max(absolute.T @ (absolute @ np.ones(n)), initial=0.0)), 1e-300)
    gamma = terms * EPS / (1.0 - terms * EPS)
    delta = ((n + DENSE_FLOOR) * EPS * (1.0 + gamma) + gamma + FORMING * (2.0 + FORMING)) * norm
    return np.asfortranarray((B.T @ B).toarray()), delta, norm


#: Largest cluster of the fast solve for which `checked_dense` retries in extended precision.
PRECISE_CLUSTER = 64

#: The count brackets (relative half-widths) tried for a chain's spring-space Ritz values
#: (`checked_ritz`): float64 Rayleigh quotients carry ~1e-14 relative rounding at 10^6 sites,
#: so the tighter `counting.LEVELS` would only cost counts.
COUNT_LEVELS = tuple(level for level in LEVELS if level >= 3e-14)


def _largest_cluster(values: NDArray[np.float64], delta: float) -> int:
    """The most values in one cluster as `cluster_bounds` groups them (delta the same for all)."""
    breaks = np.flatnonzero(np.diff(values) > 2 * delta + TARGET * np.abs(values[1:]))
    return int(np.diff(np.r_[0, breaks + 1, values.shape[0]]).max(initial=0))


def _cluster_end(values: NDArray[np.float64], delta: float, needed: NDArray[np.bool_]) -> int:
    """The end of the cluster (values closer than 2 delta + TARGET |value|, as `cluster_bounds`
    groups them) that holds the last `needed` mode; 0 when none is needed."""
    if not needed.any():
        return 0
    breaks = np.flatnonzero(np.diff(values) > 2 * delta + TARGET * np.abs(values[1:]))
    last = int(np.flatnonzero(needed)[-1])
    after = breaks[breaks >= last]
    return int(after[0]) + 1 if after.size else values.shape[0]


def _checked_text(values: NDArray[np.float64], error: NDArray[np.float64], refined: NDArray[np.bool_],
                  zero: NDArray[np.bool_]) -> str:
    """`refinement` of an accurate-checked result (the requested modes only)."""
    k, count = values.shape[0], int(refined.sum())
    kept = (f"{k - count} kept from the dense solve, certified by its a-priori bound n eps ||K~|| <= "
            f"{TARGET:g} omega^2 (bounds from their residuals)")
    if not count:
        return f"all {k} modes " + kept[len(f"{k} "):]
    with np.errstate(divide="ignore"):
        relative = error[refined & ~zero] / np.abs(values[refined & ~zero])
    worst = f", error/omega^2 up to {float(relative.max()):.1g}" if relative.size else ""
    zeros = int((refined & zero).sum())
    return (f"{count} of {k} modes below that bound's reach refined by spring-space Rayleigh-Ritz"
            f"{worst}" + (f" ({zeros} zero within rounding)" if zeros else "") + f"; {kept}")
