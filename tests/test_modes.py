"""Tests of vibra/modes.py and vibra/solvers/: normal_modes, the solver paths, Modes.

Truth comes from closed forms (seed 003 eqs. 157-158, chain spectra), from mpmath
eigenvalues at 50 digits, from scipy's ODE integrator, and from invariants.
"""

from __future__ import annotations

import dataclasses
import warnings

import mpmath
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import vibra
from vibra import System, normal_modes


# ---------------------------------------------------------------------- helpers
def free_chain(n: int, mass: float | np.ndarray = 1.0, stiffness: float | np.ndarray = 1.0) -> System:
    return System.from_springs(np.arange(n, dtype=float), mass, np.c_[np.arange(n - 1), np.arange(1, n)], stiffness)


def fixed_chain(n: int) -> System:
    return System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0,
                               anchors=[0, n - 1], anchor_stiffness=1.0)


def free_closed_form(n: int) -> np.ndarray:
    """Free chain, kappa = m = 1: omega_j = 2 sin(j pi / 2n), j = 0..n-1 (seed 003 section 5.3)."""
    return 2.0 * np.sin(np.arange(n) * np.pi / (2 * n))


def fixed_closed_form(n: int) -> np.ndarray:
    """Fixed-fixed chain with n + 1 springs: omega_k = 2 sin(k pi / 2(n+1)), k = 1..n."""
    return 2.0 * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1)))


def mp_chain_omegas(masses: np.ndarray, stiffness: np.ndarray, digits: int = 60) -> np.ndarray:
    """Free-chain frequencies from mpmath at `digits` digits, K built from the spring constants
    themselves (a float64 K would already have rounded a weak spring next to a stiff one)."""
    with mpmath.workdps(digits):
        n = len(masses)
        m = [mpmath.mpf(float(x)) for x in masses]
        k = [mpmath.mpf(float(x)) for x in stiffness]
        Kt = mpmath.matrix(n, n)
        for s in range(n - 1):
            i, j = s, s + 1
            Kt[i, i] += k[s] / m[i]
            Kt[j, j] += k[s] / m[j]
            Kt[i, j] -= k[s] / mpmath.sqrt(m[i] * m[j])
            Kt[j, i] -= k[s] / mpmath.sqrt(m[i] * m[j])
        values = mpmath.eigsy(Kt, eigvals_only=True)
        return np.array(sorted(float(mpmath.sign(v) * mpmath.sqrt(abs(v))) for v in values))


def mp_pencil_eigenvalues(springs: np.ndarray, masses: np.ndarray, indices: range, digits: int = 40) -> np.ndarray:
    """Eigenvalues number `indices` (ascending, from 0) of the free-chain pencil (K, diag(masses)).

    Sylvester's law of inertia: the number of negative pivots of the LDL^T factorisation of the
    tridiagonal K - sigma D is the number of eigenvalues below sigma. The pivots are computed in
    mpmath at `digits` digits from the spring constants themselves; each eigenvalue is bracketed
    around scipy's float64 estimate (checked by the counts) and bisected to 1e-16 relative.
    """
    n = len(masses)
    with mpmath.workdps(digits):
        k = [mpmath.mpf(float(x)) for x in springs]
        d = [mpmath.mpf(float(x)) for x in masses]
        zero = mpmath.mpf(0)

        def below(sigma: mpmath.mpf) -> int:
            negative, pivot = 0, None
            for i in range(n):
                diagonal = (k[i - 1] if i > 0 else zero) + (k[i] if i < n - 1 else zero) - sigma * d[i]
                pivot = diagonal if pivot is None else diagonal - k[i - 1] ** 2 / pivot
                negative += pivot < 0
            return negative

        scale = 1.0 / np.sqrt(masses)
        estimate = la.eigh_tridiagonal(np.r_[springs, 0.0] / masses + np.r_[0.0, springs] / masses,
                                       -springs * scale[:-1] * scale[1:], eigvals_only=True)
        values = []
        for j in indices:
            low, high = mpmath.mpf(estimate[j]) * (1 - 1e-4), mpmath.mpf(estimate[j]) * (1 + 1e-4)
            assert below(low) <= j < below(high), "the float64 estimate does not bracket the eigenvalue"
            while high - low > high * mpmath.mpf(10) ** -16:
                middle = (low + high) / 2
                if below(middle) > j:
                    high = middle
                else:
                    low = middle
            values.append(float((low + high) / 2))
    return np.array(values)


