"""The registry of solver paths: the one place that declares each path and decides which serves a request.

A request is first described as a `problem.Problem` (sizes, what is asked, the accuracy level
and the shape of the springs, `topology.classify`: all from the pattern and the sizes, O(nnz),
before any work). Each `SolverPath` is one declaration: its name (what a result reports), when
it `applies` to a problem, what it costs (`estimate`: seconds and bytes from sizes, with the
measured rates of `budget`, never from the clock) and how it runs (`run`, a function of
`runners`). `PATHS` lists them in order of preference: for ``solver="auto"`` the first that
applies on the problem's device and equation is taken (an accurate path only where the springs are known), or its
declared `rival` where that applies too and its estimate is the smaller (the only choice by cost); a named family
(``solver="sparse"``) takes its own. `dispatch.plan` and `dispatch.solve`, `quadratic_modes`, ``vibra validate``, the
budget guard and the README's table all read this registry; nothing else branches on path names.

A path may name `fallbacks`: what it reports when a check on its own result (never the clock) hands the modes on
(``accurate-checked`` becomes ``accurate-jacobi`` when a bound still misses 1e-10 after spring-space Rayleigh-Ritz).
Costs (n dofs, k modes, b half-bandwidth; `budget`'s rates, measured on one ~3 GHz core with OpenBLAS, rounded
up): memory beyond the input, then time, in each path's cost function; a `band` is priced as 64 modes."""

from __future__ import annotations

from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any, Callable

import vibra.solvers.common as common
import vibra.solvers.runners as runners
from vibra.solvers.accuracy import relative
from vibra.solvers.budget import (
    ARNOLDI_S, BANDED_S, BISECTION_VALUES_S, BISECTION_VECTORS_S, CERTIFY_BYTES, CERTIFY_S, CHECK_CALL_S,
    CHECK_FORM_S, CHECK_TERM_S, COMPANION_S, DENSE_FORM_S, DENSE_VALUES_S, JACOBI_FALLBACK_S, DENSE_VECTORS_S,
    GPU_VALUES_S, GPU_VECTORS_S, HAMILTONIAN_S, JACOBI_S, KRYLOV_RITZ_S, LANCZOS_S, MP_COUNT_S, RING_COUNTED_S,
    RING_MP_EXPECTED, RING_MP_SITES, RING_S, SKEW_S, SOLID_SEPARATOR, SPARSE_ENTRY_S, SPARSE_FACTOR_ENTRIES,
    SPARSE_FACTOR_S, SPARSE_SOLVE_S, SUPERLU_SLOWER, TRIDIAGONAL_S, TRIDIAGONAL_VECTORS_S, TRIPLET_ROW,
    TRIPLET_UNIT_S, Estimate, block_krylov_seconds, memory_limit, refinement_seconds,
)
from vibra.solvers.common import BAND_LIMIT, DENSE_LIMIT, SolveResult
from vibra.solvers.distributed.slepc import ranks as slepc_ranks, slepc_cost
from vibra.solvers.accurate.gk_bisection import DSTEBZ_S, compiled_bisection_pays
from vibra.solvers.problem import Problem, quadratic_problem
from vibra.solvers.standard.cholmod import sparse_backend
from vibra.solvers.standard.hermitian import BLOCH_EXTRAS, stack_cost
from vibra.solvers.standard.sparse import BLOCK_FILL
from vibra.solvers.standard.iterative import ITERATIVE_FROM, iterative_cost, most_modes

__all__ = ["Problem", "SolverPath", "PATHS", "BY_NAME", "choose", "estimate", "path_names", "quadratic_problem",
           "readme_table"]

Runner = Callable[[Problem, Any], Any]


@dataclass(frozen=True)
class SolverPath:
    """One solver path, declared once: its name (what `Modes.path` reports), the `solver=`
    family that selects it, when it applies, what it costs, how it runs, and its table entry.

    `run(problem, inputs)` is a function of `runners`: `runners.Inputs` for the symmetric paths, `structured.first_order.Reduced`
    for the quadratic ones. `weighted`: it runs on K~ = M^-1/2 K M^-1/2 (`dispatch.solve` forms it; False: K and M as given);
    `springs`: it takes the spring factor (B, w) where one is given. `device`: where it runs. `serves`: when a named family
    (solver="...") may take it (default `applies`).
    `rival`: the name of a path declared before it that serves the same requests another way; where both apply (and
    `weighs` the request, if given), ``solver="auto"`` takes the one with the smaller estimated time (`choose`)."""

    name: str
    family: str
    applies: Callable[[Problem], bool]
    estimate: Callable[[Problem], Estimate]
    run: Runner
    guarantee: str
    picked: str
    cost: str = ""
    fallbacks: tuple[str, ...] = field(default=())
    device: str = "cpu"
    weighted: bool = True
    springs: bool = False
    serves: Callable[[Problem], bool] | None = None
    rival: str = ""
    weighs: Callable[[Problem], bool] | None = None

    def reported(self, result: SolveResult) -> str:
        """The name a result of this path reports: its own, or the declared fallback its runner took."""
        return result.solver if result.solver in self.fallbacks else self.name


