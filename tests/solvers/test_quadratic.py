"""Gyroscopic and damped modes (issue 15, items 3 and 4): vibra.solvers.structured.quadratic and GeneralizedSystem.

Truth: closed forms (the charged particle in a magnetic field, the Foucault pendulum, the
gyroscopic-stabilisation quartic, the damped oscillator's roots), scipy.linalg.eig of the
companion form, and direct integration with scipy's solve_ivp (energy balance: a gyroscopic
term does no work, a damping term dissipates q'^T C q').
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as la
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import vibra
from vibra.mechanics.gyroscopic import charged_particle, foucault_pendulum, spinning_wheel
from vibra.mechanics.lagrangian import linearize
from vibra.solvers.structured.quadratic import QuadraticModes, check_gyroscopic, quadratic_modes

EPS = float(np.finfo(float).eps)
J = np.array([[0.0, -1.0], [1.0, 0.0]])


def _integrate(M, G, C, K, q0, v0, times, rtol=1e-12):
    """q(t), q'(t) and the dissipated work int q'^T C q' dt, by DOP853 (independent of vibra)."""
    n = len(q0)
    D = G + C

    def rhs(_, z):
        q, v = z[:n], z[n:2 * n]
        return np.concatenate([v, np.linalg.solve(M, -K @ q - D @ v), [v @ C @ v]])
    solution = solve_ivp(rhs, (times[0], times[-1]), np.concatenate([q0, v0, [0.0]]), t_eval=times,
                         method="DOP853", rtol=rtol, atol=1e-14)
    assert solution.success
    return solution.y[:n].T, solution.y[n:2 * n].T, solution.y[-1]


def _energy(M, K, q, v):
    return 0.5 * np.einsum("ti,ij,tj->t", v, M, v) + 0.5 * np.einsum("ti,ij,tj->t", q, K, q)


# ---------------------------------------------------------------------- charged particle
def _charged_particle(omega0, omega_c, mass=1.0):
    """A charge in an isotropic 2-D well in a field B along z, from its Lagrangian (seed 003 ex. 4).

    L = m (x'^2 + y'^2) / 2 - m omega0^2 (x^2 + y^2) / 2 + (q B / 2)(x y' - y x'), q B = m omega_c.
    """
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    m, w0, qB = sympy.symbols("m omega0 qB", positive=True)
    L = m * (xd**2 + yd**2) / 2 - m * w0**2 * (x**2 + y**2) / 2 + qB * (x * yd - y * xd) / 2
    return linearize(lagrangian=L, q=[x, y], qd=[xd, yd], q0=[0.0, 0.0],
                     values={m: mass, w0: omega0, qB: mass * omega_c})


def _charged_closed_form(omega0, omega_c):
    """sqrt(omega0^2 + omega_c^2 / 4) -+ omega_c / 2, the smaller one as omega0^2 / the larger."""
    upper = np.hypot(omega0, omega_c / 2) + omega_c / 2
    return np.array([omega0**2 / upper, upper])


def test_charged_particle_builder_matches_the_lagrangian():
    # The public builder (for scenes) against the Lagrangian written here.
    built = charged_particle(mass=2.0, omega0=3.0, charge=-1.5, field=0.4)
    here = _charged_particle(3.0, -1.5 * 0.4 / 2.0, mass=2.0)
    for name in ("M", "K", "G"):
        np.testing.assert_allclose(getattr(built, name), getattr(here, name), rtol=1e-15)
    np.testing.assert_allclose(built.modes().natural_frequency, _charged_closed_form(3.0, 0.3), rtol=1e-14)


def test_foucault_builder_precesses_once_a_sidereal_day_at_the_pole():
    modes = foucault_pendulum(latitude=np.pi / 2).modes()
    turn = np.diff(modes.natural_frequency)[0] / 2
    np.testing.assert_allclose(2 * np.pi / turn, 2 * np.pi / 7.2921159e-5, rtol=1e-9)


