"""`integrate`: time integration of a `System` with its quadratic potential, optional anharmonic
forces and an optional thermostat; returns a `Trajectory`.

The harmonic part and `fput`'s bond forces run in one compiled loop (`kernels.run`), in chunks
of about `cost.CHUNK_SECONDS` of estimated work that return to Python (Ctrl-C stops the run
between two; the chunks do the arithmetic of one call exactly); any other force function runs in
a Python loop over the same compiled kicks and thermostat steps.

Limits, each checked before any step and raised per call:

- the estimated time (`vibra.dynamics.cost`, from the sizes) against ``max_seconds``
  (`vibra.solvers.budget.TIME_LIMIT_S`, 600 s, by default): `ResourceLimitError` naming
  ``n_steps`` and the number of steps that fit;
- the records against `MAX_RECORD_BYTES` (raise ``record_every``).

While running, a state that leaves the finite numbers (a force function returning NaN, an
anharmonic chain blowing up, a thermostat variable overflowing) stops the run with an
`IntegrationError` naming the step; a conserved quantity that moves by more than
``drift_tolerance`` (`DRIFT_TOLERANCE` by default) of its scale gives a RuntimeWarning naming
the first record beyond it (`Trajectory.conserved_drift`).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
import vibra.dynamics.cost as cost
import vibra.dynamics.kernels as kernels
from vibra.dynamics.fput import BondForces
from vibra.dynamics.schemes import INTEGRATORS, SCHEMES, STABLE_OMEGA_DT, Scheme
from vibra.dynamics.failures import (IntegrationError, check_drift, failure_hint, finite_state, first_bad,
                                     has_potential)
from vibra.dynamics.stability import check_stable, gershgorin_omega
from vibra.dynamics.thermostats import Isokinetic, NoseHoover, Thermostat
from vibra.dynamics.trajectory import Trajectory
from vibra.solvers import budget
from vibra.system import System

__all__ = ["integrate", "check_thermostat_scale", "MAX_RECORD_BYTES", "DRIFT_TOLERANCE"]

#: Largest memory the recorded positions and velocities may take (bytes); a larger request is
#: refused before anything is allocated (raise `record_every`).
MAX_RECORD_BYTES = 2 * 1024**3

#: Largest relative change of `Trajectory.conserved` (`Trajectory.conserved_drift`) a run may show
#: without a RuntimeWarning (override: ``integrate(drift_tolerance=...)``). Velocity Verlet on an
#: oscillator moves the energy by (omega dt)^2 / 4 relative at most (0.25 at omega dt = 1, at the
#: limit 2 the shadow energy vanishes): beyond 0.5 a run is not a trajectory of the system but
#: of its step, or has blown up.
DRIFT_TOLERANCE = 0.5

def _force_function(forces: Any, n_dof: int, x0: NDArray[np.float64]) -> Callable[[NDArray[np.float64]], Any] | None:
    if forces is None:
        return None
    if not callable(forces):
        raise TypeError(f"forces must be a callable forces(u) -> (n_dof,) array (or fput's BondForces), "
                        f"got {type(forces).__name__}")
    trial = np.asarray(forces(x0.copy()))
    if trial.shape != (n_dof,):
        raise ValueError(f"forces(x0) returned shape {trial.shape}; expected ({n_dof},), one force per free dof")
    if trial.dtype.kind not in "iuf" or not np.all(np.isfinite(trial)):
        raise ValueError("forces(x0) returned non-finite or non-real values; expected finite real forces")
    return forces


def check_thermostat_scale(thermostat: Thermostat, kT: float, n_dof: int, energy: str) -> None:
    """Refuse a thermostat whose k_B T (or Nosé-Hoover masses Q) floating point cannot hold: an
    `ArgumentError` naming ``thermostat.temperature`` or ``thermostat.tau`` (what a scene checks
    before it runs, and `integrate` before it starts)."""
    tiny, huge = np.finfo(float).tiny, np.finfo(float).max
    unit = "" if energy == "1" else f" {energy}"
    if not tiny <= n_dof * kT <= huge:
        raise _validate.ArgumentError("thermostat.temperature", f"thermostat.temperature is {thermostat.temperature!r}: n_dof k_B T = {n_dof * kT:.3g}"
                         f"{unit} is outside the normal floats ({tiny:.3g} to {huge:.3g}); expected a "
                         "temperature on the scale of the system's energies")
    if isinstance(thermostat, NoseHoover):
        Q = kT * thermostat.tau**2
        if not (tiny <= Q and n_dof * Q <= huge):
            raise _validate.ArgumentError("thermostat.tau", f"thermostat.tau is {thermostat.tau!r}: the Nosé-Hoover masses k_B T tau^2 = {Q:.3g} "
                             f"(and n_dof times that) leave the normal floats ({tiny:.3g} to {huge:.3g}); expected "
                             "tau of the order of the system's periods")


def _isokinetic_velocities(v: NDArray[np.float64], masses: NDArray[np.float64], two_kinetic: float,
                           temperature: float) -> NDArray[np.float64]:
    """v0 scaled to sum m v^2 = two_kinetic (its direction kept, however small or large its length)."""
    peak = float(np.max(np.abs(v)))
    if not peak > 0:
        raise ValueError("v0 is zero; the isokinetic constraint needs a nonzero initial velocity "
                         "(it sets the direction; its length is scaled to n_dof k_B T / 2)")
    with np.errstate(all="ignore"):
        mv2 = float(np.sum(masses * v * v))
        if not np.finfo(float).tiny <= mv2 <= np.finfo(float).max:   # v0 so small (large) that v.M v under- (over-)flows
            v = v / peak                                                 # its direction, whose square does not
            mv2 = float(np.sum(masses * v * v))
        scaled = v * np.sqrt(two_kinetic / mv2)
        kept = float(np.sum(masses * scaled * scaled))
    if not (np.all(np.isfinite(scaled)) and abs(kept / two_kinetic - 1.0) < 1e-12):
        raise _validate.ArgumentError("thermostat.temperature", f"thermostat.temperature is {temperature!r}: velocities of these masses carrying "
                         f"n_dof k_B T = {two_kinetic:.3g} in kinetic energy leave the normal floats "
                         f"(sum m v^2 comes out {kept:.3g}); expected a temperature on the scale of the "
                         "system's energies")
    return scaled


def integrate(
    system: System,
    x0: ArrayLike,
    v0: ArrayLike,
    dt: float,
    n_steps: int,
    *,
    forces: Callable[[NDArray[np.float64]], ArrayLike] | BondForces | None = None,
    thermostat: Isokinetic | NoseHoover | None = None,
    integrator: str = "verlet",
    record_every: int = 1,
    max_seconds: float | None = None,
    drift_tolerance: float | None = None,
) -> Trajectory:
    """Integrate M u'' = -K u + f(u) (+ a thermostat) from (x0, v0) over n_steps steps of dt.

    Parameters
    ----------
    system : System
        The system; its Hessian K (free dofs) gives the harmonic forces -K u, its masses M.
    x0, v0 : (n_dof,) array_like
        Initial displacements from equilibrium (length unit) and velocities (length per time
        unit). Under `Isokinetic`, v0 sets the direction only and is scaled to
        n_dof k_B T / 2 of kinetic energy.
    dt : float
        Time step, in the system's time unit; it must be stable for the highest normal frequency:
        dt < `STABLE_OMEGA_DT[integrator]` / omega_max (2 / omega_max for velocity Verlet).
    n_steps : int
        Number of steps (>= 1).
    forces : callable or BondForces, optional
        Anharmonic forces f(u), (n_dof,) -> (n_dof,) in the force unit, added to -K u. A
        `BondForces` (from `fput`) runs compiled; any other callable runs in a Python loop. A
        ``potential(u)`` method, where present, adds the anharmonic energy to `potential`.
    thermostat : Isokinetic or NoseHoover, optional
        None: energy-conserving dynamics.
    integrator : {"verlet", "yoshida4", "blanes-moan"}
        The scheme (see `vibra.dynamics.schemes`); ``"blanes-moan"`` does not run a Nosé-Hoover chain.
    record_every : int
        Record every this many steps (the initial state is always recorded).
    max_seconds : float, optional
        Longest estimated run, in s (`vibra.dynamics.cost`: steps x forces per step x the
        cost of one evaluation for n_dof dofs, from the sizes); None takes
        `vibra.solvers.budget.TIME_LIMIT_S` (600 s), ``float("inf")`` runs anyway. For a
        force function that runs in Python the estimate leaves out the function's own time.
    drift_tolerance : float, optional
        Largest relative change of `Trajectory.conserved` (`Trajectory.conserved_drift`)
        without a RuntimeWarning; None takes `DRIFT_TOLERANCE` (0.5), ``float("inf")`` checks
        nothing.

    Returns
    -------
    Trajectory

    Raises
    ------
    TypeError
        `system` is not a `System`; `forces` is not callable; a thermostat of another type.
    ValueError
        x0 / v0 of the wrong shape or not finite; dt not positive or unstable (the message gives
        the stable bound from omega_max); forces(x0) of the wrong shape; an unknown integrator;
        blanes-moan with a Nosé-Hoover chain; v0 = 0 under the isokinetic constraint; a record
        that would not fit in `MAX_RECORD_BYTES`; a temperature (or tau) whose k_B T (or
        Nosé-Hoover masses) floating point cannot hold; `max_seconds` or `drift_tolerance` not
        positive.
    vibra.solvers.budget.ResourceLimitError
        The estimated time exceeds `max_seconds` (the message gives the steps that fit).
    IntegrationError
        While running: the state left the finite numbers, the force function returned a
        non-finite force, or an energy overflowed; the message names the step and the error
        holds the records before it.

    Warns
    -----
    RuntimeWarning
        The conserved quantity moved by more than `drift_tolerance` of its scale (the message
        names the first record beyond it).

    Examples
    --------
    >>> from vibra.chains import linear_chain
    >>> chain = linear_chain(3, ends="fixed", units="dimensionless")
    >>> run = integrate(chain, [0.1, 0.0, -0.1], [0.0, 0.0, 0.0], 0.01, 1000, record_every=100)
    >>> len(run.t), bool(abs(run.energy[-1] / run.energy[0] - 1) < 1e-4)
    (11, True)
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra.System (sites with diagonal masses), got {type(system).__name__}")
    n_dof = system.n_dof
    x = _validate.real_array(x0, "x0", ndim=1).copy()
    if x.shape != (n_dof,):
        raise ValueError(f"x0 has shape {x.shape}; expected ({n_dof},), one displacement per free dof")
    v = _validate.real_array(v0, "v0", ndim=1).copy()
    if v.shape != (n_dof,):
        raise ValueError(f"v0 has shape {v.shape}; expected ({n_dof},), one velocity per free dof")
    dt = _validate.positive_scalar(dt, "dt", "time step")
    n_steps = _validate.min_count(n_steps, "n_steps", low=1, what="an integration")
    force_function = _force_function(forces, n_dof, x)
    if thermostat is not None and not isinstance(thermostat, (Isokinetic, NoseHoover)):
        raise TypeError(f"thermostat must be dynamics.Isokinetic, dynamics.NoseHoover or None, "
                        f"got {type(thermostat).__name__}")
    _validate.choice(integrator, "integrator", INTEGRATORS)
    scheme = SCHEMES[integrator]
    if isinstance(thermostat, NoseHoover) and scheme.weights.size == 0:
        raise ValueError(f"integrator is {integrator!r}, which splits two flows only; a NoseHoover "
                         "thermostat runs with 'verlet' or 'yoshida4'")
    record_every = _validate.min_count(record_every, "record_every", low=1, what="recording")
    time_limit = _validate.optional_limit(max_seconds, "max_seconds")
    tolerance = _validate.optional_limit(drift_tolerance, "drift_tolerance")
    n_records = n_steps // record_every + 1
    if 2 * n_records * n_dof * 8 > MAX_RECORD_BYTES:
        raise ValueError(f"recording {n_records} states of {n_dof} dofs needs {2 * n_records * n_dof * 8 / 1e9:.3g} GB "
                         f"(limit {MAX_RECORD_BYTES / 1e9:.3g} GB); raise record_every")
    masses = system.mass_matrix()
    K = system.hessian().tocsr()
    compiled = force_function is None or isinstance(force_function, BondForces)
    bonds = _bond_arrays(system, K, force_function) if compiled else None
    _check_time(n_dof, n_steps, integrator, thermostat, compiled, K.nnz if bonds is None else bonds[-1].nnz,
                budget.TIME_LIMIT_S if time_limit is None else time_limit)
    if gershgorin_omega(K, masses) * dt >= STABLE_OMEGA_DT[integrator]:   # the bound is not enough: the value
        check_stable(K, masses, dt, integrator)
    kT = 0.0
    two_kinetic = 0.0
    if thermostat is not None:
        kT = system.units.boltzmann * thermostat.temperature
        check_thermostat_scale(thermostat, kT, n_dof, system.units.energy)
    if isinstance(thermostat, Isokinetic):
        two_kinetic = n_dof * kT
        v = _isokinetic_velocities(v, masses, two_kinetic, thermostat.temperature)
    _check_initial_energy(K, masses, x, v, force_function)
    return _run(system, K, masses, x, v, dt, n_steps, force_function, bonds, thermostat, scheme, record_every, kT,
                two_kinetic, n_records, DRIFT_TOLERANCE if tolerance is None else tolerance)


