"""Tests of vibra.mechanics.pendulum (seed 003 examples 3, 6, 8; figure 2) and vibra.charts.pendulum.

Truth: the period series T = T0 (1 + theta0^2/16 + 11 theta0^4/3072 + ...), the period
integral by scipy.integrate.quad, independent solve_ivp integrations written here, the
energy law dE/dt = -2 eta T (seed 003 eq. 63), and the measured convergence order of the
harmonic approximation.
"""

from __future__ import annotations

import dataclasses
import doctest

import numpy as np
import pytest
from helpers.images import check_png
from scipy.integrate import quad, simpson, solve_ivp

from vibra.charts._style import save_figure
from vibra.charts.pendulum import (
    plot_double_pendulum_modes,
    plot_period_vs_amplitude,
    plot_trajectory_comparison,
)
from vibra.mechanics.lagrangian import double_pendulum
from vibra.mechanics.pendulum import (
    HarmonicError,
    PendulumMotion,
    damped_motion,
    exact_motion,
    exact_period,
    harmonic_error,
    harmonic_motion,
    harmonic_period,
    separatrix_motion,
)


def _reference_motion(theta0, t, omega=1.0, eta=0.0, linear=False, velocity=0.0):
    """theta(t) by scipy's LSODA, written here independently of vibra."""
    def rhs(_, y):
        force = y[0] if linear else np.sin(y[0])
        return [y[1], -eta * y[1] - omega**2 * force]
    solution = solve_ivp(rhs, (t[0], t[-1]), [theta0, velocity], method="LSODA", t_eval=t, rtol=1e-12, atol=1e-14)
    assert solution.success
    return solution.y


# ---------------------------------------------------------------------- period
@pytest.mark.parametrize("theta0", [0.05, 0.2, 0.5, 0.8])
def test_period_series(theta0):
    # T/T0 = 1 + x/16 + 11 x^2/3072 + 173 x^3/737280 + 22931 x^4/1321205760 + ..., x = theta0^2,
    # all coefficients positive: after the theta0^4 term the remainder lies between the next
    # term and twice it (the following terms add < 5 % of it for theta0 <= 0.8).
    x = theta0**2
    ratio = float(exact_period(theta0)) / harmonic_period()
    remainder = ratio - (1.0 + x / 16.0 + 11.0 * x**2 / 3072.0)
    next_term = 173.0 * x**3 / 737280.0
    # Lower bound loosened by 1e-15 absolute: the ratio itself is rounded to ~1e-16.
    assert next_term - 1e-15 <= remainder <= 2.0 * next_term + 1e-15


@pytest.mark.parametrize("theta0", [0.1, 1.0, 2.0, 3.0])
def test_period_against_quadrature(theta0):
    # T = (4 / Omega) int_0^{pi/2} d(phi) / sqrt(1 - k^2 sin^2 phi), k = sin(theta0 / 2).
    omega = 2.3
    k2 = np.sin(theta0 / 2.0) ** 2
    integral, error = quad(lambda p: 1.0 / np.sqrt(1.0 - k2 * np.sin(p) ** 2), 0.0, np.pi / 2.0,
                           epsabs=0.0, epsrel=1e-13)
    # quad converges to ~1e-14 relative for this smooth integrand (k^2 <= 0.995).
    np.testing.assert_allclose(exact_period(theta0, omega), 4.0 * integral / omega, rtol=1e-12)


def test_period_from_zero_crossing_of_integration():
    # A quarter period is the time of the first pass through theta = 0.
    theta0 = 2.4

    def crossing(_, y):
        return y[0]
    crossing.terminal = True
    solution = solve_ivp(lambda _, y: [y[1], -np.sin(y[0])], (0.0, 10.0), [theta0, 0.0], events=crossing,
                         method="DOP853", rtol=1e-12, atol=1e-14)
    quarter = solution.t_events[0][0]
    # DOP853 at rtol 1e-12 with dense-output root finding: ~1e-10 relative.
    np.testing.assert_allclose(exact_period(theta0), 4.0 * quarter, rtol=1e-9)


def test_period_accepts_arrays():
    amplitudes = np.array([0.1, 1.0, 2.0])
    periods = exact_period(amplitudes, omega=2.0)
    assert periods.shape == (3,)
    assert np.all(np.diff(periods) > 0)  # longer with amplitude
    assert np.all(periods > harmonic_period(2.0))


