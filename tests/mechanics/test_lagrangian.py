"""Tests of vibra.mechanics.lagrangian: linearisation of T and V, and the double pendulum of seed 000.

Truth comes from the seed's closed forms (M, K before eq. 13; the quadratic (15); the ratios
(16); the single-mode condition (19)), from sympy.physics.mechanics (an independent
derivation: positions of particles -> LagrangesMethod -> linearize / rhs), and from
invariants (energy, the time integration of the full equations).
"""

from __future__ import annotations

import dataclasses
import doctest

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from sympy.physics.mechanics import LagrangesMethod, Lagrangian, Particle, Point, ReferenceFrame, dynamicsymbols

import vibra.mechanics.lagrangian as lagrangian
from vibra.mechanics.lagrangian import (
    DoublePendulumMotion,
    double_pendulum,
    double_pendulum_frequencies_squared,
    double_pendulum_mode_ratios,
    double_pendulum_rhs,
    double_pendulum_single_mode_offsets,
    integrate_double_pendulum,
    linearize,
)

# (m, m', a, b, g): equal, unequal, and very unequal parameters.
PARAMETERS = [
    (1.0, 1.0, 1.0, 1.0, 9.81),
    (1.0, 2.0, 1.5, 0.7, 9.81),
    (3.0, 0.2, 0.4, 2.5, 1.62),
]

# Entries of M and K are evaluated by sympy at 30 digits and rounded once; the float closed
# forms below round at most a few times: agreement to a few ulps.
ULP_RTOL = 1e-14


def _sympy_double_pendulum():
    """Double pendulum from particle positions (sympy.physics.mechanics), independent of vibra."""
    theta, phi = dynamicsymbols("theta phi")
    theta_dot, phi_dot = dynamicsymbols("theta phi", 1)
    m, mp, a, b, g = sympy.symbols("m mp a b g", positive=True)
    frame = ReferenceFrame("N")
    origin = Point("o")
    origin.set_vel(frame, 0)
    # Seed 000, problem II: x = a sin(theta), y = a cos(theta) with y downward.
    upper = origin.locatenew("m", a * sympy.sin(theta) * frame.x - a * sympy.cos(theta) * frame.y)
    lower = upper.locatenew("mp", b * sympy.sin(phi) * frame.x - b * sympy.cos(phi) * frame.y)
    upper.set_vel(frame, upper.pos_from(origin).dt(frame))
    lower.set_vel(frame, lower.pos_from(origin).dt(frame))
    p1, p2 = Particle("p1", upper, m), Particle("p2", lower, mp)
    p1.potential_energy = m * g * upper.pos_from(origin).dot(frame.y)
    p2.potential_energy = mp * g * lower.pos_from(origin).dot(frame.y)
    method = LagrangesMethod(Lagrangian(frame, p1, p2), [theta, phi])
    method.form_lagranges_equations()
    return method, (theta, phi, theta_dot, phi_dot), (m, mp, a, b, g)


@pytest.fixture(scope="module")
def sympy_pendulum():
    return _sympy_double_pendulum()


@pytest.fixture(scope="module")
def sympy_linearization(sympy_pendulum):
    """(M_lin, A_lin, symbols) of LagrangesMethod.linearize at the hanging position."""
    method, (theta, phi, theta_dot, phi_dot), symbols = sympy_pendulum
    op = {theta: 0, phi: 0, theta_dot: 0, phi_dot: 0}
    M_lin, A_lin = method.linearize(q_ind=[theta, phi], qd_ind=[theta_dot, phi_dot], op_point=op)[:2]
    return M_lin, A_lin, symbols


def _seed_roots_15(m, mp, a, b, g):
    """Roots of (15) exactly as printed in the seed, by sympy (independent of the helper)."""
    r = sympy.Symbol("r")
    equation = ((m + mp) * g - m * a * r) * (g - b * r) - mp * a * g * r
    roots = sympy.Poly(sympy.expand(equation), r).nroots(n=30)
    return np.sort(np.array([float(sympy.re(x)) for x in roots]))


