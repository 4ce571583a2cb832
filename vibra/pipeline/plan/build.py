"""Building the system a scene describes: scene parameters -> one builder call of vibra.

Builders are looked up in `vibra.pipeline.scene.BUILD_FUNCTIONS`, a fixed table of (module, function)
inside vibra; nothing from a scene file is imported or executed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Union

import numpy as np

from vibra._core.validate import ArgumentError
from vibra._core.text import counted
from vibra.molecules import molecule_names
from vibra.pipeline.scene import Scene, SceneError, builder_function
from vibra.pipeline.scene.builders import lattice_builders
from vibra.pipeline.scene.files import check_phonopy_scene_files, read_scene_data, scene_data_path

if TYPE_CHECKING:
    from vibra.crystals import Crystal
    from vibra.generalized import GeneralizedSystem
    from vibra.networks import Structure
    from vibra.response.oscillator import Oscillator
    from vibra.system import System

#: What a scene's builder makes (`build_system`): a `System` (chains, molecules, networks, a
#: dynamics run's chain), a `GeneralizedSystem`, a `Crystal`, or an oscillator scene's `Oscillator`s.
BuiltSystem = Union["System", "GeneralizedSystem", "Crystal", "tuple[Oscillator, ...]"]

__all__ = ["build_system", "network_structure", "check_xyz_text", "scene_key", "ARGUMENT_KEYS"]

#: builder -> {builder argument: the scene key that gives it} where the two differ (a function
#: of the scene's parameters when the key depends on them); any other argument a scene sets is
#: ``system.<argument>``.
ARGUMENT_KEYS: dict[str, dict[str, Any]] = {
    "molecule": {"name_or_atoms": lambda p: "system.xyz" if p.get("xyz") is not None else "system.name"},
    "anm": {"positions": "system.pdb", "masses": "system.pdb"},
    "gnm": {"positions": "system.pdb"},
}


def scene_key(scene: Scene, argument: str) -> str:
    """The scene key that gave the builder's `argument` (``system`` when none does)."""
    key = ARGUMENT_KEYS.get(scene.system.builder, {}).get(argument)
    if callable(key):
        return str(key(scene.system.parameters))
    if key is not None:
        return str(key)
    return f"system.{argument}" if argument in scene.system.parameters else "system"


def check_xyz_text(text: str, source: str, name: str) -> int:
    """Check that the XYZ text of the scene's ``system.xyz`` is whole; return its number of atoms.

    An XYZ file is: the number of atoms n, a comment line, then n lines ``symbol x y z`` (Å).
    Refused at ``system.xyz``, naming the file and the line: a first line that is not a
    positive integer; fewer atom lines than announced (a cut file); an atom line without three
    coordinates or with a coordinate that is not a finite number; more lines than announced
    (a second frame, or atoms the count leaves out). Blank lines at the end are allowed.

    Raises
    ------
    SceneError
    """
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()

    def fail(number: int, what: str) -> SceneError:
        return SceneError(source, "system.xyz", f"{name!r}: line {number}: {what}")

    head = lines[0].strip() if lines else ""
    try:
        count = int(head)
    except ValueError:
        raise fail(1, f"is {head[:40]!r}; an XYZ file starts with its number of atoms") from None
    if count < 1:
        raise fail(1, f"announces {count} atoms; expected at least 1")
    atoms = lines[2:]
    if len(atoms) < count:
        raise fail(len(lines), f"the file ends after {counted(len(atoms), 'atom line')}, but line 1 announces {count}; "
                   "the file looks truncated")
    for number, line in enumerate(atoms[:count], start=3):
        fields = line.split()
        if len(fields) < 4:
            raise fail(number, f"is {line.strip()[:60]!r}; an atom line reads 'symbol x y z' (coordinates in "
                       "Angstrom)")
        for axis, field in zip("xyz", fields[1:4]):
            try:
                value = float(field)
            except ValueError:
                value = None
            if value is None or not np.isfinite(value):
                raise fail(number, f"coordinate {axis} of atom {number - 3} is {field!r}; every coordinate must "
                           "be a finite number (Angstrom)")
    if len(atoms) > count:
        raise fail(count + 3, f"more lines follow the {count} atoms that line 1 announces; a scene's .xyz file "
                   "holds one molecule (one frame) whose first line counts its atoms")
    return count


