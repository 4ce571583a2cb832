"""`solve`: choose a solver path from the structure of K~ and what is asked, and run it."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from dataclasses import dataclass

from vibra.solvers.accurate import accurate_path, accurate_subpath, relative_account, ring_values_apply
from vibra.solvers.budget import (
    Estimate, Progress, ProgressCallback, describe_bytes, describe_seconds, estimate, guard,
)
from vibra.solvers.common import (
    BAND_LIMIT, DENSE_LIMIT, SolveResult, bandwidth, mass_weighted, ring_ordering,
)
from vibra.solvers.lowest import lowest_chain_modes
from vibra.solvers.sparse import sparse_path
from vibra.solvers.walled_chain import has_inner_walls
from vibra.solvers.standard import banded_path, dense_path, tridiagonal_path

#: The solver names that `normal_modes(solver=...)`, `System.modes(solver=...)` and scene
#: files accept; ``"auto"`` chooses one of the others.
SOLVER_NAMES = ("auto", "dense", "tridiagonal", "banded", "sparse", "accurate")

#: The paths a result can report in `Modes.solver` (``"accurate"`` runs one of the
#: ``accurate-*`` paths).
SOLVER_PATHS = ("dense", "tridiagonal", "banded", "sparse", "accurate-bidiagonal", "accurate-bisection",
                "accurate-ritz", "accurate-rayleigh", "accurate-checked", "accurate-jacobi", "accurate-ring",
                "accurate-walled")

#: A partial solve of a chain whose K~ diagonal spans more than this ratio (disorder in the
#: masses or springs), or asked accurately with more than `BISECTION_SIZE` dofs, goes to bisection on the
#: bidiagonal spring factor (`lowest.py`). Its cost does not depend on the spectrum's spread,
#: while shift-invert Lanczos, shifted from the spectrum's scale, sees the lowest eigenvalues
#: as one cluster there and may not converge; and its bound is certified in spring space,
#: while the Ritz path's Kato-Temple bound in K~ cannot beat (eps ||K~|| / omega_1^2)^2, which
#: passes 1e-13 relative near 30,000 sites (2.5e-9 at 10^6, where the true error is 2e-16).
BISECTION_SPREAD = 1e4

#: See `BISECTION_SPREAD`: above this size a chain's lowest modes come from bisection whatever
#: its spread (10^6 sites, lowest 20: 6.7 s values only, 12.6 s with vectors, compiled bisection, against the
#: Ritz path's 15 s; bound 2e-16 not 2.5e-9).
BISECTION_SIZE = 20_000


#: Modes assumed for a `band` request when estimating its cost (the count is unknown up front).
BAND_MODES_ESTIMATE = 64


@dataclass(frozen=True)
class Plan:
    """What `solve` will run: the solver, the detailed path, K~'s half-bandwidth (after the
    ring ordering when there is one), that ordering, and the cost estimate of the path."""

    solver: str
    path: str
    width: int
    ordering: NDArray[np.intp] | None
    cost: Estimate
    nnz: int
    n_dof: int
    fast: Estimate | None = None  # the cost of accuracy="fast" (the standard path), where "high" was asked
    lowest: Estimate | None = None  # the cost of the same accurate request for the lowest 10 modes
    accuracy: str = "high"  # the level asked (`ACCURACY_LEVELS`); it decides which certification steps run


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
) -> Plan:
    """Choose the path for this request ("auto" picks one) and estimate its cost; nothing allocated.

    Raises ValueError when the named solver cannot serve the request. Costs O(nnz) for a
    sparse K and one pass over a dense one (its bandwidth); K~ is not formed. `accuracy` is
    "high" or "certified" where a spring factor is given (the caller drops the factor for
    "fast"): "certified" takes a long chain's lowest modes to bisection (certificates of
    ~1e-16 at 2.5x the Ritz path's time) and runs the bound-tightening steps in full.
    """
    n = K.shape[0]
    requested = solver
    width = bandwidth(K) if mass.ndim == 1 else n - 1
    ordering = None
    # a ring: tridiagonal plus corners, banded once reordered (below DENSE_LIMIT only for its
    # frequencies in "high": `accurate.ring_values_apply`)
    values = spring_factor is not None and solver in ("auto", "accurate") and not vectors and ring_values_apply(
        n, band=band)
    if mass.ndim == 1 and width > BAND_LIMIT and (n > DENSE_LIMIT and solver in ("auto", "banded", "accurate") or values):
        ring = ring_ordering(K)
        if ring is not None:
            ordering, width = ring
    tridiagonal = width <= 1 and ordering is None
    partial = n_modes is not None and n_modes < n
    standard = _standard(n, width, tridiagonal=tridiagonal, partial=partial, band=band, vectors=vectors,
                         sparse=sp.issparse(K))
    fast = None
    if solver == "auto":
        solver = "accurate" if spring_factor is not None else standard
        if spring_factor is not None:  # what accuracy="fast" would run instead
            k_fast = n_modes if n_modes is not None else (min(n, BAND_MODES_ESTIMATE) if band is not None else n)
            fast = estimate(standard, n, k=n if standard == "dense" and band is not None else k_fast,
                            vectors=vectors, width=width, nnz=_stored(K))
    if solver == "tridiagonal" and not tridiagonal:
        raise ValueError("solver='tridiagonal' needs a tridiagonal K and diagonal masses")
    if solver == "banded" and mass.ndim != 1:
        raise ValueError("solver='banded' needs diagonal masses")
    if solver == "sparse" and n_modes is None and band is None:
        raise ValueError("solver='sparse' computes a few modes: give n_modes or band")
    if solver == "accurate" and spring_factor is None:
        raise ValueError("solver='accurate' needs the spring factor (B, w) of K")
    n_terms = spring_factor[0].shape[0] if solver == "accurate" and spring_factor is not None else 0
    walled = solver == "accurate" and spring_factor is not None and width <= 1 and mass.ndim == 1 and has_inner_walls(
        spring_factor[0])  # a chain with springs to a wall inside it: `walled_chain`

    def chosen(n_modes: int | None) -> str:
        path = solver
        if solver == "accurate":
            path = accurate_subpath(n, mass, n_modes=n_modes, band=band, tridiagonal=width <= 1, n_terms=n_terms,
                                    banded=ordering is not None, vectors=vectors, walled=walled)
        some = n_modes is not None and n_modes < n
        if (requested in ("auto", "accurate") and some and band is None and tridiagonal and mass.ndim == 1
                and path != "accurate-walled"
                and ((solver == "accurate" and n > BISECTION_SIZE and accuracy == "certified")
                     or _diagonal_spread(K, mass) > BISECTION_SPREAD)):
            path = "accurate-bisection"
        return path

    path = chosen(n_modes)
    k = n_modes if n_modes is not None else (min(n, BAND_MODES_ESTIMATE) if band is not None else n)
    if path == "dense" and band is not None:
        k = n
    cost = estimate(path, n, k=k, vectors=vectors, width=width, n_terms=n_terms, nnz=_stored(K), accuracy=accuracy)
    lowest = None
    if solver == "accurate" and band is None and (n_modes is None or n_modes > 50) and n > 10:
        lowest = estimate(chosen(10), n, k=10, vectors=vectors, width=width, n_terms=n_terms, nnz=_stored(K),
                          accuracy=accuracy)
    return Plan(solver, path, width, ordering, cost, _stored(K), n, fast, lowest, accuracy)


def _standard(n: int, width: int, *, tridiagonal: bool, partial: bool, band: tuple[float, float] | None,
              vectors: bool, sparse: bool) -> str:
    """The solver "auto" picks without a spring factor (absolute accuracy: ``accuracy="fast"``)."""
    if n <= DENSE_LIMIT:
        return "dense"
    if width <= BAND_LIMIT and not (vectors and (partial or band is not None)):
        # (LAPACK's banded and tridiagonal drivers allocate n x n vectors even for a subset)
        return "tridiagonal" if tridiagonal else "banded"
    if (partial or band is not None) and sparse:
        return "sparse"  # (a dense K takes the dense subset: its sparse LU would fill in)
    return "dense"


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


def alternatives(request: Plan, *, n: int, n_modes: int | None, vectors: bool,
                 band: tuple[float, float] | None) -> list[str]:
    """The cheaper requests that answer most questions, each with its own estimate."""
    options = []
    if request.fast is not None and request.fast.seconds < request.cost.seconds:
        options.append(f'accuracy="fast" (normal_modes: no spring_factor; {request.fast.path}, absolute accuracy: '
                       f'~{_short(request.fast)})')
    if vectors:
        values = estimate(request.path, n, k=n_modes or n, vectors=False, width=request.width)
        options.append(f"vectors=False (frequencies only: ~{_short(values)})")
    if request.lowest is not None:
        options.append(f"n_modes=10 (the lowest modes, {request.lowest.path}: ~{_short(request.lowest)})")
    elif n_modes is None or n_modes > 50:
        how = "sparse shift-invert" if request.nnz < 0.1 * n * n else "a dense subset"
        few = estimate("sparse" if how.startswith("sparse") else "dense", n, k=10, vectors=vectors,
                       width=request.width, nnz=request.nnz)
        options.append(f"n_modes=10 (the lowest modes by {how}: ~{_short(few)})")
    if band is None:
        options.append("band=(low, high) (only the modes in a frequency window)")
    return options


def check_plan(request: Plan, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
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
    request: Plan | None = None,
    accuracy: str = "high",
) -> SolveResult:
    """Run the solver path `solver` ("auto" chooses) on K~ and return a `SolveResult`.

    The request is planned and guarded first (`plan`, `vibra.solvers.budget.guard`): one
    whose estimated memory or time exceeds `max_memory` / `max_seconds` (defaults: the
    module-level limits of `vibra.solvers.budget`) raises `ResourceLimitError` before
    anything is allocated. `progress` reports long solves (see `budget.Progress`).

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
                       spring_factor=spring_factor, accuracy=accuracy)
        check_plan(request, n_modes=n_modes, vectors=vectors, band=band, max_memory=max_memory,
                   max_seconds=max_seconds)
    report = Progress(progress, request.cost)
    Kt = mass_weighted(K, mass)
    report.step(0.05, "mass-weighted K~ formed")
    solver, width, ordering = request.solver, request.width, request.ordering
    # Far from 1, K~'s scale trips LAPACK's bisection and ARPACK (omega^2 ~ 1e-300 or 1e+300):
    # scale by an even power of 2 (exact in floating point) and scale the results back.
    exponent = _scale_exponent(Kt)
    if exponent:
        factor = 2.0**-exponent
        if isinstance(Kt, np.ndarray):
            Kt *= factor
        else:
            Kt = sp.csr_matrix(Kt * factor)
        if band is not None:
            band = (band[0] * 2.0 ** (-exponent // 2), band[1] * 2.0 ** (-exponent // 2))
        if spring_factor is not None:
            spring_factor = (spring_factor[0], spring_factor[1] * factor)
    result = None
    if request.path == "accurate-bisection":  # None when the springs do not form a path after all
        result = lowest_chain_modes(Kt, K, mass, spring_factor, n_modes=int(n_modes or 0), vectors=vectors,
                                    scale=2.0**-exponent if exponent else 1.0)
    if result is not None:
        result = relative_account(result, "by bisection on the chain's bidiagonal spring factor")
    elif solver == "accurate":
        assert spring_factor is not None
        result = accurate_path(Kt, mass, spring_factor, n_modes=n_modes, vectors=vectors, band=band,
                               ordering=ordering, width=width, on_stage=report.step, accuracy=request.accuracy)
    elif solver == "tridiagonal":
        result = tridiagonal_path(Kt, n_modes=n_modes, vectors=vectors, band=band)
    elif solver == "banded":
        result = banded_path(Kt, width, n_modes=n_modes, vectors=vectors, band=band, ordering=ordering)
    elif solver == "sparse":
        result = sparse_path(Kt, n_modes=n_modes, vectors=vectors, band=band, spring_factor=spring_factor)
    else:
        result = dense_path(Kt, n_modes=n_modes, vectors=vectors, band=band, overwrite=Kt is not K)
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