def test_charged_particle_in_a_magnetic_field():
    system = _charged_particle(1.3, 0.7, mass=2.5)
    np.testing.assert_allclose(system.G, 2.5 * 0.7 * J, rtol=1e-15)
    modes = system.modes()
    assert isinstance(modes, QuadraticModes) and modes.method == "skew-symmetric"
    expected = _charged_closed_form(1.3, 0.7)
    np.testing.assert_allclose(modes.natural_frequency, expected, rtol=1e-14)
    np.testing.assert_allclose(modes.omega, expected, rtol=1e-14)
    # Structure preserved: exactly imaginary eigenvalues, zero damping ratios, stable.
    assert np.all(modes.eigenvalues.real == 0.0) and np.all(modes.damping_ratio == 0.0) and modes.stable
    # Circular modes: |x| = |y| and a quarter period between them (counter-rotating pair).
    np.testing.assert_allclose(np.abs(modes.shapes), 1.0, rtol=1e-13)


@settings(max_examples=60, deadline=None)
@given(st.floats(-6, 6), st.floats(-6, 6), st.floats(-3, 3))
def test_charged_particle_over_twelve_decades(log_omega0, log_omega_c, log_mass):
    omega0, omega_c = 10.0**log_omega0, 10.0**log_omega_c
    modes = _charged_particle(omega0, omega_c, 10.0**log_mass).modes()
    expected = _charged_closed_form(omega0, omega_c)
    error = np.abs(modes.natural_frequency - expected)
    # Both frequencies to a few ulps although they differ by up to 1e12 (the small one comes
    # from A^-1), and omega_error covers the true error.
    assert np.all(error <= 64 * EPS * expected), error / expected
    assert np.all(error <= modes.omega_error)


# ---------------------------------------------------------------------- Foucault
@pytest.mark.parametrize("latitude", [np.pi / 2, 0.85, 0.1, -0.6])
def test_foucault_pendulum(latitude):
    # Bob coordinates (x, y) in the Earth's frame; the vertical component Omega sin(phi) of the
    # Earth's rotation gives the Coriolis term: omega = sqrt(g/l + Omega^2 sin^2 phi) +- Omega sin phi.
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    g, length, rate = 9.81, 67.0, 7.2921159e-5       # the Pantheon's pendulum, Earth's sidereal rate
    vertical = rate * np.sin(latitude)
    L = (xd**2 + yd**2) / 2 + vertical * (x * yd - y * xd) - g / length * (x**2 + y**2) / 2
    modes = linearize(lagrangian=L, q=[x, y], qd=[xd, yd], q0=[0.0, 0.0]).modes()
    upper = np.sqrt(g / length + vertical**2) + abs(vertical)
    expected = np.array([(g / length) / upper, upper])
    np.testing.assert_allclose(modes.natural_frequency, expected, rtol=1e-14)
    # The swing plane turns at -Omega sin(phi): half the difference of the two frequencies.
    np.testing.assert_allclose(np.diff(modes.natural_frequency)[0] / 2, abs(vertical), rtol=1e-9)


# ---------------------------------------------------------------------- stabilisation
def _stabilisation_roots(k1, k2, g):
    """omega^2 from omega^4 + (k1 + k2 - g^2) omega^2 + k1 k2 = 0 (M = 1, K = -diag(k1, k2), G = g J)."""
    return np.roots([1.0, k1 + k2 - g * g, k1 * k2]).astype(complex)


@pytest.mark.parametrize("g", [3.0, 5.0, 40.0])
def test_gyroscopic_stabilisation_against_integration(g):
    # K = -diag(1, 2) is unstable alone; G = g J stabilises it when g > 1 + sqrt(2).
    K, G, M = -np.diag([1.0, 2.0]), g * J, np.eye(2)
    system = vibra.System.generalized(M, K, G=G)
    modes = system.modes()
    assert modes.method == "hamiltonian" and modes.stable
    assert np.all(modes.eigenvalues.real == 0.0)           # put on the axis (simple, self-mirrored)
    expected = np.sort(np.sqrt(_stabilisation_roots(1.0, 2.0, g).real))
    np.testing.assert_allclose(modes.natural_frequency, expected, rtol=1e-12)
    times = np.linspace(0.0, 30.0, 301)
    q0, v0 = np.array([0.1, -0.05]), np.array([0.02, 0.03])
    q, v, _ = _integrate(M, G, np.zeros((2, 2)), K, q0, v0, times)
    np.testing.assert_allclose(modes.evolve(q0, v0, times), q, atol=1e-9)
    # A gyroscopic force does no work: the energy is constant along the integration.
    energy = _energy(M, K, q, v)
    assert np.ptp(energy) < 1e-10 * np.abs(energy).max()


