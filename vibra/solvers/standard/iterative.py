"""The iterative path: the lowest modes of a large 3-D network by LOBPCG with a multigrid preconditioner.

The factorisation of the sparse path (`vibra.solvers.standard.sparse`) grows like n^(4/3) in
memory and n^2 in work on a 3-D network; this path grows like its matrix, O(nnz) per step:

- the rigid-body translations (a network's dofs in sites of three, `ordering.site_block`, each
  axis moved as one, mass-weighted: M^1/2 t) are in a free network's kernel exactly and are
  projected out of the iteration (LOBPCG's constraints; `annihilated` keeps only what K~
  annihilates: a network tied to fixed points iterates on them), then returned as modes of value 0 to rounding,
  as the factorisation path returns them; the rotations need the coordinates, which K~ does not
  carry: where they are given (`positions`) all six rigid-body modes are projected out alike, else
  the rotations are found by the iteration like any other mode;
- the preconditioner is smoothed-aggregation algebraic multigrid (pyamg) of K~ + sigma I
  (`SHIFT` ||K~||_inf: the singular K~ made definite, below the wanted modes) with the
  known rigid-body modes as its near-null space, applied to the whole block at once (`BlockMultigrid`:
  pyamg's own cycle works one column at a time, ~20 times slower on a block of 20), in single
  precision; with the coordinates its first coarse level is the rigid motions of compact groups of
  sites (`rigid_groups`), which resolves an assembly's cluster of soft modes in ~40 % fewer
  iterations;
- the products of K~ and of the cycle's levels with a block run on every core
  (`vibra.solvers.standard.rows.products`): a compiled loop over the 3 x 3 site blocks of a 3-D
  network, scipy's product on slabs of rows otherwise;
- LOBPCG (`lobpcg.block_lobpcg`, written for this path: scipy's `lobpcg` stops only when every column of its
  block has converged, and the block's edge converges slowest) on a block `WIDTH` (4) times as wide
  as the k - r modes wanted (`block_columns`, r the known rigid-body modes), stopped when those have
  a residual of `TOLERANCE` ||K~||_inf, after which one Rayleigh-Ritz step on [known modes,
  block] gives the returned pairs; every returned pair's residual is measured and a pair over
  `ACCEPTED` ||K~||_inf (the level's promise, "fast") refuses the result (RuntimeError naming
  the residual, the iterations and the factorisation path as the way out).

Inputs are K~ (sparse, symmetric), k and optionally the sites' coordinates (SLEPc takes the same request). The
cost model is `iterative_cost` (seconds and bytes from n, nnz, k and whether the coordinates are given).
"""

from __future__ import annotations

import functools
from types import ModuleType
from typing import Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra.solvers.budget import (
    ITERATIVE_GROWTH, ITERATIVE_PRODUCT_S, ITERATIVE_PRODUCTS, ITERATIVE_RIGID_GROWTH, ITERATIVE_RIGID_PRODUCTS, ITERATIVE_RIGID_STEPS,
    ITERATIVE_RITZ_S, ITERATIVE_SETUP_S, ITERATIVE_STEPS, GPU_ITERATIVE_PRODUCT_S, GPU_ITERATIVE_RITZ_S,
)
from vibra.solvers.compiled import compiled_pays
from vibra.solvers.common import SolveResult, absolute_figures
from vibra.solvers.standard.gpu import check_device, check_iterative_memory, device_csr, require_gpu
from vibra.solvers.standard.lobpcg import block_lobpcg, host
from vibra.solvers.standard.ordering import site_block
from vibra.solvers.standard.rows import RowSlabs, SiteBlocks, Unshifted, products

__all__ = ["ACCEPTED", "GROUP", "RITZ_TOLERANCE", "shifted_blocks", "KERNEL", "MOST_MODES", "WIDTH", "annihilated", "most_modes", "TOLERANCE", "BlockMultigrid", "block_columns", "iterative_cost", "lowest_modes", "rigid_body_modes", "rigid_groups",
           "translations"]

#: Residual ||K~ v - lambda v|| / ||K~||_inf at which LOBPCG stops: a third of `ACCEPTED` (the final residuals
#: measured never above LOBPCG's own; 1e-9 before, two iterations more of 26 at 10^5 dofs).
TOLERANCE = 3e-9

