"""Response of gyroscopic and non-proportionally damped systems (issue 15, item 4).

M u'' + (C + G) u' + K u = Re{f exp(i w t)}, C symmetric positive semi-definite (not
proportional), G skew. Truth comes from outside vibra.response: the receptance
(K - w^2 M + i w (C + G))^-1 f solved densely with numpy.linalg.solve in the test; the
charged particle in an isotropic 2-D well and a magnetic field (resonances at
sqrt(w0^2 + w_c^2/4) -+ w_c/2, and the closed form of each circular component); the free
charge pushed by a constant force (the E x B drift, in closed form); the critically damped
oscillator t e^(-gamma t / 2) (seed 003 eq. 128); scipy.integrate.solve_ivp (DOP853,
rtol 1e-10 or tighter); and the energy balance dE/dt = f(t) . u' - u'^T C u' (G does no work).
"""

from __future__ import annotations

import dataclasses
import math

import mpmath
import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import simpson, solve_ivp
from scipy.optimize import minimize_scalar

import vibra
from vibra import chains
from vibra.mechanics import gyroscopic
from vibra import response as R
from vibra.response import state_space

J = np.array([[0.0, -1.0], [1.0, 0.0]])


def dense_receptance(K: np.ndarray, M: np.ndarray, D: np.ndarray, omegas: np.ndarray, force: np.ndarray,
                     ) -> np.ndarray:
    """(n_freq, n_dof) (K - w^2 M + i w D)^-1 f by numpy's dense solver (D = C + G)."""
    return np.array([np.linalg.solve(K - w * w * M + 1j * w * D, force) for w in omegas])


def rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def random_system(rng: np.random.Generator, n: int) -> tuple[np.ndarray, ...]:
    """K SPD, diagonal masses, C symmetric PSD and not proportional, G skew."""
    A = rng.standard_normal((n, n))
    K = A @ A.T + n * np.eye(n)
    M = rng.uniform(0.5, 2.0, n)
    B = rng.standard_normal((n, n - 1))
    C = 0.3 * B @ B.T                                # rank n - 1: semi-definite
    S = rng.standard_normal((n, n))
    G = S - S.T
    return K, M, C, G


def integrate(K: np.ndarray, M: np.ndarray, D: np.ndarray, force: np.ndarray, omega: float, u0: np.ndarray,
              v0: np.ndarray, t: np.ndarray, rtol: float = 1e-11) -> tuple[np.ndarray, np.ndarray]:
    """u, u' of M u'' + D u' + K u = f cos(w t) by solve_ivp (DOP853); M a matrix."""
    n = K.shape[0]
    M_inv = np.linalg.inv(M)

    def rhs(time: float, y: np.ndarray) -> np.ndarray:
        u, v = y[:n], y[n:]
        return np.concatenate([v, M_inv @ (force * math.cos(omega * time) - K @ u - D @ v)])

    ode = solve_ivp(rhs, (0.0, float(t[-1])), np.concatenate([u0, v0]), t_eval=t, method="DOP853",
                    rtol=rtol, atol=1e-14)
    assert ode.success
    return ode.y[:n].T, ode.y[n:].T


# ====================================================================== frequency response
@pytest.mark.parametrize("method", ["direct", "state_space"])
def test_dense_gyroscopic_and_non_proportional_response_matches_a_dense_solve(method: str) -> None:
    rng = np.random.default_rng(15)
    n = 6
    K, M, C, G = random_system(rng, n)
    omegas = np.linspace(0.0, 4.0, 61)
    force = rng.standard_normal(n)
    truth = dense_receptance(K, np.diag(M), C + G, omegas, force)
    result = R.frequency_response(K, M, C, omegas, force, G=G, method=method)
    assert result.gyroscopic and result.method == method
    assert rel(result.response, truth) <= (1e-12 if method == "direct" else 1e-10)
    # G alone (no damping: the system is undamped but gyroscopic; none of these w is a resonance)
    truth_g = dense_receptance(K, np.diag(M), G, omegas[1:], force)
    assert rel(R.frf(K, M, None, omegas[1:], force, G=G, method=method), truth_g) <= 1e-9
    # a complex force keeps its phase: x is linear in f
    phased = force * np.exp(1j * rng.uniform(0, 2 * np.pi, n))
    truth_c = dense_receptance(K, np.diag(M), C + G, omegas, phased)
    assert rel(R.frf(K, M, C, omegas, phased, G=G, method=method), truth_c) <= 1e-10