def co2_K(kappa: float = 1.0) -> np.ndarray:
    return kappa * np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])


# ---------------------------------------------------------------------- CO2 (seed 003 example 11)
@pytest.mark.parametrize("alpha", [0.1, 16.0 / 12.0, 1.0, 7.0, 1e-6, 1e6])
@pytest.mark.parametrize("accuracy", ["high", "fast"])
def test_co2_axial_against_eqs_157_158(alpha: float, accuracy: str) -> None:
    big = 12.0
    small = alpha * big
    kappa = 3.7
    system = System.from_springs([0.0, 1.16, 2.32], [small, big, small], [[0, 1], [1, 2]], kappa)
    modes = system.modes(accuracy=accuracy)
    expected = np.array([0.0, np.sqrt(kappa / small), np.sqrt(kappa * (1 / small + 2 / big))])
    # Eq. 157. Relative 1e-12 on the nonzero pair: both paths are backward stable on a 3x3
    # problem whose eigenvalues are within a factor 1 + 2/alpha of each other... except at
    # alpha = 1e6 where the fast path's absolute error eps*||K~|| still is 1e-16 relative.
    np.testing.assert_allclose(modes.omega[1:], expected[1:], rtol=1e-12)
    assert abs(modes.omega[0]) <= 1e-7 * expected[2]  # zero mode: sqrt of rounding at most
    # Eq. 158 (physical directions, normalised) up to sign.
    u1 = np.ones(3) / np.sqrt(3)
    u2 = np.array([-1.0, 0.0, 1.0]) / np.sqrt(2)
    u3 = np.array([1 / np.sqrt(4 * alpha**2 + 2), -np.sqrt(2) * alpha / np.sqrt(2 * alpha**2 + 1),
                   1 / np.sqrt(4 * alpha**2 + 2)])
    for k, reference in enumerate([u1, u2, u3]):
        shape = modes.shapes[:, k] / np.linalg.norm(modes.shapes[:, k])
        assert min(np.abs(shape - reference).max(), np.abs(shape + reference).max()) < 1e-10


def test_normal_modes_doctest_example_and_plain_arrays() -> None:
    modes = normal_modes(co2_K(), [1.0, 1.0, 1.0])
    np.testing.assert_allclose(modes.omega_squared[1:], [1.0, 3.0], rtol=1e-13)


# ---------------------------------------------------------------------- chains: closed forms
@pytest.mark.parametrize("n", [2, 3, 10, 257, 2000])
@pytest.mark.parametrize("accuracy", ["high", "fast"])
def test_free_and_fixed_chains_against_closed_forms(n: int, accuracy: str) -> None:
    free = free_chain(n).modes(accuracy=accuracy, vectors=n <= 300)
    exact = free_closed_form(n)
    # Fast path: absolute error ~ n eps ||K~|| in omega^2, so relative error on the lowest
    # omega grows like eps n^2; the high path keeps ~1e-13 (dqds relative accuracy).
    rtol = 1e-12 if accuracy == "high" else 50 * np.finfo(float).eps * n**2
    np.testing.assert_allclose(free.omega[1:], exact[1:], rtol=max(rtol, 1e-13))
    fixed = fixed_chain(n).modes(accuracy=accuracy, vectors=False)
    np.testing.assert_allclose(fixed.omega, fixed_closed_form(n), rtol=max(rtol, 1e-13))


@pytest.mark.parametrize("n", [3, 8, 101, 1600])
def test_periodic_chain_against_closed_form(n: int) -> None:
    pairs = np.c_[np.arange(n), (np.arange(n) + 1) % n]
    ring = System.from_springs(np.arange(n, dtype=float), 1.0, pairs, 1.0)
    modes = ring.modes(vectors=n < 1000)
    exact = np.sort(2.0 * np.abs(np.sin(np.pi * np.arange(n) / n)))
    np.testing.assert_allclose(modes.omega[1:], exact[1:], rtol=1e-10)
    # Degenerate pairs +-q: every nonzero frequency below the top appears twice.
    if modes.vectors is not None and n > 3:
        sizes = [len(g) for g in modes.degenerate_groups(rtol=1e-9)]
        assert sizes.count(2) == (n - 1) // 2


