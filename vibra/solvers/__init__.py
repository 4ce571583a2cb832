"""Solver paths for the mass-weighted eigenproblem K~ d = omega^2 d (Kneller, Mécanique analytique, eqs. 138-143).

`solve` picks a path from the structure of K and from what is asked, unless told:

=================  ==========================================================================
``dense``          LAPACK symmetric eigensolver on the dense K~ (subset by index or value;
                   values only when no vectors are asked). Absolute error ~ eps ||K~||.
``tridiagonal``    K~ tridiagonal (a chain): LAPACK stemr/stebz on its diagonals.
``banded``         K~ banded with a narrow band (a chain in 2-D or 3-D, a ladder): LAPACK
                   sbevd / sbevx on the band storage, O(n b^2) per value. A ring (periodic
                   chain, any masses and springs: tridiagonal plus two corners) is reordered
                   0, n-1, 1, n-2, ... (reverse Cuthill-McKee) into a band of half-width 2.
``sparse``         A few of the lowest modes (or a band) of a large sparse K~: shift-invert
                   with a negative shift chosen from the spectrum's scale, so a singular K
                   (free system) is never hit; tridiagonal K~ is factorised with LAPACK
                   pttrf (O(N)) and iterated by ARPACK, any other of 3,000 dofs and more by
                   a sparse Cholesky in nested-dissection order (CHOLMOD through cvxopt; MKL
                   PARDISO's where installed; SuperLU's LU where neither loads) and, for 3-D
                   factors, a block Krylov iteration.
``accurate``       The system knows its springs, K = B^T W B: frequencies are the singular
                   values of B~ = W^1/2 B M^-1/2, computed to high *relative* accuracy.
                   - a chain (each spring joins neighbouring sites): dqds on its Golub-Kahan bidiagonal;
                   - few modes of a large system: sparse shift-invert vectors, then a
                     Rayleigh-Ritz step in spring space (H = (B~V)^T (B~V), O(N k));
                   - any other small system: the fast dense solve, certified by its a-priori
                     bound where that reaches 1e-10 relative; below, a Rayleigh-Ritz step in
                     spring space and a Kato-Temple bound per mode (accurate-checked); the
                     one-sided Jacobi SVD (LAPACK gejsv) of B~ only when a requested mode's
                     bound misses 1e-10 relative (accurate-jacobi);
                   - all modes of a large non-chain system: the same, with the Jacobi
                     fallback while gejsv's n_terms n^2 stays within `common.JACOBI_WORK`
                     (rings to 4,000 sites), else without (accurate-rayleigh);
                   - a ring up to 6,000 sites: each bound then certified by Sturm counts of
                     its pencil in double-double (`accurate/ring/counts.py`);
                   - all frequencies, no vectors, of a ring of 100 sites or more (free or with
                     springs to a wall), or its lowest n_modes, at any length the budget
                     allows: roots of its spring
                     form's last pivot between the eigenvalues of the chain it is cut into, each
                     certified by compiled double-double Sturm counts, O(n^2) for all,
                     O(n k) for the lowest k (accurate-ring; `accurate/ring/values.py`, `kernel.py`);
                     at "high", a ring that is not spread: the band solver's values (over
                     1,500 sites) or shift-invert's (a few), each bracketed by two counts of
                     K - x M (`accurate/ring/counted.py`, `pencil_counts.py`);
                   - the same, of a chain of 100 sites or more with springs to a wall inside
                     it: dqds (or bisection) on its bidiagonal Cholesky factor, each value
                     certified by the same counts (accurate-walled; `accurate/chain/walled.py`).
=================  ==========================================================================

Before anything is allocated, `plan` describes the request (`problem.Problem`: sizes, the
accuracy level, the springs' shape from `topology.classify`), the registry (`registry.PATHS`)
chooses the path, and that path's declared cost function (`SolverPath.estimate`, from the rates
of `budget`) gives its memory and time (a `SolvePlan`); `budget.guard` refuses (`ResourceLimitError`, a ValueError) a request over the limits
with the figures and the cheaper requests (`vectors=False`, `n_modes`, `band`), and
`budget.Progress` reports solves estimated to take over `budget.PROGRESS_AFTER_S` on stderr.

Every path returns a `SolveResult` with an error estimate per eigenvalue, the largest
relative residual and the orthogonality error, which `vibra.modes.Modes` carries.

Where each path lives (one folder per family of paths; the registry and its helpers at the top):

==================================  ==========================================================
``accuracy.py``                     what each accuracy level means: levels, targets, the time
                                    limit, what "fast" skips
``common.py``                       `SolveResult`, mass weighting, the accuracy figures, size limits
``problem.py``                      `Problem`: one request described before any work
``topology.py``                     the springs' shape (chain, walled chain, ring, walled ring,
                                    network), classified once
``registry.py``                     every path declared once: when it applies, its cost function,
                                    its runner, its name (`PATHS`, `choose`, `estimate`)
``runners.py``                      one run function per registered path
``dispatch.py``                     `plan` (describe the request, let the registry choose,
                                    estimate), `solve`
``budget.py``                       the measured rates, the guard and its limits, progress
``compiled.py``                     the compiled kernels' loading (numba on a kernel's first call,
                                    never with vibra) and when a kernel pays (`compiled_pays`)
``standard/lapack.py``              dense, tridiagonal, banded (absolute accuracy)
``standard/sparse.py``              shift-invert for a few modes or a band (the probe, the known
                                    kernel, the block iteration, ARPACK)
``standard/shifted.py``             the shifted factor (K~ - sigma I)^-1 and the shift below the
                                    spectrum
``standard/parts.py``               a K~ of several connected parts solved part by part (small
                                    parts stacked for LAPACK, large ones by shift-invert)
``standard/ordering.py``            nested-dissection ordering (METIS through pymetis) for SuperLU
``standard/cholmod.py``             the default sparse Cholesky (SuiteSparse CHOLMOD, through cvxopt)
``standard/pardiso.py``             the optional MKL PARDISO Cholesky (``vibra[pardiso]``)
``standard/krylov.py``              block Krylov iteration (block Arnoldi, full reorthogonalisation)
``standard/gpu.py``                 ``device="gpu"``: dense all-modes solve with CuPy (cuSOLVER syevd);
                                    the iterative path's GPU memory and CSR upload
``standard/iterative.py``           iterative, accurate-iterative, iterative-gpu: LOBPCG with a
                                    multigrid preconditioner (pyamg) for the lowest modes of large
                                    networks
``standard/lobpcg.py``              block LOBPCG on numpy or CuPy arrays (the iterative path's)
``distributed/slepc.py``            ``solver="slepc"``: SLEPc over MPI (a worker run by Debian's
                                    python3, ``distributed/slepc_worker.py``)
``accurate/springs.py``             the accurate paths of any spring system: -checked, -ritz,
                                    -rayleigh, -jacobi; a ring's bounds certified by counts
``accurate/spring_ritz.py``         spring-space Rayleigh-Ritz per cluster, residual bounds, B~'s
                                    own rounding
``accurate/golub_kahan.py``         B~'s singular triplets by Golub-Kahan inverse iteration
                                    (Kato-Temple)
``accurate/dd.py``                  double-double arithmetic on arrays: sums, LU and its solves
``accurate/rounding.py``            error-free arithmetic behind the chain bounds (entry roundings,
                                    scalings)
``accurate/count_kernels.py``       compiled loops chains and rings share (numba): double-double
                                    primitives, the spring form's pivots, roots and counts
``accurate/counting.py``            certifying values by counts: ladders, multisection, sorted
                                    bounds, the cut chain
``accurate/gk_bisection.py``        Golub-Kahan bisection of a bidiagonal, compiled, LANES values
                                    at a time
``accurate/chain/bidiagonal.py``    accurate-bidiagonal: dqds / dbdsqr on a chain's bidiagonal;
                                    certificates
``accurate/chain/triplets.py``      the chains' compiled certificates (numba), one triplet per value
``accurate/chain/lowest.py``        accurate-bisection: the lowest modes of a chain by Golub-Kahan
                                    bisection
``accurate/chain/walled.py``        accurate-walled: a chain with springs to a wall inside it,
                                    values certified by counts
``accurate/chain/sturm_counts.py``  Sturm counts of a chain's spring form: certificates for values
                                    in clusters
``accurate/ring/counts.py``         a ring's pencil and its Sturm counts in double-double
                                    (certified bounds)
``accurate/ring/values.py``         accurate-ring: a ring's frequencies, roots certified by counts
``accurate/ring/counted.py``        accurate-ring at "high": a standard solver's values, each
                                    bracketed by two counts
``accurate/ring/pencil_counts.py``  the compiled counts of K - x M in double-double
``structured/pencil.py``            K x = omega^2 M x with a full, possibly ill-conditioned M
``structured/equilibrated.py``      its solver (pencil-jacobi, pencil-cholesky), as the registry runs it
``structured/first_order.py``       the quadratic paths' first-order forms and their eigensolvers
``structured/quadratic.py``         gyroscopic and damped modes (`QuadraticModes`)
==================================  ==========================================================

Examples
--------
>>> import numpy as np
>>> from vibra import solvers
>>> K = np.array([[1.0, -1.0], [-1.0, 1.0]])
>>> result = solvers.solve(K, np.array([1.0, 1.0]), n_modes=None, vectors=False, band=None,
...                        solver="auto", spring_factor=None)
>>> result.solver, np.round(result.eigenvalues, 12)
('dense', array([0., 2.]))
"""