# ---------------------------------------------------------------------- motions
@pytest.mark.parametrize("theta0", [0.3, 1.5, 3.0])
def test_exact_motion_matches_integration(theta0):
    t = np.linspace(0.0, 25.0, 301)
    theta, theta_dot = _reference_motion(theta0, t, omega=1.3)
    motion = exact_motion(theta0, t, omega=1.3)
    # LSODA at rtol 1e-12 over ~5 periods: ~1e-9 rad; Jacobi functions to ~1e-15.
    # Near theta0 = 3 the motion is slow at the top, so allow a little more there.
    np.testing.assert_allclose(motion.theta, theta, atol=1e-7)
    np.testing.assert_allclose(motion.theta_dot, theta_dot, atol=1e-7)
    assert motion.method == "elliptic"
    # Energy is conserved by the closed form (rounding only).
    assert np.ptp(motion.energy) < 1e-12 * motion.energy.max()


def test_release_on_the_other_side_mirrors_the_motion():
    # A release at -theta0 is the mirror image of one at +theta0 (V is even in theta);
    # checked against the independent LSODA run, not only against vibra's own +theta0 motion.
    t = np.linspace(0.0, 12.0, 121)
    motion = exact_motion(-1.2, t, omega=1.3)
    theta, theta_dot = _reference_motion(-1.2, t, omega=1.3)
    # LSODA at rtol 1e-12 over ~2.5 periods: ~1e-9 rad (as in the test above).
    np.testing.assert_allclose(motion.theta, theta, atol=1e-7)
    np.testing.assert_allclose(motion.theta_dot, theta_dot, atol=1e-7)
    np.testing.assert_allclose(harmonic_motion(-0.2, t).theta, -0.2 * np.cos(t), rtol=0, atol=1e-16)
    # Released at 0 it stays at rest.
    np.testing.assert_array_equal(exact_motion(0.0, t).theta, 0.0)


def test_damped_motion_kicked_from_the_rest_position():
    # Starting at theta = 0 with a velocity (a kick), strong enough to go over the top:
    # E = 2.5^2 / 2 > 2 Omega^2 at first, so theta passes pi before friction traps it.
    t = np.linspace(0.0, 20.0, 401)
    motion = damped_motion(0.0, t, eta=0.1, velocity=2.5)
    theta, theta_dot = _reference_motion(0.0, t, eta=0.1, velocity=2.5)
    # DOP853 at rtol 1e-10 against LSODA at 1e-12 over 20 time units of a motion that
    # stays smooth (it never stops near the top): agreement ~1e-8 rad, allow 1e-6.
    np.testing.assert_allclose(motion.theta, theta, atol=1e-6)
    np.testing.assert_allclose(motion.theta_dot, theta_dot, atol=1e-6)
    assert motion.theta.max() > np.pi
    np.testing.assert_allclose(motion.energy[0], 0.5 * 2.5**2, rtol=1e-15)


def test_harmonic_motion_undamped_and_damped():
    t = np.linspace(0.0, 20.0, 201)
    np.testing.assert_allclose(harmonic_motion(0.2, t, 1.5).theta, 0.2 * np.cos(1.5 * t), rtol=0, atol=1e-16)
    theta, theta_dot = _reference_motion(0.2, t, omega=1.5, eta=0.4, linear=True)
    motion = harmonic_motion(0.2, t, 1.5, eta=0.4)
    # Closed form versus LSODA at rtol 1e-12 on the linear damped equation.
    np.testing.assert_allclose(motion.theta, theta, atol=1e-9)
    np.testing.assert_allclose(motion.theta_dot, theta_dot, atol=1e-9)


def test_harmonic_convergence_orders():
    amplitudes = np.geomspace(0.005, 0.08, 6)
    errors = harmonic_error(amplitudes, omega=2.0, n_periods=2.0)
    period_order, period_log_prefactor = np.polyfit(np.log(amplitudes), np.log(errors.period_error), 1)
    trajectory_order = np.polyfit(np.log(amplitudes), np.log(errors.trajectory_error), 1)[0]
    # Period error theta0^2/16 (1 + O(theta0^2)): order 2 and prefactor 1/16 to < 1 % here.
    assert abs(period_order - 2.0) < 0.01
    np.testing.assert_allclose(np.exp(period_log_prefactor), 1.0 / 16.0, rtol=0.01)
    # Trajectory error over a fixed number of periods: the phase slips by 2 pi n theta0^2/16,
    # so the gap is ~ theta0^3 (amplitude-relative ~ theta0^2).
    assert abs(trajectory_order - 3.0) < 0.02
    relative_order = np.polyfit(np.log(amplitudes), np.log(errors.relative_trajectory_error), 1)[0]
    assert abs(relative_order - 2.0) < 0.02
    # Leading term: theta_exact ~ theta0 cos(Omega t (1 - theta0^2/16)), so the gap is
    # theta0 * (Omega t theta0^2 / 16) |sin(Omega t)|, largest in [0, 2 periods] at
    # Omega t = 3.5 pi, where the theta0^3 cos(3 Omega t) distortion term vanishes: relative
    # gap 3.5 pi theta0^2 / 16, up to O(theta0^2) corrections (< 0.5 % here) and sampling.
    np.testing.assert_allclose(errors.relative_trajectory_error, 3.5 * np.pi * amplitudes**2 / 16.0, rtol=0.01)


