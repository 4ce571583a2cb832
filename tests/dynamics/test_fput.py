"""Tests of the FPUT chain (`vibra.dynamics.fput`) and the energy per normal mode.

Truth: FPUT's equations of motion written out here with numpy; the chain's closed-form
frequencies omega_k = 2 sqrt(k / m) sin(k pi / (2 (n + 1))) (fixed ends, seed 003 §5.3); each
scheme's order measured by halving dt; the harmonic limit (no energy moves between modes);
and the recurrence time of Tuck and Menzel (1972).
"""

from __future__ import annotations

import numpy as np
import pytest

from vibra import dynamics


def fput_force(u: np.ndarray, alpha: float, beta: float, ends: str) -> np.ndarray:
    """FPUT's m u_i'' for unit masses and springs, written out (walls at rest for fixed ends)."""
    if ends == "fixed":
        padded = np.concatenate([[0.0], u, [0.0]])
        d = np.diff(padded)                                # n + 1 bonds
    else:
        d = np.roll(u, -1) - u                             # bond i: u_{i+1} - u_i, ring closed
        padded = None
    tension = d + alpha * d**2 + beta * d**3
    if padded is not None:
        return tension[1:] - tension[:-1]
    return tension - np.roll(tension, 1)


@pytest.mark.parametrize("ends", ["fixed", "periodic"])
@pytest.mark.parametrize(("alpha", "beta"), [(0.25, 0.0), (0.0, 1.5), (0.3, -0.2)])
def test_fput_forces_are_fputs_equations(ends: str, alpha: float, beta: float) -> None:
    system, forces = dynamics.fput(9, alpha=alpha, beta=beta, ends=ends)
    u = np.random.default_rng(3).normal(scale=0.3, size=9)
    total = -(system.hessian() @ u) + forces(u)
    assert np.allclose(total, fput_force(u, alpha, beta, ends), rtol=0, atol=1e-14)
    # the anharmonic potential's gradient is minus the force (central differences)
    h = 1e-6
    gradient = np.array([(forces.potential(u + h * e) - forces.potential(u - h * e)) / (2 * h) for e in np.eye(9)])
    assert np.allclose(gradient, -forces(u), atol=1e-8)


def test_fput_harmonic_part_has_the_chains_closed_form_frequencies() -> None:
    system, _ = dynamics.fput(32, alpha=0.25)
    k = np.arange(1, 33)
    assert np.allclose(system.modes().omega, 2 * np.sin(k * np.pi / 66), rtol=1e-12)
    assert system.units.name == "dimensionless"


def _energy_error(integrator: str, dt: float, ends: str = "fixed") -> float:
    system, forces = dynamics.fput(32, alpha=0.25, beta=0.1, ends=ends)
    x0 = np.sin(np.pi * np.arange(1, 33) / 33) if ends == "fixed" else 0.5 * np.sin(2 * np.pi * np.arange(32) / 32)
    run = dynamics.integrate(system, x0, np.zeros(32), dt, int(round(200 / dt)), forces=forces, integrator=integrator)
    return float(np.max(np.abs(run.energy / run.energy[0] - 1.0)))


@pytest.mark.parametrize(("integrator", "order", "dt"), [("verlet", 2, 0.2), ("yoshida4", 4, 0.2),
                                                          ("blanes-moan", 4, 0.8)])
@pytest.mark.parametrize("ends", ["fixed", "periodic"])
def test_energy_error_falls_with_each_schemes_order(integrator: str, order: int, dt: float, ends: str) -> None:
    # Max |H(t) - H(0)| / H(0) over t in [0, 200]: a symplectic scheme's error is bounded and
    # goes as dt^order (measured ratios at these steps: 4.00, 16.0, 16.0).
    coarse, fine = _energy_error(integrator, dt, ends), _energy_error(integrator, dt / 2, ends)
    assert 2 ** order * 0.85 < coarse / fine < 2 ** order * 1.2, (coarse, fine)


def test_blanes_moan_beats_the_triple_jump_at_equal_work() -> None:
    # 6 forces a step against 3: blanes-moan at 2 dt costs what yoshida4 does at dt.
    assert _energy_error("blanes-moan", 0.2) < _energy_error("yoshida4", 0.1) / 100


def test_harmonic_limit_moves_no_energy_between_modes_over_a_million_steps() -> None:
    # alpha = beta = 0: velocity Verlet advances each normal mode on its own (it commutes with
    # the modal transform), so E_k keeps only its O((omega_k dt)^2) oscillation, and Verlet's
    # invariant of q'' = -omega^2 q, E_k - omega_k^2 (omega_k dt / 2)^2 q_k^2 / 2, holds to rounding.
    system, forces = dynamics.fput(32)
    modes = system.modes()
    rng = np.random.default_rng(1)
    x0 = modes.shapes[:, :8] @ rng.normal(scale=0.1, size=8)
    dt = 0.1
    run = dynamics.integrate(system, x0, np.zeros(32), dt, 10**6, forces=forces, record_every=997)
    energy = run.mode_energies(modes)
    scale = energy[0].sum()
    q = run.positions @ modes.vectors                  # unit masses: q = D^T M^1/2 u (eq. 149)
    shadow = energy - 0.5 * modes.omega**2 * (modes.omega * dt / 2) ** 2 * q**2
    assert np.max(np.abs(shadow - shadow[0])) < 1e-12 * scale           # no drift over t = 1e5
    band = np.ptp(energy, axis=0)
    assert np.all(band <= (modes.omega * dt) ** 2 / 4 * np.max(energy, axis=0) * 1.01 + 1e-14 * scale)
    assert np.max(energy[:, 8:]) < 1e-12 * scale                          # modes 9..32 never excited