def test_accurate_path_full_spectrum_n30000_beats_tridiagonal() -> None:
    n = 30000
    system = free_chain(n)
    exact = free_closed_form(n)
    high = system.modes(vectors=False)
    assert high.solver == "accurate-bidiagonal"
    error_high = np.abs(high.omega[1:] - exact[1:]) / exact[1:]
    # Every nonzero frequency, the lowest included, within 1e-10 relative (issue 2).
    assert error_high.max() < 1e-10
    fast = system.modes(accuracy="fast", vectors=False)
    error_fast = abs(fast.omega[1] - exact[1]) / exact[1]
    assert error_fast > 1000 * error_high[0]  # the accurate path is >= 1000x closer here
    # honest bound, against the closed form in 30-digit mpmath: the float64 one above is off by
    # a few ulps itself, more than the certified bounds (~2e-16 relative) allow
    with mpmath.workdps(30):
        for j in range(1, n):
            truth = 2 * mpmath.sin(j * mpmath.pi / (2 * n))
            assert abs(mpmath.mpf(float(high.omega[j])) - truth) <= high.omega_error[j], j


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_accurate_path_every_frequency_of_a_long_chain(ends: str) -> None:
    """Every frequency of a long uniform chain to 1e-10 relative, at a length where the N^2 loss shows.

    Truth: the closed forms 2 sin(j pi / 2n) (free) and 2 sin(k pi / 2(n + 1)) (fixed), evaluated
    in float64 to a few ulps relative (the argument is one rounded product and quotient, and
    sin is correctly rounded to ~1 ulp for small arguments). At n = 8000 an absolute-accuracy
    solver loses about eps ||K~|| / omega_1^2 ~ eps (2n / pi)^2 ~ 6e-9 relative on the lowest
    omega^2, so the standard tridiagonal path misses 1e-10: the check can see a loss of relative
    accuracy, which a 1e5 chain showed only at 40x the cost.
    """
    n = 8000
    system = free_chain(n) if ends == "free" else fixed_chain(n)
    exact = free_closed_form(n)[1:] if ends == "free" else fixed_closed_form(n)
    high = system.modes(vectors=False)
    assert high.solver == "accurate-bidiagonal"
    omega = high.omega[1:] if ends == "free" else high.omega
    assert np.max(np.abs(omega - exact) / exact) < 1e-10
    fast = system.modes(accuracy="fast", vectors=False)
    omega_fast = fast.omega[1:] if ends == "free" else fast.omega
    assert np.max(np.abs(omega_fast - exact) / exact) > 1e-10  # the N^2 loss is visible at this n


def test_lowest_modes_of_a_long_chain_partial_paths() -> None:
    n, k = 200_000, 12
    system = free_chain(n)
    exact = free_closed_form(n)[:k]
    certified = system.modes(n_modes=k, accuracy="certified")
    # "certified" keeps the Ritz path, each value (the vector's Rayleigh quotient in double-double)
    # bracketed by Sturm counts of the chain's spring form (a Kato-Temple bound in K~ would be
    # ~(eps n^2)^2 too loose)
    assert certified.solver == "accurate-ritz" and certified.n_modes == k
    assert np.all(certified.omega_error[1:] / certified.omega[1:] < 1e-13)
    np.testing.assert_allclose(certified.omega[1:], exact[1:], rtol=1e-10)
    assert abs(certified.omega[0]) < 1e-6 * exact[1]
    # "high" keeps the Ritz path there (its values were already right to ~1e-14): every
    # frequency within 1e-10 of the closed form, each inside its own bound
    high = system.modes(n_modes=k)
    assert high.solver == "accurate-ritz" and high.n_modes == k
    np.testing.assert_allclose(high.omega[1:], exact[1:], rtol=1e-10)
    assert np.all(np.abs(high.omega[1:] - exact[1:]) <= high.omega_error[1:])
    fast = normal_modes(system.hessian(), system.mass_matrix(), n_modes=k)
    assert fast.solver == "sparse"
    # A standard sparse solve: relative error of order eps ||K~|| / omega_1^2 ~ eps n^2 on
    # the lowest omega^2, halved for omega.
    np.testing.assert_allclose(fast.omega[1:], exact[1:], rtol=np.finfo(float).eps * n**2)
    assert fast.orthogonality < 1e-12 and fast.residual < 1e-12