# ------------------------------------------------------------------ what each path costs
def _made(name: str, p: Problem, memory: float, seconds: float, k: int | None = None) -> Estimate:
    k = p.k if k is None else k
    what = f"{'all ' if k == p.n else ''}{k} mode{'s' if k != 1 else ''} of {p.n} dofs" + (
        ", with vectors" if p.vectors else ", frequencies only")
    return Estimate(name, memory, seconds, what)


def _refined(p: Problem, seconds: float, *, chain: bool = False) -> float:
    """`seconds` plus what an accurate path with a spring factor may add after its solve
    (`budget.refinement_seconds`: the singular-triplet step, a ring's certifying counts)."""
    if not p.n_terms:
        return seconds
    return seconds + refinement_seconds(p.n, p.n_terms, k=p.k, accuracy=p.accuracy,
                                        one_dimensional=p.one_dimensional, chain=chain, loose=p.loose)


def _dense_parts(p: Problem, k: int, vectors: bool) -> tuple[float, float]:
    """LAPACK eigh of the dense K~: 8 n^2 bytes (twice with vectors) + 8 n k; DENSE_VALUES_S n^3
    for values, + (DENSE_VECTORS_S - DENSE_VALUES_S) k n^2 with k vectors, + DENSE_FORM_S n^2."""
    n, n2 = p.n, float(p.n) * p.n
    memory = 8.0 * n2 * (2 if vectors else 1) + (8.0 * n * k if vectors else 0.0) + 8.0 * 26 * n
    seconds = DENSE_FORM_S * n2 + (((DENSE_VECTORS_S - DENSE_VALUES_S) * k / n + DENSE_VALUES_S) * n2 * n if vectors else DENSE_VALUES_S * n2 * n)
    return memory, seconds


def _dense_cost(p: Problem) -> Estimate:
    k = p.n if p.band is not None else p.k  # (a band: all values, then those inside it)
    return _made("dense", p, *_dense_parts(p, k, p.vectors), k)


def _gpu_cost(p: Problem) -> Estimate:
    """The host's copies as on the dense path (the GPU's own memory is checked on the device,
    `standard.gpu.check_gpu_memory`), cuSOLVER syevd's time."""
    memory, _ = _dense_parts(p, p.k, p.vectors)
    return _made("gpu", p, memory, (GPU_VECTORS_S if p.vectors else GPU_VALUES_S) * float(p.n) ** 3)


def _tridiagonal_parts(p: Problem, *, certify: bool = False) -> tuple[float, float]:
    """LAPACK stemr / stebz (and the dqds + MRRR pairing) allocate all n vectors unless a subset
    is asked: O(n), 8 n^2 with all vectors; TRIDIAGONAL_S n^2 for all values (60 n k for a few),
    + TRIDIAGONAL_VECTORS_S n k with vectors. `certify`: every value's triplet certificate too."""
    n, k, n2 = p.n, p.k, float(p.n) * p.n
    memory = 8.0 * 12 * n + (8.0 * n2 if p.vectors and k == n else (8.0 * n * k if p.vectors else 0.0))
    if certify:  # dqds of all values, each certified (`triplets`): ~1.3 kB per site
        memory += CERTIFY_BYTES * n
        values_s = (TRIDIAGONAL_S + CERTIFY_S) * n2
    else:
        values_s = TRIDIAGONAL_S * (n2 if k == n else 60.0 * n * k)
    return memory, values_s + (TRIDIAGONAL_VECTORS_S * n * k if p.vectors else 0.0)


def _tridiagonal_cost(p: Problem) -> Estimate:
    return _made("tridiagonal", p, *_tridiagonal_parts(p))


def _bidiagonal_cost(p: Problem) -> Estimate:
    return _made("accurate-bidiagonal", p, *_tridiagonal_parts(p, certify=True))


def _banded_parts(p: Problem, vectors: bool) -> tuple[float, float]:
    """LAPACK sbevd / sbevx (a ring: b = 2): 24 (b + 1) n bytes, + 8 n^2 with vectors; the band's
    reduction BANDED_S (b + 1) n^2, then its values as on the tridiagonal path (a subset by
    bisection), + DENSE_VECTORS_S n^3 with vectors."""
    n, k, n2 = p.n, p.k, float(p.n) * p.n
    memory = 8.0 * (p.width + 1) * n * 3 + (8.0 * n2 + 8.0 * n * k if vectors else 0.0)
    values_s = TRIDIAGONAL_S * (n2 if k == n else 60.0 * n * k)
    return memory, BANDED_S * (p.width + 1) * n2 + values_s + (DENSE_VECTORS_S * n2 * n if vectors else 0.0)


def _banded_cost(p: Problem) -> Estimate:
    return _made("banded", p, *_banded_parts(p, p.vectors))