# ---------------------------------------------------------------------- M and K
@pytest.mark.parametrize("params", PARAMETERS)
def test_double_pendulum_matrices_match_seed(params):
    m, mp, a, b, g = params
    system = double_pendulum(*params)
    M_seed = np.array([[(m + mp) * a**2, mp * a * b], [mp * a * b, mp * b**2]])
    K_seed = np.diag([(m + mp) * g * a, mp * g * b])
    np.testing.assert_allclose(system.mass_matrix(), M_seed, rtol=ULP_RTOL)
    np.testing.assert_allclose(system.hessian().toarray(), K_seed, rtol=ULP_RTOL, atol=0)
    assert system.labels == ("theta", "phi")
    assert system.is_generalized


@pytest.mark.parametrize("params", PARAMETERS)
def test_double_pendulum_matches_sympy_mechanics_linearization(params, sympy_linearization):
    M_lin, A_lin, symbols = sympy_linearization
    numbers = dict(zip(symbols, params))
    # M_lin [q'; q''] = A_lin [q; q']: lower-right block of M_lin is M, lower-left of A_lin is -K.
    M_ref = np.array(M_lin[2:, 2:].subs(numbers), dtype=float)
    K_ref = -np.array(A_lin[2:, :2].subs(numbers), dtype=float)
    system = double_pendulum(*params)
    np.testing.assert_allclose(system.mass_matrix(), M_ref, rtol=ULP_RTOL)
    np.testing.assert_allclose(system.hessian().toarray(), K_ref, rtol=ULP_RTOL, atol=0)


def test_inverted_lower_pendulum_matches_sympy_mechanics(sympy_pendulum):
    # Away from the hanging position M depends on q0: at theta = 0, phi = pi (the lower mass
    # balanced upright above the upper one) cos(phi - theta) = -1 flips the coupling, and K
    # has a negative entry: one unstable mode. Independent truth: LagrangesMethod.linearize
    # at the same operating point.
    method, (theta, phi, theta_dot, phi_dot), symbols = sympy_pendulum
    params = PARAMETERS[1]
    op = {theta: 0, phi: sympy.pi, theta_dot: 0, phi_dot: 0}
    M_lin, A_lin = method.linearize(q_ind=[theta, phi], qd_ind=[theta_dot, phi_dot], op_point=op)[:2]
    numbers = dict(zip(symbols, params))
    M_ref = np.array(M_lin[2:, 2:].subs(numbers), dtype=float)
    K_ref = -np.array(A_lin[2:, :2].subs(numbers), dtype=float)
    th, ph, thd, phd = sympy.symbols("theta phi theta_dot phi_dot")
    m, mp, a, b, g = sympy.symbols("m m_prime a b g", positive=True)
    T = ((m + mp) * a**2 * thd**2 + mp * b**2 * phd**2 + 2 * mp * a * b * sympy.cos(ph - th) * thd * phd) / 2
    V = -(m + mp) * g * a * sympy.cos(th) - mp * g * b * sympy.cos(ph)
    system = linearize(T, V, [th, ph], [thd, phd], [0.0, np.pi], dict(zip((m, mp, a, b, g), params)))
    # q0 = pi is rounded to a double (1.2e-16 rad off), which moves M and K by ~1e-16
    # relative: a few ulps.
    np.testing.assert_allclose(system.mass_matrix(), M_ref, rtol=ULP_RTOL)
    np.testing.assert_allclose(system.hessian().toarray(), K_ref, rtol=ULP_RTOL, atol=1e-15 * np.abs(K_ref).max())
    assert system.mass_matrix()[0, 1] < 0  # the coupling m' a b cos(pi) changed sign
    # The squared frequencies solve det(K - r M) = 0 with the sympy matrices (a quadratic in r).
    r = sympy.Symbol("r")
    roots = sympy.Poly((sympy.Matrix(K_ref) - r * sympy.Matrix(M_ref)).det(), r).nroots(n=30)
    expected = np.sort([float(x) for x in roots])
    with pytest.warns(RuntimeWarning, match="imaginary"):
        modes = system.modes()
    # Dense generalised eigensolver, |r| ratio ~ 4 here: 1e-12 relative is a wide margin.
    np.testing.assert_allclose(modes.omega_squared, expected, rtol=1e-12)
    assert expected[0] < 0 < expected[1] and modes.omega[0] < 0  # unstable mode reported as -|omega|


