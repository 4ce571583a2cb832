"""The sparse path: a few of the lowest modes (or a band) by shift-invert Lanczos (ARPACK).

The shift is chosen below the spectrum from its scale (`shifted.lowest_shift`), so a singular K (a
free system) is never hit; the factor is `shifted.ShiftedInverse` (LAPACK pttrf for a tridiagonal K~, a sparse
Cholesky or SuperLU otherwise). Zero modes (found by a probe, or known: a free network's rigid-body modes from its
coordinates) are deflated and the rest computed by a block Krylov iteration (`shift_invert`,
`vibra.solvers.standard.krylov`), and the Ritz vectors get one Rayleigh-Ritz step in K~. A band inside the spectrum:
ARPACK.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import NDArray

from vibra.solvers.common import (
    DENSE_ALL_LIMIT, Matrix, SolveResult, absolute_figures, bandwidth, small_pencil, squared_range,
    tridiagonal_bands,
)
from vibra.solvers.standard.inertia import missed, repeats
from vibra.solvers.standard.krylov import block_eigs
from vibra.solvers.standard.shifted import NearZero, ShiftedInverse, lowest_shift, lowest_shifts, semidefinite_rounding
from vibra.solvers.standard.lapack import dense_path
from vibra.solvers.standard.parts import Solver, by_parts
from vibra.solvers.topology import components

#: Directions known to lie in K~'s kernel (a free network's rigid-body modes from its coordinates, `runners`), formed
#: where the path uses them: kernel(K~, ||K~||_inf) -> (n, z) orthonormal.
Kernel = Callable[[sp.csr_matrix, float], NDArray[np.float64]]


def lowest_pairs(Kt: sp.csr_matrix, k: int, *, rounding: float | None = None, kernel: Kernel | None = None
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], ShiftedInverse | None]:
    """The k lowest eigenpairs of K~ by shift-invert (`lowest_shifts`, then `shift_invert`), ascending, and the factor.

    A K~ of several parts (`topology.components`: its connected components) is solved part by part
    (`vibra.solvers.standard.parts`): a Krylov iteration sees the copies of a value repeated across parts only through
    rounding. Parts over `parts.SMALL_PART` dofs are shift-invert's, each on its own factor. The factor returned is K~'s
    where K~ is one part and semidefinite, else None (the caller then takes a Rayleigh-Ritz step). `kernel`
    (`Kernel`): directions known to lie in K~'s kernel (`shift_invert`), one part only."""
    count, label = components(Kt)
    if count == 1:
        return _lowest(Kt, k, *lowest_shifts(Kt, rounding=rounding), kernel)

    def connected(block: sp.csr_matrix) -> Solver:
        shifts = lowest_shifts(block, rounding=rounding)  # (one part's factors, for every count asked of it)
        return lambda wanted: _lowest(block, wanted, *shifts, None)[:2]

    return (*by_parts(Kt, k, count, label, connected, probe=PROBE), None)


def _lowest(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse, near: NearZero | None,
            kernel: Kernel | None) -> tuple[NDArray[np.float64], NDArray[np.float64], ShiftedInverse | None]:
    """`lowest_pairs` of one part from `lowest_shifts`' factors: shift-invert from the shift below the spectrum, or,
    for an indefinite K~ (`near` counts its eigenvalues under a small shift), `_saddle`."""
    if near is None:
        return (*shift_invert(Kt, k, sigma, factor, kernel=kernel), factor)
    return (*_saddle(Kt, k, sigma, factor, near), None)