def _ring_band_cost(p: Problem) -> Estimate:
    """The band solve with vectors, then the ring path's values (RING_S n^2)."""
    memory, seconds = _banded_parts(p, p.vectors)
    return _made("accurate-ring-band", p, memory, seconds + RING_S * (float(p.n) * p.n))


def _sparse_parts(p: Problem) -> tuple[float, float]:
    """Shift-invert: ARPACK's restarted basis for a narrow band (a chain, a ring reordered: a cheap factor), the block
    Krylov basis (max(10 k, 200) columns booked) for any other; (columns + 2k + 3) n words + the factor: O(n) for a
    tridiagonal K~ (pttrf), ~20 nnz (SuperLU fill) for a band; LANCZOS_S n columns per Lanczos run. A 3-D network
    (half-bandwidth over BAND_LIMIT) by the top separator w of its nested-dissection order (`Problem.separator`;
    SOLID_SEPARATOR n^(2/3) where its graph was not at hand): SPARSE_FACTOR_ENTRIES w^2 entries, SPARSE_FACTOR_S w^3
    to factor, SPARSE_ENTRY_S per stored entry, `budget.block_krylov_seconds` (SPARSE_SOLVE_S w^2 a column); a solid
    n^2, a shell (a capsid) n^1.5; SUPERLU_SLOWER for SuperLU's LU. Under BLOCK_FILL entries a row: ARPACK."""
    n, k = p.n, p.k
    w = float(p.separator) if p.separator else SOLID_SEPARATOR * float(n) ** (2.0 / 3.0)
    arpack = p.width <= BAND_LIMIT or 2.0 * SPARSE_FACTOR_ENTRIES * w * w < BLOCK_FILL * n  # (`sparse.shift_invert`)
    columns = max(2 * k + 1, 20) if arpack else min(n, max(10 * k, 200))
    basis, ritz = 8.0 * (columns + 2 * k + 3) * n, KRYLOV_RITZ_S * n * k * k
    if p.width <= BAND_LIMIT:
        return basis + (8.0 * 4 * n if p.width <= 1 else 12.0 * 20 * max(p.nnz, n)), LANCZOS_S * n * columns * 10 + ritz
    lu = SUPERLU_SLOWER if sparse_backend(n) == "superlu" else 1.0
    memory = basis + 12.0 * (SPARSE_FACTOR_ENTRIES * w * w * lu + max(p.nnz, n))
    seconds = SPARSE_ENTRY_S * max(p.nnz, n) + lu * SPARSE_FACTOR_S * w ** 3 + ritz
    solves = LANCZOS_S * n * columns * 10 + ARNOLDI_S * n * columns ** 2 if arpack else block_krylov_seconds(
        n, k, lu * SPARSE_SOLVE_S * w * w, probe=not (p.coordinates and p.free and p.parts == 1))  # (rigid modes known)
    return memory, seconds + solves


def _sparse_cost(p: Problem) -> Estimate:
    return _made("sparse", p, *_sparse_parts(p))


def _slepc_cost(p: Problem) -> Estimate:
    """`distributed.slepc.slepc_cost` (start-up, hand-off files, MUMPS's factor, shifted solves) on ``VIBRA_MPI_RANKS`` ranks."""
    return _made("slepc", p, *slepc_cost(p.n, p.nnz, p.k, slepc_ranks()))


def _ritz_cost(p: Problem) -> Estimate:
    """The sparse path's, + the spring-space Ritz (as `_check_seconds`, K~ not formed), + "certified"'s refinement."""
    memory, seconds = _sparse_parts(p)
    seconds += CHECK_CALL_S + CHECK_TERM_S * float(p.n_terms) * (p.k + 1)
    return _made("accurate-ritz", p, memory, _refined(p, seconds, chain=p.topology == "chain"))


def _iterative_cost(name: str, device: str) -> Callable[[Problem], Estimate]:
    """LOBPCG with the multigrid preconditioner on `device` (`iterative.iterative_cost`: O(nnz) bytes, O(nnz k) s an iteration)."""
    return lambda p: _made(name, p, *iterative_cost(p.n, p.nnz, p.k, coordinates=p.coordinates, device=device))


def _accurate_iterative_cost(p: Problem) -> Estimate:
    """The iterative path's (a mode more, to `RITZ_TOLERANCE`), spring-space Ritz (O(nnz k); "high" 1.4 to 1.9 times "fast",
    RESULTS.md "'High' on the iterative path"), "certified"'s refinement."""
    memory, seconds = iterative_cost(p.n, p.nnz, p.k + 1, coordinates=p.coordinates)
    return _made("accurate-iterative", p, memory, _refined(p, 1.4 * seconds))


