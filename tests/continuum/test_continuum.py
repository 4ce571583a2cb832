"""Tests of vibra.continuum and vibra.charts.chains.

Oracles: scipy's dense eigensolver on matrices written out here, sympy derivatives of the
textbook dispersion relations, the small-angle expansion sin(x)/x = 1 - x^2/6 + ...
(seed 003 eqs. 162-165: c = Omega dx), and the leading-order dispersive error of a pulse
derived by hand from omega(q) = c q (1 - (q dx)^2 / 24 + ...).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg as la
import sympy
from helpers.images import check_png
from matplotlib.figure import Figure

from vibra import Modes, chains, continuum
from vibra.charts import chains as charts
from vibra.charts._style import save_figure

EPS = np.finfo(float).eps


def ring_matrix(k: np.ndarray) -> np.ndarray:
    n = k.size
    K = np.zeros((n, n))
    for i in range(n):
        j = (i + 1) % n
        K[i, i] += k[i]
        K[j, j] += k[i]
        K[i, j] -= k[i]
        K[j, i] -= k[i]
    return K


def dense_modes(K: np.ndarray, masses: np.ndarray) -> Modes:
    """A Modes built from scipy's eigh (independent of vibra's solvers)."""
    values, shapes = la.eigh(K, np.diag(masses))
    root = np.sqrt(masses)[:, None]
    return Modes(omega=np.sqrt(np.abs(values)), vectors=shapes * root, shapes=shapes, mass=masses,
                 omega_error=np.zeros_like(values), residual=0.0, orthogonality=0.0, solver="scipy")


# ---------------------------------------------------------------------- dispersion
def test_monatomic_dispersion_matches_ring_eigenvalues():
    n, m, k, dx = 12, 2.0, 3.0, 0.4
    omega = np.sqrt(np.abs(la.eigvalsh(ring_matrix(np.full(n, k)), np.diag(np.full(n, m)))))
    q = 2 * np.pi * np.arange(n) / (n * dx)
    curve = continuum.dispersion(q, masses=m, stiffness=k, spacing=dx)
    assert curve.shape == (1, n)
    np.testing.assert_allclose(np.sort(curve[0]) ** 2, omega**2, rtol=0, atol=1e-13 * 4 * k / m)


def test_diatomic_dispersion_matches_ring_eigenvalues():
    n_cells, masses, stiffness, dx = 9, (1.0, 2.5), (1.5, 0.5), 0.5
    K = ring_matrix(np.tile(stiffness, n_cells))
    omega = np.sqrt(np.abs(la.eigvalsh(K, np.diag(np.tile(masses, n_cells)))))
    q = 2 * np.pi * np.arange(n_cells) / (n_cells * 2 * dx)  # cell length 2 dx
    curve = continuum.dispersion(q, masses=masses, stiffness=stiffness, spacing=dx)
    assert curve.shape == (2, n_cells)
    np.testing.assert_allclose(np.sort(curve.ravel()) ** 2, omega**2, rtol=0, atol=1e-13 * 8)


def _sympy_group_velocity(masses, stiffness, dx, q_values, branch):
    q = sympy.Symbol("q", positive=True)
    if np.ndim(masses) == 0:
        omega = 2 * sympy.sqrt(sympy.nsimplify(stiffness) / sympy.nsimplify(masses)) * sympy.sin(q * dx / 2)
    else:
        m1, m2 = (sympy.nsimplify(v) for v in masses)
        k1, k2 = (sympy.nsimplify(v) for v in stiffness)
        a = 2 * sympy.nsimplify(dx)
        S = (k1 + k2) * (m1 + m2) / (m1 * m2)
        root = sympy.sqrt(S**2 / 4 - 4 * k1 * k2 * sympy.sin(q * a / 2) ** 2 / (m1 * m2))
        omega = sympy.sqrt(S / 2 + (root if branch == 1 else -root))
    derivative = sympy.lambdify(q, sympy.diff(omega, q), "mpmath")
    limit = sympy.limit(sympy.diff(omega, q), q, 0, "+")
    return np.array([float(limit) if v == 0 else float(derivative(v)) for v in q_values])


@pytest.mark.parametrize(("masses", "stiffness"), [(2.0, 3.0), ((1.0, 3.0), (2.0, 0.5))])
def test_group_velocity_against_sympy(masses, stiffness):
    dx = 0.5
    q = np.array([0.0, 0.3, 1.1, 2.0, 3.0])
    v = continuum.group_velocity(q, masses=masses, stiffness=stiffness, spacing=dx)
    for branch in range(v.shape[0]):
        expected = _sympy_group_velocity(masses, stiffness, dx, q, branch)
        # Closed-form derivative evaluated in double precision: 1e-12 relative to the sound speed.
        np.testing.assert_allclose(v[branch], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    if np.ndim(masses) == 0:
        assert v[0, 0] == pytest.approx(continuum.wave_speed(masses, stiffness, dx), rel=4 * EPS)


def test_band_edges_against_bloch_matrix_scan():
    masses, stiffness = (1.0, 4.0), (1.0, 2.5)
    m1, m2 = masses
    k1, k2 = stiffness
    values = []
    for theta in np.linspace(0.0, np.pi, 2001):  # includes 0 and pi, where the edges are
        h = (k1 + k2 * np.exp(-1j * theta)) / np.sqrt(m1 * m2)
        D = np.array([[(k1 + k2) / m1, -h], [-np.conj(h), (k1 + k2) / m2]])
        values.append(np.linalg.eigvalsh(D))
    omega = np.sqrt(np.clip(np.array(values), 0.0, None))
    expected = [[0.0, omega[:, 0].max()], [omega[:, 1].min(), omega[:, 1].max()]]
    edges = continuum.band_edges(masses=masses, stiffness=stiffness)
    np.testing.assert_allclose(edges, expected, rtol=1e-12, atol=1e-7)  # atol: sqrt of a ~1e-15 zero
    np.testing.assert_allclose(edges, chains.diatomic_band_edges(masses, stiffness), rtol=4 * EPS)
    np.testing.assert_allclose(continuum.band_edges(masses=2.0, stiffness=8.0), [[0.0, 4.0]], rtol=4 * EPS)


def test_gapless_diatomic_is_the_folded_monatomic_chain():
    # m1 = m2, k1 = k2: the "diatomic" branches are the monatomic omega = 2 Omega sin(q dx / 2)
    # and its fold 2 Omega cos(q dx / 2) (textbook), so v = +Omega dx cos(q dx / 2) and
    # -Omega dx sin(q dx / 2). At the zone boundary q = pi / (2 dx) the branches touch and
    # both the root and its derivative vanish: the left derivative is finite (not inf).
    m, k, dx = 2.0, 3.0, 0.5
    omega = np.sqrt(k / m)
    boundary = np.pi / (2 * dx)
    q = np.array([0.0, 0.3, 1.0, boundary * (1 - 1e-9), boundary])
    v = continuum.group_velocity(q, masses=(m, m), stiffness=(k, k), spacing=dx)
    # The radicand is formed without cancellation: a few ulps of Omega dx (1e-14 bound).
    np.testing.assert_allclose(v[0], omega * dx * np.cos(q * dx / 2), rtol=0, atol=1e-14 * omega * dx)
    np.testing.assert_allclose(v[1], -omega * dx * np.sin(q * dx / 2), rtol=0, atol=1e-14 * omega * dx)
    curves = continuum.dispersion(q[1:], masses=(m, m), stiffness=(k, k), spacing=dx)
    np.testing.assert_allclose(curves[0], 2 * omega * np.sin(q[1:] * dx / 2), rtol=1e-14)
    np.testing.assert_allclose(curves[1], 2 * omega * np.cos(q[1:] * dx / 2), rtol=1e-14)


def test_wave_speed_and_continuum_frequencies():
    # Eq. 164: c = Omega dx; for a beaded string of k = T / d: sqrt(T / mu), mu = m / d.
    assert continuum.wave_speed(0.5, 8.0, 0.1) == pytest.approx(0.4, rel=4 * EPS)
    T, m, d = 3.0, 0.02, 0.01
    assert continuum.wave_speed(m, T / d, d) == pytest.approx(np.sqrt(T / (m / d)), rel=4 * EPS)
    L, c = 2.0, 3.0
    np.testing.assert_allclose(continuum.continuum_frequencies(3, length=L, wave_speed=c, ends="free"),
                               np.array([0, 1, 2]) * np.pi * c / L, rtol=4 * EPS)
    np.testing.assert_allclose(continuum.continuum_frequencies(3, length=L, wave_speed=c, ends="fixed"),
                               np.array([1, 2, 3]) * np.pi * c / L, rtol=4 * EPS)
    np.testing.assert_allclose(continuum.continuum_frequencies(5, length=L, wave_speed=c, ends="periodic"),
                               np.array([0, 2, 2, 4, 4]) * np.pi * c / L, rtol=4 * EPS)
    assert continuum.continuum_length(10, 0.1, ends="fixed") == pytest.approx(1.1)
    assert continuum.continuum_length(10, 0.1, ends="free") == pytest.approx(1.0)


# ---------------------------------------------------------------------- wavenumber assignment
@pytest.mark.parametrize("ends", ["free", "fixed", "periodic"])
def test_assign_wavenumbers_puts_uniform_modes_on_the_dispersion_curve(ends):
    n, m, k, dx = 15, 1.0, 2.0, 0.3
    n_bonds = {"free": n - 1, "fixed": n + 1, "periodic": n}[ends]
    K = chains.linear_chain(n, stiffness=1.0, ends=ends).hessian().toarray() * k  # layout checked in test_chains
    modes = dense_modes(K, np.full(n, m))
    assert n_bonds > 0
    q_nodes = continuum.assign_wavenumbers(modes, ends=ends, spacing=dx)
    q_index = continuum.assign_wavenumbers(modes.omega, ends=ends, spacing=dx, n_sites=n)
    np.testing.assert_array_equal(q_nodes, q_index)  # Sturm: mode i has i nodes
    on_curve = continuum.dispersion(q_nodes, masses=m, stiffness=k, spacing=dx)[0]
    # For a uniform chain the standing-wave wavenumbers are exact: omega(q_k) = omega_k.
    np.testing.assert_allclose(on_curve**2, modes.omega**2, rtol=0, atol=1e-12 * 4 * k / m)


def test_assign_wavenumbers_diatomic_folds_into_the_zone():
    system = chains.diatomic_chain(30, masses=(1.0, 3.0), ends="free")
    modes = dense_modes(system.hessian().toarray(), system.masses)
    q = continuum.assign_wavenumbers(modes, ends="free", spacing=1.0, sites_per_cell=2)
    assert q.min() >= 0 and q.max() <= np.pi / 2 + 1e-12
    curves = continuum.dispersion(q, masses=(1.0, 3.0), stiffness=1.0, spacing=1.0)
    # Boundary effects of a free diatomic chain shift q by O(pi / L): branch values agree
    # within one level spacing of the curve at that q, except a surface mode in the gap.
    acoustic = modes.omega[:30]
    assert np.abs(acoustic - curves[0, :30]).max() < 0.05


# ---------------------------------------------------------------------- continuum limit
@pytest.mark.parametrize("ends", ["free", "fixed", "periodic"])
def test_convergence_order_is_measured_two(ends):
    study = continuum.convergence_study([1, 2, 3], [32, 64, 128, 256, 512, 1024], ends=ends, length=2.0,
                                        wave_speed=3.0)
    # The chain lies below the continuum (sin x < x) ...
    assert (study.errors < 0).all()
    # ... and the error falls as N^-2: fitted order within 0.01 of 2 (the x^4/120 term bends
    # the log-log line by < 0.5% over this range).
    np.testing.assert_allclose(study.order, 2.0, atol=0.01)
    # Coefficient against (k pi)^2 / 24 (periodic (2 k pi)^2 / 24): the next term of
    # sin(x)/x changes it by x^2 / 20, at most 0.5% (periodic, N = 32, k = 3: x = 0.29);
    # the log-log fit spreads that over the range -> rtol 2%.
    np.testing.assert_allclose(study.coefficient, study.expected_coefficient(), rtol=0.02)
    closed = continuum.convergence_study([1, 2, 3], [32, 64, 128, 256, 512, 1024], ends=ends, length=2.0,
                                         wave_speed=3.0, method="closed form")
    # Solved chains (accurate path / Fourier) and the closed form agree to 1e-12 relative.
    np.testing.assert_allclose(study.omega_chain, closed.omega_chain, rtol=1e-12)


def test_free_chain_error_coefficient_at_large_n():
    # At N = 10^5 the relative error of mode 1 is ~4e-11: measuring it needs omega to
    # ~1e-13 relative (the accurate solver path). Check N^2 |error| -> pi^2 / 24 within 1e-3
    # (the x^2/20 correction is 1e-11, the solver's ~1e-15 relative error adds 2.4e-5).
    study = continuum.convergence_study([1], [50_000, 100_000], ends="free")
    scaled = np.abs(study.errors[:, 0]) * study.n_sites**2
    np.testing.assert_allclose(scaled, np.pi**2 / 24, rtol=1e-3)
    n_needed = study.n_for_error(1e-6)
    # pi^2 / 24 / N^2 <= 1e-6 -> N >= 642 (from the measured fit, not the assumed formula).
    assert abs(int(n_needed[0]) - 642) <= 2


# ---------------------------------------------------------------------- pulses
def _leading_order_error(pulse: continuum.PulseResult, time: float) -> np.ndarray:
    """-(c t dx^2 / 24) f'''(x - c t) + (dx^2 / 48)(f''(x + c t) - f''(x - c t)) (periodic images)."""
    y = sympy.Symbol("y")
    f = sympy.exp(-y**2 / (2 * sympy.Float(pulse.width) ** 2))
    f2 = sympy.lambdify(y, sympy.diff(f, y, 2), "numpy")
    f3 = sympy.lambdify(y, sympy.diff(f, y, 3), "numpy")
    c, dx, L = pulse.wave_speed, pulse.spacing, pulse.length

    def wrap(v):
        return (v + L / 2) % L - L / 2

    right = wrap(pulse.x - c * time - pulse.center)
    left = wrap(pulse.x + c * time - pulse.center)
    return -(c * time * dx**2 / 24) * f3(right) + (dx**2 / 48) * (f2(left) - f2(right))


@pytest.mark.parametrize("n", [300, 600, 1200])
def test_pulse_error_matches_leading_order_dispersion(n):
    time = 0.4
    pulse = continuum.gaussian_pulse(n, [0.0, time], width=0.04, length=1.0, wave_speed=1.0)
    assert pulse.error[0] < 1e-14  # initial data sampled exactly
    difference = pulse.chain[1] - pulse.continuum[1]
    predicted = _leading_order_error(pulse, time)
    # Next terms are O(dx^2 / sigma^2) relative to the prediction (dx / sigma = 1/12 at
    # N = 300: ~1e-2; observed 1.6%), falling 4x per doubling of N: allow 3% * (300 / N)^2.
    tolerance = 0.03 * (300 / n) ** 2
    assert np.abs(difference - predicted).max() <= tolerance * np.abs(predicted).max()
    assert pulse.error[1] == pytest.approx(np.abs(difference).max(), rel=1e-12)


@pytest.mark.parametrize("ends", ["free", "fixed"])
def test_pulse_reflects_like_dalembert_at_the_ends(ends):
    # After one reflection (t = 1) the error is still the dispersive one of a periodic run
    # of the same travel time: within 1% (observed 0.3%; the images reproduce the end
    # condition exactly, the remaining difference is the O(dx^2) reflection of the ghost).
    times = [0.0, 1.0]
    walled = continuum.gaussian_pulse(800, times, width=0.04, ends=ends)
    ring = continuum.gaussian_pulse(800, times, width=0.04, ends="periodic")
    assert walled.error[0] < 1e-14
    assert walled.error[1] == pytest.approx(ring.error[1], rel=0.01)


def test_pulse_study_orders():
    study = continuum.pulse_study([200, 400, 800], [0.02, 0.04, 0.08], time=0.5)
    # Leading error ~ c t dx^2 f''' ~ t / (N^2 sigma^3): orders 2 in N and 3 in sigma,
    # up to the O(dx^2 / sigma^2) next term (<= 10% at the narrowest pulse) -> +-0.1.
    np.testing.assert_allclose(study.order_in_n, 2.0, atol=0.1)
    np.testing.assert_allclose(study.order_in_width, 3.0, atol=0.1)
    assert study.errors.shape == (3, 3)