def _check_initial_energy(K: sp.csr_matrix, masses: NDArray[np.float64], x: NDArray[np.float64],
                          v: NDArray[np.float64], force_function: Any) -> None:
    """Refuse an initial state whose energy (or harmonic force) floating point cannot hold."""
    with np.errstate(over="ignore", invalid="ignore"):
        kinetic = 0.5 * float(np.sum(masses * v * v))
        force = K @ x
        potential = 0.5 * float(x @ force)
        if force_function is not None and has_potential(force_function):
            potential += float(force_function.potential(x.copy()))
    if not np.isfinite(kinetic):
        raise ValueError(f"v0 gives a kinetic energy of {kinetic!r}; expected velocities whose energy floating "
                         "point can hold")
    if not (np.isfinite(potential) and np.all(np.isfinite(force))):
        raise ValueError(f"x0 gives a potential energy of {potential!r} (largest harmonic force "
                         f"{float(np.max(np.abs(force))):.3g}); expected displacements whose energy floating point "
                         "can hold")


def _check_time(n_dof: int, n_steps: int, integrator: str, thermostat: Any, compiled: bool, nonzeros: int,
                limit: float) -> None:
    """Refuse a run whose estimated time (`cost.integration_seconds`) exceeds `limit`, naming the steps that fit;
    `nonzeros` the entries of the part of K that runs as a sparse product."""
    chain = thermostat.chain if isinstance(thermostat, NoseHoover) else 0
    seconds = cost.integration_seconds(n_dof, n_steps, integrator, chain=chain, compiled=compiled, nonzeros=nonzeros)
    if seconds > limit:
        fit = cost.steps_within(limit, n_dof, integrator, chain=chain, compiled=compiled, nonzeros=nonzeros)
        where = "compiled" if compiled else "Python (the force function's own time not counted)"
        raise budget.ResourceLimitError(
            f"n_steps is {n_steps}: {integrator} steps of {n_dof} dofs in the {where} loop would take about "
            f"{budget.describe_seconds(seconds)} (estimated from the sizes), more than max_seconds={limit:g}; "
            f"{fit} steps fit: take fewer steps, or pass max_seconds= (float('inf') runs anyway)")


