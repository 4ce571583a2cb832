"""The builders a scene may name, with their parameter tables derived from the builders themselves.

A scene's ``[system]`` table names a builder of `BUILD_FUNCTIONS` (a fixed table of
(module, function) inside vibra) and sets its parameters. The keys a scene may set, which of
them are required and their defaults are read from the builder's signature
(`inspect.signature`), so they cannot drift from the code that runs: a builder parameter
without a default is required in the scene, a default is the builder's own. This module only
adds what a signature cannot say: the value check of each parameter (`PARAMETER_CHECKS`),
the parameters a scene does not set (`NOT_IN_SCENES`, each with the reason), and keys the plan
applies after the builder (`SCENE_ONLY`). A builder parameter in none of these tables stops
the derivation with an error naming it, so a new builder argument cannot slip past the schema.

Which scene kinds a builder makes is said by the kinds themselves (`SceneKind.builders` in
`vibra.pipeline.scene.kinds`, which derives `BUILDER_KINDS` and `BUILDERS` from them).

>>> sorted(builder_fields("beaded_string"))
['ends', 'frozen_dofs', 'frozen_sites', 'mass', 'n', 'spacing', 'tension']
>>> builder_fields("beaded_string")["ends"].default
'fixed'
"""

from __future__ import annotations

import functools
import importlib
import inspect
from types import MappingProxyType
from typing import Any, Callable, Iterator, Mapping, TypeVar

from vibra._core.cache import remembered
from vibra.pipeline.scene.values import (
    Check, Fail, FieldSpec, boolean, brief, coordinates, field_spec, index_pairs, integer, list_of, matrix, nonnegative, number, one_of, positive,
    scalar_or_list, string,
)

__all__ = ["isotope_labels", "BUILD_FUNCTIONS", "LATTICE_MODULE", "LATTICE_CHECKS", "lattice_builders", "planar",
           "is_lattice_builder", "BuilderMapping", "PARAMETER_CHECKS", "NOT_IN_SCENES", "SCENE_ONLY",
           "SCENE_REQUIRED", "INFRARED_KEYS", "STRUCTURE_KEYS", "direction_vector", "builder_function", "builder_signature", "builder_fields"]

#: The module whose public functions (its ``__all__``) are the lattice builders of crystal scenes. A
#: lattice builder's scene entry is its signature there: its parameters are checked by name
#: (`LATTICE_CHECKS`), it makes the scenes of the kind declared with ``lattice=True`` (``"crystal"``,
#: `vibra.pipeline.scene.kinds`), and it is planar (a vacuum axis along z)
#: when it takes a ``vacuum``; so a new lattice builder touches that module only. The module is
#: imported when a lattice builder is first looked up (a chain scene does not import the crystals).
LATTICE_MODULE = "vibra.crystals.builders"


@functools.cache
def lattice_builders() -> tuple[str, ...]:
    """The lattice builders, in the order of `vibra.crystals.builders.__all__` (read once per version of
    vibra's sources: `vibra._core.cache.remembered`)."""
    return tuple(remembered("scene lattice builders", lambda: list(importlib.import_module(LATTICE_MODULE).__all__)))


#: scene builder -> (vibra module, function), before and after the lattice builders.
_FUNCTIONS_BEFORE = {
    "linear_chain": ("vibra.chains", "linear_chain"),
    "diatomic_chain": ("vibra.chains", "diatomic_chain"),
    "beaded_string": ("vibra.chains", "beaded_string"),
    "springs": ("vibra.system", "System.from_springs"),
    "co2": ("vibra.molecules", "co2"),
    "h2o": ("vibra.molecules", "h2o"),
    "molecule": ("vibra.molecules", "molecule"),
    "double_pendulum": ("vibra.mechanics.lagrangian", "double_pendulum"),
    "charged_particle": ("vibra.mechanics.gyroscopic", "charged_particle"),
    "matrices": ("vibra.system", "System.generalized"),
    "anm": ("vibra.networks", "anm"),
    "gnm": ("vibra.networks", "gnm"),
    "oscillator": ("vibra.response", "Oscillator"),
}
_FUNCTIONS_AFTER = {
    "phonopy": ("vibra.crystals", "read_phonopy"),
    "fput": ("vibra.dynamics", "fput"),
}


