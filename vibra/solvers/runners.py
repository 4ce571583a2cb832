"""How each registered solver path runs: one function per path, which its declaration in
`registry.PATHS` names (`SolverPath.run`), each given the `problem.Problem` the plan chose it for
and the inputs of `dispatch.solve` (`Inputs`; the quadratic paths: the reduced problem of
`quadratic_modes`, `structured.first_order.Reduced`).

A runner trusts the plan: the structure it needs (a chain, a ring, a walled chain) was
classified once (`topology.classify`), so none of them decides again which path it is. The
accurate runners share the last step, `accurate.springs.tightened` (the bounds tightened as far as the
accuracy level asks, no further).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

import vibra.solvers.standard.gpu as gpu_module
from vibra.solvers.accurate.golub_kahan import WANTED, loose_modes
from vibra.solvers.accurate.springs import (
    checked_dense, checked_ritz, relative_account, ring_certified, spring_rayleigh, spring_ritz_band,
    tightened, weighted_factor,
)
from vibra.solvers.accurate.chain.bidiagonal import bidiagonal_path, chain_bidiagonals
import vibra.solvers.common as common
from vibra.solvers.common import SolveResult
from vibra.solvers.accurate.ring.counts import ring_pencil
from vibra.solvers.accurate.chain.lowest import lowest_chain_modes
from vibra.solvers.accurate.chain.sturm_counts import chain_counted, chain_form
from vibra.solvers.accurate.ring.counted import ring_band_counted, ring_counted
from vibra.solvers.accurate.ring.values import MP_WANTED, pair_step, ring_result, ring_vectors
from vibra.solvers.standard.sparse import Kernel, lowest_pairs, semidefinite_rounding, sparse_path
from vibra.solvers.accurate.spring_ritz import TARGET, forming_deviation, spring_figures
from vibra.solvers.standard.iterative import RITZ_TOLERANCE, annihilated, lowest_modes, rigid_body_modes
from vibra.solvers.standard.hermitian import hermitian_stack
from vibra.solvers.standard.lapack import banded_path, dense_path, tridiagonal_path
from vibra.solvers.structured.equilibrated import pencil_result
from vibra.solvers.accurate.chain.walled import walled_result
from vibra.solvers.accuracy import uses_springs
from vibra.solvers.distributed.slepc import slepc_path
from vibra.solvers.problem import Problem
from vibra.solvers.structured.first_order import Reduced, Solved, companion_solve, hamiltonian_solve, skew_solve

__all__ = ["Inputs"]


@dataclass
class Inputs:
    """What a runner works on: K~ as solved (scaled by `scale`, an even power of 2), K and the
    masses as given, the spring factor (B, w) with w scaled alike (None on standard paths), the
    band scaled alike, the progress callback, and the sites' positions where given (the iterative
    paths' preconditioner)."""

    Kt: Any
    K: Any
    mass: NDArray[np.float64]
    factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None
    band: tuple[float, float] | None
    scale: float
    on_stage: Callable[[float, str], None] | None
    positions: NDArray[np.float64] | None = None


# ------------------------------------------------------------------ standard paths
def dense(p: Problem, x: Inputs) -> SolveResult:
    return dense_path(x.Kt, n_modes=p.n_modes, vectors=p.vectors, band=x.band, overwrite=x.Kt is not x.K)


def tridiagonal(p: Problem, x: Inputs) -> SolveResult:
    return tridiagonal_path(x.Kt, n_modes=p.n_modes, vectors=p.vectors, band=x.band)


def banded(p: Problem, x: Inputs) -> SolveResult:
    return banded_path(x.Kt, p.width, n_modes=p.n_modes, vectors=p.vectors, band=x.band, ordering=p.ordering)


def sparse(p: Problem, x: Inputs) -> SolveResult:
    return sparse_path(x.Kt, n_modes=p.n_modes, vectors=p.vectors, band=x.band, spring_factor=x.factor,
                       kernel=_rigid_kernel(x))


def _rigid_kernel(x: Inputs) -> Kernel | None:
    """The mass-weighted rigid-body modes from the sites' positions that K~ annihilates (`iterative.annihilated`), which
    the shift-invert paths deflate from the start (`sparse.shift_invert`), as a function of ||K~||_inf called only
    where the path uses them (the semidefinite one-part block iteration); None without positions."""
    if x.positions is None or (x.mass is not None and np.ndim(x.mass) != 1):
        return None
    positions, mass = x.positions, x.mass
    return lambda Kt, norm: annihilated(Kt, rigid_body_modes(positions, mass), norm)