def build_system(scene: Scene) -> BuiltSystem:
    """The `System` (for an oscillator scene the `Oscillator`s, for a crystal scene the `Crystal`) a scene describes.

    The builder validates its arguments as it would in any library call; what it refuses is
    reported as a `SceneError` at the offending key (``file: system.n: n is 1; ...``), so
    ``vibra validate`` (which builds every scene) refuses what ``vibra report`` could not run.

    Raises
    ------
    SceneError
        The builder (or freezing) refused a parameter.
    """
    try:
        return _build(scene)
    except ArgumentError as error:  # the builder named its argument: the scene key follows by construction
        raise SceneError(scene.source, scene_key(scene, error.argument), str(error)) from error
    except (ValueError, TypeError) as error:
        if isinstance(error, SceneError):
            raise
        message = str(error).replace("; pass symmetrize=True to use (K + K^T) / 2", "; a scene's K must be symmetric")
        first = message.split(" ", 1)[0].split("[", 1)[0]
        key = f"system.{first}" if first in scene.system.parameters else "system"
        raise SceneError(scene.source, key, message) from error


def network_structure(scene: Scene) -> Structure:
    """The sites and B-factors (`vibra.networks.Structure`) of a network scene's ``system.pdb``, as
    its keys ``selection``, ``chains``, ``residues``, ``model`` and ``altloc`` choose them
    (`vibra.networks.from_pdb`'s arguments of the same names; C-alpha atoms by default).

    The file must lie inside the scene's folder (`vibra.pipeline.scene.files.scene_data_path`).

    Raises
    ------
    SceneError
        A path outside the scene's folder, a missing or unreadable file (at ``system.pdb``);
        a selection that finds nothing, a model or altloc the file lacks (at that key when the
        scene gives it, else at ``system.pdb``; the message says what the file holds).
    """
    from vibra.networks import from_pdb

    p = scene.system.parameters
    path = scene_data_path(scene.source, "system.pdb", p["pdb"])
    options = {key: list(value) if isinstance(value, tuple) and key == "selection" else value
               for key in ("selection", "chains", "residues", "model", "altloc", "assembly")
               if (value := p.get(key)) is not None}
    try:
        return from_pdb(path, **options)
    except ArgumentError as error:  # from_pdb names its argument: the scene's key when given, else the file
        key = error.argument if error.argument in options else "pdb"
        raise SceneError(scene.source, f"system.{key}", str(error)) from None
    except (ValueError, OSError) as error:
        raise SceneError(scene.source, "system.pdb", str(error)) from None


def _molecule(scene: Scene, make: Any, p: dict[str, Any]) -> Any:
    """A 'molecule' scene's system: an ASE name, or an .xyz file beside the scene read with its size cap."""
    options = {key: p[key] for key in ("stretch", "bend", "torsion") if p[key] is not None}
    masses = None if p["masses"] is None else np.asarray(p["masses"], dtype=float)
    if p["xyz"] is not None:
        import io

        from ase.io import read

        text = read_scene_data(scene.source, "system.xyz", p["xyz"])
        count = check_xyz_text(text, scene.source, p["xyz"])  # whole, one molecule, finite: refused at system.xyz
        text = "\n".join(text.splitlines()[:count + 2]) + "\n"  # the checked frame (no trailing blank lines)
        try:
            atoms = read(io.StringIO(text), format="xyz")
        except Exception as error:  # ASE's parsers raise many kinds on a malformed file
            raise SceneError(scene.source, "system.xyz", f"{p['xyz']!r} is not a readable XYZ file "
                             f"({type(error).__name__}: {error})") from None
        source: Any = atoms
    else:
        source = p["name"]
        if source not in molecule_names():
            try:
                make(source)
            except ValueError as error:
                raise SceneError(scene.source, "system.name", str(error)) from None
    return make(source, isotopes=p["isotopes"], masses=masses, name=scene.name, **options)


