"""Tests of vibra.response and vibra.charts.response (issue 8).

Truth comes from outside the code under test: the seed's formulas (003 eqs. 61-67, 114-131)
evaluated in 40-digit arithmetic with mpmath, scipy.integrate.solve_ivp, the closed-form
modes and static Green's function of a uniform fixed-fixed chain, numpy's dense solver and
invariants (reciprocity, energy balance).
"""

from __future__ import annotations

import dataclasses
import math

import mpmath
import numpy as np
import pytest
import scipy.sparse as sp
from helpers.images import check_png
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq, minimize_scalar

from vibra import response as R
from vibra.charts._style import save_figure
from vibra.charts.response import (
    plot_frf,
    plot_oscillator_response,
    plot_rayleigh_damping,
)

mpmath.mp.dps = 40


# ---------------------------------------------------------------------- helpers (the oracles)
def exact_amplitude(w0: float, gamma: float, w: float, F0: complex = 1.0, m: float = 1.0) -> complex:
    """Eq. 120 in 40-digit arithmetic."""
    W0, G, W = mpmath.mpf(w0), mpmath.mpf(gamma), mpmath.mpf(w)
    value = (mpmath.mpc(F0) / m) / (W0**2 - W**2 + 1j * G * W)
    return complex(value)


def exact_free_motion(w0: float, gamma: float, u0: float, v0: float, t: float) -> float:
    """Eqs. 126-128 in 40-digit arithmetic: C1 e^{l1 t} + C2 e^{l2 t}, or the double root."""
    W0, G, T = mpmath.mpf(w0), mpmath.mpf(gamma), mpmath.mpf(t)
    disc = G**2 / 4 - W0**2
    if disc == 0:
        lam = -G / 2
        return float(mpmath.exp(lam * T) * (u0 + (v0 - lam * u0) * T))
    root = mpmath.sqrt(mpmath.mpc(disc))
    l1, l2 = -G / 2 + root, -G / 2 - root
    c2 = (v0 - l1 * u0) / (l2 - l1)
    c1 = u0 - c2
    return float(mpmath.re(c1 * mpmath.exp(l1 * T) + c2 * mpmath.exp(l2 * T)))


def chain(n: int, k: float = 1.0, ends: str = "fixed") -> sp.csr_matrix:
    """K = k tridiag(-1, 2, -1) (fixed ends) or with free ends (1 on the end diagonals)."""
    main = 2.0 * np.ones(n)
    if ends == "free":
        main[0] = main[-1] = 1.0
    elif ends == "fixed-free":
        main[-1] = 1.0
    off = -np.ones(n - 1)
    return sp.diags([off, main, off], [-1, 0, 1], format="csr") * k


