"""`plan` and `solve`: describe a request (`registry.Problem`), let the registry choose its path,
estimate and guard its cost, and run it."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra.solvers.budget import (
    Estimate, Progress, ProgressCallback, describe_bytes, describe_seconds, guard,
)
import vibra.solvers.common as common
from vibra.solvers.common import (
    BAND_LIMIT, DENSE_LIMIT, WEIGHED_FROM, SolveResult, bandwidth, mass_weighted, ring_ordering,
)
from vibra.solvers.accurate.chain.lowest import spring_factor_of_chain
from vibra.solvers.names import SOLVER_NAMES
from vibra.solvers.problem import Problem
from vibra.solvers.registry import BY_NAME, choose, path_names
from vibra.solvers.runners import Inputs
from vibra.solvers.standard.iterative import WIDTH, most_modes
from vibra.solvers.topology import classify, level_structure


#: Every path a result can report in `Modes.solver` (the registry's, and their fallbacks).
SOLVER_PATHS = path_names()


@dataclass(frozen=True)
class SolvePlan:
    """What `solve` will run: the solver family, the path, the `registry.Problem` it was chosen
    for, and the path's cost estimate; `fast` the cost of ``accuracy="fast"`` where more was
    asked, `lowest` that of the same request for the lowest 10 modes."""

    solver: str
    path: str
    width: int
    ordering: NDArray[np.intp] | None
    cost: Estimate
    nnz: int
    n_dof: int
    fast: Estimate | None = None
    lowest: Estimate | None = None
    accuracy: str = "high"
    problem: Problem | None = None


def describe(K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64], *, n_modes: int | None,
             vectors: bool, band: tuple[float, float] | None, solver: str,
             spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None, accuracy: str = "high",
             device: str = "cpu", positions: NDArray[np.float64] | None = None, max_memory: float | None = None
             ) -> Problem:
    """The `registry.Problem` of a request: sizes, K~'s band (a ring reordered where the band
    solver could use it), the springs' shape (`topology.classify`), and K~'s diagonal spread
    where the springs or a few modes of a chain are given, or K~ is large and not banded, and the
    widest breadth-first level of a large sparse K's graph (what its factor costs); O(nnz),
    nothing of K~ formed."""
    n = K.shape[0]
    diagonal = mass.ndim == 1
    width = bandwidth(K) if diagonal else n - 1
    ordering = None
    if diagonal and width > BAND_LIMIT and n > DENSE_LIMIT and solver in ("auto", "banded", "accurate"):
        ring = ring_ordering(K)
        if ring is not None:
            ordering, width = ring
    use_factor = spring_factor is not None and solver in ("auto", "accurate")
    topology = classify(spring_factor[0], diagonal_mass=diagonal) if use_factor else "none"  # type: ignore[index]
    n_terms = int(spring_factor[0].shape[0]) if use_factor else 0  # type: ignore[index]
    spread = 1.0
    partial = n_modes is not None and n_modes < n
    ringlike = topology in ("ring", "walled-ring")  # (a ring's band request routes as if unspread)
    if diagonal and (band is None and (partial and width <= 1 and ordering is None or ringlike)
                     or use_factor and not ringlike or width > BAND_LIMIT and n > DENSE_LIMIT):
        spread = _diagonal_spread(K, mass)
        if topology == "none" and solver == "auto" and spread > common.BISECTION_SPREAD:
            derived = spring_factor_of_chain(K)  # a chain given as K: its springs from K's entries
            if derived is not None and classify(derived[0]) == "chain":
                topology = "chain-derived"
    wide = sp.issparse(K) and diagonal and width > BAND_LIMIT and n >= WEIGHED_FROM
    separator, parts = level_structure(K) if wide else (0, 1)
    free = wide and _rows_sum_to_zero(K)  # (asked only by `Problem.weighed`)
    return Problem(n=n, n_modes=n_modes, band=band, vectors=vectors, accuracy=accuracy, diagonal_mass=diagonal,
                   width=width, ordering=ordering, sparse=sp.issparse(K), nnz=_stored(K), n_terms=n_terms,
                   topology=topology, spread=spread, device=device, separator=separator,
                   coordinates=positions is not None, free=free, parts=parts, max_memory=max_memory)


#: |K 1| / ||K||_inf under which K's rows count as summing to zero (`_rows_sum_to_zero`). A network's diagonal blocks
#: are minus the sums of its off-diagonal ones: ~1e-16 of its norm in double precision, 1.7e-8 for 3ENL's Hessian
#: stored in single precision (a review); values that low still sit at the shift-invert paths' shift, near zero.
FREE_ROWS = 1e-6


def _rows_sum_to_zero(K: sp.csr_matrix) -> bool:
    """Whether K 1 = 0 within `FREE_ROWS` ||K||_inf: a free network (its translations zero modes), O(nnz)."""
    return bool(np.abs(K.sum(axis=1)).max() <= FREE_ROWS * abs(K).sum(axis=1).max())


def plan(
    K: NDArray[np.float64] | sp.csr_matrix,
    mass: NDArray[np.float64],
    *,
    n_modes: int | None,
    vectors: bool,
    band: tuple[float, float] | None,
    solver: str,
    spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None,
    accuracy: str = "high",
    device: str = "cpu",
    positions: NDArray[np.float64] | None = None,
    max_memory: float | None = None,
) -> SolvePlan:
    """Choose the path for this request (`registry.choose`; "auto" picks one) and estimate its
    cost; nothing allocated.

    Raises ValueError when the named solver cannot serve the request. Costs O(nnz) for a
    sparse K and one pass over a dense one (its bandwidth); K~ is not formed. `accuracy` is
    "high" or "certified" where a spring factor is given (the caller drops the factor for
    "fast"): "certified" runs the bound-tightening steps in full (a chain's Ritz values
    bracketed by Sturm counts from 8 eps). `positions` ((n / 3, 3), the sites' coordinates, checked
    by the caller) are priced in by the iterative paths' estimate, which they speed up. `max_memory` (the caller's
    limit, as `solve` takes it): of paths whose estimates are weighed, one that fits is taken over one that does not.
    """
    _check_named(solver, K, mass, n_modes=n_modes, band=band, spring_factor=spring_factor, device=device)
    problem = describe(K, mass, n_modes=n_modes, vectors=vectors, band=band, solver=solver,
                       spring_factor=spring_factor, accuracy=accuracy, device=device, positions=positions,
                       max_memory=max_memory)
    return plan_problem(problem, solver)


def plan_problem(problem: Problem, solver: str) -> SolvePlan:
    """The `SolvePlan` of a described request: the registry's path for it (`registry.choose`) and
    that path's estimate, with the costs of the cheaper requests where more was asked; every
    solve (`plan`, `quadratic_modes`) is planned here. Raises ValueError when `solver` cannot
    serve it."""
    path = choose(problem, solver)
    cost = path.estimate(problem)
    fast = lowest = None
    if path.family == "accurate" and problem.topology != "chain-derived":
        springless = replace(problem, topology="none", n_terms=0)  # what accuracy="fast" runs
        fast = choose(springless, "auto").estimate(springless)
        if problem.band is None and (problem.n_modes is None or problem.n_modes > 50) and problem.n > 10:
            ten = replace(problem, n_modes=10)
            lowest = choose(ten, solver).estimate(ten)
    return SolvePlan(path.family if solver == "auto" else solver, path.name, problem.width, problem.ordering, cost,
                     problem.nnz, problem.n, fast, lowest, problem.accuracy, problem)


def _check_named(solver: str, K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64], *,
                 n_modes: int | None, band: tuple[float, float] | None,
                 spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None, device: str = "cpu") -> None:
    """A named solver family that cannot serve the request: ValueError naming what it needs."""
    if solver == "tridiagonal" and not (mass.ndim == 1 and bandwidth(K) <= 1):
        raise ValueError("solver='tridiagonal' needs a tridiagonal K and diagonal masses")
    if solver == "banded" and mass.ndim != 1:
        raise ValueError("solver='banded' needs diagonal masses")
    if solver == "sparse" and n_modes is None and band is None:
        raise ValueError("solver='sparse' computes a few modes: give n_modes or band")
    if solver == "slepc" and (n_modes is None or band is not None or mass.ndim != 1 or n_modes >= K.shape[0] - 1):
        raise ValueError("solver='slepc' computes the lowest modes of a large K with diagonal masses: give n_modes "
                         f"below n_dof - 1 = {K.shape[0] - 1}")
    if solver == "iterative":
        _check_iterative(K.shape[0], mass, n_modes, band, device)
    if solver == "accurate" and spring_factor is None:
        raise ValueError("solver='accurate' needs the spring factor (B, w) of K")


def _check_iterative(n: int, mass: NDArray[np.float64], n_modes: int | None, band: tuple[float, float] | None,
                     device: str = "cpu") -> None:
    """solver='iterative' (LOBPCG): the lowest n_modes of a K with diagonal masses; one message per cause (the
    way out on the GPU its dense path, which serves both)."""
    what = "solver='iterative' computes the lowest n_modes of a large sparse K"
    on_gpu = "use solver='dense' or 'auto' (device='gpu': all modes densely, then kept), or device='cpu'"
    if mass.ndim != 1:
        raise ValueError(f"{what} with diagonal masses; M is a full matrix: "
                         + (on_gpu if device == "gpu" else "use solver='pencil' or 'auto'"))
    if band is not None:
        raise ValueError(f"{what}; band={band!r} asks for a frequency window: "
                         + (on_gpu if device == "gpu" else "use solver='sparse' or 'auto' for a band"))
    most = most_modes(n)
    if most < 1:
        raise ValueError(f"{what}: K has {n} dofs, and it needs {5 * WIDTH} at least (LOBPCG's block, {WIDTH} times "
                         "the modes, stays under n / 5); use solver='dense' or 'auto'")
    if n_modes is None or not 1 <= n_modes <= most:
        raise ValueError(f"{what}: n_modes is {n_modes!r}; give n_modes from 1 to {most} (K has {n} dofs; LOBPCG's "
                         f"block, {WIDTH} times the modes, stays under n / 5)")


def _diagonal_spread(K: NDArray[np.float64] | sp.csr_matrix, mass: NDArray[np.float64]) -> float:
    """max / min of K~'s nonzero diagonal entries |K_ii| / m_i (1 for a uniform chain); O(n)."""
    diagonal = np.abs(np.asarray(K.diagonal(), dtype=float)) / mass
    diagonal = diagonal[diagonal > 0]
    return float(diagonal.max() / diagonal.min()) if diagonal.size else 1.0