def test_harmonic_error_grows_with_amplitude_and_is_large_at_large_amplitude():
    errors = harmonic_error([0.1, 1.0, 2.5])
    assert np.all(np.diff(errors.period_error) > 0)
    # At 2.5 rad the exact period is ~1.6 times 2 pi / Omega (K(sin^2 1.25) ~ 2.5).
    assert errors.period_error[-1] > 0.5
    assert errors.harmonic_period == pytest.approx(2 * np.pi)


# ---------------------------------------------------------------------- damping
def test_damped_energy_law():
    eta, omega = 0.3, 1.7
    t = np.linspace(0.0, 15.0, 3001)
    motion = damped_motion(2.0, t, omega=omega, eta=eta)
    energy = motion.energy
    assert np.all(np.diff(energy) <= 1e-12 * energy[0])  # never increases
    # Integrated eq. (63): E(t) - E(0) = -2 eta int_0^t T dt. Simpson on 3001 points of a
    # smooth T: quadrature error ~1e-9 relative; the integration error is ~1e-10.
    dissipated = 2.0 * eta * simpson(motion.kinetic, x=t)
    np.testing.assert_allclose(energy[0] - energy[-1], dissipated, rtol=1e-7)
    assert energy[-1] < 0.05 * energy[0]  # exp(-eta t) ~ 1 %: the decay is real


def test_damped_small_amplitude_matches_damped_harmonic():
    t = np.linspace(0.0, 20.0, 401)
    gaps = []
    amplitudes = np.array([0.01, 0.02])
    for amplitude in amplitudes:
        gap = np.abs(damped_motion(amplitude, t, eta=0.2).theta - harmonic_motion(amplitude, t, eta=0.2).theta).max()
        gaps.append(gap)
    # The non-linear correction is O(theta0^3): doubling theta0 multiplies the gap by ~8.
    assert 7.0 < gaps[1] / gaps[0] < 9.0
    assert gaps[0] < 1e-5


def test_damped_without_friction_is_exact_motion():
    t = np.linspace(0.0, 12.0, 121)
    # solve_ivp at rtol 1e-10 against the elliptic closed form: ~1e-9 rad.
    np.testing.assert_allclose(damped_motion(2.2, t, eta=0.0).theta, exact_motion(2.2, t).theta, atol=1e-7)


