"""Molecule scenes computed by an electronic-structure engine (``[system] engine = "pyscf"``).

- `scene_engine(scene)`: the scene's validated `EngineChoice` (None for the bundled force field).
- `engine_missing(scene)`: the `EngineMissingError` when the engine's package is not installed:
  `vibra validate` refuses the scene with it, and `vibra report` renders the scene as a page that
  says what to install (the ``engine-missing`` step) instead of failing the report.
- `check_engine_plan(scene, system)`: the cost estimate (`vibra.molecules.engines.engine_cost`,
  from sizes, before any SCF) against the scene's limits (``compute.time_limit_s``, default
  `vibra.solvers.accuracy.TIME_LIMIT_S`; ``compute.memory_limit_gib``, default
  `vibra.solvers.budget.memory_limit`): over either, a `SceneError` at the key that chose the
  level, naming the estimate, the limit and the levels that would fit.
- The steps: ``electronic`` (optimise the geometry with the engine, then
  `vibra.molecules.engines.electronic_structure`: the Hessian the modes come from, the dipole and
  polarisability derivatives) and ``engine-missing``; its chart, ``chart-experiment`` (computed
  against observed fundamentals, from `experiment_comparison`), is in `vibra.pipeline.plan.chartsteps`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from vibra.molecules.engines.choice import (EngineChoice, EngineChoiceError, EngineMissingError, cheaper_choices,
                                            check_engine_choice, engine_cost, make_engine, require_engine)
from vibra.pipeline.scene import Scene, SceneError

if TYPE_CHECKING:
    from vibra.generalized import GeneralizedSystem
    from vibra.modes import Modes
    from vibra.molecules.engines.electronic import ElectronicStructure
    from vibra.pipeline.plan.analysis import MoleculeSpectra, MoleculeSymmetry
    from vibra.pipeline.plan.build import BuiltSystem
    from vibra.spectra.experiment import ExperimentComparison
    from vibra.system import System

__all__ = ["scene_engine", "engine_missing", "check_engine_plan", "engine_summary", "electronic_run",
           "electronic_spectra", "electronic_hints", "experiment_comparison", "engine_system", "ENGINE_KEYS", "OPTIMISER_FMAX", "OPTIMISER_STEPS",
           "ELECTRONIC_STEPS"]

#: The scene keys of an engine choice.
ENGINE_KEYS = ("engine", "method", "basis")
#: Largest residual force after the engine's geometry optimisation, in eV / Angstrom (below the
#: 1e-3 that `electronic_structure` accepts), and the most steps the optimiser may take.
OPTIMISER_FMAX = 2e-4
OPTIMISER_STEPS = 200


def scene_engine(scene: Scene) -> EngineChoice | None:
    """The scene's engine choice (None: the bundled force field, or a scene without those keys).

    Raises
    ------
    SceneError
        An unknown engine, method or basis (at ``system.<key>``).
    """
    params = scene.system.parameters
    if params.get("engine") in (None, "forcefield") and params.get("method") is None and params.get("basis") is None:
        return None
    try:
        choice = check_engine_choice(params.get("engine"), params.get("method"), params.get("basis"), require=False)
    except EngineChoiceError as error:
        raise SceneError(scene.source, f"system.{error.key}", str(error)) from None
    except EngineMissingError:
        return EngineChoice(str(params.get("engine")), params.get("method"), params.get("basis"))
    return choice if choice.electronic else None


def engine_missing(scene: Scene) -> EngineMissingError | None:
    """The missing-package error of the scene's engine (None when installed or no engine)."""
    params = scene.system.parameters
    engine = params.get("engine")
    if engine in (None, "forcefield"):
        return None
    try:
        require_engine(str(engine))
    except EngineMissingError as error:
        return error
    except KeyError:
        return None
    return None


def _numbers(system: System | GeneralizedSystem) -> list[int]:
    from ase.data import atomic_numbers

    from vibra.pipeline.scene.values import element_symbol

    return [atomic_numbers[element_symbol(s)] for s in system.symbols]