def _bisection_cost(p: Problem) -> Estimate:
    """Sturm bisection on the 2n Golub-Kahan tridiagonal (compiled, in SIMD lanes), inverse
    iteration (dstein), the certificates' double-double residuals in blocks (measured peak ~430 n
    bytes); + DSTEBZ_S n k where dstebz takes the values (`gk_bisection.compiled_bisection_pays`)."""
    n, k = p.n, p.k
    seconds = (BISECTION_VECTORS_S if p.vectors else BISECTION_VALUES_S) * n * k
    if not compiled_bisection_pays(n, k):
        seconds += DSTEBZ_S * n * k
    return _made("accurate-bisection", p, 8.0 * 64 * n + (8.0 * n * k if p.vectors else 0.0), seconds)


def _counted_parts(p: Problem, walled: bool) -> tuple[float, float]:
    """A ring's (or a walled chain's) values: the cut chain's values (dqds, or bisection for the
    lowest k + 1 when cheaper), then each value's roots of its spring form and counts (~2.5
    double-double counts of 2n nodes per value, RING_S n k), ~40 n words; "certified": at most
    RING_MP_SITES sites of mpmath counts. With vectors: stemr's for all of a walled chain's, else a
    Golub-Kahan LU per mode (`golub_kahan.singular_vectors`)."""
    n, k, n2 = p.n, p.k, float(p.n) * p.n
    memory = 8.0 * 40 * n + (8.0 * n * k if p.vectors else 0.0)
    poles = TRIDIAGONAL_S * n2 if k >= n - 1 else min(TRIDIAGONAL_S * n2, BISECTION_VALUES_S * n * (k + 1.0))
    seconds = poles + RING_S * float(n) * k
    if p.accuracy == "certified":  # (mpmath counts: "high" stops at 1e-10, which the dd counts meet)
        seconds += MP_COUNT_S * min(RING_MP_SITES, RING_MP_EXPECTED * n)
    if p.vectors and walled and k >= n - 1:
        memory += 8.0 * 12 * n
        seconds += TRIDIAGONAL_VECTORS_S * n * k
    elif p.vectors:
        seconds += TRIPLET_UNIT_S * TRIPLET_ROW * 2.0 * n * k
    return memory, seconds


def _ring_cost(p: Problem) -> Estimate:
    """At "high" from a standard solver (`p.ring_route`, `ring.counted`): shift-invert's values
    (a few), each bracketed by ~2 counts per level, or the band solver's (all), each by two
    counts of K - x M; else the ring's own values path (`_counted_parts`)."""
    route = p.ring_route
    if route == "sparse":
        memory, seconds = _sparse_parts(p)
        return _made("accurate-ring", p, memory, seconds + RING_S * float(p.n) * p.k)
    if route == "banded":
        memory, seconds = _banded_parts(p, False)
        return _made("accurate-ring", p, memory + 8.0 * 12 * p.n, seconds + RING_COUNTED_S * float(p.n) * p.k)
    return _made("accurate-ring", p, *_counted_parts(p, walled=False))


def _walled_cost(p: Problem) -> Estimate:
    return _made("accurate-walled", p, *_counted_parts(p, walled=True))


def _pencil_jacobi_cost(p: Problem) -> Estimate:
    """M's and K's equilibrated Cholesky factors, then gejsv on n x n: 8 n^2 bytes a few times."""
    n2 = float(p.n) * p.n
    return _made("pencil-jacobi", p, 8.0 * n2 * 6, (JACOBI_S + DENSE_VECTORS_S) * n2 * p.n)


def _pencil_cholesky_cost(p: Problem) -> Estimate:
    """M's equilibrated Cholesky factor, then eigh of L^-1 K L^-T."""
    n2 = float(p.n) * p.n
    return _made("pencil-cholesky", p, 8.0 * n2 * 6, DENSE_VECTORS_S * 2 * n2 * p.n)


def _check_seconds(p: Problem) -> float:
    """The spring-space check of `springs.checked_dense` beyond its dense solve: CHECK_CALL_S, +
    CHECK_TERM_S per spring term and mode checked (k + 1), + CHECK_FORM_S n^2 (K~ formed dense)."""
    return CHECK_CALL_S + CHECK_TERM_S * float(p.n_terms) * min(p.k + 1, p.n) + CHECK_FORM_S * float(p.n) * p.n


def _rayleigh_cost(p: Problem) -> Estimate:
    """K~ (its vectors in place), divide and conquer's 2 n^2 work space, the mass-weighted K: 32 n^2
    bytes; as dense with vectors, + the check (`_check_seconds`), + the refinement."""
    n2 = float(p.n) * p.n
    return _made("accurate-rayleigh", p, 8.0 * n2 * 4, _refined(p, DENSE_VECTORS_S * n2 * p.n + _check_seconds(p)))