def _stored(K: NDArray[np.float64] | sp.csr_matrix) -> int:
    """Entries stored: nnz of a sparse K, n^2 of a dense one."""
    if isinstance(K, np.ndarray):
        return int(K.shape[0]) * int(K.shape[1])
    return int(K.nnz)


def alternatives(request: SolvePlan, *, n: int, n_modes: int | None, vectors: bool,
                 band: tuple[float, float] | None) -> list[str]:
    """The cheaper requests that answer most questions, each with its own estimate (the
    registry's cost functions on the request changed)."""
    problem = request.problem
    assert problem is not None
    if problem.quadratic:
        return ["none with G or C (all 2n eigenvalues at once); without them, the symmetric paths' partial "
                "solves (n_modes=, band=)"]
    path = BY_NAME[request.path]
    options = []
    if problem.device == "gpu":  # (the CPU's plan for the same request, e.g. where the GPU's paths do not apply)
        on_cpu = replace(problem, device="cpu")
        cpu = choose(on_cpu, "auto")
        options.append(f'device="cpu" ({cpu.name}: ~{_short(cpu.estimate(on_cpu))})')
    if request.fast is not None and request.fast.seconds < request.cost.seconds:
        options.append(f'accuracy="fast" (normal_modes: no spring_factor; {request.fast.path}, absolute accuracy: '
                       f'~{_short(request.fast)})')
    if vectors:
        values = path.estimate(replace(problem, vectors=False))
        options.append(f"vectors=False (frequencies only: ~{_short(values)})")
    if request.lowest is not None:
        options.append(f"n_modes=10 (the lowest modes, {request.lowest.path}: ~{_short(request.lowest)})")
    elif n_modes is None or n_modes > 50:
        how = "sparse shift-invert" if request.nnz < 0.1 * n * n else "a dense subset"
        ten = replace(problem, n_modes=min(10, n), band=None, topology="none", n_terms=0, device="cpu")
        few = choose(ten, "sparse" if how.startswith("sparse") else "dense").estimate(ten)
        options.append(f"n_modes=10 (the lowest modes by {how}: ~{_short(few)})")
    if band is None:
        options.append("band=(low, high) (only the modes in a frequency window)")
    return options