_NAMED_FUNCTIONS = {**_FUNCTIONS_BEFORE, **_FUNCTIONS_AFTER}


def is_lattice_builder(builder: str) -> bool:
    """Whether `builder` is a lattice builder; a named builder is answered without importing the crystals."""
    return builder not in _NAMED_FUNCTIONS and builder in lattice_builders()


_Row = TypeVar("_Row")


class BuilderMapping(Mapping[str, _Row]):
    """builder -> ``value(builder)`` for every builder of `BUILD_FUNCTIONS`, in its order. A named
    builder is looked up without importing the crystals."""

    def __init__(self, value: Callable[[str], _Row]) -> None:
        self._value = value

    def __getitem__(self, builder: str) -> _Row:
        if builder in _NAMED_FUNCTIONS or (isinstance(builder, str) and is_lattice_builder(builder)):
            return self._value(builder)
        raise KeyError(builder)

    def __iter__(self) -> Iterator[str]:
        return iter((*_FUNCTIONS_BEFORE, *lattice_builders(), *_FUNCTIONS_AFTER))

    def __len__(self) -> int:
        return len(_NAMED_FUNCTIONS) + len(lattice_builders())


def _per_builder(fixed: Mapping[str, _Row], lattice: Callable[[str], _Row]) -> BuilderMapping[_Row]:
    """A table of the named builders' rows (`fixed`) and one row made by `lattice(builder)` for each lattice builder."""
    return BuilderMapping(lambda builder: fixed[builder] if builder in _NAMED_FUNCTIONS else lattice(builder))


#: scene builder -> (vibra module, function). The only way a scene names code.
BUILD_FUNCTIONS: Mapping[str, tuple[str, str]] = BuilderMapping(
    lambda builder: _NAMED_FUNCTIONS.get(builder, (LATTICE_MODULE, builder)))


def planar(builder: str) -> bool:
    """Whether a crystal builder makes a 2-D crystal (a vacuum axis along z): it takes a ``vacuum``."""
    return builder in lattice_builders() and "vacuum" in builder_fields(builder)


MASS = scalar_or_list(positive)
ENDS = one_of("free", "fixed", "periodic")
_SITES = list_of(integer(0), min_length=0)
FROZEN = {"frozen_sites": field_spec(_SITES), "frozen_dofs": field_spec(_SITES)}


def isotope_labels(value: Any, fail: Fail) -> tuple[str | None, ...]:
    """One isotope label per atom (``"D"``, ``"T"``, ``"13C"``, ``"18O"``), ``""`` keeping an atom's mass.

    TOML has no null, so ``isotopes = ["", "D", "D"]`` is heavy water; the labels themselves
    are checked by the builder (`vibra.molecules.isotope_masses`), which knows the atoms.
    """
    labels = list_of(string)(value, fail)
    return tuple(label or None for label in labels)


ISOTOPES = isotope_labels


def symmetrize_option(value: Any, fail: Fail) -> bool | str:
    """A phonopy scene's ``symmetrize``: true, false, "auto", "phonopy" or "projection" (`read_phonopy`)."""
    if isinstance(value, bool):
        return value
    return one_of("auto", "phonopy", "projection")(value, fail)


def direction_vector(value: Any, fail: Fail) -> tuple[float, float, float]:
    """A polar crystal's ``infrared_direction``: 3 Cartesian components, not all zero (any length)."""
    direction = list_of(number, length=3)(value, fail)
    if not any(direction):
        fail(f"is {list(direction)}; the light's polarisation needs a direction (3 Cartesian components, "
             "not all zero)")
    return direction


def chain_ids(value: Any, fail: Fail) -> tuple[str, ...]:
    """A network scene's ``chains``: ``"A"``, ``"AB"`` (one character per chain) or ``["A", "B"]``."""
    if isinstance(value, str):
        if not value.strip() or value != value.strip():
            fail(f"is {brief(value)}; expected chain identifiers such as \"A\" or \"AB\" (one character "
                 "each) or a list such as [\"A\", \"B\"]")
        return tuple(value)
    ids = list_of(string)(value, fail)
    for i, chain in enumerate(ids):
        if not chain.strip() or chain != chain.strip():
            fail(f"[{i}] is {brief(chain)}; a chain identifier is one or more characters without spaces")
    return ids


