"""The steps of a dynamics scene: integrate the system, then chart what the runs recorded.

A dynamics scene (``kind = "dynamics"``, keys in `vibra.pipeline.scene.dynamics`) builds a
harmonic `System` or an FPUT chain and runs `vibra.dynamics.integrate` once per Nosé-Hoover
chain length of ``compute.chain`` (once without one). The run step also keeps the lowest normal
modes of the harmonic part (the report's frequency table) and reports each run's
`Trajectory.conserved_drift`. The charts draw only what the library computed:

- ``chart-mode-energies``: `Trajectory.mode_energies` of the lowest modes against time;
- ``chart-energies``: `Trajectory.kinetic`, `potential`, `conserved` and the thermostat's
  variable (``mu`` beside the seed's closed form -(K x).v / (n_dof k_B T) for a harmonic
  system, or ``xi1``) against time;
- ``chart-histogram``: the positions of one dof against the Boltzmann Gaussian of variance
  k_B T (K^-1)_ii, with the Kolmogorov-Smirnov distance (`scipy.stats.kstest`).

`check_dynamics_plan` is what ``vibra validate`` checks on the built system (the stable time
step from omega_max, the initial state's length, a rigid mode under the histogram), and
`dynamics_cost` the line it prints. `KIND` declares all of it for the dynamics scene kind
(`vibra.pipeline.plan.kinds`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from vibra._core.validate import ArgumentError
from vibra.pipeline.plan.checks import refused_as
from vibra.pipeline.plan.model import Plan, PlanKind, Step, build_step
from vibra.pipeline.scene import Scene, SceneError
from vibra.pipeline.scene.dynamics import THERMOSTATS
from vibra.pipeline.scene.limits import DEFAULT_TIME_LIMIT_S, dynamics_estimate
from vibra.solvers.budget import ResourceLimitError, describe_bytes, describe_seconds
from vibra.sources import cite
from vibra._core.text import counted

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from vibra.dynamics import BondForces, Trajectory
    from vibra.modes import Modes
    from vibra.system import System

__all__ = ["check_dynamics_plan", "dynamics_cost", "DynamicsRuns", "DYNAMICS_STEPS", "DYNAMICS_STEP_KEYS",
           "anharmonic_forces", "initial_state", "dynamics_steps", "dynamics_plan", "KIND"]

#: How many of the lowest normal modes the report's table lists when the run needs none.
TABLE_MODES = 6
#: The estimated cost (`vibra.solvers.budget`) beyond which that table is left out.
TABLE_LIMITS = {"max_seconds": 1.0, "max_memory": 2.0**28}
#: step name -> the scene key that controls it.
DYNAMICS_STEP_KEYS = {"dynamics-run": "compute", "chart-mode-energies": "draw.mode_energies",
                      "chart-energies": "draw.energies", "chart-histogram": "draw.histogram"}


@dataclass(frozen=True, eq=False)
class DynamicsRuns:
    """What the run step computed for the charts.

    Attributes
    ----------
    labels : tuple of str
        One label per run (``"Nosé-Hoover chain of 4"``, ``"isokinetic"``, ...).
    runs : tuple of Trajectory
        The trajectories, in the order of ``compute.chain``.
    modes : Modes or None
        The lowest normal modes of the harmonic part (with vectors), for the mode energies and
        the initial mode.
    kT : float
        k_B T of the thermostat, in the energy unit (0 without one).
    """

    labels: tuple[str, ...]
    runs: tuple[Trajectory, ...]
    modes: Modes | None
    kT: float


def anharmonic_forces(scene: Scene) -> BondForces | None:
    """The anharmonic `vibra.dynamics.BondForces` of an FPUT scene (None for a harmonic system)."""
    if scene.system.builder != "fput":
        return None
    from vibra.dynamics import fput

    p = scene.system.parameters
    if p["alpha"] == 0 and p["beta"] == 0:
        return None
    _, forces = fput(p["n"], alpha=p["alpha"], beta=p["beta"], ends=p["ends"], mass=p["mass"],
                     stiffness=p["stiffness"], units=scene.units)
    return forces


def _wanted_modes(scene: Scene) -> int:
    spec = scene.dynamics
    assert spec is not None
    return max(spec.n_modes_drawn if spec.mode_energies else 0, spec.mode or 0)


def initial_state(scene: Scene, system: System, modes: Modes | None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(x0, v0) of the scene: its lists, or ``compute.energy`` put into ``compute.mode`` as a displacement
    x0 = q d_k with omega_k^2 q^2 / 2 = energy (shapes are M-orthonormal), v0 = 0.

    Raises
    ------
    SceneError
        The mode is a rigid one (omega = 0: no displacement holds a finite energy).
    """
    spec = scene.dynamics
    assert spec is not None
    n_dof = system.n_dof
    if spec.mode is None:
        x0 = np.zeros(n_dof) if spec.x0 is None else np.asarray(spec.x0, dtype=float)
        v0 = np.zeros(n_dof) if spec.v0 is None else np.asarray(spec.v0, dtype=float)
        return x0, v0
    omega = float(modes.omega[spec.mode - 1])
    if not omega > 1e-8 * float(np.max(np.abs(modes.omega))):
        raise SceneError(scene.source, "compute.mode", f"is {spec.mode}, a rigid mode (omega = {omega:.3g}); "
                         "choose a vibrating mode, or hold the system (fixed ends)")
    amplitude = np.sqrt(2.0 * spec.energy) / omega
    return amplitude * np.asarray(modes.shapes[:, spec.mode - 1]), np.zeros(n_dof)