def test_linearize_accepts_dynamicsymbols(sympy_pendulum):
    # The same T and V written with sympy.physics.mechanics dynamicsymbols.
    theta, phi = dynamicsymbols("theta phi")
    theta_dot, phi_dot = dynamicsymbols("theta phi", 1)
    m, mp, a, b, g = sympy.symbols("m mp a b g")
    T = ((m + mp) * a**2 * theta_dot**2 + mp * b**2 * phi_dot**2
         + 2 * mp * a * b * sympy.cos(phi - theta) * theta_dot * phi_dot) / 2
    V = -(m + mp) * g * a * sympy.cos(theta) - mp * g * b * sympy.cos(phi)
    system = linearize(T, V, [theta, phi], [theta_dot, phi_dot], [0, 0], {m: 1.0, mp: 2.0, a: 1.5, b: 0.7, g: 9.81})
    reference = double_pendulum(1.0, 2.0, 1.5, 0.7, 9.81)
    np.testing.assert_allclose(system.mass_matrix(), reference.mass_matrix(), rtol=ULP_RTOL)
    np.testing.assert_allclose(system.hessian().toarray(), reference.hessian().toarray(), rtol=ULP_RTOL)


# ---------------------------------------------------------------------- (15), (16), (19)
@pytest.mark.parametrize("params", PARAMETERS)
def test_squared_frequencies_solve_quadratic_15(params):
    roots = _seed_roots_15(*params)
    modes = double_pendulum(*params).modes()
    # Dense generalised eigensolver: eigenvalues to ~1e-15 * ||M^-1/2 K M^-1/2||; the ratio
    # of the two roots is at most ~60 here, so 1e-12 relative leaves a wide margin.
    np.testing.assert_allclose(modes.omega_squared, roots, rtol=1e-12)
    np.testing.assert_allclose(double_pendulum_frequencies_squared(*params), roots, rtol=1e-14)
    # The seed: one root below g/b, the other above.
    g, b = params[4], params[3]
    assert roots[0] < g / b < roots[1]


@pytest.mark.parametrize("params", PARAMETERS)
def test_mode_ratios_16(params):
    m, mp, a, b, g = params
    r = _seed_roots_15(*params)
    mu_seed = a * r / (g - b * r)
    modes = double_pendulum(*params).modes()
    ratios = modes.shapes[1] / modes.shapes[0]
    # Eigenvectors of a well-separated pair are accurate to ~eps / gap; 1e-10 is generous.
    np.testing.assert_allclose(ratios, mu_seed, rtol=1e-10)
    np.testing.assert_allclose(double_pendulum_mode_ratios(*params), mu_seed, rtol=1e-13)
    # Seed: mu_1 > 1 (in phase) and mu_2 < 0 (opposite phase).
    assert mu_seed[0] > 1.0 and mu_seed[1] < 0.0


@pytest.mark.parametrize("params", PARAMETERS)
def test_single_mode_offsets_19(params):
    m, mp, a, b, g = params
    beta = 0.01
    offsets = double_pendulum_single_mode_offsets(m, mp, a, b, phi0=beta)
    alpha = offsets[:, 0]
    np.testing.assert_array_equal(offsets[:, 1], beta)
    # (19) as printed: (m + m') a alpha^2 + (m + m')(b - a) alpha beta - m' b beta^2 = 0.
    residual = (m + mp) * a * alpha**2 + (m + mp) * (b - a) * alpha * beta - mp * b * beta**2
    scale = (m + mp) * a * alpha**2 + abs((m + mp) * (b - a) * alpha * beta) + mp * b * beta**2
    assert np.all(np.abs(residual) <= 1e-14 * scale)
    # The seed: the in-phase root alpha / beta lies in (0, 1).
    assert 0.0 < alpha[0] / beta < 1.0
    # alpha / beta = 1 / mu (16): same modes.
    r = _seed_roots_15(*params)
    np.testing.assert_allclose(alpha / beta, (g - b * r) / (a * r), rtol=1e-12)
    # Released at rest from each offset, the motion has one normal coordinate only.
    modes = double_pendulum(*params).modes()
    for k in range(2):
        q = modes.normal_coordinates(offsets[k])
        # The other normal coordinate vanishes to rounding in the eigenvectors (~1e-15 relative).
        assert abs(q[1 - k]) <= 1e-12 * abs(q[k])


