"""Tests of `vibra.dynamics`: integrate, the schemes, the isokinetic and Nosé-Hoover thermostats.

Truth from outside the code under test: scipy's DOP853 at rtol 1e-13 on the same equations of
motion written out here; the seed's closed form of the isokinetic friction (003 §4.2, example 10,
mu = -K (r . r') / (3 k_B T)); invariants (the constrained kinetic energy, the extended energy of
a Nosé-Hoover chain, each scheme's order measured by halving dt); the harmonic oscillator's
stability bound omega dt < 2 for velocity Verlet; and the Boltzmann distribution (a
Kolmogorov-Smirnov test, scipy.stats).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import constants, stats
from scipy.integrate import solve_ivp

from vibra import System
from vibra import dynamics
from vibra.chains import linear_chain
from vibra.units import ASE, SI

MASS, SPRING, TEMPERATURE = 2.0, 3.0, 0.5          # the 3-D isokinetic oscillator (dimensionless, k_B = 1)


def oscillator_3d() -> System:
    return System.from_hessian([[0.0, 0.0, 0.0]], MASS, SPRING * np.eye(3), units="dimensionless")


def oscillator_1d() -> System:
    return System.from_hessian([0.0], 1.0, [[1.0]], units="dimensionless")


X0 = np.array([0.3, -0.2, 0.1])
V0 = np.array([0.1, 0.4, -0.3])


# ---------------------------------------------------------------------- isokinetic (Gauss) thermostat
def test_isokinetic_keeps_the_kinetic_energy_over_a_million_steps() -> None:
    run = dynamics.integrate(oscillator_3d(), X0, V0, 0.01, 10**6, thermostat=dynamics.Isokinetic(TEMPERATURE),
                             record_every=1000)
    target = 1.5 * TEMPERATURE                       # m |r'|^2 / 2 = 3 k_B T / 2 (seed, example 10)
    assert np.max(np.abs(run.kinetic / target - 1.0)) < 1e-12
    assert np.array_equal(run.conserved, run.kinetic)
    assert np.ptp(run.potential) > 0.1               # not frozen: the position moves


def test_isokinetic_friction_is_the_seeds_closed_form_at_every_step() -> None:
    run = dynamics.integrate(oscillator_3d(), X0, V0, 0.01, 5000, thermostat=dynamics.Isokinetic(TEMPERATURE))
    seed = -SPRING * np.sum(run.positions * run.velocities, axis=1) / (3.0 * TEMPERATURE)
    assert run.thermostat_labels == ("mu",)
    assert np.max(np.abs(run.state("mu") - seed)) < 1e-13 * np.max(np.abs(seed)) * 10
    assert run.state("mu").min() < 0 < run.state("mu").max()   # it brakes and it pushes (seed)


def _isokinetic_reference(t: np.ndarray, v_start: np.ndarray) -> np.ndarray:
    def rhs(_: float, y: np.ndarray) -> np.ndarray:
        x, v = y[:3], y[3:]
        force = -SPRING * x
        mu = force @ v / (MASS * v @ v)
        return np.concatenate([v, force / MASS - mu * v])

    sol = solve_ivp(rhs, (0.0, t[-1]), np.concatenate([X0, v_start]), method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=t)
    return sol.y[:3].T


@pytest.mark.parametrize(("integrator", "order", "dt"), [("verlet", 2, 0.004), ("yoshida4", 4, 0.02),
                                                          ("blanes-moan", 4, 0.05)])
def test_isokinetic_trajectory_follows_dop853_at_the_schemes_order(integrator: str, order: int, dt: float) -> None:
    v_start = V0 * np.sqrt(3 * TEMPERATURE / (MASS * V0 @ V0))   # integrate scales v0 to the temperature
    errors = []
    for step in (dt, dt / 2):
        run = dynamics.integrate(oscillator_3d(), X0, V0, step, int(round(5.0 / step)), integrator=integrator,
                                 thermostat=dynamics.Isokinetic(TEMPERATURE), record_every=int(round(0.5 / step)))
        assert np.allclose(run.velocities[0], v_start, rtol=1e-14)
        errors.append(np.max(np.abs(run.positions - _isokinetic_reference(run.t, v_start))))
    assert errors[0] < 1e-5
    assert 2 ** order * 0.8 < errors[0] / errors[1] < 2 ** order * 1.25


# ---------------------------------------------------------------------- Nosé-Hoover
def _nose_hoover_reference(t: np.ndarray, chain: int, x0: float, v0: float) -> np.ndarray:
    """DOP853 on Martyna-Klein-Tuckerman's equations, 1-D oscillator, m = k = k_B T = tau = 1."""
    Q = np.ones(chain)

    def rhs(_: float, y: np.ndarray) -> np.ndarray:
        x, v, xi = y[0], y[1], y[2:2 + chain]
        dxi = np.empty(chain)
        for j in range(chain):
            g = (v * v - 1.0) / Q[0] if j == 0 else (Q[j - 1] * xi[j - 1] ** 2 - 1.0) / Q[j]
            dxi[j] = g - (xi[j] * xi[j + 1] if j < chain - 1 else 0.0)
        return np.concatenate([[v, -x - xi[0] * v], dxi, xi])

    y0 = np.concatenate([[x0, v0], np.zeros(2 * chain)])
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t)
    return sol.y.T


