"""A `Scene` -> a `Plan`: the list of steps that compute exactly what the scene asks.

DESIGN.md, "Model only what a scene requires": the plan solves only the degrees of freedom
the scene models (the axial CO2 scene solves 3), passes ``n_modes`` / ``band`` to the
solver (a partial solver for "the lowest 10 modes of 10^6 sites"), computes shapes only
when a drawing needs them (``vectors=False`` otherwise), and imports ASE/phonopy only in
the cross-check step. `execute` runs the steps in order and records, per step, what was
computed, by which solver, its accuracy figure and its wall time.

Builders are looked up in `BUILD_FUNCTIONS`, a fixed table of (module, function) inside
vibra; nothing from a scene file is imported or executed.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from vibra.scene import Scene

__all__ = ["Step", "Plan", "StepRecord", "PlanResult", "make_plan", "execute", "BUILD_FUNCTIONS"]

#: scene builder -> (vibra module, function). The only way a scene names code.
BUILD_FUNCTIONS: dict[str, tuple[str, str]] = {
    "linear_chain": ("vibra.chains", "linear_chain"),
    "diatomic_chain": ("vibra.chains", "diatomic_chain"),
    "beaded_string": ("vibra.chains", "beaded_string"),
    "springs": ("vibra.system", "System.from_springs"),
    "co2": ("vibra.molecules", "co2"),
    "h2o": ("vibra.molecules", "h2o"),
    "double_pendulum": ("vibra.lagrangian", "double_pendulum"),
    "matrices": ("vibra.system", "System.generalized"),
    "oscillator": ("vibra.response", "Oscillator"),
}


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


def make_plan(scene: Scene) -> Plan:
    """The steps that compute exactly what `scene` asks (no work is done here)."""
    compute, draw = scene.compute, scene.draw
    steps = [Step("build", f"build the system with builder {scene.system.builder!r}")]
    vectors = bool(compute.shapes or draw.needs_shapes)
    n_modes = compute.n_modes
    if scene.kind != "oscillator":
        if n_modes is not None:
            how = f"lowest {n_modes} modes (partial solver)"
        elif compute.band is not None:
            how = f"modes with omega in [{compute.band[0]:g}, {compute.band[1]:g}]"
        else:
            how = "all modes"
        shapes = "frequencies and shapes" if vectors else "frequencies only (no shapes)"
        steps.append(Step("modes", f"{how}: {shapes}, accuracy={compute.accuracy!r}"))
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
    if draw.modes:
        steps.append(Step("render-modes", f"render {draw.n_draw} mode shapes off-screen (pyvista)"))
    if draw.gif:
        steps.append(Step("render-gif", "animated GIF of the lowest drawn mode (pyvista)"))
    if draw.spectrum:
        steps.append(Step("chart-spectrum", "stick spectrum of the frequencies"))
    if draw.dispersion:
        steps.append(Step("chart-dispersion", "dispersion relation with the chain's modes"))
    if draw.response:
        steps.append(Step("chart-response", "response amplitude and phase against frequency"))
    if draw.convergence:
        steps.append(Step("chart-convergence", "error of the chain's modes against N (log-log)"))
    return Plan(scene=scene, steps=tuple(steps), n_modes=n_modes, vectors=vectors)


# ---------------------------------------------------------------------- building
def _function(builder: str) -> Callable[..., Any]:
    module_name, attribute = BUILD_FUNCTIONS[builder]
    target: Any = importlib.import_module(module_name)
    for part in attribute.split("."):
        target = getattr(target, part)
    return target


def build_system(scene: Scene) -> Any:
    """The `System` (or, for an oscillator scene, the `Oscillator`) a scene describes."""
    p = dict(scene.system.parameters)
    builder = scene.system.builder
    frozen_sites = p.pop("frozen_sites", None)
    frozen_dofs = p.pop("frozen_dofs", None)
    make = _function(builder)
    lists = {k: (np.asarray(v) if isinstance(v, tuple) else v) for k, v in p.items()}
    if builder == "linear_chain":
        mass = lists.pop("mass")
        site, defect = lists.pop("defect_site"), lists.pop("defect_mass")
        if site is not None:
            mass = np.full(p["n"], mass, dtype=float) if np.ndim(mass) == 0 else np.array(mass, dtype=float)
            mass[site] = defect
        system = make(lists.pop("n"), mass=mass, units=scene.units, name=scene.name, **lists)
    elif builder in ("diatomic_chain", "beaded_string"):
        if builder == "diatomic_chain":
            lists["masses"] = tuple(p["masses"])
            if isinstance(p["stiffness"], tuple):
                lists["stiffness"] = tuple(p["stiffness"])
        system = make(units=scene.units, name=scene.name, **lists)
    elif builder == "springs":
        lists.pop("symbols")
        springs = np.asarray(p["springs"], dtype=np.intp).reshape(-1, 2)
        anchors = lists.pop("anchors")
        system = make(lists.pop("positions"), lists.pop("masses"), springs=springs,
                      stiffness=lists.pop("stiffness"),
                      anchors=None if anchors is None else np.asarray(anchors, dtype=np.intp),
                      anchor_stiffness=lists.pop("anchor_stiffness"), units=scene.units,
                      name=scene.name)
    elif builder == "co2":
        system = make(dims=p["dims"])
    elif builder == "h2o":
        system = make()
    elif builder == "double_pendulum":
        system = make(**p)
    elif builder == "matrices":
        system = make(np.asarray(p["M"]), np.asarray(p["K"]), coordinates=p["coordinates"],
                      units=scene.units, name=scene.name)
    elif builder == "oscillator":
        gammas = p["gamma"] if isinstance(p["gamma"], tuple) else (p["gamma"],)
        return tuple(make(p["w0"], g, p["m"]) for g in gammas)
    else:  # pragma: no cover - BUILDERS and BUILD_FUNCTIONS are kept in step
        raise KeyError(builder)
    if frozen_sites or frozen_dofs:
        system = system.freeze(sites=None if not frozen_sites else np.asarray(frozen_sites, dtype=np.intp),
                               dofs=None if not frozen_dofs else np.asarray(frozen_dofs, dtype=np.intp))
    return system


# ---------------------------------------------------------------------- execution
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
    outputs: list[str] = field(default_factory=list)
    captions: list[str] = field(default_factory=list)


def _accuracy_text(modes: Any) -> str:
    parts = []
    if np.isfinite(modes.residual):
        parts.append(f"residual {modes.residual:.2e}")
    if modes.n_modes:
        scale = max(float(np.abs(modes.omega).max()), np.finfo(float).tiny)
        parts.append(f"max omega error {float(np.max(modes.omega_error)) / scale:.2e} (relative to max omega)")
    return ", ".join(parts) or "n/a"


def frequency_lines(scene: Scene, modes: Any) -> tuple[str, ...]:
    """A text table of the modes: index, omega (scene units) and a spectroscopic unit."""
    units = modes.units
    omega = np.asarray(modes.omega)
    header = f"{'mode':>5}  {'omega [' + units.omega + ']':>26}"
    extra = None
    if units.time_s is not None:
        extra = ("cm^-1", modes.wavenumbers_cm1()) if scene.kind == "molecule" else ("Hz", modes.frequencies_hz())
        header += f"  {extra[0]:>14}"
    lines = [header]
    for k in range(modes.n_modes):
        line = f"{k:>5}  {omega[k]:>26.10g}"
        if extra is not None:
            line += f"  {extra[1][k]:>14.6g}"
        lines.append(line)
    return tuple(lines)


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
    records = []
    renderer = None
    try:
        for step in plan.steps:
            if on_step is not None:
                on_step(step.name)
            before = len(context.outputs)
            start = time.perf_counter()
            if step.name.startswith("render") and renderer is None and plan.scene.kind in ("chain", "molecule"):
                from vibra.render import SceneRenderer
                renderer = SceneRenderer(plan.scene.draw.window_size)
            solver, accuracy = _STEPS[step.name](plan, context, renderer)
            seconds = time.perf_counter() - start
            records.append(StepRecord(name=step.name, what=step.what, seconds=seconds, solver=solver,
                                      accuracy=accuracy, outputs=tuple(context.outputs[before:])))
    finally:
        if renderer is not None:
            renderer.close()
    lines: tuple[str, ...] = ()
    if context.modes is not None:
        lines = frequency_lines(plan.scene, context.modes)
    return PlanResult(records=tuple(records), outputs=tuple(context.outputs),
                      captions=tuple(context.captions), frequencies=lines, modes=context.modes)


def _step_build(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    context.system = build_system(plan.scene)
    system = context.system
    if plan.scene.kind == "oscillator":
        return None, None
    return None, f"{system.n_dof} degrees of freedom"


def _step_modes(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    compute = plan.scene.compute
    context.modes = context.system.modes(plan.n_modes, accuracy=compute.accuracy, vectors=plan.vectors,
                                         band=compute.band, solver=compute.solver)
    if context.modes.n_modes == 0 and compute.band is not None:  # only a band can come back empty
        raise RuntimeError(f"compute.band: no mode has omega in [{compute.band[0]:g}, {compute.band[1]:g}] "
                           f"{context.modes.units.omega}; nothing to list or draw")
    return context.modes.solver, _accuracy_text(context.modes)


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
    omegas = np.linspace(r.omega_min, r.omega_max, r.n_points)
    if plan.scene.kind == "oscillator":
        context.response = omegas
        return "closed form (seed 003 eq. 120)", None
    system = context.system
    force = np.zeros(system.n_dof)
    force[r.force_site] = 1.0
    K, M = system.hessian(), system.mass_matrix()
    C = response.rayleigh_damping(K, M, r.alpha, r.beta)
    method: Any = r.method  # "direct" or "modal", checked by the scene schema
    result = response.frequency_response(K, M, C, omegas, force, method=method, n_modes=r.n_modes,
                                         units=system.units)
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
    from vibra.charts._style import save_figure

    name = f"{context.scene.name}_{what}.png"
    save_figure(figure, context.out_dir / name)
    context.outputs.append(name)
    context.captions.append(caption)


def _write_text(context: _Context, name: str, text: str, caption: str) -> None:
    from vibra.report import atomic_write_text

    atomic_write_text(context.out_dir / name, text)
    context.outputs.append(name)
    context.captions.append(caption)


def _drawn_modes(plan: Plan, context: _Context) -> list[int]:
    """Indices of the modes to draw: the lowest non-zero ones, `n_draw` of them."""
    modes = context.modes
    zero = modes.zero_modes(1e-6) if modes.n_modes > 1 else np.zeros(modes.n_modes, dtype=bool)
    moving = [k for k in range(modes.n_modes) if not zero[k]] or list(range(modes.n_modes))
    return moving[: plan.scene.draw.n_draw]


def _step_render_modes(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    indices = _drawn_modes(plan, context)
    if renderer is None:  # generalised coordinates: no geometry to render in 3-D
        if plan.scene.system.builder == "double_pendulum":
            from vibra.charts.pendulum import plot_double_pendulum_modes

            p = plan.scene.system.parameters
            figure = plot_double_pendulum_modes(context.modes, p["a"], p["b"])
            caption = (f"{plan.scene.title}: the two normal modes drawn as pendulum positions "
                       "(seed 000, eqs. 15-16)")
        else:
            from vibra.report import shapes_figure

            figure, caption = shapes_figure(plan.scene, context.system, context.modes, indices)
        _save_chart(context, figure, "modes", caption)
        return None, None
    hints = _ir_hints(plan.scene, context.system, context.modes)
    for name, caption in renderer.render_modes(plan.scene, context.system, context.modes, indices,
                                               context.out_dir, hints=hints):
        context.outputs.append(name)
        context.captions.append(caption)
    return None, None


def _ir_hints(scene: Scene, system: Any, modes: Any) -> dict[int, str]:
    """Per-mode IR intensity from the point-charge model of `vibra.spectra` (molecules only).

    Charges come from Pauling electronegativities over the drawn bonds; a mode whose
    intensity is below 1e-8 of the strongest is called IR-inactive.
    """
    if scene.kind != "molecule" or system.dim != 3:
        return {}
    from vibra import spectra
    from vibra.render import molecule_bonds, molecule_symbols

    symbols = molecule_symbols(system, scene.system.parameters.get("symbols"))
    bonds = molecule_bonds(system, symbols, scene.system.parameters.get("springs"))
    if not bonds:
        return {}
    charges = spectra.electronegativity_charges(symbols, bonds)
    ir = spectra.ir_spectrum(system, modes, charges=charges)
    strongest = float(np.max(ir.intensities)) if len(ir.intensities) else 0.0
    hints = {}
    for k, intensity in zip(ir.mode_indices, ir.intensities):
        active = strongest > 0 and intensity > 1e-8 * strongest
        hints[int(k)] = (f"IR {'active' if active else 'inactive'} "
                         f"(point charges: {intensity / strongest if strongest else 0.0:.2f} of strongest)")
    return hints


def _step_render_gif(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    index = _drawn_modes(plan, context)[0]
    name, caption = renderer.render_gif(plan.scene, context.system, context.modes, index,
                                        context.out_dir, context.work_dir)
    context.outputs.append(name)
    context.captions.append(caption)
    return None, None


def _step_chart_spectrum(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.report import spectrum_figure

    figure, caption = spectrum_figure(plan.scene, context.modes)
    _save_chart(context, figure, "spectrum", caption)
    return None, None


def _step_chart_dispersion(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts import chains as chain_charts

    p = plan.scene.system.parameters
    masses = p["mass"] if "mass" in p else tuple(p["masses"])
    stiffness = tuple(p["stiffness"]) if isinstance(p["stiffness"], tuple) else p["stiffness"]
    figure = chain_charts.plot_dispersion(masses=masses, stiffness=stiffness, spacing=p["spacing"],
                                          modes=context.modes, ends=p["ends"], units=plan.scene.units,
                                          title=f"{plan.scene.title}: dispersion")
    _save_chart(context, figure, "dispersion",
                f"{plan.scene.title}: dispersion relation omega(q) over the Brillouin zone, with the "
                f"{context.modes.n_modes} modes of the finite chain on top")
    return None, None


def _step_chart_response(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts import response as response_charts

    if plan.scene.kind == "oscillator":
        oscillators = context.system
        figure = response_charts.plot_oscillator_response(list(oscillators), context.response,
                                                          units=plan.scene.units)
        gammas = ", ".join(f"{o.gamma:g}" for o in oscillators)
        caption = (f"{plan.scene.title}: amplitude and phase against omega (seed 003 eqs. 120-123) "
                   f"for gamma = {gammas}, omega0 = {oscillators[0].w0:g}")
    else:
        r = plan.scene.compute.response
        assert r is not None
        natural = None if context.modes is None else np.asarray(context.modes.omega)
        figure = response_charts.plot_frf(context.response, r.force_site, natural_frequencies=natural,
                                          title=f"{plan.scene.title}: response of dof {r.force_site}")
        caption = (f"{plan.scene.title}: receptance at the driven dof {r.force_site} for a unit force "
                   f"({context.response.solver} solver, C = {r.alpha:g} M + {r.beta:g} K)"
                   + (", resonances marked" if natural is not None else ""))
    _save_chart(context, figure, "response", caption)
    return None, None


def _step_chart_convergence(plan: Plan, context: _Context, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts import chains as chain_charts

    figure = chain_charts.plot_convergence(context.continuum)
    c = plan.scene.compute.continuum
    assert c is not None  # make_plan adds this step only with a continuum table
    _save_chart(context, figure, "convergence",
                f"Relative error of modes {list(c.modes)} of a {c.ends}-end chain against the wave equation, "
                "versus N at fixed length (seed 003 eqs. 162-165)")
    return None, None


_STEPS: dict[str, Callable[[Plan, _Context, Any], tuple[str | None, str | None]]] = {
    "build": _step_build,
    "modes": _step_modes,
    "crosscheck": _step_crosscheck,
    "response": _step_response,
    "continuum": _step_continuum,
    "render-modes": _step_render_modes,
    "render-gif": _step_render_gif,
    "chart-spectrum": _step_chart_spectrum,
    "chart-dispersion": _step_chart_dispersion,
    "chart-response": _step_chart_response,
    "chart-convergence": _step_chart_convergence,
}