def _thermostat_arrays(thermostat: Any, kT: float, n_dof: int) -> tuple[int, NDArray[np.float64], tuple[str, ...]]:
    if isinstance(thermostat, NoseHoover):
        M = thermostat.chain
        Q = np.full(M, kT * thermostat.tau**2)
        Q[0] *= n_dof
        labels = tuple(f"xi{j + 1}" for j in range(M)) + tuple(f"eta{j + 1}" for j in range(M))
        return kernels.NOSE_HOOVER, Q, labels
    if isinstance(thermostat, Isokinetic):
        return kernels.ISOKINETIC, np.ones(0), ("mu",)
    return kernels.NONE, np.ones(0), ()


def _run(system: System, K: sp.csr_matrix, masses: NDArray[np.float64], x: NDArray[np.float64],
         v: NDArray[np.float64], dt: float, n_steps: int, force_function: Any, bonds: tuple[Any, ...] | None,
         thermostat: Any, scheme: Scheme, record_every: int, kT: float, two_kinetic: float, n_records: int,
         tolerance: float) -> Trajectory:
    n_dof = x.size
    kind, Q, labels = _thermostat_arrays(thermostat, kT, n_dof)
    chain = Q.size
    xi, eta = np.zeros(chain), np.zeros(chain)
    rec_x = np.empty((n_records, n_dof))
    rec_v = np.empty((n_records, n_dof))
    rec_state = np.zeros((n_records, 2 * chain))
    drifts = scheme.weights if kind == kernels.NOSE_HOOVER else scheme.drifts
    compiled = bonds is not None
    if bonds is not None:
        first, second, k, alpha, beta, rest = bonds
        ghost = np.append(x, 0.0)                      # the wall: a ghost dof at rest
        arrays = (masses, rest.indptr.astype(np.int64), rest.indices.astype(np.int64),
                  np.asarray(rest.data, dtype=np.float64), first, second, k, alpha, beta, scheme.kicks, drifts,
                  kind, kT, float(n_dof), Q)
        steps = cost.chunk_steps(n_dof, scheme.name, chain=chain if kind == kernels.NOSE_HOOVER else 0,
                                 nonzeros=rest.nnz)
        failure = _compiled_loop(ghost, v, xi, eta, arrays, two_kinetic, dt, n_steps, record_every, rec_x, rec_v,
                                 rec_state, steps)
    else:
        failure = _python_loop(K, masses, x, v, force_function, scheme.kicks, drifts, kind, kT, n_dof, Q, xi, eta,
                               two_kinetic, dt, n_steps, record_every, rec_x, rec_v, rec_state)

    def records(rows: int) -> Trajectory:
        return _trajectory(system, K, masses, force_function, kind, Q, kT, labels, rec_x[:rows], rec_v[:rows],
                           rec_state[:rows], record_every, dt, scheme.name, compiled)

    hint = failure_hint(force_function, kind)
    if failure is None:                                # a record past the last check (never expected)
        bad = ~(np.isfinite(rec_x).all(axis=1) & np.isfinite(rec_v).all(axis=1) & np.isfinite(rec_state).all(axis=1))
        if bad.any():
            row = int(np.argmax(bad))
            failure = (row * record_every, "a record " + first_bad(rec_x[row], rec_v[row], np.zeros(n_dof), masses,
                                                                    rec_state[row, :chain], rec_state[row, chain:]), None)
    if failure is not None:
        step, what, expected = failure
        try:
            partial: Trajectory | None = records((step - 1) // record_every + 1)
        except Exception:                              # the force function fails on the records too
            partial = None
        if expected is not None:
            message = f"integrate: {what} at step {step} of {n_steps} (t = {step * dt:.6g}); expected {expected}"
        else:
            message = (f"integrate: the state left the finite numbers at step {step} of {n_steps} "
                       f"(t = {step * dt:.6g}): {what}; {hint}")
        raise IntegrationError(message, step, step * dt, partial)
    run = records(n_records)
    energies = {"kinetic": run.kinetic, "potential": run.potential, "conserved": run.conserved}
    if not has_potential(force_function):             # NaN, documented: only the kinetic energy is known
        energies = {"kinetic": run.kinetic}
    finite = np.logical_and.reduce([np.isfinite(values) for values in energies.values()])
    if not finite.all():
        row = int(np.argmax(~finite))
        step = row * record_every
        name, values = next((name, values) for name, values in energies.items() if not np.isfinite(values[row]))
        raise IntegrationError(f"integrate: the {name} energy left the finite numbers by step {step} of {n_steps} "
                               f"(t = {step * dt:.6g}, the first record where it is {float(values[row])!r}); "
                               f"{hint}", step, step * dt, records(row))
    check_drift(run, kind, tolerance, record_every, failure_hint(force_function, kind, drift=True))
    return run


def _trajectory(system: System, K: sp.csr_matrix, masses: NDArray[np.float64], force_function: Any, kind: int,
                Q: NDArray[np.float64], kT: float, labels: tuple[str, ...], rec_x: NDArray[np.float64],
                rec_v: NDArray[np.float64], rec_state: NDArray[np.float64], record_every: int, dt: float,
                integrator: str, compiled: bool) -> Trajectory:
    """The `Trajectory` of the records: energies, the thermostat's variables, the conserved quantity."""
    n_records, n_dof = rec_x.shape
    chain = Q.size
    with np.errstate(over="ignore", invalid="ignore"):       # checked by the caller, record by record
        kinetic = 0.5 * np.sum(masses * rec_v * rec_v, axis=1)
        potential = 0.5 * np.einsum("ij,ij->i", rec_x, (K @ rec_x.T).T)
        if force_function is not None:
            if isinstance(force_function, BondForces):
                potential = potential + force_function.potentials(rec_x)
            elif has_potential(force_function):
                potential = potential + np.array([float(force_function.potential(row)) for row in rec_x])
            else:
                potential = np.full(n_records, np.nan)
        if kind == kernels.ISOKINETIC:
            total_force = -(K @ rec_x.T).T
            if force_function is not None:
                total_force += np.array([np.asarray(force_function(row), dtype=float) for row in rec_x]).reshape(
                    total_force.shape)
            mu = np.sum(total_force * rec_v, axis=1) / np.sum(masses * rec_v * rec_v, axis=1)
            state = mu[:, None]
            conserved = kinetic
        elif kind == kernels.NOSE_HOOVER:
            state = rec_state
            xis, etas = rec_state[:, :chain], rec_state[:, chain:]
            conserved = (kinetic + potential + 0.5 * np.sum(Q * xis * xis, axis=1) + n_dof * kT * etas[:, 0]
                         + kT * np.sum(etas[:, 1:], axis=1))
        else:
            state = np.zeros((n_records, 0))
            conserved = kinetic + potential
    t = np.arange(n_records) * (record_every * dt)
    return Trajectory(t=t, positions=rec_x, velocities=rec_v, kinetic=kinetic, potential=potential,
                      conserved=conserved, thermostat_state=state, thermostat_labels=labels, masses=masses,
                      dt=dt, integrator=integrator, compiled=compiled, units=system.units)


def _compiled_loop(x: NDArray[np.float64], v: NDArray[np.float64], xi: NDArray[np.float64],
                   eta: NDArray[np.float64], arrays: tuple[Any, ...], two_kinetic: float, dt: float, n_steps: int,
                   record_every: int, rec_x: NDArray[np.float64], rec_v: NDArray[np.float64],
                   rec_state: NDArray[np.float64], chunk: int) -> tuple[int, str, str | None] | None:
    """`kernels.run` over chunks of `chunk` steps, each a return to Python (a KeyboardInterrupt stops
    the run there); a chunk that ends outside the finite numbers runs again from its start with the
    per-step check, which names the step. Returns (step, what, None) of a failure, None otherwise."""
    (masses, indptr, indices, data, first_bond, second_bond, k, alpha, beta, kicks, drifts, kind, kT, n_f,
     Q) = arrays
    n = v.size
    force = np.empty(n + 1)
    carry = np.zeros(1)
    first = 1
    while first <= n_steps:
        last = min(n_steps, first + chunk - 1)
        saved = [array.copy() for array in (x, v, xi, eta, force, carry)]
        for check in (False, True):
            try:
                bad = kernels.run(x, v, masses, indptr, indices, data, first_bond, second_bond, k, alpha, beta,
                                  kicks, drifts, kind, kT, n_f, Q, xi, eta, two_kinetic, dt, n_steps, record_every,
                                  rec_x, rec_v, rec_state, force, carry, first, last, check)
            except ZeroDivisionError:                  # numba's: the isokinetic kick's velocities all vanished
                # the chunk's first step: the records before it are the ones written (the chunk's own may not be)
                return first, f"the velocities vanished in an isokinetic kick (between steps {first} and {last})", None
            if check or finite_state(x[:n], v, force[:n], masses, xi, eta):
                break
            for array, start in zip((x, v, xi, eta, force, carry), saved):
                array[:] = start
        if bad or check:
            return (bad or last), first_bad(x[:n], v, force[:n], masses, xi, eta), None
        first = last + 1
    return None


def _spring_bonds(system: System, n_dof: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]] | None:
    """K as bonds (i, j, k): each row of the spring factor is c (x_j - x_i) or c x_j (a spring to a
    wall, i = the ghost index n_dof), k = w c^2; None where a row is anything else (K stays CSR)."""
    factor = system.spring_factor()
    if factor is None:
        return None
    B, w = factor
    B = sp.csr_matrix(B)
    counts = np.diff(B.indptr)
    if B.shape[0] == 0 or counts.max() > 2:
        return None
    first = np.full(B.shape[0], n_dof, dtype=np.int64)
    second = np.full(B.shape[0], n_dof, dtype=np.int64)
    coefficient = np.zeros(B.shape[0])
    for row in range(B.shape[0]):
        columns = B.indices[B.indptr[row]:B.indptr[row + 1]]
        values = B.data[B.indptr[row]:B.indptr[row + 1]]
        if columns.size == 2:
            if values[0] != -values[1]:
                return None
            low, high = (0, 1) if values[1] > 0 else (1, 0)
            first[row], second[row], coefficient[row] = columns[low], columns[high], values[high]
        else:
            if values[0] > 0:
                second[row] = columns[0]
            else:
                first[row] = columns[0]
            coefficient[row] = abs(values[0])
    return first, second, w * coefficient**2


