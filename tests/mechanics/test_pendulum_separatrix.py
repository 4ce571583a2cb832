"""The pendulum up to the top (issue 15, item 1): theta0 = pi - 10^-k, k = 1..15, and pi itself.

Truth: mpmath at 50 digits (the complete elliptic integral K(m) and the Jacobi functions
sn, cn, dn, cd of the exact float theta0), the separatrix's closed form evaluated in mpmath,
and an independent DOP853 integration written here.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from vibra.mechanics.pendulum import exact_motion, exact_period, harmonic_error, jacobi_sn_cn_dn, separatrix_motion

EPS = float(np.finfo(float).eps)
DIGITS = 50


def _reference(theta0: float, times: np.ndarray, omega: float = 1.0):
    """(period, theta(t), theta'(t)) in 50-digit mpmath for the float theta0 taken exactly."""
    with mpmath.workdps(DIGITS):
        half = mpmath.mpf(theta0) / 2
        k = mpmath.sin(half)
        m = k * k
        period = 4 * mpmath.ellipk(m) / omega
        theta, rate = [], []
        for t in times:
            u = mpmath.mpf(omega) * mpmath.mpf(float(t))
            cd = mpmath.ellipfun("cd", u, m=m)
            sn, dn = mpmath.ellipfun("sn", u, m=m), mpmath.ellipfun("dn", u, m=m)
            angle = 2 * mpmath.asin(k * cd)
            theta.append(float(angle))
            # d/dt sin(theta/2) = k Omega cd'(u), cd' = -(1 - m) sn / dn^2; theta' = 2 (...) / cos(theta/2).
            rate.append(float(2 * k * omega * (-(1 - m) * sn / dn**2) / mpmath.cos(angle / 2)))
        return float(period), np.array(theta), np.array(rate)


@pytest.mark.parametrize("k", range(1, 16))
def test_period_to_an_ulp_up_to_the_top(k):
    theta0 = np.pi - 10.0**-k
    period, _, _ = _reference(theta0, [])
    # ellipkm1 of the directly computed complement: a few ulps (measured <= 1.7e-16).
    assert abs(float(exact_period(theta0)) / period - 1.0) <= 4 * EPS


@pytest.mark.parametrize("k", range(1, 16))
def test_motion_to_the_rounding_of_t_up_to_the_top(k):
    theta0 = np.pi - 10.0**-k
    times = np.linspace(0.0, 60.0, 61)
    _, theta, rate = _reference(theta0, times)
    motion = exact_motion(theta0, times)
    # Omega t itself is rounded (|d theta / dt| <= 2 Omega): the bound is a few ulps of pi plus
    # 2 ulps of 2 Omega t. Measured: <= 8e-15 relative to pi over k = 1..15.
    bound = 4 * EPS * (np.pi + 2.0 * times)
    assert np.all(np.abs(motion.theta - theta) <= bound)
    assert np.all(np.abs(motion.theta_dot - rate) <= 4 * EPS * (2.0 + 2.0 * times))


def test_the_issue_case_leaves_the_top():
    # pi - 1e-9 at t = 20: the true angle is 2.899 (issue 15), not pi.
    _, theta, _ = _reference(np.pi - 1e-9, [20.0])
    motion = exact_motion(np.pi - 1e-9, [0.0, 20.0])
    assert abs(theta[0] - 2.899) < 1e-3
    assert abs(motion.theta[1] - theta[0]) <= 4 * EPS * (np.pi + 40.0)


def test_negative_amplitude_and_omega_scale():
    theta0, omega = -(np.pi - 1e-6), 3.7
    times = np.linspace(0.0, 10.0, 11)
    _, theta, rate = _reference(abs(theta0), times, omega)
    motion = exact_motion(theta0, times, omega)
    np.testing.assert_allclose(motion.theta, -theta, rtol=0, atol=4 * EPS * (np.pi + 2 * omega * times[-1]))
    np.testing.assert_allclose(motion.theta_dot, -rate, rtol=0, atol=4 * EPS * omega * (2 + 2 * omega * times[-1]))


def test_the_separatrix_itself():
    # Released at rest exactly on top (np.pi is read as pi): an infinite period, and it stays.
    assert np.isinf(exact_period(np.pi))
    assert np.isinf(harmonic_error([np.pi], n_points=11).exact_period[0])
    rest = exact_motion(np.pi, [0.0, 5.0, 50.0])
    assert np.all(rest.theta == np.pi) and np.all(rest.theta_dot == 0.0)
    # The separatrix motion: theta = 2 arcsin(tanh(Omega t)), in mpmath.
    omega = 2.0
    times = np.linspace(-20.0, 20.0, 81)
    motion = separatrix_motion(times, omega)
    with mpmath.workdps(DIGITS):
        theta = np.array([float(2 * mpmath.asin(mpmath.tanh(omega * mpmath.mpf(float(t))))) for t in times])
        rate = np.array([float(2 * omega / mpmath.cosh(omega * mpmath.mpf(float(t)))) for t in times])
    np.testing.assert_allclose(motion.theta, theta, rtol=4 * EPS, atol=0)
    np.testing.assert_allclose(motion.theta_dot, rate, rtol=8 * EPS, atol=0)
    # It is the limit of the swings: near pi the motion follows it through the bottom.
    near = exact_motion(np.pi - 1e-15, times[40:] + float(exact_period(np.pi - 1e-15)) / 4, 1.0)
    follow = separatrix_motion(times[40:], 1.0)
    assert np.all(np.abs(near.theta[:5] + follow.theta[:5]) < 1e-6)


def test_separatrix_conserves_energy():
    # E = theta'^2 / 2 + Omega^2 (1 - cos theta) = 2 Omega^2 on the separatrix.
    motion = separatrix_motion(np.linspace(-5.0, 5.0, 101), 1.5)
    np.testing.assert_allclose(motion.energy, 2.0 * 1.5**2, rtol=8 * EPS)


def test_close_to_the_top_matches_integration():
    # Independent check: DOP853 at rtol 1e-13 over one swing through the bottom.
    theta0 = np.pi - 1e-3
    times = np.linspace(0.0, 12.0, 25)
    solution = solve_ivp(lambda _, y: [y[1], -np.sin(y[0])], (0.0, 12.0), [theta0, 0.0], t_eval=times,
                         method="DOP853", rtol=1e-13, atol=1e-15)
    # Near the top the flow amplifies the integrator's local errors; 1e-8 is its measured level.
    np.testing.assert_allclose(exact_motion(theta0, times).theta, solution.y[0], atol=1e-8)


@settings(max_examples=40, deadline=None)
@given(st.floats(min_value=-40.0, max_value=0.0))
def test_jacobi_functions_near_m_one(log_complement):
    # sn, cn, dn(u | 1 - m1) against mpmath for m1 = 10^-40..1 over |u| <= K.
    m1 = 10.0**log_complement
    with mpmath.workdps(DIGITS):
        m = 1 - mpmath.mpf(m1)
        quarter = float(mpmath.ellipk(m))
        u = np.linspace(-quarter, quarter, 9)
        ref = {f: np.array([float(mpmath.ellipfun(f, mpmath.mpf(x), m=m)) for x in u]) for f in ("sn", "cn", "dn")}
    sn, cn, dn = jacobi_sn_cn_dn(u, float(m), m1)
    for name, value in (("sn", sn), ("cn", cn), ("dn", dn)):
        assert np.abs(value - ref[name]).max() <= 8 * EPS, name