from __future__ import annotations

from importlib import import_module as _import_module
from typing import TYPE_CHECKING
from typing import Any as _Any

if TYPE_CHECKING:  # bound on first access (`__getattr__`): a reader of `accuracy` alone imports no scipy
    from vibra.solvers.accuracy import LEVELS as ACCURACY_LEVELS
    from vibra.solvers.budget import Estimate, Progress, ResourceLimitError, available_memory, guard
    from vibra.solvers.common import (
        BAND_LIMIT, BDSQR_LIMIT, DENSE_ALL_LIMIT, DENSE_LIMIT, EPS, FACTOR_RTOL, SAMPLE, SolveResult,
        check_factor_matches, check_spring_factor, largest_entry, mass_weighted, physical_shapes,
    )
    from vibra.solvers.dispatch import SOLVER_PATHS, SolvePlan, alternatives, check_solve_plan, plan, solve
    from vibra.solvers.names import SOLVER_NAMES
    from vibra.solvers.accurate.chain.bidiagonal import Segment
    from vibra.solvers.registry import estimate

    Plan = SolvePlan
    check_plan = check_solve_plan

__all__ = [
    "solve", "plan", "SolvePlan", "check_solve_plan", "alternatives", "SolveResult", "ResourceLimitError",
    "Estimate", "estimate", "guard", "Progress", "ACCURACY_LEVELS", "SOLVER_NAMES", "physical_shapes",
    "mass_weighted",
]