def banded_skew(n: int, width: int, rng: np.random.Generator) -> sp.csr_matrix:
    """A skew matrix with nonzeros on diagonals 1..width (and their negatives below)."""
    upper = sp.diags([rng.standard_normal(n - k) for k in range(1, width + 1)], list(range(1, width + 1)))
    return sp.csr_matrix(upper - upper.T)


@pytest.mark.parametrize(("width", "solver"), [(1, "tridiagonal"), (3, "banded"), (40, "sparse LU")])
def test_sparse_gyroscopic_chain_keeps_the_fast_solvers(width: int, solver: str) -> None:
    # A chain with a dashpot at one end (C non-proportional) in a rotating frame (G of the
    # given half-bandwidth): the direct method still runs its tridiagonal / banded solver.
    rng = np.random.default_rng(width)
    n = 80
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    M = rng.uniform(1.0, 2.0, n)
    C = sp.csr_matrix(([0.7], ([n - 1], [n - 1])), shape=(n, n))
    G = 0.2 * banded_skew(n, width, rng)
    omegas = np.linspace(0.05, 1.6, 25)
    force = np.zeros(n)
    force[0] = 1.0
    result = R.frequency_response(K, M, C, omegas, force, G=G)
    assert result.solver == solver
    truth = dense_receptance(K.toarray(), np.diag(M), (C + G).toarray(), omegas, force)
    assert rel(result.response, truth) <= 1e-10


def charged(mass: float, omega0: float, omega_c: float, c: float) -> tuple[np.ndarray, ...]:
    """M, K, C, G of a charge in an isotropic 2-D well and a field along z (q B = m omega_c)."""
    return mass * np.eye(2), mass * omega0**2 * np.eye(2), c * np.eye(2), mass * omega_c * J


def circular_peaks(omega0: float, omega_c: float) -> tuple[float, float]:
    """sqrt(w0^2 + w_c^2 / 4) -+ w_c / 2, the lower without cancellation (w0^2 / upper)."""
    upper = math.sqrt(omega0**2 + omega_c**2 / 4) + abs(omega_c) / 2
    return omega0**2 / upper, upper


@settings(max_examples=60, deadline=None)
@given(mass=st.floats(1e-3, 1e3), omega0=st.floats(1e-3, 1e3), ratio=st.floats(1e-3, 1e3))
def test_charged_particle_resonances_are_at_the_closed_form(mass: float, omega0: float, ratio: float) -> None:
    # The equations for X + iY and X - iY separate: with a = m (w0^2 - w^2) + i c w and
    # b = m w_c w, X + iY = (F_x + i F_y) / (a - b) and X - iY = (F_x - i F_y) / (a + b). At
    # the lower peak w_-, m (w0^2 - w^2) = m w_c w, so |X + iY| = |F_x + i F_y| / (c w_-)
    # exactly; at the upper one |X - iY| = |F_x - i F_y| / (c w_+).
    omega_c = ratio * omega0
    c = 1e-6 * mass * omega0                         # light damping: the peaks are w_-+ to O(1e-12)
    M, K, C, G = charged(mass, omega0, omega_c, c)
    low, high = circular_peaks(omega0, omega_c)
    force = np.array([1.0, 0.3])
    x = R.frequency_response(K, M, C, [low, high], force, G=G).response
    plus = x[0, 0] + 1j * x[0, 1]
    minus = x[1, 0] - 1j * x[1, 1]
    # rounding: m w0^2 eps against the damping term c w ~ 1e-6 m w0 w: a few 1e-10 relative
    assert abs(plus) == pytest.approx(abs(1.0 + 0.3j) / (c * low), rel=1e-8)
    assert abs(minus) == pytest.approx(abs(1.0 - 0.3j) / (c * high), rel=1e-8)