def _saddle(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse, near: NearZero
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k lowest pairs of an indefinite K~ (a saddle point's Hessian, springs in tension) whose inertia counts
    `near.below` eigenvalues under the small shift s = `near.sigma`: the lowest min(below, k) from the shift below the
    spectrum (two at least, so that a lone negative value bunched with the zero modes there is told from them:
    `_shift_invert`'s closer shift), and the k - below lowest above s as the largest values of F = (K~ - s I)^-1 with
    the pairs below s projected out of it (their values in F, negative and possibly huge, would hold the iteration
    back), the zero modes found first as in a semidefinite K~; a Rayleigh-Ritz step in K~ on the union. From the shift
    below the spectrum alone, the zero modes and the lowest positive values lie bunched in F (3ENL with five springs in
    tension: 1 / 240.6 against 1 / 241.0): the runs did not converge, or returned two copies of a six-fold zero.
    A known kernel is not used: the rigid-body directions of a noisy Hessian overlap its pairs under s. Where the
    first run returns a value at or above s, one below it was missed: a RuntimeError naming the dense path."""
    n, low = Kt.shape[0], min(near.below, k)
    if low:
        lower, low_basis = shift_invert(Kt, min(max(low, 2), n), sigma, factor)
        lower, low_basis = lower[:low], low_basis[:, :low]
    else:
        lower, low_basis = np.zeros(0), np.zeros((n, 0))
    if np.any(lower >= near.sigma):
        raise RuntimeError(f"the {k} lowest modes of a {n}-dof system: {near.below} eigenvalues lie below "
                           f"{near.sigma:.3g} (counted by Sylvester's inertia) and the shift-invert run found "
                           f"{int(np.count_nonzero(lower < near.sigma))} of the {low} asked; use solver='dense'")
    if low == k:
        return lower, low_basis
    deflated = near.factor.deflated(np.linalg.qr(low_basis)[0]) if low else near.factor
    upper, high_basis = shift_invert(Kt, k - low, near.sigma, deflated, reshift=0, below=low)
    return _ritz(Kt, np.column_stack([low_basis, high_basis]))


#: Modes asked of the first shift-invert run, which finds a free system's zero modes (doubled
#: while every one it returns is zero).
PROBE = 8

#: Relative Ritz residual in F = (K~ - sigma I)^-1 at which the block iteration stops: residuals
#: in K~ come out ~1e-14 ||K~|| (measured on 3-D networks of 30,000 dofs).
TOLERANCE = 1e-13


#: Factor entries per row from which the block iteration pays: a solve then costs more than
#: orthogonalising against the whole basis (~4 m n flops per column, m up to ~200 columns);
#: below it (chains, 2-D meshes) ARPACK's restarted Lanczos keeps the basis small.
BLOCK_FILL = 400


#: |lambda| / ||K~||_inf at or under which a pair counts as a zero mode (a free system's rigid motions).
ZERO = 1e-8

#: Least distance of a closer shift below the lowest eigenvalue, relative to ||K~||_inf
#: (`_closer_shift`): F's largest value then exceeds the others' by at most ~1e6, where zero modes
#: at a shift of -1e4 eps ||K~|| exceed them by ~1e12 and must be deflated.
CLOSEST = 1e-6

#: ARPACK's implicit restarts before the shift is questioned (`shift_invert`): the lowest 6 to 26 modes
#: of chains of 10^5-10^6 sites and a 300 x 300 mesh take 2-4 (30-112 solves); a chain of 10^4 sites on
#: unit on-site springs, whose values bunch within 7e-6 of 1, took 50 s at a shift near zero.
ARPACK_RESTARTS = 30

#: Factorisations one closer shift may take (`_closer_shift`'s bisection on the inertia).
BISECTIONS = 24

#: Closer shifts tried at most, one after another (each probe nearer: the estimate of the lowest
#: value sharpens as in Rayleigh-quotient iteration).
RESHIFTS = 3


def shift_invert(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse | None = None, *,
                 reshift: int = RESHIFTS, kernel: Kernel | None = None, below: int = 0
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k lowest eigenpairs of K~, sigma below the spectrum, by shift-invert Krylov, ascending.

    Zero modes (a free system) dominate (K~ - sigma I)^-1 by ||K~|| / |sigma| ~ 1e12 and would
    hold every other Ritz pair at ~1e-4 relative: a first run (`PROBE` modes, doubled while all
    it finds are zero) finds them, and the rest are computed with them deflated, whose
    dominant value is then 1 / (lambda_1 - sigma). Solves stay accurate once projected (their
    error lies in the near-null space). An expensive factor (3-D networks: `fill` >=
    `BLOCK_FILL`) runs `vibra.solvers.standard.krylov.block_eigs` in blocks of `BLOCK_LOWEST` columns
    (widened where a multiple value shows); a cheap one, ARPACK (`_shift_invert_arpack`).

    A `kernel` known (a free network's rigid-body modes from its coordinates, `runners`) is deflated from the start
    by the block iteration, without the probe (`_known_kernel`).

    `below`: eigenvalues known to lie under sigma (an indefinite K~'s, counted, their pairs projected out of `factor`:
    `_saddle`): the k pairs are then the lowest above sigma, F's largest values, and the count that checks them leaves
    those out.

    A zero mode is a pair with |lambda| <= `ZERO` ||K~||; k of them asked and found (a network of
    many parts, isolated sites) are the answer. Where the probe shows the wanted values bunched far
    above sigma (`_closer_shift`: on-site springs, an indefinite K~) the run starts again from a
    shift just below them, at the cost of one more factorisation, `reshift` times at most. With a
    cheap factor ARPACK's own pairs say whether they are bunched (single-vector Lanczos far from a
    multiple value can return it with a copy short), or, where it has not converged in
    `ARPACK_RESTARTS` restarts, three block steps of F.

    Where a nonzero value found shows two copies or more (`inertia.repeats`: a symmetric structure), the
    eigenvalues below the highest one found are counted (`inertia.missed`, one more factorisation); if
    some were not found (a value more multiple than the iteration saw), `_missing` finds them with the
    found pairs deflated, and the answer is counted again (a RuntimeError naming the dense path where the
    count still disagrees).
    """
    if factor is None:
        factor = ShiftedInverse(Kt, sigma, need_inertia=False)
    scale = float(abs(Kt).sum(axis=1).max())
    # the kernel's zero modes are F's largest values where the shift lies near zero, below the spectrum; a shift below
    # Gershgorin's bound (an indefinite K~'s lowest values) does not favour them: the probes serve it
    semidefinite = factor.below_spectrum and -sigma <= ZERO * scale
    known = _known_kernel(Kt, k, sigma, factor, kernel(Kt, scale)) if kernel is not None and semidefinite and \
        factor.fill >= BLOCK_FILL else None
    values, basis = known or _shift_invert(Kt, k, sigma, factor, reshift)
    if not repeats(values, scale):
        return values, basis
    missing, low = missed(Kt, values, scale, under=below)
    if missing:  # (from a shift just below the values where they lie bunched far above sigma, as `_shift_invert`)
        sigma, factor = (None if below else _closer_shift(Kt, values, basis, sigma)) or (sigma, factor)
        values, basis = _missing(Kt, k, factor, sigma, values, basis, missing, low)
        if missed(Kt, values, scale, under=below)[0]:
            raise RuntimeError(f"the {k} lowest modes of a {Kt.shape[0]}-dof system: a multiple eigenvalue's copies "
                               f"were not all found (counted by Sylvester's inertia); use solver='dense'")
    return values, basis


def _known_kernel(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse, kernel: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """`_shift_invert_blocks` with the z directions of `kernel` deflated from the start (after one sweep of F, as the
    probe's zero modes are) in place of its probe (~20 applications of F on a protein's network): None where the run
    meets a zero mode the kernel lacks (a floppy part), at which it stops (the probes then find them), or does not
    converge."""
    z = kernel.shape[1]
    if z == 0:
        return None
    Z = np.linalg.qr(factor.solve(kernel[:, :k]))[0]
    if z >= k:
        return _ritz(Kt, Z)
    scale = float(abs(Kt).sum(axis=1).max())

    def enough(mu: NDArray[np.float64], residual: NDArray[np.float64]) -> bool:
        zero = np.abs(sigma + 1.0 / mu) <= ZERO * scale
        return bool(np.any(zero & (residual <= TOLERANCE * mu))) or (
            mu.shape[0] >= k - z and bool(np.all(residual <= TOLERANCE * np.abs(mu))))

    mu, rest, _, done = block_eigs(factor.solve, Kt.shape[0], k - z, tol=TOLERANCE, block=BLOCK_LOWEST, deflate=Z,
                                   enough=enough, widen=True)
    if not done or np.any(np.abs(sigma + 1.0 / mu) <= ZERO * scale):
        return None
    return np.r_[np.zeros(z), sigma + 1.0 / mu], np.column_stack([Z, rest])


def _missing(Kt: sp.csr_matrix, k: int, factor: ShiftedInverse, sigma: float, values: NDArray[np.float64],
             basis: NDArray[np.float64], missing: int, low: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k lowest pairs once `missing` eigenvalues below the `low` lowest found were counted and not found:
    the block iteration on F with those `low` pairs deflated (after one sweep of F, as `_shift_invert_blocks`
    sharpens its zero modes) finds the largest of F there, as many as are missing but k at most (they may lie
    below some of those found), a block one wider than they are (it then holds every copy it asks of any value);
    the highest values found fill what they leave, and a Rayleigh-Ritz step in K~ keeps the k lowest."""
    wanted = min(missing, k)
    Z = np.linalg.qr(factor.solve(np.linalg.qr(basis[:, :low])[0]))[0] if low else basis[:, :0]
    mu, more, _, done = block_eigs(factor.solve, Kt.shape[0], wanted, tol=TOLERANCE, block=wanted + 1, deflate=Z)
    if not done:
        raise RuntimeError(f"shift-invert block Krylov did not converge for the {wanted} modes the count says the "
                           f"{k} lowest of a {Kt.shape[0]}-dof system lacked; use solver='dense'")
    values, basis = _ritz(Kt, np.column_stack([Z, more, basis[:, low:max(k - wanted, low)]]))
    return values[:k], basis[:, :k]


def _shift_invert(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse, reshift: int
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`shift_invert` before its count."""
    if factor.fill < BLOCK_FILL:
        if not reshift or k < 2:
            return _shift_invert_arpack(Kt, k, sigma, factor)
        try:
            values, basis = _shift_invert_arpack(Kt, k, sigma, factor, restarts=ARPACK_RESTARTS)
        except sla.ArpackNoConvergence:  # three block steps of F: are the lowest values bunched far from sigma?
            values, basis = None, None
            mu, Y = block_eigs(factor.solve, Kt.shape[0], BLOCK_PROBE, block=BLOCK_PROBE, max_dim=3 * BLOCK_PROBE)[:2]
        closer = _closer_shift(Kt, sigma + 1.0 / mu, Y, sigma) if values is None else _closer_shift(Kt, values, basis, sigma)
        if closer is not None:  # (bunched values: a multiple one may have lost a copy)
            return _shift_invert(Kt, k, *closer, reshift - 1)
        return _shift_invert_arpack(Kt, k, sigma, factor) if values is None else (values, basis)
    return _shift_invert_blocks(Kt, k, sigma, factor, reshift)


def _shift_invert_blocks(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse, reshift: int,
                         block: int | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`shift_invert` by the block iteration: a probe for zero modes (doubled while every pair it finds is one), then
    the rest with them deflated, `block` columns wide (`BLOCK_LOWEST` by default); ARPACK where a probe does not
    converge, even a column per pair."""
    n = Kt.shape[0]
    scale = float(abs(Kt).sum(axis=1).max())
    probe = min(k, PROBE)

    def is_zero(mu: NDArray[np.float64]) -> NDArray[np.bool_]:  # |lambda| <= 1e-8 ||K~||: a zero mode
        return np.abs(sigma + 1.0 / mu) <= ZERO * scale

    def found(mu: NDArray[np.float64], residual: NDArray[np.float64]) -> bool:
        # every zero mode converged, and the largest other one to 1e-3: the spectrum below
        # them is really seen (a first crude Ritz value may look non-zero); or all the probe's
        # pairs zero modes, converged (the probe then doubles: a network of many parts)
        zero = is_zero(mu)
        other = np.flatnonzero(~zero)
        converged = bool(np.all(residual[zero] <= TOLERANCE * mu[zero]))
        if not other.size:
            return converged and mu.shape[0] >= min(probe, n - Z.shape[1])
        return bool(residual[other[0]] <= 1e-3 * mu[other[0]]) and converged

    Z, zero_values = np.zeros((n, 0)), np.zeros(0)  # zero modes of earlier probes, all of whose pairs were zero
    while True:
        mu, basis, _, done = block_eigs(factor.solve, n, probe, block=BLOCK_PROBE, enough=found,
                                        deflate=Z if Z.shape[1] else None)
        if not done and probe > BLOCK_PROBE:  # a value more multiple than the block sees (many zero modes of several
            # parts): its Ritz pairs are not to be trusted; again with a column per pair, which holds every copy it asks
            mu, basis, _, done = block_eigs(factor.solve, n, probe, block=probe, enough=found,
                                            deflate=Z if Z.shape[1] else None)
        if not done:  # still not: ARPACK's restarted Lanczos serves the request (its pairs checked, `_arpack`)
            return _shift_invert_arpack(Kt, k, sigma, factor, blocks=False, restarts=ARPACK_RESTARTS)
        values = sigma + 1.0 / mu
        zero = is_zero(mu)
        if not zero.all() or Z.shape[1] + probe >= k:
            break
        Z, zero_values = np.column_stack([Z, basis]), np.r_[zero_values, values]
        probe = min(2 * probe, k - Z.shape[1])
    if zero.all():  # k zero modes (a network of many parts), after one more sweep of F (as below: the probes stop
        # at TOLERANCE in F, ~1e-10 ||K~|| residuals in K~ on 3ENL's network and 11 far sites; after it ~1e-15)
        return _ritz(Kt, np.linalg.qr(factor.solve(np.linalg.qr(np.column_stack([Z, basis])[:, :k])[0]))[0])
    if reshift and not Z.shape[1]:
        closer = _closer_shift(Kt, values, basis, sigma)
        if closer is not None:
            return _shift_invert(Kt, k, *closer, reshift - 1)
    # one more sweep of F on the zero modes: their error shrinks by mu_other / mu_zero ~ 1e-9
    zero_values = np.r_[zero_values, values[zero]]
    Z = np.column_stack([Z, basis[:, zero]])
    Z = np.linalg.qr(factor.solve(np.linalg.qr(Z)[0]))[0] if Z.shape[1] else Z
    mu, rest, _, done = block_eigs(factor.solve, n, k - Z.shape[1], tol=TOLERANCE, block=block or BLOCK_LOWEST,
                                   deflate=Z if Z.shape[1] else None, start=basis[:, ~zero], widen=True)
    if not done:  # a value more multiple than the widened block held (a star of 60 equal arms): ARPACK serves, and
        # `shift_invert` counts what it finds
        return _shift_invert_arpack(Kt, k, sigma, factor, blocks=False, restarts=ARPACK_RESTARTS)
    values = np.r_[zero_values, sigma + 1.0 / mu]
    basis = np.column_stack([Z, rest])
    order = np.argsort(values)
    return values[order], basis[:, order]


def _closer_shift(Kt: sp.csr_matrix, values: NDArray[np.float64], basis: NDArray[np.float64], sigma: float
                  ) -> tuple[float, ShiftedInverse] | None:
    """A shift just below the lowest eigenvalue, and its factorisation, where a probe's Ritz pairs
    (`values`, `basis`; zero modes included) lie bunched far above `sigma`: their spread smaller
    than their distance from it. Then the wanted values of F = (K~ - sigma I)^-1 lie within a few
    per cent of each other and no Krylov iteration converges in reasonable time: on-site springs
    (K + c M: a network's rigid motions become a six-fold value c, a chain's lowest values bunch
    within (pi k / n)^2 of c) or an indefinite K~, whose shift went below Gershgorin's bound.

    The lowest value a is sigma + 1 / mu for a Ritz value mu of F (or ARPACK's Rayleigh quotient of
    K~), and mu <= 1 / (lambda_1 - sigma), so lambda_1 <= a; some eigenvalue lies within
    r = ||K~ v - a v|| of a (v its unit vector; Krylov and Bogoliubov): the first shift tried is
    a - 2 r. The factorisation's inertia then says whether a shift lies below the whole
    spectrum (a probe can miss a lower value), and the interval between the highest shift found
    below and a is halved until it is narrower than a tenth of the spread, or `CLOSEST` ||K~||_inf
    if more (nearer, lambda_1 would dominate F as zero modes do): one factorisation where the probe
    has converged (a 3-D network's block iteration), tens of cheap ones where it has not (three
    steps on a long chain's O(n) factor), `BISECTIONS` at most. None where the values are not
    bunched (a free network: its zero modes at sigma's own distance).
    """
    if values.shape[0] < 2:
        return None
    lowest = int(np.argmin(values))
    low = float(values[lowest])
    distance, spread = low - sigma, float(values.max()) - low
    if spread >= distance:
        return None
    width = max(0.1 * spread, CLOSEST * float(abs(Kt).sum(axis=1).max()))
    if width >= distance:
        return None
    v = basis[:, lowest] / np.linalg.norm(basis[:, lowest])
    below, above, factor = sigma, low, None  # sigma lies below the spectrum, and low is not below lambda_1
    shift = low - max(2.0 * float(np.linalg.norm(Kt @ v - low * v)), width)
    for _ in range(BISECTIONS):
        if not below < shift < above:
            shift = 0.5 * (below + above)
        trial = ShiftedInverse(Kt, shift)
        if trial.below_spectrum:
            below, factor = shift, trial
        else:
            above = shift
        if factor is not None and above - below <= width:
            break
        shift = 0.5 * (below + above)
    return None if factor is None else (below, factor)


#: Block width of the lowest-mode iteration. A block of b columns needs ~70 + 18 (b - 1)
#: applications of F to converge 21 modes of a protein's or a random network's K~, and a
#: b-column solve costs nearly b single ones at these sizes (PARDISO; CHOLMOD from b = 2), so
#: the narrowest block is the cheapest. Two columns, not one: a double value then shows as a
#: pair, and a cluster as wide as the block sends the run again, wider (`krylov.block_eigs`'s
#: `widen`: a symmetric lattice pays a second run). (figures: benchmarks/RESULTS.md, "Block width")
BLOCK_LOWEST = 2

#: Block width of the first run, which finds a free system's zero modes: 6 of them, equal, in
#: a 3-D network (F amplifies them by ~1e12 per step, so a block of 4 picks up all 6).
BLOCK_PROBE = 4


def _shift_invert_arpack(Kt: sp.csr_matrix, k: int, sigma: float, factor: ShiftedInverse,
                         restarts: int | None = None, blocks: bool = True
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`shift_invert` by ARPACK (one vector at a time, restarted): every pair a run returns
    converged to `KEPT_RESIDUAL` is kept and deflated from the next run, which asks the rest.

    The first run asks all k modes. Where nothing dominates (a long chain, whose lowest values
    lie within a few |sigma|) every pair converges and that one run is all; zero modes
    dominating (K~ - sigma I)^-1 leave the pairs beside them at residuals ~1e-11 ||K~|| (a
    2-D mesh), and those are asked again with the converged ones (the zero modes) deflated.
    The last run's pairs are kept where their residuals are within `LAST_RESIDUAL`; where they are not, the
    request goes to the block iteration (`blocks`), or raises where the block iteration sent it here.
    """
    inverse = factor.operator()
    scale = float(abs(Kt).sum(axis=1).max())
    kept = np.zeros((Kt.shape[0], 0))
    kept_values = np.zeros(0)
    start = None
    for attempt in range(MAX_RUNS):
        ask = k - kept.shape[1]
        if kept.shape[1]:
            Z = kept

            def deflated(x: NDArray[np.float64], Z: NDArray[np.float64] = Z) -> NDArray[np.float64]:
                x = np.asarray(x).reshape(-1)
                y = inverse.matvec(x - Z @ (Z.T @ x))
                return y - Z @ (Z.T @ y)

            operator = sla.LinearOperator(Kt.shape, matvec=deflated, dtype=float)
        else:
            operator = inverse
        try:
            values, basis = _arpack(Kt, ask, sigma, operator, deflate=kept if kept.shape[1] else None, start=start,
                                    restarts=restarts)
        except sla.ArpackNoConvergence as error:
            if blocks:  # (`_shift_invert` asks a capped run first, and catches this)
                raise
            raise RuntimeError(f"shift-invert did not converge for the {k} lowest modes of a {Kt.shape[0]}-dof system "
                               f"in {restarts} restarts; use solver='dense'") from error
        except sla.ArpackError as error:  # error 3, no shifts to apply (a star of 400 equal arms, 450 modes asked:
            # a 399-fold value): the block iteration with a column per pair, which holds every copy it asks
            if not blocks:
                raise RuntimeError(f"shift-invert failed for the {k} lowest modes of a {Kt.shape[0]}-dof system "
                                   f"({error}); use solver='dense'") from error
            return _shift_invert_blocks(Kt, k, sigma, factor, 0, block=k + 1)
        if kept.shape[1]:  # a Rayleigh-Ritz step off the kept pairs
            basis = basis - kept @ (kept.T @ basis)
            product = Kt @ basis
            values, rotation = small_pencil(basis.T @ product, basis.T @ basis)
            basis, product = basis @ rotation, product @ rotation
        else:  # ARPACK's first run: orthonormal Ritz vectors already, their Rayleigh quotients
            basis = np.ascontiguousarray(basis)
            product = Kt @ basis
            values = np.einsum("ij,ij->j", basis, product)
        residual = _residual_norms(product, basis, values)
        good = residual <= KEPT_RESIDUAL * scale
        if attempt == MAX_RUNS - 1 and not bool(np.all(residual <= LAST_RESIDUAL * scale)):  # unconverged: not
            # returned as they are (a 450-dof part with 6 zero modes, 27 or 45 modes asked at a shift of -1e4 eps ||K~||: every
            # run's pairs ~1e-4 ||K~|| from converged, held by the zero modes; the last run's were returned, values
            # off by 8e7 times the rounding; RESULTS.md, "A network of parts, part by part"): the block iteration,
            # whose probe deflates the zero modes first
            if not blocks:
                raise RuntimeError(f"shift-invert did not converge for the {k} lowest modes of a {Kt.shape[0]}-dof "
                                   f"system; ask for fewer modes or use solver='dense'")
            return _shift_invert_blocks(Kt, k, sigma, factor, reshift=0)
        if attempt == MAX_RUNS - 1:
            good[:] = True
        if good.all() and not kept.shape[1]:  # one run was all (no copies of n x k arrays)
            return _ascending(values, basis)
        start = basis[:, ~good].sum(axis=1) if not good.all() else None
        kept_values = np.r_[kept_values, values[good]]
        kept = np.column_stack([kept, basis[:, good]])
        if kept.shape[1] >= k:
            break
    values, basis = _ascending(kept_values, kept)
    return values[:k], basis[:, :k]


def _ascending(values: NDArray[np.float64], basis: NDArray[np.float64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pairs sorted by value; the (n, k) basis is copied only where the order changes."""
    order = np.argsort(values, kind="stable")
    if np.array_equal(order, np.arange(order.shape[0])):
        return values, basis
    return values[order], basis[:, order]


def _residual_norms(product: NDArray[np.float64], basis: NDArray[np.float64], values: NDArray[np.float64]
                    ) -> NDArray[np.float64]:
    """||K~ v - lambda v|| of each column, overwriting `product` (K~ V): one (n, k) temporary,
    where `norm(product - basis * values)` makes two (a 10^6-site chain's 21 pairs: 0.10 s
    against 0.5-1.2 s with their page faults); the same figures, bit for bit."""
    product -= basis * values
    return np.sqrt(np.einsum("ij,ij->j", product, product))


#: Residual ||K~ v - lambda v|| / ||K~||_inf under which a shift-invert pair is kept and
#: deflated: deflated runs reach ~2e-16, pairs held by a dominant zero mode ~1e-11.
KEPT_RESIDUAL = 1e-14

#: Shift-invert runs at most (each keeps at least its dominant, converged pair).
MAX_RUNS = 4

#: Residual / ||K~||_inf within which the last ARPACK run's pairs are kept (the path reports its error from the
#: residuals, ~1e-12 ||K~|| at worst then); past it the request goes to the block iteration.
LAST_RESIDUAL = 1e-12


def _arpack(Kt: sp.csr_matrix, k: int, sigma: float, inverse: sla.LinearOperator,
            deflate: NDArray[np.float64] | None = None, start: NDArray[np.float64] | None = None,
            restarts: int | None = None, which: str = "LA") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The k eigenpairs of K~ just above sigma (ARPACK shift-invert, the largest values of (K~ - sigma I)^-1; where
    sigma lies below the spectrum, those nearest it; `which` "LM": nearest it on either side), ascending; the start
    vector (seeded where not given: reproducible runs) is kept off `deflate`."""
    if start is None:
        start = np.random.default_rng(0).standard_normal(Kt.shape[0])
    if deflate is not None:
        start = start - deflate @ (deflate.T @ start)
    values, basis = sla.eigsh(Kt, k=k, sigma=sigma, which=which, OPinv=inverse, tol=0.0,
                              ncv=min(Kt.shape[0], max(2 * k + 1, 20)), v0=start, maxiter=restarts)
    return _ascending(values, basis)


def sparse_path(Kt: Matrix, *, n_modes: int | None, vectors: bool, band: tuple[float, float] | None,
                spring_factor: tuple[sp.csr_matrix, NDArray[np.float64]] | None = None,
                kernel: Kernel | None = None) -> SolveResult:
    """The lowest `n_modes` (or those in `band`) of a sparse K~ by shift-invert block Krylov.

    `spring_factor` (B, w), when K~ was assembled from springs: a nonnegative w makes K~
    semidefinite, and the factorisation's inertia need not be read (`lowest_shift`). `kernel`: `lowest_pairs`'s.
    """
    Kt = sp.csr_matrix(Kt)
    n = Kt.shape[0]
    if band is not None:
        return _sparse_band(Kt, band, vectors)
    k = int(n_modes)  # type: ignore[arg-type]
    if k >= n - 1:
        return dense_path(Kt, n_modes=n_modes, vectors=vectors, band=None)
    rounding = semidefinite_rounding(spring_factor, float(abs(Kt).sum(axis=1).max()))
    values, basis, factor = lowest_pairs(Kt, k, rounding=rounding, kernel=kernel)
    if factor is None or factor.fill >= BLOCK_FILL:  # ARPACK's pairs come out of a Rayleigh-Ritz step already
        values, basis = _ritz(Kt, basis)
    result = absolute_figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _sparse_band(Kt: sp.csr_matrix, band: tuple[float, float], vectors: bool) -> SolveResult:
    low, high = squared_range(band)
    n = Kt.shape[0]
    if bandwidth(Kt) <= 1:
        d, e = tridiagonal_bands(Kt)
        inside = la.eigvalsh_tridiagonal(d, e, select="v", select_range=(low, high))
        count = inside.shape[0]
    else:
        count = None
    if count == 0:
        return SolveResult(np.zeros(0), np.zeros((n, 0)) if vectors else None, np.zeros(0), 0.0, 0.0, "sparse")
    if count is None or count > n // 4:
        if n > DENSE_ALL_LIMIT:
            raise ValueError("band selection on a large non-tridiagonal K is not supported; give n_modes")
        return dense_path(Kt, n_modes=None, vectors=vectors, band=band)
    centre = 0.5 * (low + high)
    shift = centre - 1e-9 * (high - low + abs(centre))
    inverse = ShiftedInverse(Kt, shift, need_inertia=False).operator()
    values, basis = _arpack(Kt, min(count + 2, n - 2), shift, inverse, which="LM")  # eigenvalues nearest the shift
    keep = (values >= low) & (values <= high)
    values, basis = _ritz(Kt, basis[:, keep])
    result = absolute_figures(Kt, values, basis, "sparse", floor=4.0)
    if not vectors:
        result.vectors = None
    return result


def _ritz(Kt: sp.csr_matrix, basis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rayleigh-Ritz on span(basis): diagonalise V^T K~ V against the Gram matrix V^T V."""
    small = basis.T @ (Kt @ basis)
    values, rotation = small_pencil(small, basis.T @ basis)
    return values, basis @ rotation