# ---------------------------------------------------------------------- 3-D networks
def test_rigid_cluster_has_six_zero_modes_and_freezing_removes_them(rng: np.random.Generator) -> None:
    points = rng.normal(size=(7, 3))
    pairs = np.array([(i, j) for i in range(7) for j in range(i + 1, 7)])
    cluster = System.from_springs(points, rng.uniform(1, 3, 7), pairs, rng.uniform(1, 2, len(pairs)))
    for accuracy in ("high", "fast"):
        modes = cluster.modes(accuracy=accuracy)
        assert int(modes.zero_modes(rtol=1e-6).sum()) == 6
        assert modes.omega[6] > 1e-3
    frozen = cluster.freeze(sites=[0, 1, 2])
    assert frozen.n_dof == 12
    assert int(frozen.modes().zero_modes(rtol=1e-6).sum()) == 0


def test_linear_molecule_with_bends_has_five_zero_modes() -> None:
    # A-B-C along x with two stretches and two linear-bend coordinates (y and z), whose
    # Wilson-B rows are d(theta)/du = (1/L1, -(1/L1 + 1/L2), 1/L2) on the y (or z) components.
    L1, L2 = 1.16, 1.16
    positions = np.array([[-L1, 0, 0], [0.0, 0, 0], [L2, 0, 0]])
    rows = np.zeros((4, 9))
    rows[0, [0, 3]] = [-1.0, 1.0]
    rows[1, [3, 6]] = [-1.0, 1.0]
    for r, axis in ((2, 1), (3, 2)):
        rows[r, [axis, 3 + axis, 6 + axis]] = [1 / L1, -(1 / L1 + 1 / L2), 1 / L2]
    system = System.from_terms(positions, [16.0, 12.0, 16.0], sp.csr_matrix(rows), [10.0, 10.0, 0.5, 0.5],
                               units="ASE")
    modes = system.modes()
    assert int(modes.zero_modes(rtol=1e-6).sum()) == 5
    groups = modes.degenerate_groups(rtol=1e-10)
    assert [len(g) for g in groups if not modes.zero_modes()[g[0]]] == [2]  # the degenerate bend
    # Frozen centre: the two rotations about it stay free (they leave every coordinate unchanged).
    assert int(system.freeze(sites=[1]).modes().zero_modes(rtol=1e-6).sum()) == 2
    # Frozen ends: the centre atom is held by the stretches (x) and the bends (y, z).
    assert int(system.freeze(sites=[0, 2]).modes().zero_modes(rtol=1e-6).sum()) == 0


# ---------------------------------------------------------------------- invariants
def test_shapes_are_m_orthonormal_and_vectors_orthonormal(rng: np.random.Generator) -> None:
    n = 40
    masses = rng.uniform(0.5, 5.0, n)
    system = free_chain(n, masses, rng.uniform(1, 3, n - 1))
    for accuracy in ("high", "fast"):
        modes = system.modes(accuracy=accuracy)
        np.testing.assert_allclose(modes.shapes.T @ (masses[:, None] * modes.shapes), np.eye(n), atol=1e-12)
        np.testing.assert_allclose(modes.vectors.T @ modes.vectors, np.eye(n), atol=1e-12)
        assert modes.orthogonality < 1e-12 and modes.residual < 1e-12


def test_generalized_mass_matrix_modes(rng: np.random.Generator) -> None:
    a = rng.normal(size=(4, 4))
    M = a @ a.T + 4 * np.eye(4)
    b = rng.normal(size=(4, 4))
    K = b @ b.T
    modes = normal_modes(K, M)
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(4), atol=1e-12)
    np.testing.assert_allclose(K @ modes.shapes, M @ modes.shapes * modes.omega_squared, atol=1e-11)


