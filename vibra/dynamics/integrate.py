"""`integrate`: time integration of a `System` with its quadratic potential, optional anharmonic
forces and an optional thermostat; returns a `Trajectory`.

The harmonic part and `fput`'s bond forces run in one compiled loop (`kernels.run`); any other
force function runs in a Python loop over the same compiled kicks and thermostat steps.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
import vibra.dynamics.kernels as kernels
from vibra.dynamics.fput import BondForces
from vibra.dynamics.schemes import INTEGRATORS, SCHEMES, STABLE_OMEGA_DT, Scheme
from vibra.dynamics.thermostats import Isokinetic, NoseHoover
from vibra.dynamics.trajectory import Trajectory
from vibra.system import System

__all__ = ["integrate", "highest_omega", "stable_dt", "MAX_RECORD_BYTES"]

#: Largest memory the recorded positions and velocities may take (bytes); a larger request is
#: refused before anything is allocated (raise `record_every`).
MAX_RECORD_BYTES = 2 * 1024**3

#: Up to this many dofs the highest frequency comes from a dense eigvalsh of K~; above, from ARPACK.
_DENSE_OMEGA_MAX = 1500


def highest_omega(K: sp.csr_matrix, masses: NDArray[np.float64]) -> float:
    """The largest normal frequency sqrt(max eig(M^-1/2 K M^-1/2)), in rad per time unit (0 if none is positive)."""
    scale = sp.diags(1.0 / np.sqrt(masses))
    K_tilde = (scale @ K @ scale).tocsr()
    n = K_tilde.shape[0]
    if n <= _DENSE_OMEGA_MAX:
        top = float(np.linalg.eigvalsh(K_tilde.toarray())[-1])
    else:
        top = float(sla.eigsh(K_tilde, k=1, which="LA", tol=1e-10, return_eigenvectors=False)[0])
    return float(np.sqrt(top)) if top > 0 else 0.0


def stable_dt(omega_max: float, integrator: str = "verlet") -> float:
    """The largest stable time step for a highest frequency omega_max: STABLE_OMEGA_DT / omega_max
    (2 / omega_max for velocity Verlet), in the time unit; inf for omega_max = 0.

    Examples
    --------
    >>> round(stable_dt(2.0, "verlet"), 12)
    1.0
    """
    _validate.choice(integrator, "integrator", INTEGRATORS)
    return float("inf") if omega_max <= 0 else STABLE_OMEGA_DT[integrator] / omega_max


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
        that would not fit in `MAX_RECORD_BYTES`.

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
    n_records = n_steps // record_every + 1
    if 2 * n_records * n_dof * 8 > MAX_RECORD_BYTES:
        raise ValueError(f"recording {n_records} states of {n_dof} dofs needs {2 * n_records * n_dof * 8 / 1e9:.3g} GB "
                         f"(limit {MAX_RECORD_BYTES / 1e9:.3g} GB); raise record_every")
    masses = system.mass_matrix()
    K = system.hessian().tocsr()
    omega_max = highest_omega(K, masses)
    if omega_max * dt >= STABLE_OMEGA_DT[integrator]:
        raise ValueError(
            f"dt is {dt:g}, unstable for the highest normal frequency omega_max = {omega_max:.6g}: "
            f"{integrator} is stable for dt < {STABLE_OMEGA_DT[integrator]:.4g} / omega_max = "
            f"{stable_dt(omega_max, integrator):.6g}")
    kT = 0.0
    two_kinetic = 0.0
    if thermostat is not None:
        kT = system.units.boltzmann * thermostat.temperature
    if isinstance(thermostat, Isokinetic):
        mv2 = float(np.sum(masses * v * v))
        if not mv2 > 0:
            raise ValueError("v0 is zero; the isokinetic constraint needs a nonzero initial velocity "
                             "(it sets the direction; its length is scaled to n_dof k_B T / 2)")
        two_kinetic = n_dof * kT
        v *= np.sqrt(two_kinetic / mv2)
    return _run(system, K, masses, x, v, dt, n_steps, force_function, thermostat, scheme, record_every, kT,
                two_kinetic, n_records)


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
         v: NDArray[np.float64], dt: float, n_steps: int, force_function: Any, thermostat: Any, scheme: Scheme,
         record_every: int, kT: float, two_kinetic: float, n_records: int) -> Trajectory:
    n_dof = x.size
    kind, Q, labels = _thermostat_arrays(thermostat, kT, n_dof)
    chain = Q.size
    xi, eta = np.zeros(chain), np.zeros(chain)
    rec_x = np.empty((n_records, n_dof))
    rec_v = np.empty((n_records, n_dof))
    rec_state = np.zeros((n_records, 2 * chain))
    drifts = scheme.weights if kind == kernels.NOSE_HOOVER else scheme.drifts
    compiled = force_function is None or isinstance(force_function, BondForces)
    if compiled:
        first, second, k, alpha, beta, rest = _bond_arrays(system, K, force_function)
        ghost = np.append(x, 0.0)                      # the wall: a ghost dof at rest
        kernels.run(ghost, v, masses, rest.indptr.astype(np.int64), rest.indices.astype(np.int64),
                    np.asarray(rest.data, dtype=np.float64), first, second, k, alpha, beta, scheme.kicks, drifts,
                    kind, kT, float(n_dof), Q, xi, eta, two_kinetic, dt, n_steps, record_every, rec_x, rec_v,
                    rec_state)
    else:
        _python_loop(K, masses, x, v, force_function, scheme.kicks, drifts, kind, kT, n_dof, Q, xi, eta,
                     two_kinetic, dt, n_steps, record_every, rec_x, rec_v, rec_state)
    kinetic = 0.5 * np.sum(masses * rec_v * rec_v, axis=1)
    potential = 0.5 * np.einsum("ij,ij->i", rec_x, (K @ rec_x.T).T)
    if force_function is not None:
        if isinstance(force_function, BondForces):
            potential = potential + force_function.potentials(rec_x)
        elif callable(getattr(force_function, "potential", None)):
            potential = potential + np.array([float(force_function.potential(row)) for row in rec_x])
        else:
            potential = np.full(n_records, np.nan)
    if kind == kernels.ISOKINETIC:
        total_force = -(K @ rec_x.T).T
        if force_function is not None:
            total_force += np.array([np.asarray(force_function(row), dtype=float) for row in rec_x])
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
                      dt=dt, integrator=scheme.name, compiled=compiled, units=system.units)


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
                 rec_v: NDArray[np.float64], rec_state: NDArray[np.float64]) -> None:
    """The steps of `kernels.run` in Python, for a force function numba cannot call."""
    chain = Q.size

    def total_force() -> NDArray[np.float64]:
        return -(K @ x) + np.asarray(force_function(x.copy()), dtype=float)

    def kick(force: NDArray[np.float64], h: float) -> None:
        if kind == kernels.ISOKINETIC:
            kernels.isokinetic_kick(v, force, masses, h, two_kinetic)
        else:
            v[:] += h * force / masses

    force = total_force()
    rec_x[0], rec_v[0] = x, v
    rec_state[0, :chain], rec_state[0, chain:] = xi, eta
    row = 0
    for step in range(1, n_steps + 1):
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
        if step % record_every == 0:
            row += 1
            rec_x[row], rec_v[row] = x, v
            rec_state[row, :chain], rec_state[row, chain:] = xi, eta