def check_solve_plan(request: SolvePlan, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
                     max_memory: float | None, max_seconds: float | None) -> None:
    """`budget.guard` on a plan's cost, with the cheaper requests as the way out."""
    n = request.n_dof
    guard(request.cost, n_dof=n, max_memory=max_memory, max_seconds=max_seconds,
          alternatives=alternatives(request, n=n, n_modes=n_modes, vectors=vectors, band=band))


def _short(cost: Estimate) -> str:
    return f"{describe_bytes(cost.memory)}, {describe_seconds(cost.seconds)}"


def solve(
    K: NDArray[np.float64] | sp.csr_matrix,
    mass: NDArray[np.float64],
    *,
    n_modes: int | None,
    vectors: bool,
    band: tuple[float, float] | None,
    solver: str,
    spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None,
    max_memory: float | None = None,
    max_seconds: float | None = None,
    progress: bool | ProgressCallback | None = None,
    request: SolvePlan | None = None,
    accuracy: str = "high",
    positions: NDArray[np.float64] | None = None,
) -> SolveResult:
    """Run the path the registry chose for this request (`plan`) on K~ and return a `SolveResult`.

    The request is planned and guarded first (`plan`, `vibra.solvers.budget.guard`): one
    whose estimated memory or time exceeds `max_memory` / `max_seconds` (defaults: the
    module-level limits of `vibra.solvers.budget`) raises `ResourceLimitError` before
    anything is allocated. `progress` reports long solves (see `budget.Progress`). `positions`
    ((n / 3, 3) or None) go to the iterative paths (`iterative.lowest_modes`); the others ignore them.

    Examples
    --------
    >>> import numpy as np
    >>> K = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])   # CO2 axial, kappa = 1
    >>> result = solve(K, np.array([1.0, 2.0, 1.0]), n_modes=None, vectors=False, band=None,
    ...                solver="dense", spring_factor=None)
    >>> np.round(result.eigenvalues, 12)          # 0, kappa / m, kappa (1/m + 2/M) (eq. 157)
    array([0., 1., 2.])
    """
    if request is None:
        request = plan(K, mass, n_modes=n_modes, vectors=vectors, band=band, solver=solver,
                       spring_factor=spring_factor, accuracy=accuracy, positions=positions, max_memory=max_memory)
        check_solve_plan(request, n_modes=n_modes, vectors=vectors, band=band, max_memory=max_memory,
                         max_seconds=max_seconds)
    problem = request.problem
    assert problem is not None
    if problem.coordinates != (positions is not None):
        raise ValueError(f"request was planned {'with' if problem.coordinates else 'without'} positions and is solved "
                         f"{'with' if positions is not None else 'without'} them; plan and solve with the same positions")
    path = BY_NAME[request.path]
    report = Progress(progress, request.cost)
    if not path.weighted:  # (K and M as given: no K~ formed)
        result = path.run(problem, Inputs(None, K, mass, None, band, 1.0, report.step))
        result.solver = path.reported(result)
        report.done()
        return result
    Kt = mass_weighted(K, mass, share=True)  # (K itself for unit masses: the paths only read K~)
    report.step(0.05, "mass-weighted K~ formed")
    # Far from 1, K~'s scale trips LAPACK's bisection and ARPACK (omega^2 ~ 1e-300 or 1e+300):
    # scale by an even power of 2 (exact in floating point) and scale the results back.
    exponent = _scale_exponent(Kt)
    factor = spring_factor if path.springs else None  # (the sparse path: for its shift's rounding, where given)
    scale = 1.0
    if exponent:
        scale = 2.0**-exponent
        if isinstance(Kt, np.ndarray):
            Kt *= scale
        else:
            Kt = sp.csr_matrix(Kt * scale)
        if band is not None:
            band = (band[0] * 2.0 ** (-exponent // 2), band[1] * 2.0 ** (-exponent // 2))
        if factor is not None:
            factor = (factor[0], factor[1] * scale)
    result = path.run(problem, Inputs(Kt, K, mass, factor, band, scale, report.step, positions))
    result.solver = path.reported(result)  # (the name the registry declares, or its declared fallback)
    if exponent:
        result.eigenvalues = result.eigenvalues * 2.0**exponent
        result.error = result.error * 2.0**exponent
    report.done()
    return result


#: K~ whose largest diagonal entry lies within 2^+-SCALE_EXPONENT is solved as it is.
SCALE_EXPONENT = 64


def _scale_exponent(Kt: NDArray[np.float64] | sp.csr_matrix) -> int:
    """An even e with max|diag K~| 2^-e near 1, or 0 when the scale is already moderate."""
    diagonal = np.abs(Kt.diagonal())
    largest = float(diagonal.max()) if diagonal.size else 0.0
    if largest == 0.0 or not np.isfinite(largest):
        return 0
    exponent = int(np.frexp(largest)[1])
    if abs(exponent) <= SCALE_EXPONENT:
        return 0
    return exponent - exponent % 2


__all__ = ["SOLVER_NAMES", "SOLVER_PATHS", "SolvePlan", "describe", "plan", "plan_problem", "alternatives",
           "check_solve_plan", "solve"]