#: `TOLERANCE` for "high"'s spring-space Rayleigh-Ritz (bounds ~ residual^2 / gap; synthetic assembly, relative
#: bounds: 1e-9 up to 1.9e-8 at 3e4 dofs; 1e-11 up to 3.9e-13 at 3e4, 3e-11 at 10^5, +1 iteration over 3e-11).
RITZ_TOLERANCE = 1e-11

#: The largest residual ||K~ v - lambda v|| / ||K~||_inf a returned pair may have (the "fast"
#: promise on this path: an eigenvalue within that of a true one, Weyl; issue 47).
ACCEPTED = 1e-8

#: Columns beyond the wanted modes in LOBPCG's block, at least: the block is `WIDTH` times the wanted
#: columns wide (`block_columns`).
EXTRA = 4

#: LOBPCG's block width over the wanted columns. The (b+1)-th value bounds the gap the wanted ones
#: converge with, and the low spectrum of a large assembly is a tight cluster that grows denser
#: with n (one soft mode per copy of the protein: ~440 within 7 % of each other at 10^5 dofs):
#: 20 modes of the synthetic assembly (RESULTS.md, "Iterative path"), iterations and seconds at
#: 3e4 / 1e5 dofs with 2x: 47 / 164 (18 / 228 s); 3x: 24 / 57 (17 / 149 s); 4x: 22 / 43 (18 / 115 s).
#: Even the exact preconditioner (K~ + sigma)^-1 takes 106 iterations at 1e5 dofs with 2x.
WIDTH = 4

#: LOBPCG iterations at most (measured: 31 at 3e3 dofs, 59 at 1e4, 359 at 3e4 on a protein assembly).
MAX_ITERATIONS = 1000

#: Modes this path serves at most (`most_modes`): LOBPCG's Rayleigh-Ritz costs n (3b)^2 per
#: iteration, b = `WIDTH` k, which passes the products' O(nnz b) from b ~ 1.2 nnz / n (~200 columns,
#: ~50 modes, on a protein assembly; the cost model prices both).
MOST_MODES = 100

#: Dofs from which "auto" may take this path (its estimate against the factorisation's decides
#: beyond): below, the factorisation was faster on every network measured (2.0 s against 3.8 s at
#: 10^4 dofs) and this path's estimate runs up to 5x under the actual time (below ~3,000 dofs).
ITERATIVE_FROM = 10_000

#: The preconditioner's shift, relative to ||K~||_inf: K~ + sigma I is definite, and sigma lies
#: below the lowest nonzero mode of the networks measured (~1e-3 ||K~||_inf at 10^4..10^6 dofs).
SHIFT = 1e-4

#: pyamg's strength threshold: couplings under STRENGTH sqrt(|a_ii a_jj|) do not join aggregates
#: (0 joins every neighbour: on a network of ~50 neighbours per site two levels, a weak coarse space).
STRENGTH = 0.1

#: Chebyshev smoothing: its degree (products with A per sweep) and the ratio of the top of D^-1 A's
#: spectrum to the bottom of the part it damps (the rest the coarse levels take).
DEGREE = 3
CHEBYSHEV_RATIO = 30.0

#: The multigrid cycle's arithmetic (`BlockMultigrid`): single precision, half the memory traffic.
PRECISION = np.float32

#: A sparse matrix's product with a block (`vibra.solvers.standard.rows.products`).
Product = SiteBlocks | RowSlabs

#: A block-Jacobi step X -> D^-1 X (`_jacobi`).
Jacobi = Callable[[NDArray[np.float64]], NDArray[np.float64]]

#: Sites per rigid block at most (`rigid_groups`, where the coordinates are given): recursive bisection
#: gives blocks of GROUP / 2 to GROUP sites. 20 modes of the synthetic assembly (RESULTS.md), iterations
#: and seconds at 3e4 / 1e5 dofs: 16 sites 12 / 27 (15 / 102 s, a larger coarse level to set up);
#: 32 sites 14 / 26 (11 / 84 s); 64 sites 14 at 3e4; translations only (no coordinates) 22 / 43 (21 / 120 s).
GROUP = 32

#: The coarsest level's size at most, in pyamg's block rows (a dense inverse: up to 6 x 500 dofs, 72 MB, with
#: the rigid groups' 6 x 6 blocks; 1,728 dofs measured at 10^5 dofs).
MAX_COARSE = 500