def iterative(p: Problem, x: Inputs) -> SolveResult:
    result = lowest_modes(x.Kt, int(p.n_modes), mass=x.mass, positions=x.positions,  # type: ignore[arg-type]
                          on_stage=x.on_stage, device=p.device)
    if not p.vectors:
        result.vectors = None
    return result


def iterative_gpu(p: Problem, x: Inputs) -> SolveResult:
    return iterative(p, x)  # (`p.device` is "gpu": LOBPCG and its multigrid cycle run there)


def pencil_jacobi(p: Problem, x: Inputs) -> SolveResult:
    return pencil_result(x.K, _full(x.mass), n_modes=p.n_modes, vectors=p.vectors, band=x.band)


def pencil_cholesky(p: Problem, x: Inputs) -> SolveResult:
    return pencil_result(x.K, _full(x.mass), n_modes=p.n_modes, vectors=p.vectors, band=x.band, jacobi=False)


def _full(mass: NDArray[np.float64]) -> NDArray[np.float64]:
    """M as the matrix the pencil paths factor (solver="pencil" serves diagonal masses too)."""
    return mass if mass.ndim == 2 else np.diag(mass)


def gpu(p: Problem, x: Inputs) -> SolveResult:
    return gpu_module.solve_gpu(x.K, x.mass, n_modes=p.n_modes, vectors=p.vectors, band=p.band)


def slepc(p: Problem, x: Inputs) -> SolveResult:  # (issue 47 item 3: SLEPc over MPI, `solvers.distributed`)
    return slepc_path(x.Kt, n_modes=int(p.n_modes), vectors=p.vectors)  # type: ignore[arg-type]


# ------------------------------------------------------------------ quadratic paths (M q'' + (G + C) q' + K q = 0)
def skew_symmetric(p: Problem, r: Reduced) -> Solved:
    return skew_solve(r)


def hamiltonian(p: Problem, r: Reduced) -> Solved:
    return hamiltonian_solve(r)


def companion(p: Problem, r: Reduced) -> Solved:
    return companion_solve(r)


def hermitian(p: Problem, matrices: NDArray[np.complex128]
              ) -> tuple[NDArray[np.float64], NDArray[np.complex128] | None, NDArray[np.float64]]:
    """A chunk of a crystal's D(q) (`problem.bloch_problem`): values, vectors where asked, bounds
    (`hermitian_stack`). The crystals assemble the chunks and re-solve near Gamma themselves
    (`vibra.crystals.dynamical.phonons`)."""
    return hermitian_stack(matrices, vectors=p.vectors)


# ------------------------------------------------------------------ accurate paths
def accurate_bisection(p: Problem, x: Inputs) -> SolveResult:
    result = lowest_chain_modes(x.Kt, x.K, x.mass, x.factor, n_modes=int(p.n_modes), vectors=p.vectors,
                                scale=x.scale)
    if result is None:  # the plan classified a chain: its bidiagonal factor exists
        raise RuntimeError("accurate-bisection: the springs do not form a chain after all (a planning error)")
    return relative_account(result, "by bisection on the chain's bidiagonal spring factor")


def accurate_bidiagonal(p: Problem, x: Inputs) -> SolveResult:
    coupling, weights = _factor(x)
    weighted = weighted_factor(coupling, weights, x.mass)
    segments = chain_bidiagonals(weighted)
    if segments is None:
        raise RuntimeError("accurate-bidiagonal: the springs do not form a chain after all (a planning error)")
    chain = bidiagonal_path(x.Kt, weighted, segments, n_modes=p.n_modes, vectors=p.vectors, band=x.band,
                            on_stage=x.on_stage, factor=x.factor, mass=x.mass)
    chain = relative_account(chain, "from the relative-accuracy SVD of the chain's bidiagonal spring factor")
    return chain_counted(chain, coupling, weights, x.mass, x.band)