def test_evolve_matches_numerical_integration_and_conserves_energy(rng: np.random.Generator) -> None:
    n = 12
    masses = rng.uniform(1, 4, n)
    system = free_chain(n, masses, rng.uniform(1, 3, n - 1))
    K = system.hessian().toarray()
    modes = system.modes()
    u0, v0 = rng.normal(size=n), rng.normal(size=n)  # includes drift of the zero mode
    times = np.linspace(0.0, 20.0, 41)

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        return np.r_[y[n:], -(K @ y[:n]) / masses]

    reference = solve_ivp(rhs, (0, 20), np.r_[u0, v0], t_eval=times, rtol=1e-12, atol=1e-12, method="DOP853")
    motion = modes.evolve(u0, v0, times)
    # DOP853 at rtol=atol=1e-12 over ~20 time units: global error ~1e-10; 1e-8 leaves margin.
    np.testing.assert_allclose(motion, reference.y[:n].T, atol=1e-8)
    energy0 = 0.5 * v0 @ (masses * v0) + 0.5 * u0 @ K @ u0
    # The velocity of the modal motion (central differences of evolve, step h = 1e-5:
    # truncation h^2 |u^(3)| / 6 ~ 1e-10, round-off eps |u| / h ~ 1e-11) against the integrator's
    # velocity (global error ~1e-10), and the energy 1/2 v^T M v + 1/2 u^T K u of that motion at
    # every sample against E(0): conserved to the differencing error.
    h = 1e-5
    velocity = (modes.evolve(u0, v0, times + h) - modes.evolve(u0, v0, times - h)) / (2 * h)
    np.testing.assert_allclose(velocity, reference.y[n:].T, atol=1e-8)
    energies = 0.5 * np.einsum("ti,i,ti->t", velocity, masses, velocity) + 0.5 * np.einsum(
        "ti,ij,tj->t", motion, K, motion)
    np.testing.assert_allclose(energies, energy0, rtol=1e-9)
    assert modes.energy(u0, v0) == pytest.approx(energy0, rel=1e-12)
    # Energy along the exact motion from the normal-coordinate form: each q_k's energy is constant.
    u_half = modes.evolve(u0, v0, 7.3)
    v_half = (modes.evolve(u0, v0, 7.3 + 1e-6) - modes.evolve(u0, v0, 7.3 - 1e-6)) / 2e-6
    assert 0.5 * v_half @ (masses * v_half) + 0.5 * u_half @ K @ u_half == pytest.approx(energy0, rel=1e-8)


def test_evolve_zero_and_imaginary_modes() -> None:
    # One free particle (zero mode) and one inverted oscillator (omega^2 = -4).
    with pytest.warns(RuntimeWarning, match="imaginary"):
        modes = normal_modes(np.diag([0.0, -4.0]), [1.0, 1.0])
    assert modes.omega[0] == pytest.approx(-2.0) and modes.unstable.tolist() == [True, False]
    u = modes.evolve([1.0, 0.5], [2.0, 0.25], 1.5)
    # Exact: dof 0 drifts, x(t) = 1 + 2 t; dof 1 is inverted, y(t) = 0.5 cosh(2t) + 0.25 sinh(2t) / 2.
    np.testing.assert_allclose(u, [1.0 + 2.0 * 1.5, 0.5 * np.cosh(3.0) + 0.125 * np.sinh(3.0)], rtol=1e-12)


@given(
    log_ratio=st.floats(min_value=-12, max_value=12),
    log_stiffness=st.floats(min_value=-12, max_value=12),
    n=st.integers(min_value=2, max_value=7),
)
def test_extreme_mass_and_stiffness_ratios_against_mpmath(log_ratio: float, log_stiffness: float, n: int) -> None:
    masses = np.where(np.arange(n) % 2 == 0, 1.0, 10.0**log_ratio)
    stiffness = np.where(np.arange(n - 1) % 2 == 0, 1.0, 10.0**log_stiffness)
    system = free_chain(n, masses, stiffness)
    modes = system.modes(vectors=False)
    reference = mp_chain_omegas(masses, stiffness)
    # Ratios up to 1e12 and 1e24 between frequencies: the accurate path keeps every nonzero
    # frequency to ~n eps relative (dqds); 1e-12 allows for forming B~ (sqrt, divide).
    np.testing.assert_allclose(modes.omega[1:], reference[1:], rtol=1e-12)
    assert np.all(modes.omega_error[1:] >= np.abs(modes.omega[1:] - reference[1:]))


def test_nearly_singular_K_weak_link_keeps_relative_accuracy() -> None:
    n = 20
    stiffness = np.ones(n - 1)
    stiffness[9] = 1e-13  # two halves joined by an almost-broken spring
    system = free_chain(n, 1.0, stiffness)
    reference = mp_chain_omegas(np.ones(n), stiffness)
    high = system.modes(vectors=False)
    assert abs(high.omega[1] - reference[1]) / reference[1] < 1e-12
    fast = system.modes(accuracy="fast", vectors=False)
    # The fast path works on the rounded K (1 + 1e-13 keeps 3 digits of the weak spring):
    # it cannot resolve omega_1 ~ 1e-7, and its error bar says so.
    assert abs(fast.omega[1] - reference[1]) <= fast.omega_error[1]
    assert fast.omega_error[1] > 1e-3 * reference[1]