def translations(n: int, mass: NDArray[np.float64] | None, pattern: sp.spmatrix) -> NDArray[np.float64]:
    """(n, 3) orthonormal mass-weighted rigid translations M^1/2 t of a 3-D network (dofs in sites of
    three, site-major), or (n, 0) when K~'s dofs do not come in sites of three."""
    if n % 3 or site_block(sp.csr_matrix(pattern)) != 3:
        return np.zeros((n, 0))
    weights = np.ones(n) if mass is None else np.sqrt(np.asarray(mass, dtype=float))
    basis = np.zeros((n, 3))
    for axis in range(3):
        basis[axis::3, axis] = weights[axis::3]
    return basis / np.linalg.norm(basis, axis=0)


def rigid_body_modes(positions: NDArray[np.float64], mass: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """(3 n_sites, 6) orthonormal mass-weighted rigid-body modes M^1/2 u of sites at `positions`
    ((n_sites, 3), site-major dofs): three translations and three rotations about the centroid."""
    positions = np.asarray(positions, dtype=float)
    centred = positions - positions.mean(axis=0)
    n_sites = positions.shape[0]
    basis = np.zeros((n_sites, 3, 6))
    for axis in range(3):
        basis[:, axis, axis] = 1.0
        unit = np.zeros(3)
        unit[axis] = 1.0
        basis[:, :, 3 + axis] = np.cross(unit, centred)
    flat = basis.reshape(3 * n_sites, 6)
    if mass is not None:
        flat = flat * np.sqrt(np.asarray(mass, dtype=float))[:, None]
    return np.asarray(np.linalg.qr(flat)[0])


def rigid_groups(positions: NDArray[np.float64], size: int = GROUP) -> sp.csr_matrix:
    """(n_sites, n_groups) 0/1 matrix of compact groups of `size` / 2 to `size` sites (fewer where there
    are fewer sites): recursive coordinate bisection, each group halved at its median across its
    widest extent until none has more than `size` (a sort per round, O(n log^2 n), numpy; a group's rigid motions are the
    rigid-block coarse space of `BlockMultigrid`, the blocks of Tama et al.'s RTB)."""
    positions = np.asarray(positions, dtype=float)
    if size < 1:
        raise ValueError(f"size is {size!r}; expected a group of 1 site at least")
    n_sites = positions.shape[0]
    label = np.zeros(n_sites, dtype=np.intp)
    groups = 1
    sites = np.arange(n_sites)
    while True:
        counts = np.bincount(label, minlength=groups)
        split = counts > size
        if not split.any():
            return sp.csr_matrix((np.ones(n_sites), (sites, label)), shape=(n_sites, groups))
        low = np.full((groups, 3), np.inf)
        high = np.full((groups, 3), -np.inf)
        np.minimum.at(low, label, positions)
        np.maximum.at(high, label, positions)
        along = positions[sites, np.argmax(high - low, axis=1)[label]]
        order = np.lexsort((along, label))
        rank = np.empty(n_sites, dtype=np.intp)
        rank[order] = sites - np.repeat(np.cumsum(counts) - counts, counts)
        upper = split[label] & (rank >= (counts[label] + 1) // 2)
        label = np.where(upper, (groups + np.cumsum(split) - 1)[label], label)
        groups += int(split.sum())


#: A direction v of the rigid-body basis is in K~'s kernel where ||K~ v|| <= KERNEL ||K~||_inf (v
#: of unit norm): a pair-spring network's translations give ~eps times the row's entries (1e-14).
KERNEL = 1e-10


def annihilated(Kt: sp.spmatrix, basis: NDArray[np.float64], norm: float) -> NDArray[np.float64]:
    """The part of span(`basis`) (orthonormal columns) that K~ annihilates, ||K~ v|| <= `KERNEL` `norm`:
    the whole basis for a free network; less where it is tied to fixed points (springs to a wall, a
    restrained atom), whose translations are then iterated on like any mode, not projected out."""
    if basis.shape[1] == 0:
        return basis
    _, values, right = np.linalg.svd(np.asarray(Kt @ basis), full_matrices=False)
    return basis @ right[values <= KERNEL * norm].T


def most_modes(n: int, extra: int = 0) -> int:
    """The most modes `lowest_modes` serves on an n-dof K~ with `extra` columns more: `MOST_MODES`,
    and LOBPCG's block (`WIDTH` times the modes) within n / 5. Below 1: too small a K~."""
    return min(MOST_MODES, n // (5 * WIDTH) - extra)


def block_columns(k: int, rigid: int) -> int:
    """LOBPCG's block width for the k lowest modes, `rigid` of them known and projected out: `WIDTH`
    times the k - rigid columns wanted, `EXTRA` more at least."""
    wanted = max(k - rigid, 0)
    return wanted + max(EXTRA, (WIDTH - 1) * wanted)


class BlockMultigrid:
    """Smoothed-aggregation multigrid of A = K~ + sigma I applied to a block of columns at once.

    The hierarchy (aggregates, smoothed prolongators P and Galerkin coarse matrices) is pyamg's
    (`pyamg.smoothed_aggregation_solver`, near-null space `near_null`, K~'s 3 x 3 site blocks kept
    together where it has them); one V-cycle per application with Chebyshev smoothing before and
    after (`DEGREE` products, block-Jacobi preconditioned: a fixed polynomial, so the cycle is
    symmetric, as LOBPCG needs) and a dense inverse on the coarsest level (`_coarse_inverse`). With
    `groups` ((n / 3, g) 0/1, `rigid_groups`) the first coarse level is pyamg's predefined aggregation
    of those groups, the near-null space's restriction to each (the rigid motions), unsmoothed. The cycle runs in
    `PRECISION` (single): a preconditioner only steers the search, LOBPCG's products and residuals
    stay in double, and the products, memory-bound, take about half the time.
    """

    def __init__(self, A: sp.csr_matrix | sp.bsr_matrix, near_null: NDArray[np.float64], *,
                 groups: sp.csr_matrix | None = None, compiled: bool = True, xp: ModuleType = np) -> None:
        import pyamg

        if isinstance(A, sp.bsr_matrix):  # (`shifted_blocks`: the 3 x 3 blocks taken as they are, not copied)
            blocks, fine = A.blocksize[0], A
        else:
            blocks = 3 if A.shape[0] % 3 == 0 and site_block(A) == 3 else 1
            fine = A.tobsr(blocksize=(blocks, blocks)) if blocks > 1 else A
        strength = ("symmetric", {"theta": STRENGTH})
        options: dict = {"strength": strength}
        if groups is not None:  # the first level: the given groups' rigid motions, unsmoothed (Tama's blocks)
            options = {"aggregate": [("predefined", {"AggOp": groups}), "standard"], "strength": [None, strength],
                       "smooth": [None, ("jacobi", {"omega": 4.0 / 3.0})], "improve_candidates": None}
        hierarchy = pyamg.smoothed_aggregation_solver(fine, B=near_null if near_null.shape[1] else None,
                                                      max_coarse=MAX_COARSE, keep=False, **options)
        self.levels: list[tuple[Product, Jacobi, float, Product, Product]] = []
        for index, level in enumerate(hierarchy.levels[:-1]):
            size = blocks if index == 0 else int(getattr(level.A, "blocksize", (1, 1))[0])
            matrix = fine if index == 0 else sp.csr_matrix(level.A)
            inverse = _block_inverse(matrix, size).astype(PRECISION)
            prolongator = level.P.astype(PRECISION)
            if xp is np:
                single, jacobi = products(matrix.astype(PRECISION), compiled=compiled), _jacobi(inverse, compiled)
                P, R = products(prolongator, compiled=compiled), products(prolongator.T, compiled=compiled)
            else:  # on the GPU: cuSPARSE products, D^-1 as a block-diagonal sparse matrix
                single, P, R = (device_csr(part) for part in (matrix.astype(PRECISION), prolongator, prolongator.T))
                jacobi = device_csr(_block_diagonal(inverse)).__matmul__
            self.levels.append((single, jacobi, _spectral_radius(single, jacobi, xp), P, R))
        del hierarchy.levels[:-1]
        self._coarse = xp.asarray(_coarse_inverse(np.asarray(hierarchy.levels[-1].A.toarray())).astype(PRECISION))
        self.xp = xp
        self.depth = len(self.levels) + 1

    def __call__(self, X: NDArray[np.float64]) -> NDArray[np.float64]:
        X = self.xp.asarray(X)
        single = X.ndim == 1
        out = self._cycle(0, X.reshape(X.shape[0], -1).astype(PRECISION)).astype(np.float64)
        return out.ravel() if single else out

    def _cycle(self, index: int, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        if index == len(self.levels):
            return self._coarse @ rhs
        matrix, jacobi, radius, P, R = self.levels[index]
        x = _smooth(matrix, jacobi, radius, rhs)
        residual = rhs - matrix @ x
        x += P @ self._cycle(index + 1, R @ residual)
        residual = rhs - matrix @ x
        x += _smooth(matrix, jacobi, radius, residual)
        return x


def shifted_blocks(Kt: sp.csr_matrix, shift: float) -> sp.csr_matrix | sp.bsr_matrix:
    """K~ + shift I: in 3 x 3 blocks (`scipy.sparse.bsr_matrix`) where K~'s dofs come in sites of three
    (`ordering.site_block`), the shift added to the diagonal blocks of a double-precision copy in place (no
    CSR copy of the sum beside K~ and the blocks: 2 GB at 10^6 dofs), CSR otherwise. Its product gives K~'s
    too (`rows.Unshifted`)."""
    n = Kt.shape[0]
    if n % 3 == 0 and n >= 6 and site_block(Kt) == 3:
        tiled = Kt.astype(np.result_type(Kt.dtype, np.float64), copy=False).tobsr(blocksize=(3, 3), copy=True)  # (K~ untouched)
        own = _own_blocks(tiled)[1]
        if own.size == n // 3:
            tiled.data[own] += shift * np.eye(3)
            return tiled
        # a site without a block of its own (no spring: an isolated site) takes the CSR sum, in blocks all the same
        return (Kt + shift * sp.identity(n, format="csr")).tobsr(blocksize=(3, 3))
    return (Kt + shift * sp.identity(n, format="csr")).tocsr()


def _coarse_inverse(coarse: NDArray[np.float64]) -> NDArray[np.float64]:
    """The coarsest level's inverse: by Cholesky (A = K~ + sigma I is definite, and so is its Galerkin
    product with a prolongator of full rank), the pseudo-inverse where rounding made it singular.
    (scipy's `pinvh` by eigh took 2.0 s at 1,104 dofs against Cholesky's 0.03 s.)"""
    coarse = 0.5 * (coarse + coarse.T)
    try:
        return np.asarray(la.cho_solve(la.cho_factor(coarse), np.eye(coarse.shape[0])))
    except la.LinAlgError:
        values, vectors = la.eigh(coarse, driver="evd")
        kept = values > coarse.shape[0] * np.finfo(float).eps * max(abs(values).max(), 1e-300)
        return np.asarray((vectors[:, kept] / values[kept]) @ vectors[:, kept].T)


def _smooth(matrix: Product, jacobi: Jacobi, radius: float, rhs: NDArray[np.float64]
            ) -> NDArray[np.float64]:
    """`DEGREE` steps of Chebyshev iteration on A x = rhs from 0, preconditioned by the block diagonal D,
    aimed at D^-1 A's eigenvalues in [radius / `CHEBYSHEV_RATIO`, radius] (a fixed polynomial: symmetric)."""
    upper, lower = radius, radius / CHEBYSHEV_RATIO
    centre, half = 0.5 * (upper + lower), 0.5 * (upper - lower)
    sigma = centre / half
    rho = 1.0 / sigma
    step = jacobi(rhs) / centre
    x = step.copy()
    residual = rhs
    for _ in range(DEGREE - 1):
        residual = residual - matrix @ step
        following = 1.0 / (2.0 * sigma - rho)
        step = following * rho * step + (2.0 * following / half) * jacobi(residual)
        x += step
        rho = following
    return x


def _block_inverse(matrix: sp.csr_matrix | sp.bsr_matrix, blocks: int) -> NDArray[np.float64]:
    """(n / b, b, b) inverses of A's b x b diagonal blocks (b = `blocks`; 1: the diagonal's); A in b x b
    blocks already (`scipy.sparse.bsr_matrix`) is read as it is."""
    n = matrix.shape[0]
    if blocks == 1 or n % blocks:
        diagonal = matrix.diagonal()
        return np.where(diagonal != 0, 1.0 / np.where(diagonal != 0, diagonal, 1.0), 0.0).reshape(-1, 1, 1)
    tiled = matrix if isinstance(matrix, sp.bsr_matrix) and matrix.blocksize == (blocks, blocks) \
        else sp.bsr_matrix(matrix, blocksize=(blocks, blocks))
    sites, own = _own_blocks(tiled)
    diagonal = np.zeros((n // blocks, blocks, blocks))
    diagonal[sites] = tiled.data[own]  # (a site with no block of its own keeps a zero one)
    return np.linalg.pinv(diagonal, hermitian=True)  # (a coarse block may be singular)


def _own_blocks(tiled: sp.bsr_matrix) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The block rows that store their diagonal block, and where in `tiled.data` it is."""
    rows = np.repeat(np.arange(tiled.shape[0] // tiled.blocksize[0]), np.diff(tiled.indptr))
    own = np.flatnonzero(rows == tiled.indices)
    return rows[own], own


def _jacobi(inverse: NDArray[np.float64], compiled: bool = True) -> Jacobi:
    """X -> D^-1 X for D^-1 given as its (n / b, b, b) diagonal blocks: 3 x 3 blocks by the compiled
    site-block product (`rows.SiteBlocks`, block row s holding block s alone) where `compiled`, others by numpy."""
    if inverse.shape[1] == 3 and compiled:
        sites = inverse.shape[0]
        diagonal = SiteBlocks(sp.bsr_matrix((inverse, np.arange(sites), np.arange(sites + 1)), shape=(3 * sites, 3 * sites)))
        return diagonal.__matmul__
    return functools.partial(_apply_block, inverse)


def _apply_block(inverse: NDArray[np.float64], X: NDArray[np.float64]) -> NDArray[np.float64]:
    """D^-1 X, D^-1 given as its (n / b, b, b) diagonal blocks."""
    b = inverse.shape[1]
    if b == 1:
        return X * inverse.ravel()[:, None]
    columns = X.shape[1]
    return np.einsum("sij,sjc->sic", inverse, X.reshape(-1, b, columns)).reshape(-1, columns)


def _spectral_radius(matrix: sp.csr_matrix | Product, jacobi: Jacobi, xp: ModuleType = np) -> float:
    """rho(D^-1 A) from 15 power steps, raised by 10% (a lower bound from below otherwise), in A's own precision."""
    x = xp.asarray(np.random.default_rng(0).standard_normal((matrix.shape[0], 1)).astype(matrix.dtype))
    value = 1.0
    for _ in range(15):
        y = jacobi(matrix @ x)
        value = float(xp.linalg.norm(y) / xp.linalg.norm(x))
        x = y / xp.linalg.norm(y)
    return 1.1 * value


def _block_diagonal(inverse: NDArray[np.float64]) -> sp.csr_matrix:
    """The block-diagonal matrix of (n / b, b, b) blocks, as CSR."""
    sites, b = inverse.shape[0], inverse.shape[1]
    return sp.bsr_matrix((inverse, np.arange(sites), np.arange(sites + 1)), shape=(b * sites, b * sites)).tocsr()


def lowest_modes(Kt: sp.spmatrix, n_modes: int, *, mass: NDArray[np.float64] | None = None,
                 rigid: NDArray[np.float64] | None = None, positions: NDArray[np.float64] | None = None,
                 extra: int = 0, tolerance: float = TOLERANCE, max_iterations: int = MAX_ITERATIONS, on_stage: Callable[[float, str], None] | None = None,
                 device: str = "cpu") -> SolveResult:
    """The `n_modes` lowest eigenpairs of the sparse symmetric positive semidefinite K~, ascending.

    Parameters
    ----------
    Kt : (n, n) sparse matrix
        K~ = M^-1/2 K M^-1/2, in omega^2 units.
    n_modes : int
        Modes wanted (rigid-body ones included), 1 <= n_modes <= `most_modes`(n, extra).
    mass : (n,) ndarray, optional
        The dofs' masses, for the translations M^1/2 t (`translations`); 1 where not given.
    rigid : (n, r) ndarray, optional
        A known basis of K~'s kernel (mass-weighted rigid-body modes), projected out of the
        iteration; by default the translations, or all six rigid-body modes where `positions` are given.
    positions : (n / 3, 3) ndarray, optional
        The sites' coordinates (dofs site-major, three per site). They give the rotations (then
        projected out like the translations) and the multigrid's first coarse level: the rigid
        motions of compact groups of sites (`rigid_groups`), which cuts the iterations by ~40 % on a
        protein assembly (RESULTS.md).
    extra : int
        Columns to return beyond `n_modes` (Rayleigh-Ritz on them bounds the gap; "high"). They stop at `tolerance`
        too: a looser gap column would pass its residual to a mode it is (near-)degenerate with, in the final
        Rayleigh-Ritz and in the spring-space bound of that mode's cluster (a symmetric assembly's pairs).
    tolerance : float
        LOBPCG's stopping residual over ||K~||_inf (`TOLERANCE`; "high" asks `RITZ_TOLERANCE`).
    max_iterations : int
        LOBPCG's iterations at most.
    device : {"cpu", "gpu"}
        Where LOBPCG and the multigrid cycle run: "gpu" on CuPy (cuSPARSE products, cuBLAS blocks; its
        memory, `gpu.iterative_gpu_memory`, checked first). The hierarchy is built by pyamg on the CPU
        either way, the small Rayleigh-Ritz matrices are solved on the host, and the returned pairs'
        residuals are measured again on the host with K~ itself.

    Raises
    ------
    ValueError
        n_modes not an integer from 1 to `most_modes`(n, extra), or K~ too small for one.
    RuntimeError
        A returned pair's residual over `ACCEPTED` ||K~||_inf (LOBPCG did not converge).
    """
    Kt = sp.csr_matrix(Kt)
    n = Kt.shape[0]
    wanted = n_modes + extra
    most = most_modes(n, extra)
    if most < 1:
        raise ValueError(f"K~ has {n} dofs; the iterative path needs {5 * WIDTH * (1 + extra)} at least (LOBPCG's "
                         f"block, {WIDTH} times the modes, within n / 5); the dense solver serves this one")
    if not isinstance(n_modes, (int, np.integer)) or not 1 <= n_modes <= most:
        raise ValueError(f"n_modes is {n_modes!r}; expected an integer from 1 to {most} for a {n}-dof K~ "
                         f"(LOBPCG's block stays under n / 5, {MOST_MODES} modes at most; the dense or the "
                         "sparse solver serves more)")
    groups = None
    if positions is not None:
        positions = _validate.site_positions(positions, n)
        groups = rigid_groups(positions)
        if rigid is None:
            rigid = rigid_body_modes(positions, mass)
    norm = float(abs(Kt).sum(axis=1).max())
    smooth = translations(n, mass, Kt) if rigid is None else np.linalg.qr(np.asarray(rigid, dtype=float))[0]
    kernel = annihilated(Kt, smooth, norm)
    kernel = kernel[:, :min(kernel.shape[1], wanted)]
    stage = on_stage or (lambda fraction, message: None)
    xp = np if check_device(device) == "cpu" else require_gpu()
    if xp is not np:  # (before the setup's minutes: the figures of a solve that cannot fit)
        check_iterative_memory(n, Kt.nnz, block_columns(wanted, kernel.shape[1]))
    compiled = compiled_pays(iterative_cost(n, Kt.nnz, wanted, coordinates=groups is not None)[1])  # (numba pays from ~0.1 s)
    shift = SHIFT * norm
    shifted = shifted_blocks(Kt, shift)
    preconditioner = BlockMultigrid(shifted, smooth if smooth.shape[1] else np.zeros((n, 0)), groups=groups,
                                    compiled=compiled, xp=xp)
    stage(0.2, f"multigrid preconditioner of {preconditioner.depth} levels built")
    columns = block_columns(wanted, kernel.shape[1])
    # K~ X as (K~ + sigma I) X - sigma X on the shifted blocks where they are kept: one copy of K~'s entries, not two
    if xp is np:
        product_of = Unshifted(products(shifted), shift) if compiled and isinstance(shifted, sp.bsr_matrix) \
            else products(Kt, compiled=compiled)
    else:
        product_of = device_csr(Kt.astype(np.float64, copy=False))
    del shifted
    try:
        values, vectors, residuals, iterations = _lobpcg_pairs(product_of, preconditioner, kernel, columns, wanted,
                                                               tolerance * norm, max_iterations, xp)
    finally:
        del product_of, preconditioner
        if xp is not np:
            xp.get_default_memory_pool().free_all_blocks()
    stage(0.9, f"LOBPCG: {iterations} iterations of {columns} columns" + (" on the GPU" if xp is not np else ""))
    worst = int(np.argmax(residuals[:n_modes]))
    if residuals[worst] > ACCEPTED * norm:
        raise RuntimeError(
            f"the iterative path did not converge: mode {worst}'s residual is {residuals[worst] / norm:.2g} "
            f"||K~|| after LOBPCG's iterations (max_iterations={max_iterations}), over the "
            f"{ACCEPTED:g} promised; use solver='sparse' (the factorisation) for this network")
    result = absolute_figures(Kt, values, vectors, "iterative", floor=4.0, norm=norm)
    result.error = np.maximum(result.error, residuals)
    return result


def _lobpcg_pairs(A: Product | Unshifted, preconditioner: BlockMultigrid, kernel: NDArray[np.float64], columns: int,
                  wanted: int, tolerance: float, max_iterations: int, xp: ModuleType
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
    """LOBPCG from a random block of `columns` in `xp` (numpy or CuPy), then one Rayleigh-Ritz step on [kernel,
    block]: the `wanted` lowest values, their vectors and residual norms (on the host) and LOBPCG's iterations."""
    constraints = xp.asarray(kernel)
    start = xp.asarray(np.random.default_rng(0).standard_normal((kernel.shape[0], columns)))
    block, iterations = block_lobpcg(A, preconditioner, constraints, start, wanted - kernel.shape[1],
                                     tolerance, max_iterations, xp=xp)
    del start
    basis = xp.concatenate([constraints, block], axis=1) if kernel.shape[1] else block
    del block, constraints
    basis = xp.linalg.qr(basis)[0]
    product = xp.asarray(A @ basis)
    values, rotation = np.linalg.eigh(host(basis.T @ product))
    keep = xp.asarray(rotation[:, :wanted])
    vectors, product = basis @ keep, product @ keep
    values = values[:wanted]
    del basis
    product -= vectors * xp.asarray(values)
    residuals = host(xp.sqrt(xp.einsum("ij,ij->j", product, product)))
    return values, host(vectors), residuals, iterations


def iterative_cost(n: int, nnz: int, k: int, *, coordinates: bool = False, device: str = "cpu") -> tuple[float, float]:
    """(bytes, seconds) of `lowest_modes` for the k lowest modes of an n-dof K~ with nnz stored entries.

    Memory (33 nnz + 128 n b bytes, kept from before `shifted_blocks`, now an upper bound: 13.0 GB
    against 11.1 GB measured at 10^6 dofs, the network included): K~ + sigma I in 3 x 3 blocks
    (~8 nnz bytes, LOBPCG's products too), its single-precision copy (~4), pyamg's setup and the
    hierarchy (~4 at the operator complexity ~1.0 measured), LOBPCG's blocks (X, AX, P, R, W, [W, P],
    Q, AQ: ~8 n b doubles at once) and the cycle's temporaries (~4 n b), b = `block_columns`(k, 3). Time: the setup (`ITERATIVE_SETUP_S` per
    stored entry) and `ITERATIVE_STEPS` (n / 10^4)^`ITERATIVE_GROWTH` iterations (the count grows with
    n: the low spectrum of a large assembly is a tight cluster), each `ITERATIVE_PRODUCTS` sparse products on b
    columns (`ITERATIVE_PRODUCT_S` per entry and column, as measured on two cores: from sizes only,
    not the machine's core count, so that the plan's choice between this path and the factorisation
    is the same everywhere) and the Rayleigh-Ritz of 3 b columns (`ITERATIVE_RITZ_S` per n b^2).
    With `coordinates` (the sites' positions given): the six rigid-body modes known, b =
    `block_columns`(k, 6), and `ITERATIVE_RIGID_STEPS` (n / 10^4)^`ITERATIVE_RIGID_GROWTH` iterations of
    `ITERATIVE_RIGID_PRODUCTS` products (the rigid-block level's cycle added). On the GPU (`device`): the
    same setup and iterations, each product at `GPU_ITERATIVE_PRODUCT_S` and the blocks' work at
    `GPU_ITERATIVE_RITZ_S`; the host keeps the setup's memory and the returned vectors (the GPU's own,
    `gpu.iterative_gpu_memory`, is checked on the device).
    """
    b = block_columns(k, 6 if coordinates else 3)
    on_gpu = device == "gpu"
    memory = 33.0 * nnz + 8.0 * (2 if on_gpu else 16) * n * b
    sweeps = ITERATIVE_RIGID_PRODUCTS if coordinates else ITERATIVE_PRODUCTS
    product_s, ritz_s = (GPU_ITERATIVE_PRODUCT_S, GPU_ITERATIVE_RITZ_S) if on_gpu else (ITERATIVE_PRODUCT_S, ITERATIVE_RITZ_S)
    per_step = sweeps * product_s * float(nnz) * b + ritz_s * float(n) * b * b
    steps = (ITERATIVE_RIGID_STEPS * (n / 1e4) ** ITERATIVE_RIGID_GROWTH if coordinates
             else ITERATIVE_STEPS * (n / 1e4) ** ITERATIVE_GROWTH)
    return memory, ITERATIVE_SETUP_S * nnz + steps * per_step