def check_dynamics_plan(scene: Scene, system: System) -> None:
    """What the dynamics steps would refuse, checked on the built system (nothing integrated).

    Raises
    ------
    SceneError
        ``compute.dt`` unstable for the highest normal frequency (the message gives the stable
        bound), ``compute.x0`` / ``compute.v0`` of the wrong length, ``compute.mode`` beyond the
        system's modes or a rigid one, ``draw.histogram_dof`` beyond the dofs, a histogram of a
        system with a rigid mode (its positions have no Boltzmann distribution).
    """
    from vibra.dynamics import STABLE_OMEGA_DT, highest_omega, stable_dt

    spec = scene.dynamics
    assert spec is not None
    n_dof = system.n_dof
    for key in ("x0", "v0"):
        value = getattr(spec, key)
        if value is not None and len(value) != n_dof:
            raise SceneError(scene.source, f"compute.{key}", f"needs {counted(n_dof, 'value')} (one per free "
                             f"degree of freedom), got {len(value)}")
    if spec.mode is not None and spec.mode > n_dof:
        raise SceneError(scene.source, "compute.mode", f"is {spec.mode}; the system has {counted(n_dof, 'mode')} (1 to {n_dof})")
    if spec.histogram and spec.histogram_dof >= n_dof:
        raise SceneError(scene.source, "draw.histogram_dof", f"is {spec.histogram_dof}; degrees of freedom run "
                         f"from 0 to {n_dof - 1}")
    omega_max = highest_omega(system.hessian().tocsr(), system.mass_matrix())
    if omega_max * spec.dt >= STABLE_OMEGA_DT[spec.integrator]:
        bound = stable_dt(omega_max, spec.integrator)
        raise SceneError(scene.source, "compute.dt", f"is {spec.dt:g}, unstable for the highest normal frequency "
                         f"omega_max = {omega_max:.6g} {system.units.omega}: {spec.integrator} is stable for dt < "
                         f"{STABLE_OMEGA_DT[spec.integrator]:.4g} / omega_max = {bound:.6g} (a step of a twentieth "
                         f"of the shortest period, {np.pi / (10 * omega_max):.3g}, keeps the energy accurate)")
    thermostat, _ = _thermostat(scene, 1)  # the scale does not depend on the chain
    if thermostat is not None:  # k_B T or the Nosé-Hoover masses within floating point, as the run checks
        from vibra.dynamics.integrate import check_thermostat_scale

        try:
            check_thermostat_scale(thermostat, system.units.boltzmann * spec.temperature, n_dof, system.units.energy)
        except ArgumentError as error:
            raise _thermostat_error(scene, error) from None
    if spec.histogram or spec.mode is not None:
        lowest = np.asarray(system.modes(max(1, spec.mode or 1), vectors=False).omega)
        rigid = np.abs(lowest) <= 1e-8 * omega_max
        if spec.histogram and rigid[0]:
            raise SceneError(scene.source, "draw.histogram", "the system has a rigid mode (omega = 0), along which "
                             "positions have no Boltzmann distribution; hold it (fixed ends, anchors)")
        if spec.mode is not None and rigid[spec.mode - 1]:
            raise SceneError(scene.source, "compute.mode", f"is {spec.mode}, a rigid mode (omega = 0); choose a "
                             "vibrating mode, or hold the system (fixed ends)")


