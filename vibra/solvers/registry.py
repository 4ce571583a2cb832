"""The registry of solver paths: the one place that decides which path serves a request.

A request is first described as a `Problem` (sizes, what is asked, the accuracy level and the
shape of the springs, `topology.classify`: all from the pattern and the sizes, O(nnz), before
any work). Each `SolverPath` says whether it `applies` to a problem, what it costs
(`estimate`: seconds and bytes from sizes, never from the clock) and how it runs. `PATHS` lists
them in order of preference: for ``solver="auto"`` the first that applies is taken, within
the family the request names (the standard paths for ``accuracy="fast"`` or without springs,
the accurate ones with them). `dispatch.plan` and `dispatch.solve`, ``vibra validate``, the
budget guard and the README's table all read this registry; nothing else branches on path
names.

A path may name `fallbacks`: what it reports instead when a check on its own result (never the
clock) hands the modes to a stronger method: ``accurate-checked`` becomes ``accurate-jacobi``
when a requested bound still misses 1e-10 after spring-space Rayleigh-Ritz.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.budget import Estimate, estimate
import vibra.solvers.common as common
import vibra.solvers.runners as runners
from vibra.solvers.common import BAND_LIMIT, DENSE_LIMIT, SolveResult

__all__ = ["Problem", "SolverPath", "PATHS", "BY_NAME", "choose", "path_names", "quadratic_problem", "readme_table"]


@dataclass(frozen=True)
class Problem:
    """One request, described before any work: sizes, what is asked, and structure.

    `width` is K~'s half-bandwidth (after `ordering`, a ring's banded order, where there is one);
    `topology` the shape of the springs (`topology.classify`; "none" without a spring factor, and
    "chain-derived" for a chain given as K alone whose springs `lowest.spring_factor_of_chain`
    recovers: only bisection uses them);
    `spread` the ratio of K~'s largest to smallest nonzero diagonal entry (rings, and chains with
    a few modes asked; else 1).
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
    # (G only) or "damped" (C given); `definite`: K~ positive definite (its Cholesky factor exists)
    equation: str = "undamped"
    definite: bool = True

    @property
    def quadratic(self) -> bool:
        """G or C given: a quadratic eigenproblem (`structured.quadratic`)."""
        return self.equation != "undamped"

    @property
    def partial(self) -> bool:
        """Fewer modes than all of them (by count)."""
        return self.n_modes is not None and self.n_modes < self.n

    @property
    def few(self) -> bool:
        """A few modes (or a band) of a system over DENSE_LIMIT dofs: the partial solvers' work."""
        return (self.n_modes is not None and self.n_modes < self.n - 1 or self.band is not None) and self.n > DENSE_LIMIT

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
    def ringlike(self) -> bool:
        return self.topology in ("ring", "walled-ring")

    @property
    def ring_route(self) -> str | None:
        """How "high" takes a ring's values from a standard solver (`common.ring_route`): the band
        solver's where the ring has its banded order and no vectors are asked."""
        return common.ring_route(self.accuracy, self.few, self.spread, self.ordering is not None and not self.vectors)


Runner = Callable[..., SolveResult]


@dataclass(frozen=True)
class SolverPath:
    """One solver path: its name (what `Modes.solver` reports), the `solver=` family that
    selects it, when it applies, what it costs, and how it runs (`run` takes the `Problem`
    and the inputs of `dispatch.solve`)."""

    name: str
    family: str
    applies: Callable[[Problem], bool]
    run: Runner | None  # None: the quadratic family, run by `structured.quadratic` (its own result type)
    guarantee: str
    picked: str
    cost: str = ""
    fallbacks: tuple[str, ...] = field(default=())
    auto: bool = True   # "auto" may pick it (the GPU path only when asked)
    serves: Callable[[Problem], bool] | None = None  # when named (solver="..."): default `applies`

    def estimate(self, problem: Problem) -> Estimate:
        """Seconds and bytes from sizes (`budget.estimate`), before any work."""
        k = problem.n if self.name == "dense" and problem.band is not None else problem.k
        return estimate(self.name, problem.n, k=k, vectors=problem.vectors, width=problem.width,
                        n_terms=problem.n_terms if self.family == "accurate" else 0, nnz=problem.nnz,
                        accuracy=problem.accuracy,
                        one_dimensional=problem.topology in ("chain", "walled-chain", "ring", "walled-ring"),
                        chain=problem.topology == "chain",
                        ring_route=problem.ring_route)