def _key(scene: Scene) -> str:
    params = scene.system.parameters
    return "system.basis" if params.get("basis") is not None else "system.method" if params.get(
        "method") is not None else "system.engine"


def check_engine_plan(scene: Scene, system: System | GeneralizedSystem) -> None:
    """Refuse an engine scene whose estimate exceeds its time or memory limit, before any SCF."""
    choice = scene_engine(scene)
    if choice is None:
        return
    if not system.symbols or system.dim != 3:
        raise SceneError(scene.source, "system.engine", "an engine computes a 3-D molecule with chemical symbols")
    from vibra.solvers.accuracy import TIME_LIMIT_S
    from vibra.solvers.budget import describe_bytes, memory_limit

    compute = scene.compute
    try:
        cost = engine_cost(choice, _numbers(system))
    except EngineChoiceError as error:
        raise SceneError(scene.source, f"system.{error.key}", str(error)) from None
    seconds = TIME_LIMIT_S if compute.time_limit_s is None else float(compute.time_limit_s)
    known = memory_limit(None if compute.memory_limit_gib is None else compute.memory_limit_gib * 2.0**30)
    room = float("inf") if known is None else known[1]
    over = []
    if cost.seconds > seconds:
        over.append(f"about {cost.seconds:.3g} s, more than the time limit of {seconds:g} s (compute.time_limit_s)")
    if cost.memory > room:
        over.append(f"about {describe_bytes(cost.memory)}, more than the memory limit of {describe_bytes(room)} "
                    "(compute.memory_limit_gib)")
    if over:
        fits = cheaper_choices(choice, _numbers(system), seconds, room)
        advice = "; within the limits: " + ", ".join(fits) if fits else "; no cheaper level fits"
        raise SceneError(scene.source, _key(scene), f"{cost.level} for {cost.n_atoms} atoms would take "
                         f"{' and '.join(over)}: {cost.detail}{advice}, or raise the limit")


def engine_summary(scene: Scene, system: System | GeneralizedSystem) -> str | None:
    """What ``vibra validate`` prints of an engine scene: its level and cost estimate (None without one)."""
    choice = scene_engine(scene)
    if choice is None:
        return None
    from vibra.solvers.budget import describe_bytes

    cost = engine_cost(choice, _numbers(system))
    return (f"{cost.level}: about {cost.seconds:.2g} s and {describe_bytes(cost.memory)} before the modes "
            f"({cost.calculations} engine calculations and one Hessian, estimated from sizes)")


def electronic_run(scene: Scene, system: System) -> ElectronicStructure:
    """Optimise the molecule with the scene's engine, then its `ElectronicStructure`.

    Raises
    ------
    RuntimeError
        The optimiser did not reach `OPTIMISER_FMAX` in `OPTIMISER_STEPS` steps, or an SCF failed.
    """
    from ase import Atoms
    from ase.optimize import BFGS

    from vibra.molecules.engines import EngineCalculator, electronic_structure
    from vibra.pipeline.scene.values import element_symbol

    choice = scene_engine(scene)
    assert choice is not None  # the plan adds this step for engine scenes only
    engine = make_engine(choice)
    symbols = [element_symbol(s) for s in system.symbols]
    atoms = Atoms(symbols, positions=np.asarray(system.positions, dtype=float).reshape(-1, 3),
                  masses=np.asarray(system.masses, dtype=float))
    atoms.calc = EngineCalculator(engine)
    optimiser = BFGS(atoms, logfile=None)
    if not optimiser.run(fmax=OPTIMISER_FMAX, steps=OPTIMISER_STEPS):
        raise RuntimeError(f"{engine.level}: the geometry optimisation did not reach a residual force of "
                           f"{OPTIMISER_FMAX:g} eV/Angstrom in {OPTIMISER_STEPS} steps")
    atoms.calc = None
    return electronic_structure(atoms, engine)


def _species(analysis: Any, indices: Any) -> list[str]:
    labels = dict(zip((int(k) for k in analysis.vibrations), analysis.species))
    return [labels.get(int(k), "") for k in indices]