@pytest.mark.parametrize(("omega0", "omega_c"), [(1.0, 1.0), (3.0, 0.2), (0.5, 40.0)])
def test_charged_particle_amplitude_peaks_where_the_closed_form_says(omega0: float, omega_c: float) -> None:
    # The maximum of |x(w)| (force along x), found by a bounded search that calls the code,
    # lies at w_-+ (the damping and the other circular component move it by ~1e-13) to the
    # accuracy the search reaches: scipy's bounded Brent stops at sqrt(eps) |w| = 1.5e-8 |w|,
    # 1 % of the peaks' width c / m = 1e-6 w0.
    M, K, C, G = charged(2.0, omega0, omega_c, 2e-6 * omega0)
    for peak in circular_peaks(omega0, omega_c):
        def minus_amplitude(w: float) -> float:
            return -float(np.abs(R.frf(K, M, C, [w], [1.0, 0.0], G=G)[0, 0]))

        found = minimize_scalar(minus_amplitude, bounds=(peak * (1 - 1e-4), peak * (1 + 1e-4)), method="bounded",
                                options={"xatol": 1e-14 * peak})
        assert found.x == pytest.approx(peak, rel=3e-8)


def test_undamped_charged_particle_is_singular_exactly_at_both_peaks() -> None:
    M, K, _, G = charged(1.0, 1.0, 1.0, 0.0)
    low, high = circular_peaks(1.0, 1.0)
    for i, w in enumerate([0.3, low, high]):
        if i == 0:
            R.frf(K, M, None, [w], [1.0, 0.0], G=G)      # off resonance: fine
            continue
        with pytest.raises(ValueError, match=r"omegas\[0\] is .*: K - w\^2 M \+ i w \(C \+ G\) is singular there"):
            R.frf(K, M, None, [w], [1.0, 0.0], G=G)
    # off by 1e-6 relative: finite, of size 1 / (distance to the root)
    near = R.frf(K, M, None, [high * (1 + 1e-6)], [1.0, 0.0], G=G)
    assert 1e4 < np.abs(near).max() < 1e7


def test_state_space_natural_frequencies_of_the_charged_particle() -> None:
    M, K, _, G = charged(1.0, 2.0, 3.0, 0.0)
    result = R.frequency_response(K, M, None, [1.0], [1.0, 0.0], G=G, method="state_space")
    assert result.natural_frequencies == pytest.approx(circular_peaks(2.0, 3.0), rel=1e-12)


# ====================================================================== transient response
@pytest.mark.parametrize("case", ["non-proportional", "gyroscopic", "gyroscopic undamped", "dense M"])
@pytest.mark.parametrize("omega", [0.0, 1.3])
def test_transient_matches_integration(case: str, omega: float) -> None:
    rng = np.random.default_rng(3)
    n = 3
    K, masses, C, G = random_system(rng, n)
    M: np.ndarray = masses
    M_matrix = np.diag(masses)
    if case == "dense M":
        B = rng.standard_normal((n, n))
        M_matrix = B @ B.T + n * np.eye(n)
        M = M_matrix
    G_arg = None if case == "non-proportional" else G
    C_arg = None if case == "gyroscopic undamped" else C
    D = np.zeros((n, n)) + (C_arg if C_arg is not None else 0.0) + (G_arg if G_arg is not None else 0.0)
    force = np.array([1.0, -0.5, 0.25])
    u0 = np.array([0.1, -0.2, 0.3])
    v0 = np.array([0.0, 0.5, -0.1])
    t = np.linspace(0.0, 12.0, 121)
    result = R.transient_response(K, M, C_arg, t, force, G=G_arg, omega=omega, u0=u0, v0=v0)
    assert result.method == "state space" and result.n_modes == n
    u, v = integrate(K, M_matrix, D, force, omega, u0, v0, t)
    # DOP853 at rtol 1e-11 over 12 time units: ~1e-10 of the motion; bound 1e-8.
    assert np.allclose(result.displacement, u, rtol=0, atol=1e-8 * np.abs(u).max())
    assert np.allclose(result.velocity, v, rtol=0, atol=1e-8 * np.abs(v).max())


