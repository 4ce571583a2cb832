"""``accurate-ring``: every frequency of a ring of `common.RING_VALUES_FROM` sites or more, values only.

Truth from outside the code under test: the closed form of the uniform ring,
omega_j = 2 sqrt(k / m) |sin(pi j / n)| in 30-digit mpmath, and for disordered rings Sylvester
inertia counts of K - x M in mpmath (`tests/solvers/test_ring_bounds.ring_count`, K built from the spring
constants themselves), with as many digits as ||K~|| / omega^2 needs. The issue's criterion
for the accurate paths: every frequency within 1e-10 relative, every bound covering the
true error and within 1000 times it or within 1e-13 relative; the bounds reached here are
within 1e-13 relative for every nonzero mode, which is what the tests assert.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
from helpers.rings import disordered_ring, ring_count, sampled
from helpers.rings import kernel_arrays as _kernel_arrays

from vibra import normal_modes, solvers
from vibra.chains import linear_chain
from vibra.solvers.accurate.dd import UNIT, div, mul
from vibra.solvers.accurate.ring import counts as ring_counts
from vibra.solvers.accurate import count_kernels, counting
from vibra.solvers.accurate.ring import values as ring_values


def criterion(omega: np.ndarray, error: np.ndarray, true_error: np.ndarray) -> np.ndarray:
    """Per nonzero mode: the bound covers the true error and is within 1000 times it or 1e-13."""
    return (true_error <= error) & ((error <= 1000 * true_error) | (error <= 1e-13 * omega))


@pytest.mark.slow
def test_a_uniform_ring_of_8000_sites_meets_the_criterion_mode_by_mode() -> None:
    """8,000 sites: its frequencies come in exactly degenerate pairs, each pair an eigenvalue of
    the chain it is cut into (a root at a pole: `ring_values._polish`'s linear case). Before,
    the band solver's values were off by up to 4.5e-9 relative, with 7,994 bounds over 1000
    times their true error."""
    n = 8000
    modes = linear_chain(n, ends="periodic", units="dimensionless").modes(vectors=False, accuracy="certified")
    assert modes.solver == "accurate-ring"
    assert f"{n} of {n} bounds certified by Sturm counts" in modes.refinement
    with mp.workdps(30):
        truth = np.sort(np.array([float(2 * abs(mp.sin(mp.pi * j / n))) for j in range(n)]))
    omega, error = modes.omega[1:], modes.omega_error[1:]
    true_error = np.abs(omega - truth[1:])  # (truth to 1 ulp: the float64 rounding of 30 digits)
    assert np.all(criterion(omega, error, np.maximum(true_error - 1e-16 * omega, 0.0)))
    assert np.all(error <= 1e-13 * omega)
    assert np.max(true_error / truth[1:]) < 1e-13
    assert modes.omega[0] == 0.0


@pytest.mark.parametrize(("spread", "seed"), [(3.0, 1), (6.0, 2), (12.0, 3)])
def test_disordered_rings_are_certified_against_mpmath_counts(spread: float, seed: int) -> None:
    """2,000 sites, masses and springs log-uniform over 10^spread (up to ||K~|| / omega_1^2 ~
    1e30): every nonzero bound within 1e-13 relative; the lowest, loosest and 8 random modes
    covered by mpmath counts (digits enough for the spread: 40 + 2 spread)."""
    n = 2000
    mass, springs = disordered_ring(n, spread, seed)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    modes = ring.modes(vectors=False)
    assert modes.solver == "accurate-ring"
    omega, error = modes.omega, modes.omega_error
    assert np.all(np.diff(omega) >= 0)
    relative = error[1:] / omega[1:]
    assert relative.max() <= 1e-13
    digits = 40 + int(2 * spread)
    for j in sampled(n, np.r_[0.0, relative], np.random.default_rng(seed)):
        if j == 0:
            assert omega[0] == 0.0
            continue
        with mp.workdps(digits):
            low, high = (mp.mpf(omega[j]) - mp.mpf(error[j])) ** 2, (mp.mpf(omega[j]) + mp.mpf(error[j])) ** 2
        assert ring_count(mass, springs, low, digits) <= j < ring_count(mass, springs, high, digits), j


def test_a_nearly_uniform_ring_splits_its_pairs_within_the_bounds() -> None:
    """2,000 unit masses, springs 1 + 1e-9 x (standard normal): each degenerate pair of the uniform
    ring split by ~1e-9, one frequency each side of the cut chain's (`ring_values._polish`: the
    bracket on the root's side, regula falsi). accuracy="certified": every nonzero bound within
    1e-13 relative; a sample covered by 60-digit mpmath counts."""
    n = 2000
    mass = np.ones(n)
    springs = 1.0 + 1e-9 * np.random.default_rng(0).standard_normal(n)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    modes = ring.modes(vectors=False, accuracy="certified")
    assert modes.solver == "accurate-ring"
    omega, error = modes.omega, modes.omega_error
    relative = error[1:] / omega[1:]
    assert relative.max() <= 1e-13
    for j in sampled(n, np.r_[0.0, relative], np.random.default_rng(8)):
        if j == 0:
            continue
        with mp.workdps(60):
            low, high = (mp.mpf(omega[j]) - mp.mpf(error[j])) ** 2, (mp.mpf(omega[j]) + mp.mpf(error[j])) ** 2
        assert ring_count(mass, springs, low, 60) <= j < ring_count(mass, springs, high, 60), j


def test_bounds_of_values_sorted_after_bounding_still_hold() -> None:
    """`counting.sorted_bounds`: two values bounded for eigenvalues 1 and 2 that sorting swaps.
    Eigenvalue 1 within 1e-10 of 2 + 1e-9 and eigenvalue 2 within 1e-8 of 2 put eigenvalue 2 in
    [2 + 0.9e-9, 2 + 1e-8]: within 9e-9 of 2 + 1e-9, its new position (and eigenvalue 1 within
    1e-8 of 2); identity orders are left alone."""
    values = np.array([1.0, 2.0 + 1e-9, 2.0, 3.0])
    bound = np.array([1e-3, 1e-10, 1e-8, 1e-3])
    order = np.argsort(values, kind="stable")
    sorted_bound = counting.sorted_bounds(values[order], bound[order], order)
    assert sorted_bound[1] >= 1e-9 and sorted_bound[2] >= 9e-9 - 1e-20
    assert sorted_bound[2] <= 1e-8 and sorted_bound[0] == 1e-3 and sorted_bound[3] == 1e-3
    assert counting.sorted_bounds(np.sort(values), bound, np.arange(4)) is bound


@pytest.mark.parametrize("n", [3, 5, 40, 300])
def test_compiled_counts_agree_with_the_numpy_spring_form_and_a_dense_solve(n: int) -> None:
    """`count_kernels.spring_counts` (compiled, its reciprocal by one Newton step) against
    `ring_counts.count_below_springs` (numpy) and the eigenvalues of a dense eigh: at points across
    1e-20..1e20 and beside every eigenvalue, the counts agree wherever certain, and every
    certain count matches the dense solve where that resolves the point (small rings)."""
    rng = np.random.default_rng(n)
    for spread in (0.0, 3.0, 12.0):
        mass, springs = disordered_ring(n, spread, n + int(spread))
        ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
        pencil = ring_counts.ring_pencil(*ring.spring_factor(), mass)
        m, compliance, off, squares, closing = _kernel_arrays(pencil)
        values = la.eigh(ring.hessian().toarray(), np.diag(mass), eigvals_only=True)
        beside = np.abs(values[1:]) * (1 + np.array([[-1e-6], [1e-6]]))
        x = np.r_[10.0 ** rng.uniform(-20, 20, 200), beside.ravel()]
        compiled, sure, _ = count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT)
        reference, reference_sure, _ = ring_counts.count_below_springs(pencil, x)
        both = sure & reference_sure
        assert np.array_equal(compiled[both], reference[both])
        assert sure.mean() >= reference_sure.mean() - 0.02
        if n <= 40 and spread == 0.0:  # float64 eigh resolves points 1e-6 from its values here
            dense = np.searchsorted(np.r_[0.0, values[1:]], x)  # (the rigid mode is exactly 0)
            assert np.array_equal(compiled[sure], dense[sure])


def test_compiled_counts_do_not_depend_on_how_points_are_grouped() -> None:
    """The kernels count `count_kernels.LANES` points together (a block's last point repeated to
    fill it): each point's count, certainty and last pivot are the same counted alone, in
    blocks of any fill, in any order (the lanes share no arithmetic)."""
    mass, springs = disordered_ring(257, 6.0, 4)
    ring = linear_chain(257, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    pencil = ring_counts.ring_pencil(*ring.spring_factor(), mass)
    m, compliance, off, squares, closing = _kernel_arrays(pencil)
    x = np.r_[10.0 ** np.random.default_rng(1).uniform(-8, 4, 3 * count_kernels.LANES + 5), 0.0, -1.0, np.inf]
    together = count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT)
    order = np.random.default_rng(2).permutation(x.shape[0])
    shuffled = count_kernels.spring_counts(x[order], m, compliance, off, squares, closing, 4 * UNIT)
    for j in range(x.shape[0]):
        alone = count_kernels.spring_counts(x[j: j + 1], m, compliance, off, squares, closing, 4 * UNIT)
        for part, every, mixed in zip(alone, together, shuffled):
            assert np.array_equal(part[0], every[j], equal_nan=True)
            assert np.array_equal(mixed[np.flatnonzero(order == j)[0]], every[j], equal_nan=True)
    site = np.zeros(2 * 257 - 1, dtype=bool)
    site[0::2] = True
    weights = np.ones(2 * 257 - 1)
    weights[1::2] = springs[:256]
    masses = np.zeros(2 * 257 - 1)
    masses[0::2] = mass
    path = (site, masses, div(np.ones_like(weights), np.zeros_like(weights), weights, np.zeros_like(weights)),
            mul(np.ones_like(weights), np.zeros_like(weights), np.ones_like(weights), np.zeros_like(weights)))
    together = count_kernels.chain_counts(x, *path)
    for j in range(x.shape[0]):
        alone = count_kernels.chain_counts(x[j: j + 1], *path)
        assert alone[0][0] == together[0][j] and alone[1][0] == together[1][j]


def test_lane_kernels_repeat_the_one_point_kernels_bit_for_bit() -> None:
    """The kernels take `count_kernels.LANES` points together, each point's operations in the
    same order as one point at a time (`scalar_kernels`, the previous kernels: a regression
    guard, the counts' truth being the mpmath and dense tests here): on 200 random forms with
    entries over 1e-150..1e150 (zero, huge and tiny couplings) at points over +-1e300, 0, +-inf
    and nan, every count, certainty and last pivot is the same; so are the pivot roots (value,
    evaluations, side) on the brackets of disordered and uniform rings."""
    import scalar_kernels

    rng = np.random.default_rng(11)
    with np.errstate(all="ignore"):
        for _ in range(200):
            n = int(rng.integers(1, 40))
            e = float(rng.choice([0.0, 8.0, 300.0]))
            m, w = 10.0 ** rng.uniform(-e / 2, e / 2, n), 10.0 ** rng.uniform(-e / 2, e / 2, n)
            compliance = div(np.ones(n), np.zeros(n), w, np.zeros(n))
            off = rng.choice([-1.0, 1.0, 0.0, 1e150, 1e-150], 2 * n - 1)
            squares = mul(off, np.zeros_like(off), off, np.zeros_like(off))
            closing = float(rng.choice([1.0, -1.0, 1e-150]))
            x = np.r_[10.0 ** rng.uniform(-300, 300, 13), -(10.0 ** rng.uniform(-300, 300, 4)), 0.0, np.inf, -np.inf,
                      np.nan]
            lanes = count_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT)
            one = scalar_kernels.spring_counts(x, m, compliance, off, squares, closing, 4 * UNIT)
            for a, b in zip(lanes, one):
                assert np.array_equal(a, b, equal_nan=True)
            site = rng.random(n) < 0.5
            path = (site, m, compliance, (squares[0][:n], squares[1][:n]))
            count, certain = count_kernels.chain_counts(x, *path)
            negative, sure = scalar_kernels.chain_counts(x, *path)
            assert np.array_equal(certain, sure)
            assert np.array_equal(count, np.count_nonzero(site) - negative)
    for spread in (0.0, 6.0):
        mass, springs = disordered_ring(3001, spread, 2) if spread else (np.ones(3001), np.ones(3001))
        ring = linear_chain(3001, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
        pencil = ring_counts.ring_pencil(*ring.spring_factor(), mass)
        m, compliance, off, _, closing = _kernel_arrays(pencil)
        _, w, c_in, c_out = ring_values.spring_arrays(pencil)
        d = np.r_[np.abs(np.sqrt(w[:-1]) * c_in[:-1] / np.sqrt(m[:-1])), 0.0]
        poles = np.sort(la.svdvals(np.diag(d) + np.diag(np.abs(np.sqrt(w[:-1]) * c_out[:-1] / np.sqrt(m[1:])), 1)))**2
        low, high = poles[1:-1], poles[2:]
        arguments = (low, high, low, high, m, compliance[0], off, closing)
        for a, b in zip(count_kernels.pivot_roots(*arguments), scalar_kernels.pivot_roots(*arguments)):
            assert np.array_equal(a, b)


def test_roots_and_bounds_of_ring_values_are_sorted_and_finite() -> None:
    """`ring_values.ring_values` on a 400-site ring with a spread of 1e6: n values ascending,
    the zero mode exactly 0, every bound finite and certified."""
    mass, springs = disordered_ring(400, 6.0, 9)
    ring = linear_chain(400, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    found = ring_values.ring_values(ring_counts.ring_pencil(*ring.spring_factor(), mass))
    assert found is not None
    assert found.values.shape == (400,) and np.all(np.diff(found.values) >= 0)
    assert found.values[0] == 0.0 and found.certified.all() and np.all(np.isfinite(found.bound))
    dense = la.eigh(ring.hessian().toarray(), np.diag(mass), eigvals_only=True)
    # float64 eigh is accurate to ~eps ||K~|| only: compare where that is tight
    top = dense > 1e-3 * dense[-1]
    assert np.allclose(found.values[top], dense[top], rtol=1e-12)


def test_the_plan_takes_accurate_ring_for_values_only_at_any_length() -> None:
    """Planning, "high": ``accurate-ring`` for all frequencies without vectors and for the lowest
    10 with or without, at 3,000 and 120,000 sites (the plan names the path that runs; the
    budget, not a length, limits it); all modes with vectors the checked dense solve (3,000) or
    the band's vectors with ``accurate-ring``'s certified values (120,000: ``accurate-ring-band``, the name
    the result reports too, where the plan once said "banded")."""
    for n, k, vectors, path in ((3000, None, False, "accurate-ring"), (3000, None, True, "accurate-checked"),
                                (120000, None, False, "accurate-ring"), (120000, None, True, "accurate-ring-band"),
                                (3000, 10, False, "accurate-ring"), (3000, 10, True, "accurate-ring"),
                                (120000, 10, False, "accurate-ring"), (120000, 10, True, "accurate-ring")):
        ring = linear_chain(n, ends="periodic")
        request = solvers.plan(ring.hessian(), ring.mass_matrix(), n_modes=k, vectors=vectors, band=None,
                               solver="auto", spring_factor=ring.spring_factor())
        assert request.path == path, (n, k, vectors)
    assert "accurate-ring" in solvers.SOLVER_PATHS


@pytest.mark.slow
def test_a_ring_with_a_spring_to_a_wall_agrees_with_the_checked_dense_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """A ring with one spring to a wall (1,510 sites) takes `accurate-ring` too (its cut chain's
    factor keeps the wall: `tests/solvers/test_ring_walls.py`); the checked dense solve it took before
    (`common.RING_VALUES_FROM` out of reach) is an independent path: every pair of
    certified intervals overlaps, and both are within 1e-10 relative (the ring's path at
    accuracy="certified": within 1e-13)."""

    n = 1510
    mass, springs = disordered_ring(n, 1.0, 4)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    B, w = ring.spring_factor()
    walled = sp.vstack([sp.csr_matrix(B), sp.csr_matrix(([1.0], ([0], [7])), shape=(1, n))]).tocsr()
    weights = np.r_[w, 0.5]
    K = (walled.T @ sp.diags(weights) @ walled).tocsr()
    assert ring_counts.ring_pencil(walled, weights, mass).walls
    modes = normal_modes(K, mass, spring_factor=(walled, weights), vectors=False, accuracy="certified")
    assert modes.solver == "accurate-ring"
    assert np.all(modes.omega_error <= 1e-13 * modes.omega)
    monkeypatch.setattr(solvers.common, "RING_VALUES_FROM", 10**12)  # the ring's own path off
    dense = normal_modes(K, mass, spring_factor=(walled, weights), vectors=False)
    assert dense.solver in ("accurate-checked", "accurate-jacobi")
    assert np.all(dense.omega_error <= 1e-10 * dense.omega)
    assert np.all(np.abs(modes.omega - dense.omega) <= modes.omega_error + dense.omega_error)


def test_a_long_ring_with_vectors_gets_certified_frequencies(monkeypatch: pytest.MonkeyPatch) -> None:
    """Above RING_DENSE_LIMIT with vectors a ring takes its band solver's vectors; their
    frequencies now come from `ring.values` (certified, paired by rank). RING_DENSE_LIMIT is
    lowered to 1,000 so that a 1,600-site uniform ring takes that route in a second (measured
    at 6,100 sites: every bound within 9.5e-14, the largest true error 8.6e-15). Truth: the
    closed form; the vectors: residuals of K~ against their certified frequencies."""

    monkeypatch.setattr(solvers.common, "RING_DENSE_LIMIT", 1000)
    n = 1600
    ring = linear_chain(n, ends="periodic", units="dimensionless")
    modes = ring.modes(vectors=True)
    assert "certified by Sturm counts" in modes.refinement and "vectors from the band solver" in modes.refinement
    with mp.workdps(30):
        truth = np.sort(np.array([float(2 * abs(mp.sin(mp.pi * j / n))) for j in range(n)]))
    omega, error = modes.omega[1:], modes.omega_error[1:]
    assert np.all(np.abs(omega - truth[1:]) <= error + 1e-16 * truth[1:])
    assert np.all(error <= 1e-13 * omega)
    Kt = ring.hessian().toarray()  # unit masses: K~ = K
    shapes = modes.shapes
    residual = np.linalg.norm(Kt @ shapes - shapes * modes.omega_squared, axis=0)
    assert residual.max() < 1e-12 * 4.0


def assert_vectors(ring: object, modes: object, mass: np.ndarray) -> None:
    """Mass-weighted residuals of K against the certified frequencies within 1e-14 of ||K~||
    (its largest row sum), and the shapes M-orthonormal to 1e-12."""
    K = ring.hessian()  # type: ignore[attr-defined]
    shapes, squared = modes.shapes, modes.omega_squared  # type: ignore[attr-defined]
    norm = float(abs(K).sum(axis=1).max() / mass.min())
    residual = np.linalg.norm((K @ shapes - (mass[:, None] * shapes) * squared) / np.sqrt(mass)[:, None], axis=0)
    assert residual.max() <= 1e-14 * norm
    assert np.abs(shapes.T @ (mass[:, None] * shapes) - np.eye(shapes.shape[1])).max() <= 1e-12


@pytest.mark.parametrize(("spread", "n", "vectors"), [(12.0, 2000, False), (6.0, 8000, False), (12.0, 2000, True)])
def test_the_lowest_modes_of_a_disordered_ring(spread: float, n: int, vectors: bool) -> None:
    """`modes(n_modes=10)` of a ring over DENSE_LIMIT, values only: ``accurate-ring`` on the
    lowest ten brackets (O(10 n) beyond the cut chain's dqds). Before, shift-invert saw the
    lowest values as one cluster: at 2,000 sites with a spread of 1e12 ARPACK did not converge
    (0 of 8 after 20,001 iterations, 11.5 s); at 8,000 with 1e6 the bounds reached 1.9e-6. Each
    value covered by mpmath counts (40 + 2 spread digits), every bound within 1e-13 relative.
    With vectors (they too failed there): each the singular vector of B~ by Golub-Kahan inverse
    iteration, residuals of K~ within 1e-14 of ||K~||, M-orthonormal to 1e-12."""
    mass, springs = disordered_ring(n, spread, 11)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    modes = ring.modes(n_modes=10, vectors=vectors)
    if vectors:
        assert_vectors(ring, modes, mass)
    assert modes.solver == "accurate-ring" and modes.n_modes == 10
    omega, error = modes.omega, modes.omega_error
    assert omega[0] == 0.0 and np.all(error[1:] <= 1e-13 * omega[1:])
    digits = 40 + int(2 * spread)
    for j in range(1, 10):
        with mp.workdps(digits):
            low, high = (mp.mpf(omega[j]) - mp.mpf(error[j])) ** 2, (mp.mpf(omega[j]) + mp.mpf(error[j])) ** 2
        assert ring_count(mass, springs, low, digits) <= j < ring_count(mass, springs, high, digits), j


@pytest.mark.slow
def test_the_lowest_modes_of_rings_longer_than_the_values_limit() -> None:
    """60,000 sites, `modes(n_modes=...)`: ``accurate-ring`` in O(n k),
    the cut chain's lowest eigenvalues by bisection on its Golub-Kahan form instead of dqds of
    all of them. Before, shift-invert: at 50,000 sites with a spread of 1e6, 164 s, bounds up to
    2.8 relative and the rigid mode at 1.2e-12; on a uniform ring the last mode's bound 1.3e-9
    relative (no gap above it known). Disordered (spread 1e12, with vectors): each value covered
    by 64-digit mpmath counts, every bound within 1e-13 relative, residuals of K~ within 1e-14
    of ||K~||. Uniform (exact pairs, the last of the ten the first of a pair): against the closed
    form in 30-digit mpmath; the pairs' count bounds (~5e-13 relative, counts uncertain near a
    double eigenvalue) tightened by spring-space Rayleigh-Ritz on their singular vectors."""
    n = 60000
    mass, springs = disordered_ring(n, 12.0, 5)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    modes = ring.modes(n_modes=6, vectors=True, accuracy="certified")
    assert modes.solver == "accurate-ring" and modes.n_modes == 6
    omega, error = modes.omega, modes.omega_error
    assert omega[0] == 0.0 and np.all(error[1:] <= 1e-13 * omega[1:])
    for j in range(1, 6):
        with mp.workdps(64):
            low, high = (mp.mpf(omega[j]) - mp.mpf(error[j])) ** 2, (mp.mpf(omega[j]) + mp.mpf(error[j])) ** 2
        assert ring_count(mass, springs, low, 64) <= j < ring_count(mass, springs, high, 64), j
    assert_vectors(ring, modes, mass)

    uniform = linear_chain(n, ends="periodic", units="dimensionless").modes(n_modes=10, vectors=False,
                                                                           accuracy="certified")
    assert uniform.solver == "accurate-ring"
    assert "tightened by spring-space Rayleigh-Ritz" in uniform.refinement
    with mp.workdps(30):
        truth = np.sort(np.array([float(2 * mp.sin(mp.pi * min(j, n - j) / n)) for j in range(6)] * 2))[1:11]
    omega, error = uniform.omega[1:], uniform.omega_error[1:]
    true_error = np.abs(omega - truth[1:])
    assert np.all(criterion(omega, error, np.maximum(true_error - 1e-16 * omega, 0.0)))
    assert np.all(error <= 1e-13 * omega) and uniform.omega[0] == 0.0


@pytest.mark.slow
def test_the_pairs_of_a_200000_site_uniform_ring_are_bounded_within_1e_13() -> None:
    """The lowest 10 of a uniform ring of 200,000 sites: its pairs' Rayleigh-Ritz bounds, r^2 /
    gap, grow as n^4 relative with float64 vectors (3.2e-12 here, 6 over 1000 times the true
    error); with vectors refined to extended precision (`golub_kahan.Refiner`) every
    bound is within 1e-13 relative and meets the criterion. With B~ v formed error-free
    (`spring_ritz._error_free_product`: the Rayleigh quotient's rounding no longer grows as
    1 / omega) every bound is within 1e-15: float64's own rounding of omega (~2 eps) is what
    is left (measured 4.5e-16; 2.8e-14 before). Truth: the closed form, 30 digits."""
    n = 200000
    modes = linear_chain(n, ends="periodic", units="dimensionless").modes(n_modes=10, vectors=False,
                                                                         accuracy="certified")
    assert modes.solver == "accurate-ring"
    with mp.workdps(30):
        truth = np.sort(np.array([float(2 * mp.sin(mp.pi * j / n)) for j in range(6)] * 2))[1:11]
    omega, error = modes.omega[1:], modes.omega_error[1:]
    true_error = np.abs(omega - truth[1:])
    assert np.all(criterion(omega, error, np.maximum(true_error - 1e-16 * omega, 0.0)))
    assert np.all(error <= 1e-15 * omega)
    assert np.all(true_error <= error)


def test_refined_vectors_of_a_double_eigenvalue_reach_extended_precision() -> None:
    """`golub_kahan.Refiner`: a uniform ring's first pair (an exact double eigenvalue),
    float64 singular vectors leave a residual ||K~ v - omega^2 v|| of a few eps ||K~|| (their own
    rounding); after the extended-precision Newton steps it is below 100 long-double units of
    ||K~|| (a bound r^2 / gap that is quadratic in it then reaches ~1e-20 relative at 20,000
    sites). Residuals in extended precision against the closed form (K~ = K: unit masses)."""
    from vibra.solvers.accurate import golub_kahan
    from vibra.solvers.accurate.spring_ritz import forming_deviation

    n = 20000
    ring = linear_chain(n, ends="periodic", units="dimensionless")
    B, w = ring.spring_factor()
    weighted = sp.csr_matrix(sp.diags(np.sqrt(w)) @ B)
    with mp.workdps(40):
        value = float(4 * mp.sin(mp.pi / n) ** 2)
    values = np.array([value, value])
    rough = golub_kahan.singular_vectors(weighted, values, np.ones(n))
    fine = golub_kahan.Refiner(weighted, forming_deviation(weighted, B, w, np.ones(n))).refine(rough, values)
    exact = weighted.astype(np.longdouble)

    def residual(V: np.ndarray) -> float:
        V = np.asarray(V, dtype=np.longdouble)
        return float(np.max(np.linalg.norm(np.asarray(exact.T @ (exact @ V)) - V * np.longdouble(value), axis=0)))

    unit = float(np.finfo(np.longdouble).eps)
    assert residual(rough) > 1000 * unit * 4.0
    assert residual(fine) < 100 * unit * 4.0
    assert np.abs(np.asarray(fine.T @ fine, dtype=float) - np.eye(2)).max() < 1e-15


@pytest.mark.parametrize("compiled", [True, False])
def test_the_error_free_product_is_within_one_unit_of_each_entry(compiled: bool,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """`spring_ritz._error_free_product` (B V in long double by two-product and two-sum): each
    entry within one unit of the exact rational value (Python fractions), on sparse B with
    entries over 1e-3..1e3 of both signs, where the plain product loses tens of units to
    cancellation. The Rayleigh quotient of a low mode is formed from it. Both routes: the
    compiled triple-double sums and the numpy loop in long double (which serves products too
    small to pay for loading the kernel, `spring_ritz.NUMPY_PRODUCT_S`)."""
    from fractions import Fraction

    from vibra.solvers.accurate import spring_ritz
    from vibra.solvers.accurate.spring_ritz import _error_free_product

    monkeypatch.setattr(spring_ritz, "compiled_pays", lambda seconds: compiled)

    rng = np.random.default_rng(0)
    ld = np.longdouble
    unit = float(np.finfo(ld).eps)
    worst = plain = 0.0
    for trial in range(20):
        B = sp.random(40, 30, density=0.1, random_state=trial, format="csr")
        B.data = rng.standard_normal(B.nnz) * 10.0 ** rng.uniform(-3, 3, B.nnz)
        B = B.astype(ld)
        V = (1.0 + rng.standard_normal((30, 2)) * np.r_[1.0, 1e-7]).astype(ld)
        E, naive, entries = _error_free_product(B, V), np.asarray(B @ V), B.tocoo()

        def exact(x: np.longdouble) -> Fraction:
            return Fraction(*x.as_integer_ratio())

        for j in range(2):
            truth = [Fraction(0)] * 40
            for r, c, b in zip(entries.row, entries.col, entries.data):
                truth[r] += exact(b) * exact(V[c, j])
            for r in range(40):
                if truth[r] != 0:
                    worst = max(worst, float(abs(exact(E[r, j]) - truth[r]) / abs(truth[r])))
                    plain = max(plain, float(abs(exact(naive[r, j]) - truth[r]) / abs(truth[r])))
    assert worst <= unit
    assert plain > 10 * unit  # (the cancellation it avoids)


def test_the_error_free_product_in_row_blocks_is_the_same(monkeypatch: pytest.MonkeyPatch) -> None:
    """`_error_free_product` forms B V in blocks of rows (`EFT_ELEMENTS` entries at a time, to
    bound its temporaries): rows are independent, so blocks of any size give the same bits."""
    from vibra.solvers.accurate import spring_ritz

    rng = np.random.default_rng(1)
    B = sp.random(5000, 3000, density=0.002, random_state=2, format="csr")
    B.data = rng.standard_normal(B.nnz)
    B = B.astype(np.longdouble)
    V = rng.standard_normal((3000, 7)).astype(np.longdouble)
    whole = spring_ritz._error_free_product(B, V)
    monkeypatch.setattr(spring_ritz, "EFT_ELEMENTS", 7 * 333)  # 16 blocks, the last one short
    assert np.array_equal(spring_ritz._error_free_product(B, V), whole)


@pytest.mark.parametrize(("n", "spread", "wall"), [(100, 0.0, False), (100, 12.0, True), (640, 6.0, False),
                                                  (1200, 3.0, True)])
def test_rings_from_100_sites_take_the_ring_path_and_agree_with_the_dense_solve(
        n: int, spread: float, wall: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """From `common.RING_VALUES_FROM` (100) sites up to DENSE_LIMIT, frequencies only: ``accurate-ring``
    (a ring of 1,000 sites in 0.03 s where the checked dense solve took 5 s); the dense solve
    it replaces is an independent path: every pair of certified intervals overlaps, both
    within 1e-13 relative (1e-10 for the dense one's promise). One site fewer keeps the dense
    solve, and so does a request with vectors."""

    assert solvers.common.RING_VALUES_FROM == 100
    mass, springs = disordered_ring(n, spread, n) if spread else (np.ones(n), np.ones(n))
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    B, w = ring.spring_factor()
    if wall:
        B, w = sp.vstack([sp.csr_matrix(B), sp.csr_matrix(([1.0], ([0], [n // 2])), shape=(1, n))]).tocsr(), np.r_[w, 2.0]
    K = (sp.csr_matrix(B).T @ sp.diags(w) @ sp.csr_matrix(B)).tocsr()
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-ring"
    nonzero = modes.omega > 0
    assert np.all(modes.omega_error[nonzero] <= 1e-13 * modes.omega[nonzero])
    lowest = normal_modes(K, mass, spring_factor=(B, w), n_modes=5, vectors=False)
    assert lowest.solver == "accurate-ring"
    assert np.all(np.abs(lowest.omega - modes.omega[:5]) <= lowest.omega_error + modes.omega_error[:5])
    assert normal_modes(K, mass, spring_factor=(B, w), n_modes=5).solver in ("accurate-checked", "accurate-jacobi")
    monkeypatch.setattr(solvers.common, "RING_VALUES_FROM", 10**12)  # the ring's own path off
    dense = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert dense.solver in ("accurate-checked", "accurate-jacobi")
    assert np.all(dense.omega_error[nonzero] <= 1e-10 * dense.omega[nonzero])
    assert np.all(np.abs(modes.omega - dense.omega) <= modes.omega_error + dense.omega_error)
    monkeypatch.undo()
    if n == 100:
        smaller = linear_chain(n - 1, ends="periodic", mass=mass[:-1], stiffness=springs[:-1], units="dimensionless")
        assert smaller.modes(vectors=False).solver in ("accurate-checked", "accurate-jacobi")


def test_high_on_a_few_modes_of_a_long_ring_brackets_shift_inverts_values() -> None:
    """The lowest 9 frequencies of a uniform free ring of 20,000 sites at "high": shift-invert's
    values, each bracketed by two double-double counts (`ring_counted`): within 1e-10 of the
    closed form omega_j = 2 sin(pi ceil(j/2) / n) (double pairs), each bound covering its error
    and at most 1e-10 relative; the rotation exactly 0. "certified" takes the ring's own path."""
    n = 20_000
    ring = linear_chain(n, ends="periodic", units="dimensionless")
    exact = 2 * np.sin(np.pi * np.ceil(np.arange(9) / 2) / n)
    modes = ring.modes(n_modes=9, vectors=False)
    assert modes.solver == "accurate-ring" and "shift-invert" in modes.refinement
    assert modes.omega[0] == 0.0
    error = np.abs(modes.omega[1:] - exact[1:])
    assert np.all(error <= 1e-10 * exact[1:]) and np.all(error <= modes.omega_error[1:])
    assert np.all(modes.omega_error[1:] <= 1e-10 * exact[1:])
    assert "shift-invert" not in ring.modes(n_modes=9, vectors=False, accuracy="certified").refinement
