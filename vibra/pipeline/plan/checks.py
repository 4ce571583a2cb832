"""What `vibra validate` checks on a built system, and how a failing step becomes a `SceneError`.

`check_modes_plan(scene, system)` runs, on the system the builder of a modes scene returned (the
kinds of `modes_plan`; `vibra.pipeline.plan.kinds.check_plan` picks each kind's checks), the cheap
checks of what the later steps would refuse: a solver that cannot serve the system's structure, a
response grid that starts at omega = 0 on a free system, elements the drawings do not know,
and, for a small system (up to `SPECTRUM_CHECK_LIMIT` dofs), a dry run of the solve
(frequencies only: an empty band, a failing solver) and of the response grid (a pole of an
undamped system) exactly as the plan will run them. `step_error(scene, step,
error)` turns what a library function refused while a step ran into a `SceneError` at the
scene key that controls that step, so the command line prints one line, never a traceback.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Mapping, TypeVar

import numpy as np

from vibra.pipeline.plan.analysis import chain_dispersion
from vibra.pipeline.plan.chartsteps import CHART_STEP_KEYS
from vibra.pipeline.plan.electronic import check_engine_plan, engine_summary
from vibra.pipeline.plan.model import modes_plan
from vibra.pipeline.scene import Scene, SceneError
from vibra.pipeline.scene.values import element_symbol
from vibra import solvers
from vibra.generalized import GeneralizedSystem
from vibra.solvers.accuracy import uses_springs
from vibra.solvers.budget import describe_bytes, describe_seconds
from vibra._core.text import counted

if TYPE_CHECKING:
    import scipy.sparse as sp
    from numpy.typing import NDArray

    from vibra.modes import Modes
    from vibra.solvers.dispatch import SolvePlan
    from vibra.solvers.structured.quadratic import QuadraticModes
    from vibra.system import System

_Built = TypeVar("_Built")

__all__ = ["check_modes_plan", "modes_summary", "step_error", "refused_as", "STEP_KEYS", "REFUSALS",
           "SPECTRUM_CHECK_LIMIT", "solve_request", "solve_limits", "DRY_RESPONSE_LIMIT", "response_request", "empty_band"]

#: A response grid is checked against the system's frequencies up to this many dofs (a fast
#: frequencies-only solve); larger systems are checked when the response step runs.
SPECTRUM_CHECK_LIMIT = 2000
#: The response of a small system is computed as a dry run when n_dof x n_points is at most this.
DRY_RESPONSE_LIMIT = 200_000

#: step name -> the scene key that controls it (named in the error of a failing step); a kind's
#: own steps add theirs (`PlanKind.step_keys`).
STEP_KEYS = {
    "build": "system", "modes": "compute", "crosscheck": "compute.crosscheck", "response": "compute.response",
    "continuum": "compute.continuum", "dispersion": "draw.dispersion", "structure": "system",
    "render-modes": "draw.modes", "render-gif": "draw.gif", "electronic": "system.engine",
    "engine-missing": "system.engine", **CHART_STEP_KEYS,
}

#: What a library function raises when it refuses a request or a solve fails (`LinAlgError` is
#: a ValueError, ARPACK's errors are RuntimeErrors); anything else is a bug, not a scene error.
REFUSALS = (ValueError, TypeError, ArithmeticError, RuntimeError, MemoryError)


def step_error(scene: Scene, step: str, error: BaseException, *, keys: Mapping[str, str] | None = None) -> SceneError:
    """The `SceneError` for `error` raised by `step`, at the scene key that controls the step
    (`STEP_KEYS`, or `keys`: the scene kind's own steps, `PlanKind.step_keys`)."""
    if isinstance(error, SceneError):
        return error
    key = (keys or {}).get(step) or STEP_KEYS.get(step, "")
    if step == "modes" and scene.compute.solver != "auto":
        key = "compute.solver"
    text = " ".join(str(error).split()) or type(error).__name__
    if not isinstance(error, (ValueError, TypeError)) or type(error).__name__ == "LinAlgError":
        text = f"{type(error).__name__}: {text}"
    if len(text) > 300:
        text = text[:297] + "..."
    return SceneError(scene.source, key, f"the {step} step failed: {text}")


def refused_as(step: str, check: Callable[[Scene, _Built], None], *, keys: Mapping[str, str] | None = None
               ) -> Callable[[Scene, _Built, bool], None]:
    """A `PlanKind.check` of a kind with its own steps: ``check(scene, system)``, whose refusal is
    reported as a failure of `step` (at its scene key, `step_error`)."""
    def checked(scene: Scene, system: _Built, response: bool) -> None:
        try:
            check(scene, system)
        except REFUSALS as error:
            raise step_error(scene, step, error, keys=keys) from error
    return checked


def solve_limits(scene: Scene, system: object) -> dict[str, float]:
    """The resource limits a scene raised (``compute.memory_limit_gib``, ``compute.time_limit_s``), as
    the ``max_memory`` / ``max_seconds`` of its solve (a `GeneralizedSystem` takes the defaults)."""
    compute = scene.compute
    limits: dict[str, float] = {}
    if not isinstance(system, GeneralizedSystem):  # (it has no resource options)
        if compute.memory_limit_gib is not None:
            limits["max_memory"] = compute.memory_limit_gib * 2.0**30
        if compute.time_limit_s is not None:
            limits["max_seconds"] = compute.time_limit_s
    return limits


def _solve_plan(scene: Scene, system: System | GeneralizedSystem) -> None:
    """The scene's solve, planned by the solver registry (`vibra.solvers.plan`: its path and its cost
    from sizes, nothing solved or allocated) with the plan's modes and shapes, and guarded with the
    scene's limits (`solve_limits`), as the modes step will run it: validate refuses what the solve
    would refuse, with the same figures."""
    compute = scene.compute
    if getattr(system, "G", None) is not None or getattr(system, "C", None) is not None:
        return  # (a quadratic eigenproblem: planned and guarded by `quadratic_modes`)
    factor = system.spring_factor() if uses_springs(compute.accuracy) else None
    if compute.solver == "accurate" and factor is None:
        raise SceneError(scene.source, "compute.solver", f"'accurate' needs a spring system (K = B^T W B); the "
                         f"{scene.system.builder!r} builder gives none; use 'auto' or 'dense'")
    plan = modes_plan(scene)
    try:
        request = solvers.plan(system.hessian(), system.mass_matrix(), n_modes=plan.n_modes, vectors=plan.vectors,
                               band=compute.band, solver=compute.solver, spring_factor=factor,
                               accuracy=compute.accuracy, positions=_positions(system))
    except ValueError as error:
        if compute.solver == "auto":
            raise
        raise SceneError(scene.source, "compute.solver", f"{error}; use 'auto'") from error
    limits = solve_limits(scene, system)
    solvers.check_solve_plan(request, n_modes=plan.n_modes, vectors=plan.vectors, band=compute.band,
                             max_memory=limits.get("max_memory"), max_seconds=limits.get("max_seconds"))


def response_request(scene: Scene, system: System | GeneralizedSystem) -> tuple[
        sp.csr_matrix, NDArray[np.float64], NDArray[np.float64] | sp.csr_matrix, NDArray[np.float64] | None,
        NDArray[np.float64], NDArray[np.float64], str, int | None]:
    """The arguments of `vibra.response.frequency_response` for the scene's ``[compute.response]``.

    Returns ``(K, M, C, G, omegas, force, method, n_modes)``: a unit force at ``force_site``,
    Rayleigh damping C = alpha M + beta K (plus a generalised system's own C), the system's
    gyroscopic G (None if it has none), omegas spaced linearly.
    """
    from vibra import response

    r = scene.compute.response
    assert r is not None  # called only with a response table
    omegas = np.linspace(r.omega_min, r.omega_max, r.n_points)
    force = np.zeros(system.n_dof)
    force[r.force_site] = 1.0
    parts = response.system_matrices(system)
    K, M = parts.K, parts.M
    C = response.rayleigh_damping(K, M, r.alpha, r.beta)
    if parts.C is not None:
        C = C + parts.C
    return K, M, C, parts.G, omegas, force, r.method, r.n_modes


def empty_band(scene: Scene, modes: Modes | QuadraticModes) -> SceneError | None:
    """The error for a ``compute.band`` that holds no mode (None when it holds some or there is no band)."""
    band = scene.compute.band
    if band is None or modes.n_modes:
        return None
    return SceneError(scene.source, "compute.band", f"no mode has omega in [{band[0]:g}, {band[1]:g}] "
                      f"{modes.units.omega}; nothing to list or draw")


def _dry_run(scene: Scene, system: System | GeneralizedSystem, response: bool) -> None:
    """Run the cheap steps of a small system as the plan will (frequencies only, the response grid)."""
    compute = scene.compute
    r = compute.response
    if response and r is not None and r.omega_min == 0.0:
        omega = np.asarray(system.modes(vectors=False, accuracy="fast").omega, dtype=float) \
            if system.n_dof <= SPECTRUM_CHECK_LIMIT else np.ones(1)
        zero = np.abs(omega) <= 1e-6 * float(np.max(np.abs(omega), initial=0.0))
        if zero.any():
            raise SceneError(scene.source, "compute.response.omega_min", "is 0, where this free system (it has "
                             f"{int(zero.sum())} rigid-body modes) has an unbounded static response; start the "
                             "grid above 0 or hold the system (frozen_sites, anchors, fixed ends)")
    if scene.draw.dispersion:
        try:
            chain_dispersion(scene.system.parameters, n_q=2)
        except REFUSALS as error:
            raise step_error(scene, "dispersion", error) from error
    if system.n_dof > SPECTRUM_CHECK_LIMIT:
        return
    try:
        modes = system.modes(compute.n_modes, accuracy=compute.accuracy, vectors=False, band=compute.band,
                             solver=compute.solver)
    except REFUSALS as error:
        raise step_error(scene, "modes", error) from error
    empty = empty_band(scene, modes)
    if empty is not None:
        raise empty
    if response and r is not None and system.n_dof * r.n_points <= DRY_RESPONSE_LIMIT:
        from vibra import response as analyses

        K, M, C, G, omegas, force, method, n_modes = response_request(scene, system)
        try:
            analyses.frequency_response(K, M, C, omegas, force, method=method, n_modes=n_modes,
                                        units=system.units, G=G)
        except REFUSALS as failure:
            raise step_error(scene, "response", failure) from failure


def _symbols(scene: Scene, system: System | GeneralizedSystem) -> None:
    """Elements the structure step needs (point charges of 3-D molecules that draw their modes)."""
    symbols = scene.system.parameters.get("symbols")
    if symbols is None or scene.kind != "molecule" or not (scene.draw.modes or scene.draw.gif) or system.dim != 3:
        return
    from vibra.spectra import PAULING_ELECTRONEGATIVITY

    for i, symbol in enumerate(symbols):
        if element_symbol(symbol) not in PAULING_ELECTRONEGATIVITY:
            raise SceneError(scene.source, f"system.symbols[{i}]", f"is {symbol!r}, which the IR-activity hints "
                             f"of drawn modes do not know; known: {', '.join(PAULING_ELECTRONEGATIVITY)}")


def check_modes_plan(scene: Scene, system: System | GeneralizedSystem, response: bool = True) -> None:
    """Check, on the built `system` of a modes scene (`modes_plan`), what the plan's later steps would
    refuse (cheap checks only).

    Raises
    ------
    SceneError
        A solver that cannot serve this system (``compute.solver``), or a response grid on
        a pole: omega = 0 for a free system, an undamped resonance (``compute.response``;
        checked only when `response` is true).
    """
    try:
        _solve_plan(scene, system)
        _symbols(scene, system)
        _dry_run(scene, system, response)
    except REFUSALS as error:
        raise step_error(scene, "modes", error) from error
    check_engine_plan(scene, system)  # an engine's cost estimate against the limits, before any SCF


def modes_summary(scene: Scene, system: System | GeneralizedSystem) -> str:
    """What ``vibra validate`` prints of an accepted modes scene: its size, and the solver path the
    report's modes solve would take with its estimated time and memory (`vibra.solvers.plan`:
    from sizes, nothing solved or allocated).

    >>> from vibra.pipeline.plan.build import build_system
    >>> from vibra.pipeline.scene import Scene
    >>> scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 4}}, source="c.toml")
    >>> modes_summary(scene, build_system(scene)).split(";")[0]
    '4 dofs'
    """
    n_dof = getattr(system, "n_dof", None)
    if not isinstance(n_dof, (int, np.integer)):  # (a system without one K)
        return f"{scene.kind} system"
    if getattr(system, "G", None) is not None or getattr(system, "C", None) is not None:
        return f"{counted(n_dof, 'dof')}; a quadratic eigenproblem"
    engine = engine_summary(scene, system) if scene.kind == "molecule" else None
    if engine is not None:
        return f"{counted(n_dof, 'dof')}; {engine}"
    compute = scene.compute
    try:
        plan = modes_plan(scene)
    except (ValueError, TypeError):
        return counted(n_dof, "dof")
    request = solve_request(system, n_modes=plan.n_modes, vectors=plan.vectors, band=compute.band,
                            solver=compute.solver, accuracy=compute.accuracy)
    if request is None:
        return counted(n_dof, "dof")  # (what the solve would refuse, check_plan refused first)
    cost = request.cost
    return (f"{counted(n_dof, 'dof')}; modes: {request.path} path, {cost.what}, estimated ~{describe_seconds(cost.seconds)} "
            f"and {describe_bytes(cost.memory)}")


def solve_request(system: System | GeneralizedSystem, *, n_modes: int | None, vectors: bool,
                  band: tuple[float, float] | None, solver: str, accuracy: str) -> SolvePlan | None:
    """The solver registry's plan of `system.modes(...)` with these arguments (its path and its cost,
    estimated from sizes before any work), or None for a system or a request it would refuse:
    what ``vibra validate`` prints and what a sweep multiplies by its points."""
    try:
        factor = system.spring_factor() if uses_springs(accuracy) else None
        return solvers.plan(system.hessian(), system.mass_matrix(), n_modes=n_modes, vectors=vectors, band=band,
                            solver=solver, spring_factor=factor, accuracy=accuracy, positions=_positions(system))
    except (ValueError, TypeError, AttributeError, NotImplementedError):
        return None


def _positions(system: System | GeneralizedSystem) -> NDArray[np.float64] | None:
    """What `System.modes` passes as `positions` (`System.solver_positions`); None for a generalised system."""
    chosen = getattr(system, "solver_positions", None)
    return chosen() if callable(chosen) else None