#: Where each name is defined: (module under vibra.solvers, its name there). Besides `__all__`, the
#: names kept importable from vibra.solvers as before, though not part of its API, so that no
#: ``from vibra.solvers import X`` breaks: constants and helpers of its modules, the former names
#: (``Plan`` for `SolvePlan`, ``check_plan`` for `check_solve_plan`).
_HOMES: dict[str, tuple[str, str]] = {
    "ACCURACY_LEVELS": ("accuracy", "LEVELS"),
    **{name: ("budget", name) for name in ("Estimate", "Progress", "ResourceLimitError", "guard", "available_memory")},
    **{name: ("common", name) for name in (
        "SolveResult", "mass_weighted", "physical_shapes", "BAND_LIMIT", "BDSQR_LIMIT", "DENSE_ALL_LIMIT",
        "DENSE_LIMIT", "EPS", "FACTOR_RTOL", "SAMPLE", "check_factor_matches", "check_spring_factor",
        "largest_entry")},
    "SOLVER_NAMES": ("names", "SOLVER_NAMES"),  # (its light home: reading it imports no numpy)
    **{name: ("dispatch", name) for name in (
        "SOLVER_PATHS", "SolvePlan", "alternatives", "check_solve_plan", "plan", "solve")},
    "Plan": ("dispatch", "SolvePlan"),
    "check_plan": ("dispatch", "check_solve_plan"),
    "estimate": ("registry", "estimate"),
    "Segment": ("accurate.chain.bidiagonal", "Segment"),
}


def _submodules() -> set[str]:
    from pkgutil import iter_modules

    return {module.name for module in iter_modules(__path__)}


def __getattr__(name: str) -> _Any:
    if name in _HOMES:
        module, attribute = _HOMES[name]
        value = getattr(_import_module(f"vibra.solvers.{module}"), attribute)
        globals()[name] = value  # bound once: later accesses are plain attribute reads
        return value
    if not name.startswith("__") and name in _submodules():  # vibra.solvers.budget after ``import vibra.solvers``
        return _import_module(f"vibra.solvers.{name}")
    raise AttributeError(f"module 'vibra.solvers' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_HOMES, *_submodules()})