# ------------------------------------------------------------------ when each path applies
def _standard_wide(p: Problem) -> bool:
    return not (p.vectors and (p.partial or p.band is not None))


def _dense(p: Problem) -> bool:
    return p.device == "cpu"


def _tridiagonal(p: Problem) -> bool:
    return p.n > DENSE_LIMIT and p.diagonal_mass and p.tridiagonal and _standard_wide(p)


def _banded(p: Problem) -> bool:
    if not (p.n > DENSE_LIMIT and p.diagonal_mass and not p.tridiagonal and p.width <= BAND_LIMIT
            and _standard_wide(p)):
        return False
    # a few values of a long band: its reduction to tridiagonal costs (b + 1) n^2 whatever k,
    # shift-invert O(n k), so the cheaper estimate takes it
    # (figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
    if _sparse(p):
        sizes = dict(k=p.k, vectors=p.vectors, width=p.width, nnz=p.nnz)
        return estimate("banded", p.n, **sizes).seconds <= estimate("sparse", p.n, **sizes).seconds
    return True


def _sparse(p: Problem) -> bool:
    # a band of a non-tridiagonal K~ has no count of its modes up front: the dense solve takes it
    few = (p.n_modes is not None and p.n_modes < p.n - 1) or (p.band is not None and p.width <= 1 and p.ordering is None)
    return p.n > DENSE_LIMIT and p.sparse and few


def _pencil(p: Problem) -> bool:
    return not p.diagonal_mass and p.device == "cpu"


def _bisection(p: Problem) -> bool:
    chain = p.topology in ("chain", "chain-derived")
    return (chain and p.diagonal_mass and p.tridiagonal and p.partial and p.band is None
            and p.spread > common.BISECTION_SPREAD)


def _values_path(p: Problem) -> bool:
    return p.band is None and p.n >= common.RING_VALUES_FROM


def _walled(p: Problem) -> bool:
    return p.topology == "walled-chain" and _values_path(p) and (p.few or not p.vectors or p.n > DENSE_LIMIT)


def _bidiagonal(p: Problem) -> bool:
    return p.topology == "chain" and p.diagonal_mass and not p.few


def _ring(p: Problem) -> bool:
    return p.ringlike and _values_path(p) and (p.few or not p.vectors)


def _ring_band_vectors(p: Problem) -> bool:
    return p.ringlike and p.ordering is not None and not p.few and p.vectors and p.n > common.RING_DENSE_LIMIT


def _ritz(p: Problem) -> bool:
    return p.few


def _jacobi_allowed(p: Problem) -> bool:
    return p.n <= DENSE_LIMIT or float(p.n_terms) * p.n * p.n <= common.JACOBI_WORK


def _checked(p: Problem) -> bool:
    return not p.few and _jacobi_allowed(p)


def _rayleigh(p: Problem) -> bool:
    return not p.few and not _jacobi_allowed(p)


def _gpu(p: Problem) -> bool:
    return p.device == "gpu"


def _companion(p: Problem) -> bool:
    return p.equation == "damped"


def _skew(p: Problem) -> bool:
    return p.equation == "gyroscopic" and p.definite


def _hamiltonian(p: Problem) -> bool:
    return p.equation == "gyroscopic"


def quadratic_problem(n: int, *, damped: bool, definite: bool) -> Problem:
    """The `Problem` of a quadratic eigenproblem of n dofs (all 2n eigenvalues, dense)."""
    return Problem(n=n, n_modes=None, band=None, vectors=True, accuracy="high", diagonal_mass=False, width=n,
                   ordering=None, sparse=False, nnz=n * n, n_terms=0, topology="none",
                   equation="damped" if damped else "gyroscopic", definite=definite)


def _run(name: str) -> Runner:
    """The runner of path `name`: the function of `runners` named after it."""
    run: Runner = getattr(runners, name.replace("-", "_"))
    return run