def _checked_cost(p: Problem) -> Estimate:
    """Time as the dense solve with vectors and its check (`_check_seconds`), + one-sided Jacobi
    where loose bounds are expected (`Problem.loose`: its fallback, JACOBI_FALLBACK_S n_terms n^2),
    + the refinement; memory the larger of the dense solve's and Jacobi's (gejsv of the
    n_terms x n B~: 24 n (n_terms + n), + 8 n^2 with vectors), which a loose bound may run on any
    input."""
    n, k = p.n, p.k
    fast_memory, fast_seconds = _dense_parts(p, min(k + 1, n), True)
    rows = max(p.n_terms, n)
    jacobi_memory = 8.0 * rows * n * 3 + (8.0 * (float(n) * n) if p.vectors else 0.0)
    fast_seconds += _check_seconds(p)
    if p.loose:
        fast_seconds += JACOBI_FALLBACK_S * float(rows) * n * n
    return _made("accurate-checked", p, max(fast_memory, jacobi_memory), _refined(p, fast_seconds))


def _bloch_cost(p: Problem) -> Estimate:
    """`hermitian.stack_cost`: a crystal's D(q) at `p.batch` wave vectors, from `p.nnz` entries each."""
    memory, seconds = stack_cost(p.n, p.batch, p.nnz, p.vectors)
    return Estimate("hermitian-eigh", memory, seconds, f"{p.n} branches at {p.batch:,} q-point"
                    f"{'s' if p.batch != 1 else ''}, {'with vectors' if p.vectors else 'frequencies only'}")


def _first_order_cost(name: str, rate: float) -> Callable[[Problem], Estimate]:
    """The first-order form of 2n (`structured.first_order`): complex vectors of 2n, twice, ~200 n^2
    bytes; `rate` n^3 (two Hermitian solves of 2n, or one or two geev)."""
    def cost(p: Problem) -> Estimate:
        n2 = float(p.n) * p.n
        return _made(name, p, 200.0 * n2, rate * n2 * p.n)
    return cost


def estimate(path: str, n: int, *, k: int, vectors: bool, width: int = 1, n_terms: int = 0, nnz: int = 0,
             accuracy: str = "high", topology: str | None = None, separator: int = 0, coordinates: bool = False) -> Estimate:
    """Memory and time of the path named `path` computing `k` of `n` modes (with vectors or not) at
    `accuracy`, from sizes alone: its declaration's `estimate` on that request (`topology`: "network"
    where `n_terms` springs are given, else "none"; `separator`: `topology.separator_width` of K,
    0 for a 3-D solid's; `coordinates`: the sites' positions given)."""
    shape = topology if topology is not None else ("network" if n_terms else "none")
    problem = Problem(n=n, n_modes=None if k >= n else k, band=None, vectors=vectors, accuracy=accuracy,
                      diagonal_mass=True, width=width, ordering=None, sparse=True, nnz=nnz, n_terms=n_terms,
                      topology=shape, separator=separator, coordinates=coordinates)
    return BY_NAME[path].estimate(problem)


# ------------------------------------------------------------------ when each path applies
def _standard_wide(p: Problem) -> bool:
    return not (p.vectors and (p.partial or p.band is not None))


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
        return _banded_cost(p).seconds <= _sparse_cost(p).seconds
    return True


def _sparse(p: Problem) -> bool:
    # a band of a non-tridiagonal K~ has no count of its modes up front: the dense solve takes it
    few = (p.n_modes is not None and p.n_modes < p.n - 1) or (p.band is not None and p.width <= 1 and p.ordering is None)
    return (p.n > DENSE_LIMIT or p.weighed) and p.sparse and few


def _iterative(p: Problem) -> bool:
    # a few of the lowest modes of a large 3-D network (a chain's or a ring's band is narrow), whose springs and masses
    # do not spread over decades (`Problem.loose`: there LOBPCG's residuals stall short of 1e-8; the factorisation serves)
    return _sparse(p) and _serves_iterative(p) and p.width > BAND_LIMIT and p.n >= ITERATIVE_FROM and not p.loose


def _serves_iterative(p: Problem) -> bool:  # (solver="iterative": the lowest n_modes of a diagonal-mass problem)
    return p.partial and p.band is None and p.diagonal_mass and p.n_modes <= most_modes(p.n)  # type: ignore[operator]


def _pencil(p: Problem) -> bool:
    return not p.diagonal_mass


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
    return p.springs and (p.few or p.weighed)


def _accurate_iterative(p: Problem) -> bool:
    return _ritz(p) and p.topology == "network" and _iterative(p) and p.n_modes is not None and p.n_modes <= most_modes(p.n, 1)


def _jacobi_allowed(p: Problem) -> bool:
    return p.n <= DENSE_LIMIT or float(p.n_terms) * p.n * p.n <= common.JACOBI_WORK


def _checked(p: Problem) -> bool:
    return p.springs and not p.few and _jacobi_allowed(p)


def _rayleigh(p: Problem) -> bool:
    return p.springs and not p.few and not _jacobi_allowed(p)


def _anything(p: Problem) -> bool:
    return True


def _companion(p: Problem) -> bool:
    return p.equation == "damped"


def _skew(p: Problem) -> bool:
    return p.equation == "gyroscopic" and p.definite


def _hamiltonian(p: Problem) -> bool:
    return p.equation == "gyroscopic"