def test_transient_at_solve_ivp_rtol_1e_10_on_unsorted_repeated_times() -> None:
    # The brief's tolerance: solve_ivp at rtol 1e-10 is the truth; times in any order, repeated.
    rng = np.random.default_rng(7)
    K, M, C, G = random_system(rng, 3)
    t = np.array([5.0, 0.0, 2.5, 5.0, 1.0, 7.25, 0.5])
    force = np.array([0.0, 1.0, 0.0])
    result = R.transient_response(K, M, C, t, force, G=G, omega=0.9, u0=[1.0, 0.0, 0.0])
    times, where = np.unique(t, return_inverse=True)
    u, v = integrate(K, np.diag(M), C + G, force, 0.9, np.array([1.0, 0.0, 0.0]), np.zeros(3), times, rtol=1e-10)
    assert np.allclose(result.displacement, u[where], rtol=0, atol=1e-7 * np.abs(u).max())
    assert np.allclose(result.velocity, v[where], rtol=0, atol=1e-7 * np.abs(v).max())
    assert np.array_equal(result.displacement[0], result.displacement[3])
    assert np.array_equal(result.displacement[1], [1.0, 0.0, 0.0])


def test_undamped_gyroscopic_resonance_grows_instead_of_being_refused() -> None:
    # Driven exactly at w_+ with no damping the amplitude grows as t: the exponential of the
    # augmented system holds it exactly (checked against solve_ivp).
    M, K, _, G = charged(1.0, 1.0, 1.0, 0.0)
    high = circular_peaks(1.0, 1.0)[1]
    t = np.linspace(0.0, 60.0, 61)
    result = R.transient_response(K, M, None, t, [1.0, 0.0], G=G, omega=high)
    u, _ = integrate(K, M, G, np.array([1.0, 0.0]), high, np.zeros(2), np.zeros(2), t)
    assert np.allclose(result.displacement, u, rtol=0, atol=1e-8 * np.abs(u).max())
    late = np.abs(result.displacement[-10:]).max()
    early = np.abs(result.displacement[:10]).max()
    assert late > 5 * early                          # it grows (about linearly)


@pytest.mark.parametrize(("spin", "stable"), [(1.0, False), (3.0, True)])
def test_gyroscopic_stabilisation_of_an_indefinite_K(spin: float, stable: bool) -> None:
    # K = -diag(1, 2) alone diverges; G = spin J holds it when spin > 1 + sqrt(2) (the
    # Hamiltonian threshold). The state-space motion follows solve_ivp either way: bounded
    # when stabilised, growing when not.
    K = -np.diag([1.0, 2.0])
    G = spin * J
    t = np.linspace(0.0, 10.0, 51)
    result = R.transient_response(K, [1.0, 1.0], None, t, [0.0, 0.0], G=G, u0=[1e-3, 0.0])
    u, _ = integrate(K, np.eye(2), G, np.zeros(2), 0.0, np.array([1e-3, 0.0]), np.zeros(2), t)
    assert np.allclose(result.displacement, u, rtol=0, atol=1e-8 * np.abs(u).max())
    growth = np.abs(result.displacement).max() / 1e-3
    assert (growth < 10) if stable else (growth > 100)


