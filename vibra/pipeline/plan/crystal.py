"""The steps of a crystal scene: bands with the DOS, thermal properties, one mode on a supercell.

A crystal scene (``kind = "crystal"``) builds a `vibra.crystals.Crystal` (a lattice builder, or a
phonopy file beside the scene) and then computes only what its ``[draw]`` table asks:

- ``bands``: the band structure along the scene's path (SeeK-path's when none) and, beside it,
  the DOS on the scene's mesh (``crystal-bands``, drawn by ``chart-bands``);
- ``thermal``: free energy, entropy and heat capacity on the same mesh (``crystal-thermal``,
  drawn by ``chart-thermal``);
- ``mode``: one branch at one q written out on a supercell (``crystal-mode``) and animated
  (``render-crystal-mode``, a GIF);
- a polar crystal (Born charges in ``system.born_file`` or the yaml's ``nac`` section): its infrared response, the TO modes at
  Gamma with their mode charges, ε(ω) with the damping ``system.infrared_damping`` (cm⁻¹) and
  the LO frequencies along ``system.infrared_direction`` (``crystal-infrared``), drawn as ε(ω)
  and the reflectivity with its reststrahlen band (``chart-infrared``).

The steps themselves are listed by `crystal_steps`.
`check_crystal_plan` is what ``vibra validate`` checks on the built crystal (path labels, the
mode's q label and branch, the supercell along vacuum axes), and `crystal_cost` the size and
cost line it prints. `KIND` declares all of it for the crystal scene kind (`vibra.pipeline.plan.kinds`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra.pipeline.plan.checks import refused_as
from vibra.pipeline.plan.model import Plan, PlanKind, Step, build_step
from vibra.pipeline.scene import Scene, SceneError
from vibra.pipeline.scene.limits import DEFAULT_TIME_LIMIT_S, frames_that_fit, render_seconds
from vibra.solvers.budget import describe_seconds
from vibra._core.text import counted

if TYPE_CHECKING:
    from vibra.crystals import Crystal

__all__ = ["check_crystal_plan", "crystal_cost", "light_direction", "CRYSTAL_STEPS", "CRYSTAL_STEP_KEYS",
           "DEFAULT_LIGHT_DIRECTION", "polar_crystal", "crystal_steps", "crystal_plan", "KIND"]

#: step name -> the scene key that controls it.
CRYSTAL_STEP_KEYS = {"crystal-bands": "compute", "chart-bands": "draw.bands", "crystal-thermal": "compute",
                     "chart-thermal": "draw.thermal", "crystal-mode": "draw.mode",
                     "render-crystal-mode": "draw.mode", "crystal-infrared": "system.born_file",
                     "chart-infrared": "system.born_file"}

#: The light's polarisation when a polar scene gives no ``system.infrared_direction``.
DEFAULT_LIGHT_DIRECTION = (1.0, 0.0, 0.0)


def _known_points(scene: Scene, crystal: Crystal) -> dict[str, Any]:
    from vibra.crystals.bands import special_points

    try:
        table, _ = special_points(crystal)
    except ValueError as error:
        raise SceneError(scene.source, "compute.path", f"no special points for this crystal ({error})") from None
    return table


def _label(scene: Scene, table: dict[str, Any], label: str, key: str) -> str:
    from vibra.crystals.bands import ALIASES

    name = label if label in table else ALIASES.get(label, label)
    if name not in table:
        known = ", ".join(sorted(table)) or "none"
        raise SceneError(scene.source, key, f"is {label!r}, not a special point of this crystal; known "
                         f"points: {known} ('G' and 'Γ' also mean 'GAMMA')")
    return name


def mode_wave_vector(scene: Scene, crystal: Crystal) -> NDArray[np.float64]:
    """(3,) fractional q of ``draw.mode_q`` (a special-point label or 3 numbers)."""
    spec = scene.crystal
    assert spec is not None
    if isinstance(spec.mode_q, str):
        table = _known_points(scene, crystal)
        return np.asarray(table[_label(scene, table, spec.mode_q, "draw.mode_q")], dtype=float)
    return np.asarray(spec.mode_q, dtype=float)


def mode_supercell(crystal: Crystal, supercell: Sequence[int]) -> NDArray[np.int64]:
    """(3, 3) supercell matrix of the mode render for ``draw.supercell`` = (n1, n2, n3).

    For a cubic lattice (simple, face- or body-centred: sc, bcc, fcc, diamond, rock salt) the
    mode is drawn on conventional cubes, which read along the cube's axes (an fcc primitive
    supercell is a rhombohedron whose rows of atoms hide each other): as many cubes along
    each axis as give at most n1 n2 n3 primitive cells (at least 1). Other lattices: diag(n).
    """
    from vibra.crystals import conventional_cube

    size = np.asarray(supercell, dtype=np.int64)
    cube = conventional_cube(crystal)
    if cube is None or len(set(size.tolist())) != 1:
        return np.diag(size)
    per_cube = abs(round(float(np.linalg.det(cube))))
    edge = max(1, int(float(size[0]) / per_cube ** (1.0 / 3.0) + 1e-9))
    return edge * cube


def check_crystal_plan(scene: Scene, crystal: Crystal) -> None:
    """What the crystal steps would refuse, checked on the built crystal (no bands computed).

    Raises
    ------
    SceneError
        A path label that is not a special point of the crystal (``compute.path[r][k]``), the
        same for ``draw.mode_q``, a branch beyond the crystal's, a supercell or mesh that is not
        1 along a vacuum axis.
    ResourceLimitError
        The D(q) solves of the bands or the mesh estimated over the limits their run is guarded
        with (`vibra.crystals.dynamical.solve_plan`: the default ones).
    """
    spec = scene.crystal
    assert spec is not None
    crystal.require_force_constants()
    if spec.bands and spec.path is not None:
        table = _known_points(scene, crystal)
        for r, run in enumerate(spec.path):
            for k, label in enumerate(run):
                _label(scene, table, label, f"compute.path[{r}][{k}]" if len(spec.path) > 1 else f"compute.path[{k}]")
    if spec.mode:
        mode_wave_vector(scene, crystal)
        if spec.mode_branch >= crystal.n_branches:
            raise SceneError(scene.source, "draw.mode_branch", f"is {spec.mode_branch}; this crystal has "
                             f"{crystal.n_branches} branches (0 to {crystal.n_branches - 1})")
        atoms = _mode_atoms(crystal, spec.supercell)
        seconds = render_seconds(atoms, spec.frames)
        if seconds > DEFAULT_TIME_LIMIT_S:
            raise SceneError(scene.source, "draw.frames", f"is {spec.frames}: the animation of {atoms} atoms "
                             f"(draw.supercell {list(spec.supercell)}) would take about {describe_seconds(seconds)} "
                             f"to render, more than {DEFAULT_TIME_LIMIT_S:g} s; {frames_that_fit(atoms, DEFAULT_TIME_LIMIT_S)} "
                             "frames fit, or take a smaller supercell")
    _check_infrared(scene, crystal)
    from vibra.crystals.dynamical import solve_plan  # the run's own guard, before it (ResourceLimitError)

    if spec.bands:
        solve_plan(crystal, spec.npoints, vectors=True)
    if spec.bands or spec.thermal:
        solve_plan(crystal, int(np.prod(spec.mesh)), vectors=False)
    for axis in range(3):
        if not crystal.periodic[axis]:
            if spec.mode and spec.supercell[axis] != 1:
                raise SceneError(scene.source, "draw.supercell", f"is {list(spec.supercell)}; axis {axis} is a "
                                 "vacuum axis of this crystal and takes 1 cell")
            if (spec.bands or spec.thermal) and spec.mesh[axis] != 1:
                raise SceneError(scene.source, "compute.mesh", f"is {list(spec.mesh)}; axis {axis} is a vacuum "
                                 "axis of this crystal and takes 1 point")


def _check_infrared(scene: Scene, crystal: Crystal) -> None:
    """The infrared keys need Born charges; a polar crystal needs a stable, primitive cell at Gamma."""
    params = scene.system.parameters
    if not polar_crystal(scene):
        for key in ("infrared_damping", "infrared_direction"):
            if params.get(key) is not None:
                raise SceneError(scene.source, f"system.{key}", "is set, but this crystal has no Born charges: "
                                 "name the BORN file in system.born_file (or read a yaml with a nac section)")
        return
    from vibra.crystals import infrared_response

    nac = crystal.nac
    where = "system.born_file" if params.get("born_file") is not None else "system.file"  # the charges' source
    if nac is None:  # pragma: no cover - read_phonopy gives the correction of a BORN file or a nac section
        raise SceneError(scene.source, where, "gave no non-analytic correction")
    try:  # what the crystal-infrared step would refuse (a cell not primitive, an unstable optical mode)
        infrared_response(crystal, nac.born, nac.dielectric, factor=nac.factor)
    except (ValueError, RuntimeError) as error:
        raise SceneError(scene.source, where, f"the infrared response is not defined: {error}") from None


def light_direction(scene: Scene) -> NDArray[np.float64]:
    """(3,) unit Cartesian polarisation of the light: ``system.infrared_direction`` or [1, 0, 0]."""
    given = scene.system.parameters.get("infrared_direction")
    direction = np.asarray(DEFAULT_LIGHT_DIRECTION if given is None else given, dtype=float)
    return direction / np.linalg.norm(direction)


def _mode_atoms(crystal: Crystal, supercell: Sequence[int]) -> int:
    """Atoms drawn in a crystal's mode animation on `supercell` (`mode_supercell`'s cells)."""
    return abs(round(float(np.linalg.det(mode_supercell(crystal, supercell))))) * crystal.n_atoms


def crystal_cost(scene: Scene, crystal: Crystal) -> str:
    """The size of a crystal scene and the work it asks for, in one line (``vibra validate``)."""
    spec = scene.crystal
    assert spec is not None
    fc = crystal.require_force_constants()
    n3 = crystal.n_branches
    parts = [f"{counted(crystal.n_atoms, 'atom')} per cell, {counted(n3, 'branch')}, "
             f"{counted(fc.n_terms, 'force-constant term')}"]
    if spec.bands:
        parts.append(f"bands {spec.npoints} q")
    n_mesh = 0
    if spec.bands or spec.thermal:
        n_mesh = int(np.prod(spec.mesh))
        parts.append(f"mesh {'x'.join(str(n) for n in spec.mesh)} = {n_mesh} q (fewer by symmetry)")
    if spec.mode:
        atoms = _mode_atoms(crystal, spec.supercell)
        parts.append(f"mode on {atoms} atoms x {spec.frames} frames (~{describe_seconds(render_seconds(atoms, spec.frames))} "
                     "to render)")
    infrared = 0
    if polar_crystal(scene):
        from vibra.charts.infrared import GRID_POINTS

        parts.append(f"infrared: Gamma modes, eps(omega) on {GRID_POINTS} wavenumbers")
        infrared = GRID_POINTS * n3 * 9 * 2 * 8  # eps(omega) and the reflectivity: complex (3 x 3) sums per mode
    from vibra.crystals.dynamical import solve_plan

    # the solves costed once, by the solver registry's hermitian-eigh path (`dynamical.solve_plan`:
    # the bands with vectors, to connect their branches; the mesh's frequencies, all of its q-points)
    seconds = 0.0
    for n_q, vectors in ((spec.npoints if spec.bands else 0, True), (n_mesh, False), (1 if infrared else 0, True)):
        if n_q:
            seconds += solve_plan(crystal, n_q, vectors=vectors, guarded=False).cost.seconds
    parts.append(f"D(q) solves ~{describe_seconds(seconds)} (the hermitian-eigh path's estimate)"
                 + (" and eps(omega)" if infrared else ""))
    return "; ".join(parts)


# ---------------------------------------------------------------------- steps
def _frequency_text(scene: Scene, units: Any, omega: float) -> str:
    spec = scene.crystal
    assert spec is not None
    if spec.frequency_unit == "THz":
        return f"{float(units.omega_to_thz(omega)):.4g} THz"
    return f"{float(units.omega_to_cm1(omega)):.4g} cm^-1"


def _step_bands(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    spec = plan.scene.crystal
    crystal = context.system
    path = None if spec.path is None else [list(run) for run in spec.path]
    bands = crystal.band_structure(path, npoints=spec.npoints)
    dos = crystal.dos(list(spec.mesh), method=spec.dos_method)
    context.bands = (bands, dos)
    scale = max(float(np.abs(bands.omega).max()), np.finfo(float).tiny)
    return "stacked Hermitian eigh + " + spec.dos_method, \
        f"max omega error {float(bands.omega_error.max()) / scale:.2e} (relative to max omega)"


def _step_chart_bands(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.crystals import plot_bands_dos
    from vibra.crystals.irreps import NotPrimitiveError, gamma_modes

    spec = plan.scene.crystal
    bands, dos = context.bands
    try:
        gamma = gamma_modes(context.system)
        irreps = "; optical levels at Gamma labelled with their irreps (point group " + gamma.point_group + ")"
    except NotPrimitiveError:
        gamma = None
        irreps = "; Gamma levels unlabelled: the cell is not primitive (its Gamma holds folded zone-boundary modes)"
    except RuntimeError as error:  # spglib found no group, or its operations do not map the atoms
        gamma = None
        irreps = f"; Gamma levels unlabelled: {' '.join(str(error).split())}"
    figure = plot_bands_dos(bands, dos, unit=spec.frequency_unit, title=plan.scene.title, gamma=gamma,
                            polar=getattr(context.system, "nac", None) is not None)
    unit = "THz" if spec.frequency_unit == "THz" else "cm^-1"
    nac = getattr(context.system, "nac", None)
    polar = "" if nac is None else (f"; with the Born charges' long-range field ("
                                    f"{'Gonze-Lee' if nac.method == 'gonze' else 'Wang'} correction) the LO branch "
                                    "splits from the TO at Gamma, Gamma approached along the path")
    context.save_chart(figure, "bands",
                       f"{plan.scene.title}: phonon bands along the path (vertical lines at the special points, "
                       f"a heavier one where the path breaks) and the {dos.method} DOS on a "
                       f"{'x'.join(str(int(n)) for n in dos.mesh)} mesh, in {unit}{polar}{irreps}")
    # the interactive view of the same bands (issue 46, item 5): click a point, see its mode on a supercell
    from vibra.pipeline.plan.views import write_band_view

    write_band_view(plan, context, bands, unit=spec.frequency_unit)
    return None, None


def _step_thermal(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    spec = plan.scene.crystal
    temperatures = np.linspace(spec.temperatures[0], spec.temperatures[1], spec.n_temperatures)
    context.thermal = context.system.thermal_properties(temperatures, mesh=list(spec.mesh))
    excluded = context.thermal.excluded
    return "harmonic sums over the mesh", f"{counted(excluded, 'mode')} left out as not certainly positive"


def _step_chart_thermal(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.crystals import plot_thermal

    figure = plot_thermal(context.thermal, title=plan.scene.title)
    context.save_chart(figure, "thermal",
                       f"{plan.scene.title}: harmonic free energy, entropy and heat capacity per mole of cells "
                       "against temperature (C_v tends to 3 n_atoms R, the Dulong-Petit limit)")
    return None, None


def _step_mode(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    spec = plan.scene.crystal
    crystal = context.system
    q = mode_wave_vector(plan.scene, crystal)
    context.supercell_mode = crystal.supercell_mode(q, spec.mode_branch, mode_supercell(crystal, spec.supercell))
    mode = context.supercell_mode
    return None, f"omega = {_frequency_text(plan.scene, crystal.units, mode.omega)} at q = {np.round(q, 4).tolist()}"


def _step_render_mode(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    spec = plan.scene.crystal
    mode = context.supercell_mode
    label = spec.mode_q if isinstance(spec.mode_q, str) else str(list(spec.mode_q))
    frequency = f"branch {mode.branch} at q = {label}: {_frequency_text(plan.scene, mode.units, mode.omega)}"
    name, caption = renderer.render_supercell_mode(plan.scene, mode, context.out_dir, frames=spec.frames,
                                                   frequency=frequency)
    context.outputs.append(name)
    context.captions.append(caption)
    return None, None


def _step_infrared(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.crystals import infrared_response

    crystal = context.system
    nac = crystal.nac
    damping = float(plan.scene.system.parameters.get("infrared_damping") or 0.0)
    response = infrared_response(crystal, nac.born, nac.dielectric, factor=nac.factor,
                                 damping=crystal.units.cm1_to_omega(damping))
    context.infrared = response
    direction = light_direction(plan.scene)
    bands = crystal.units.omega_to_cm1(response.reststrahlen_bands(direction))
    product, ratio = response.lyddane_sachs_teller(direction)
    pairs = ", ".join(f"TO {to:.4g} / LO {lo:.4g}" for to, lo in bands)
    pairs = f"{pairs} cm^-1" if pairs else "no mode couples to light along the polarisation"
    return "Gamma modes (analytic D(0)) + oscillator sum over the TO modes", \
        f"{pairs}; Lyddane-Sachs-Teller off by {abs(product / ratio - 1.0):.1e}"


def _step_chart_infrared(plan: Plan, context: Any, renderer: Any) -> tuple[str | None, str | None]:
    from vibra.charts.infrared import infrared_figure

    response = context.infrared
    direction = light_direction(plan.scene)
    figure = infrared_figure(response, direction=direction, title=plan.scene.title)
    units = response.units
    bands = units.omega_to_cm1(response.reststrahlen_bands(direction))
    where = "; ".join(f"{to:.0f} to {lo:.0f} cm^-1" for to, lo in bands) or "none"
    epsilon_0 = float(direction @ response.static_dielectric() @ direction)
    epsilon_inf = float(direction @ response.epsilon_inf @ direction)
    damping = float(plan.scene.system.parameters.get("infrared_damping") or 0.0)
    context.save_chart(figure, "infrared",
                       f"{plan.scene.title}: dielectric function eps(omega) (real and imaginary parts) and the "
                       f"normal-incidence reflectivity for light polarised along {np.round(direction, 3).tolist()}, "
                       f"from the Born charges and the TO modes at Gamma (damping {damping:g} cm^-1); the "
                       f"reststrahlen band, TO to LO, is shaded: {where}; eps(0) = {epsilon_0:.4g}, "
                       f"eps(inf) = {epsilon_inf:.4g}")
    return None, None


#: step name -> the function that runs it (joined to `vibra.pipeline.plan.steps.STEPS`).
CRYSTAL_STEPS: dict[str, Callable[[Plan, Any, Any], tuple[str | None, str | None]]] = {
    "crystal-bands": _step_bands,
    "chart-bands": _step_chart_bands,
    "crystal-thermal": _step_thermal,
    "chart-thermal": _step_chart_thermal,
    "crystal-mode": _step_mode,
    "render-crystal-mode": _step_render_mode,
    "crystal-infrared": _step_infrared,
    "chart-infrared": _step_chart_infrared,
}


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


def crystal_plan(scene: Scene) -> Plan:
    """A crystal scene's plan: no Modes of one system, but bands, DOS, thermal properties, a mode on a supercell."""
    return Plan(scene=scene, steps=(build_step(scene), *crystal_steps(scene)), n_modes=None, vectors=False)


#: The crystal scene kind: what it plans, checks, prints and runs.
KIND = PlanKind("crystal", plan=crystal_plan, check=refused_as("build", check_crystal_plan), summary=crystal_cost,
                build_note=crystal_cost,
                steps=CRYSTAL_STEPS, step_keys=CRYSTAL_STEP_KEYS, renders=True)