def electronic_spectra(electronic: ElectronicStructure, *, line_width: float, merge_cm1: float = 0.5) -> MoleculeSpectra:
    """The `MoleculeSpectra` of an engine's results: IR from dipole derivatives, Raman from
    polarisability derivatives where the engine gives them, species on each line."""
    from vibra import spectra
    from vibra.molecules import vibrational_analysis
    from vibra.pipeline.plan.analysis import MoleculeSpectra

    analysis = vibrational_analysis(electronic.system())
    top = float(np.max(np.abs(analysis.wavenumbers_cm1()), initial=0.0))
    grid = np.linspace(0.0, 1.1 * top + 4 * line_width, 2400)
    ir = spectra.electronic_ir_spectrum(electronic, analysis)
    ir_sticks = ir.sticks(merge_cm1=merge_cm1)
    ir_species = _line_species(ir_sticks.wavenumbers, ir.wavenumbers, _species(analysis, ir.mode_indices), merge_cm1)
    level = electronic.level
    raman = raman_profile = None
    raman_species: tuple[str, ...] = ()
    raman_model = f"no Raman: {level} gives no polarisability"
    if electronic.polarizability_derivatives is not None:
        result = spectra.electronic_raman_spectrum(electronic, analysis)
        raman = result.sticks(merge_cm1=merge_cm1)
        raman_profile = raman.broadened(grid, line_width, "lorentzian")
        raman_species = _line_species(raman.wavenumbers, result.wavenumbers,
                                      _species(analysis, result.mode_indices), merge_cm1)
        raman_model = f"Raman activities from {level} polarisability derivatives ({electronic.polarizability_method})"
    return MoleculeSpectra(ir=ir_sticks, ir_profile=ir_sticks.broadened(grid, line_width, "lorentzian"),
                           ir_species=ir_species, ir_model=f"IR intensities from {level} dipole derivatives",
                           raman=raman, raman_profile=raman_profile, raman_species=raman_species,
                           raman_model=raman_model, n_rigid=int(analysis.n_rigid))


def _line_species(positions: Any, wavenumbers: Any, species: list[str], merge_cm1: float) -> tuple[str, ...]:
    out = []
    for position in positions:
        near = [s for s, w in zip(species, wavenumbers) if abs(w - position) <= merge_cm1 and s]
        out.append("+".join(dict.fromkeys(near)))
    return tuple(out)


def electronic_hints(electronic: ElectronicStructure, system: System, modes: Modes, indices: Sequence[int],
                     symmetry: MoleculeSymmetry | None) -> dict[int, str]:
    """Per drawn mode: its species and activity by symmetry (`symmetry_hints` without point
    charges) and the engine's IR intensity (km/mol, and relative to the strongest line)."""
    from vibra import spectra
    from vibra.molecules import vibrational_analysis
    from vibra.pipeline.plan.analysis import symmetry_hints

    hints = symmetry_hints(system, modes, indices, list(system.symbols), [], symmetry)
    ir = spectra.electronic_ir_spectrum(electronic, vibrational_analysis(electronic.system()))
    km = np.asarray(ir.intensities_km_per_mol())
    strongest = float(km.max(initial=0.0))
    wavenumbers = np.asarray(modes.wavenumbers_cm1())
    for k in indices:
        distance = np.abs(np.asarray(ir.wavenumbers) - wavenumbers[int(k)])
        if not len(distance) or distance.min() > 1.0:  # (a rigid-body mode: no line)
            continue
        value = float(km[int(np.argmin(distance))])
        text = (f"IR {value:.3g} km/mol at {electronic.level}"
                + (f" ({value / strongest:.2f} of strongest)" if strongest > 0 else ""))
        hints[int(k)] = "; ".join(part for part in (hints.get(int(k), ""), text) if part)
    return hints


