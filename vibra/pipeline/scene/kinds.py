"""What a scene file may be: one `SceneKind` declaration per ``kind``, in `SCENE_KINDS`.

A kind's declaration says everything the scene layer and the report know of it: its name, its
default units, the heading of its group in the report and what its page calls it, the builders
that make it, its own ``[compute]`` and ``[draw]`` tables when it has them (a crystal's bands, a dynamics run's time
step), and the one-line reasons ``vibra modes`` and ``vibra sweep`` refuse it. What a kind
computes (its steps, checks and costs) is its `vibra.pipeline.plan.kinds.PlanKind`, one layer up:
the scene layer cannot import the plan (docs/architecture.md, "Scene kinds and builders").
Nothing else branches on a kind's name to learn these: `KINDS`, `DEFAULT_UNITS`, the report's
`GROUPS` and the sweep's `NOT_SWEPT` are read from here, and so are the builders' tables
`BUILDER_KINDS` (builder -> the kinds it makes, the inverse of the declarations) and `BUILDERS`.

>>> KINDS[:3]
('chain', 'molecule', 'oscillator')
>>> SCENE_KINDS["network"].units
'dimensionless'
>>> BUILDER_KINDS["springs"]
('chain', 'molecule', 'dynamics')
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping

from vibra.pipeline.scene.builders import BuilderMapping, builder_fields, is_lattice_builder
from vibra.pipeline.scene.dynamics import check_dynamics, parse_dynamics
from vibra.pipeline.scene.schema import check_crystal, parse_crystal
from vibra.pipeline.scene.values import FieldSpec

__all__ = ["SceneKind", "OwnTables", "SCENE_KINDS", "KINDS", "DEFAULT_UNITS", "REPORT_ORDER", "BUILDER_KINDS",
           "BUILDERS"]


@dataclass(frozen=True)
class OwnTables:
    """A kind's own ``[compute]`` and ``[draw]`` keys, read instead of the modes kinds' ones.

    Attributes
    ----------
    parse : callable
        ``parse(reader, compute, draw) -> (DrawSpec, spec)``: both tables, key by key.
    check : callable
        ``check(reader, scene)``: what the keys must agree on, once the scene is whole.
    field : str
        The `Scene` attribute that holds ``spec`` (``"crystal"``, ``"dynamics"``).
    """

    parse: Callable[[Any, Any, Any], tuple[Any, Any]]
    check: Callable[[Any, Any], None]
    field: str


@dataclass(frozen=True)
class SceneKind:
    """One scene kind, declared once.

    Attributes
    ----------
    name : str
        The ``kind`` of the scene file.
    units : str
        The units of a scene that gives none (``"SI"``, ``"ASE"``, ``"dimensionless"``).
    heading : str
        The heading of the kind's group in the report's sidebar and index.
    phrase : str
        What a scene page says the scene is (``"a molecule"``).
    builders : tuple of str
        The named builders of `vibra.pipeline.scene.builders.BUILD_FUNCTIONS` that make it (scene
        errors list them in that table's order, not this one).
    lattice : bool
        Every lattice builder (`vibra.crystals.builders.__all__`) makes it too.
    tables : OwnTables or None
        Its own ``[compute]`` and ``[draw]`` tables; None: the modes kinds' (`parse_compute`,
        `parse_draw`, `check_combinations`).
    no_modes : str or None
        Why ``vibra modes`` refuses the kind (None: it lists the modes).
    no_sweep : str or None
        Why ``vibra sweep`` refuses the kind (None: a sweep applies).
    """

    name: str
    units: str
    heading: str
    phrase: str
    builders: tuple[str, ...] = ()
    lattice: bool = False
    tables: OwnTables | None = None
    no_modes: str | None = None
    no_sweep: str | None = None

    def makes(self, builder: str) -> bool:
        """Whether `builder` makes scenes of this kind (the crystals are imported only to answer for a
        builder that is not named here, when the kind takes the lattice builders)."""
        return builder in self.builders or (self.lattice and is_lattice_builder(builder))


CHAIN = SceneKind("chain", "SI", "Chains", "a chain of masses and springs",
                  builders=("linear_chain", "diatomic_chain", "beaded_string", "springs"))
MOLECULE = SceneKind("molecule", "ASE", "Molecules", "a molecule", builders=("springs", "co2", "h2o", "molecule"))
OSCILLATOR = SceneKind("oscillator", "SI", "Oscillators", "driven damped oscillators", builders=("oscillator",),
                       no_modes="an oscillator scene has no normal modes to list",
                       no_sweep="an oscillator scene has no normal modes to sweep")
GENERALIZED = SceneKind("generalized", "SI", "Generalised systems", "a system in generalised coordinates",
                        builders=("double_pendulum", "charged_particle", "matrices"))
NETWORK = SceneKind("network", "dimensionless", "Networks", "an elastic network of a protein", builders=("anm", "gnm"))
#: bands, DOS, thermal properties, a mode on a supercell
CRYSTAL = SceneKind(
    "crystal", "ASE", "Crystals", "a crystal", builders=("phonopy",), lattice=True,
    tables=OwnTables(parse_crystal, check_crystal, "crystal"),
    no_modes="a crystal has a band of frequencies at every wave vector, not one list of modes; draw its bands "
             "with vibra report, or use vibra.crystals (frequencies(q))",
    no_sweep="a crystal scene has phonon branches over the wave vector, not one list of normal modes: vibra sweep "
             "does not apply to it (vary the crystal in a script and tabulate Crystal.frequencies at the q you want)")
#: the time step, the thermostat, the charts of a time integration
DYNAMICS = SceneKind("dynamics", "dimensionless", "Dynamics", "a dynamics run", builders=("linear_chain", "springs", "fput"),
                     tables=OwnTables(parse_dynamics, check_dynamics, "dynamics"))

#: kind -> its declaration, in the order scene errors list the kinds.
SCENE_KINDS: Mapping[str, SceneKind] = MappingProxyType({kind.name: kind for kind in (
    CHAIN, MOLECULE, OSCILLATOR, GENERALIZED, NETWORK, CRYSTAL, DYNAMICS)})
KINDS: tuple[str, ...] = tuple(SCENE_KINDS)
DEFAULT_UNITS: Mapping[str, str] = MappingProxyType({name: kind.units for name, kind in SCENE_KINDS.items()})
#: The order of the kinds' groups in the report (a kind not listed comes after these, in `KINDS` order).
REPORT_ORDER = ("chain", "molecule", "network", "generalized", "oscillator", "crystal", "dynamics")

#: builder -> the scene kinds it makes, in `KINDS` order: the inverse of the kinds' ``builders``
#: and ``lattice`` (a named builder is looked up without importing the crystals).
BUILDER_KINDS: Mapping[str, tuple[str, ...]] = BuilderMapping(
    lambda builder: tuple(name for name, kind in SCENE_KINDS.items() if kind.makes(builder)))
#: builder name -> (scene kinds it makes, parameter table, derived on first use). The plan maps each
#: name to one function in vibra (`BUILD_FUNCTIONS`); nothing read from a file is ever imported or run.
BUILDERS: Mapping[str, tuple[tuple[str, ...], Mapping[str, FieldSpec]]] = BuilderMapping(
    lambda builder: (BUILDER_KINDS[builder], builder_fields(builder)))