#: Every path, in order of preference.
PATHS: tuple[SolverPath, ...] = (
    SolverPath("gpu", "dense", _anything, _gpu_cost, runners.gpu, "absolute ~ n ε‖K̃‖",
               'only when asked, device="gpu": all modes densely on an NVIDIA GPU (CuPy)', device="gpu",
               weighted=False, cost="n^3 on the GPU; ~5 n^2 doubles of its memory, checked first"),
    SolverPath("iterative-gpu", "iterative", _iterative, _iterative_cost("iterative-gpu", "gpu"), runners.iterative_gpu, "absolute ~ 1e-8 ‖K̃‖",
               'device="gpu", where the iterative path applies and its estimate is under the dense GPU solve\'s: its LOBPCG '
               "and multigrid cycle on the GPU (CuPy, cuSPARSE), the hierarchy built on the host", device="gpu", rival="gpu",
               serves=_serves_iterative, cost="the iterative path's setup on the host, + its iterations at ~2e-12 s per entry and column"),
    SolverPath("accurate-bisection", "accurate", _bisection, _bisection_cost, runners.accurate_bisection,
               "relative, each bound a certificate",
               'the lowest modes of a chain whose K~ diagonal spreads over 1e4: bisection on the bidiagonal '
               'spring factor', springs=True,
               cost="~5e-7 n k s values, ~1e-6 n k with vectors (compiled, SIMD lanes)"),
    SolverPath("accurate-walled", "accurate", _walled, _walled_cost, runners.accurate_walled,
               "relative, each bound a certificate",
               "a chain of 100 sites or more with springs to a wall inside it: dqds or bisection on its "
               "bidiagonal Cholesky factor, certified by Sturm counts", springs=True,
               cost="~3e-8 n^2 s all values; O(n k) the lowest k"),
    SolverPath("accurate-bidiagonal", "accurate", _bidiagonal, _bidiagonal_cost, runners.accurate_bidiagonal,
               "relative, each bound a certificate where the a-priori one exceeds 1e-13",
               "a chain (each spring joins neighbouring sites): dqds on its bidiagonal spring factor", springs=True,
               cost="~2e-8 n^2 s (dqds, and a certificate per value)"),
    SolverPath("accurate-ring", "accurate", _ring, _ring_cost, runners.accurate_ring, "relative, each bound a certificate",
               "a ring of 100 sites or more (free or on walls), all values or the lowest n_modes: roots "
               "between the cut chain's eigenvalues, certified by Sturm counts; at \"high\" a standard "
               "solver's values (the band solver's over 1,500 sites, shift-invert's for a few), each "
               "bracketed by two counts", springs=True,
               cost="~3e-8 n^2 s all values; ~1e-7 n k the lowest k; high: the standard solve + ~5e-9 n k"),
    SolverPath("accurate-ring-band", "accurate", _ring_band_vectors, _ring_band_cost, runners.accurate_ring_band,
               "relative values (certified as accurate-ring), vectors absolute",
               "a ring over 6,000 sites with all its vectors: the band solver's vectors, the ring path's values",
               springs=True, cost="the band solve with vectors, then the ring path's values"),
    SolverPath("accurate-ritz", "accurate", _ritz, _ritz_cost, runners.accurate_ritz, "relative, bound per mode",
               "a few modes (or a band) of a large spring system: shift-invert vectors, spring-space "
               "Rayleigh-Ritz, a Kato-Temple bound per mode (a chain's values bracketed by two Sturm counts each)",
               springs=True,
               cost="the sparse path's, + O(nnz k) spring-space products; certified: one Golub-Kahan LU per loose mode"),
    SolverPath("accurate-iterative", "accurate", _accurate_iterative, _accurate_iterative_cost,
               runners.accurate_iterative, "relative, bound per mode",
               "as accurate-ritz, on a large 3-D network where its estimate is the smaller: the iterative "
               "path's vectors (one more mode), spring-space Rayleigh-Ritz, a Kato-Temple bound per mode",
               springs=True, rival="accurate-ritz",
               cost="the iterative path's, + O(nnz k) spring-space products"),
    SolverPath("accurate-checked", "accurate", _checked, _checked_cost, runners.accurate_checked,
               "relative, bound per mode",
               "all modes of any other spring system up to 1,500 dofs (or rings to 6,000 sites), or a few where its "
               "estimate is under accurate-ritz's (a 3-D network of 900 to 1,500 dofs): the dense solve, each mode checked by its residual, the low ones refined in spring space",
               fallbacks=("accurate-jacobi",), springs=True, rival="accurate-ritz", weighs=attrgetter("weighed"),
               cost="dense eigh with vectors (~1.5e-10 n^3 s); Jacobi ~5e-10 n_terms n^2 s where it escalates"),
    SolverPath("accurate-rayleigh", "accurate", _rayleigh, _rayleigh_cost, runners.accurate_rayleigh,
               "relative where the bound says so",
               "all modes of a large spring system where one-sided Jacobi would cost too much: the checked "
               "dense solve without it", springs=True,
               cost="dense eigh with vectors (~1.5e-10 n^3 s, 32 n^2 bytes)"),
    SolverPath("pencil-jacobi", "pencil", lambda p: _pencil(p) and relative(p.accuracy), _pencil_jacobi_cost,
               runners.pencil_jacobi, "relative ~ n ε (cond M_s + cond K_s) per mode",
               "a full mass matrix (generalised coordinates): the equilibrated pencil, K's and M's Cholesky "
               "factors, one-sided Jacobi (LAPACK gejsv) where K is positive definite",
               fallbacks=("pencil-cholesky",), serves=_anything, weighted=False,
               cost="~1e-9 n^3 s (two Cholesky factors, a pivoted QR, gejsv); 8 n^2 bytes a few times"),
    SolverPath("pencil-cholesky", "pencil", _pencil, _pencil_cholesky_cost, runners.pencil_cholesky,
               "absolute ~ n ε ‖L⁻¹K_sL⁻ᵀ‖",
               'a full mass matrix with accuracy="fast" (or K not positive definite): the equilibrated '
               "pencil reduced by M's Cholesky factor, LAPACK eigh", weighted=False,
               cost="~3e-10 n^3 s; 8 n^2 bytes a few times"),
    SolverPath("tridiagonal", "tridiagonal", _tridiagonal, _tridiagonal_cost, runners.tridiagonal,
               "absolute ~ n ε‖K̃‖", "a tridiagonal K~ over 1,500 dofs, all modes or values only: LAPACK stemr / stebz",
               serves=lambda p: p.diagonal_mass and p.width <= 1,
               cost="~1e-8 n^2 s all values, + 1e-7 n k s with vectors"),
    SolverPath("banded", "banded", _banded, _banded_cost, runners.banded, "absolute ~ n ε‖K̃‖",
               "a narrow band (a ring reordered to half-width 2, a ladder) over 1,500 dofs: LAPACK sbevd / sbevx",
               serves=lambda p: p.diagonal_mass,
               cost="~2e-9 (b + 1) n^2 s, + 1.5e-10 n^3 s with vectors"),
    SolverPath("sparse", "sparse", _sparse, _sparse_cost, runners.sparse, "absolute ~ ε‖K̃‖",
               "a few modes (or a band of a chain) of a large sparse K: shift-invert with an inertia-checked "
               "shift (a band holding over a quarter of the modes: the dense solve)", fallbacks=("dense",),
               serves=lambda p: p.n_modes is not None or p.band is not None, springs=True,
               cost="the factor (O(n) for a chain, ~20 nnz words for a band); a 3-D network by its top separator w (K's widest "
                    "breadth-first level): ~6e-11 w^3 s to factor, ~1.4e-9 w^2 s per Krylov column (~3k + 40 of them), "
                    "~1.5e-9 n s per column squared to reorthogonalise, ~4 w^2 words"),
    SolverPath("slepc", "slepc", lambda p: False, _slepc_cost, runners.slepc, "absolute ~ ε‖K̃‖, every residual checked",
               'only when asked, solver="slepc": the lowest n_modes of a large sparse K on SLEPc over MPI '
               "(Krylov-Schur, shift-and-invert by MUMPS) in a separate program, ranks from VIBRA_MPI_RANKS",
               serves=lambda p: p.partial and p.band is None and p.diagonal_mass and p.n_modes < p.n - 1,  # type: ignore[operator]
               cost="~1.5 s start + two factors (~1.2e-8 n^2 s each for a 3-D network) + ~2e-7 n^(4/3) s a shifted solve"),
    SolverPath("iterative", "iterative", _iterative, _iterative_cost("iterative", "cpu"), runners.iterative, "absolute ~ 1e-8 ‖K̃‖",
               "a few of the lowest modes of a large 3-D network where its estimate is under the "
               "factorisation's: LOBPCG, smoothed-aggregation multigrid (its first level the rigid motions of groups of sites where the coordinates are given), the known rigid-body modes deflated, every "
               "residual checked", rival="sparse", serves=_serves_iterative,
               cost="~3e-7 nnz s setup, + ~13 (n / 1e4)^0.52 iterations of 9 products with a block of 4k columns (1.3e-10 s per entry and column, on 2 cores); with the coordinates ~10.4 (n / 1e4)^0.38 iterations of 10 products; ~33 nnz + 512 n k bytes"),
    SolverPath("dense", "dense", _anything, _dense_cost, runners.dense, "absolute ~ n ε‖K̃‖",
               "anything else, and a few modes of a 3-D network from 900 dofs where its estimate is under the "
               "shift-invert's: LAPACK eigh on the dense K~ (a subset by index or value)", rival="sparse", weighs=attrgetter("weighed"),
               cost="~8e-11 n^3 s values, ~1.5e-10 n^3 s with all vectors; 8 n^2 bytes"),
    SolverPath("hermitian-eigh", "bloch", _anything, _bloch_cost, runners.hermitian, "absolute ~ n ε‖D(q)‖ per q; at "
               "\"high\" a spring model's q-points near Γ relative, ε-level", "a crystal's D(q) at a batch of wave "
               "vectors (`vibra.crystals`): stacked LAPACK heevd in chunks of ~1 MiB; at \"high\" a spring model's q-points "
               "whose bound misses 1e-10 re-solved as the singular values of their spring factor; a polar crystal's "
               "D(q) corrected first", weighted=False, cost="per q: ~5e-10 n^3 + 4e-8 n^2 s (2.5 times with vectors) + "
               "2e-9 s per force-constant entry", fallbacks=tuple(f"hermitian-eigh + {how}" for how in BLOCH_EXTRAS)),
    SolverPath("skew-symmetric", "quadratic", _skew, _first_order_cost("skew-symmetric", SKEW_S),
               runners.skew_symmetric,
               "exactly real frequencies; absolute ~ ε‖A‖, small ones relative (from A⁻¹)",
               "gyroscopic (G, no C), K positive definite: Hermitian eigh of i A, A = [[0, F^T], [-F, -G~]] "
               "real skew-symmetric (a stable system never gets a spurious growth rate)", weighted=False,
               cost="~2e-8 n^3 s (two Hermitian solves of 2n); ~200 n^2 bytes"),
    SolverPath("hamiltonian", "quadratic", _hamiltonian, _first_order_cost("hamiltonian", HAMILTONIAN_S),
               runners.hamiltonian,
               "absolute ~ ε‖A‖ cond(λ); on the imaginary axis where the mirror test proves it",
               "gyroscopic (G, no C), K indefinite or singular: geev of the Hamiltonian first-order form",
               weighted=False, cost="~2e-8 n^3 s (geev of 2n); ~200 n^2 bytes"),
    SolverPath("companion", "quadratic", _companion, _first_order_cost("companion", COMPANION_S), runners.companion,
               "absolute ~ ε‖A‖ cond(λ); small ones relative (from A⁻¹) where K is definite",
               "damped (C given): geev of the first companion form [[0, I], [-K~, -(G~ + C~)]]", weighted=False,
               cost="~4e-8 n^3 s (geev of 2n, twice where K is definite); ~200 n^2 bytes"),
)