def accurate_walled(p: Problem, x: Inputs) -> SolveResult:
    coupling, weights = _factor(x)
    weighted = weighted_factor(coupling, weights, x.mass)
    walled = walled_result(coupling, weights, x.mass, weighted, p.n_modes, vectors=p.vectors and p.few)
    if walled is None:
        raise RuntimeError("accurate-walled: not a chain with springs to a wall after all (a planning error)")
    if p.few or not p.vectors:
        return walled
    # all modes with vectors: LAPACK stemr's, each paired by rank with its certified value
    basis = tridiagonal_path(x.Kt, n_modes=None, vectors=True, band=None).vectors
    assert basis is not None
    paired = spring_figures(sp.csr_matrix(weighted), walled.eigenvalues, basis, True, "accurate-walled")
    paired.error, paired.refined = walled.error, walled.refined
    paired.refinement = f"{walled.refinement}; vectors from the tridiagonal solver (LAPACK stemr), paired by rank"
    return paired


def accurate_ring(p: Problem, x: Inputs) -> SolveResult:
    route = p.ring_route
    if route is not None:
        # a standard solver's values, each bracketed by counts: a few of a long ring's modes
        # from shift-invert, all of them from the band solver
        coupling, weights = _factor(x)
        pencil = ring_pencil(coupling, weights, x.mass)
        counted = None
        if pencil is not None and route == "sparse" and p.n_modes is not None:
            counted = ring_counted(pencil, sparse_path(x.Kt, n_modes=p.n_modes, vectors=p.vectors, band=None))
        elif pencil is not None and route == "banded":
            values = banded_path(x.Kt, p.width, n_modes=p.n_modes, vectors=False, band=None, ordering=p.ordering)
            counted = ring_band_counted(pencil, values)
        if counted is not None:
            return counted
    coupling, weights, weighted, deviation = _springs(x)
    ring = ring_result(coupling, weights, x.mass, p.n_modes, tighten=pair_step(weighted, deviation, x.mass, _aim(p)),
                       lowest=p.few, aim=_aim(p))
    if ring is None:
        raise RuntimeError("accurate-ring: the springs do not close one ring after all (a planning error)")
    return ring_vectors(weighted, x.mass, ring) if p.vectors else ring


def accurate_ring_band(p: Problem, x: Inputs) -> SolveResult:
    """A long ring with all its vectors: the band solver's vectors, each paired by rank with the
    ring path's certified frequency."""
    coupling, weights, weighted, deviation = _springs(x)
    banded_result = banded_path(x.Kt, p.width, n_modes=p.n_modes, vectors=True, band=x.band, ordering=p.ordering)
    result = spring_rayleigh(weighted, banded_result, vectors=True, deviation=deviation, name="accurate-ring-band")
    certified = ring_result(coupling, weights, x.mass, p.n_modes, tighten=pair_step(weighted, deviation, x.mass, _aim(p)),
                            aim=_aim(p))
    if certified is None or certified.eigenvalues.shape != result.eigenvalues.shape:
        raise RuntimeError("accurate-ring-band: the springs do not close one ring after all (a planning error)")
    result.eigenvalues, result.error = certified.eigenvalues, certified.error
    result.refined = certified.refined
    result.refinement = f"{certified.refinement}; vectors from the band solver, paired by rank"
    return result


def accurate_ritz(p: Problem, x: Inputs) -> SolveResult:
    if x.band is None:
        matrix = sp.csr_matrix(x.Kt)
        rounding = semidefinite_rounding(x.factor, float(abs(matrix).sum(axis=1).max()))
        _, basis, _ = lowest_pairs(matrix, min(int(p.n_modes) + 1, p.n - 2), rounding=rounding,  # type: ignore[arg-type]
                                   kernel=_rigid_kernel(x))
        return _spring_ritz(p, x, basis, "shift-invert")  # (one more vector than asked: the gap)
    coupling, weights, weighted, deviation = _springs(x, lazy=True)
    standard = sparse_path(x.Kt, n_modes=None, vectors=True, band=x.band)
    deviation = deviation()
    result = relative_account(spring_ritz_band(weighted, standard, x.band, vectors=p.vectors, deviation=deviation),
                              "by spring-space Rayleigh-Ritz on the sparse path's vectors in the band")
    return _finished(p, x, result, weighted, deviation)