# ---------------------------------------------------------------------- results are frozen
def test_results_are_frozen():
    motion = exact_motion(0.5, [0.0, 1.0])
    errors = harmonic_error([0.1, 0.2], n_points=11)
    assert isinstance(motion, PendulumMotion) and isinstance(errors, HarmonicError)
    with pytest.raises(dataclasses.FrozenInstanceError):
        motion.omega = 2.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        errors.amplitudes = np.ones(2)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        motion.theta[0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        errors.period_error[0] = 0.0


# ---------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda: exact_period(0.0), ValueError, r"amplitude is 0.0 rad; a release angle must lie in \(0, pi\]"),
        (lambda: exact_period(3.2), ValueError, r"amplitude is 3.2 rad; a release angle must lie in \(0, pi\]"),
        (lambda: exact_period([0.1, -0.2]), ValueError, r"amplitude\[1\] is -0.2 rad"),
        (lambda: exact_period(np.nan), ValueError, r"amplitude is nan; it must be finite"),
        (lambda: exact_period("1"), TypeError, r"amplitude must be a real number, got str"),
        (lambda: exact_period(0.1, omega=0.0), ValueError, r"omega is 0.0"),
        (lambda: exact_motion(0.1, [1.0, 0.5]), ValueError, r"t must increase: t\[1\] = 0.5 <= t\[0\] = 1.0"),
        (lambda: exact_motion(0.1, [0.0]), ValueError, r"t must hold at least 2 times"),
        (lambda: harmonic_motion(0.1, [0.0, 1.0], eta=-0.1), ValueError, r"eta is -0.1"),
        (lambda: harmonic_motion(0.1, [0.0, 1.0], omega=1.0, eta=2.0), ValueError, r"eta is 2.0; harmonic_motion covers"),
        (lambda: damped_motion(0.1, [0.0, 1.0], eta=-1.0), ValueError, r"eta is -1.0"),
        (lambda: damped_motion(0.1, [0.0, 1.0], eta=0.1, velocity=np.inf), ValueError, r"velocity is inf"),
        (lambda: harmonic_error([0.1], n_periods=0.0), ValueError, r"n_periods is 0.0"),
        (lambda: harmonic_error([0.1], n_points=1), ValueError, r"n_points is 1"),
        (lambda: harmonic_error([3.5]), ValueError, r"amplitudes\[0\] is 3.5 rad"),
        (lambda: exact_motion(-3.2, [0.0, 1.0]), ValueError,
         r"amplitude is -3.2 rad; a release angle must lie in \[-pi, pi\]"),
        (lambda: separatrix_motion([0.0, 1.0], omega=-1.0), ValueError, r"omega is -1.0"),
        (lambda: separatrix_motion([1.0, 0.0]), ValueError, r"t must increase"),
        (lambda: harmonic_motion(4.0, [0.0, 1.0]), ValueError, r"amplitude is 4.0 rad"),
        (lambda: exact_motion(np.inf, [0.0, 1.0]), ValueError, r"amplitude is inf; it must be finite"),
        (lambda: damped_motion(np.nan, [0.0, 1.0], eta=0.1), ValueError, r"amplitude is nan"),
        (lambda: damped_motion(0.1, [0.0, 1.0], eta=0.1, rtol=0.0), ValueError,
         r"rtol is 0.0; an integration tolerance must be positive"),
        (lambda: damped_motion(0.1, [0.0, 1.0], eta=0.1, atol=-1e-9), ValueError, r"atol is -1e-09"),
        (lambda: damped_motion(0.1, [0.0, 1.0], eta=0.1, atol="1e-9"), TypeError, r"atol must be a real number"),
    ],
)
def test_bad_input(call, error, pattern):
    with pytest.raises(error, match=pattern):
        call()


# ---------------------------------------------------------------------- charts


def test_chart_period_vs_amplitude(tmp_path):
    fig = plot_period_vs_amplitude(harmonic_error(np.linspace(0.05, 3.0, 25), n_points=201))
    # figsize (11, 4.6) in at savefig.dpi 120
    check_png(save_figure(fig, tmp_path / "period.png"), (552, 1320))


def test_chart_double_pendulum_modes(tmp_path):
    modes = double_pendulum(1.0, 1.0, 1.0, 1.0).modes()
    check_png(save_figure(plot_double_pendulum_modes(modes, 1.0, 1.0), tmp_path / "modes.png"), (576, 1200))


def test_chart_trajectory_comparison(tmp_path):
    t = np.linspace(0.0, 4 * np.pi, 300)
    pairs = [(exact_motion(a, t), harmonic_motion(a, t)) for a in (0.1, 2.5)]
    check_png(save_figure(plot_trajectory_comparison(pairs), tmp_path / "trajectories.png"), (528, 1320))


def test_chart_bad_input():
    with pytest.raises(TypeError, match="errors must be a HarmonicError"):
        plot_period_vs_amplitude([0.1])
    with pytest.raises(TypeError, match="modes must be a Modes"):
        plot_double_pendulum_modes(None, 1.0, 1.0)
    with pytest.raises(ValueError, match="pairs is empty"):
        plot_trajectory_comparison([])
    with pytest.raises(TypeError, match=r"pairs\[0\] must be a pair of PendulumMotion"):
        plot_trajectory_comparison([(1, 2)])
    modes = double_pendulum().modes()
    with pytest.raises(ValueError, match=r"b is -1.0 m; a string length must be positive"):
        plot_double_pendulum_modes(modes, 1.0, -1.0)
    with pytest.raises(TypeError, match=r"a must be a real number, got str"):
        plot_double_pendulum_modes(modes, "1", 1.0)
    with pytest.raises(ValueError, match=r"amplitude is 2.0 rad; the drawn angle must lie in \(0, pi/2\]"):
        plot_double_pendulum_modes(modes, 1.0, 1.0, amplitude=2.0)
    modes_without_shapes = double_pendulum().modes(vectors=False)
    with pytest.raises(ValueError, match="modes must hold the 2 mode shapes"):
        plot_double_pendulum_modes(modes_without_shapes, 1.0, 1.0)


def test_docstring_examples_run():
    import vibra.mechanics.pendulum

    failures, attempted = doctest.testmod(vibra.mechanics.pendulum, optionflags=doctest.ELLIPSIS)
    assert attempted > 0 and failures == 0