def test_equal_lengths_closed_forms():
    # Seed: for a = b, alpha = beta sqrt(m'/(m+m')), mu_1 = sqrt((m+m')/m'),
    # r_1 = g / (a (1 + sqrt(m'/(m+m')))).
    m, mp, a, g = 1.3, 0.6, 0.9, 9.81
    offsets = double_pendulum_single_mode_offsets(m, mp, a, a, phi0=1.0)
    np.testing.assert_allclose(offsets[0, 0], np.sqrt(mp / (m + mp)), rtol=1e-14)
    modes = double_pendulum(m, mp, a, a, g).modes()
    np.testing.assert_allclose(modes.shapes[1, 0] / modes.shapes[0, 0], np.sqrt((m + mp) / mp), rtol=1e-10)
    np.testing.assert_allclose(modes.omega_squared[0], g / (a * (1.0 + np.sqrt(mp / (m + mp)))), rtol=1e-12)


def test_single_mode_motion_is_a_simple_oscillation():
    # Seed, after (19): theta = alpha cos(t sqrt(r1)), phi = beta cos(t sqrt(r1)).
    params = PARAMETERS[1]
    m, mp, a, b, g = params
    alpha, beta = double_pendulum_single_mode_offsets(m, mp, a, b, phi0=1e-3)[0]
    r1 = _seed_roots_15(*params)[0]
    t = np.linspace(0.0, 10.0, 201)
    u = double_pendulum(*params).modes().evolve([alpha, beta], [0.0, 0.0], t)
    expected = np.outer(np.cos(np.sqrt(r1) * t), [alpha, beta])
    # Linear motion: exact up to eigenvector / frequency rounding (~1e-12 relative over 10 s).
    np.testing.assert_allclose(u, expected, rtol=0, atol=1e-12 * beta)


# ---------------------------------------------------------------------- non-linear (13)
def test_rhs_matches_sympy_mechanics_equations(sympy_pendulum, rng):
    method, (theta, phi, theta_dot, phi_dot), symbols = sympy_pendulum
    m, mp, a, b, g = PARAMETERS[1]
    numbers = dict(zip(symbols, PARAMETERS[1]))
    rhs = method.rhs().subs(numbers)
    state_symbols = [theta, phi, theta_dot, phi_dot]
    reference = sympy.lambdify(state_symbols, rhs, "numpy")
    for state in rng.uniform(-3.0, 3.0, size=(20, 4)):
        expected = np.asarray(reference(*state), dtype=float).ravel()
        got = double_pendulum_rhs(0.0, state, m, mp, a, b, g)
        # Two float evaluations of the same algebra in different orders: ~1e-15 relative.
        np.testing.assert_allclose(got, expected, rtol=1e-11, atol=1e-11 * np.abs(expected).max())


def test_small_amplitude_motion_matches_nonlinear_integration():
    params = PARAMETERS[1]
    m, mp, a, b, g = params
    modes = double_pendulum(*params).modes()
    r1 = double_pendulum_frequencies_squared(*params)[0]
    t = np.linspace(0.0, 3 * 2 * np.pi / np.sqrt(r1), 400)  # three slow periods
    gaps = []
    amplitudes = np.array([0.004, 0.008, 0.016])
    for amplitude in amplitudes:
        start = amplitude * np.array([0.5, 1.0])  # mixes both modes
        motion = integrate_double_pendulum(*start, t, m=m, m_prime=mp, a=a, b=b, g=g)
        linear = modes.evolve(start, [0.0, 0.0], t)
        gap = np.abs(np.column_stack([motion.theta, motion.phi]) - linear).max()
        gaps.append(gap / amplitude)
    gaps = np.array(gaps)
    # Non-linear corrections shift frequencies by O(amplitude^2): the relative gap falls as
    # amplitude^2 (order measured by a fit; integration error 1e-10 is far below the gaps).
    order = np.polyfit(np.log(amplitudes), np.log(gaps), 1)[0]
    assert abs(order - 2.0) < 0.1
    # And it is small in absolute terms: < 1e-3 of the amplitude at 0.016 rad, where the
    # frequency shift ~ amplitude^2 / 16 accumulates over 3 periods to ~ 3 * 2 pi * 1.6e-5.
    assert gaps[-1] < 1e-3


def test_integration_conserves_energy_at_large_amplitude():
    motion = integrate_double_pendulum(1.2, -0.8, np.linspace(0.0, 10.0, 501))
    drift = np.abs(motion.energy - motion.energy[0]).max() / abs(motion.energy[0])
    # DOP853 at rtol 1e-10 over ~20 oscillations (chaotic regime): drift ~1e-10 per unit time.
    assert drift < 1e-8


