"""The plan's values: `Step`, `Plan`, `StepRecord`, `PlanResult`, and `make_plan` (scene -> steps)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vibra.pipeline.scene import Scene
from vibra._core.text import counted

__all__ = ["Step", "Plan", "StepRecord", "PlanResult", "make_plan", "crystal_steps", "polar_crystal", "dynamics_steps"]

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
    if scene.kind == "crystal":  # no Modes of one system: bands, DOS, thermal properties, a mode on a supercell
        return Plan(scene=scene, steps=tuple(steps + crystal_steps(scene)), n_modes=None, vectors=False)
    if scene.kind == "dynamics":  # a time integration: its own steps and charts
        return Plan(scene=scene, steps=tuple(steps + dynamics_steps(scene)), n_modes=None, vectors=False)
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
    if draw.spectrum:
        steps.append(Step("chart-spectrum", "IR and Raman spectra (model intensities, Lorentzian lines)"
                          if scene.kind == "molecule" else "stick spectrum of the frequencies"))
    if draw.spectrum and engine is not None:
        steps.append(Step("chart-experiment", "computed (scaled) against observed fundamentals and IR intensities, "
                          "where the molecule has observed values bundled"))
    if draw.dispersion:
        steps.append(Step("chart-dispersion", "dispersion relation with the chain's modes"))
    if draw.response:
        steps.append(Step("chart-response", "response amplitude and phase against frequency"))
    if draw.bfactors:
        steps.append(Step("chart-bfactors", "fitted against crystallographic B-factors per residue, on one axis"))
    if scene.kind == "network":
        steps.append(Step("chart-correlations", "residue cross-correlation map of the computed modes"))
    if draw.convergence:
        steps.append(Step("chart-convergence", "error of the chain's modes against N (log-log)"))
    return Plan(scene=scene, steps=tuple(steps), n_modes=n_modes, vectors=vectors)


def _engine_steps(scene: Scene) -> tuple[Step, ...] | None:
    """The steps of a molecule scene's electronic-structure engine (`vibra.pipeline.plan.electronic`):
    ``electronic`` after the build, or ``engine-missing`` alone when its package is not installed;
    None for the bundled force field."""
    if scene.kind != "molecule":
        return None
    from vibra.pipeline.plan.electronic import engine_missing, scene_engine

    choice = scene_engine(scene)
    if choice is None:
        return None
    missing = engine_missing(scene)
    if missing is not None:
        return (Step("engine-missing", f"nothing computed: {missing}"),)
    return (Step("electronic", f"{choice.level}: optimise the geometry, then the analytic Hessian and the dipole "
                 "and polarisability derivatives by finite differences (vibra.molecules.engines)"),)


def polar_crystal(scene: Scene) -> bool:
    """True for a crystal scene whose crystal carries Born charges (a phonopy scene's ``born_file``,
    or the ``nac`` section of its yaml): its bands show the LO-TO split and the plan adds its
    infrared response."""
    if scene.kind != "crystal" or scene.system.builder != "phonopy":
        return False
    params = scene.system.parameters
    if params.get("born_file") is not None:
        return True
    from vibra.pipeline.scene.files import phonopy_yaml_summary

    return phonopy_yaml_summary(scene.source, params["file"]).born


def crystal_steps(scene: Scene) -> list[Step]:
    """The steps after ``build`` that a crystal scene asks for."""
    spec = scene.crystal
    assert spec is not None
    mesh = "x".join(str(n) for n in spec.mesh)
    steps = []
    if spec.bands:
        where = "SeeK-path's path" if spec.path is None else "the path " + " | ".join("-".join(r) for r in spec.path)
        steps.append(Step("crystal-bands", f"bands on {spec.npoints} q-points along {where}; "
                          f"{spec.dos_method} DOS on a {mesh} mesh"))
        steps.append(Step("chart-bands", f"band structure with the DOS beside it, in {spec.frequency_unit}"))
    if polar_crystal(scene):
        damping = scene.system.parameters.get("infrared_damping") or 0.0
        steps.append(Step("crystal-infrared", f"TO modes at Gamma, their mode charges and eps(omega) of the Born "
                          f"charges, LO frequencies, damping {damping:g} cm^-1"))
        steps.append(Step("chart-infrared", "dielectric function and reflectivity with the reststrahlen band"))
    if spec.thermal:
        steps.append(Step("crystal-thermal", f"free energy, entropy and heat capacity at {spec.n_temperatures} "
                          f"temperatures in [{spec.temperatures[0]:g}, {spec.temperatures[1]:g}] K on a {mesh} mesh"))
        steps.append(Step("chart-thermal", "thermal properties against temperature"))
    if spec.mode:
        cells = "x".join(str(n) for n in spec.supercell)
        steps.append(Step("crystal-mode", f"branch {spec.mode_branch} at q = {spec.mode_q} on a {cells} supercell"))
        steps.append(Step("render-crystal-mode", f"animated GIF of that mode, {spec.frames} frames (pyvista)"))
    return steps


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