def _build(scene: Scene) -> BuiltSystem:
    p = dict(scene.system.parameters)
    builder = scene.system.builder
    frozen_sites = p.pop("frozen_sites", None)
    frozen_dofs = p.pop("frozen_dofs", None)
    make = builder_function(builder)
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
        anchors, anchor_stiffness, directions = lists.pop("anchors"), lists.pop("anchor_stiffness"), None
        if anchors is not None:  # a scene's anchor holds every axis of its site: one spring per axis
            first = p["positions"][0]
            dim = len(first) if isinstance(first, tuple) else 1
            anchor_stiffness = np.repeat(np.broadcast_to(np.asarray(anchor_stiffness, dtype=float),
                                                         (len(anchors),)), dim)
            directions = np.tile(np.eye(dim), (len(anchors), 1))
            anchors = np.repeat(np.asarray(anchors, dtype=np.intp), dim)
        system = make(lists.pop("positions"), lists.pop("masses"), springs=springs,
                      stiffness=lists.pop("stiffness"), anchors=anchors, anchor_stiffness=anchor_stiffness,
                      anchor_directions=directions, units=scene.units, name=scene.name)
    elif builder == "co2":
        system = make(dims=p["dims"], isotopes=p["isotopes"])
    elif builder == "h2o":
        system = make(isotopes=p["isotopes"])
    elif builder == "molecule":
        system = _molecule(scene, make, p)
    elif builder in ("double_pendulum", "charged_particle"):
        system = make(**p)
    elif builder == "matrices":
        system = make(np.asarray(p["M"]), np.asarray(p["K"]), coordinates=p["coordinates"],
                      units=scene.units, name=scene.name)
    elif builder in ("anm", "gnm"):  # the same keys; a GNM's System keeps the site indices, not the coordinates
        structure = network_structure(scene)
        system = make(structure.positions, cutoff=p["cutoff"], gamma=p["gamma"], name=scene.name)
    elif builder == "phonopy":
        files = check_phonopy_scene_files(scene.source, p)  # whole files, each refusal at its key
        try:
            return make(files["file"], force_constants=files["force_constants_file"],
                        force_sets=files["force_sets_file"], symmetrize=p["symmetrize"], primitive=p["primitive"],
                        born=files["born_file"], nac=p["nac"], name=scene.name)
        except ValueError as error:
            if files["born_file"] is not None and str(error).startswith(str(files["born_file"])):
                raise SceneError(scene.source, "system.born_file", f"{p['born_file']!r}: "
                                 f"{str(error).removeprefix(str(files['born_file']) + ': ')}") from None
            raise
    elif builder in lattice_builders():
        import dataclasses

        return dataclasses.replace(make(units=scene.units, **lists), name=scene.name)
    elif builder == "fput":  # the harmonic chain; its anharmonic forces: vibra.pipeline.plan.dynamics
        system, _ = make(units=scene.units, **lists)
        return system
    elif builder == "oscillator":
        gammas = p["gamma"] if isinstance(p["gamma"], tuple) else (p["gamma"],)
        return tuple(make(p["w0"], g, p["m"]) for g in gammas)
    else:  # pragma: no cover - BUILDERS and BUILD_FUNCTIONS are kept in step
        raise KeyError(builder)
    if frozen_sites or frozen_dofs:
        system = system.freeze(sites=None if not frozen_sites else np.asarray(frozen_sites, dtype=np.intp),
                               dofs=None if not frozen_dofs else np.asarray(frozen_dofs, dtype=np.intp))
    return system