def accurate_iterative(p: Problem, x: Inputs) -> SolveResult:
    """The iterative path's k + 1 lowest vectors (the last bounds the gap), then as `accurate_ritz`."""
    basis = lowest_modes(x.Kt, int(p.n_modes), mass=x.mass, positions=x.positions, extra=1,  # type: ignore[arg-type]
                         tolerance=RITZ_TOLERANCE, on_stage=x.on_stage).vectors
    assert basis is not None
    return _spring_ritz(p, x, basis, "LOBPCG")


def _spring_ritz(p: Problem, x: Inputs, basis: NDArray[np.float64], how: str) -> SolveResult:
    """Spring-space Rayleigh-Ritz on k + 1 vectors of the lowest modes (`checked_ritz`), bounds tightened."""
    coupling, weights, weighted, deviation = _springs(x, lazy=True)
    k = int(p.n_modes)  # type: ignore[arg-type]
    # a chain's Ritz values bracketed by Sturm counts of its spring form: "high" from 3e-14,
    # "certified" from 8 eps, its values the vectors' Rayleigh quotients in double-double
    form = chain_form(coupling, weights, x.mass) if p.topology == "chain" and uses_springs(p.accuracy) else None
    result = relative_account(checked_ritz(weighted, basis, k, vectors=p.vectors, deviation=deviation, form=form,
                                           precise=p.accuracy == "certified"),
                              f"by spring-space Rayleigh-Ritz on {basis.shape[1]} {how} vectors")
    return _finished(p, x, result, weighted, deviation)


def accurate_checked(p: Problem, x: Inputs) -> SolveResult:
    return _checked(p, x, jacobi=True)


def accurate_rayleigh(p: Problem, x: Inputs) -> SolveResult:
    return _checked(p, x, jacobi=False)


def _checked(p: Problem, x: Inputs, *, jacobi: bool) -> SolveResult:
    coupling, weights, weighted, deviation = _springs(x, lazy=True)  # (B~'s deviations formed only where a bound needs them)
    result = checked_dense(weighted, n_modes=p.n_modes, vectors=p.vectors, band=x.band, jacobi=jacobi,
                           deviation=deviation)
    return _finished(p, x, result, weighted, deviation)


def _finished(p: Problem, x: Inputs, result: SolveResult, weighted: Any, deviation: Any) -> SolveResult:
    """A ring's bounds certified by its Sturm counts (up to RING_DENSE_LIMIT sites); any other
    system's tightened as far as the accuracy level asks (`accurate.springs.tightened`)."""
    if p.ringlike and p.n <= common.RING_DENSE_LIMIT and result.error.shape[0]:
        coupling, weights = _factor(x)
        pencil = ring_pencil(coupling, weights, x.mass)
        if pencil is not None:
            return ring_certified(result, pencil, x.band)
    if (x.band is None and x.mass.ndim == 1 and result.error.shape[0]
            and np.all(np.diff(result.eigenvalues) >= 0)):
        assert x.factor is not None
        wanted = WANTED if p.accuracy == "certified" else TARGET
        if callable(deviation):  # (computed only where a bound is still to tighten)
            if not np.any(loose_modes(result.eigenvalues, result.error, wanted)):
                return result
            deviation = deviation()
        result = tightened(result, weighted, deviation, x.factor, x.mass, accuracy=p.accuracy)
    return result


def _aim(p: Problem) -> float:
    """The relative bound a ring's pair step tightens to: "certified" as far as it goes, "high"
    to `accurate.TARGET` (1e-10), which the counts alone already meet."""
    return MP_WANTED if p.accuracy == "certified" else TARGET


def _springs(x: Inputs, lazy: bool = False) -> tuple[sp.csr_matrix, NDArray[np.float64], Any, Any]:
    """(B, w, B~ = W^1/2 B M^-1/2, B~'s own rounding entry by entry: `forming_deviation`; with
    `lazy`, a function that computes it, for the steps that may not need it)."""
    coupling, weights = _factor(x)
    weighted = weighted_factor(coupling, weights, x.mass)
    if lazy:
        # (cached: `checked_ritz` and `_finished` may each ask for it; formed once)
        return coupling, weights, weighted, functools.cache(lambda: forming_deviation(weighted, coupling, weights,
                                                                                      x.mass))
    return coupling, weights, weighted, forming_deviation(weighted, coupling, weights, x.mass)


def _factor(x: Inputs) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    if x.factor is None:
        raise RuntimeError("an accurate path without a spring factor (a planning error)")
    return x.factor

