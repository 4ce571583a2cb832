"""`Problem`: one request to the solver registry, described before any work.

A request is described by its sizes, what is asked, the accuracy level and the shape of the
springs (`topology.classify`): all from the pattern and the sizes, O(nnz). The registry's
predicates (which path applies), cost functions (what it costs) and runners (how it runs) all
take one (`vibra.solvers.registry`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import vibra.solvers.common as common
from vibra.solvers.accuracy import uses_springs
from vibra.solvers.common import BAND_LIMIT, DENSE_LIMIT, WEIGHED_FROM

__all__ = ["Problem", "quadratic_problem", "chain_problem", "bloch_problem"]


@dataclass(frozen=True)
class Problem:
    """One request, described before any work: sizes, what is asked, and structure.

    `width` is K~'s half-bandwidth (after `ordering`, a ring's banded order, where there is one);
    `topology` the shape of the springs (`topology.classify`; "none" without a spring factor, and
    "chain-derived" for a chain given as K alone whose springs `lowest.spring_factor_of_chain`
    recovers: only bisection uses them);
    `spread` the ratio of K~'s largest to smallest nonzero diagonal entry (where masses are
    diagonal and the springs or a few modes of a chain are given; else 1);
    `separator` the widest breadth-first level of K's graph (`topology.separator_width`: what a
    nested-dissection factor of a sparse K wider than a band costs), 0 where not measured;
    `batch` the number of matrices solved alike: a crystal's D(q) at `batch` wave vectors
    (``equation="bloch"``, `bloch_problem`), 1 for every other request;
    `coordinates` whether the sites' positions came with K (three dofs per site): the iterative
    path's preconditioner and exact rotations use them (`iterative.lowest_modes`);
    `free` whether K's rows sum to zero (K 1 = 0: a free network, every rigid translation a zero mode), and `parts`
    the connected components of K's graph (`topology.level_structure`), both measured only where a request may be
    `weighed`; `max_memory` the caller's memory limit (`budget.memory_limit`: None, the default one), which a rival
    path's memory estimate must fit to be taken (`registry.choose`).
    """

    n: int
    n_modes: int | None
    band: tuple[float, float] | None
    vectors: bool
    accuracy: str
    diagonal_mass: bool
    width: int
    ordering: NDArray[np.intp] | None
    sparse: bool
    nnz: int
    n_terms: int
    topology: str
    spread: float = 1.0
    device: str = "cpu"
    # M q'' + (G + C) q' + K q = 0: "undamped" (no G, no C: the symmetric paths), "gyroscopic"
    # (G only) or "damped" (C given); "bloch": a crystal's Hermitian D(q), one per wave vector;
    # `definite`: K~ positive definite (its Cholesky factor exists)
    equation: str = "undamped"
    definite: bool = True
    separator: int = 0
    batch: int = 1
    coordinates: bool = False
    free: bool = False
    parts: int = 1
    max_memory: float | None = None

    @property
    def quadratic(self) -> bool:
        """G or C given: a quadratic eigenproblem (`structured.quadratic`)."""
        return self.equation in ("gyroscopic", "damped")

    @property
    def springs(self) -> bool:
        """The spring factor (B, w) of K is given: the accurate paths may serve."""
        return self.topology not in ("none", "chain-derived")

    @property
    def partial(self) -> bool:
        """Fewer modes than all of them (by count)."""
        return self.n_modes is not None and self.n_modes < self.n

    @property
    def few(self) -> bool:
        """A few modes (or a band) of a system over DENSE_LIMIT dofs: the partial solvers' work."""
        return (self.n_modes is not None and self.n_modes < self.n - 1 or self.band is not None) and self.n > DENSE_LIMIT

    @property
    def weighed(self) -> bool:
        """Fewer than n - 1 modes of a sparse free 3-D network in one part (wider than a band, diagonal masses, K 1 = 0;
        springs of no 1-D shape, which has its own paths) of `WEIGHED_FROM` dofs or more, "fast" or "high": the
        shift-invert paths serve it beside the dense ones (at "high" `accurate-checked` up to DENSE_LIMIT, where its
        Jacobi fallback stays affordable), and the plan weighs them by estimate: the dense solve wins where many modes
        are asked (450 of a 2,001-dof star: 0.82 s against 17.8 s; RESULTS.md, "Many modes priced").
        "certified", whose refinement dominates either, keeps the dense path: network-1500 took 463 s there in one run
        and 560 s on the shift-invert path in another, both estimated ~3 min; not weighed until measured side by side.
        A K that is not free (on-site springs, an indefinite K) keeps the dense path: its lowest values lie away from
        zero, where the shift-invert estimate places no shift, and the shift is searched by extra factorisations (a
        random sparse 1,000 x 1,000 K, + 25 I or indefinite, 5 modes: 81-84 ms dense, 187-405 ms shift-invert). A K
        of several parts keeps the plan by size: the shift-invert path solves it part by part, which its estimate does
        not price (30 parts of 40 sites, 400 modes: 0.17 s measured, 4.6 s estimated; a review of the change)."""
        return (self.sparse and self.diagonal_mass and self.width > BAND_LIMIT and self.band is None and self.free
                and self.topology in ("network", "none") and self.accuracy != "certified"
                and self.parts == 1 and self.n_modes is not None and self.n_modes < self.n - 1 and self.n >= WEIGHED_FROM)

    @property
    def tridiagonal(self) -> bool:
        return self.width <= 1 and self.ordering is None

    @property
    def k(self) -> int:
        """Modes to estimate for: n_modes, or common.BAND_MODES_ESTIMATE for a band, or all."""
        if self.n_modes is not None:
            return self.n_modes
        return min(self.n, common.BAND_MODES_ESTIMATE) if self.band is not None else self.n

    @property
    def loose(self) -> bool:
        """Bounds over 1e-10 expected after the spring-space Ritz check: K~'s diagonal spreads
        over `common.LOOSE_SPREAD` (masses or springs over decades); the checked path's Jacobi
        fallback and "high"'s triplet step are then counted in its estimate."""
        return self.spread > common.LOOSE_SPREAD

    @property
    def ringlike(self) -> bool:
        return self.topology in ("ring", "walled-ring")

    @property
    def one_dimensional(self) -> bool:
        """Springs along one line (a chain or a ring, walls or not)."""
        return self.topology in ("chain", "walled-chain", "ring", "walled-ring")

    @property
    def ring_route(self) -> str | None:
        """How "high" takes a ring's values from a standard solver (`common.ring_route`): the band
        solver's where the ring has its banded order and no vectors are asked."""
        return common.ring_route(self.accuracy, self.few, self.spread, self.ordering is not None and not self.vectors)