@settings(max_examples=40, deadline=None)
@given(omega_c=st.floats(1e-2, 1e2), force=st.floats(1e-3, 1e3), t=st.floats(0.0, 50.0))
def test_free_charge_pushed_by_a_constant_force_drifts_across_it(omega_c: float, force: float, t: float) -> None:
    # m x'' = q B y' + F, m y'' = -q B x' from rest (K = 0: two rigid-body modes):
    # x = F (1 - cos w_c t) / (m w_c^2), y = -F (w_c t - sin w_c t) / (m w_c^2): cyclotron
    # loops on a drift of speed F / (q B) perpendicular to the force (E x B).
    mass = 2.0
    G = mass * omega_c * J
    result = R.transient_response(np.zeros((2, 2)), [mass, mass], None, [t], [force, 0.0], G=G)
    phase = omega_c * t
    scale = force / (mass * omega_c**2)
    expected = scale * np.array([2 * math.sin(phase / 2) ** 2, -(phase - math.sin(phase))])
    size = scale * max(1.0, phase)
    # n_t = 1: one exponential of a norm-w_c t matrix; rounding ~ eps * w_c t of the motion
    assert np.allclose(result.displacement[0], expected, rtol=0, atol=1e-12 * size)
    assert result.velocity[0] == pytest.approx(force / (mass * omega_c) * np.array([math.sin(phase),
                                                                                     -(1 - math.cos(phase))]),
                                               abs=1e-12 * force / (mass * omega_c) * max(1.0, phase))


@pytest.mark.parametrize("G_scale", [0.0, 0.8])
def test_energy_balance_with_dissipation(G_scale: float) -> None:
    # E = u'^T M u' / 2 + u^T K u / 2 changes by the work of the force minus the dissipation:
    # E(T) - E(0) = int f cos(w t) . u' dt - int u'^T C u' dt; G does no work (u'^T G u' = 0).
    rng = np.random.default_rng(11)
    K, M, C, G = random_system(rng, 3)
    force = np.array([0.5, 0.0, -1.0])
    omega = 1.7
    t = np.linspace(0.0, 8.0, 8001)
    result = R.transient_response(K, M, C, t, force, G=G_scale * G, omega=omega, u0=[0.2, 0.0, -0.1],
                                  v0=[0.0, 0.3, 0.0])
    u, v = result.displacement, result.velocity
    energy = 0.5 * np.einsum("ti,i,ti->t", v, M, v) + 0.5 * np.einsum("ti,ij,tj->t", u, K, u)
    power_in = (v @ force) * np.cos(omega * t)
    dissipated = np.einsum("ti,ij,tj->t", v, C, v)
    work = simpson(power_in, x=t)
    loss = simpson(dissipated, x=t)
    # Simpson on h = 1e-3 (frequencies up to ~3): error ~ h^4 w^5 T ~ 1e-9 of the energies.
    scale = max(energy.max(), abs(work), loss)
    assert energy[-1] - energy[0] == pytest.approx(work - loss, abs=1e-8 * scale)


def test_gyroscopic_forces_do_no_work() -> None:
    # No damping, no force: E stays constant (to the rounding of the steps) over 400 steps.
    rng = np.random.default_rng(5)
    K, M, _, G = random_system(rng, 4)
    t = np.linspace(0.0, 40.0, 401)
    result = R.transient_response(K, M, None, t, np.zeros(4), G=3.0 * G, u0=[1.0, 0.0, -1.0, 0.5])
    u, v = result.displacement, result.velocity
    energy = 0.5 * np.einsum("ti,i,ti->t", v, M, v) + 0.5 * np.einsum("ti,ij,tj->t", u, K, u)
    assert np.max(np.abs(energy - energy[0])) <= 1e-12 * energy[0]


def free_oscillator(w0: float, gamma: float, u0: float, v0: float, t: float) -> float:
    """u(t) of u'' + gamma u' + w0^2 u = 0 by eqs. 126-128 in 40-digit arithmetic (double root too)."""
    with mpmath.workdps(40):
        W0, Gm, T = mpmath.mpf(w0), mpmath.mpf(gamma), mpmath.mpf(t)
        disc = Gm**2 / 4 - W0**2
        if disc == 0:
            return float(mpmath.exp(-Gm / 2 * T) * (u0 + (v0 + Gm / 2 * u0) * T))
        root = mpmath.sqrt(mpmath.mpc(disc))
        l1, l2 = -Gm / 2 + root, -Gm / 2 - root
        c2 = (v0 - l1 * u0) / (l2 - l1)
        return float(mpmath.re((u0 - c2) * mpmath.exp(l1 * T) + c2 * mpmath.exp(l2 * T)))