# ---------------------------------------------------------------------- results are frozen
def test_results_are_immutable():
    study = continuum.convergence_study([1], [10, 20], method="closed form")
    pulse = continuum.gaussian_pulse(50, [0.0, 0.1], width=0.05)
    pulses = continuum.pulse_study([50, 100], [0.05, 0.1], time=0.1)
    for result, field in ((study, "errors"), (pulse, "chain"), (pulses, "errors")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(result, field, None)
        with pytest.raises(ValueError, match="read-only"):
            getattr(result, field)[0] = 1.0


# ---------------------------------------------------------------------- validation
def test_continuum_validation_messages():
    with pytest.raises(ValueError, match=r"modes\[1\] is 0; mode labels start at 1"):
        continuum.convergence_study([1, 0], [10, 20])
    with pytest.raises(ValueError, match=r"n_sites must be a 1-D sequence of at least two int sizes"):
        continuum.convergence_study([1], [10])
    with pytest.raises(ValueError, match=r"n_sites\[0\] is 3; it must be >= 5"):
        continuum.convergence_study([4], [3, 20])
    with pytest.raises(ValueError, match=r"modes must be a 1-D sequence of int"):
        continuum.convergence_study([1.5], [10, 20])
    with pytest.raises(ValueError, match=r"method is 'guess'"):
        continuum.convergence_study([1], [10, 20], method="guess")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"ends is 'open'"):
        continuum.convergence_study([1], [10, 20], ends="open")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"width is 0.2; it must be <= length / 10"):
        continuum.gaussian_pulse(100, [0.0], width=0.2)
    with pytest.raises(ValueError, match=r"times\[1\] is -1.0"):
        continuum.gaussian_pulse(100, [0.0, -1.0], width=0.05)
    with pytest.raises(ValueError, match=r"center is 2.0; it must lie in \[0, length\]"):
        continuum.gaussian_pulse(100, [0.0], width=0.05, center=2.0)
    with pytest.raises(ValueError, match=r"n_sites is 1"):
        continuum.gaussian_pulse(1, [0.0], width=0.05)
    with pytest.raises(ValueError, match=r"widths must hold at least two widths"):
        continuum.pulse_study([10, 20], [0.05], time=0.1)
    with pytest.raises(ValueError, match=r"masses must be one value or a pair"):
        continuum.dispersion(0.1, masses=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match=r"spacing is -1.0"):
        continuum.dispersion(0.1, spacing=-1.0)
    with pytest.raises(ValueError, match=r"n_sites is required when modes is an array"):
        continuum.assign_wavenumbers([0.0, 1.0])
    with pytest.raises(ValueError, match=r"sites_per_cell is 3"):
        continuum.assign_wavenumbers([0.0, 1.0], n_sites=2, sites_per_cell=3)
    with pytest.raises(ValueError, match=r"target is 0.0"):
        continuum.convergence_study([1], [10, 20], method="closed form").n_for_error(0.0)
    with pytest.raises(ValueError, match=r"length is 0.0"):
        continuum.continuum_frequencies(2, length=0.0)
    # Repeated or decreasing sizes and widths make the log-log fit meaningless.
    with pytest.raises(ValueError, match=r"n_sites\[1\] is 10 <= n_sites\[0\] = 20; sizes must increase"):
        continuum.convergence_study([1], [20, 10], method="closed form")
    with pytest.raises(ValueError, match=r"n_sites\[2\] is 40 <= n_sites\[1\] = 40"):
        continuum.pulse_study([20, 40, 40], [0.05, 0.1], time=0.1)
    with pytest.raises(ValueError, match=r"widths\[1\] is 0.05 <= widths\[0\] = 0.05; widths must increase"):
        continuum.pulse_study([20, 40], [0.05, 0.05], time=0.1)
    with pytest.raises(ValueError, match=r"time is 0.0; a comparison time must be positive"):
        continuum.pulse_study([20, 40], [0.05, 0.1], time=0.0)
    with pytest.raises(ValueError, match=r"^center is nan; it must be finite$"):
        continuum.gaussian_pulse(100, [0.0], width=0.05, center=float("nan"))


