"""Ill-conditioned mass matrices (issue 15, item 2): vibra.solvers.structured.pencil and its use by linearize.

Truth: seed 000's eq. (15), the double pendulum's closed form, evaluated in 50-digit mpmath
for the float parameters; scipy.linalg.eigh (an independent solver) on well-conditioned
problems; mpmath's eigensolver (mp.eig of M^-1 K at 120 digits) for random graded pencils.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.linalg as la
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

import vibra
from vibra.mechanics.lagrangian import double_pendulum, linearize
from vibra.modes import pencil_modes
from vibra.solvers.structured.pencil import check_mass_matrix, scaled_condition

EPS = float(np.finfo(float).eps)


def _eq15_roots(m, m_prime, a, b, g):
    """Roots r1 < r2 of seed 000 eq. (15) in 50-digit mpmath for the float parameters."""
    with mpmath.workdps(50):
        m, m_prime, a, b, g = (mpmath.mpf(x) for x in (m, m_prime, a, b, g))
        quadratic, linear, constant = m * a * b, -(m + m_prime) * g * (a + b), (m + m_prime) * g * g
        root = mpmath.sqrt(linear**2 - 4 * quadratic * constant)
        return [float((-linear - root) / (2 * quadratic)), float((-linear + root) / (2 * quadratic))]


def test_the_issue_double_pendulum_is_accepted_and_accurate():
    # Seed 000 problem II with m = 1e-3, m' = 1e3, a = 1, b = 1e-3: cond(M) ~ 1e12. Formerly
    # refused ("T is not positive definite"); both roots of (15) to 1e-9 relative now.
    system = double_pendulum(m=1e-3, m_prime=1e3, a=1.0, b=1e-3)
    assert np.linalg.cond(system.M) > 1e11
    modes = system.modes()
    assert modes.solver == "pencil-jacobi"
    expected = np.array(_eq15_roots(1e-3, 1e3, 1.0, 1e-3, 9.81))
    error = np.abs(modes.omega**2 / expected - 1.0)
    assert np.all(error < 1e-9), error          # measured: 9e-16 and 1.7e-10 (the rounding of M itself)
    # omega_error is honest: it covers the true error, within a factor 100 of it for the upper root.
    true_omega_error = np.abs(modes.omega - np.sqrt(expected))
    assert np.all(true_omega_error <= modes.omega_error)
    assert modes.omega_error[1] < 100 * true_omega_error[1]
    np.testing.assert_allclose(modes.shapes.T @ system.M @ modes.shapes, np.eye(2), atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.floats(-12, 12), st.floats(-6, 6), st.floats(-6, 6), st.floats(-6, 6))
def test_double_pendulum_over_twelve_decades(log_mass_ratio, log_m, log_a, log_b):
    # m' / m from 1e-12 to 1e12 and lengths over 1e-6..1e6: both roots of (15) to 1e-9 relative
    # whenever M is not singular to working precision.
    m = 10.0**log_m
    m_prime, a, b = m * 10.0**log_mass_ratio, 10.0**log_a, 10.0**log_b
    try:
        system = double_pendulum(m=m, m_prime=m_prime, a=a, b=b)
    except ValueError as error:
        assert "condition number" in str(error)
        return
    expected = np.array(_eq15_roots(m, m_prime, a, b, 9.81))
    modes = system.modes()
    relative = np.abs(modes.omega**2 / expected - 1.0)
    # First-order perturbation bound for the rounding of M's and K's entries: a few eps * cond(D M D).
    bound = max(1e-9, 16 * EPS * scaled_condition(system.M))
    assert np.all(relative <= bound), (relative, bound)
    assert np.all(np.abs(modes.omega - np.sqrt(expected)) <= modes.omega_error + 4 * EPS * np.sqrt(expected))


def test_linearize_accepts_the_ill_conditioned_double_pendulum():
    theta, phi, theta_dot, phi_dot = sympy.symbols("theta phi theta_dot phi_dot")
    m, mp, a, b, g = 1e-3, 1e3, 1.0, 1e-3, 9.81
    T = ((m + mp) * a**2 * theta_dot**2 + mp * b**2 * phi_dot**2
         + 2 * mp * a * b * sympy.cos(phi - theta) * theta_dot * phi_dot) / 2
    V = -(m + mp) * g * a * sympy.cos(theta) - mp * g * b * sympy.cos(phi)
    modes = linearize(T, V, [theta, phi], [theta_dot, phi_dot], [0.0, 0.0]).modes()
    np.testing.assert_allclose(modes.omega**2, _eq15_roots(m, mp, a, b, g), rtol=1e-9)


def _mp_pencil(K, M):
    """Eigenvalues of (K, M) at 120 digits (spreads of 1e48 need them): mp.eig of M^-1 K."""
    with mpmath.workdps(120):
        Km, Mm = mpmath.matrix(K.tolist()), mpmath.matrix(M.tolist())
        values = mpmath.eig(Mm**-1 * Km, left=False, right=False)
        return np.sort(np.array([float(mpmath.re(v)) for v in values]))


@pytest.mark.parametrize("seed", range(4))
def test_graded_pencils_against_mpmath(seed):
    # M = S A S and K = E B E with well-conditioned A, B and scalings S, E over 1e-6..1e6: cond(M)
    # and cond(K) up to 1e24, yet every eigenvalue is determined to ~eps cond(A) cond(B).
    rng = np.random.default_rng(seed)
    n = 5
    A = np.eye(n) + 0.3 * (lambda x: (x + x.T) / 2)(rng.uniform(-1, 1, (n, n)))
    B = np.eye(n) + 0.3 * (lambda x: (x + x.T) / 2)(rng.uniform(-1, 1, (n, n)))
    S, E = np.diag(10.0 ** rng.uniform(-6, 6, n)), np.diag(10.0 ** rng.uniform(-6, 6, n))
    M, K = S @ A @ S, E @ B @ E
    expected = _mp_pencil(K, M)
    modes = pencil_modes(K, M, vectors=False)
    np.testing.assert_allclose(modes.omega**2, expected, rtol=1e-12)
    assert np.all(np.abs(modes.omega - np.sqrt(expected)) <= modes.omega_error)


def test_pencil_agrees_with_scipy_when_well_conditioned():
    rng = np.random.default_rng(7)
    X = rng.normal(size=(6, 6))
    M = X @ X.T + 6 * np.eye(6)
    Y = rng.normal(size=(6, 6))
    K = Y @ Y.T + np.eye(6)
    modes = pencil_modes(K, M, units="SI")
    np.testing.assert_allclose(modes.omega**2, la.eigh(K, M, eigvals_only=True), rtol=1e-13)
    np.testing.assert_allclose(modes.shapes.T @ M @ modes.shapes, np.eye(6), atol=1e-13)
    np.testing.assert_allclose(modes.vectors.T @ modes.vectors, np.eye(6), atol=1e-12)
    assert modes.residual < 1e-14 and modes.orthogonality < 1e-13
    assert pencil_modes(K, M, n_modes=2).omega.shape == (2,)
    band = (float(modes.omega[1]) - 1e-9, float(modes.omega[3]) + 1e-9)
    np.testing.assert_allclose(pencil_modes(K, M, band=band).omega, modes.omega[1:4], rtol=1e-15)


def test_indefinite_K_goes_through_the_cholesky_path():
    M = np.array([[2.0, 0.5], [0.5, 1.0]])
    K = np.array([[-1.0, 0.0], [0.0, 3.0]])
    with pytest.warns(RuntimeWarning, match="imaginary"):
        modes = pencil_modes(K, M)
    assert modes.solver == "pencil-cholesky"
    expected = la.eigh(K, M, eigvals_only=True)
    np.testing.assert_allclose(modes.omega * np.abs(modes.omega), expected, rtol=1e-14)


def test_generalized_system_uses_the_pencil_for_a_dense_M():
    system = vibra.System.generalized([[2.0, 1.0], [1.0, 1.0]], np.diag([2.0, 1.0]))
    assert system.modes().solver == "pencil-jacobi"
    # A diagonal M keeps the core solver, and an explicit solver choice is honoured.
    assert vibra.System.generalized([2.0, 1.0], np.diag([2.0, 1.0])).modes().solver == "dense"
    assert system.modes(solver="dense").solver == "dense"


@pytest.mark.parametrize(
    ("M", "pattern"),
    [
        ([[1.0, 1.0], [1.0, 1.0]], r"M is singular to working precision: D M D .* condition number \S+ >= 1 / \(n eps\)"),
        ([[1.0, 1 - 2e-16], [1 - 2e-16, 1.0]], r"M is singular to working precision: .* condition number \d\.\d+e\+15"),
        ([[1.0, 2.0], [2.0, 1.0]], r"M is not positive definite: D M D .* smallest eigenvalue -1 and condition number 3"),
        ([[1.0, 0.0], [0.0, -1.0]], r"M\[1,1\] is -1.0; every diagonal entry of a mass matrix"),
        ([[1.0, 0.0], [0.1, 1.0]], r"M is not symmetric"),
        ([[1.0, 0.0, 0.0]], r"M must be square"),
        (np.eye(3), r"M must be \(2, 2\) to match K"),
    ],
)
def test_mass_matrix_messages(M, pattern):
    with pytest.raises(ValueError, match=pattern):
        pencil_modes(np.eye(2), M)
    with pytest.raises(ValueError, match=pattern):
        vibra.System.generalized(M, np.eye(2))


def test_linearize_names_the_condition_number():
    x, y, xd, yd = sympy.symbols("x y x_dot y_dot")
    with pytest.raises(ValueError, match=r"T is not positive definite at q0: d2T/dqd2 is singular .*condition number"):
        linearize((xd + yd) ** 2 / 2, (x**2 + y**2) / 2, [x, y], [xd, yd], [0.0, 0.0])


def test_pencil_input_messages():
    with pytest.raises(ValueError, match=r"K must be square"):
        pencil_modes(np.ones((2, 3)), np.eye(2))
    with pytest.raises(ValueError, match=r"give either n_modes or band"):
        pencil_modes(np.eye(2), np.eye(2), n_modes=1, band=(0.0, 2.0))
    with pytest.raises(ValueError, match=r"n_modes is 3"):
        pencil_modes(np.eye(2), np.eye(2), n_modes=3)
    assert check_mass_matrix(np.eye(2)).flags.writeable
    assert scaled_condition(np.array([[1.0, 0.0], [0.0, -1.0]])) == float("inf")


def test_normal_modes_routes_a_full_mass_matrix_to_the_pencil() -> None:
    """`normal_modes(K, M)` with a full M goes through the registry to the pencil paths (issue
    29): seed 000's double pendulum with m = 1e-3, m' = 1e3, b = 1e-3 (cond M ~1e12), both
    frequencies against the 2 x 2 characteristic polynomial det(K - lambda M) = 0 in 50-digit
    mpmath, each within its bound, the same values as `pencil_modes` called directly; "fast"
    takes the Cholesky reduction."""
    import mpmath

    from vibra import normal_modes
    from vibra.mechanics.lagrangian import double_pendulum

    system = double_pendulum(m=1e-3, m_prime=1e3, a=1.0, b=1e-3)
    K, M = np.asarray(system.hessian().toarray()), np.asarray(system.mass_matrix())
    modes = normal_modes(K, M)
    assert modes.solver == "pencil-jacobi"
    with mpmath.workdps(50):
        k, m = mpmath.matrix(K.tolist()), mpmath.matrix(M.tolist())
        a = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
        b = -(k[0, 0] * m[1, 1] + k[1, 1] * m[0, 0] - k[0, 1] * m[1, 0] - k[1, 0] * m[0, 1])
        c = k[0, 0] * k[1, 1] - k[0, 1] * k[1, 0]
        root = mpmath.sqrt(b * b - 4 * a * c)
        truth = sorted(float(mpmath.sqrt(x)) for x in ((-b - root) / (2 * a), (-b + root) / (2 * a)))
    assert np.all(np.abs(modes.omega - truth) <= modes.omega_error)
    np.testing.assert_array_equal(modes.omega, pencil_modes(K, M).omega)
    assert normal_modes(K, M, accuracy="fast").solver == "pencil-cholesky"