#: Every path, in order of preference within its family.
PATHS: tuple[SolverPath, ...] = (
    SolverPath("gpu", "gpu", _gpu, _run("gpu"), "absolute ~ n ε‖K̃‖",
               'only when asked, device="gpu": all modes densely on an NVIDIA GPU (CuPy)', auto=False,
               cost="n^3 on the GPU; ~5 n^2 doubles of its memory, checked first"),
    SolverPath("accurate-bisection", "accurate", _bisection, _run("accurate-bisection"),
               "relative, each bound a certificate",
               'the lowest modes of a chain whose K~ diagonal spreads over 1e4: bisection on the bidiagonal '
               'spring factor',
               cost="~5e-7 n k s values, ~1e-6 n k with vectors (compiled, SIMD lanes)"),
    SolverPath("accurate-walled", "accurate", _walled, _run("accurate-walled"), "relative, each bound a certificate",
               "a chain of 100 sites or more with springs to a wall inside it: dqds or bisection on its "
               "bidiagonal Cholesky factor, certified by Sturm counts",
               cost="~3e-8 n^2 s all values; O(n k) the lowest k"),
    SolverPath("accurate-bidiagonal", "accurate", _bidiagonal, _run("accurate-bidiagonal"),
               "relative, each bound a certificate where the a-priori one exceeds 1e-13",
               "a chain (each spring joins neighbouring sites): dqds on its bidiagonal spring factor",
               cost="~2e-8 n^2 s (dqds, and a certificate per value)"),
    SolverPath("accurate-ring", "accurate", _ring, _run("accurate-ring"), "relative, each bound a certificate",
               "a ring of 100 sites or more (free or on walls), all values or the lowest n_modes: roots "
               "between the cut chain's eigenvalues, certified by Sturm counts; at \"high\" a standard "
               "solver's values (the band solver's over 1,500 sites, shift-invert's for a few), each "
               "bracketed by two counts",
               cost="~3e-8 n^2 s all values; ~1e-7 n k the lowest k; high: the standard solve + ~5e-9 n k"),
    SolverPath("accurate-ring-band", "accurate", _ring_band_vectors, _run("accurate-ring-band"),
               "relative values (certified as accurate-ring), vectors absolute",
               "a ring over 6,000 sites with all its vectors: the band solver's vectors, the ring path's values",
               cost="the band solve with vectors, then the ring path's values"),
    SolverPath("accurate-ritz", "accurate", _ritz, _run("accurate-ritz"), "relative, bound per mode",
               "a few modes (or a band) of a large spring system: shift-invert vectors, spring-space "
               "Rayleigh-Ritz, a Kato-Temple bound per mode (a chain's values bracketed by two Sturm counts each)",
               cost="the sparse path's, + O(nnz k) spring-space products; certified: one Golub-Kahan LU per loose mode"),
    SolverPath("accurate-checked", "accurate", _checked, _run("accurate-checked"), "relative, bound per mode",
               "all modes of any other spring system up to 1,500 dofs (or rings to 6,000 sites): the dense "
               "solve, each mode checked by its residual, the low ones refined in spring space",
               fallbacks=("accurate-jacobi",),
               cost="dense eigh with vectors (~1.5e-10 n^3 s); Jacobi ~5e-10 n_terms n^2 s where it escalates"),
    SolverPath("accurate-rayleigh", "accurate", _rayleigh, _run("accurate-rayleigh"),
               "relative where the bound says so",
               "all modes of a large spring system where one-sided Jacobi would cost too much: the checked "
               "dense solve without it",
               cost="dense eigh with vectors (~1.5e-10 n^3 s, 32 n^2 bytes)"),
    SolverPath("pencil-jacobi", "pencil", lambda p: _pencil(p) and p.accuracy != "fast", _run("pencil-jacobi"),
               "relative ~ n ε (cond M_s + cond K_s) per mode",
               "a full mass matrix (generalised coordinates): the equilibrated pencil, K's and M's Cholesky "
               "factors, one-sided Jacobi (LAPACK gejsv) where K is positive definite",
               fallbacks=("pencil-cholesky",), serves=lambda p: p.device == "cpu",
               cost="~1e-9 n^3 s (two Cholesky factors, a pivoted QR, gejsv); 8 n^2 bytes a few times"),
    SolverPath("pencil-cholesky", "pencil", _pencil, _run("pencil-cholesky"),
               "absolute ~ n ε ‖L⁻¹K_sL⁻ᵀ‖",
               'a full mass matrix with accuracy="fast" (or K not positive definite): the equilibrated '
               "pencil reduced by M's Cholesky factor, LAPACK eigh",
               cost="~3e-10 n^3 s; 8 n^2 bytes a few times"),
    SolverPath("tridiagonal", "tridiagonal", _tridiagonal, _run("tridiagonal"), "absolute ~ n ε‖K̃‖",
               "a tridiagonal K~ over 1,500 dofs, all modes or values only: LAPACK stemr / stebz",
               serves=lambda p: p.diagonal_mass and p.width <= 1,
               cost="~1e-8 n^2 s all values, + 1e-7 n k s with vectors"),
    SolverPath("banded", "banded", _banded, _run("banded"), "absolute ~ n ε‖K̃‖",
               "a narrow band (a ring reordered to half-width 2, a ladder) over 1,500 dofs: LAPACK sbevd / sbevx",
               serves=lambda p: p.diagonal_mass,
               cost="~2e-9 (b + 1) n^2 s, + 1.5e-10 n^3 s with vectors"),
    SolverPath("sparse", "sparse", _sparse, _run("sparse"), "absolute ~ ε‖K̃‖",
               "a few modes (or a band of a chain) of a large sparse K: shift-invert with an inertia-checked "
               "shift (a band holding over a quarter of the modes: the dense solve)", fallbacks=("dense",),
               serves=lambda p: p.n_modes is not None or p.band is not None,
               cost="the factor (O(n) for a chain, ~20 nnz words else) + ~2e-7 n k s of Krylov iteration"),
    SolverPath("dense", "dense", _dense, _run("dense"), "absolute ~ n ε‖K̃‖",
               "anything else: LAPACK eigh on the dense K~ (a subset by index or value)",
               cost="~5e-11 n^3 s values, ~1.5e-10 n^3 s with vectors; 8 n^2 bytes"),
    SolverPath("skew-symmetric", "quadratic", _skew, None,
               "exactly real frequencies; absolute ~ ε‖A‖, small ones relative (from A⁻¹)",
               "gyroscopic (G, no C), K positive definite: Hermitian eigh of i A, A = [[0, F^T], [-F, -G~]] "
               "real skew-symmetric (a stable system never gets a spurious growth rate)",
               cost="~2e-8 n^3 s (two Hermitian solves of 2n); ~200 n^2 bytes"),
    SolverPath("hamiltonian", "quadratic", _hamiltonian, None,
               "absolute ~ ε‖A‖ cond(λ); on the imaginary axis where the mirror test proves it",
               "gyroscopic (G, no C), K indefinite or singular: geev of the Hamiltonian first-order form",
               cost="~2e-8 n^3 s (geev of 2n); ~200 n^2 bytes"),
    SolverPath("companion", "quadratic", _companion, None,
               "absolute ~ ε‖A‖ cond(λ); small ones relative (from A⁻¹) where K is definite",
               "damped (C given): geev of the first companion form [[0, I], [-K~, -(G~ + C~)]]",
               cost="~4e-8 n^3 s (geev of 2n, twice where K is definite); ~200 n^2 bytes"),
)

