"""Executing a `Plan`: each step computes (build, modes, analyses) or draws what was computed.

`execute` runs the steps in order and records, per step, what was computed, by which solver,
its accuracy figure and its wall time. Analysis steps (``crosscheck``, ``response``,
``continuum``, ``dispersion``, ``structure``) compute everything the drawings need; the
``render-*`` and ``chart-*`` steps hand those results to `vibra.pipeline.render` and `vibra.charts`,
which only draw. Every file is written through `vibra._core.filesystem` (atomically).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from vibra._core.filesystem import atomic_write_text
from vibra.pipeline.plan.analysis import (chain_dispersion, molecule_structure, molecule_symmetry,
                                          network_fluctuations, symmetry_hints)
from vibra.pipeline.plan.build import build_system, network_structure
from vibra.pipeline.plan.chartsteps import CHART_STEPS, ChartStep
from vibra.pipeline.plan.electronic import electronic_hints
from vibra.pipeline.plan.checks import REFUSALS, empty_band, response_request, solve_limits, step_error
from vibra.pipeline.plan.kinds import PLAN_KINDS, build_note, check_plan, plan_kind
from vibra.pipeline.plan.model import Plan, PlanResult, StepRecord
from vibra.pipeline.plan.tables import frequency_lines, mode_names
from vibra.pipeline.plan.views import mode_view
from vibra.pipeline.scene import Scene
from vibra.pipeline.scene.values import element_symbol
from vibra.sources import cite
from vibra.solvers.structured.quadratic import QuadraticModes
from vibra._core.text import counted

__all__ = ["execute", "frequency_lines", "STEPS"]


@dataclass
class _Context:
    """Mutable state of one execution (private; results leave as frozen records)."""

    scene: Scene
    out_dir: Path
    work_dir: Path
    system: Any = None
    modes: Any = None
    response: Any = None
    continuum: Any = None
    crosscheck: Any = None
    dispersion: Any = None
    structure: Any = None
    symmetry: Any = None
    network: Any = None
    bands: Any = None              # crystal scenes: (BandStructure, DensityOfStates)
    thermal: Any = None            # crystal scenes: ThermalProperties
    supercell_mode: Any = None     # crystal scenes: SupercellMode
    infrared: Any = None           # polar crystal scenes: InfraredResponse
    dynamics: Any = None           # dynamics scenes: DynamicsRuns
    electronic: Any = None         # molecule scenes with an engine: ElectronicStructure
    results: dict[str, Any] = field(default_factory=dict)  # what a kind's own steps computed, by name
    hints: dict[int, str] = field(default_factory=dict)
    outputs: list[str] = field(default_factory=list)
    captions: list[str] = field(default_factory=list)

    def save_chart(self, figure: Any, what: str, caption: str) -> None:
        """Write a chart as ``<scene>_<what>.png`` and record it with its caption."""
        _save_chart(self, figure, what, caption)


def _is_quadratic(modes: Any) -> bool:
    """True for the modes of a gyroscopic or damped system (`vibra.solvers.structured.quadratic.QuadraticModes`)."""
    return isinstance(modes, QuadraticModes)


def _accuracy_text(modes: Any) -> str:
    parts = []
    if _is_quadratic(modes):
        scale = max(float(np.abs(modes.natural_frequency).max(initial=0.0)), np.finfo(float).tiny)
        stable = "stable" if modes.stable else f"UNSTABLE ({counted(int(np.sum(modes.unstable)), 'growing mode')})"
        return (f"max omega error {float(np.max(modes.omega_error, initial=0.0)) / scale:.2e} (relative to max "
                f"omega), {stable}")
    if np.isfinite(modes.residual):
        parts.append(f"residual {modes.residual:.2e}")
    if modes.n_modes:
        scale = max(float(np.abs(modes.omega).max()), np.finfo(float).tiny)
        parts.append(f"max omega error {float(np.max(modes.omega_error)) / scale:.2e} (relative to max omega)")
    return ", ".join(parts) or "n/a"


def execute(plan: Plan, out_dir: Path, work_dir: Path, *,
            on_step: Callable[[str], None] | None = None) -> PlanResult:
    """Run every step of `plan`, writing images under `out_dir` (atomically).

    Parameters
    ----------
    plan : Plan
    out_dir : Path
        Folder of the finished images.
    work_dir : Path
        This scene's private scratch folder (cross-check caches, GIF frames).
    on_step : callable, optional
        Called with each step's name before it runs (progress display).

    Returns
    -------
    PlanResult
    """
    context = _Context(scene=plan.scene, out_dir=out_dir, work_dir=work_dir)
    kind = plan_kind(plan.scene)
    records = []
    renderer = None
    try:
        for step in plan.steps:
            if on_step is not None:
                on_step(step.name)
            before = len(context.outputs)
            start = time.perf_counter()
            if step.name.startswith("render") and renderer is None and kind.renders:
                from vibra.pipeline.render import SceneRenderer
                renderer = SceneRenderer(plan.scene.draw.window_size)
            try:
                solver, accuracy = STEPS[step.name](plan, context, renderer)
            except REFUSALS as error:  # a library refusal or a failed solve: one line at the step's key
                raise step_error(plan.scene, step.name, error, keys=kind.step_keys) from error
            seconds = time.perf_counter() - start
            records.append(StepRecord(name=step.name, what=step.what, seconds=seconds, solver=solver,
                                      accuracy=accuracy, outputs=tuple(context.outputs[before:])))
    finally:
        if renderer is not None:
            renderer.close()
    lines: tuple[str, ...] = ()
    if context.modes is not None:
        lines = frequency_lines(plan.scene, context.modes, context.symmetry)
    return PlanResult(records=tuple(records), outputs=tuple(context.outputs),
                      captions=tuple(context.captions), frequencies=lines, modes=context.modes)


def _step_build(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    context.system = build_system(plan.scene)
    system = context.system
    check_plan(plan.scene, system)  # what validate checks: solver fits, response grid off the poles
    return None, build_note(plan.scene, system)


def _step_modes(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    compute = plan.scene.compute
    limits = solve_limits(plan.scene, context.system)  # the solver's own guard, as validate checked it
    context.modes = context.system.modes(plan.n_modes, accuracy=compute.accuracy, vectors=plan.vectors,
                                         band=compute.band, solver=compute.solver, **limits)
    error = empty_band(plan.scene, context.modes)  # only a band can come back empty
    if error is not None:
        raise error
    solver = context.modes.path
    return solver, _accuracy_text(context.modes)


def _crosscheck_inputs(scene: Scene) -> tuple[Any, Any]:
    """The ase.Atoms and valence model of a molecule scene, with the builder's constants."""
    from vibra import molecules

    if scene.system.builder == "co2":
        atoms = molecules.co2_atoms()
        model = molecules.valence_model(atoms, bonds=np.array([[0, 1], [1, 2]]),
                                        stretch=molecules.CO2_STRETCH, bend=molecules.CO2_BEND)
    else:  # "h2o" (the scene schema allows the cross-check for these two only)
        atoms = molecules.h2o_atoms()
        model = molecules.valence_model(atoms, bonds=np.array([[0, 1], [0, 2]]),
                                        stretch=molecules.H2O_STRETCH, bend=molecules.H2O_BEND)
    return atoms, model


