"""The ``[compute]`` and ``[draw]`` tables of a dynamics scene (``kind = "dynamics"``).

A dynamics scene builds a harmonic `System` (``linear_chain``, ``springs``) or an FPUT chain
(``fput``: the harmonic chain and its anharmonic bond forces) and integrates it with
`vibra.dynamics.integrate`, with or without a thermostat, then charts what the run recorded:

- ``draw.mode_energies``: energy per normal mode against time (Kneller, Mécanique analytique, eq. 149; FPUT's
  recurrence when the energy starts in one mode);
- ``draw.energies``: kinetic, potential and conserved energy against time, with the
  thermostat's variable (the isokinetic friction mu, or the first Nosé-Hoover xi);
- ``draw.histogram``: the histogram of one coordinate against its Boltzmann distribution
  (one run per entry of ``compute.chain``: a single Nosé-Hoover thermostat against a chain).

Everything here is checked before anything is built; what needs the built system (the stable
time step from omega_max, the lengths of ``x0`` / ``v0`` after freezing) is checked by
`vibra.pipeline.plan.dynamics.check_dynamics_plan`, which ``vibra validate`` runs too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from vibra.pipeline.scene.limits import (
    DEFAULT_TIME_LIMIT_S, MAX_DYNAMICS_STEPS, default_memory_limit, dynamics_estimate, gib, n_dof_bound,
)
from vibra._core.cache import remembered
from vibra._core.text import counted
from vibra.pipeline.scene.specs import DrawSpec
from vibra.pipeline.scene.values import (
    boolean, field_spec, integer, list_of, number, one_of, positive, scalar_or_list,
)

if TYPE_CHECKING:  # (a `Scene` is typed Any here: the scene package imports this module)
    from vibra.pipeline.scene.schema import Reader

__all__ = ["DynamicsSpec", "THERMOSTATS", "parse_dynamics", "check_dynamics"]

#: ``compute.thermostat`` -> what it is (`vibra.dynamics.Isokinetic`, `vibra.dynamics.NoseHoover`).
THERMOSTATS = {"none": "energy-conserving dynamics", "isokinetic": "Gauss's isokinetic constraint",
               "nose-hoover": "a Nosé-Hoover thermostat or chain"}
#: Records a run keeps by default (``compute.record_every`` follows from n_steps).
DEFAULT_RECORDS = 2000


@dataclass(frozen=True)
class DynamicsSpec:
    """What a dynamics scene integrates and draws.

    Attributes
    ----------
    dt : float
        Time step, in the scene's time unit (stable for the highest frequency: checked on the
        built system).
    n_steps : int
        Steps of each run.
    record_every : int
        A state is recorded every this many steps (the initial state always).
    integrator : str
        A key of `vibra.dynamics.INTEGRATORS`.
    thermostat : str
        A key of `THERMOSTATS`.
    temperature : float or None
        T in K (SI, ASE) or k_B T (dimensionless); required with a thermostat.
    tau : float
        Nosé-Hoover time scale, in the time unit.
    chains : tuple of int
        Nosé-Hoover chain lengths, one run each (``(1,)`` without a Nosé-Hoover thermostat).
    x0, v0 : tuple of float or None
        Initial displacements and velocities, one per free dof (None: zeros).
    mode : int or None
        1-based normal mode that starts with all the energy (FPUT's initial condition), as a
        displacement; None when x0 / v0 are given.
    energy : float
        Energy put into `mode`, in the energy unit.
    mode_energies, energies, histogram : bool
        The charts drawn.
    n_modes_drawn : int
        Modes shown in the mode-energy chart (the lowest ones).
    histogram_dof : int
        The free dof whose positions the histogram shows.
    bins : int
        Bins of the histogram.
    """

    dt: float
    n_steps: int
    record_every: int
    integrator: str = "verlet"
    thermostat: str = "none"
    temperature: float | None = None
    tau: float = 1.0
    chains: tuple[int, ...] = (1,)
    x0: tuple[float, ...] | None = None
    v0: tuple[float, ...] | None = None
    mode: int | None = None
    energy: float = 1.0
    mode_energies: bool = False
    energies: bool = False
    histogram: bool = False
    n_modes_drawn: int = 4
    histogram_dof: int = 0
    bins: int = 60
    memory_limit_gib: float | None = None
    time_limit_s: float | None = None

    @property
    def n_runs(self) -> int:
        """Trajectories the scene integrates (one per Nosé-Hoover chain length)."""
        return len(self.chains)


def _integrators() -> tuple[str, ...]:
    """`vibra.dynamics.INTEGRATORS`, read once per version of vibra's sources (`vibra._core.cache.remembered`):
    importing vibra.dynamics loads numba (1 s), which a scene refused for a misspelt key should not wait for."""
    def derive() -> list[str]:
        from vibra.dynamics import INTEGRATORS

        return list(INTEGRATORS)

    return tuple(remembered("dynamics integrators", derive))


def parse_dynamics(reader: Reader, compute: Any, draw: Any) -> tuple[DrawSpec, DynamicsSpec]:
    """The ``[compute]`` and ``[draw]`` tables of a dynamics scene."""
    c = reader.table(compute, "compute", {
        "dt": field_spec(positive, required=True),
        "n_steps": field_spec(integer(1, MAX_DYNAMICS_STEPS), required=True),
        "record_every": field_spec(integer(1)),
        "integrator": field_spec(one_of(*_integrators()), "verlet"),
        "thermostat": field_spec(one_of(*THERMOSTATS), "none"),
        "temperature": field_spec(positive),
        "tau": field_spec(positive),
        "chain": field_spec(scalar_or_list(integer(1, 64))),
        "x0": field_spec(list_of(number)),
        "v0": field_spec(list_of(number)),
        "mode": field_spec(integer(1)),
        "energy": field_spec(positive),
        "memory_limit_gib": field_spec(positive),
        "time_limit_s": field_spec(positive),
    })
    d = reader.table(draw, "draw", {
        "mode_energies": field_spec(boolean, False),
        "energies": field_spec(boolean, False),
        "histogram": field_spec(boolean, False),
        "n_modes_drawn": field_spec(integer(1, 64), 4),
        "histogram_dof": field_spec(integer(0), 0),
        "bins": field_spec(integer(5, 1000), 60),
        "window_size": field_spec(list_of(integer(64, 4096), length=2), (1024, 640)),
    })
    thermostat = c["thermostat"]
    if thermostat == "none":
        for key in ("temperature", "tau", "chain"):
            if c[key] is not None:
                reader.fail(f"compute.{key}", "applies with a thermostat only; set compute.thermostat = "
                            "\"isokinetic\" or \"nose-hoover\", or remove it")
    else:
        if c["temperature"] is None:
            reader.fail("compute.temperature", f"is required with thermostat = {thermostat!r} (in K, or k_B T "
                        "for a dimensionless scene)")
        if thermostat == "isokinetic":
            for key in ("tau", "chain"):
                if c[key] is not None:
                    reader.fail(f"compute.{key}", "applies to the Nosé-Hoover thermostat only; the isokinetic "
                                "constraint has no time scale or chain")
    chains = c["chain"] if isinstance(c["chain"], tuple) else (c["chain"] or 1,)
    if thermostat == "nose-hoover" and c["integrator"] == "blanes-moan":
        reader.fail("compute.integrator", "'blanes-moan' splits two flows only; a Nosé-Hoover thermostat runs "
                    "with 'verlet' or 'yoshida4'")
    if c["mode"] is not None and (c["x0"] is not None or c["v0"] is not None):
        reader.fail("compute.mode", "give the initial state as mode (with energy) or as x0 / v0, not both")
    if c["energy"] is not None and c["mode"] is None:
        reader.fail("compute.energy", "is the energy put into compute.mode; give mode = k too, or remove it")
    if c["mode"] is None and c["x0"] is None and c["v0"] is None:
        reader.fail("compute", "has no initial state: give mode = k (with energy) or x0 / v0 (one value per "
                    "degree of freedom)")
    if thermostat == "isokinetic" and (c["v0"] is None or not any(c["v0"])):
        reader.fail("compute.v0", "is zero or missing; the isokinetic constraint needs a nonzero initial velocity "
                    "(it sets the direction, scaled to n_dof k_B T / 2)")
    if not (d["mode_energies"] or d["energies"] or d["histogram"]):
        reader.fail("draw", "a dynamics scene draws nothing: set draw.mode_energies, draw.energies or "
                    "draw.histogram to true")
    if d["histogram"] and thermostat == "none":
        reader.fail("draw.histogram", "compares positions with the Boltzmann distribution at the thermostat's "
                    "temperature; set compute.thermostat = \"nose-hoover\" (or \"isokinetic\")")
    record_every = c["record_every"] or max(1, c["n_steps"] // DEFAULT_RECORDS)
    if record_every > c["n_steps"]:
        reader.fail("compute.record_every", f"is {record_every}, more than n_steps = {c['n_steps']}; nothing "
                    "would be recorded after the initial state")
    spec = DynamicsSpec(
        dt=c["dt"], n_steps=c["n_steps"], record_every=record_every, integrator=c["integrator"],
        thermostat=thermostat, temperature=c["temperature"], tau=c["tau"] or 1.0, chains=chains,
        x0=c["x0"], v0=c["v0"], mode=c["mode"], energy=c["energy"] or 1.0, mode_energies=d["mode_energies"],
        energies=d["energies"], histogram=d["histogram"], n_modes_drawn=d["n_modes_drawn"],
        histogram_dof=d["histogram_dof"], bins=d["bins"], memory_limit_gib=c["memory_limit_gib"],
        time_limit_s=c["time_limit_s"])
    return DrawSpec(window_size=d["window_size"]), spec


def check_dynamics(reader: Reader, scene: Any) -> None:
    """What a dynamics scene's keys must agree on before anything is built: the initial state's
    length, the mode numbers, anharmonic forces with the histogram, and the memory and time of
    the runs (`vibra.pipeline.scene.limits.dynamics_estimate`)."""
    spec, builder, params = scene.dynamics, scene.system.builder, scene.system.parameters
    if spec.histogram and builder == "fput" and (params["alpha"] != 0 or params["beta"] != 0):
        reader.fail("draw.histogram", "compares with the Gaussian Boltzmann distribution of a harmonic system; "
                    "this FPUT chain has alpha or beta nonzero (set both to 0, or draw.histogram = false)")
    n_dof = n_dof_bound(builder, params)
    if n_dof is None:
        return
    frozen = builder != "fput" and bool(params.get("frozen_sites") or params.get("frozen_dofs"))
    if not frozen:  # (with frozen dofs the count is checked on the built system)
        for key in ("x0", "v0"):
            value = getattr(spec, key)
            if value is not None and len(value) != n_dof:
                reader.fail(f"compute.{key}", f"needs {n_dof} values (one per degree of freedom), got {len(value)}")
        if spec.mode is not None and spec.mode > n_dof:
            reader.fail("compute.mode", f"is {spec.mode}; the system has {counted(n_dof, 'mode')} (1 to {n_dof})")
        if spec.histogram_dof >= n_dof:
            reader.fail("draw.histogram_dof", f"is {spec.histogram_dof}; degrees of freedom run from 0 to {n_dof - 1}")
    if spec.mode_energies and spec.n_modes_drawn > n_dof:
        reader.fail("draw.n_modes_drawn", f"is {spec.n_modes_drawn}; the system has {counted(n_dof, 'mode')}")
    estimate = dynamics_estimate(n_dof, spec)
    limit = default_memory_limit() if spec.memory_limit_gib is None else spec.memory_limit_gib * 2**30
    if estimate.memory > limit:
        reader.fail("compute.record_every", f"the recorded states would need about {gib(estimate.memory)}, more "
                    f"than the limit of {gib(limit)}; raise compute.record_every, or compute.memory_limit_gib")
    time_limit = DEFAULT_TIME_LIMIT_S if spec.time_limit_s is None else spec.time_limit_s
    if estimate.seconds > time_limit:
        reader.fail("compute.n_steps", f"is {spec.n_steps}: {counted(spec.n_runs, 'run')} of {counted(n_dof, 'dof')} would take about "
                    f"{estimate.seconds:.2g} s, more than the limit of {time_limit:g} s; take fewer steps, or raise "
                    "compute.time_limit_s")