def _bond_arrays(system: System, K: sp.csr_matrix, bonds: BondForces | None) -> tuple[Any, ...]:
    """The kernel's bonds (first, second, k, alpha, beta; walls at the ghost index n) and K_rest."""
    n_dof = K.shape[0]
    harmonic = _spring_bonds(system, n_dof)
    if harmonic is None:
        first, second, k = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        rest = K
    else:
        first, second, k = harmonic
        rest = sp.csr_matrix((n_dof, n_dof))
    alpha, beta = np.zeros(k.size), np.zeros(k.size)
    if bonds is not None:
        where = {(int(i), int(j)): b for b, (i, j) in enumerate(zip(first, second))}
        extra_first, extra_second, extra_alpha, extra_beta = [], [], [], []
        for i, j, a, b4 in zip(bonds.first, bonds.second, bonds.alpha, bonds.beta):
            i, j = (n_dof if i < 0 else int(i)), (n_dof if j < 0 else int(j))
            if (i, j) in where:
                alpha[where[i, j]] += a
                beta[where[i, j]] += b4
            elif (j, i) in where:                      # the same spring read the other way: d -> -d
                alpha[where[j, i]] -= a
                beta[where[j, i]] += b4
            else:
                extra_first.append(i), extra_second.append(j), extra_alpha.append(a), extra_beta.append(b4)
        if extra_first:
            first = np.concatenate([first, np.array(extra_first, dtype=np.int64)])
            second = np.concatenate([second, np.array(extra_second, dtype=np.int64)])
            k = np.concatenate([k, np.zeros(len(extra_first))])
            alpha = np.concatenate([alpha, extra_alpha])
            beta = np.concatenate([beta, extra_beta])
    return first, second, k, alpha, beta, rest