def _thermostat_error(scene: Scene, error: ArgumentError) -> SceneError:
    """A thermostat's scale refusal at its scene key (``thermostat.tau`` -> ``compute.tau``)."""
    key = {"thermostat.tau": "compute.tau"}.get(error.argument, "compute.temperature")
    return SceneError(scene.source, key, str(error).split(": ", 1)[1])


def dynamics_cost(scene: Scene, system: System) -> str:
    """The size of a dynamics scene and the work it asks for, in one line (``vibra validate``)."""
    spec = scene.dynamics
    assert spec is not None
    estimate = dynamics_estimate(system.n_dof, spec)
    runs, dofs = counted(spec.n_runs, "run"), counted(system.n_dof, "dof")
    return (f"{dofs}; {runs} of {spec.n_steps} {spec.integrator} steps of dt = {spec.dt:g} "
            f"({THERMOSTATS[spec.thermostat]}), {estimate.records} records each; estimated "
            f"~{describe_seconds(estimate.seconds)} and {describe_bytes(estimate.memory)}")


# ---------------------------------------------------------------------- steps
def _thermostat(scene: Scene, chain: int) -> tuple[Any, str]:
    from vibra import dynamics

    spec = scene.dynamics
    assert spec is not None
    if spec.thermostat == "isokinetic":
        return dynamics.Isokinetic(spec.temperature), "isokinetic (Gauss)"
    if spec.thermostat == "nose-hoover":
        label = "one Nosé-Hoover thermostat" if chain == 1 else f"Nosé-Hoover chain of {chain}"
        return dynamics.NoseHoover(spec.temperature, spec.tau, chain=chain), label
    return None, "no thermostat"


def _table_modes(system: System) -> Modes | None:
    """The lowest `TABLE_MODES` normal modes (no shapes) for the report's table, or None when the solver
    registry estimates them beyond `TABLE_LIMITS` (the table is left out rather than the run slowed)."""
    try:
        return system.modes(min(system.n_dof, TABLE_MODES), vectors=False, **TABLE_LIMITS)
    except ResourceLimitError:
        return None