def test_degenerate_modes_grouped() -> None:
    modes = normal_modes(np.diag([1.0, 4.0, 4.0, 4.0, 9.0]), np.ones(5))
    groups = modes.degenerate_groups()
    assert [g.tolist() for g in groups] == [[1, 2, 3]]


def test_sparse_path_with_zero_modes_and_band() -> None:
    system = free_chain(5000)
    K, M = system.hessian(), system.mass_matrix()
    modes = normal_modes(K, M, n_modes=6, solver="sparse")
    np.testing.assert_allclose(modes.omega[1:], free_closed_form(5000)[1:6], rtol=1e-8)
    assert abs(modes.omega[0]) < 1e-6
    band = normal_modes(K, M, band=(0.01, 0.0105))
    exact = free_closed_form(5000)
    inside = exact[(exact >= 0.01) & (exact <= 0.0105)]
    np.testing.assert_allclose(band.omega, inside, rtol=1e-8)


def test_values_only_and_unit_conversions() -> None:
    system = System.from_springs([0.0, 1.16, 2.32], [15.995, 12.0, 15.995], [[0, 1], [1, 2]], 100.0, units="ASE")
    modes = system.modes(vectors=False)
    assert modes.vectors is None and modes.shapes is None
    with pytest.raises(ValueError, match="vectors=False"):
        modes.evolve(np.zeros(3), np.zeros(3), 1.0)
    # Independent conversion: omega (rad per ASE time unit) -> cm^-1 with ASE's own units.
    from ase import units as ase_units

    reference = modes.omega * ase_units.s / (2 * np.pi * ase_units._c * 100)
    np.testing.assert_allclose(modes.wavenumbers_cm1(), reference, rtol=1e-7)  # CODATA 2014 vs 2018
    np.testing.assert_allclose(modes.energies_mev(), modes.omega * ase_units.s * ase_units._hbar * ase_units.J * 1e3,
                               rtol=1e-7)
    with pytest.raises(ValueError, match="dimensionless"):
        normal_modes(np.eye(2), np.ones(2)).frequencies_hz()