# Tuck and Menzel (1972), "The superperiod of the nonlinear weighted string (FPU) problem",
# Adv. Math. 9, 399: the first recurrence of the alpha chain started in mode 1 with amplitude a,
# N intervals, follows T_R ~= 0.38 N^(3/2) (a alpha)^(-1/2) T_1 (equivalently 0.38 N^(5/2)
# (a alpha)^(-1/2) time units with T_1 ~= 2N), an empirical fit over their runs. (The paper was
# out of reach of this session's search; the constant is the one quoted with their name in
# secondary sources, e.g. the public FPUT code lucnico/fput, FPUT_KAM.c.) FPUT's case: N = 32
# intervals (31 moving masses), alpha = 1/4, a = 1: 137.6 T_1. Tolerance 12 %: the law is a fit
# over N and a, and the recurrence instant (the peak of E_1) sits in a slowly varying envelope;
# measured here 146.7 T_1 (+6.6 %), the same with blanes-moan at dt = 0.1 (the integration is
# converged). Over N = 16, 32, 64 and a = 1, 2 the measured constant is 0.399 - 0.410: the
# exponents of the law hold to 3 % (test below), only its constant differs by ~7 %.
TUCK_MENZEL = 0.38


@pytest.mark.parametrize(("integrator", "dt"), [("verlet", 0.05), ("blanes-moan", 0.1)])
def test_alpha_fput_recurrence_against_tuck_and_menzel(integrator: str, dt: float) -> None:
    n_intervals, alpha, amplitude = 32, 0.25, 1.0
    system, forces = dynamics.fput(n_intervals - 1, alpha=alpha)
    modes = system.modes()
    x0 = amplitude * np.sin(np.pi * np.arange(1, n_intervals) / n_intervals)
    period = 2 * np.pi / modes.omega[0]
    every = int(round(1.0 / dt))
    run = dynamics.integrate(system, x0, np.zeros(n_intervals - 1), dt, int(200 * period / dt), forces=forces,
                             integrator=integrator, record_every=every)
    e1 = run.mode_energies(modes)[:, 0] / run.mode_energies(modes)[0].sum()
    gone = int(np.argmax(e1 < 0.5))                   # energy leaves mode 1 ...
    back = gone + int(np.argmax(e1[gone:] > 0.8))     # ... and comes back
    leave = back + int(np.argmax(e1[back:] < 0.5))
    peak = back + int(np.argmax(e1[back:leave]))
    measured = run.t[peak] / period
    published = TUCK_MENZEL * n_intervals**1.5 / np.sqrt(amplitude * alpha)
    assert abs(measured / published - 1.0) < 0.12, (measured, published)
    assert e1[peak] > 0.97 and e1[:peak].min() < 0.1  # a near-complete return after a deep exchange


def _recurrence_periods(n_intervals: int, amplitude: float, alpha: float = 0.25) -> float:
    system, forces = dynamics.fput(n_intervals - 1, alpha=alpha)
    modes = system.modes()
    period = 2 * np.pi / modes.omega[0]
    x0 = amplitude * np.sin(np.pi * np.arange(1, n_intervals) / n_intervals)
    run = dynamics.integrate(system, x0, np.zeros(n_intervals - 1), 0.05, int(0.6 * n_intervals**1.5 / np.sqrt(
        amplitude * alpha) * period / 0.05), forces=forces, record_every=20)
    energy = run.mode_energies(modes)
    e1 = energy[:, 0] / energy[0].sum()
    gone = int(np.argmax(e1 < 0.5))
    back = gone + int(np.argmax(e1[gone:] > 0.8))
    leave = back + int(np.argmax(e1[back:] < 0.5))
    return float(run.t[back + int(np.argmax(e1[back:leave]))] / period)


def test_recurrence_time_scales_as_tuck_and_menzels_law() -> None:
    # T_R / T_1 proportional to N^(3/2) (a alpha)^(-1/2): the constant is the same to 3 % over N and a.
    constants = [_recurrence_periods(n, a) * np.sqrt(a * 0.25) / n**1.5 for n, a in ((16, 1.0), (32, 1.0), (32, 2.0))]
    assert max(constants) / min(constants) < 1.03, constants


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"ends": "open"}, ValueError, r"ends is 'open'; expected one of 'free', 'fixed', 'periodic'"),
    ({"n": 1}, ValueError, r"n is 1; an FPUT chain needs n >= 2"),
    ({"alpha": float("nan")}, ValueError, r"alpha is nan; it must be finite"),
    ({"beta": "big"}, TypeError, r"beta must be a real number"),
    ({"mass": 0.0}, ValueError, r"mass is 0.0; a mass must be positive"),
])
def test_bad_fput_arguments(kwargs: dict, error: type, match: str) -> None:
    arguments = {"n": 8, **kwargs}
    with pytest.raises(error, match=match):
        dynamics.fput(**arguments)


def test_fput_forces_wrong_size_is_refused_by_integrate() -> None:
    system, _ = dynamics.fput(8)
    _, other = dynamics.fput(9, alpha=0.1)
    with pytest.raises(ValueError, match=r"forces\(x0\) returned shape \(9,\); expected \(8,\)"):
        dynamics.integrate(system, np.zeros(8), np.zeros(8), 0.1, 10, forces=other)