def experiment_comparison(electronic: ElectronicStructure) -> ExperimentComparison | None:
    """`vibra.spectra.compare_with_experiment` of an engine's IR spectrum against the molecule's
    observed fundamentals; None when the molecule has none bundled."""
    from vibra import spectra
    from vibra.molecules import experimental_fundamentals, vibrational_analysis

    entry = experimental_fundamentals(list(electronic.symbols), electronic.masses)
    if entry is None:
        return None
    analysis = vibrational_analysis(electronic.system())
    ir = spectra.electronic_ir_spectrum(electronic, analysis)
    return spectra.compare_with_experiment(ir, _species(analysis, ir.mode_indices), entry)


# ------------------------------------------------------------------------------ the steps
def _step_electronic(plan: Any, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    """Optimise, then the engine's Hessian and derivatives; the system of the modes is the engine's."""
    built = context.system
    electronic = electronic_run(plan.scene, built)
    context.electronic = electronic
    context.system = _projected_system(electronic, built.masses, plan.scene.name)
    how = electronic.hessian_method
    check = ""
    if electronic.analytic_hessian is not None:
        check = f"; |analytic - finite difference| <= {electronic.hessian_disagreement():.2g} x the fd error estimate"
    methods = dict(electronic.methods)
    return (f"{electronic.level} ({how} Hessian, polarisability: {methods.get('polarizability', 'none')})",
            f"finite differences of the dipole{' and polarisability' if electronic.polarizability_derivatives is not None else ''}{check}")


def _projected_system(electronic: Any, masses: Any, name: str) -> Any:
    """The molecule with the engine's Hessian, translations and rotations projected out (Eckart, as
    `vibra.molecules.vibrational_analysis` does): its rigid-body modes come out at zero, not at the
    few cm^-1 (real or imaginary) that the residual force and the finite SCF convergence leave."""
    from vibra.molecules.rigid_body import rigid_body_vectors
    from vibra.system import System

    positions = np.asarray(electronic.positions, dtype=float)
    masses = np.asarray(masses, dtype=float)
    rigid = rigid_body_vectors(positions, masses)
    projector = np.eye(rigid.shape[0]) - rigid @ rigid.T
    root = np.sqrt(np.repeat(masses, 3))
    weighted = projector @ (np.asarray(electronic.hessian) / np.outer(root, root)) @ projector
    hessian = (weighted + weighted.T) / 2.0 * np.outer(root, root)
    system = System.from_hessian(positions, masses, hessian, units="ASE", name=name)
    return system.with_symbols(list(electronic.symbols))


def engine_system(scene: Scene, system: BuiltSystem) -> BuiltSystem:
    """The system whose modes a scene asks for: `system` itself, or for an engine scene the
    molecule with the engine's Hessian (`electronic_run`, projected as the report's plan does).

    Raises
    ------
    SceneError
        The engine's package is missing (at ``system.engine``).
    """
    if scene.kind != "molecule" or scene_engine(scene) is None:
        return system
    missing = engine_missing(scene)
    if missing is not None:
        raise SceneError(scene.source, "system.engine", str(missing))
    return _projected_system(electronic_run(scene, system), system.masses, scene.name)


def _step_engine_missing(plan: Any, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    """Write what the scene needs, instead of computing it."""
    from vibra._core.filesystem import atomic_write_text

    missing = engine_missing(plan.scene)
    text = (f"{plan.scene.title}: not computed on this machine. {missing}\n"
            "The scene's level of theory needs that package; with it installed, `vibra report` computes the "
            "spectra.\n")
    from vibra.charts.experiment import needs_figure

    needs = (f"needs {missing.package}: pip install 'vibra[{missing.extra}]'" if missing is not None
             else "needs the engine's package")
    context.save_chart(needs_figure(plan.scene.title, str(missing)), "needs", f"{plan.scene.title}: {needs}")
    name = f"{plan.scene.name}_needs.txt"
    atomic_write_text(context.out_dir / name, text)
    context.outputs.append(name)
    context.captions.append(needs)
    return None, "not computed: the engine's package is missing"


#: step name -> the function that runs it.
ELECTRONIC_STEPS = {"electronic": _step_electronic, "engine-missing": _step_engine_missing}
