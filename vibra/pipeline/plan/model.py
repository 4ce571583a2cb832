"""The plan's values: `Step`, `Plan`, `StepRecord`, `PlanResult`, `PlanKind` (what a scene kind computes), and
`modes_plan`, the steps of the kinds whose result is one set of normal modes (scene -> steps)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from vibra.pipeline.plan.chartsteps import chart_steps
from vibra.pipeline.plan.electronic import engine_missing, scene_engine
from vibra.pipeline.scene import Scene
from vibra._core.text import counted

__all__ = ["Step", "Plan", "StepRecord", "PlanResult", "PlanKind", "build_step", "modes_plan"]

@dataclass(frozen=True)
class Step:
    """One planned step.

    Attributes
    ----------
    name : str
        Short identifier (``"build"``, ``"modes"``, ``"render-modes"``, ...).
    what : str
        What the step computes or draws, in words, for the report.
    """

    name: str
    what: str


@dataclass(frozen=True)
class Plan:
    """The steps a scene needs, in order.

    Attributes
    ----------
    scene : Scene
    steps : tuple of Step
    n_modes : int or None
        Modes asked of the solver (None: all, or the band).
    vectors : bool
        Whether mode shapes are computed.
    """

    scene: Scene
    steps: tuple[Step, ...]
    n_modes: int | None
    vectors: bool

    @property
    def step_names(self) -> tuple[str, ...]:
        """Names of the steps, in order."""
        return tuple(step.name for step in self.steps)


@dataclass(frozen=True)
class StepRecord:
    """What one executed step did.

    Attributes
    ----------
    name, what : str
        As in `Step`.
    seconds : float
        Wall time of the step, in s.
    solver : str or None
        The solver path that ran (`Modes.solver`), for solving steps.
    accuracy : str or None
        Accuracy figure in words (residual, largest omega error, cross-check difference).
    outputs : tuple of str
        Files written by the step (names relative to the output folder).
    """

    name: str
    what: str
    seconds: float
    solver: str | None = None
    accuracy: str | None = None
    outputs: tuple[str, ...] = ()


@dataclass(frozen=True)
class PlanResult:
    """Everything an executed plan produced.

    Attributes
    ----------
    records : tuple of StepRecord
    outputs : tuple of str
        Every file written, in order (relative to the output folder).
    captions : tuple of str
        One caption per output.
    frequencies : tuple of str
        Lines of the frequency table (for the terminal and the report).
    modes : Modes or None
        The computed modes (None for an oscillator scene).
    """

    records: tuple[StepRecord, ...]
    outputs: tuple[str, ...]
    captions: tuple[str, ...]
    frequencies: tuple[str, ...]
    modes: Any = None


@dataclass(frozen=True)
class PlanKind:
    """What one scene kind computes, declared once (its scene facts: `vibra.pipeline.scene.kinds.SceneKind`).

    The plan, the checks ``vibra validate`` runs, its summary line and the build step's figure are
    read from here (`vibra.pipeline.plan.kinds`); nothing else branches on the kind's name for them.

    Attributes
    ----------
    name : str
        The scene kind (a key of `vibra.pipeline.scene.SCENE_KINDS`).
    plan : callable
        ``plan(scene) -> Plan``: the steps that compute exactly what the scene asks.
    check : callable
        ``check(scene, system, response)``: what the later steps would refuse, on the built system
        (a `SceneError` at the key that controls it); `response`: whether to dry-run a response grid.
    summary : callable
        ``summary(scene, system) -> str``: what ``vibra validate`` prints of an accepted scene.
    build_note : callable
        ``build_note(scene, system) -> str or None``: the build step's figure in the report.
    steps : Mapping
        Its own step functions, by step name (``(plan, context, renderer) -> (solver, accuracy)``),
        added to `vibra.pipeline.plan.steps.STEPS`.
    step_keys : Mapping
        Its own steps' scene keys, by step name (where `step_error` reports a failing step).
    renders : bool
        Whether its ``render-*`` steps draw with pyvista (`vibra.pipeline.render.SceneRenderer`).
    """

    name: str
    plan: Callable[[Scene], Plan]
    check: Callable[[Scene, Any, bool], None]
    summary: Callable[[Scene, Any], str]
    build_note: Callable[[Scene, Any], str | None]
    steps: Mapping[str, Callable[..., tuple[str | None, str | None]]] = field(default_factory=dict)
    step_keys: Mapping[str, str] = field(default_factory=dict)
    renders: bool = False


def build_step(scene: Scene) -> Step:
    """The first step of every plan: build the scene's system."""
    return Step("build", f"build the system with builder {scene.system.builder!r}")