@pytest.mark.parametrize("offset", [-1e-12, 0.0, 1e-12])
def test_critical_damping_is_passed_continuously(offset: float) -> None:
    # dof 0 alone is the oscillator u'' + c u' + 4 u = 0 at c = 4 (1 + offset): critically
    # damped at offset 0, u = (u0 + (v0 + 2 u0) t) e^(-2t) (eq. 128), and just under- or
    # over-damped beside it (eqs. 126-127, where each root alone cancels: mpmath). dofs 1 and
    # 2 have non-proportional damping, so the whole system goes through the state-space path.
    K = np.diag([4.0, 3.0, 1.0])
    K[1, 2] = K[2, 1] = -1.0
    C = np.zeros((3, 3))
    C[0, 0] = 4.0 * (1.0 + offset)
    C[1:, 1:] = [[0.5, 0.0], [0.0, 0.0]]
    M = np.ones(3)
    t = np.linspace(0.0, 10.0, 101)
    u0, v0 = np.array([1.0, 0.5, 0.0]), np.array([-3.0, 0.0, 1.0])
    result = R.transient_response(K, M, C, t, np.zeros(3), u0=u0, v0=v0)
    assert result.method == "state space"
    expected = np.array([free_oscillator(2.0, C[0, 0], 1.0, -3.0, time) for time in t])
    assert np.allclose(result.displacement[:, 0], expected, rtol=0, atol=1e-14)
    u, _ = integrate(K, np.eye(3), C, np.zeros(3), 0.0, u0, v0, t)
    assert np.allclose(result.displacement[:, 1:], u[:, 1:], rtol=0, atol=1e-9)


def test_sparse_exponential_path_on_a_long_chain_with_a_dashpot(monkeypatch: pytest.MonkeyPatch) -> None:
    # 120 masses (242 states) with a dashpot at the far end: above a lowered dense limit the
    # sparse exponential (expm_multiply) runs; both paths against solve_ivp.
    n = 120
    K = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr") * 4.0
    M = np.linspace(1.0, 2.0, n)
    C = sp.csr_matrix(([1.5], ([n - 1], [n - 1])), shape=(n, n))
    force = np.zeros(n)
    force[0] = 1.0
    t = np.linspace(0.0, 6.0, 31)
    dense = R.transient_response(K, M, C, t, force, omega=0.7)
    monkeypatch.setattr(state_space, "DENSE_STATE_MAX", 100)
    sparse_result = R.transient_response(K, M, C, t, force, omega=0.7)
    u, v = integrate(K.toarray(), np.diag(M), C.toarray(), force, 0.7, np.zeros(n), np.zeros(n), t)
    for result in (dense, sparse_result):
        assert result.method == "state space"
        assert np.allclose(result.displacement, u, rtol=0, atol=1e-8 * np.abs(u).max())
        assert np.allclose(result.velocity, v, rtol=0, atol=1e-8 * np.abs(v).max())


def test_proportional_damping_keeps_the_modal_path() -> None:
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    C = R.rayleigh_damping(K, [1.0, 1.0], 0.1, 0.05)
    assert R.transient_response(K, [1.0, 1.0], C, [0.0, 1.0], [1.0, 0.0]).method == "modal"
    assert R.transient_response(K, [1.0, 1.0], C, [0.0, 1.0], [1.0, 0.0], G=np.zeros((2, 2))).method == "modal"
    assert R.frequency_response(K, [1.0, 1.0], C, [1.0], [1.0, 0.0], G=sp.csr_matrix((2, 2))).gyroscopic is False