def test_too_little_spin_is_reported_unstable():
    K, G = -np.diag([1.0, 2.0]), 2.0 * J            # below the threshold 1 + sqrt(2)
    with pytest.warns(RuntimeWarning, match=r"the system is unstable: 1 growing mode\(s\) \(mode \d: Re lambda = "):
        modes = vibra.System.generalized(np.eye(2), K, G=G).modes()
    assert not modes.stable and modes.unstable.sum() == 1
    # The quadruple +-a +-ib: a = Re sqrt(omega^2 root) from the quartic.
    rate = np.abs(np.sqrt(-_stabilisation_roots(1.0, 2.0, 2.0)).real).max()
    np.testing.assert_allclose(modes.growth_rate.max(), rate, rtol=1e-12)
    # The integration grows at that rate.
    times = np.array([0.0, 10.0, 20.0])
    q, _, _ = _integrate(np.eye(2), G, np.zeros((2, 2)), K, np.array([1e-6, 0.0]), np.zeros(2), times)
    growth = np.log(np.linalg.norm(q[2]) / np.linalg.norm(q[1])) / 10.0
    assert abs(growth - rate) < 1e-3


def test_divergence_is_a_negative_natural_frequency():
    with pytest.warns(RuntimeWarning, match="unstable"):
        modes = quadratic_modes(np.eye(2), np.diag([-4.0, 1.0]), G=np.zeros((2, 2)))
    np.testing.assert_allclose(modes.natural_frequency, [-2.0, 1.0], rtol=1e-14)
    assert modes.unstable.tolist() == [True, False]


def test_spinning_top_rotating_wheel_with_its_coupling_kept():
    # A wheel spinning at rate s about its axis, pivoted at its lowest point and standing
    # upright (the sleeping top): tilts (a, b) with M = I1, G = I3 s J, K = -m g l. Stable when
    # I3 s > 2 sqrt(I1 m g l) (Maxwell's criterion), omega = (I3 s +- sqrt(I3^2 s^2 - 4 I1 m g l)) / (2 I1).
    mass, radius, height, g = 2.0, 0.3, 0.2, 9.81
    I3 = mass * radius**2 / 2
    I1 = mass * radius**2 / 4 + mass * height**2
    for spin in (40.0, 200.0):
        system = spinning_wheel(mass, radius, height, spin, g=g)
        modes = system.modes()
        root = np.sqrt((I3 * spin) ** 2 - 4 * I1 * mass * g * height)
        expected = np.array([(I3 * spin - root) / (2 * I1), (I3 * spin + root) / (2 * I1)])
        np.testing.assert_allclose(modes.natural_frequency, expected, rtol=1e-12)
        assert modes.stable
    with pytest.warns(RuntimeWarning, match="unstable"):
        assert not spinning_wheel(mass, radius, height, 5.0, g=g).modes().stable


# ---------------------------------------------------------------------- damped
def _companion_eigenvalues(M, D, K):
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(M, K), -la.solve(M, D)]])
    return la.eig(A, right=False)


@pytest.mark.parametrize("seed", range(5))
def test_non_proportional_damping_against_the_companion_form(seed):
    rng = np.random.default_rng(seed)
    n = 4
    X = rng.normal(size=(n, n))
    M = X @ X.T + n * np.eye(n)
    Y = rng.normal(size=(n, n))
    K = Y @ Y.T + np.eye(n)
    C = np.diag(rng.uniform(0.0, 2.0, n))                   # not proportional to M or K
    G = (lambda Z: Z - Z.T)(rng.normal(size=(n, n))) if seed % 2 else np.zeros((n, n))
    system = vibra.System.generalized(M, K, C=C, G=G if G.any() else None)
    modes = system.modes()
    assert modes.method == "companion"
    reference = _companion_eigenvalues(M, G + C, K)
    ours = modes.eigenvalues.reshape(-1)
    for value in reference:     # every companion eigenvalue is one of ours
        assert np.min(np.abs(ours - value)) <= 1e-12 * np.abs(reference).max()
    # Per mode: natural frequency |lambda| and damping ratio -Re lambda / |lambda| of the pair.
    first = modes.eigenvalues[:, 0]
    complex_pairs = first.imag > 0
    np.testing.assert_allclose(modes.natural_frequency[complex_pairs], np.abs(first[complex_pairs]), rtol=1e-13)
    np.testing.assert_allclose(modes.damping_ratio[complex_pairs],
                               -first[complex_pairs].real / np.abs(first[complex_pairs]), rtol=1e-12)
    # The shapes solve the quadratic eigenproblem.
    for k in range(n):
        value, shape = modes.eigenvalues[k, 0], modes.shapes[:, k]
        gap = (value**2 * M + value * (G + C) + K) @ shape
        assert np.linalg.norm(gap) <= 1e-12 * (abs(value) ** 2 * la.norm(M) + la.norm(K)) * np.linalg.norm(shape)