def _step_run(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra import dynamics

    scene, system = plan.scene, context.system
    spec = scene.dynamics
    wanted = _wanted_modes(scene)
    modes = system.modes(wanted) if wanted else None
    context.modes = modes if modes is not None else _table_modes(system)
    x0, v0 = initial_state(scene, system, modes)
    forces = anharmonic_forces(scene)
    labels, runs = [], []
    time_limit = DEFAULT_TIME_LIMIT_S if spec.time_limit_s is None else spec.time_limit_s   # checked at validate
    for chain in spec.chains:
        thermostat, label = _thermostat(scene, chain)
        try:
            run = dynamics.integrate(system, x0, v0, spec.dt, spec.n_steps, forces=forces, thermostat=thermostat,
                                     integrator=spec.integrator, record_every=spec.record_every,
                                     max_seconds=time_limit, drift_tolerance=float("inf"))   # reported below
        except dynamics.IntegrationError as error:
            way_out = ("an anharmonic potential with alpha or beta != 0 is unbounded (a large amplitude escapes it, or "
                       "a large dt does): lower compute.energy (or x0, v0), system.alpha, or compute.dt"
                       if forces is not None else "lower compute.dt, or bring compute.temperature and compute.tau "
                       "to the system's energies and periods")
            raise SceneError(scene.source, "compute", f"the run ({label}) diverged: its state left the finite "
                             f"numbers at step {error.step} (t = {error.time:.4g}); {way_out}") from error
        except ArgumentError as error:                # k_B T or the Nosé-Hoover masses beyond floating point
            raise _thermostat_error(scene, error) from error
        runs.append(run)
        labels.append(label)
    kT = 0.0 if spec.temperature is None else system.units.boltzmann * spec.temperature
    context.dynamics = DynamicsRuns(labels=tuple(labels), runs=tuple(runs), modes=modes, kT=kT)
    drifts = [run.conserved_drift() for run in runs]
    what = "kinetic energy" if spec.thermostat == "isokinetic" else (
        "extended energy" if spec.thermostat == "nose-hoover" else "energy")
    values = f"{drifts[0]:.2e}" if len(runs) == 1 else ", ".join(
        f"{drift:.2e} ({label})" for label, drift in zip(labels, drifts))
    how = f"{runs[0].integrator}, {'compiled' if runs[0].compiled else 'Python'} loop"
    if any(drift > dynamics.DRIFT_TOLERANCE for drift in drifts):
        return how, (f"largest relative change of the {what}: {values}, beyond the library's tolerance "
                     f"{dynamics.DRIFT_TOLERANCE:g} (vibra.dynamics.DRIFT_TOLERANCE): lower compute.dt")
    return how, f"largest relative change of the {what}: {values}"


def mode_energy_lines(runs: DynamicsRuns) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(t, (n_records, n_modes) energies) of the first run in each computed mode (`Trajectory.mode_energies`)."""
    run = runs.runs[0]
    return run.t, run.mode_energies(runs.modes)


def _step_chart_mode_energies(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.dynamics import plot_mode_energies

    scene, runs = plan.scene, context.dynamics
    spec = scene.dynamics
    t, every = mode_energy_lines(runs)
    energies = every[:, :spec.n_modes_drawn]
    total = float(np.asarray(runs.runs[0].energy)[0])
    figure = plot_mode_energies(t, energies, total=total, units=context.system.units, title=scene.title)
    start = f"all of it in mode {spec.mode} at t = 0" if spec.mode is not None else "the scene's x0, v0"
    recurrence = ""
    if spec.mode is not None and total > 0:
        share = every[:, spec.mode - 1] / total
        gone = int(np.argmax(share < 0.5)) if np.any(share < 0.5) else None
        if gone is not None and np.any(share[gone:] > 0.8):
            back = gone + int(np.argmax(share[gone:] > 0.8))
            after = share[back:]
            leave = back + (int(np.argmax(after < 0.5)) if np.any(after < 0.5) else after.size)
            peak = back + int(np.argmax(share[back:leave]))
            recurrence = (f"; mode {spec.mode} gets back {100 * share[peak]:.1f} % of the energy at "
                          f"t = {t[peak]:.4g} (the recurrence)")
    context.save_chart(figure, "mode_energies",
                       f"{scene.title}: energy in each of the lowest {energies.shape[1]} normal modes of the harmonic "
                       f"part against time (E_k = (q'_k^2 + omega_k^2 q_k^2) / 2, {cite('003')}, eq. 149), {start}"
                       + recurrence)
    return None, recurrence.lstrip("; ") or None


def isokinetic_closed_form(run: Trajectory, system: System, kT: float) -> NDArray[np.float64]:
    """(n_records,) the seed's friction mu = -(K x).v / (n_dof k_B T) of a harmonic system under the
    isokinetic constraint (Kneller, Mécanique analytique, §4.2 example 10: -K (r.r') / (3 k_B T) in 3-D), in 1 / time unit."""
    K = system.hessian().tocsr()
    x, v = np.asarray(run.positions), np.asarray(run.velocities)
    return -np.sum((K @ x.T).T * v, axis=1) / (x.shape[1] * kT)


def _step_chart_energies(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.dynamics import plot_energies

    scene, runs = plan.scene, context.dynamics
    spec = scene.dynamics
    run = runs.runs[-1]
    label, reference, note = None, None, ""
    if spec.thermostat == "isokinetic":
        label = "mu"
        if anharmonic_forces(scene) is None:
            reference = isokinetic_closed_form(run, context.system, runs.kT)
            gap = float(np.max(np.abs(reference - run.state("mu"))))
            note = (f"; mu beside the closed form -(K x).v / (n_dof k_B T) ({cite('003')}, §4.2, example 10), "
                    f"largest difference {gap:.2g}")
    elif spec.thermostat == "nose-hoover":
        label = "xi1"
    target = None if spec.thermostat != "isokinetic" else 0.5 * run.positions.shape[1] * runs.kT
    heading = scene.title if spec.n_runs == 1 else f"{scene.title}: {runs.labels[-1]}"
    figure = plot_energies(run, label, reference=reference, target_kinetic=target, title=heading)
    context.save_chart(figure, "energies",
                       f"{scene.title}, {runs.labels[-1]}: kinetic, potential and conserved energy against time"
                       + (f", and the thermostat variable {label}" if label else "") + note)
    return None, None


def position_histograms(runs: DynamicsRuns, system: System, dof: int
                        ) -> tuple[tuple[NDArray[np.float64], ...], float, tuple[float, ...]]:
    """The samples of dof `dof` of each run (the initial state left out), the Boltzmann standard
    deviation sqrt(k_B T (K^-1)_ii) in the length unit, and each run's Kolmogorov-Smirnov distance
    to that Gaussian (`scipy.stats.kstest`; successive records are correlated, so read D, not a p-value)."""
    from scipy import stats
    from scipy.sparse.linalg import spsolve

    K = system.hessian().tocsc()
    unit = np.zeros(K.shape[0])
    unit[dof] = 1.0
    sigma = float(np.sqrt(runs.kT * np.atleast_1d(spsolve(K, unit))[dof]))
    samples = tuple(np.asarray(run.positions[1:, dof]) for run in runs.runs)
    distances = tuple(float(stats.kstest(s / sigma, "norm").statistic) for s in samples)
    return samples, sigma, distances


def _step_chart_histogram(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.dynamics import plot_position_histograms

    scene, runs = plan.scene, context.dynamics
    spec = scene.dynamics
    samples, sigma, distances = position_histograms(runs, context.system, spec.histogram_dof)
    figure = plot_position_histograms(samples, runs.labels, sigma, distances, bins=spec.bins,
                                      units=context.system.units, title=scene.title)
    verdicts = ", ".join(f"{label}: D = {d:.3f}" for label, d in zip(runs.labels, distances))
    context.save_chart(figure, "histogram",
                       f"{scene.title}: positions of dof {spec.histogram_dof} over each run against the Boltzmann "
                       f"distribution exp(-x^2 / 2 sigma^2), sigma^2 = k_B T (K^-1)_ii = {sigma**2:.4g}; "
                       f"Kolmogorov-Smirnov distance {verdicts}")
    return "scipy.stats.kstest", verdicts


#: step name -> the function that runs it (joined to `vibra.pipeline.plan.steps.STEPS`).
DYNAMICS_STEPS: dict[str, Callable[[Plan, Any, Any], tuple[str | None, str | None]]] = {
    "dynamics-run": _step_run,
    "chart-mode-energies": _step_chart_mode_energies,
    "chart-energies": _step_chart_energies,
    "chart-histogram": _step_chart_histogram,
}


def dynamics_steps(scene: Scene) -> list[Step]:
    """The steps after ``build`` that a dynamics scene asks for."""
    spec = scene.dynamics
    assert spec is not None
    thermostat = {"none": "no thermostat", "isokinetic": "the isokinetic constraint",
                  "nose-hoover": "Nosé-Hoover chain(s) of " + ", ".join(str(c) for c in spec.chains)}[spec.thermostat]
    start = f"energy {spec.energy:g} in mode {spec.mode}" if spec.mode is not None else "x0, v0 of the scene"
    steps = [Step("dynamics-run", f"{spec.n_steps} {spec.integrator} steps of dt = {spec.dt:g} with {thermostat}, "
                  f"from {start}, one state in {spec.record_every} recorded")]
    if spec.mode_energies:
        steps.append(Step("chart-mode-energies", f"energy of the lowest {spec.n_modes_drawn} normal modes against time"))
    if spec.energies:
        steps.append(Step("chart-energies", "kinetic, potential and conserved energy and the thermostat variable "
                          "against time"))
    if spec.histogram:
        steps.append(Step("chart-histogram", f"positions of dof {spec.histogram_dof} against the Boltzmann "
                          "distribution"))
    return steps


def dynamics_plan(scene: Scene) -> Plan:
    """A dynamics scene's plan: a time integration, its own steps and charts."""
    return Plan(scene=scene, steps=(build_step(scene), *dynamics_steps(scene)), n_modes=None, vectors=False)


#: The dynamics scene kind: what it plans, checks, prints and runs.
KIND = PlanKind("dynamics", plan=dynamics_plan,
                check=refused_as("dynamics-run", check_dynamics_plan, keys=DYNAMICS_STEP_KEYS),
                summary=dynamics_cost, build_note=dynamics_cost,
                steps=DYNAMICS_STEPS, step_keys=DYNAMICS_STEP_KEYS)
