"""How much memory (and time) a scene would take, estimated from its parameters before anything is built.

`vibra validate` and `vibra report` refuse a scene whose estimate exceeds its memory limit
(``compute.memory_limit_gib``; by default half of this machine's physical memory) before any
array is allocated, saying what it would take and the cheaper request that answers the
question (``n_modes``, no shapes, fewer response points). The figures are upper bounds of the
arrays the plan keeps (float64, 8 bytes a number), not of the solvers' small workspaces.
Likewise a request for all modes of a large system, O(N^2) work at least, is refused when its
estimate exceeds ``compute.time_limit_s`` (default `DEFAULT_TIME_LIMIT_S`): the solver registry's
cost (`vibra.solvers.registry`) of the cheapest all-modes solve a system of N dofs can have, a
chain's, at the scene's accuracy (`all_modes_seconds`); the built system's own solve is planned
and guarded with the same cost functions and limits (`vibra.pipeline.plan.checks`).

>>> from types import MappingProxyType
>>> sites_and_dim("linear_chain", MappingProxyType({"n": 10}))
(10, 1)
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

from vibra.solvers.accuracy import TIME_LIMIT_S

if TYPE_CHECKING:
    from vibra.pipeline.scene.specs import ComputeSpec, DrawSpec
# (a `DynamicsSpec` is typed Any here: vibra.pipeline.scene.dynamics imports this module)

__all__ = ["MAX_DYNAMICS_STEPS", "DynamicsEstimate", "dynamics_estimate", "BYTES_PER_DOF", "DEFAULT_TIME_LIMIT_S", "render_seconds", "frames_that_fit",
           "RENDER_SECONDS_PER_ATOM_FRAME", "RENDER_SECONDS_FIXED", "sites_and_dim", "n_dof_bound",
           "default_memory_limit", "MemoryEstimate", "memory_estimate", "all_modes_seconds", "gib"]

#: Bytes a built system keeps per degree of freedom (positions, masses, sparse K and M, spring factor).
BYTES_PER_DOF = 512
#: Longest estimated solve a scene may ask for without ``compute.time_limit_s``, in s: the library's
#: own limit (`vibra.solvers.accuracy.TIME_LIMIT_S`), one decision.
DEFAULT_TIME_LIMIT_S = TIME_LIMIT_S

#: An off-screen mode animation (pyvista, a sphere per atom per frame, then the GIF): seconds per
#: atom and frame, and the fixed part (the plotter, the file), from solid argon's 32 atoms x 16
#: frames (3.9 s) and 1,372 atoms x 48 frames (61.6 s) on the shared 2-core machine.
RENDER_SECONDS_PER_ATOM_FRAME = 9e-4
RENDER_SECONDS_FIXED = 3.5


def render_seconds(atoms: int, frames: int) -> float:
    """Estimated seconds to render a mode animation of `atoms` atoms over `frames` frames."""
    return RENDER_SECONDS_FIXED + RENDER_SECONDS_PER_ATOM_FRAME * atoms * frames


def frames_that_fit(atoms: int, seconds: float) -> int:
    """The most frames of `atoms` atoms that `render_seconds` puts within `seconds` (0 if none)."""
    return max(0, int((seconds - RENDER_SECONDS_FIXED) / (RENDER_SECONDS_PER_ATOM_FRAME * max(1, atoms))))


def sites_and_dim(builder: str, p: Mapping[str, Any]) -> tuple[int, int] | None:
    """(number of sites, coordinates per site) of a site-based builder's parameters (None otherwise)."""
    if builder in ("linear_chain", "fput"):
        return p["n"], 1
    if builder == "diatomic_chain":
        return 2 * p["n_cells"], 1
    if builder == "beaded_string":
        return p["n"], 2  # (x, y) per bead, x held at rest: transverse motion only
    if builder == "springs":
        first = p["positions"][0]
        return len(p["positions"]), len(first) if isinstance(first, tuple) else 1
    if builder == "co2":
        return 3, p["dims"]
    if builder == "h2o":
        return 3, 3
    return None


#: Most steps one dynamics run may take (``compute.n_steps``), whatever the time limit.
MAX_DYNAMICS_STEPS = 100_000_000


@dataclass(frozen=True)
class DynamicsEstimate:
    """Memory and time of a dynamics scene's runs.

    Attributes
    ----------
    memory : int
        Recorded positions and velocities of every run, plus the mode energies, in bytes.
    seconds : float
        The integration (compiled loop), in s.
    records : int
        States recorded per run.
    """

    memory: int
    seconds: float
    records: int


def dynamics_estimate(n_dof: int, spec: Any) -> DynamicsEstimate:
    """What the runs of a dynamics scene (`vibra.pipeline.scene.dynamics.DynamicsSpec`) cost, from sizes:
    the time of each run is `vibra.dynamics.cost.integration_seconds`, the estimate `integrate`
    checks against its ``max_seconds`` too, plus loading the compiled kernels once
    (`vibra.dynamics.cost.START_SECONDS`).

    >>> from types import SimpleNamespace
    >>> spec = SimpleNamespace(n_steps=1000, record_every=10, integrator="verlet", n_runs=1, chains=(1,),
    ...                        thermostat="none")
    >>> dynamics_estimate(4, spec).records
    101
    """
    records = spec.n_steps // spec.record_every + 1
    memory = spec.n_runs * records * (3 * n_dof + 8) * 8
    from vibra.dynamics.cost import START_SECONDS, integration_seconds   # here: numba loads with vibra.dynamics

    chains = spec.chains if spec.thermostat == "nose-hoover" else (0,) * spec.n_runs
    seconds = START_SECONDS + sum(integration_seconds(n_dof, spec.n_steps, spec.integrator, chain=chain)
                                  for chain in chains)
    return DynamicsEstimate(memory=memory, seconds=seconds, records=records)