# ---------------------------------------------------------------------- immutability
def test_modes_are_immutable() -> None:
    modes = normal_modes(co2_K(), [1.0, 2.0, 1.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        modes.omega = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(ValueError):
        modes.omega[0] = 1.0
    with pytest.raises(ValueError):
        modes.shapes[0, 0] = 1.0


# ---------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("K", "M", "kwargs", "error", "match"),
    [
        (np.array([[1.0, 2.0], [0.0, 1.0]]), [1, 1], {}, ValueError, r"K is not symmetric: \|K\[0,1\] - K\[1,0\]\|"),
        (np.ones((2, 3)), [1, 1], {}, ValueError, r"K must be square"),
        (np.array([[1.0, np.nan], [np.nan, 1.0]]), [1, 1], {}, ValueError, r"K\[0,1\] is nan"),
        (np.eye(2), [1.0, -2.0], {}, ValueError, r"M\[1\] is -2.0; every mass must be positive"),
        (np.eye(2), [1.0, np.inf], {}, ValueError, r"M\[1\] is inf"),
        (np.eye(2), [1.0, 1.0, 1.0], {}, ValueError, r"M must have 2 masses"),
        (np.eye(2), np.array([[1.0, 2.0], [2.0, 1.0]]), {}, ValueError, r"M is not positive definite"),
        (np.eye(2), [1, 1], {"n_modes": 3}, ValueError, r"n_modes is 3; expected 1 <= n_modes <= 2"),
        (np.eye(2), [1, 1], {"n_modes": 1.5}, TypeError, r"n_modes must be an int"),
        (np.eye(2), [1, 1], {"solver": "magic"}, ValueError, r"solver is 'magic'; expected one of"),
        (np.eye(2), [1, 1], {"solver": "accurate"}, ValueError, r"needs spring_factor"),
        (np.eye(2), [1, 1], {"band": (2.0, 1.0)}, ValueError, r"band must be \(low, high\)"),
        ("abc", [1, 1], {}, TypeError, r"K must be an array of real numbers"),
    ],
)
def test_normal_modes_validation_messages(K, M, kwargs, error, match) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(error, match=match):
        normal_modes(K, M, **kwargs)


def test_symmetrize_opt_in_and_indefinite_warns() -> None:
    K = np.array([[2.0, -1.0], [-1.0 + 1e-3, 2.0]])
    modes = normal_modes(K, [1.0, 1.0], symmetrize=True)
    np.testing.assert_allclose(modes.omega_squared, np.linalg.eigvalsh((K + K.T) / 2), rtol=1e-13)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        normal_modes(np.eye(2), [1.0, 1.0])  # a PSD K does not warn
    with pytest.warns(RuntimeWarning, match="1 imaginary mode"):
        modes = normal_modes(np.diag([-9.0, 1.0]), [1.0, 1.0])
    assert modes.omega.tolist() == pytest.approx([-3.0, 1.0])
    assert not np.isnan(modes.omega).any()


def test_top_level_api_is_lazy() -> None:
    import subprocess
    import sys

    code = "import sys, vibra; print(any(m in sys.modules for m in ('pyvista', 'ase', 'phonopy', 'vtk')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
    assert vibra.System is System


def test_banded_path_on_a_3d_chain_and_sparse_diagonal_mass(rng: np.random.Generator) -> None:
    # A zig-zag chain in 3-D with next-nearest springs: K has half-bandwidth 5 (> tridiagonal).
    n_sites = 700
    positions = np.c_[np.arange(n_sites), 0.3 * (np.arange(n_sites) % 2), 0.1 * (np.arange(n_sites) % 3)]
    pairs = np.r_[np.c_[np.arange(n_sites - 1), np.arange(1, n_sites)], np.c_[np.arange(n_sites - 2), np.arange(2, n_sites)]]
    system = System.from_springs(positions, rng.uniform(1, 2, n_sites), pairs, rng.uniform(1, 2, len(pairs)))
    K, masses = system.hessian(), system.mass_matrix()
    reference = np.sqrt(np.abs(np.linalg.eigvalsh(K.toarray() / np.sqrt(np.outer(masses, masses)))))
    banded = normal_modes(K, sp.diags(masses), vectors=False)  # sparse diagonal M stays a vector
    assert banded.solver == "banded"
    # Both are backward-stable absolute-accuracy solvers: agree to ~n eps ||K~|| in omega^2.
    scale = np.finfo(float).eps * K.shape[0] * reference.max() ** 2
    np.testing.assert_allclose(banded.omega**2, reference**2, atol=scale)
    subset = normal_modes(K, masses, n_modes=10, vectors=True, solver="banded")
    np.testing.assert_allclose(subset.omega_squared, reference[:10] ** 2, atol=scale)
    assert subset.residual < 1e-12 and subset.orthogonality < 1e-12
    with pytest.raises(ValueError, match=r"solver='banded' needs diagonal masses"):
        normal_modes(np.eye(2), [[2.0, 0.5], [0.5, 1.0]], solver="banded")


@pytest.mark.parametrize("solver", ["auto", "dense", "tridiagonal", "sparse"])
def test_empty_band_returns_no_modes(solver: str) -> None:
    system = free_chain(50)
    K, M = system.hessian(), system.mass_matrix()
    modes = normal_modes(K, M, band=(5.0, 6.0), solver=solver)  # above the band edge 2
    assert modes.n_modes == 0 and modes.shapes is not None and modes.shapes.shape == (50, 0)


def test_accurate_path_with_a_dense_mass_matrix_and_few_modes(rng: np.random.Generator) -> None:
    """The accurate (Ritz) path keeps relative accuracy with a full SPD mass matrix.

    Truth by congruence: for a free chain B 1 = 0, so with T = I - 1 v^T / (1 + v.1) (whose
    inverse is I + 1 v^T) and M = T^T D T (dense, SPD), T^-T K T^-1 = K and the pencil (K, M)
    has exactly the eigenvalues of (K, D), D diagonal. Those come from Sylvester inertia counts
    of the tridiagonal K - sigma D (negative LDL^T pivots) in mpmath at 40 digits, bisected to
    1e-16 relative, with K built from the spring constants (no float64 rounding of K).
    Springs 1e-3..1 and masses 1..1e3 make ||K~|| / omega_1^2 ~ 1e10, so an absolute-accuracy
    solver loses ~1e-7 relative (LAPACK's generalised eigh is checked to miss 1e-10 here), while
    a relative-accuracy one keeps ~1e-14: the bound 1e-10 sees the difference. Rounding M's
    entries perturbs the eigenvalues by ~eps cond(D^-1/2 M D^-1/2) ~ 1e-15 relative only.
    """
    n = 1600  # above DENSE_LIMIT, so that few modes take the Ritz path
    springs = 10.0 ** rng.uniform(-3.0, 0.0, n - 1)
    diagonal_mass = 10.0 ** rng.uniform(0.0, 3.0, n)
    rows = np.r_[np.arange(n - 1), np.arange(n - 1)]
    B = sp.csr_matrix((np.r_[-np.ones(n - 1), np.ones(n - 1)], (rows, np.r_[np.arange(n - 1), np.arange(1, n)])),
                      shape=(n - 1, n))
    K = (B.T @ sp.diags(springs) @ B).tocsr()
    v = rng.uniform(0.0, 2.0 / n, n)
    T = np.eye(n) - np.outer(np.ones(n), v) / (1.0 + v.sum())
    M = T.T @ (diagonal_mass[:, None] * T)
    M = 0.5 * (M + M.T)
    modes = normal_modes(K, M, n_modes=5, spring_factor=(B, springs))
    assert modes.solver == "accurate-ritz"
    reference = mp_pencil_eigenvalues(springs, diagonal_mass, range(1, 5))
    assert np.max(np.abs(modes.omega_squared[1:] / reference - 1.0)) < 1e-10
    absolute = la.eigh(K.toarray(), M, subset_by_index=(0, 4), eigvals_only=True)
    assert np.max(np.abs(absolute[1:] / reference - 1.0)) > 1e-10  # the case can show a loss
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(5), atol=1e-10)