@pytest.mark.parametrize(("integrator", "order"), [("verlet", 2), ("yoshida4", 4)])
def test_nose_hoover_chain_follows_dop853_at_the_schemes_order(integrator: str, order: int) -> None:
    errors = []
    for dt in (0.02, 0.01):
        run = dynamics.integrate(oscillator_1d(), [1.0], [0.5], dt, int(round(10 / dt)), integrator=integrator,
                                 thermostat=dynamics.NoseHoover(1.0, 1.0, chain=3), record_every=int(round(1 / dt)))
        reference = _nose_hoover_reference(run.t, 3, 1.0, 0.5)
        mine = np.column_stack([run.positions[:, 0], run.velocities[:, 0], run.thermostat_state])
        errors.append(np.max(np.abs(mine - reference)))
    assert errors[0] < 1e-3
    assert 2 ** order * 0.8 < errors[0] / errors[1] < 2 ** order * 1.25


@pytest.mark.parametrize("chain", [1, 4])
def test_nose_hoover_extended_energy_is_conserved_to_second_order(chain: int) -> None:
    # Over a fixed span (t = 50): the extended energy's error falls 4x when dt halves.
    spreads = []
    for dt in (0.04, 0.02):
        run = dynamics.integrate(oscillator_1d(), [1.0], [0.5], dt, int(round(50 / dt)),
                                 thermostat=dynamics.NoseHoover(1.0, 1.0, chain=chain))
        spreads.append(np.max(np.abs(run.conserved - run.conserved[0])))
        assert np.ptp(run.energy) > 0.1              # the physical energy itself moves
    assert spreads[0] < 1e-2
    assert 3.2 < spreads[0] / spreads[1] < 5.0
    assert run.thermostat_labels == tuple(f"xi{j + 1}" for j in range(chain)) + tuple(f"eta{j + 1}" for j in range(chain))


# One Nosé-Hoover thermostat on one 1-D harmonic oscillator is not ergodic (Hoover, Phys. Rev. A
# 31, 1695 (1985)); a chain of 4 is (Martyna, Klein and Tuckerman 1992). Run length and thinning:
# 2e6 steps of dt = 0.05 (t = 1e5, about 16,000 periods, ~1 s compiled), positions every 10 time
# units (1.6 periods, beyond the chain's correlation time), n = 10^4 samples. Measured over 8
# random starts each: one thermostat gives sqrt(n) D >= 2.6 (p <= 2e-6; the tori and the chaotic
# sea alike miss the Gaussian, D ~ 0.03 - 0.4), the chain sqrt(n) D <= 1.02 (p >= 0.25). The
# thresholds below (p < 1e-4, p > 0.01) sit a factor 20+ inside both, so the verdict does not
# depend on the machine's rounding (a chaotic trajectory differs, its statistics do not).
KS_STEPS, KS_DT, KS_EVERY = 2 * 10**6, 0.05, 200


@pytest.mark.parametrize("start", [(0.0, 1.0), (-1.3, 0.4)])
def test_one_nose_hoover_thermostat_is_not_ergodic_on_an_oscillator(start: tuple[float, float]) -> None:
    run = dynamics.integrate(oscillator_1d(), [start[0]], [start[1]], KS_DT, KS_STEPS,
                             thermostat=dynamics.NoseHoover(1.0, 1.0, chain=1), record_every=KS_EVERY)
    result = stats.kstest(run.positions[1:, 0], "norm")          # Boltzmann: x ~ N(0, k_B T / k) = N(0, 1)
    assert result.pvalue < 1e-4, result


def test_a_nose_hoover_chain_samples_the_boltzmann_gaussian() -> None:
    run = dynamics.integrate(oscillator_1d(), [0.0], [1.0], KS_DT, KS_STEPS,
                             thermostat=dynamics.NoseHoover(1.0, 1.0, chain=4), record_every=KS_EVERY)
    result = stats.kstest(run.positions[1:, 0], "norm")
    assert result.pvalue > 0.01, result
    assert abs(np.mean(run.velocities[1:, 0] ** 2) - 1.0) < 0.05      # <m v^2> = k_B T