def test_damped_motion_and_energy_balance_against_integration():
    M = np.array([[2.0, 0.3, 0.0], [0.3, 1.0, 0.1], [0.0, 0.1, 1.5]])
    K = np.array([[4.0, -2.0, 0.0], [-2.0, 5.0, -1.0], [0.0, -1.0, 3.0]])
    C = np.array([[0.4, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.05]])
    G = np.array([[0.0, 0.5, 0.0], [-0.5, 0.0, 0.2], [0.0, -0.2, 0.0]])
    modes = quadratic_modes(M, K, G=G, C=C)
    assert modes.stable and np.all(modes.damping_ratio > 0)
    times = np.linspace(0.0, 20.0, 201)
    q0, v0 = np.array([0.1, 0.0, -0.2]), np.array([0.0, 0.3, 0.0])
    q, v, dissipated = _integrate(M, G, C, K, q0, v0, times)
    np.testing.assert_allclose(modes.evolve(q0, v0, times), q, atol=1e-10)
    # Energy balance: E(t) + int_0^t q'^T C q' = E(0) (G does no work).
    energy = _energy(M, K, q, v)
    np.testing.assert_allclose(energy + dissipated, energy[0], rtol=0, atol=1e-11 * energy[0])
    assert energy[-1] < 0.5 * energy[0]


@settings(max_examples=60, deadline=None)
@given(st.floats(-6, 6), st.sampled_from([-1e-12, 0.0, 1e-12]), st.floats(-3, 3))
def test_continuous_through_critical_damping(log_omega0, offset, log_mass):
    # A 1-dof oscillator m q'' + 2 zeta omega0 m q' + m omega0^2 q = 0 at zeta = 1 +- 1e-12: the
    # two roots meet, yet omega_n and zeta come out to a few ulps on either side.
    omega0, mass, zeta = 10.0**log_omega0, 10.0**log_mass, 1.0 + offset
    modes = quadratic_modes([mass], [[mass * omega0**2]], C=[[2.0 * zeta * omega0 * mass]])
    assert abs(modes.natural_frequency[0] / omega0 - 1.0) <= 8 * EPS
    assert abs(modes.damping_ratio[0] - zeta) <= 8 * EPS
    assert abs(modes.natural_frequency[0] - omega0) <= modes.omega_error[0]


@settings(max_examples=40, deadline=None)
@given(st.floats(-12, 6), st.floats(-6, 6))
def test_damping_ratios_over_eighteen_decades(log_zeta, log_omega0):
    # Light to heavy damping: roots -omega0 (zeta -+ sqrt(zeta^2 - 1)) in closed form.
    zeta, omega0 = 10.0**log_zeta, 10.0**log_omega0
    modes = quadratic_modes([1.0], [[omega0**2]], C=[[2.0 * zeta * omega0]])
    assert abs(modes.damping_ratio[0] / zeta - 1.0) <= 8 * EPS
    assert abs(modes.natural_frequency[0] / omega0 - 1.0) <= 8 * EPS
    if zeta < 1:
        # omega_d = omega0 sqrt(1 - zeta^2) has condition number 1 / (1 - zeta^2) in C's rounding.
        condition = 1.0 / ((1 - zeta) * (1 + zeta))
        np.testing.assert_allclose(modes.omega[0], omega0 * np.sqrt((1 - zeta) * (1 + zeta)),
                                   rtol=16 * EPS * (1 + condition))


