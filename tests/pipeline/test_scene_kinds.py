"""Tests of vibra/pipeline/scene/kinds.py and vibra/pipeline/plan/kinds.py (issue 43 item 3): every scene
kind declared once per layer, every builder serving declared kinds, and what reads the declarations."""

from __future__ import annotations

import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import vibra.pipeline.scene.kinds as scene_kinds
from vibra.pipeline.plan import PLAN_KINDS, PlanKind, make_plan
from vibra.pipeline.plan.steps import STEPS
from vibra.pipeline.scene import BUILDERS, KINDS, SCENE_KINDS, SceneKind, load_scene
from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, lattice_builders, planar
from vibra.pipeline.scene.kinds import BUILDER_KINDS

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = sorted(path for folder in ("chains", "molecules", "networks", "crystals", "dynamics")
                 for path in (ROOT / folder).rglob("*.toml"))


def test_every_kind_has_exactly_one_declaration_per_layer() -> None:
    assert KINDS[:7] == ("chain", "molecule", "oscillator", "generalized", "network", "crystal", "dynamics")
    assert tuple(SCENE_KINDS) == KINDS and tuple(PLAN_KINDS) == KINDS  # one key each: one declaration
    for name in KINDS:
        assert isinstance(SCENE_KINDS[name], SceneKind) and SCENE_KINDS[name].name == name
        assert isinstance(PLAN_KINDS[name], PlanKind) and PLAN_KINDS[name].name == name
    declared = [value for value in vars(scene_kinds).values() if isinstance(value, SceneKind)]
    assert sorted(kind.name for kind in declared) == sorted(KINDS)  # no second declaration of a kind


def test_every_builder_serves_declared_kinds() -> None:
    assert list(BUILDER_KINDS) == list(BUILD_FUNCTIONS) == list(BUILDERS)
    for builder, kinds in BUILDER_KINDS.items():
        assert kinds and set(kinds) <= set(SCENE_KINDS), builder
    for kind in KINDS:  # and every kind has a builder
        assert any(kind in kinds for kinds in BUILDER_KINDS.values()), kind


def test_builder_kinds_is_the_inverse_of_the_kinds_declarations() -> None:
    """One table says which builder makes which kind: each kind's ``builders`` (and ``lattice``).
    Truth: the rows `BUILDER_KINDS` held when it was written by hand (issue 43), and the inverse
    computed here from the declarations."""
    lattice = lattice_builders()
    for kind in SCENE_KINDS.values():
        assert set(kind.builders) <= set(BUILD_FUNCTIONS) - set(lattice), kind.name  # no misspelt builder
        assert len(set(kind.builders)) == len(kind.builders), kind.name
    for builder in BUILD_FUNCTIONS:
        expected = tuple(name for name, kind in SCENE_KINDS.items()
                         if builder in kind.builders or (kind.lattice and builder in lattice))
        assert BUILDER_KINDS[builder] == expected, builder
    seven = KINDS[:7]  # the kinds whose rows were written by hand (a kind added later is left out here)
    assert {builder: tuple(kind for kind in kinds if kind in seven)
            for builder, kinds in BUILDER_KINDS.items() if builder not in lattice} == {
        "linear_chain": ("chain", "dynamics"), "diatomic_chain": ("chain",), "beaded_string": ("chain",),
        "springs": ("chain", "molecule", "dynamics"), "co2": ("molecule",), "h2o": ("molecule",),
        "molecule": ("molecule",), "double_pendulum": ("generalized",), "charged_particle": ("generalized",),
        "matrices": ("generalized",), "anm": ("network",), "gnm": ("network",), "oscillator": ("oscillator",),
        "phonopy": ("crystal",), "fput": ("dynamics",)}


def test_a_chain_scene_does_not_import_the_crystals() -> None:
    """The kinds of a named builder, and a chain scene, are read without the lattice builders' module."""
    code = ("import sys\nfrom vibra.pipeline.scene import Scene\nfrom vibra.pipeline.scene.kinds import BUILDER_KINDS\n"
            "assert 'chain' in BUILDER_KINDS['linear_chain']\n"
            "Scene.from_dict({'kind': 'chain', 'system': {'builder': 'linear_chain', 'n': 4}}, source='s.toml')\n"
            "print('vibra.crystals.builders' in sys.modules)\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert result.stdout.strip() == "False"


def test_the_lattice_builders_are_the_crystals_builders_module() -> None:
    """A lattice builder's scene entry is its signature in vibra.crystals.builders: its kind, its keys,
    and planar exactly when the crystal it builds has a vacuum axis (truth: the Crystal's periodic flags)."""
    from vibra.crystals import builders

    assert lattice_builders() == tuple(builders.__all__)
    for name in builders.__all__:
        function = getattr(builders, name)
        assert BUILDER_KINDS[name] == ("crystal",) and BUILD_FUNCTIONS[name] == ("vibra.crystals.builders", name)
        parameters = inspect.signature(function).parameters
        mass = "mass" if "mass" in parameters else "masses"
        crystal = function(a=1.0, **{mass: 1.0}, stiffness=1.0)
        assert planar(name) == (not all(crystal.periodic)), name
        assert set(BUILDERS[name][1]) == set(parameters) - {"units"}, name
    assert not planar("phonopy") and BUILDER_KINDS["phonopy"] == ("crystal",)


def test_the_report_and_the_sweep_read_the_declarations() -> None:
    from vibra.pipeline.report.frame import GROUPS
    from vibra.pipeline.report.scenepage import KIND_WORDS
    from vibra.pipeline.sweep import NOT_SWEPT

    # the report's groups in the order it always showed them, any later kind after them
    assert GROUPS[:7] == (("chain", "Chains"), ("molecule", "Molecules"), ("network", "Networks"),
                          ("generalized", "Generalised systems"), ("oscillator", "Oscillators"),
                          ("crystal", "Crystals"), ("dynamics", "Dynamics"))
    assert GROUPS[-1] == ("", "Other scenes") and sorted(kind for kind, _ in GROUPS[:-1]) == sorted(KINDS)
    assert set(KIND_WORDS) == set(KINDS)
    assert set(NOT_SWEPT) == {name for name, kind in SCENE_KINDS.items() if kind.no_sweep} >= {"oscillator", "crystal"}
    assert {"oscillator", "crystal"} <= {name for name, kind in SCENE_KINDS.items() if kind.no_modes}
    assert {"crystal", "dynamics"} <= {name for name, kind in SCENE_KINDS.items() if kind.tables}


def test_every_kind_step_has_a_function() -> None:
    for kind in PLAN_KINDS.values():
        for name, run in kind.steps.items():
            assert STEPS[name] is run, (kind.name, name)


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_every_planned_step_runs_somewhere(path: Path) -> None:
    scene = load_scene(path)
    for name in make_plan(scene).step_names:
        assert name in STEPS, (path.name, name)