def _python_loop(K: sp.csr_matrix, masses: NDArray[np.float64], x: NDArray[np.float64], v: NDArray[np.float64],
                 force_function: Any, kicks: NDArray[np.float64], drifts: NDArray[np.float64], kind: int, kT: float,
                 n_dof: int, Q: NDArray[np.float64], xi: NDArray[np.float64], eta: NDArray[np.float64],
                 two_kinetic: float, dt: float, n_steps: int, record_every: int, rec_x: NDArray[np.float64],
                 rec_v: NDArray[np.float64], rec_state: NDArray[np.float64]) -> tuple[int, str, str | None] | None:
    """The steps of `kernels.run` in Python, for a force function numba cannot call, each force and
    each step's state checked. Returns (step, what, expected) of the first failure (expected: what
    the force function should have returned; None for the state), None otherwise."""
    chain = Q.size

    def total_force() -> NDArray[np.float64]:
        extra = np.asarray(force_function(x.copy()))
        if extra.shape != (n_dof,) or extra.dtype.kind not in "iuf":
            raise _ForceFailure(f"forces(u) returned shape {extra.shape} of {extra.dtype}",
                                f"({n_dof},) real forces, one per free dof")
        total = -(K @ x) + extra
        if not np.isfinite(total).all():
            i = int(np.argmax(~np.isfinite(total)))
            if np.isfinite(extra[i]):                       # the harmonic part overflowed: the state's failure
                raise _ForceFailure(f"the force on dof {i} is {float(total[i])!r}", None)
            raise _ForceFailure(f"forces(u) returned {float(extra[i])!r} for dof {i}", "finite real forces at every state")
        return total

    def kick(force: NDArray[np.float64], h: float) -> None:
        if kind == kernels.ISOKINETIC:
            kernels.isokinetic_kick(v, force, masses, h, two_kinetic)
        else:
            v[:] += h * force / masses

    force = total_force()
    rec_x[0], rec_v[0] = x, v
    rec_state[0, :chain], rec_state[0, chain:] = xi, eta
    row = 0
    with np.errstate(over="ignore", invalid="ignore"):      # each step's state is checked below
        for step in range(1, n_steps + 1):
            try:
                if kind == kernels.NOSE_HOOVER:
                    for w in drifts:
                        h = w * dt
                        kernels.nose_hoover_chain(v, masses, xi, eta, Q, kT, float(n_dof), 0.5 * h)
                        v[:] += 0.5 * h * force / masses
                        x[:] += h * v
                        force = total_force()
                        v[:] += 0.5 * h * force / masses
                        kernels.nose_hoover_chain(v, masses, xi, eta, Q, kT, float(n_dof), 0.5 * h)
                else:
                    for s in range(drifts.size):
                        kick(force, kicks[s] * dt)
                        x[:] += drifts[s] * dt * v
                        force = total_force()
                    kick(force, kicks[-1] * dt)
            except _ForceFailure as failure:
                return step, failure.what, failure.expected
            except ZeroDivisionError:                  # numba's: the isokinetic kick's velocities all vanished
                return step, "the velocities vanished in an isokinetic kick", None
            if not finite_state(x, v, force, masses, xi, eta):
                return step, first_bad(x, v, force, masses, xi, eta), None
            if step % record_every == 0:
                row += 1
                rec_x[row], rec_v[row] = x, v
                rec_state[row, :chain], rec_state[row, chain:] = xi, eta
    return None


class _ForceFailure(Exception):
    """A force evaluation of the Python loop that is not a finite force: what came, in words, and
    what was expected (None where the state, not the force function, is at fault)."""

    def __init__(self, what: str, expected: str | None) -> None:
        super().__init__(what)
        self.what = what
        self.expected = expected