def test_integration_agrees_with_independent_solve_ivp_run(sympy_pendulum):
    # Same (13) integrated by scipy's Radau from the sympy.physics.mechanics right-hand side.
    method, (theta, phi, theta_dot, phi_dot), symbols = sympy_pendulum
    params = PARAMETERS[0]
    rhs = sympy.lambdify([theta, phi, theta_dot, phi_dot], method.rhs().subs(dict(zip(symbols, params))), "numpy")
    t = np.linspace(0.0, 2.0, 41)
    reference = solve_ivp(lambda _, y: np.asarray(rhs(*y), dtype=float).ravel(), (0.0, 2.0), [0.6, 0.9, 0.0, 0.0],
                          method="Radau", t_eval=t, rtol=1e-11, atol=1e-13)
    motion = integrate_double_pendulum(0.6, 0.9, t)
    # Both at ~1e-10 local tolerance over 2 s of non-chaotic motion: agree to ~1e-8 rad.
    np.testing.assert_allclose(motion.theta, reference.y[0], atol=1e-7)
    np.testing.assert_allclose(motion.phi, reference.y[1], atol=1e-7)


def test_double_pendulum_motion_is_frozen():
    motion = integrate_double_pendulum(0.1, 0.1, [0.0, 0.5, 1.0])
    assert isinstance(motion, DoublePendulumMotion)
    with pytest.raises(dataclasses.FrozenInstanceError):
        motion.theta = np.zeros(3)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        motion.theta[0] = 1.0


# ---------------------------------------------------------------------- general linearize
def test_tilted_equilibrium_found_by_root_finding_is_accepted():
    # A pendulum with a torsion spring whose rest angle is 1 rad: equilibrium where
    # m g l sin(theta) = c (theta_r - theta); K = m g l cos(theta) + c there.
    th, thd = sympy.symbols("theta theta_dot")
    m, g, l, c, theta_r = 0.5, 9.81, 0.8, 3.0, 1.0
    T = m * l**2 * thd**2 / 2
    V = -m * g * l * sympy.cos(th) + c * (th - theta_r) ** 2 / 2
    q0 = brentq(lambda x: m * g * l * np.sin(x) - c * (theta_r - x), 0.0, 1.0, xtol=1e-15, rtol=1e-15)
    system = linearize(T, V, [th], [thd], [q0])
    np.testing.assert_allclose(system.hessian().toarray()[0, 0], m * g * l * np.cos(q0) + c, rtol=1e-13)
    np.testing.assert_allclose(system.mass_matrix()[0, 0], m * l**2, rtol=1e-15)
    # 1e-4 rad away it is no longer an equilibrium: the residual force names the coordinate.
    with pytest.raises(ValueError, match=r"q0 is not an equilibrium.*theta"):
        linearize(T, V, [th], [thd], [q0 + 1e-4])


def test_rotating_wheel_steady_motion_problem_III():
    # Seed 000, problem III: T = 1/2 m r^2 [w'^2 + 2 sin(al) k w' + (1 - cos^2 al cos^2 w) k^2],
    # force function m g r cos(al) cos(w) (potential energy = minus that). The seed's
    # equation of motion r w'' - r cos^2(al) cos(w) sin(w) k^2 + g cos(al) sin(w) = 0
    # linearised at w = 0 gives Omega^2 = g cos(al) / r - k^2 cos^2(al).
    w, wd = sympy.symbols("omega omega_dot")
    m, r, al, k, g = sympy.symbols("m r alpha k g", positive=True)
    T = m * r**2 * (wd**2 + 2 * sympy.sin(al) * k * wd + (1 - sympy.cos(al) ** 2 * sympy.cos(w) ** 2) * k**2) / 2
    V = -m * g * r * sympy.cos(al) * sympy.cos(w)
    numbers = {m: 0.2, r: 0.5, al: 0.4, k: 2.0, g: 9.81}
    system = linearize(T, V, [w], [wd], [0.0], numbers)
    expected = 9.81 * np.cos(0.4) / 0.5 - 2.0**2 * np.cos(0.4) ** 2
    np.testing.assert_allclose(system.modes().omega_squared[0], expected, rtol=1e-13)
    # The same as a Lagrangian with its velocity-linear term m r^2 sin(al) k w' kept (issue 15):
    # for one coordinate it is a total derivative, so G vanishes (omitted) and nothing changes.
    kept = linearize(lagrangian=T - V, q=[w], qd=[wd], q0=[0.0], values=numbers)
    assert kept.G is None
    np.testing.assert_allclose(kept.modes().omega_squared[0], expected, rtol=1e-13)
    # Spun too fast (k^2 > g / (r cos al)), the bottom of the channel is unstable.
    fast = linearize(lagrangian=T - V, q=[w], qd=[wd], q0=[0.0], values={**numbers, k: 5.0})
    with pytest.warns(RuntimeWarning, match="imaginary"):
        assert fast.modes().omega[0] < 0