def test_temperatures_use_the_systems_boltzmann_constant() -> None:
    assert SI.boltzmann == constants.k and ASE.boltzmann == pytest.approx(constants.k / constants.e, rel=1e-15)
    chain = linear_chain(3, mass=1e-26, stiffness=1.0, ends="fixed")              # SI: kg, N/m, kelvin
    run = dynamics.integrate(chain, np.zeros(3), [1.0, 0.0, 0.0], 1e-14, 10, thermostat=dynamics.Isokinetic(300.0))
    assert run.kinetic[0] == pytest.approx(1.5 * constants.k * 300.0, rel=1e-14)


# ---------------------------------------------------------------------- schemes and the result
@pytest.mark.parametrize("integrator", dynamics.INTEGRATORS)
def test_stability_bound_is_the_harmonic_oscillators(integrator: str) -> None:
    limit = dynamics.STABLE_OMEGA_DT[integrator]
    if integrator == "verlet":
        assert limit == pytest.approx(2.0, rel=1e-12)     # |1 - (omega dt)^2 / 2| < 1
    for factor, bounded in ((0.99, True), (1.01, False)):
        # just inside: bounded; just outside: refused by integrate (checked below), and it grows
        step = factor * limit
        system = oscillator_1d()
        if bounded:
            run = dynamics.integrate(system, [1.0], [0.0], step, 20000, integrator=integrator, record_every=100)
            assert np.max(np.abs(run.positions)) < 1e3
        else:
            with pytest.raises(ValueError, match=r"dt is .* unstable .* omega_max = 1\b"):
                dynamics.integrate(system, [1.0], [0.0], step, 10, integrator=integrator)


def test_harmonic_energy_is_exact_for_normal_coordinates() -> None:
    # Verlet on a harmonic chain: each mode's energy stays within its O((omega dt)^2) band.
    chain = linear_chain(6, ends="fixed", units="dimensionless")
    modes = chain.modes()
    x0 = modes.shapes[:, 1] * 0.1 + modes.shapes[:, 4] * 0.05
    run = dynamics.integrate(chain, x0, np.zeros(6), 0.01, 20000, record_every=10)
    energy = run.mode_energies(modes)
    assert np.allclose(energy.sum(axis=1), run.energy, rtol=1e-12)
    spread = np.ptp(energy, axis=0) / np.max(energy.sum(axis=1))
    assert np.all(spread < (modes.omega * 0.01) ** 2)
    assert np.all(energy[:, [0, 2, 3, 5]] < 1e-25)


def test_trajectory_is_frozen() -> None:
    run = dynamics.integrate(oscillator_1d(), [1.0], [0.0], 0.1, 10)
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.dt = 1.0  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        run.positions[0, 0] = 1.0
    assert repr(run).startswith("Trajectory(11 records of 1 dof to t = 1, dt = 0.1, compiled, path 'verlet'")


def test_python_forces_run_the_same_steps_as_the_compiled_loop() -> None:
    system, bonds = dynamics.fput(8, alpha=0.3, beta=0.2, ends="periodic")
    x0 = np.linspace(-0.2, 0.3, 8)
    x0 -= x0.mean()

    def plain(u: np.ndarray) -> np.ndarray:
        return bonds(u)

    for thermostat in (None, dynamics.Isokinetic(0.01), dynamics.NoseHoover(0.01, 2.0, chain=2)):
        v0 = np.linspace(0.1, -0.1, 8)
        compiled = dynamics.integrate(system, x0, v0, 0.05, 200, forces=bonds, thermostat=thermostat, record_every=20)
        python = dynamics.integrate(system, x0, v0, 0.05, 200, forces=plain, thermostat=thermostat, record_every=20)
        assert compiled.compiled and not python.compiled
        assert np.allclose(compiled.positions, python.positions, rtol=0, atol=1e-12)
        assert np.all(np.isnan(python.potential)) and np.all(np.isfinite(compiled.potential))