def test_damping_from_a_rayleigh_function_and_the_response_module():
    # linearize(..., dissipation=R) -> C; the response module takes hessian, mass and damping.
    from vibra.response import frequency_response

    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    T = (2 * xd**2 + yd**2 + xd * yd) / 2
    V = (3 * x**2 + 2 * y**2 - 2 * x * y) / 2
    R = (0.4 * xd**2 + 0.1 * (xd - yd) ** 2) / 2
    system = linearize(T, V, [x, y], [xd, yd], [0.0, 0.0], dissipation=R)
    np.testing.assert_allclose(system.C, [[0.5, -0.1], [-0.1, 0.1]], rtol=1e-15)
    assert system.is_quadratic and system.G is None
    omegas = np.array([0.3, 1.1, 2.0])
    force = np.array([1.0, 0.0])
    for method in ("direct", "state_space"):
        response = frequency_response(system.hessian(), system.mass_matrix(), system.damping_matrix(),
                                      omegas, force, method=method).response
        for w, x_w in zip(omegas, response):
            expected = np.linalg.solve(system.K - w**2 * system.M + 1j * w * system.C, force)
            np.testing.assert_allclose(x_w, expected, rtol=1e-12)


def test_result_is_frozen_and_reports_units():
    modes = vibra.System.generalized(np.eye(2), np.eye(2), G=J, units="SI").modes()
    with pytest.raises(dataclasses.FrozenInstanceError):
        modes.method = "x"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        modes.natural_frequency[0] = 0.0
    np.testing.assert_allclose(modes.frequencies_hz(), modes.natural_frequency / (2 * np.pi), rtol=1e-15)
    assert modes.n_modes == 2


def test_generalized_system_carries_G_and_C_through_freeze():
    C = np.diag([0.1, 0.2, 0.3])
    system = vibra.System.generalized(np.eye(3), np.diag([1.0, 2.0, 3.0]), C=C).freeze(dofs=[1])
    np.testing.assert_array_equal(system.damping_matrix(), np.diag([0.1, 0.3]))
    assert system.gyroscopic_matrix() is None
    assert system.modes().n_modes == 2


@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda: vibra.System.generalized(np.eye(2), np.eye(2), G=np.eye(2)), ValueError,
         r"G is not skew-symmetric: \|G\[0,0\] \+ G\[0,0\]\| = 2 > atol=1e-10 .*its symmetric part belongs in C"),
        (lambda: vibra.System.generalized(np.eye(2), np.eye(2), G=np.zeros((3, 3))), ValueError,
         r"G must be \(2, 2\) to match K, got shape \(3, 3\)"),
        (lambda: vibra.System.generalized(np.eye(2), np.eye(2), C=[[1.0, 0.5], [0.0, 1.0]]), ValueError,
         r"C is not symmetric"),
        (lambda: vibra.System.generalized(np.eye(2), np.eye(2), C=np.eye(3)), ValueError,
         r"C must be \(2, 2\) to match K, got shape \(3, 3\)"),
        (lambda: vibra.System.generalized(np.eye(2), np.eye(2), C=np.eye(2)).modes(n_modes=1), ValueError,
         r"n_modes and band are not available for a system with G or C"),
        (lambda: quadratic_modes(np.eye(2), np.eye(2), G=J).evolve([1.0], [0.0, 0.0], [0.0]), ValueError,
         r"q0 must have 2 entries \(one per coordinate\), got 1"),
        (lambda: quadratic_modes(np.eye(2), np.eye(2), G=J).evolve([1.0, 0.0], [0.0, np.nan], [0.0]), ValueError,
         r"v0"),
        (lambda: quadratic_modes([1.0, -1.0], np.eye(2)), ValueError, r"M\[1\]"),
        (lambda: quadratic_modes(np.eye(3), np.eye(2)), ValueError, r"M must be \(2, 2\) to match K"),
        (lambda: quadratic_modes(np.eye(2), np.ones((2, 3))), ValueError, r"K must be square"),
        (lambda: check_gyroscopic("x", 2), TypeError, r"G"),
        (lambda: foucault_pendulum(latitude=2.0), ValueError, r"latitude is 2.0 rad; it must lie in \[-pi/2, pi/2\]"),
        (lambda: foucault_pendulum(length=0.0), ValueError, r"length"),
        (lambda: charged_particle(mass=-1.0), ValueError, r"mass"),
        (lambda: charged_particle(field=np.inf), ValueError, r"field is inf"),
        (lambda: spinning_wheel(radius=0.0), ValueError, r"radius"),
        (lambda: spinning_wheel(spin="fast"), TypeError, r"spin must be a real number"),
    ],
)
def test_validation_messages(call, error, pattern):
    with pytest.raises(error, match=pattern):
        call()