def residue_range(value: Any, fail: Fail) -> tuple[int, int]:
    """A network scene's ``residues``: ``[first, last]`` residue numbers, both kept (first <= last)."""
    first, last = list_of(integer(-9999), length=2)(value, fail)
    if first > last:
        fail(f"is [{first}, {last}]; expected [first, last] residue numbers with first <= last")
    return first, last


def atom_selection(value: Any, fail: Fail) -> str | tuple[str, ...]:
    """A network scene's ``selection``: "CA", "protein", "all", or a list of atom names (`from_pdb`)."""
    if isinstance(value, list):
        names = list_of(string)(value, fail)
        for i, name in enumerate(names):
            if not name.strip():
                fail(f"[{i}] is {brief(name)}; an atom name such as \"CA\" or \"N\"")
        return names
    if value not in ("CA", "protein", "all"):
        fail(f"is {brief(value)}; expected \"CA\" (C-alpha atoms), \"protein\" (every atom of the amino "
             "acids), \"all\" (every atom) or a list of atom names such as [\"N\", \"CA\", \"C\"]")
    return value


def altloc_code(value: Any, fail: Fail) -> str:
    """A network scene's ``altloc``: one alternate-location character (``"B"``)."""
    code = string(value, fail)
    if len(code) != 1 or not code.strip():
        fail(f"is {brief(value)}; expected one alternate-location character such as \"A\" or \"B\"")
    return code


#: The keys of a network scene that choose the sites of its structure file: those of
#: `vibra.networks.from_pdb`, under the same names (its errors name the argument, which is the
#: key); a key not given keeps from_pdb's default (C-alpha atoms of every chain of the first model).
STRUCTURE_KEYS: Mapping[str, FieldSpec] = MappingProxyType({
    "selection": field_spec(atom_selection), "chains": field_spec(chain_ids), "residues": field_spec(residue_range),
    "model": field_spec(integer(1)), "altloc": field_spec(altloc_code), "assembly": field_spec(integer(1)),
})


#: Keys of a polar crystal's infrared response (the plan's ``crystal-infrared`` step, which runs
#: when the scene names Born charges in ``born_file``): the damping gamma of every optical mode,
#: in cm^-1 (none: 0, undamped), and the Cartesian polarisation of the light (none: [1, 0, 0]).
INFRARED_KEYS: Mapping[str, FieldSpec] = MappingProxyType({
    "infrared_damping": field_spec(nonnegative), "infrared_direction": field_spec(direction_vector),
})

#: A lattice builder's parameters -> their value checks (`LATTICE_MODULE`: checked by name).
LATTICE_CHECKS: Mapping[str, Check] = MappingProxyType({
    "a": positive, "mass": positive, "masses": MASS, "stiffness": scalar_or_list(positive), "shells": integer(1, 12),
    "transverse": scalar_or_list(nonnegative), "vacuum": positive,
})


def _lattice_checks(builder: str) -> Mapping[str, Check]:
    parameters = builder_signature(builder)["names"]
    return MappingProxyType({name: check for name, check in LATTICE_CHECKS.items() if name in parameters})