# ====================================================================== systems taken as they are
def test_a_gyroscopic_system_is_taken_unchanged() -> None:
    system = gyroscopic.charged_particle(mass=2.0, omega0=1.5, charge=0.5, field=3.0)
    omegas = np.linspace(0.1, 3.0, 30)
    force = np.array([1.0, 0.0])
    extra = 0.01 * np.eye(2)
    result = R.system_frequency_response(system, omegas, force, C=extra)
    M, K, _, G = charged(2.0, 1.5, 0.5 * 3.0 / 2.0, 0.0)
    assert rel(result.response, dense_receptance(K, M, extra + G, omegas, force)) <= 1e-12
    assert result.gyroscopic and result.units == system.units
    t = np.linspace(0.0, 5.0, 11)
    motion = R.system_transient_response(system, t, force, omega=1.0, v0=[0.0, 1.0])
    u, _ = integrate(K, M, G, force, 1.0, np.zeros(2), np.array([0.0, 1.0]), t)
    assert np.allclose(motion.displacement, u, rtol=0, atol=1e-8 * np.abs(u).max())


def test_a_damped_generalized_system_with_frozen_coordinates() -> None:
    C = np.array([[0.4, 0.1, 0.0], [0.1, 0.2, 0.05], [0.0, 0.05, 0.3]])
    G = 0.5 * np.array([[0.0, 1.0, -2.0], [-1.0, 0.0, 1.0], [2.0, -1.0, 0.0]])
    M = np.array([[2.0, 0.3, 0.0], [0.3, 1.0, 0.1], [0.0, 0.1, 1.5]])
    K = np.array([[5.0, -1.0, 0.0], [-1.0, 4.0, -1.0], [0.0, -1.0, 3.0]])
    system = vibra.System.generalized(M, K, C=C, G=G).freeze(dofs=[1])
    parts = R.system_matrices(system)
    keep = np.ix_([0, 2], [0, 2])
    np.testing.assert_array_equal(parts.C, C[keep])
    np.testing.assert_array_equal(parts.G, G[keep])
    omegas = np.array([0.5, 1.5, 2.5])
    result = R.system_frequency_response(system, omegas, [1.0, 1.0])
    truth = dense_receptance(K[keep], M[keep], C[keep] + G[keep], omegas, np.array([1.0, 1.0]))
    assert rel(result.response, truth) <= 1e-12


def test_a_site_system_takes_added_damping() -> None:
    chain = chains.linear_chain(12, ends="fixed")
    parts = R.system_matrices(chain)
    assert parts.C is None and parts.G is None
    C = R.rayleigh_damping(parts.K, parts.M, 0.05, 0.01)
    omegas = np.linspace(0.1, 1.5, 15)
    force = np.zeros(chain.n_dof)
    force[0] = 1.0
    ours = R.system_frequency_response(chain, omegas, force, C=C)
    truth = dense_receptance(parts.K.toarray(), np.diag(parts.M), C.toarray(), omegas, force)
    assert rel(ours.response, truth) <= 1e-12