BY_NAME: dict[str, SolverPath] = {path.name: path for path in PATHS}


def path_names() -> tuple[str, ...]:
    """Every name a result can report: the paths and their fallbacks."""
    names = [path.name for path in PATHS]
    names += [name for path in PATHS for name in path.fallbacks if name not in names]
    return tuple(names)


def choose(problem: Problem, solver: str) -> SolverPath:
    """The path for `problem`, among those for its device and equation (the symmetric paths, the
    quadratic ones for G or C, the crystals' for D(q)): ``solver="auto"`` takes the first that applies, a named family
    its own, each weighed against its rivals (`_cheaper_rival`; a quadratic method by its name). Raises ValueError."""
    serving = [path for path in PATHS if path.device == problem.device and (path.family == "quadratic") == problem.quadratic
               and (path.family == "bloch") == (problem.equation == "bloch")]
    if problem.quadratic:
        for path in serving:
            if solver in ("auto", path.name) and path.applies(problem):
                return path
        served = [path.name for path in serving if path.applies(problem)]
        raise ValueError(f"solver={solver!r} cannot serve this quadratic eigenproblem: "
                         f"expected 'auto' or one of {served}")
    for path in serving:
        if (path.applies(problem) if solver == "auto" else path.family == solver and (path.serves or path.applies)(problem)):
            return _cheaper_rival(path, problem, [rival for rival in serving if solver in ("auto", rival.family)])
    raise ValueError(f"solver={solver!r} cannot serve this request")


def _cheaper_rival(first: SolverPath, problem: Problem, serving: list[SolverPath]) -> SolverPath:
    """The one rule that weighs cost (issues 45, 47): of `first` and the paths serving that declare it their `rival`, the
    least estimated time of those that fit the caller's memory (`Problem.max_memory`), else `first` (the guard refuses)."""
    rivals = [path for path in serving if path.rival == first.name and path.applies(problem)
              and (path.weighs is None or path.weighs(problem))]
    room = memory_limit(problem.max_memory) if rivals else None
    fits = [path for path in [first, *rivals] if room is None or path.estimate(problem).memory <= room[1]]
    return min(fits or [first], key=lambda path: path.estimate(problem).seconds)


def readme_table() -> str:
    """The README's table of solver paths, one line per registered path (tested against it)."""
    lines = ["| path | picked when | cost (one core) | guarantee |", "| --- | --- | --- | --- |"]
    for path in PATHS:
        name = f"`{path.name}`" + "".join(f" (or `{other}`)" for other in path.fallbacks)
        lines.append(f"| {name} | {path.picked} | {path.cost} | {path.guarantee} |")
    return "\n".join(lines)