def test_gyroscopic_terms_are_kept():
    # A particle seen from a frame turning at unit rate: T has x' y - y' x terms (Coriolis).
    # Formerly refused; now G = N - N^T = [[0, -2], [2, 0]] and K = diag(6 - 1, 6 - 1)
    # (centrifugal -1). In the fixed frame the particle oscillates at sqrt(6); seen from the
    # rotating frame its frequencies are sqrt(6) -+ 1.
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    T = ((xd - y) ** 2 + (yd + x) ** 2) / 2
    V = 3 * (x**2 + y**2)
    system = linearize(T, V, [x, y], [xd, yd], [0.0, 0.0])
    np.testing.assert_array_equal(system.G, [[0.0, -2.0], [2.0, 0.0]])
    np.testing.assert_array_equal(system.K, np.diag([5.0, 5.0]))
    modes = system.modes()
    expected = np.sqrt(6.0) + np.array([-1.0, 1.0])
    # A 4 x 4 Hermitian eigensolve of norm ~3.4: a few ulps of it (measured 4.4e-15).
    np.testing.assert_allclose(modes.natural_frequency, expected, rtol=1e-14)
    assert np.all(np.abs(modes.natural_frequency - expected) <= modes.omega_error)


def test_q0_as_mapping_and_values_by_name():
    th, thd = sympy.symbols("theta theta_dot")
    m, l, g = sympy.symbols("m l g", positive=True)
    system = linearize(m * l**2 * thd**2 / 2, -m * g * l * sympy.cos(th), [th], [thd], {"theta": 0.0},
                       {"m": 2.0, "l": 0.5, "g": 9.81})
    np.testing.assert_allclose(system.hessian().toarray(), [[2.0 * 9.81 * 0.5]], rtol=1e-15)
    np.testing.assert_allclose(system.mass_matrix(), [[2.0 * 0.25]], rtol=1e-15)


def test_docstring_examples_run():
    failures, _ = doctest.testmod(lagrangian, optionflags=doctest.ELLIPSIS)
    assert failures == 0


# ---------------------------------------------------------------------- bad input
TH, PH, THD, PHD, G_SYM = sympy.symbols("theta phi theta_dot phi_dot g")
T2 = (THD**2 + PHD**2) / 2
V2 = -G_SYM * (sympy.cos(TH) + sympy.cos(PH))