#: builder -> {parameter: value check}, for every builder parameter a scene may set.
PARAMETER_CHECKS: Mapping[str, Mapping[str, Check]] = _per_builder({
    "linear_chain": {"n": integer(2), "mass": MASS, "stiffness": scalar_or_list(positive), "spacing": positive,
                     "ends": ENDS},
    "diatomic_chain": {"n_cells": integer(1), "masses": list_of(positive, length=2),
                       "stiffness": scalar_or_list(positive), "spacing": positive, "ends": ENDS},
    "beaded_string": {"n": integer(1), "mass": positive, "tension": positive, "spacing": positive,
                      "ends": ENDS},
    "springs": {"positions": coordinates, "masses": MASS, "springs": index_pairs,
                "stiffness": scalar_or_list(positive), "anchors": _SITES,
                "anchor_stiffness": scalar_or_list(positive), "frozen_sites": _SITES, "frozen_dofs": _SITES},
    "co2": {"dims": one_of(1, 3), "isotopes": ISOTOPES},
    "h2o": {"isotopes": ISOTOPES},
    # system.name is ASE's molecule name: the plan passes it as name_or_atoms (and as the System's name)
    "molecule": {"name": string, "isotopes": ISOTOPES, "masses": list_of(positive)},
    "double_pendulum": {"m": positive, "m_prime": positive, "a": positive, "b": positive, "g": positive},
    "charged_particle": {"mass": positive, "omega0": positive, "charge": number, "field": number},
    "matrices": {"M": matrix, "K": matrix, "coordinates": list_of(string)},
    "oscillator": {"w0": positive, "gamma": scalar_or_list(nonnegative), "m": positive},
    "anm": {"cutoff": positive, "gamma": positive},
    "gnm": {"cutoff": positive, "gamma": positive},
    "phonopy": {"symmetrize": symmetrize_option, "primitive": one_of("auto"), "nac": one_of("gonze", "wang")},
    "fput": {"n": integer(2), "alpha": number, "beta": number, "ends": ENDS, "mass": positive, "stiffness": positive},
}, _lattice_checks)

_UNITS = "the scene's top-level units"
_NAME = "the scene's name"
#: builder -> {parameter: why a scene does not set it}.
NOT_IN_SCENES: Mapping[str, Mapping[str, str]] = _per_builder({
    "linear_chain": {"units": _UNITS, "name": _NAME},
    "diatomic_chain": {"units": _UNITS, "name": _NAME},
    "beaded_string": {"units": _UNITS, "name": _NAME},
    "springs": {"units": _UNITS, "name": _NAME,
                "anchor_directions": "anchors in scenes hold every axis of a site",
                "blocks": "scenes give pair springs only (no general Hessian blocks)",
                "cell": "a periodic solid is a crystal scene (kind = \"crystal\"), not a spring system"},
    "co2": {"bond_length": "the builder's constant (the cross-check reuses it)",
            "stretch": "the builder's constant (the cross-check reuses it)",
            "bend": "the builder's constant (the cross-check reuses it)"},
    "h2o": {"stretch": "the builder's constant (the cross-check reuses it)",
            "bend": "the builder's constant (the cross-check reuses it)"},
    "molecule": {"name_or_atoms": "given by the scene's system.name (an ASE molecule name) or system.xyz (a file)",
                 "valence_model_options": "the scene keys stretch, bend and torsion"},
    "double_pendulum": {"units": "Vieille's problem is in SI"},
    "charged_particle": {},
    "matrices": {"units": _UNITS, "name": _NAME,
                 "G": "gyroscopic and damped scenes are not wired yet (issue 15)",
                 "C": "gyroscopic and damped scenes are not wired yet (issue 15)"},
    "oscillator": {},
    "anm": {"positions": "the sites of the structure file system.pdb that system.selection, chains, residues, "
                         "model and altloc choose (C-alpha atoms by default)",
            "masses": "unit masses, as ProDy's ANM", "name": _NAME},
    "gnm": {"positions": "the sites of the structure file system.pdb that system.selection, chains, residues, "
                         "model and altloc choose (C-alpha atoms by default)", "name": _NAME},
    "phonopy": {"path": "the file system.file beside the scene (phonopy.yaml)",
                "force_constants": "the file system.force_constants_file beside the scene",
                "force_sets": "the file system.force_sets_file beside the scene",
                "born": "the file system.born_file beside the scene", "name": _NAME},
    "fput": {"units": _UNITS},
}, lambda builder: {"units": _UNITS})