def test_results_are_frozen() -> None:
    parts = R.system_matrices(vibra.System.generalized(np.eye(2), np.eye(2), G=J))
    with pytest.raises(dataclasses.FrozenInstanceError):
        parts.G = None  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        parts.M[0, 0] = 2.0
    motion = R.transient_response(np.eye(2), [1.0, 1.0], None, [0.0, 1.0], [0.0, 0.0], G=J, u0=[1.0, 0.0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        motion.method = "modal"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        motion.velocity[0, 0] = 1.0
    assert motion.method in R.TRANSIENT_METHODS


# ====================================================================== validation
K2, M2 = np.eye(2), [1.0, 1.0]


@pytest.mark.parametrize(
    ("call", "error", "pattern"),
    [
        (lambda: R.frequency_response(K2, M2, None, [1.0], [1.0, 0.0], G=np.eye(2)), ValueError,
         r"G is not skew-symmetric: \|G\[0,0\] \+ G\[0,0\]\| = 2 > atol=1e-10 .*its symmetric part belongs in C"),
        (lambda: R.frequency_response(K2, M2, None, [1.0], [1.0, 0.0], G=sp.csr_matrix([[0.0, 1.0], [1.0, 0.0]])),
         ValueError, r"G is not skew-symmetric: \|G\[0,1\] \+ G\[1,0\]\| = 2 > atol=1e-10"),
        (lambda: R.frequency_response(K2, M2, None, [1.0], [1.0, 0.0], G=J + [[0.0, 1e-9], [0.0, 0.0]]),
         ValueError, r"G is not skew-symmetric: \|G\[0,1\] \+ G\[1,0\]\| = 1e-09"),
        (lambda: R.frequency_response(K2, M2, None, [1.0], [1.0, 0.0], G=np.zeros((3, 3))), ValueError,
         r"G must be \(2, 2\) to match K, got shape \(3, 3\)"),
        (lambda: R.frf(K2, M2, None, [1.0], [1.0, 0.0], G=np.zeros((2, 3))), ValueError,
         r"G must be square, got shape \(2, 3\)"),
        (lambda: R.frf(K2, M2, None, [1.0], [1.0, 0.0], G=[[0.0, np.nan], [0.0, 0.0]]), ValueError,
         r"G\[0,1\] is .*nan.*must be finite"),
        (lambda: R.frf(K2, M2, None, [1.0], [1.0, 0.0], G="J"), TypeError, r"G must be an array of real numbers, got str"),
        (lambda: R.frequency_response(K2, M2, None, [1.0], [1.0, 0.0], G=J, method="modal"), ValueError,
         r"G is given, and method='modal' superposes real normal modes.*method='direct' or method='state_space'"),
        (lambda: R.transient_response(K2, M2, None, [1.0], [1.0, 0.0], G=np.eye(2)), ValueError,
         r"G is not skew-symmetric"),
        (lambda: R.transient_response(K2, M2, None, [1.0], [1.0, 0.0], G=J, n_modes=1), ValueError,
         r"n_modes is given with G: a gyroscopic system moves in state space with all 2 dofs"),
        (lambda: R.transient_response(K2, M2, None, [1.0], [1.0, 0.0], G=J, damping_ratios=0.1), ValueError,
         r"damping_ratios is given with G: .*\(give damping as C\)"),
        (lambda: R.transient_response(K2, M2, None, [1.0], [1.0, 0.0], G=J, modes=vibra.normal_modes(K2, M2)),
         ValueError, r"modes is given with G"),
        (lambda: R.transient_response(K2, M2, [[1.0, 2.0], [2.0, 1.0]], [1.0], [1.0, 0.0], G=J), ValueError,
         r"C is not positive semi-definite"),
        (lambda: R.system_matrices(np.eye(2)), TypeError, r"system must be a vibra.System, got ndarray"),
        (lambda: R.system_frequency_response(vibra.System.generalized(K2, K2), [1.0], [1.0, 0.0], G=J), TypeError,
         r"G is taken from the system; build the system with it"),
        (lambda: R.system_frequency_response(vibra.System.generalized(K2, K2), [1.0], [1.0, 0.0], units="SI"),
         TypeError, r"units is taken from the system"),
        (lambda: R.system_transient_response(vibra.System.generalized(K2, K2), [1.0], [1.0, 0.0], G=J), TypeError,
         r"G is taken from the system"),
        (lambda: R.system_frequency_response(vibra.System.generalized(K2, K2), [1.0], [1.0, 0.0], C=np.eye(3)),
         ValueError, r"C must be \(2, 2\) to match the system's 2 free dofs, got shape \(3, 3\)"),
        (lambda: R.system_transient_response(vibra.System.generalized(K2, K2, C=np.eye(2)), [1.0], [1.0, 0.0],
                                             C=-2.0 * np.eye(2)),
         ValueError, r"C\[0,0\] is .*-1\.0.*non-negative diagonal"),
    ],
)
def test_every_new_validation_message(call, error: type[Exception], pattern: str) -> None:
    with pytest.raises(error, match=pattern):
        call()


def test_a_dense_mass_matrix_too_large_for_the_state_space_path_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(state_space, "DENSE_MASS_MAX", 1)
    with pytest.raises(ValueError, match=r"the state-space transient with a dense mass matrix is dense "
                                         r"\(2 n_dof = 4\); it takes n_dof <= 1, or diagonal masses"):
        R.transient_response(K2, np.array([[2.0, 0.5], [0.5, 1.0]]), None, [1.0], [1.0, 0.0], G=J)