@pytest.mark.parametrize(
    ("kwargs", "error", "pattern"),
    [
        (dict(q0=[0.3, 0.0]), ValueError, r"q0 is not an equilibrium.*Q\[0\].*theta"),
        (dict(values={}), ValueError, r"symbols left without values: \['g'\]"),
        (dict(qd=[THD]), ValueError, r"q has 2 coordinate\(s\) but qd has 1 velocity"),
        (dict(q=[TH, TH]), ValueError, r"q\[1\] repeats q\[0\] \(theta\)"),
        (dict(qd=[THD, TH]), ValueError, r"qd\[1\] \(theta\) is also a coordinate"),
        (dict(q=[TH, "phi"]), TypeError, r"q\[1\] must be a sympy Symbol"),
        (dict(q=TH), TypeError, r"q must be a list of sympy symbols"),
        (dict(q=[]), ValueError, r"q is empty"),
        (dict(q0=[0.0]), ValueError, r"q0 must have 2 value\(s\)"),
        (dict(q0={"theta": 0.0}), ValueError, r"q0 has no value for coordinate q\[1\] \(phi\)"),
        (dict(q0={"theta": 0.0, "phi": 0.0, "psi": 1.0}), ValueError, r"q0 names \['psi'\]"),
        (dict(q0=[0.0, np.nan]), ValueError, r"q0\[1\] is .*nan"),
        (dict(values={G_SYM: np.inf}), ValueError, r"values\[g\] is inf"),
        (dict(values={G_SYM: "9.81"}), TypeError, r"values\[g\] must be a real number"),
        (dict(values=[9.81]), TypeError, r"values must be a mapping"),
        (dict(values={1: 9.81}), TypeError, r"values has key 1"),
        (dict(values={G_SYM: 9.81, TH: 0.0}), ValueError, r"values gives a number to theta"),
        (dict(T="theta_dot**2"), TypeError, r"T must be a sympy expression, got a str"),
        (dict(V=[1.0]), TypeError, r"V must be a sympy expression, got list"),
        (dict(V=V2 + PHD), ValueError, r"V depends on the velocity qd\[1\] \(phi_dot\)"),
        (dict(T=(THD**2 - PHD**2) / 2), ValueError, r"T is not positive definite at q0"),
        (dict(T=THD**2 / 2), ValueError, r"T is not positive definite at q0"),
        (dict(V=V2 + sympy.sqrt(TH - 1)), ValueError, r"is not real|not an equilibrium|real and finite"),
        (dict(rtol=0.0), ValueError, r"rtol is 0.0"),
        (dict(q0={"theta": 0.0, "phi": "0"}), TypeError, r"q0\[phi\] must be a real number, got str"),
        (dict(q0={TH: 0.0, PH: np.inf}), ValueError, r"q0\[phi\] is inf"),
    ],
)
def test_linearize_rejects_bad_input(kwargs, error, pattern):
    arguments = dict(T=T2, V=V2, q=[TH, PH], qd=[THD, PHD], q0=[0.0, 0.0], values={G_SYM: 9.81})
    arguments.update(kwargs)
    with pytest.raises(error, match=pattern):
        linearize(arguments.pop("T"), arguments.pop("V"), arguments.pop("q"), arguments.pop("qd"),
                  arguments.pop("q0"), arguments.pop("values"), **arguments)


def test_value_not_real_at_q0_is_reported():
    with pytest.raises(ValueError, match=r"must be real and finite there"):
        linearize(T2, V2 + sympy.sqrt(TH - 1), [TH, PH], [THD, PHD], [0.0, 0.0], {G_SYM: 9.81})


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [(dict(m=0.0), r"m is 0.0"), (dict(m_prime=-1.0), r"m_prime is -1.0"), (dict(a=np.nan), r"a is .*nan"),
     (dict(g=0.0), r"g is 0.0")],
)
def test_double_pendulum_rejects_bad_parameters(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        double_pendulum(**kwargs)


@pytest.mark.parametrize(
    ("t", "pattern"),
    [([0.0], r"t must hold at least 2 times"), ([0.0, 1.0, 1.0], r"t must increase: t\[2\]"),
     ([[0.0, 1.0]], r"t must be 1-D")],
)
def test_integrate_rejects_bad_times(t, pattern):
    with pytest.raises(ValueError, match=pattern):
        integrate_double_pendulum(0.1, 0.1, t)


@pytest.mark.parametrize(
    ("kwargs", "error", "pattern"),
    [
        (dict(theta0=np.nan), ValueError, r"theta0 is nan; it must be finite"),
        (dict(phi0="0.1"), TypeError, r"phi0 must be a real number, got str"),
        (dict(theta_dot0=np.inf), ValueError, r"theta_dot0 is inf"),
        (dict(phi_dot0=[1.0]), TypeError, r"phi_dot0 must be a real number, got list"),
        (dict(b=-1.0), ValueError, r"b is -1.0; it must be positive"),
        (dict(rtol=0.0), ValueError, r"rtol is 0.0; an integration tolerance must be positive"),
        (dict(atol=-1.0), ValueError, r"atol is -1.0"),
    ],
)
def test_integrate_rejects_bad_arguments(kwargs, error, pattern):
    arguments = dict(theta0=0.1, phi0=0.1, t=[0.0, 1.0])
    arguments.update(kwargs)
    with pytest.raises(error, match=pattern):
        integrate_double_pendulum(arguments.pop("theta0"), arguments.pop("phi0"), arguments.pop("t"), **arguments)


def test_single_mode_offsets_rejects_bad_phi0():
    with pytest.raises(ValueError, match=r"phi0 is nan; it must be finite"):
        double_pendulum_single_mode_offsets(phi0=np.nan)