BY_NAME: dict[str, SolverPath] = {path.name: path for path in PATHS}

def path_names() -> tuple[str, ...]:
    """Every name a result can report: the paths and their fallbacks."""
    names = [path.name for path in PATHS]
    names += [name for path in PATHS for name in path.fallbacks if name not in names]
    return tuple(names)


def choose(problem: Problem, solver: str) -> SolverPath:
    """The path for `problem`: ``solver="auto"`` takes the first that applies among the accurate
    paths (where the springs are known and the level is not "fast") and the standard ones;
    a named family its own (raises ValueError when none of them applies)."""
    if problem.quadratic:  # (G or C: the quadratic methods, by what is given; no other family serves)
        for path in PATHS:
            if path.family == "quadratic" and (solver in ("auto", path.name)) and path.applies(problem):
                return path
        served = [path.name for path in PATHS if path.family == "quadratic" and path.applies(problem)]
        raise ValueError(f"solver={solver!r} cannot serve this quadratic eigenproblem: "
                         f"expected 'auto' or one of {served}")
    if problem.device == "gpu":
        return BY_NAME["gpu"]
    if solver == "auto":
        families = ("accurate",) if problem.topology not in ("none", "chain-derived") else ()
        families += ("pencil", "tridiagonal", "banded", "sparse", "dense")
        candidates = [path for path in PATHS if path.family in families and path.auto]
        if problem.topology == "chain-derived":  # a chain given as K: bisection where it is spread
            candidates.insert(0, BY_NAME["accurate-bisection"])
        for path in candidates:
            if path.applies(problem):
                return path
    else:
        for path in PATHS:
            if path.family == solver and (path.serves or path.applies)(problem):
                return path
    raise ValueError(f"solver={solver!r} cannot serve this request")


def readme_table() -> str:
    """The README's table of solver paths, one line per registered path (tested against it)."""
    lines = ["| path | picked when | cost (one core) | guarantee |", "| --- | --- | --- | --- |"]
    for path in PATHS:
        name = f"`{path.name}`" + "".join(f" (or `{other}`)" for other in path.fallbacks)
        lines.append(f"| {name} | {path.picked} | {path.cost} | {path.guarantee} |")
    return "\n".join(lines)
