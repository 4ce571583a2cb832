"""Hostile input for `vibra.dynamics` and the thermochemistry (issue 44, "Reliability"): bounded work,
interruptible compiled loops, no silent NaN.

Each case of the tables is an input and what must come of it: a one-line error naming the input (or
the step, the temperature, the mode), a warning where a partial result is useful, or the correct
result. Truth from outside the code under test: closed forms (the harmonic oscillator's C_v -> 0 and
n k limits, the zero-point energy h c nu / 2 from scipy's constants, the isokinetic kinetic energy
n_dof k_B T / 2), invariants (a run one step shorter than the reported step is finite; chunked and
unchunked loops agree to the bit), and a subprocess that receives SIGINT.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
import warnings
from typing import Any, Callable

import numpy as np
import pytest
from scipy import constants

import vibra.dynamics.cost as cost
import vibra.dynamics.kernels as kernels
from vibra import System, dynamics
from vibra.chains import linear_chain
from vibra.solvers.budget import TIME_LIMIT_S, ResourceLimitError
from vibra.spectra import ideal_gas_thermochemistry, thermochemistry

K_EV = constants.k / constants.e                                     # k_B, eV/K
EV_PER_CM1 = constants.h * constants.c / constants.centi / constants.e


def oscillator_3d() -> System:
    return System.from_hessian([[0.0, 0.0, 0.0]], 2.0, 3.0 * np.eye(3), units="dimensionless")


def oscillator_1d() -> System:
    return System.from_hessian([0.0], 1.0, [[1.0]], units="dimensionless")


def dense_system(n: int) -> System:
    """n dofs coupled by a dense positive-definite K (no spring bonds: K runs as a sparse product)."""
    A = np.random.default_rng(4).standard_normal((n, n))
    return System.from_hessian(np.zeros(n), 1.0, A @ A.T / n + np.eye(n), units="dimensionless")


def fput_mode_1(n: int, amplitude: float, **anharmonic: float) -> tuple[System, Any, np.ndarray]:
    system, forces = dynamics.fput(n, **anharmonic)
    return system, forces, amplitude * np.sin(np.pi * np.arange(1, n + 1) / (n + 1))


def beta_fput(amplitude: float, dt: float, n_steps: int, **options: Any) -> Any:
    """A beta-FPUT chain of 8 masses (beta = 1) started in mode 1 at `amplitude`, at rest."""
    system, forces, x0 = fput_mode_1(8, amplitude, beta=1.0)
    return dynamics.integrate(system, x0, np.zeros(8), dt, n_steps, forces=forces, **options)


def nan_after(calls: int, value: float = np.nan, shape: int | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """A force function that returns zeros `calls` times (the check at x0 counts), then `value`
    (or an array of another length)."""
    count = {"n": 0}

    def forces(u: np.ndarray) -> np.ndarray:
        count["n"] += 1
        if count["n"] <= calls:
            return np.zeros(u.size)
        return np.zeros(shape) if shape is not None else np.full(u.size, value)

    return forces


def integrate_3d(**changes: Any) -> Any:
    arguments: dict[str, Any] = {"system": oscillator_3d(), "x0": [0.3, -0.2, 0.1], "v0": [0.1, 0.4, -0.3],
                                 "dt": 0.01, "n_steps": 100}
    arguments.update(changes)
    return dynamics.integrate(arguments.pop("system"), arguments.pop("x0"), arguments.pop("v0"),
                              arguments.pop("dt"), arguments.pop("n_steps"), **arguments)


# ---------------------------------------------------------------------- the table: input -> one-line error
STEPS_3D_FIT = cost.steps_within(TIME_LIMIT_S, 3, "verlet", nonzeros=3)   # the 3-D oscillator's K runs as CSR (3 entries)

ERRORS = [
    # bounded work: refused from the sizes, before any step; the message names n_steps and what fits
    ("1e12 steps, sparse records", lambda: integrate_3d(n_steps=10**12, record_every=10**9), ResourceLimitError,
     rf"^n_steps is 1000000000000: verlet steps of 3 dofs in the compiled loop would take about .* days .*"
     rf"more than max_seconds=600; {STEPS_3D_FIT} steps fit"),
    ("1e9 steps of a Python force function", lambda: integrate_3d(n_steps=10**9, record_every=10**6,
                                                                  forces=lambda u: -u**3),
     ResourceLimitError, r"^n_steps is 1000000000: .* Python .* loop .* more than max_seconds=600; \d+ steps fit"),
    ("a dense K counts its entries", lambda: dynamics.integrate(dense_system(400), np.full(400, 0.01), np.zeros(400),
                                                                0.01, 10**7, record_every=10**6),
     ResourceLimitError, r"^n_steps is 10000000: .* 400 dofs .* more than max_seconds=600"),
    ("yoshida4 costs 3 forces a step", lambda: integrate_3d(n_steps=STEPS_3D_FIT // 3 + 10, integrator="yoshida4",
                                                            record_every=10**8),
     ResourceLimitError, rf"{cost.steps_within(TIME_LIMIT_S, 3, 'yoshida4', nonzeros=3)} steps fit"),
    ("a tighter max_seconds", lambda: integrate_3d(n_steps=10_000, max_seconds=1e-4), ResourceLimitError,
     r"more than max_seconds=0\.0001; \d+ steps fit"),
    ("max_seconds negative", lambda: integrate_3d(max_seconds=-1.0), ValueError,
     r"^max_seconds is -1\.0; it must be positive"),
    ("max_seconds nan", lambda: integrate_3d(max_seconds=float("nan")), ValueError, r"^max_seconds is nan"),
    ("drift_tolerance zero", lambda: integrate_3d(drift_tolerance=0.0), ValueError, r"^drift_tolerance is 0\.0"),
    # no silent NaN: a force function that fails mid-run, named with its step
    ("forces NaN after 3 calls", lambda: integrate_3d(forces=nan_after(3)), dynamics.IntegrationError,
     r"^integrate: forces\(u\) returned nan for dof 0 at step 2 of 100 \(t = 0\.02\); expected finite real forces"),
    ("forces inf at step 1", lambda: integrate_3d(forces=nan_after(2, np.inf)), dynamics.IntegrationError,
     r"forces\(u\) returned inf for dof 0 at step 1 of 100"),
    ("forces change shape", lambda: integrate_3d(forces=nan_after(4, shape=2)), dynamics.IntegrationError,
     r"^integrate: forces\(u\) returned shape \(2,\) of float64 at step 3 of 100 \(t = 0\.03\); expected \(3,\) "
     r"real forces, one per free dof$"),
    ("forces NaN under Nosé-Hoover", lambda: integrate_3d(forces=nan_after(5), thermostat=dynamics.NoseHoover(1.0, 1.0)),
     dynamics.IntegrationError, r"forces\(u\) returned nan for dof 0 at step 4 of 100"),
    # an anharmonic chain the harmonic dt check lets through
    ("beta-FPUT blows up (compiled)", lambda: beta_fput(3.0, 0.5, 2000), dynamics.IntegrationError, r"^integrate: the state left the finite numbers at step \d+ of 2000 \(t = .*\): "
     r"(x|v|force)\[\d\] = -?inf; the dt check sees only the harmonic omega_max"),
    # thermostats whose scale floating point cannot hold
    ("isokinetic at 1e-300 K (SI)", lambda: dynamics.integrate(linear_chain(3, mass=1e-26, stiffness=1.0, ends="fixed"),
                                                               np.zeros(3), [1.0, 0.0, 0.0], 1e-14, 10,
                                                               thermostat=dynamics.Isokinetic(1e-300)),
     ValueError, r"^thermostat\.temperature is 1e-300: n_dof k_B T = .* J is outside the normal floats"),
    ("isokinetic at k_B T = 1e308", lambda: integrate_3d(thermostat=dynamics.Isokinetic(1e308)), ValueError,
     r"^thermostat\.temperature is 1e\+308: n_dof k_B T = inf is outside the normal floats"),
    ("Nosé-Hoover tau 1e-200", lambda: integrate_3d(thermostat=dynamics.NoseHoover(1.0, 1e-200)), ValueError,
     r"^thermostat\.tau is 1e-200: the Nosé-Hoover masses k_B T tau\^2 = 0"),
    ("isokinetic kick overflows at step 1", lambda: integrate_3d(thermostat=dynamics.Isokinetic(1e-300)),
     dynamics.IntegrationError, r"^integrate: the state left the finite numbers at step 1 of 100 .*: x\[0\] = nan; "
     r"forces far larger than the velocities carry"),
    ("Nosé-Hoover tau far below dt", lambda: integrate_3d(thermostat=dynamics.NoseHoover(1.0, 1e-10)),
     dynamics.IntegrationError, r"at step 1 of 100 .*: (x|v|force)\[0\] = -?(inf|nan); the Nosé-Hoover variables "
     r"outgrew"),
    # an initial state whose energy overflows
    ("x0 = 1e200", lambda: integrate_3d(x0=[1e200, 0.0, 0.0]), ValueError, r"^x0 gives a potential energy of inf"),
    ("v0 = 1e200", lambda: integrate_3d(v0=[1e200, 0.0, 0.0]), ValueError, r"^v0 gives a kinetic energy of inf"),
    # thermochemistry: a temperature where a result leaves the floats, named with the quantity and the mode
    ("C_v at 1e-320 K", lambda: thermochemistry([1000.0, 10.0], [300.0, 1e-320]), ValueError,
     r"^thermochemistry: temperatures\[1\] is 1e-320 K, where entropy is nan \(the mode at 10 cm\^-1 gives nan\)"),
    ("C_v at 0 K is refused as before", lambda: thermochemistry([1000.0], [0.0]), ValueError, r"temperatures"),
    ("ideal gas at 1e-320 K", lambda: ideal_gas_thermochemistry([1000.0], [1e-320], geometry=_diatomic(),
                                                                symmetry_number=1),
     ValueError, r"^thermochemistry: temperatures\[0\] is 1e-320 K"),
]


def _diatomic() -> Any:
    from ase import Atoms

    return Atoms("HCl", positions=[[0.0, 0.0, 0.0], [0.0, 0.0, 1.27]])


@pytest.mark.parametrize(("make", "error", "match"), [case[1:] for case in ERRORS], ids=[case[0] for case in ERRORS])
def test_hostile_input_is_refused_in_one_line(make: Callable[[], Any], error: type, match: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)             # a drift warning before the failure is fine
        with pytest.raises(error, match=match) as raised:
            make()
    assert "\n" not in str(raised.value)


# ---------------------------------------------------------------------- the table: input -> warning
WARNINGS = [
    ("Nosé-Hoover far below the system's energy", lambda: dynamics.integrate(oscillator_1d(), [1.0], [0.5], 0.01, 1000,
                                                                          thermostat=dynamics.NoseHoover(1e-30, 1.0)),
     r"^integrate: the extended energy went from 0\.625 to .* by step 1 \(t = 0\.01\), .* beyond drift_tolerance=0\.5: "
     r"the thermostat's own frequency"),
    ("verlet at 0.99 of its bound", lambda: dynamics.integrate(oscillator_1d(), [1.0], [0.0], 1.98, 20000,
                                                               record_every=100),
     r"^integrate: the energy went from 0\.5 to .* by step \d+ .* beyond drift_tolerance=0\.5: dt is stable for "
     r"omega_max but coarse"),
    ("a beta-FPUT chain past a tight tolerance", lambda: beta_fput(4.0, 0.3, 2000, record_every=10,
                                                                   drift_tolerance=0.01),
     r"energy went from .* by step \d+ .* beyond drift_tolerance=0\.01: the dt check sees only the harmonic omega_max"),
    ("Grimme's free rotor at 1e-300 K", lambda: thermochemistry([1000.0, 10.0], [1e-300, 300.0], low_frequency="grimme"),
     r"^thermochemistry: the entropy is negative .* at temperatures\[0\] = 1e-300 K .* from Grimme's free rotor of "
     r"the mode at 10 cm\^-1"),
    ("an ideal gas at 1e-300 K", lambda: ideal_gas_thermochemistry([2990.0], [1e-300, 300.0], geometry=_diatomic(),
                                                                   symmetry_number=1),
     r"^ideal_gas_thermochemistry: the entropy is negative .* at temperatures\[0\] = 1e-300 K .* from translation"),
]


@pytest.mark.parametrize(("make", "match"), [case[1:] for case in WARNINGS], ids=[case[0] for case in WARNINGS])
def test_hostile_input_warns_and_returns_finite_values(make: Callable[[], Any], match: str) -> None:
    with pytest.warns(RuntimeWarning, match=match) as caught:
        result = make()
    assert all("\n" not in str(w.message) for w in caught)
    for name in ("positions", "velocities", "kinetic", "conserved", "heat_capacity", "entropy", "gibbs"):
        values = getattr(result, name, None)
        if values is not None:
            assert np.all(np.isfinite(values)), name


# ---------------------------------------------------------------------- the table: input -> the correct result
def _isokinetic_direction(v0: list[float]) -> None:
    run = integrate_3d(v0=v0, thermostat=dynamics.Isokinetic(0.5))
    target = 3 * 0.5 / 2                                        # n_dof k_B T / 2
    assert np.allclose(run.kinetic, target, rtol=1e-13, atol=0)
    direction = np.asarray(v0) / np.max(np.abs(v0))
    assert np.allclose(run.velocities[0] / np.max(np.abs(run.velocities[0])), direction, rtol=1e-15, atol=0)


def _cold_harmonic(temperature: float, low_frequency: str | None) -> None:
    thermo = thermochemistry([1000.0, 10.0], [temperature], low_frequency=low_frequency)
    zpe = 0.5 * (1000.0 + 10.0) * EV_PER_CM1                    # h c nu / 2 each
    assert thermo.heat_capacity[0] == 0.0 and thermo.entropy[0] == 0.0   # x^2 e^-x and x / (e^x - 1) -> 0
    assert thermo.internal_energy[0] == pytest.approx(zpe, rel=1e-14)
    assert thermo.helmholtz_energy[0] == pytest.approx(zpe, rel=1e-14)
    assert thermo.log_partition_function_bottom[0] == pytest.approx(-zpe / (K_EV * temperature), rel=1e-14)


def _hot_harmonic() -> None:
    thermo = thermochemistry([1000.0, 10.0], [1e300])          # x ~ 1e-299: C_v = n k (1 - x^2 / 12)
    assert thermo.heat_capacity[0] == pytest.approx(2 * K_EV, rel=1e-15)
    assert np.isfinite(thermo.helmholtz_energy[0])


def _grimme_rotor_log() -> None:
    # the free rotor's ln(8 pi^3 mu' k T / h^2) at 1e-300 K: the product underflows, its log does not
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        thermo = thermochemistry([10.0], [1e-300], low_frequency="grimme")
    mu = constants.h / (8 * np.pi**2 * 10.0 / constants.centi * constants.c)
    reduced = mu * 1e-44 / (mu + 1e-44)
    rotor = K_EV * (0.5 + 0.5 * (math.log(8 * np.pi**3 * reduced * constants.k / constants.h**2) + math.log(1e-300)))
    weight = 1.0 / (1.0 + (100.0 / 10.0) ** 4)
    assert thermo.entropy[0] == pytest.approx((1 - weight) * rotor, rel=1e-12)     # the harmonic part is 0


def _chunks_follow_the_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple[int, int]] = []
    original = kernels.run

    def spy(*args: Any) -> Any:
        calls.append((args[-3], args[-2]))
        return original(*args)

    monkeypatch.setattr(kernels, "run", spy)
    monkeypatch.setattr(cost, "CHUNK_SECONDS", 1e-4)
    system, forces, x0 = fput_mode_1(16, 0.5, alpha=0.25)
    dynamics.integrate(system, x0, np.zeros(16), 0.1, 5000, forces=forces, record_every=7)
    per_chunk = max(1, int(1e-4 / cost.step_seconds(16, "verlet")))
    assert calls[0] == (1, per_chunk) and calls[-1][1] == 5000
    assert len(calls) == math.ceil(5000 / per_chunk)
    assert all(b[0] == a[1] + 1 for a, b in zip(calls, calls[1:]))


def _long_chain_stability() -> None:
    # the highest frequency of a 20,000-site chain (ARPACK needed 11 minutes for it): the closed
    # form 2 sin(n pi / (2 (n + 1))) from LAPACK's bisection of the tridiagonal K~, and the step
    # just inside and just outside its bound (the Gershgorin bound 2 alone would refuse the first)
    n = 20_000
    chain = linear_chain(n, ends="fixed", units="dimensionless")
    omega = 2 * np.sin(n * np.pi / (2 * (n + 1)))
    assert dynamics.highest_omega(chain.hessian(), chain.mass_matrix()) == pytest.approx(omega, rel=1e-14)
    run = dynamics.integrate(chain, np.zeros(n), np.full(n, 1e-3), 0.999_999_99 * 2 / omega, 10, record_every=10)
    assert np.all(np.isfinite(run.positions))
    with pytest.raises(ValueError, match=rf"omega_max = {omega:.6g}"):
        dynamics.integrate(chain, np.zeros(n), np.full(n, 1e-3), 1.000_000_01 * 2 / omega, 10)


RESULTS = [
    ("a 20,000-site chain's stable step, exactly", lambda mp: _long_chain_stability()),
    ("isokinetic v0 = 1e-300 keeps its direction", lambda mp: _isokinetic_direction([1e-300, 0.0, -2e-300])),
    ("isokinetic v0 = 1e300 keeps its direction", lambda mp: _isokinetic_direction([1e300, 1e300, 0.0])),
    ("isokinetic v0 = 1e-170 (v.M v subnormal)", lambda mp: _isokinetic_direction([1e-170, 3e-170, 0.0])),
    ("C_v, S at 1e-300 K are 0, U = F = ZPE", lambda mp: _cold_harmonic(1e-300, None)),
    ("Truhlar at 1e-300 K as harmonic", lambda mp: _cold_harmonic(1e-300, "truhlar")),
    ("C_v at 1e300 K is n k", lambda mp: _hot_harmonic()),
    ("Grimme's rotor entropy at 1e-300 K", lambda mp: _grimme_rotor_log()),
    ("chunks of the estimated size", _chunks_follow_the_estimate),
]


@pytest.mark.parametrize("check", [case[1] for case in RESULTS], ids=[case[0] for case in RESULTS])
def test_hostile_input_gives_the_correct_result(check: Callable[[pytest.MonkeyPatch], None],
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    check(monkeypatch)


# ---------------------------------------------------------------------- where a failure appears
@pytest.mark.parametrize(("amplitude", "dt", "compiled"), [(3.0, 0.5, True), (4.0, 0.8, True), (3.0, 0.5, False)])
def test_a_blow_up_is_named_at_its_step(amplitude: float, dt: float, compiled: bool) -> None:
    system, bonds, x0 = fput_mode_1(8, amplitude, beta=1.0)
    forces = bonds if compiled else (lambda u: bonds(u))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(dynamics.IntegrationError) as raised:
            dynamics.integrate(system, x0, np.zeros(8), dt, 5000, forces=forces, record_every=3)
        step = raised.value.step
        assert raised.value.time == pytest.approx(step * dt)
        partial = raised.value.trajectory
        assert partial.t[-1] < step * dt and np.all(np.isfinite(partial.positions))
        # the step before is finite: the state left the finite numbers exactly at `step`
        before = dynamics.integrate(system, x0, np.zeros(8), dt, step - 1, forces=forces, record_every=step - 1,
                                    drift_tolerance=float("inf"))
    assert np.all(np.isfinite(before.positions[-1])) and np.all(np.isfinite(before.velocities[-1]))
    assert np.array_equal(before.positions[0], partial.positions[0])


def test_a_dynamics_scene_that_blows_up_names_the_step(tmp_path: Any) -> None:
    from vibra.pipeline.plan import execute, make_plan
    from vibra.pipeline.scene import Scene, SceneError

    data = {"kind": "dynamics", "system": {"builder": "fput", "n": 8, "beta": 1.0},
            "compute": {"dt": 0.5, "n_steps": 2000, "x0": list(fput_mode_1(8, 3.0)[2]), "v0": [0.0] * 8},
            "draw": {"energies": True}}
    scene = Scene.from_dict(data, source="blow.toml")
    with pytest.raises(SceneError, match=r"blow\.toml: compute: the run \(no thermostat\) diverged: its state left "
                                         r"the finite numbers at step \d+ \(t = "):
        execute(make_plan(scene), tmp_path, tmp_path)


def test_the_scene_estimate_is_the_librarys() -> None:
    from types import SimpleNamespace

    from vibra.pipeline.scene.limits import dynamics_estimate

    spec = SimpleNamespace(n_steps=10**6, record_every=10, integrator="yoshida4", n_runs=2, chains=(1, 4),
                           thermostat="nose-hoover")
    expected = cost.START_SECONDS + sum(cost.integration_seconds(40, 10**6, "yoshida4", chain=c) for c in (1, 4))
    assert dynamics_estimate(40, spec).seconds == pytest.approx(expected, rel=1e-15)


# ---------------------------------------------------------------------- chunks: bit-identical, interruptible
@pytest.mark.parametrize("thermostat", [None, dynamics.Isokinetic(0.01), dynamics.NoseHoover(0.01, 2.0, chain=2)],
                         ids=["none", "isokinetic", "nose-hoover"])
@pytest.mark.parametrize("integrator", dynamics.INTEGRATORS)
def test_chunked_runs_are_bit_identical_to_one_call(thermostat: Any, integrator: str,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    if integrator == "blanes-moan" and isinstance(thermostat, dynamics.NoseHoover):
        pytest.skip("blanes-moan does not run a Nosé-Hoover chain")
    system, bonds = dynamics.fput(9, alpha=0.3, beta=0.2, ends="periodic")
    x0 = np.linspace(-0.2, 0.3, 9)
    x0 -= x0.mean()
    v0 = np.linspace(0.1, -0.1, 9)
    runs = []
    for seconds in (float("inf"), 1e-12, 3e-6):                    # one call; chunks of 1 step; of a few steps
        monkeypatch.setattr(cost, "CHUNK_SECONDS", seconds)
        runs.append(dynamics.integrate(system, x0, v0, 0.05, 1000, forces=bonds, thermostat=thermostat,
                                       integrator=integrator, record_every=7))
    for run in runs[1:]:
        for name in ("positions", "velocities", "thermostat_state", "conserved"):
            assert np.array_equal(getattr(run, name), getattr(runs[0], name)), name


INTERRUPTED = """
import numpy as np
from vibra import System, dynamics
oscillator = System.from_hessian([0.0], 1.0, [[1.0]], units="dimensionless")
dynamics.integrate(oscillator, [1.0], [0.0], 0.01, 1000, record_every=100)      # load the compiled kernels
print("ready", flush=True)
dynamics.integrate(oscillator, [1.0], [0.0], 0.01, 300_000_000_000, record_every=100_000_000, max_seconds=float("inf"))
print("finished", flush=True)
"""


def test_ctrl_c_stops_a_compiled_integration() -> None:
    # 3e11 steps run for most of an hour in one compiled call; in chunks of ~CHUNK_SECONDS, SIGINT
    # stops them between two. No time is asserted: communicate's timeout is only the guard against
    # a run that does not stop (an unchunked loop would hold the signal for the whole hour).
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    process = subprocess.Popen([sys.executable, "-c", INTERRUPTED], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env=env)
    try:
        assert process.stdout is not None and process.stdout.readline().strip() == "ready"
        time.sleep(1.0)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert "KeyboardInterrupt" in err and "finished" not in out, err
    assert process.returncode != 0


def test_highest_frequency_work_is_bounded_and_an_unconverged_arpack_gives_a_safe_upper_bound(monkeypatch) -> None:
    """Above DENSE_OMEGA_MAX a non-chain's highest frequency comes from ARPACK with a bounded
    number of restarts; unconverged, the Gershgorin bound is taken: never below the true
    highest frequency (dense eigvalsh, the truth), so the dt it gives stays stable."""
    import numpy as np
    import scipy.sparse as sp

    from vibra.dynamics import stability

    n = stability.DENSE_OMEGA_MAX + 500
    A = sp.random(n, n, density=5 / n, random_state=1)
    K = (A @ A.T + sp.eye(n)).tocsr()
    masses = np.random.default_rng(0).uniform(1.0, 2.0, n)
    scale = 1.0 / np.sqrt(masses)
    truth = float(np.sqrt(np.linalg.eigvalsh((K.toarray() * scale).T * scale)[-1]))
    assert abs(stability.highest_omega(K, masses) - truth) <= 1e-8 * truth
    # ARPACK's start vector is random, so whether it converges within a given number of restarts
    # is not: its non-convergence is made certain here, and the fallback checked
    import scipy.sparse.linalg as sla

    def unconverged(*args, **kwargs):
        assert kwargs["maxiter"] == stability.ARPACK_RESTARTS  # the work is bounded
        raise sla.ArpackNoConvergence("no convergence", np.zeros(0), np.zeros((n, 0)))

    monkeypatch.setattr(stability.sla, "eigsh", unconverged)
    bounded = stability.highest_omega(K, masses)
    assert bounded >= truth * (1 - 1e-12) and bounded == stability.gershgorin_omega(K, masses)