#: builder -> keys a scene may set that are not builder parameters (the plan applies them).
SCENE_ONLY: Mapping[str, Mapping[str, FieldSpec]] = _per_builder({
    "linear_chain": {"defect_site": field_spec(integer(0)), "defect_mass": field_spec(positive), **FROZEN},
    "diatomic_chain": dict(FROZEN),
    "beaded_string": dict(FROZEN),
    "springs": {"symbols": field_spec(list_of(string))},
    "co2": dict(FROZEN),
    "h2o": dict(FROZEN),
    "molecule": {"xyz": field_spec(string), "stretch": field_spec(positive),
                 "bend": field_spec(positive), "torsion": field_spec(positive),
                 # an electronic-structure engine instead of the force field (vibra.molecules.engines.choice,
                 # checked in schema._check_molecule; the plan's "electronic" step runs it)
                 "engine": field_spec(string), "method": field_spec(string), "basis": field_spec(string)},
    "double_pendulum": {},
    "charged_particle": {},
    "matrices": {},
    "oscillator": {},
    "anm": {"pdb": field_spec(string, required=True), **STRUCTURE_KEYS},
    "gnm": {"pdb": field_spec(string, required=True), **STRUCTURE_KEYS},  # the anm builder's keys
    "phonopy": {"file": field_spec(string, required=True), "force_constants_file": field_spec(string),
                "force_sets_file": field_spec(string), "born_file": field_spec(string), **INFRARED_KEYS},
    "fput": {},
}, lambda builder: {})

#: builder -> parameters a scene must give although the builder has a default for them.
SCENE_REQUIRED: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "springs": ("springs", "stiffness"),  # without springs a scene has no stiffness to solve
})


def builder_function(builder: str) -> Callable[..., Any]:
    """The vibra function (or class) that `builder` names in `BUILD_FUNCTIONS`."""
    module_name, attribute = BUILD_FUNCTIONS[builder]
    target: Any = importlib.import_module(module_name)
    for part in attribute.split("."):
        target = getattr(target, part)
    return target


def _signature(builder: str) -> dict[str, Any]:
    """What the schema reads of `builder`'s signature: the names of its parameters, and for each one a
    scene may set (not variadic, not in `NOT_IN_SCENES`) [name, required, default] (required: no default)."""
    skipped = NOT_IN_SCENES[builder]
    parameters = inspect.signature(builder_function(builder)).parameters
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return {"names": list(parameters),
            "scene": [[name, parameter.default is inspect.Parameter.empty,
                       None if parameter.default is inspect.Parameter.empty else parameter.default]
                      for name, parameter in parameters.items() if name not in skipped and parameter.kind not in variadic]}


def builder_signature(builder: str) -> Mapping[str, Any]:
    """`builder`'s signature as the schema reads it (`_signature`), read once per version of vibra's
    sources and then from the cache (`vibra._core.cache.remembered`): reading it imports the builder's
    module (numpy, scipy, the builders: 0.4 s for a chain, 1 s for a crystal), which a scene refused
    for a misspelt key should not wait for. Lists read back as tuples (a default of [1, 2] as (1, 2))."""
    return remembered(f"scene builder signature {builder}", lambda: _signature(builder))


@functools.cache
def builder_fields(builder: str) -> Mapping[str, FieldSpec]:
    """The keys of ``[system]`` for `builder`: its signature's parameters, checked, plus `SCENE_ONLY`.

    Raises
    ------
    RuntimeError
        A builder parameter is in neither `PARAMETER_CHECKS` nor `NOT_IN_SCENES`, or a
        checked name is not a parameter of the builder (the tables drifted from the code).
    """
    checks = PARAMETER_CHECKS[builder]
    fields: dict[str, FieldSpec] = {}
    for name, no_default, default in builder_signature(builder)["scene"]:
        if name not in checks:
            table = "LATTICE_CHECKS" if builder in lattice_builders() else "PARAMETER_CHECKS or NOT_IN_SCENES"
            raise RuntimeError(f"builder {builder!r} has a parameter {name!r} that the scene schema does not know; "
                               f"add it to {table} in vibra/pipeline/scene/builders.py")
        fields[name] = field_spec(checks[name], None if no_default else default,
                                  required=no_default or name in SCENE_REQUIRED.get(builder, ()))
    unknown = sorted(set(checks) - set(fields))
    if unknown:
        raise RuntimeError(f"scene schema checks {unknown} for builder {builder!r}, which takes no such parameter")
    return MappingProxyType({**fields, **SCENE_ONLY[builder]})