def quadratic_problem(n: int, *, damped: bool, definite: bool) -> Problem:
    """The `Problem` of a quadratic eigenproblem of n dofs (all 2n eigenvalues, dense)."""
    return Problem(n=n, n_modes=None, band=None, vectors=True, accuracy="high", diagonal_mass=False, width=n,
                   ordering=None, sparse=False, nnz=n * n, n_terms=0, topology="none",
                   equation="damped" if damped else "gyroscopic", definite=definite)


def chain_problem(n: int, *, accuracy: str, n_modes: int | None = None, vectors: bool = False) -> Problem:
    """The `Problem` of a chain of n dofs (tridiagonal K~, diagonal masses, its springs known unless
    the level skips them): the cheapest request of that size, which a check made from sizes alone,
    before any system is built, plans (`vibra.pipeline.scene.limits.all_modes_seconds`)."""
    springs = uses_springs(accuracy)
    return Problem(n=n, n_modes=n_modes, band=None, vectors=vectors, accuracy=accuracy, diagonal_mass=True, width=1,
                   ordering=None, sparse=True, nnz=3 * n, n_terms=max(n - 1, 0) if springs else 0,
                   topology="chain" if springs else "none")


def bloch_problem(n_branches: int, n_q: int, *, vectors: bool, accuracy: str, entries: int, springs: bool) -> Problem:
    """The `Problem` of a crystal's D(q) at `n_q` wave vectors: `n_q` complex Hermitian matrices of
    `n_branches`, assembled from `entries` stored force-constant entries each (the scatter's
    n_translations (3 n_atoms)^2, `vibra.crystals.dynamical.Assembly`), all eigenvalues (and
    vectors), the spring factor known (`springs`) where "high" may re-solve a q-point through it."""
    return Problem(n=n_branches, n_modes=None, band=None, vectors=vectors, accuracy=accuracy, diagonal_mass=True,
                   width=n_branches, ordering=None, sparse=False, nnz=entries, n_terms=0,
                   topology="network" if springs else "none", equation="bloch", batch=n_q)