# ---------------------------------------------------------------------- issue 16: factor and scale
def test_the_spring_factor_is_checked_against_K() -> None:
    """(B, w) must factor K: round-off differences pass, a 1e-6 change in one spring does not.

    Truth: the CO2 axial K = kappa [[1,-1,0],[-1,2,-1],[0,-1,1]] (eq. 157) is B^T diag(w) B for
    the two springs B = [[-1,1,0],[0,-1,1]], w = (kappa, kappa).
    """
    kappa = 1.7
    B = np.array([[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])
    K = co2_K(kappa) * (1.0 + 1e-15)  # a few ulps from B^T W B, as assembly leaves it
    masses = np.array([16.0, 12.0, 16.0])
    modes = normal_modes(K, masses, spring_factor=(B, np.array([kappa, kappa])))
    assert modes.solver.startswith("accurate")
    with pytest.raises(ValueError, match=r"spring_factor \(B, w\) does not factor K: .* for a random x"):
        normal_modes(K, masses, spring_factor=(B, np.array([kappa, kappa * (1 + 1e-6)])))
    other_springs = np.array([[-1.0, 0.0, 1.0], [0.0, -1.0, 1.0]])  # 0-2 and 1-2: another system
    with pytest.raises(ValueError, match=r"does not factor K"):
        normal_modes(K, masses, spring_factor=(other_springs, np.array([kappa, kappa])))


def test_extreme_but_representable_scales_are_solved_and_beyond_them_refused() -> None:
    """max|K| / min(m) up to 1e300 is solved to full relative accuracy; past it, refused.

    Truth: the CO2 axial closed form omega^2 = 0, kappa/m, kappa (1/m + 2/M) (eq. 157).
    """
    kappa, m, big = 1e290, 1e-5, 2e-5
    modes = normal_modes(co2_K(kappa), [m, big, m], vectors=False)
    exact = np.array([kappa / m, kappa * (1 / m + 2 / big)])
    assert np.all(np.isfinite(modes.omega))
    assert np.max(np.abs(modes.omega[1:] ** 2 - exact) / exact) < 1e-13
    with pytest.raises(ValueError, match=r"max\|K\| / min\(M\) is about 1e305 .* would overflow float64"):
        normal_modes(co2_K(1e300), [1e-5, 1.0, 1e-5])