def modes_plan(scene: Scene) -> Plan:
    """The steps of a scene whose result is one set of normal modes (chain, molecule, network,
    generalised system; an oscillator's closed forms): exactly what `scene` asks, no work done here."""
    compute, draw = scene.compute, scene.draw
    steps = [build_step(scene)]
    engine = _engine_steps(scene)  # a molecule computed by an electronic-structure engine
    if engine is not None and engine[0].name == "engine-missing":
        return Plan(scene=scene, steps=engine, n_modes=None, vectors=False)
    steps.extend(engine or ())
    # network fluctuations and a molecule's IR/Raman intensities need shapes
    vectors = bool(compute.shapes or draw.needs_shapes or scene.kind == "network"
                   or (scene.kind == "molecule" and draw.spectrum))
    n_modes = compute.n_modes
    if scene.kind != "oscillator":
        if n_modes is not None:
            how = f"lowest {counted(n_modes, 'mode')} (partial solver)"
        elif compute.band is not None:
            how = f"modes with omega in [{compute.band[0]:g}, {compute.band[1]:g}]"
        else:
            how = "all modes"
        shapes = "frequencies and shapes" if vectors else "frequencies only (no shapes)"
        steps.append(Step("modes", f"{how}: {shapes}, accuracy={compute.accuracy!r}"))
    if scene.kind == "network":
        steps.append(Step("fluctuations", "thermal fluctuations from the computed non-rigid modes, predicted "
                          "B-factors (8 pi^2/3 <u^2>) and their correlation with the file's B-factors"))
    if compute.crosscheck:
        steps.append(Step("crosscheck", "same force field through ASE Vibrations and phonopy"))
    if compute.response is not None:
        r = compute.response
        steps.append(Step("response", f"{r.method} response at {r.n_points} frequencies in "
                          f"[{r.omega_min:g}, {r.omega_max:g}], C = {r.alpha:g} M + {r.beta:g} K"))
    if compute.continuum is not None:
        c = compute.continuum
        steps.append(Step("continuum", f"modes {list(c.modes)} against the wave equation for "
                          f"N = {list(c.sizes)} ({c.ends} ends)"))
    if draw.dispersion:
        steps.append(Step("dispersion", "dispersion branches omega(q) and the wavenumber of each mode"))
    if scene.kind == "molecule":
        steps.append(Step("symmetry", "point group and symmetry species of the modes, IR/Raman activity "
                          "by symmetry, observed fundamentals of bundled molecules"))
    if scene.kind == "molecule" and (draw.modes or draw.gif):
        steps.append(Step("structure", "elements and bonds of the molecule; symmetry species and "
                          "point-charge IR activity of the drawn modes"))
    if draw.modes:
        steps.append(Step("render-modes", f"render {draw.n_draw} mode shapes off-screen (pyvista)"))
    if draw.gif:
        steps.append(Step("render-gif", "animated GIF of the lowest drawn mode (pyvista)"))
    steps.extend(Step(name, what) for name, what in chart_steps(scene))  # its charts, declared in chartsteps
    return Plan(scene=scene, steps=tuple(steps), n_modes=n_modes, vectors=vectors)


def _engine_steps(scene: Scene) -> tuple[Step, ...] | None:
    """The steps of a molecule scene's electronic-structure engine (`vibra.pipeline.plan.electronic`):
    ``electronic`` after the build, or ``engine-missing`` alone when its package is not installed;
    None for the bundled force field."""
    if scene.kind != "molecule":
        return None
    choice = scene_engine(scene)
    if choice is None:
        return None
    missing = engine_missing(scene)
    if missing is not None:
        return (Step("engine-missing", f"nothing computed: {missing}"),)
    return (Step("electronic", f"{choice.level}: optimise the geometry, then the analytic Hessian and the dipole "
                 "and polarisability derivatives by finite differences (vibra.molecules.engines)"),)