def chain_modes(n: int, k: float, m: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed form of the fixed-fixed uniform chain: omega_j = 2 sqrt(k/m) sin(j pi / 2(n+1)),
    M-orthonormal shapes sqrt(2/((n+1) m)) sin(i j pi / (n+1))."""
    j = np.arange(1, n + 1)
    omega = 2.0 * np.sqrt(k / m) * np.sin(j * np.pi / (2 * (n + 1)))
    i = np.arange(1, n + 1)[:, None]
    shapes = np.sqrt(2.0 / ((n + 1) * m)) * np.sin(i * j[None, :] * np.pi / (n + 1))
    return omega, shapes


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


# ====================================================================== the single oscillator
W_SPAN = np.sort(np.concatenate([[0.0], np.geomspace(1e-8, 1e8, 65), [1.0 - 1e-9, 1.0, 1.0 + 1e-9]]))


@pytest.mark.parametrize("w0", [1.0, 3.7e-3, 2.5e4])
@pytest.mark.parametrize("zeta", [1e-9, 1e-3, 0.25, 0.5 * (1 - 1e-12), 0.5, 0.5 * (1 + 1e-12), 3.0, 1e6])
def test_complex_amplitude_amplitude_and_phase_match_eqs_120_121_123(w0: float, zeta: float) -> None:
    # gamma = 2 zeta w0; w spans 1e-8 to 1e8 w0, with w = w0 and its neighbours 1e-9 away.
    gamma = 2.0 * zeta * w0
    osc = R.Oscillator(w0=w0, gamma=gamma, m=2.0)
    w = W_SPAN * w0
    F0 = 3.0 - 1.0j
    truth = np.array([exact_amplitude(w0, gamma, x, F0, 2.0) for x in w])
    # A few ulps for each of (w0-w)(w0+w), gamma*w and the complex division: 1e-14 leaves
    # room; the naive w0**2 - w**2 would lose ~9 digits at w = w0 (1 +- 1e-9).
    assert np.all(np.abs(osc.complex_amplitude(w, F0) - truth) <= 1e-14 * np.abs(truth))
    assert np.allclose(osc.amplitude(w, F0), np.abs(truth), rtol=1e-14, atol=0)
    # Eq. 121 written as in the seed, in mpmath.
    amp121 = [float(abs(F0) / 2.0 / mpmath.sqrt((mpmath.mpf(x) ** 2 - mpmath.mpf(w0) ** 2) ** 2
                                                + (mpmath.mpf(gamma) * x) ** 2)) for x in w]
    assert np.allclose(osc.amplitude(w, F0), amp121, rtol=1e-14, atol=0)
    # Eq. 123: arctan(gamma w / (w^2 - w0^2)) on the branch from 0 to -pi: below w0 the
    # arctan itself, above w0 the arctan minus pi, -pi/2 at w0.
    phase = osc.phase(w)
    for x, got in zip(w, phase):
        X, W0 = mpmath.mpf(x), mpmath.mpf(w0)
        if x == w0:
            want = -mpmath.pi / 2
        elif x == 0:
            want = mpmath.mpf(0)
        else:
            want = mpmath.atan(gamma * X / (X**2 - W0**2)) - (mpmath.pi if x > w0 else 0)
        assert abs(got - float(want)) <= 1e-14 * math.pi
    assert np.all(np.diff(phase) <= 0) and phase.max() <= 0 and phase.min() >= -math.pi


def test_tiny_damping_at_resonance_is_finite_and_accurate() -> None:
    osc = R.Oscillator(w0=1.0, gamma=1e-9)
    # |u0(w0)| = F0 / (m gamma w0) = 1e9 exactly in real arithmetic; a few ulps allowed.
    assert osc.amplitude(1.0) == pytest.approx(1e9, rel=1e-15)
    assert osc.complex_amplitude(1.0) == pytest.approx(-1e9j, rel=1e-15)
    assert osc.phase(1.0) == -math.pi / 2


def test_undamped_resonance_is_an_explicit_infinity_or_a_clear_error() -> None:
    osc = R.Oscillator(w0=2.0, gamma=0.0)
    assert osc.amplitude(2.0) == math.inf
    value = osc.complex_amplitude([1.0, 2.0, 3.0], F0=1.0)
    assert not np.isnan(value).any()
    assert value[1] == complex(0.0, -math.inf)        # the gamma -> 0+ limit, -i F0 direction
    assert value[0] == pytest.approx(1.0 / 3.0) and value[2] == pytest.approx(-0.2)
    assert list(osc.phase([1.0, 2.0, 3.0])) == [0.0, -math.pi / 2, -math.pi]
    with pytest.raises(ValueError, match=r"omega is 2\.0 = w0 and gamma = 0"):
        osc.motion([0.0, 1.0], F0=1.0, omega=2.0)
    with pytest.raises(ValueError, match=r"no steady state"):
        osc.steady_state(1.0, F0=1.0, omega=2.0)


def test_static_and_high_frequency_asymptotes() -> None:
    osc = R.Oscillator(w0=3.0, gamma=0.7, m=2.0)
    # w -> 0: the static response F0 / (m w0^2); w -> inf: -F0 / (m w^2) (mass line).
    # Relative corrections are (gamma w / w0^2) and (w0^2/w^2, gamma/w): at w = 1e-8 and 1e8
    # they are < 1e-8, so rtol 1e-7.
    assert osc.complex_amplitude(0.0, 5.0) == pytest.approx(5.0 / 18.0, rel=1e-15)
    assert osc.complex_amplitude(1e-8, 5.0) == pytest.approx(5.0 / 18.0, rel=1e-7)
    assert osc.complex_amplitude(1e8, 5.0) == pytest.approx(-5.0 / (2.0 * 1e16), rel=1e-7)
    assert osc.phase(1e8) == pytest.approx(-math.pi, abs=1e-8)


@pytest.mark.parametrize("w0,gamma", [(1.0, 0.5), (1.0, 1.0), (2.0, 0.01), (1.0, 1.4), (1.0, 1.5), (1.0, 4.0)])
def test_resonance_peak_quality_factor_and_bandwidth(w0: float, gamma: float) -> None:
    osc = R.Oscillator(w0=w0, gamma=gamma, m=1.5)

    def amp(w: float) -> float:  # eq. 121, typed in independently
        return 2.0 / 1.5 / math.sqrt((w * w - w0 * w0) ** 2 + gamma * gamma * w * w)

    found = minimize_scalar(lambda w: -amp(w), bounds=(0.0, 3.0 * w0), method="bounded",
                            options={"xatol": 1e-12})
    peak = osc.resonance_frequency()
    if gamma < math.sqrt(2.0) * w0:
        # The peak of a smooth maximum is located to ~sqrt(eps) by a bounded search: 1e-6.
        assert peak == pytest.approx(found.x, rel=1e-6)
        assert osc.peak_amplitude(2.0) == pytest.approx(amp(found.x), rel=1e-12)
    else:
        # gamma >= sqrt2 w0: no resonance; the amplitude falls from its static value.
        assert peak is None
        grid = np.linspace(0.0, 5.0 * w0, 2001)
        assert np.all(np.diff([amp(w) for w in grid]) < 0)
        assert osc.peak_amplitude(2.0) == pytest.approx(amp(0.0), rel=1e-15)
    # The seed's eq. 122: the free damped frequency, none when gamma >= 2 w0; it is the
    # imaginary part of the characteristic roots (126), found here by numpy.
    roots = np.roots([1.0, gamma, w0 * w0])
    damped = osc.damped_frequency()
    if gamma < 2 * w0:
        assert damped == pytest.approx(abs(roots.imag).max(), rel=1e-12)
    else:
        assert damped is None
    assert osc.decay_rate() == pytest.approx(-roots.real.max(), rel=1e-12)
    assert osc.quality_factor == pytest.approx(w0 / gamma, rel=1e-15)
    points = osc.half_power_frequencies()
    if peak is not None and points is not None:
        half = amp(found.x) / math.sqrt(2.0)
        low = brentq(lambda w: amp(w) - half, 1e-12, found.x, xtol=1e-15)
        high = brentq(lambda w: amp(w) - half, found.x, 10 * w0, xtol=1e-15)
        # brentq to 1e-15 absolute on a function with nonzero slope: 1e-10 relative is safe.
        assert points == pytest.approx((low, high), rel=1e-10)
        assert osc.half_power_bandwidth() == pytest.approx(high - low, rel=1e-9)


def test_half_power_bandwidth_tends_to_gamma() -> None:
    # Delta w = gamma (1 + O(gamma^2/w0^2)); for gamma = 1e-6 w0 the correction is ~1e-12.
    osc = R.Oscillator(w0=1.0, gamma=1e-6)
    assert osc.half_power_bandwidth() == pytest.approx(1e-6, rel=1e-11)
    assert R.Oscillator(w0=1.0, gamma=0.0).half_power_bandwidth() == 0.0
    assert R.Oscillator(w0=1.0, gamma=1.3).half_power_frequencies() is None  # no lower point


@pytest.mark.parametrize("gamma", [0.0, 0.3, 2.0 * (1 - 1e-12), 2.0, 2.0 * (1 + 1e-12), 2.0 * (1 + 1e-6), 7.0, 2e6])
def test_free_motion_matches_eqs_126_to_128_across_critical_damping(gamma: float) -> None:
    osc = R.Oscillator(w0=1.0, gamma=gamma)
    t = np.concatenate([[0.0], np.geomspace(1e-6, 40.0, 30)])
    got = osc.motion(t, 0.7, -1.3)
    want = np.array([exact_free_motion(1.0, gamma, 0.7, -1.3, x) for x in t])
    scale = np.abs(want) + 1e-300
    # A handful of ulps per operation; near critical damping the naive sqrt(gamma^2/4 - w0^2)
    # would lose 6 of 16 digits (error ~1e-10); 1e-13 relative (+1e-16 absolute for the
    # underflowing tail) shows it does not.
    assert np.all(np.abs(got - want) <= 1e-13 * scale + 1e-16)
    velocity = osc.velocity(t, 0.7, -1.3)
    assert velocity[0] == pytest.approx(-1.3, rel=1e-15)


def test_motion_is_continuous_at_critical_damping() -> None:
    t = np.linspace(0.0, 10.0, 101)
    critical = R.Oscillator(w0=1.0, gamma=2.0).motion(t, 1.0, 0.5)
    # Eq. 128 with lambda = -w0 and the initial conditions: exp(-t) (1 + (0.5 + 1) t).
    assert np.allclose(critical, np.exp(-t) * (1.0 + 1.5 * t), rtol=1e-14, atol=1e-16)
    for side in (1 - 1e-12, 1 + 1e-12):
        near = R.Oscillator(w0=1.0, gamma=2.0 * side).motion(t, 1.0, 0.5)
        # The exact difference is O(|gamma - 2 w0| t^2) <= 1e-12 * 100 here; 2e-10 bound.
        assert np.max(np.abs(near - critical)) <= 2e-10


@pytest.mark.parametrize("gamma,omega", [(0.4, 1.7), (2.0, 0.6), (5.0, 2.0), (0.05, 0.99), (0.0, 0.5)])
def test_forced_motion_matches_numerical_integration(gamma: float, omega: float) -> None:
    w0, m, F0 = 1.2, 0.8, 1.5 - 0.4j
    osc = R.Oscillator(w0=w0, gamma=gamma, m=m)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        force = (F0 * np.exp(1j * omega * t)).real
        return [y[1], force / m - gamma * y[1] - w0 * w0 * y[0]]

    t = np.linspace(0.0, 25.0, 60)
    solution = solve_ivp(rhs, (0.0, 25.0), [0.3, -0.2], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-13)
    # DOP853 at rtol 1e-12 over ~5 periods keeps ~1e-10 of the amplitude (order 1): 1e-8.
    assert np.allclose(osc.motion(t, 0.3, -0.2, F0=F0, omega=omega), solution.y[0], rtol=0, atol=1e-8)
    assert np.allclose(osc.velocity(t, 0.3, -0.2, F0=F0, omega=omega), solution.y[1], rtol=0, atol=1e-8)


def test_steady_state_amplitude_and_phase_from_integration() -> None:
    w0, gamma, omega = 1.0, 0.5, 1.3
    osc = R.Oscillator(w0=w0, gamma=gamma)

    def rhs(t: float, y: np.ndarray) -> list[float]:
        return [y[1], math.cos(omega * t) - gamma * y[1] - w0 * w0 * y[0]]

    # The transient decays as exp(-gamma t / 2): by t = 120 it is e^-30 ~ 1e-13 (eq. 131).
    period = 2 * math.pi / omega
    t = np.linspace(120.0, 120.0 + period, 2001)
    solution = solve_ivp(rhs, (0.0, t[-1]), [1.0, 0.0], t_eval=t, method="DOP853", rtol=1e-12, atol=1e-13)
    u = solution.y[0]
    # Project one period on cos and sin: u = A cos(w t + phi) = A cos(phi) cos - A sin(phi) sin.
    c = 2.0 / period * np.trapezoid(u * np.cos(omega * t), t)
    s = -2.0 / period * np.trapezoid(u * np.sin(omega * t), t)
    # Trapezoid over a full period of a trigonometric polynomial is exact to round-off; the
    # integration error ~1e-10 dominates: 1e-8.
    assert math.hypot(c, s) == pytest.approx(osc.amplitude(omega), abs=1e-8)
    assert math.atan2(s, c) == pytest.approx(osc.phase(omega), abs=1e-8)
    # And the motion from (1, 0) has reached u_p (eq. 131).
    assert np.allclose(osc.motion(t, 1.0, 0.0, F0=1.0, omega=omega), osc.steady_state(t, 1.0, omega),
                       rtol=0, atol=1e-12)


@pytest.mark.parametrize("gamma", [0.3, 2.0, 9.0])
def test_transient_decays_at_the_decay_rate(gamma: float) -> None:
    osc = R.Oscillator(w0=1.0, gamma=gamma)
    rate = osc.decay_rate()
    t = np.array([20.0, 40.0]) / rate
    gap = np.abs(osc.motion(t, 1.0, 0.0, F0=1.0, omega=0.8) - osc.steady_state(t, 1.0, 0.8))
    # |u - u_p| <= (const + const t) exp(-rate t): at rate t = 40 below 1e-14 for these O(1)
    # initial conditions (the critical case has the extra factor t, ~40 here).
    assert gap[1] <= 1e-14
    assert gap[1] < gap[0]


@pytest.mark.parametrize("gamma", [0.2, 2.0, 6.0])
def test_energy_decay_obeys_eq_63(gamma: float) -> None:
    osc = R.Oscillator(w0=1.3, gamma=gamma, m=0.7)
    u0, v0 = 1.0, 0.4

    def energy(t: float) -> float:
        return float(osc.energy(osc.motion(t, u0, v0), osc.velocity(t, u0, v0)))

    def kinetic(t: float) -> float:
        return 0.5 * 0.7 * float(osc.velocity(t, u0, v0)) ** 2

    for t0, t1 in [(0.0, 0.5), (0.5, 3.0), (3.0, 10.0)]:
        dissipated, _ = quad(kinetic, t0, t1, epsabs=1e-15, epsrel=1e-13)
        # E(t1) - E(t0) = -2 gamma int T dt; quad to 1e-13: compare at 1e-11 of E(0).
        assert energy(t1) - energy(t0) == pytest.approx(-2.0 * gamma * dissipated, abs=1e-11 * energy(0.0))


def test_heavy_damping_slow_root_keeps_its_digits() -> None:
    osc = R.Oscillator(w0=1.0, gamma=1e8)
    slow = osc.roots()[0].real
    # -w0^2/(gamma/2 + sqrt(gamma^2/4 - w0^2)) = -1e-8 (1 + 1e-16 ...); the naive -gamma/2 +
    # sqrt(...) gives 0 or 7.45e-9 in double precision.
    assert slow == pytest.approx(-1e-8, rel=1e-15)
    assert osc.decay_rate() == pytest.approx(1e-8, rel=1e-15)
    t = np.array([1e6, 1e8, 1e9])
    want = [exact_free_motion(1.0, 1e8, 1.0, 0.0, x) for x in t]
    assert np.allclose(osc.motion(t, 1.0, 0.0), want, rtol=1e-13, atol=0)


def test_oscillator_validation() -> None:
    with pytest.raises(ValueError, match=r"w0 is -1\.0; the natural angular frequency must be positive"):
        R.Oscillator(w0=-1.0, gamma=0.1)
    with pytest.raises(ValueError, match=r"gamma is -0\.1; the friction rate must be >= 0"):
        R.Oscillator(w0=1.0, gamma=-0.1)
    with pytest.raises(ValueError, match=r"m is 0\.0; the mass must be positive"):
        R.Oscillator(w0=1.0, gamma=0.1, m=0.0)
    with pytest.raises(ValueError, match=r"w0 is inf; it must be finite"):
        R.Oscillator(w0=math.inf, gamma=0.1)
    with pytest.raises(TypeError, match=r"gamma must be a real number, got str"):
        R.Oscillator(w0=1.0, gamma="0.1")  # type: ignore[arg-type]
    osc = R.Oscillator(w0=1.0, gamma=0.1)
    with pytest.raises(ValueError, match=r"omega\[1\] is .*-2\.0.*; every angular frequency must be >= 0"):
        osc.amplitude([1.0, -2.0])
    with pytest.raises(ValueError, match=r"omega\[0\] is .*nan.*; every entry must be finite"):
        osc.phase([math.nan])
    with pytest.raises(ValueError, match=r"t\[0\] is .*-1\.0.*; every time must be >= 0"):
        osc.motion([-1.0, 2.0], 1.0, 0.0)
    with pytest.raises(TypeError, match=r"F0 must be a \(complex\) number, got list"):
        osc.complex_amplitude(1.0, [1.0])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"u0 is nan; it must be finite"):
        osc.motion(1.0, math.nan)


def test_oscillator_is_frozen() -> None:
    osc = R.Oscillator(w0=1.0, gamma=0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        osc.gamma = 0.2  # type: ignore[misc]
    assert osc.regime == "underdamped"
    assert R.Oscillator(w0=1.0, gamma=2.0).regime == "critical"


# ====================================================================== multi-dof response
N, K_SPRING, MASS = 24, 50.0, 2.0


def modal_sum_truth(omegas: np.ndarray, force: np.ndarray, c_of_omega_k) -> np.ndarray:
    """x(w) from the closed-form modes of the fixed-fixed chain (not from vibra)."""
    omega_k, shapes = chain_modes(N, K_SPRING, MASS)
    c = c_of_omega_k(omega_k)
    loads = shapes.T @ force
    denominators = omega_k[None, :] ** 2 - omegas[:, None] ** 2 + 1j * omegas[:, None] * c[None, :]
    return (loads / denominators) @ shapes.T


@pytest.fixture
def fixed_chain() -> tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray]:
    K = chain(N, K_SPRING)
    M = np.full(N, MASS)
    force = np.zeros(N)
    force[0] = 1.0                                   # force at one end
    omega_max = 2.0 * math.sqrt(K_SPRING / MASS)
    omegas = np.linspace(0.0, 1.2 * omega_max, 400)
    return K, M, force, omegas


@pytest.mark.parametrize("method", ["direct", "modal", "state_space"])
def test_frf_of_a_chain_with_friction_matches_closed_form_modes(fixed_chain, method: str) -> None:
    K, M, force, omegas = fixed_chain
    eta = 0.05
    C = R.friction_damping(M, eta)                    # C = eta M: c_k = eta for every mode
    truth = modal_sum_truth(omegas, force, lambda w: np.full_like(w, eta))
    C_in = C.toarray() if method == "state_space" else C
    K_in = K.toarray() if method == "state_space" else K
    got = R.frf(K_in, M, C_in, omegas, force, method=method)
    assert got.shape == (omegas.size, N) and got.dtype == np.complex128
    # Round-off amplified by the conditioning at resonance (Q = w_k / eta <= 200): 1e-11.
    assert rel(got, truth) <= 1e-11


def test_rayleigh_damping_ratio_of_each_mode(fixed_chain) -> None:
    K, M, force, omegas = fixed_chain
    a, b = R.rayleigh_coefficients(1.0, 8.0, 0.02, 0.03)
    assert R.rayleigh_damping_ratio([1.0, 8.0], a, b) == pytest.approx([0.02, 0.03], rel=1e-14)
    C = R.rayleigh_damping(K, M, a, b)
    omega_k, shapes = chain_modes(N, K_SPRING, MASS)
    # phi_k^T C phi_k = a + b w_k^2 = 2 zeta(w_k) w_k (closed-form shapes, M-orthonormal).
    projected = np.diag(shapes.T @ (C @ shapes))
    assert projected / (2 * omega_k) == pytest.approx(R.rayleigh_damping_ratio(omega_k, a, b), rel=1e-12)
    truth = modal_sum_truth(omegas[1:], force, lambda w: a + b * w * w)
    assert rel(R.frf(K, M, C, omegas[1:], force, method="modal"), truth) <= 1e-11
    result = R.frequency_response(K, M, None, omegas[1:], force, method="modal",
                                  damping_ratios=R.rayleigh_damping_ratio(omega_k, a, b))
    assert rel(result.response, truth) <= 1e-11


def test_reciprocity(rng: np.random.Generator) -> None:
    n = 12
    A = rng.standard_normal((n, n))
    K = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    M = B @ B.T + n * np.eye(n)                      # a dense SPD mass matrix
    D = rng.standard_normal((n, n))
    C = 0.1 * (D @ D.T)                               # general, non-proportional damping
    omegas = np.linspace(0.1, 3.0, 40)
    H = np.stack([R.frf(K, M, C, omegas, np.eye(n)[j]) for j in range(n)], axis=2)  # H[f, i, j]
    # (K - w^2 M + i w C) is complex symmetric, so H = H^T to round-off times its condition.
    assert np.max(np.abs(H - H.transpose(0, 2, 1))) <= 1e-12 * np.max(np.abs(H))
    dense = np.stack([np.linalg.solve(K - w * w * M + 1j * w * C, np.eye(n)) for w in omegas])
    assert rel(H, dense) <= 1e-12
    ss = np.stack([R.frf(K, M, C, omegas, np.eye(n)[j], method="state_space") for j in range(3)], axis=2)
    assert rel(ss, dense[:, :, :3]) <= 1e-10      # eigen-decomposition route: ~1e-12, 1e-10 bound
    with pytest.raises(ValueError, match=r"C is not diagonal in the modal basis.*use method='direct'"):
        R.frf(K, M, C, omegas, np.eye(n)[0], method="modal")
    # transient_response no longer refuses this C (issue 15, item 4): it moves in state space
    # (checked against solve_ivp in tests/response/test_gyroscopic.py), and keeps every dof.
    assert R.transient_response(K, M, C, [0.0, 1.0], np.eye(n)[0]).method == "state space"
    with pytest.raises(ValueError, match=r"n_modes is 3: C is not diagonal in the modal basis.*leave n_modes out"):
        R.transient_response(K, M, C, [0.0, 1.0], np.eye(n)[0], n_modes=3)


def test_modal_truncation_error_shrinks_and_is_estimated_honestly(fixed_chain) -> None:
    K, M, force, _ = fixed_chain
    C = R.rayleigh_damping(K, M, 0.05, 1e-3)
    omega_k, _ = chain_modes(N, K_SPRING, MASS)
    omegas = np.linspace(0.05, omega_k[3], 200)      # below the 5th mode
    exact = R.frf(K, M, C, omegas, force)
    previous = {False: np.inf, True: np.inf}
    for n_modes in (5, 8, 12, 18):
        for corrected in (False, True):
            result = R.frequency_response(K, M, C, omegas, force, method="modal", n_modes=n_modes,
                                          residual_correction=corrected)
            diff = result.response - exact
            error = np.sqrt(np.sum(np.abs(diff) ** 2 * M, axis=1) / np.sum(np.abs(result.response) ** 2 * M, axis=1))
            # The estimate is a bound over the dropped modes (they all lie above omegas
            # here); 1e-12 slack for round-off in the comparison itself.
            assert np.all(result.truncation_error >= error - 1e-12)
            assert error.max() < previous[corrected]
            previous[corrected] = error.max()
            assert result.n_modes == n_modes and result.natural_frequencies is not None
    # The static correction helps most at low frequency: error ~ (w / w_next)^2.
    plain = R.frequency_response(K, M, C, omegas[:5], force, method="modal", n_modes=8)
    fixed = R.frequency_response(K, M, C, omegas[:5], force, method="modal", n_modes=8, residual_correction=True)
    assert rel(fixed.response, exact[:5]) < 1e-2 * rel(plain.response, exact[:5])
    everything = R.frequency_response(K, M, C, omegas, force, method="modal")
    assert np.all(everything.truncation_error == 0)
    assert rel(everything.response, exact) <= 1e-12    # all modes = direct to round-off


def test_static_limit_and_mass_line(fixed_chain) -> None:
    K, M, force, _ = fixed_chain
    # Static Green's function of the fixed-fixed chain: x_i = (n+1-i) / ((n+1) k) for a unit
    # force on site 1 (i counted from 1).
    i = np.arange(1, N + 1)
    static = (N + 1 - i) / ((N + 1) * K_SPRING)
    C = R.friction_damping(M, 0.3)
    for method in ("direct", "modal", "state_space"):
        K_in = K.toarray() if method == "state_space" else K
        C_in = C.toarray() if method == "state_space" else C
        x = R.frf(K_in, M, C_in, [0.0, 1e-9], force, method=method)
        assert np.allclose(x[0], static, rtol=1e-12, atol=0)
        # w = 1e-9: the damping term shifts x by about w eta / omega_1^2 ~ 1e-9 * 0.3 / 0.39
        # of its size (omega_1^2 ~ 0.39 for this chain): bound 1e-8 of max|x|.
        assert np.allclose(x[1], static, rtol=0, atol=1e-8 * static.max())
    # w -> infinity: x -> -M^-1 f / w^2; relative corrections O(w_max^2 / w^2) ~ 1e-15 and
    # O(eta / w) = 3e-9 (the damping term) at w = 1e8: bound 1e-8 of the driven dof.
    x = R.frf(K, M, C, [1e8], force)[0]
    assert np.allclose(x, -force / MASS / 1e16, rtol=0, atol=1e-8 * 0.5e-16)


def test_free_structure_rigid_body_modes() -> None:
    n = 10
    K = chain(n, 3.0, ends="free")                   # one rigid-body (translation) mode
    M = np.linspace(1.0, 2.0, n)
    C = R.rayleigh_damping(K, M, 0.0, 0.01)          # stiffness-proportional: no rigid damping
    force = np.zeros(n)
    force[0] = 1.0
    with pytest.raises(ValueError, match=r"omegas\[0\] is 0\.0: K - w\^2 M \+ i w C is singular"):
        R.frf(K, M, C, [0.0, 1.0], force)
    with pytest.raises(ValueError, match=r"omegas\[0\] is 0\.0"):
        R.frf(K, M, C, [0.0, 1.0], force, method="modal")
    omegas = np.geomspace(1e-4, 1.0, 12)

    def exact(w: float) -> np.ndarray:  # 30-digit LU solve (mpmath): free of conditioning
        mpmath.mp.dps = 30
        W = mpmath.mpf(w)
        A = (mpmath.matrix(K.toarray().tolist()) - W * W * mpmath.diag(M.tolist())
             + 1j * W * mpmath.matrix(C.toarray().tolist()))
        x = mpmath.lu_solve(A, mpmath.matrix(force.tolist()))
        mpmath.mp.dps = 40
        return np.array([complex(v) for v in x])

    dense = np.stack([exact(w) for w in omegas])
    # Rigid-body motion dominates at low w: x ~ -f_total / (M_total w^2) in every dof.
    assert np.allclose(dense[0], -1.0 / (M.sum() * 1e-8), rtol=1e-3)
    # The direct solve loses digits to the conditioning, ~ (w_max / w)^2 <= 1.2e9 here:
    # bound 10 eps (w_max / w)^2 per frequency (w_max^2 <= 4 k / m_min = 12).
    direct = R.frf(K, M, C, omegas, force)
    gap = np.linalg.norm(direct - dense, axis=1) / np.linalg.norm(dense, axis=1)
    assert np.all(gap <= 10 * 2.2e-16 * 12.0 / omegas**2)
    for corrected in (False, True):
        result = R.frequency_response(K, M, C, omegas, force, method="modal", n_modes=4,
                                      residual_correction=corrected)
        error = np.linalg.norm(result.response - dense, axis=1) / np.linalg.norm(dense, axis=1)
        assert np.all(result.truncation_error * math.sqrt(M.max() / M.min()) >= error - 1e-12)
    # With the static correction of the flexible modes the low-frequency error is tiny.
    assert error[0] <= 1e-10


@pytest.mark.parametrize("width,kind,solver", [(1, "sparse", "tridiagonal"), (3, "sparse", "banded"),
                                                (3, "dense", "banded"), (40, "sparse", "sparse LU"),
                                                (40, "dense", "dense LU")])
def test_direct_solver_paths_agree_with_dense_solve(rng: np.random.Generator, width: int, kind: str,
                                                    solver: str) -> None:
    n = 90
    A = np.zeros((n, n))
    for offset in range(1, width + 1):
        values = rng.uniform(0.1, 1.0, n - offset)
        A -= np.diag(values, offset) + np.diag(values, -offset)
    K = A + np.diag(np.abs(A).sum(axis=1) + 0.5)
    Md = rng.uniform(1.0, 2.0, n)
    C = 0.02 * K + 0.01 * np.diag(Md)
    force = rng.standard_normal(n)
    omegas = np.linspace(0.0, 4.0, 25)
    K_in = sp.csr_matrix(K) if kind == "sparse" else K
    C_in = sp.csr_matrix(C) if kind == "sparse" else C
    result = R.frequency_response(K_in, Md, C_in, omegas, force)
    assert result.solver == solver and result.method == "direct" and result.n_modes is None
    dense = np.stack([np.linalg.solve(K - w * w * np.diag(Md) + 1j * w * C, force) for w in omegas])
    assert rel(result.response, dense) <= 1e-11


def test_undamped_direct_solve_at_an_exact_resonance_is_refused() -> None:
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])          # omega^2 = 1 and 3 with unit masses
    with pytest.raises(ValueError, match=r"omegas\[1\] is 1\.0"):
        R.frf(K, [1.0, 1.0], None, [0.5, 1.0], [1.0, 0.0])


def test_transient_of_a_chain_forced_at_one_end_against_integration() -> None:
    n = 8
    K = chain(n, 4.0, ends="fixed-free").toarray()
    M = np.full(n, 0.5)
    C = R.rayleigh_damping(K, M, 0.1, 0.02)
    force = np.zeros(n)
    force[-1] = 1.0                                   # at the free end
    omega = 1.1
    t = np.linspace(0.0, 15.0, 40)
    result = R.transient_response(K, M, C, t, force, omega=omega)
    Minv = 1.0 / M

    def rhs(time: float, y: np.ndarray) -> np.ndarray:
        u, v = y[:n], y[n:]
        return np.concatenate([v, Minv * (force * math.cos(omega * time) - K @ u - C @ v)])

    ode = solve_ivp(rhs, (0.0, 15.0), np.zeros(2 * n), t_eval=t, method="DOP853", rtol=1e-11, atol=1e-12)
    scale = np.abs(ode.y[:n]).max()
    # DOP853 at rtol 1e-11 over 15 time units: ~1e-9 of the motion; bound 1e-7.
    assert np.allclose(result.displacement, ode.y[:n].T, rtol=0, atol=1e-7 * scale)
    assert np.allclose(result.velocity, ode.y[n:].T, rtol=0, atol=1e-7 * np.abs(ode.y[n:]).max())
    # A constant force (omega = 0) switched on at t = 0 settles on the static deflection K^-1 f.
    # Slowest decay c_1 / 2 ~ 0.053: by t = 800 the transient is e^-42 ~ 1e-18 of it.
    step = R.transient_response(K, M, C, [800.0], force)
    assert np.allclose(step.displacement[0], np.linalg.solve(K, force), rtol=1e-9)


@pytest.mark.parametrize("eta", [0.0, 0.3])
def test_free_chain_pushed_at_one_end_drifts_like_a_free_mass(eta: float) -> None:
    # A free chain (one rigid-body mode) under a constant force at one end has no steady
    # state, but its motion is well defined: the centre of mass moves as X'' + eta X' = F / M_tot
    # (friction C = eta M), X = F t^2 / (2 M_tot) without damping. Checked against that closed
    # form and against solve_ivp for the whole chain; c t runs from 0 to 3 (both branches of
    # the drift formula).
    n = 6
    K = chain(n, 2.0, ends="free").toarray()
    M = np.linspace(1.0, 2.0, n)                       # unequal masses: rigid omega is round-off
    C = R.friction_damping(M, eta).toarray()
    force = np.zeros(n)
    force[0] = 1.0
    t = np.linspace(0.0, 10.0, 41)
    result = R.transient_response(K, M, C if eta else None, t, force)
    centre = result.displacement @ M / M.sum()
    if eta == 0:
        expected = t**2 / (2 * M.sum())
    else:
        expected = (t - (-np.expm1(-eta * t)) / eta) / (eta * M.sum())
    # Closed form in double precision; the modal sum adds round-off of the flexible modes: 1e-12.
    assert np.allclose(centre, expected, rtol=0, atol=1e-12 * expected.max())

    def rhs(time: float, y: np.ndarray) -> np.ndarray:
        u, v = y[:n], y[n:]
        return np.concatenate([v, (force - K @ u - C @ v) / M])

    ode = solve_ivp(rhs, (0.0, 10.0), np.zeros(2 * n), t_eval=t, method="DOP853", rtol=1e-11, atol=1e-12)
    # DOP853 at rtol 1e-11 over 10 time units: ~1e-9 of the motion; bound 1e-7.
    assert np.allclose(result.displacement, ode.y[:n].T, rtol=0, atol=1e-7 * np.abs(ode.y[:n]).max())
    assert np.allclose(result.velocity, ode.y[n:].T, rtol=0, atol=1e-7 * np.abs(ode.y[n:]).max())


def test_undamped_mode_driven_at_its_frequency_is_refused() -> None:
    with pytest.raises(ValueError, match=r"mode 0 \(omega_k = 2\.0\) has no damping and is driven at omega = 2\.0"):
        R.transient_response(np.array([[4.0]]), [1.0], None, [0.0, 1.0], [1.0], omega=2.0)


def test_damped_chain_energy_obeys_eq_63() -> None:
    n, eta = 6, 0.15
    K = chain(n, 2.0).toarray()
    M = np.linspace(1.0, 3.0, n)
    C = R.friction_damping(M, eta)                    # the seed's friction: C = eta M
    u0 = np.sin(np.arange(n))
    v0 = np.cos(np.arange(n))

    def state(t: float) -> tuple[np.ndarray, np.ndarray]:
        result = R.transient_response(K, M, C, [t], np.zeros(n), u0=u0, v0=v0)
        return result.displacement[0], result.velocity[0]

    def energy(t: float) -> float:
        u, v = state(t)
        return 0.5 * float(v @ (M * v) + u @ K @ u)

    def kinetic(t: float) -> float:
        _, v = state(t)
        return 0.5 * float(v @ (M * v))

    for t0, t1 in [(0.0, 1.0), (1.0, 6.0)]:
        dissipated, _ = quad(kinetic, t0, t1, epsabs=1e-14, epsrel=1e-12, limit=200)
        # dE/dt = -2 eta T (eq. 63) integrated; quad to 1e-12: bound 1e-10 of E(0).
        assert energy(t1) - energy(t0) == pytest.approx(-2 * eta * dissipated, abs=1e-10 * energy(0.0))


def test_response_validation(fixed_chain) -> None:
    K, M, force, omegas = fixed_chain
    C = R.friction_damping(M, 0.1)
    with pytest.raises(ValueError, match=r"K must be square, got shape \(3, 4\)"):
        R.frf(np.ones((3, 4)), M, C, omegas, force)
    with pytest.raises(ValueError, match=r"M must have 24 masses to match K, got shape \(23,\)"):
        R.frf(K, M[:-1], C, omegas, force)
    with pytest.raises(ValueError, match=r"M\[2\] is .*-1\.0.*; every mass must be positive"):
        R.frf(K, np.where(np.arange(N) == 2, -1.0, M), C, omegas, force)
    with pytest.raises(ValueError, match=r"C must be \(24, 24\) to match K, got shape \(23, 23\)"):
        R.frf(K, M, np.eye(N - 1), omegas, force)
    with pytest.raises(ValueError, match=r"C\[0,0\] is .*-0\.2.*; a damping matrix must have a non-negative diagonal"):
        R.frf(K, M, -C, omegas, force)
    with pytest.raises(ValueError, match=r"force must have 24 entries to match K, got shape \(5,\)"):
        R.frf(K, M, C, omegas, force[:5])
    with pytest.raises(ValueError, match=r"omegas\[2\] is .*-1\.0.*; every angular frequency must be >= 0"):
        R.frf(K, M, C, [0.0, 1.0, -1.0], force)
    with pytest.raises(ValueError, match=r"method is 'fast'; expected one of 'direct', 'modal', 'state_space'"):
        R.frf(K, M, C, omegas, force, method="fast")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"n_modes is 3; it applies to method='modal' only"):
        R.frf(K, M, C, omegas, force, n_modes=3)
    with pytest.raises(ValueError, match=r"n_modes is 25; expected 1 <= n_modes <= 24"):
        R.frf(K, M, C, omegas, force, method="modal", n_modes=25)
    with pytest.raises(ValueError, match=r"give either C or damping_ratios, not both"):
        R.frequency_response(K, M, C, omegas, force, method="modal", damping_ratios=0.1)
    with pytest.raises(ValueError, match=r"damping_ratios\[1\] is .*-0\.1.*; every damping ratio must be >= 0"):
        R.frequency_response(K, M, None, omegas, force, method="modal", n_modes=2, damping_ratios=[0.1, -0.1])
    with pytest.raises(ValueError, match=r"damping_ratios must have 2 entries"):
        R.frequency_response(K, M, None, omegas, force, method="modal", n_modes=2, damping_ratios=[0.1] * 3)
    with pytest.raises(ValueError, match=r"K is not symmetric"):
        R.frf(np.triu(K.toarray()), M, C, omegas, force)
    with pytest.raises(TypeError, match=r"residual_correction must be a bool, got str"):
        R.frequency_response(K, M, C, omegas, force, residual_correction="yes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"eta is -0\.5; the friction rate must be >= 0"):
        R.friction_damping(M, -0.5)
    with pytest.raises(ValueError, match=r"b is -1\.0; Rayleigh coefficients must be >= 0"):
        R.rayleigh_damping(K, M, 0.1, -1.0)
    with pytest.raises(ValueError, match=r"omega\[0\] is .*0\.0.*; every angular frequency must be positive"):
        R.rayleigh_damping_ratio([0.0, 1.0], 0.1, 0.1)
    with pytest.raises(ValueError, match=r"one is negative"):
        R.rayleigh_coefficients(1.0, 2.0, 0.5, 0.01)
    with pytest.raises(ValueError, match=r"omega_1 and omega_2 are both 1\.0"):
        R.rayleigh_coefficients(1.0, 1.0, 0.1, 0.1)
    with pytest.raises(ValueError, match=r"t\[1\] is .*-2\.0.*; every time must be >= 0"):
        R.transient_response(K, M, C, [0.0, -2.0], force)
    with pytest.raises(ValueError, match=r"u0 must have 24 entries to match K, got shape \(3,\)"):
        R.transient_response(K, M, C, [0.0], force, u0=np.zeros(3))


def test_result_types_are_frozen(fixed_chain) -> None:
    K, M, force, omegas = fixed_chain
    result = R.frequency_response(K, M, R.friction_damping(M, 0.1), omegas, force, method="modal", n_modes=4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.method = "direct"  # type: ignore[misc]
    for array in (result.omegas, result.response, result.force, result.truncation_error,
                  result.natural_frequencies):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0  # type: ignore[index]
    transient = R.transient_response(K, M, R.friction_damping(M, 0.1), [0.0, 1.0], force)
    with pytest.raises(dataclasses.FrozenInstanceError):
        transient.n_modes = 1  # type: ignore[misc]
    for array in (transient.t, transient.displacement, transient.velocity):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0


# ====================================================================== charts


def test_charts_render(tmp_path, fixed_chain) -> None:
    K, M, force, omegas = fixed_chain
    path = save_figure(plot_oscillator_response(), tmp_path / "fig7.png")
    check_png(path, (552, 1320))                     # 11 x 4.6 in at 120 dpi
    result = R.frequency_response(K, M, R.friction_damping(M, 0.1), omegas[1:], force, method="modal")
    path = save_figure(plot_frf(result, N - 1), tmp_path / "frf.png")
    check_png(path, (780, 1080))
    path = save_figure(plot_rayleigh_damping(0.05, 1e-3, omegas[1:], natural_frequencies=result.natural_frequencies),
                       tmp_path / "rayleigh.png")
    check_png(path, (600, 960))
    with pytest.raises(ValueError, match=r"dof is 24; expected 0 <= dof <= 23"):
        plot_frf(result, N)
    with pytest.raises(TypeError, match=r"oscillators\[0\] must be an Oscillator, got float"):
        plot_oscillator_response([1.0])  # type: ignore[list-item]


def test_charts_name_the_units_of_the_system() -> None:
    # The receptance of an SI system is in m/N and omega in rad/s; a dimensionless one says so.
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    si = R.frequency_response(K, [1.0, 1.0], 0.1 * np.eye(2), np.linspace(0.1, 2.0, 50), [1.0, 0.0],
                                     units="SI")
    figure = plot_frf(si, 0, K=K, M=[1.0, 1.0], title="two masses")
    assert figure.axes[0].get_ylabel().endswith("per unit force (m/N)")
    assert figure.axes[0].get_title() == "two masses"
    assert figure.axes[1].get_xlabel().endswith("(rad/s)")
    figure = plot_oscillator_response(units="SI")
    assert figure.axes[0].get_ylabel().endswith("(m)") and figure.axes[0].get_xlabel().endswith("(rad/s)")
    generic = plot_oscillator_response()
    assert generic.axes[0].get_xlabel().endswith("(rad / time unit)")


# ====================================================================== issue 16: phases and damping
@pytest.mark.parametrize("method", ["direct", "modal", "state_space"])
def test_a_complex_force_keeps_its_phase(fixed_chain, method: str) -> None:
    """f = |f| exp(i phi) per dof: the response is the closed-form modal sum for the complex f.

    Truth: the closed-form modes of the fixed chain (modal_sum_truth), linear in f, so a force
    with a quarter-period lag at one end and in phase at the other is the sum of the two.
    """
    K, M, _, omegas = fixed_chain
    force = np.zeros(N, dtype=complex)
    force[0], force[-1] = 1.0, 0.5j
    eta = 0.05
    C = R.friction_damping(M, eta)
    truth = modal_sum_truth(omegas, force, lambda w: np.full_like(w, eta))
    C_in = C.toarray() if method == "state_space" else C
    K_in = K.toarray() if method == "state_space" else K
    result = R.frequency_response(K_in, M, C_in, omegas, force, method=method)
    assert rel(result.response, truth) <= 1e-11
    assert np.iscomplexobj(result.force) and result.force[-1] == 0.5j
    assert np.all(result.truncation_error == 0.0)
    # the phase is not dropped: the real part alone gives another response
    real_only = R.frf(K_in, M, C_in, omegas, force.real, method=method)
    assert rel(real_only, truth) > 0.1


def test_an_indefinite_damping_matrix_is_refused_beyond_its_diagonal() -> None:
    """C with a non-negative diagonal but a negative eigenvalue (negative damping) is refused.

    Truth: C = c (2 I - A), A the adjacency of a ring, has eigenvalues c (2 - 2 cos theta) >= 0;
    C = c (I + A) has eigenvalue c (1 - 2) = -c < 0 (theta = pi, even n): the diagonal is c > 0.
    """
    n = 2400  # above the dense limit of the check: the sparse LDL^T pivots decide
    ring = sp.diags([np.ones(n - 1), np.ones(n - 1)], [-1, 1], format="lil")
    ring[0, n - 1] = ring[n - 1, 0] = 1.0
    ring = ring.tocsr()
    K = chain(n, K_SPRING)
    M = np.full(n, MASS)
    force = np.zeros(n)
    force[0] = 1.0
    psd = 0.1 * (2 * sp.identity(n, format="csr") - ring)
    assert R.frf(K, M, psd, [1.0], force).shape == (1, n)  # singular but semi-definite: accepted
    with pytest.raises(ValueError, match=r"C is not positive semi-definite: its smallest eigenvalue is -0\.1"):
        R.frf(K, M, 0.1 * (sp.identity(n, format="csr") + ring), [1.0], force)
    small = np.array([[1.0, 2.0], [2.0, 1.0]])  # eigenvalues 3 and -1, the dense branch
    with pytest.raises(ValueError, match=r"C is not positive semi-definite: its smallest eigenvalue is -1"):
        R.frf(np.eye(2), [1.0, 1.0], small, [1.0], [1.0, 0.0])


def test_a_response_too_large_to_hold_is_refused_before_it_starts() -> None:
    """10^4 frequencies x 10^6 dofs of complex output is 16e10 bytes = 149 GiB: refused at once."""

    n = 10**6
    K = chain(n, K_SPRING)
    M = np.full(n, MASS)
    force = np.zeros(n)
    force[0] = 1.0
    omegas = np.linspace(0.1, 1.0, 10**4)
    import tracemalloc

    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"K has 1000000 dofs: the direct path \(10000 frequencies x 1000000 "
                                             r"dofs\) would need about 149\.\d GiB"):  # 149.0 GiB of output + work
            R.frf(K, M, None, omegas, force)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # refused before the work: the checks' O(n) temporaries at most (8 MB per array of 10^6), not
    # any part of the 149 GiB (no time is asserted: a test runs on loaded machines)
    assert peak < 256 * 2**20
    assert f"{16e10 / 2**30:.1f}" == "149.0"
    small = R.frequency_response(chain(8, K_SPRING), np.full(8, MASS), None, [0.1], np.eye(8)[0],
                                 max_memory=float("inf"), max_seconds=float("inf"))
    assert small.response.shape == (1, 8)