# ---------------------------------------------------------------------- dispersion curves, power-law fit
def test_dispersion_curves_over_the_zone_with_a_finite_chain():
    """Truth: omega = 2 sqrt(k/m) |sin(q dx / 2)|; a free chain's mode j sits at q = j pi / (N dx)."""
    system = chains.linear_chain(6, mass=2.0, stiffness=8.0, spacing=0.5)
    modes = dense_modes(system.hessian().toarray(), system.masses)
    curves = continuum.dispersion_curves(masses=2.0, stiffness=8.0, spacing=0.5, modes=modes, n_q=5)
    assert curves.n_branches == 1 and curves.gap == 0.0 and curves.n_sites == 6 and curves.ends == "free"
    assert curves.zone_edge == pytest.approx(np.pi / 0.5, rel=1e-15)
    np.testing.assert_allclose(curves.q, np.linspace(0.0, 2.0 * np.pi, 5), rtol=1e-15)
    np.testing.assert_allclose(curves.omega[0], 4.0 * np.abs(np.sin(curves.q * 0.25)), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(curves.band_edges, [[0.0, 4.0]], rtol=1e-15)
    np.testing.assert_allclose(curves.mode_wavenumbers, np.arange(6) * np.pi / 3.0, rtol=1e-14)
    # Each mode of the uniform chain lies on the infinite chain's branch (seed 003 eq. 161).
    # atol: eigh gives the zero mode's omega^2 to ~eps |K|, so its omega to ~sqrt(eps |K|) ~ 3e-8.
    np.testing.assert_allclose(curves.mode_omega, 4.0 * np.sin(curves.mode_wavenumbers * 0.25), atol=1e-7)
    assert curves.units == modes.units


def test_dispersion_curves_diatomic_gap():
    """Truth: zone-boundary frequencies sqrt(2k/m2) and sqrt(2k/m1) bound the gap (m1 < m2)."""
    curves = continuum.dispersion_curves(masses=(1.0, 3.0), stiffness=2.0, spacing=1.0, units="SI")
    assert curves.n_branches == 2 and curves.zone_edge == pytest.approx(np.pi / 2.0, rel=1e-15)
    assert curves.gap == pytest.approx(np.sqrt(4.0) - np.sqrt(4.0 / 3.0), rel=1e-14)
    assert curves.mode_wavenumbers is None and curves.mode_omega is None and curves.n_sites is None
    assert curves.units.name == "SI"
    with pytest.raises(dataclasses.FrozenInstanceError):
        curves.q = None  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        curves.omega[0, 0] = 1.0


def test_power_law_fit_recovers_an_exact_power_law():
    x = np.array([10.0, 20.0, 40.0, 80.0])
    order, coefficient = continuum.power_law_fit(x, -0.7 * x ** -2.5)  # the sign is ignored
    assert order == pytest.approx(2.5, rel=1e-12) and coefficient == pytest.approx(0.7, rel=1e-12)


def test_dispersion_curves_and_power_law_fit_validation():
    with pytest.raises(TypeError, match=r"^modes must be a vibra.Modes, got list$"):
        continuum.dispersion_curves(modes=[1.0, 2.0])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^n_q is 1; expected 2 <= n_q"):
        continuum.dispersion_curves(n_q=1)
    with pytest.raises(TypeError, match=r"^n_q must be an int, got float$"):
        continuum.dispersion_curves(n_q=10.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^ends is 'open'"):
        continuum.dispersion_curves(ends="open")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^x and errors must be two 1-D arrays of the same length >= 2"):
        continuum.power_law_fit([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match=r"^errors\[1\] is 0.0; a power law needs non-zero errors$"):
        continuum.power_law_fit([1.0, 2.0], [1.0, 0.0])
    with pytest.raises(ValueError, match=r"^x holds one value only; a fit needs two distinct abscissae$"):
        continuum.power_law_fit([2.0, 2.0], [1.0, 0.5])
    with pytest.raises(ValueError, match=r"^x\[0\] is -1.0; every abscissa must be positive"):
        continuum.power_law_fit([-1.0, 2.0], [1.0, 0.5])
    with pytest.raises(TypeError, match=r"^n_modes must be an int, got float$"):
        continuum.continuum_frequencies(1.5)  # type: ignore[arg-type]


# ---------------------------------------------------------------------- charts
def _check_png(fig: Figure, path) -> None:
    save_figure(fig, path)
    check_png(path, least=(300, 500))


def test_charts_render(tmp_path):
    system = chains.diatomic_chain(8, masses=(1.0, 3.0), ends="free")
    modes = dense_modes(system.hessian().toarray(), system.masses)
    fig = charts.plot_dispersion(continuum.dispersion_curves(masses=(1.0, 3.0), modes=modes, ends="free", units="SI"))
    assert "π/a" in fig.axes[0].get_xlabel() and "rad/s" in fig.axes[0].get_ylabel()
    edge = [t.get_text() for t in fig.axes[0].get_legend().get_texts() if "zone edge" in t.get_text()]
    assert edge and "rad/m" in edge[0]  # the zone edge pi/a, marked with its value
    assert fig.axes[0].lines[-1].get_xdata()[0] == 1.0  # ... at q = pi/a, the axis' unit
    _check_png(fig, tmp_path / "dispersion.png")
    study = continuum.convergence_study([1, 2], [10, 20, 40], method="closed form")
    _check_png(charts.plot_convergence(study), tmp_path / "convergence.png")
    _check_png(charts.plot_chain_mode_shapes(system, modes, [0, 1, 15]), tmp_path / "shapes.png")
    pulse = continuum.gaussian_pulse(200, np.linspace(0.0, 0.5, 26), width=0.03)
    fig = charts.plot_pulse_spacetime(pulse)
    assert fig.axes[0].get_xlabel().startswith("position x")
    _check_png(fig, tmp_path / "pulse.png")


def test_chart_input_errors():
    with pytest.raises(TypeError, match="study must be a ConvergenceStudy"):
        charts.plot_convergence("study")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="pulse must be a PulseResult"):
        charts.plot_pulse_spacetime(None)  # type: ignore[arg-type]
    system = chains.linear_chain(4)
    modes = dense_modes(system.hessian().toarray(), system.masses)
    with pytest.raises(ValueError, match=r"indices\[1\] is 9"):
        charts.plot_chain_mode_shapes(system, modes, [0, 9])