# ---------------------------------------------------------------------- bad input: one line each, naming it
@pytest.mark.parametrize(("make", "match"), [
    (lambda: dynamics.Isokinetic(0.0), r"temperature is 0.0; a temperature must be positive"),
    (lambda: dynamics.Isokinetic(float("nan")), r"temperature is nan; it must be finite"),
    (lambda: dynamics.NoseHoover(-1.0, 1.0), r"temperature is -1.0"),
    (lambda: dynamics.NoseHoover(1.0, 0.0), r"tau is 0.0"),
    (lambda: dynamics.NoseHoover(1.0, 1.0, chain=0), r"chain is 0; expected 1 <= chain <= 64"),
])
def test_bad_thermostats(make, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()


def _call(**changes):
    arguments = {"system": oscillator_3d(), "x0": X0, "v0": V0, "dt": 0.01, "n_steps": 10}
    arguments.update(changes)
    return dynamics.integrate(arguments.pop("system"), arguments.pop("x0"), arguments.pop("v0"),
                              arguments.pop("dt"), arguments.pop("n_steps"), **arguments)


@pytest.mark.parametrize(("changes", "error", "match"), [
    ({"v0": np.zeros(3), "thermostat": dynamics.Isokinetic(1.0)}, ValueError,
     r"v0 is zero; the isokinetic constraint needs a nonzero initial velocity"),
    ({"dt": 2.0}, ValueError,
     r"dt is 2, unstable for the highest normal frequency omega_max = 1\.22474: verlet is stable for "
     r"dt < 2 / omega_max = 1\.63299"),
    ({"dt": 1.5, "integrator": "yoshida4"}, ValueError, r"yoshida4 is stable for dt < 1\.573 / omega_max"),
    ({"forces": lambda u: np.zeros(2)}, ValueError,
     r"forces\(x0\) returned shape \(2,\); expected \(3,\), one force per free dof"),
    ({"forces": lambda u: np.full(3, np.nan)}, ValueError, r"forces\(x0\) returned non-finite"),
    ({"forces": np.zeros(3)}, TypeError, r"forces must be a callable"),
    ({"integrator": "rk4"}, ValueError, r"integrator is 'rk4'; expected one of 'verlet', 'yoshida4', 'blanes-moan'"),
    ({"integrator": "blanes-moan", "thermostat": dynamics.NoseHoover(1.0, 1.0)}, ValueError,
     r"integrator is 'blanes-moan', which splits two flows only"),
    ({"thermostat": "nose-hoover"}, TypeError, r"thermostat must be dynamics.Isokinetic"),
    ({"x0": np.zeros(2)}, ValueError, r"x0 has shape \(2,\); expected \(3,\)"),
    ({"v0": [0.0, np.nan, 0.0]}, ValueError, r"v0\[1\]"),
    ({"dt": 0.0}, ValueError, r"dt is 0.0; a time step must be positive"),
    ({"n_steps": 0}, ValueError, r"n_steps is 0"),
    ({"record_every": 0}, ValueError, r"record_every is 0"),
    ({"n_steps": 10**9, "record_every": 1}, ValueError, r"recording 1000000001 states .* raise record_every"),
    ({"system": System.generalized(np.eye(2), np.eye(2))}, TypeError, r"system must be a vibra.System"),
])
def test_bad_integrate_arguments(changes: dict, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        _call(**changes)


def test_mode_energies_refuses_modes_of_another_system() -> None:
    run = dynamics.integrate(oscillator_3d(), X0, V0, 0.01, 10)
    with pytest.raises(ValueError, match=r"modes has 4 dofs; this trajectory has 3"):
        run.mode_energies(linear_chain(4, units="dimensionless").modes())
    with pytest.raises(ValueError, match=r"modes.mass differs"):
        run.mode_energies(System.from_hessian([[0.0, 0.0, 0.0]], 1.0, np.eye(3), units="dimensionless").modes())
    with pytest.raises(ValueError, match=r"modes has no vectors"):
        run.mode_energies(oscillator_3d().modes(vectors=False))
    with pytest.raises(TypeError, match=r"modes must be a vibra.Modes"):
        run.mode_energies(np.eye(3))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"label is 'mu'; this trajectory's thermostat variables are \[\]"):
        run.state("mu")


def test_thermostats_and_bond_forces_are_frozen() -> None:
    _, bonds = dynamics.fput(4, alpha=0.1)
    for value, field in ((dynamics.Isokinetic(1.0), "temperature"), (dynamics.NoseHoover(1.0, 1.0), "tau"),
                         (bonds, "n_dof")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, field, 2)
    with pytest.raises(ValueError, match="read-only"):
        bonds.alpha[0] = 1.0


def test_a_force_object_with_a_potential_conserves_its_energy_in_the_python_loop() -> None:
    class Quartic:
        """An on-site quartic potential beta u^4 / 4 on every dof (not a bond: runs in Python)."""

        def __call__(self, u: np.ndarray) -> np.ndarray:
            return -0.5 * u**3

        def potential(self, u: np.ndarray) -> float:
            return float(np.sum(0.5 * u**4 / 4))

    chain = linear_chain(5, ends="fixed", units="dimensionless")
    errors = []
    for dt in (0.02, 0.01):
        run = dynamics.integrate(chain, [0.5, -0.3, 0.8, 0.0, -0.6], np.zeros(5), dt, int(round(20 / dt)),
                                 forces=Quartic())
        assert not run.compiled and np.all(np.isfinite(run.potential))
        errors.append(np.max(np.abs(run.energy / run.energy[0] - 1)))
    assert errors[0] < 1e-3 and 3.5 < errors[0] / errors[1] < 4.5     # velocity Verlet: second order