def default_memory_limit() -> int:
    """Half of the physical memory, in bytes (8 GiB where the system does not say), and never more
    than the room under the address-space limit (``ulimit -v``) or the cgroup memory limit
    (`vibra.solvers.budget.memory_sources`: a container's limit is the machine's size for us)."""
    try:
        half = int(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")) // 2
    except (ValueError, OSError, AttributeError):
        half = 8 << 30
    from vibra.solvers.budget import MEMORY_READERS

    limits = [reader() for name, reader in MEMORY_READERS.items() if name != "available physical memory"]
    return int(min([half, *(value for value in limits if value is not None)]))


@dataclass(frozen=True)
class MemoryEstimate:
    """The memory a scene's plan would take.

    Attributes
    ----------
    total : int
        Estimated peak, in bytes.
    largest : str
        The largest part, in words (``"mode shapes 10000 x 10000"``).
    key : str
        The scene key that controls that part (``"system.n"``, ``"compute.response.n_points"``).
    advice : str
        The cheaper request that answers the same question.
    """

    total: int
    largest: str
    key: str
    advice: str


def n_dof_bound(builder: str, parameters: Mapping[str, Any]) -> int | None:
    """Degrees of freedom a builder's parameters describe, before freezing (None: not size-driven)."""
    if builder == "matrices":
        return len(parameters["M"])
    geometry = sites_and_dim(builder, parameters)
    return None if geometry is None else geometry[0] * geometry[1]


def all_modes_seconds(builder: str, parameters: Mapping[str, Any], compute: ComputeSpec) -> float:
    """Estimated seconds of the scene's solve when it asks for all modes (0 for a partial request),
    before the system is built: the solver registry's plan of all frequencies of a chain of that
    many dofs at the scene's accuracy (`vibra.solvers.problem.chain_problem`: O(N^2), the cheapest
    all-modes solve there is); ``n_modes`` or ``band`` use a partial solver instead.
    """
    n_dof = n_dof_bound(builder, parameters)
    if n_dof is None or compute.n_modes is not None or compute.band is not None:
        return 0.0
    from vibra.solvers.dispatch import plan_problem   # here: a refused scene is reported without the solvers
    from vibra.solvers.problem import chain_problem

    return plan_problem(chain_problem(n_dof, accuracy=compute.accuracy), "auto").cost.seconds


def memory_estimate(builder: str, parameters: Mapping[str, Any], compute: ComputeSpec, draw: DrawSpec) -> MemoryEstimate | None:
    """Estimate the memory of a scene's plan from its parameters (None: not size-driven).

    Parameters
    ----------
    builder : str
        The scene's builder.
    parameters : Mapping
        Its checked ``[system]`` parameters.
    compute, draw : ComputeSpec, DrawSpec
        What the scene computes and draws.
    """
    bound = n_dof_bound(builder, parameters)
    if bound is None:
        return None
    n_dof = bound
    size_key = {"linear_chain": "system.n", "beaded_string": "system.n", "diatomic_chain": "system.n_cells",
                "springs": "system.positions", "matrices": "system.M"}.get(builder, "system")
    vectors = bool(compute.shapes or draw.modes or draw.gif)
    kept = n_dof if compute.n_modes is None else min(compute.n_modes, n_dof)
    parts: list[tuple[int, str, str, str]] = [
        (BYTES_PER_DOF * n_dof, f"the system of {n_dof} degrees of freedom", size_key,
         f"a smaller {size_key}")]
    if vectors:
        # shapes and mass-weighted vectors, plus the solver's copy; a dense solve of all modes
        # holds the n x n matrix as well
        parts.append((3 * 8 * n_dof * kept, f"{kept} mode shapes of {n_dof} values each", "compute.n_modes",
                      "fewer modes (compute.n_modes) or no shapes (draw.modes = false, draw.gif = false, "
                      "compute.shapes = false)"))
    else:
        parts.append((16 * 8 * n_dof, f"the frequencies of {n_dof} degrees of freedom", size_key,
                      f"a smaller {size_key}"))
    response = compute.response
    if response is not None:
        parts.append((16 * response.n_points * n_dof, f"a complex response at {response.n_points} frequencies "
                      f"for {n_dof} degrees of freedom", "compute.response.n_points",
                      "fewer compute.response.n_points"))
    continuum = compute.continuum
    if continuum is not None:
        parts.append((BYTES_PER_DOF * sum(continuum.sizes), f"chains of {sum(continuum.sizes)} sites in all",
                      "compute.continuum.sizes", "smaller compute.continuum.sizes"))
    total = sum(part[0] for part in parts)
    _, largest, key, advice = max(parts, key=lambda part: part[0])
    return MemoryEstimate(total=total, largest=largest, key=key, advice=advice)


def gib(n_bytes: float) -> str:
    """`n_bytes` in words (``"7.5 GiB"``, ``"3.1e+08 GiB"``)."""
    value = n_bytes / 2**30
    return f"{value:.3g} GiB" if value < 1e6 else f"{value:.2g} GiB"