def _step_crosscheck(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra import crosscheck  # ASE and phonopy are imported here only

    atoms, model = _crosscheck_inputs(plan.scene)
    result = crosscheck.crosscheck(atoms, model=model, name=plan.scene.title)
    context.crosscheck = result
    _write_text(context, f"{plan.scene.name}_crosscheck.txt", result.table() + "\n",
                "Cross-check of the wavenumbers against ASE Vibrations and phonopy (cm^-1)")
    vibrations = ~np.asarray(result.rigid)
    ase_gap = float(np.max(np.abs(result.ase_difference_cm1[vibrations]), initial=0.0))
    phonopy_gap = float(np.max(np.abs(result.phonopy_difference_cm1[vibrations]), initial=0.0))
    verdict = "within" if result.within_error() else "NOT within"
    return "ASE Vibrations + phonopy", (f"largest difference of the vibrations: ASE {ase_gap:.2g} cm^-1, "
                                        f"phonopy {phonopy_gap:.2g} cm^-1 ({verdict} the finite-difference error)")


def _step_response(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra import response

    r = plan.scene.compute.response
    assert r is not None  # make_plan adds this step only with a response table
    if plan.scene.kind == "oscillator":
        context.response = np.linspace(r.omega_min, r.omega_max, r.n_points)
        return f"closed form ({cite('003')}, eq. 120)", None
    system = context.system
    K, M, C, G, omegas, force, method, n_modes = response_request(plan.scene, system)
    result = response.frequency_response(K, M, C, omegas, force, method=method, n_modes=n_modes,
                                         units=system.units, G=G)
    context.response = result
    error = float(np.max(result.truncation_error)) if len(result.truncation_error) else 0.0
    return result.solver, f"estimated truncation error {error:.2g} (relative, M-norm)"


def _step_continuum(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra import continuum

    c = plan.scene.compute.continuum
    assert c is not None
    ends: Any = c.ends  # "free", "fixed" or "periodic", checked by the scene schema
    study = continuum.convergence_study(list(c.modes), list(c.sizes), ends=ends)
    context.continuum = study
    order = getattr(study, "order", getattr(study, "fitted_order", None))
    if order is not None:
        values = np.atleast_1d(np.asarray(order, dtype=float))
        return None, "fitted convergence order " + ", ".join(f"{v:.3f}" for v in values)
    return None, None


def _save_chart(context: _Context, figure: Any, what: str, caption: str) -> None:
    from vibra.charts import save_figure

    name = f"{context.scene.name}_{what}.png"
    save_figure(figure, context.out_dir / name)
    context.outputs.append(name)
    context.captions.append(caption)


def _write_text(context: _Context, name: str, text: str, caption: str) -> None:
    atomic_write_text(context.out_dir / name, text)
    context.outputs.append(name)
    context.captions.append(caption)


def _drawn_modes(plan: Plan, context: _Context) -> list[int]:
    """Indices of the modes to draw: the lowest non-zero ones, `n_draw` of them."""
    modes = context.modes
    zero = modes.zero_modes(1e-6) if modes.n_modes > 1 else np.zeros(modes.n_modes, dtype=bool)
    moving = [k for k in range(modes.n_modes) if not zero[k]] or list(range(modes.n_modes))
    return moving[: plan.scene.draw.n_draw]


def _mode_names(plan: Plan, context: _Context) -> dict[int, str]:
    """The drawn modes' names as the frequency table numbers them ("ν2 (A1)", "mode 1")."""
    return mode_names(plan.scene, context.modes, context.symmetry, species=True)


def _step_render_modes(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    if _is_quadratic(context.modes):  # gyroscopic: complex shapes trace orbits in the (x, y) plane
        from vibra.charts.orbits import plot_mode_orbits

        system, modes = context.system, context.modes
        names = [system.labels[i] for i in system.free_dofs][:2]
        figure = plot_mode_orbits(modes, coordinates=names, title=f"{plan.scene.title}: mode orbits")
        frequencies = " and ".join(f"{w:.4g}" for w in modes.natural_frequency)
        _save_chart(context, figure, "orbits",
                    f"{plan.scene.title}: orbit of each mode over one period, q(t) = Re{{x exp(i omega t)}} "
                    f"(omega = {frequencies} {modes.units.omega}); the two modes turn in opposite senses")
        return None, None
    indices = _drawn_modes(plan, context)
    if renderer is None:  # generalised coordinates: no geometry to render in 3-D
        if plan.scene.system.builder == "double_pendulum":
            from vibra.charts.pendulum import plot_double_pendulum_modes

            p = plan.scene.system.parameters
            figure = plot_double_pendulum_modes(context.modes, p["a"], p["b"])
            caption = (f"{plan.scene.title}: the two normal modes drawn as pendulum positions "
                       f"({cite('000')}, eqs. 15-16)")
        else:
            from vibra.charts.modes import shapes_figure

            figure, caption = shapes_figure(plan.scene, context.system, context.modes, indices)
        _save_chart(context, figure, "modes", caption)
        return None, None
    scalar = plan.scene.system.builder == "gnm"  # one amplitude per residue: drawn as colours, no 3-D view
    sites = network_structure(plan.scene) if scalar else None
    for name, caption in renderer.render_modes(plan.scene, context.system, context.modes, indices,
                                               context.out_dir, structure=context.structure,
                                               hints=context.hints, names=_mode_names(plan, context),
                                               sites=None if sites is None else sites.positions):
        context.outputs.append(name)
        context.captions.append(caption)
    if scalar:
        _gnm_profiles(plan, context, sites.labels, indices)
    view = None if scalar else mode_view(plan.scene, context.system, context.modes, indices,
                                         structure=context.structure, symmetry=context.symmetry)
    if view is not None:  # the report's interactive 3-D view of the same modes
        _write_text(context, f"{plan.scene.name}_view.json", json.dumps(view, separators=(",", ":")),
                    "the drawn modes in 3-D: drag to rotate, scroll to zoom, pick a mode and its amplitude")
    return None, None


def _gnm_profiles(plan: Plan, context: _Context, labels: Any, indices: list[int]) -> None:
    """The drawn modes of a Gaussian network model along the sequence (`plot_mode_profiles`)."""
    from vibra.charts.networks import plot_mode_profiles

    names = _mode_names(plan, context)
    omega = np.asarray(context.modes.omega)
    titles = [f"{names.get(k, f'mode {k}')}: ω = {omega[k]:.4g} √(γ/m)" for k in indices]
    figure = plot_mode_profiles(labels, np.asarray(context.modes.shapes)[:, indices], titles, title=plan.scene.title)
    _save_chart(context, figure, "profiles",
                f"{plan.scene.title}: the drawn modes' amplitude per residue along the sequence, each scaled to a "
                "largest |u| of 1 (red and blue move in opposition; a sign change is a hinge)")


def _step_structure(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    """Elements, bonds, and each drawn mode's symmetry / IR-activity text (molecules)."""
    context.structure = molecule_structure(plan.scene, context.system)
    structure = context.structure
    if context.electronic is not None:  # the engine's own IR intensities, not point charges
        context.hints = electronic_hints(context.electronic, context.system, context.modes,
                                         _drawn_modes(plan, context), context.symmetry)
    else:
        context.hints = symmetry_hints(context.system, context.modes, _drawn_modes(plan, context),
                                       structure.symbols, structure.bonds, context.symmetry)
    return None, counted(len(structure.bonds), "bond")


def _step_symmetry(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    """Point group, species and observed fundamentals of a 3-D molecule's modes (`molecule_symmetry`)."""
    context.symmetry = molecule_symmetry(context.system, context.modes)
    if context.symmetry is None:
        return None, "no point group (not a free 3-D molecule)"
    source = "" if context.symmetry.source is None else "; observed fundamentals shown"
    return "vibra.molecules.point_group", f"point group {context.symmetry.group}{source}"


def _step_fluctuations(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    """B-factors of a network scene predicted from its computed modes (`network_fluctuations`)."""
    context.network = network_fluctuations(network_structure(plan.scene), context.system, context.modes)
    return "kT sum |u_k|^2 / omega_k^2 (rigid modes left out)", \
        f"B-factor correlation r = {context.network.correlation:.3f} over {counted(len(context.network.labels), 'residue')}"


def _step_dispersion(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    context.dispersion = chain_dispersion(plan.scene.system.parameters, context.modes)
    return None, None


def _step_render_gif(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    index = _drawn_modes(plan, context)[0]
    name, caption = renderer.render_gif(plan.scene, context.system, context.modes, index,
                                        context.out_dir, context.work_dir, structure=context.structure,
                                        names=_mode_names(plan, context))
    context.outputs.append(name)
    context.captions.append(caption)
    return None, None


def _chart_step(chart: ChartStep) -> Callable[[Plan, _Context, Any], tuple[str | None, str | None]]:
    """The step function of a chart of `vibra.pipeline.plan.chartsteps`: it draws, no solver runs."""
    def run(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
        return None, chart.run(plan.scene, context)
    return run


#: step name -> the function that runs it.
STEPS: dict[str, Callable[[Plan, _Context, Any], tuple[str | None, str | None]]] = {
    "build": _step_build,
    "modes": _step_modes,
    "crosscheck": _step_crosscheck,
    "response": _step_response,
    "continuum": _step_continuum,
    "dispersion": _step_dispersion,
    "symmetry": _step_symmetry,
    "fluctuations": _step_fluctuations,
    "structure": _step_structure,
    "render-modes": _step_render_modes,
    "render-gif": _step_render_gif,
    **{chart.step: _chart_step(chart) for chart in CHART_STEPS},  # the modes plan's charts
    **{name: run for kind in PLAN_KINDS.values() for name, run in kind.steps.items()},  # each kind's own steps
}
