"""Tests of vibra/pipeline/scene/: the scene schema, its validation messages, and the bundled scenes."""

from __future__ import annotations

import dataclasses
import inspect
import json
from pathlib import Path

import pytest

from vibra.modes import SOLVERS
from vibra.pipeline.scene import BUILDERS, KINDS, Scene, SceneError, find_scene_files, load_scene

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = (sorted((ROOT / "chains").glob("*.toml")) + sorted((ROOT / "molecules").glob("*.toml"))
           + sorted((ROOT / "networks" / "ubiquitin").glob("*.toml")) + sorted((ROOT / "crystals").glob("*.toml")))
BROKEN = ROOT / "tests" / "broken_scenes"

#: broken scene file -> the specific message it must produce (key path included).
BROKEN_MESSAGES = {
    "typo-key.toml": r"system\.stifness: unknown key; did you mean 'stiffness'\?",
    "wrong-type.toml": r"system\.n: expected an integer, got a string \('twelve'\)",
    "negative-mass.toml": r"system\.mass: must be positive, got -1\.0",
    "unknown-builder.toml": r"system\.builder: unknown builder 'linear_chian'; did you mean 'linear_chain'\?",
    "escape-path.toml": r"name: '\.\./escaped' is not a safe file name",
    "absolute-path.toml": r"name: '/tmp/vibra-escaped' is not a safe file name",
    "section-typo.toml": r"draws: unknown key; did you mean 'draw'\?",
    "invalid-toml.toml": r"invalid TOML",
    "code-injection.toml": r"system\.n: expected an integer, got a string",
    "three-problems.toml": r"system\.mass: must be positive, got -1\.0",  # the first of three (test_validate_all)
}


def chain(**system: object) -> dict[str, object]:
    """A minimal valid chain scene table, with `system` keys merged in."""
    return {"kind": "chain", "system": {"builder": "linear_chain", "n": 4, **system}}


def test_bundled_scenes_are_the_issue_list() -> None:
    names = {path.name for path in BUNDLED}
    expected = {"co2-axial.toml", "co2.toml", "h2o.toml", "monatomic-free.toml", "monatomic-fixed.toml",
                "diatomic.toml", "mass-defect.toml", "continuum-limit.toml", "forced-damped.toml",
                "long-chain.toml", "double-pendulum.toml", "ch4.toml", "d2o.toml", "charged-particle.toml",
                "ubiquitin-anm.toml", "argon-fcc.toml", "silicon-diamond.toml"}
    assert expected <= names


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_every_bundled_scene_validates(path: Path) -> None:
    scene = load_scene(path)
    assert scene.kind in KINDS
    assert scene.name == path.stem
    json.dumps(scene.dump())  # a summary can always hold it


@pytest.mark.parametrize("file_name", sorted(BROKEN_MESSAGES))
def test_broken_scene_fails_with_its_message(file_name: str) -> None:
    path = BROKEN / file_name
    with pytest.raises(SceneError, match=BROKEN_MESSAGES[file_name]) as info:
        load_scene(path)
    assert str(info.value).startswith(str(path) + ": ")  # the file name leads the message


def test_every_broken_scene_has_a_message() -> None:
    assert {p.name for p in BROKEN.glob("*.toml")} == set(BROKEN_MESSAGES)


def test_missing_file() -> None:
    with pytest.raises(SceneError, match=r"nowhere\.toml: file not found"):
        load_scene("nowhere.toml")


def test_scene_error_is_a_value_error_with_parts() -> None:
    error = SceneError("a.toml", "system.n", "is required")
    assert isinstance(error, ValueError)
    assert (error.source, error.key, error.problem) == ("a.toml", "system.n", "is required")
    assert str(error) == "a.toml: system.n: is required"


def test_code_in_a_value_is_never_run(tmp_path: Path) -> None:
    # The injection scene would create this file if any value were evaluated.
    marker = Path("/tmp/vibra-pwned")
    marker.unlink(missing_ok=True)
    with pytest.raises(SceneError):
        load_scene(BROKEN / "code-injection.toml")
    assert not marker.exists()


def test_builder_names_are_a_fixed_table() -> None:
    with pytest.raises(SceneError, match=r"unknown builder 'os\.system'"):
        Scene.from_dict(chain(builder="os.system"), source="x.toml")


def test_defaults_are_filled_from_the_schema() -> None:
    scene = Scene.from_dict(chain(), source="chains/x.toml")
    p = scene.system.parameters
    assert (p["mass"], p["stiffness"], p["spacing"], p["ends"]) == (1.0, 1.0, 1.0, "free")
    assert scene.units == "SI" and scene.title == "x" and scene.name == "x"
    assert scene.compute.n_modes is None and scene.compute.accuracy == "high"
    assert scene.draw.modes is False and scene.draw.window_size == (1024, 640)
    molecule = Scene.from_dict({"kind": "molecule", "system": {"builder": "co2"}}, source="m.toml")
    assert molecule.units == "ASE" and molecule.system.parameters["dims"] == 3


def test_lists_become_tuples() -> None:
    scene = Scene.from_dict(chain(mass=[1.0, 2.0, 1.0, 2.0]), source="x.toml")
    assert scene.system.parameters["mass"] == (1.0, 2.0, 1.0, 2.0)


def test_scene_is_immutable() -> None:
    scene = load_scene(BUNDLED[0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.name = "other"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.draw.modes = False  # type: ignore[misc]
    with pytest.raises(TypeError):
        scene.system.parameters["n"] = 3  # type: ignore[index]


def test_every_builder_serves_a_known_kind() -> None:
    # Each builder's kinds are known, and a minimal scene of each of those kinds with that
    # builder passes the builder check (a builder listed for a kind really makes it).
    for builder, (kinds, fields) in BUILDERS.items():
        assert kinds and set(kinds) <= set(KINDS), builder
        required = {name: spec for name, spec in fields.items() if spec.required}
        assert fields and all(not isinstance(spec.default, list) for spec in fields.values()), builder
        for kind in kinds:
            with pytest.raises(SceneError) as info:
                Scene.from_dict({"kind": kind, "system": {"builder": builder, "no_such_key": 1}}, source="s.toml")
            assert "system.no_such_key: unknown key" in str(info.value) or any(
                f"system.{name}: is required" in str(info.value) for name in required), (builder, kind)


def _signature_parameters(builder: str) -> dict[str, inspect.Parameter]:
    from vibra.pipeline.scene import builder_function

    return dict(inspect.signature(builder_function(builder)).parameters)


@pytest.mark.parametrize("builder", sorted(BUILDERS))
def test_every_builder_parameter_is_known_to_the_schema(builder: str) -> None:
    # Truth: the builder's own signature. Every parameter is a scene key with the builder's
    # default (required exactly when the builder has none, or the scene must say it), or is
    # listed, with a reason, as not set by scenes. A new builder argument fails here.
    from vibra.pipeline.scene.builders import NOT_IN_SCENES, SCENE_ONLY, SCENE_REQUIRED

    _, fields = BUILDERS[builder]
    for name, parameter in _signature_parameters(builder).items():
        if name in NOT_IN_SCENES[builder]:
            assert name not in fields and NOT_IN_SCENES[builder][name], (builder, name)
            continue
        assert name in fields, f"{builder}({name}=...) is unknown to the scene schema"
        has_default = parameter.default is not inspect.Parameter.empty
        assert fields[name].required == (not has_default or name in SCENE_REQUIRED.get(builder, ())), name
        if has_default:
            default = parameter.default
            assert fields[name].default == (tuple(default) if isinstance(default, list) else default), name
    assert set(fields) - set(_signature_parameters(builder)) == set(SCENE_ONLY[builder]), builder


def test_a_builder_argument_the_schema_does_not_know_stops_the_derivation(monkeypatch: pytest.MonkeyPatch) -> None:
    import vibra.chains
    from vibra.pipeline.scene import builders
    from vibra.pipeline.scene.builders import builder_fields

    original = vibra.chains.beaded_string

    def beaded_string(n: int, *, mass: float = 1.0, tension: float = 1.0, spacing: float = 1.0,
                      ends: str = "fixed", damping: float = 0.0, units: str = "SI", name: str | None = None) -> object:
        return original(n, mass=mass, tension=tension, spacing=spacing, ends=ends, units=units, name=name)

    monkeypatch.setattr(vibra.chains, "beaded_string", beaded_string)
    # an edit of the builder's source changes the cache's key (`vibra._core.cache.source_key`): no cached signature
    monkeypatch.setattr(builders, "remembered", lambda name, derive: derive())
    builder_fields.cache_clear()
    try:
        with pytest.raises(RuntimeError, match=r"builder 'beaded_string' has a parameter 'damping' that the scene "
                           r"schema does not know"):
            builder_fields("beaded_string")
    finally:
        monkeypatch.undo()
        builder_fields.cache_clear()
    assert "damping" not in builder_fields("beaded_string")


@pytest.mark.parametrize("solver", SOLVERS)
def test_every_solver_of_normal_modes_is_a_scene_solver(solver: str) -> None:
    # Truth: vibra.modes.SOLVERS, the list normal_modes validates against ("banded" included).
    # n_modes: the one request every solver serves ("sparse" computes a few modes only).
    scene = Scene.from_dict({**chain(), "compute": {"solver": solver, "n_modes": 2}}, source="s.toml")
    assert scene.compute.solver == solver


def test_dispersion_of_a_chain_with_a_mass_list_is_refused() -> None:
    # A chain of unequal masses has no single dispersion relation: refused at validation,
    # naming the key, instead of failing in `vibra report`.
    with pytest.raises(SceneError, match=r"^s\.toml: draw\.dispersion: needs a uniform chain, but system\.mass is "
                       r"a list; .*diatomic_chain"):
        Scene.from_dict({**chain(mass=[1.0, 2.0, 1.0, 2.0]), "draw": {"dispersion": True}}, source="s.toml")
    with pytest.raises(SceneError, match=r"draw\.dispersion: needs a uniform chain, but system\.stiffness is a list"):
        Scene.from_dict({**chain(stiffness=[1.0, 2.0, 1.0]), "draw": {"dispersion": True}}, source="s.toml")


def test_builder_refusal_is_a_scene_error_at_its_key() -> None:
    # beaded_string with n = 1 passes the schema's type checks; building it (as `vibra validate`
    # does) reports the builder's own check at system.n.
    from vibra.pipeline.plan import build_system

    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "beaded_string", "n": 1}}, source="b.toml")
    with pytest.raises(SceneError, match=r"^b\.toml: system\.n: n is 1; a chain needs n >= 2$"):
        build_system(scene)


@pytest.mark.parametrize("data, message", [
    ({"system": {"builder": "linear_chain", "n": 4}}, r"kind: is required"),
    ({"kind": "solid", "system": {}}, r"kind: is 'solid'; expected one of 'chain'"),
    ({"kind": "chain"}, r"system: is required"),
    ({"kind": "chain", "system": 3}, r"system: expected a table"),
    ({"kind": "chain", "system": {"n": 4}}, r"system\.builder: is required \(for kind 'chain'"),
    ({"kind": "chain", "system": {"builder": 7}}, r"system\.builder: expected a string, got an integer"),
    ({"kind": "chain", "system": {"builder": "co2"}}, r"system\.builder: builder 'co2' does not make a 'chain' scene"),
    (chain(n=1), r"system\.n: must be >= 2, got 1"),
    (chain(n=True), r"system\.n: expected an integer, got a boolean"),
    (chain(n=4.0), r"system\.n: expected an integer, got a number"),
    (chain(ends="closed"), r"system\.ends: is 'closed'; expected one of 'free', 'fixed', 'periodic'"),
    (chain(mass=[1.0, 0.0, 1.0, 1.0]), r"system\.mass: \[1\] must be positive, got 0\.0"),
    (chain(mass=[1.0, 1.0]), r"system\.mass: needs 4 values for 4 free-end masses, got 2"),
    (chain(stiffness=[1.0] * 4, ends="fixed"), r"system\.stiffness: needs 5 values for 4 fixed-end masses, got 4"),
    (chain(spacing=float("nan")), r"system\.spacing: expected a finite number"),
    (chain(defect_site=1), r"system\.defect_mass: defect_site and defect_mass go together"),
    (chain(defect_site=9, defect_mass=0.5), r"system\.defect_site: is 9; sites run from 0 to 3"),
    ({**chain(), "name": ""}, r"name: '' is not a safe file name"),
    ({**chain(), "name": "a/b"}, r"name: 'a/b' is not a safe file name"),
    ({**chain(), "name": "a..b"}, r"name: 'a\.\.b' is not a safe file name"),
    ({**chain(), "units": "cgs"}, r"units: is 'cgs'; expected one of 'SI', 'ASE', 'dimensionless' \(in any capitalisation\)"),
    ({**chain(), "compute": {"n_modes": 5}}, r"compute\.n_modes: is 5; the system has only 4 degrees of freedom"),
    ({**chain(), "compute": {"n_modes": 2, "band": [0.0, 1.0]}}, r"compute\.band: give either n_modes or band"),
    ({**chain(), "compute": {"band": [2.0, 1.0]}}, r"compute\.band: must be \[low, high\] with low < high"),
    ({**chain(), "compute": {"accuracy": "best"}}, r"compute\.accuracy: is 'best'; expected one of 'fast', 'high', 'certified'"),
    ({**chain(), "compute": {"shapes": "yes"}}, r"compute\.shapes: expected true or false, got a string"),
    ({**chain(), "compute": {"n_mode": 2}}, r"compute\.n_mode: unknown key; did you mean 'n_modes'\?"),
    ({**chain(), "compute": {"response": {"omega_min": 2.0, "omega_max": 1.0}}},
     r"compute\.response\.omega_max: must exceed omega_min \(2\), got 1"),
    ({**chain(), "compute": {"response": {"omega_max": 1.0}}}, r"compute\.response\.omega_min: is required"),
    ({**chain(), "compute": {"response": {"omega_min": 0.0, "omega_max": 1.0, "alpha": -1.0}}},
     r"compute\.response\.alpha: must be >= 0, got -1\.0"),
    ({**chain(), "compute": {"response": {"omega_min": 0.0, "omega_max": 1.0, "force_site": 4}}},
     r"compute\.response\.force_site: is 4; degrees of freedom run from 0 to 3"),
    ({**chain(), "compute": {"continuum": {"sizes": [8]}}}, r"compute\.continuum\.sizes: needs at least 2 sizes"),
    ({**chain(), "compute": {"continuum": {"modes": [8], "sizes": [8, 16]}}},
     r"compute\.continuum\.modes: mode 8 needs chains longer than the smallest size 8"),
    ({**chain(), "compute": {"crosscheck": True}}, r"compute\.crosscheck: is available for the 3-D molecules"),
    ({**chain(), "draw": {"response": True}}, r"draw\.response: needs a \[compute\.response\] table"),
    ({**chain(), "draw": {"convergence": True}}, r"draw\.convergence: needs a \[compute\.continuum\] table"),
    ({**chain(), "draw": {"n_draw": 0}}, r"draw\.n_draw: must be 1 <= value <= 24, got 0"),
    ({**chain(), "draw": {"window_size": [800]}}, r"draw\.window_size: needs 2 values, got 1"),
    ({**chain(), "draw": {"window_size": [10, 10]}}, r"draw\.window_size: \[0\] must be 64 <= value <= 4096"),
    ({"kind": "chain", "system": {"builder": "beaded_string", "n": 3}, "draw": {"dispersion": True}},
     r"draw\.dispersion: needs a linear_chain or diatomic_chain system"),
    ({"kind": "molecule", "system": {"builder": "co2", "dims": 2}}, r"system\.dims: is 2; expected one of 1, 3"),
    ({"kind": "molecule", "system": {"builder": "co2", "dims": True}}, r"system\.dims: is True; expected one of 1, 3"),
    ({"kind": "molecule", "system": {"builder": "co2", "dims": 1}, "compute": {"crosscheck": True}},
     r"compute\.crosscheck: is available for the 3-D molecules 'co2' \(dims = 3\) and 'h2o'"),
    ({"kind": "molecule", "system": {"builder": "springs", "positions": [[0, 0, 0], [1, 0, 0]],
                                      "masses": [1.0], "springs": [[0, 1]], "stiffness": 1.0}},
     r"system\.masses: needs 2 values \(one per site\), got 1"),
    ({"kind": "molecule", "system": {"builder": "springs", "positions": [[0, 0, 0], [1, 0, 0]],
                                      "masses": 1.0, "springs": [[0, 2]], "stiffness": 1.0}},
     r"system\.springs\[0\]: is \[0, 2\]; site indices run from 0 to 1"),
    ({"kind": "molecule", "system": {"builder": "springs", "positions": [[0, 0], [1, 0, 0]],
                                      "masses": 1.0, "springs": [[0, 1]], "stiffness": 1.0}},
     r"system\.positions: every site needs the same number \(1, 2 or 3\) of coordinates"),
    ({"kind": "generalized", "system": {"builder": "matrices", "M": [[1.0, 0.0], [0.0, 1.0]], "K": [[1.0]]}},
     r"system\.K: must be 2x2 like M, got 1x1"),
    ({"kind": "generalized", "system": {"builder": "matrices", "M": [[1.0, 0.0], [1.0]], "K": [[1.0]]}},
     r"system\.M: must be a square matrix"),
    ({"kind": "generalized", "system": {"builder": "double_pendulum"}, "draw": {"gif": True}},
     r"draw\.gif: animates chains and molecules, not a 'generalized' scene"),
    ({"kind": "oscillator", "system": {"builder": "oscillator", "w0": 1.0, "gamma": 0.5}, "draw": {"modes": True}},
     r"draw\.modes: an oscillator scene draws only its response"),
    ({"kind": "oscillator", "system": {"builder": "oscillator", "w0": 1.0, "gamma": [0.5, -1.0]}},
     r"system\.gamma: \[1\] must be >= 0, got -1\.0"),
    # impossible values caught before any work (they used to fail only while building)
    (chain(frozen_sites=[0, 9]), r"system\.frozen_sites\[1\]: is 9; sites run from 0 to 3"),
    (chain(frozen_dofs=[4]), r"system\.frozen_dofs\[0\]: is 4; degrees of freedom run from 0 to 3"),
    ({"kind": "chain", "system": {"builder": "beaded_string", "n": 3, "frozen_dofs": [6]}},
     r"system\.frozen_dofs\[0\]: is 6; degrees of freedom \(site \* 2 \+ axis\) run from 0 to 5"),
    (chain(frozen_sites=[0, 1, 2, 3]), r"system\.frozen_sites: holds every degree of freedom at rest"),
    (chain(frozen_sites=[0, 1], frozen_dofs=[2, 3]), r"system\.frozen_dofs: holds every degree of freedom at rest"),
    ({"kind": "chain", "system": {"builder": "beaded_string", "n": 2, "frozen_dofs": [1, 3]}},
     r"system\.frozen_dofs: holds every degree of freedom at rest"),  # x is already held: 2 dof, both frozen
    ({**chain(frozen_sites=[1, 1]), "compute": {"n_modes": 4}},  # a repeated site is frozen once: 3 dof
     r"compute\.n_modes: is 4; the system has only 3 degrees of freedom"),
    ({"kind": "molecule", "system": {"builder": "co2", "dims": 3, "frozen_sites": [1]}, "compute": {"n_modes": 7}},
     r"compute\.n_modes: is 7; the system has only 6 degrees of freedom"),
    ({**chain(), "compute": {"response": {"omega_min": 0.0, "omega_max": 1.0, "method": "modal", "n_modes": 5}}},
     r"compute\.response\.n_modes: is 5; the system has only 4 degrees of freedom"),
    ({"kind": "chain", "system": {"builder": "springs", "positions": [0.0, 1.0], "masses": 1.0,
                                   "springs": [[1, 1]], "stiffness": 1.0}},
     r"system\.springs\[0\]: is \[1, 1\]; a spring joins two different sites"),
    ({"kind": "chain", "system": {"builder": "springs", "positions": [0.0, 1.0], "masses": 1.0,
                                   "springs": [[0, 1]], "stiffness": 1.0, "anchors": [0, 2],
                                   "anchor_stiffness": 1.0}},
     r"system\.anchors\[1\]: is 2; site indices run from 0 to 1"),
    ({"kind": "chain", "system": {"builder": "springs", "positions": [0.0, 1.0], "masses": 1.0,
                                   "springs": [[0, 1]], "stiffness": 1.0, "anchors": [0]}},
     r"system\.anchor_stiffness: is required with anchors"),
    ({"kind": "chain", "system": {"builder": "springs", "positions": [0.0, 1.0], "masses": 1.0,
                                   "springs": [[0, 1]], "stiffness": 1.0, "anchor_stiffness": 2.0}},
     r"system\.anchor_stiffness: is given but there are no anchors"),
    ({"kind": "chain", "system": {"builder": "springs", "positions": [0.0, 1.0], "masses": 1.0,
                                   "springs": [[0, 1]], "stiffness": 1.0, "anchors": [0, 1],
                                   "anchor_stiffness": [1.0, 2.0, 3.0]}},
     r"system\.anchor_stiffness: needs 2 values \(one per anchor\), got 3"),
    ({"kind": "molecule", "system": {"builder": "springs", "positions": [[0, 0, 0], [1.1, 0, 0]],
                                      "masses": [12.0, 16.0], "springs": [[0, 1]], "stiffness": 50.0,
                                      "symbols": ["C", "Xx"]}},
     r"system\.symbols\[1\]: is 'Xx', not a chemical symbol"),
])
def test_validation_messages(data: dict[str, object], message: str) -> None:
    with pytest.raises(SceneError, match=r"^scene\.toml: " + message):
        Scene.from_dict(data, source="scene.toml")


def test_unsafe_file_stem_names_the_file_and_the_fix() -> None:
    # No `name` key: the name comes from the file, so the message says so and how to fix it.
    with pytest.raises(SceneError, match=r"^chains/my scene\.toml: name: 'my scene' \(the file name, as no name "
                       r"is given\) is not a safe file name: .*no spaces.*; rename the file or add a name"):
        Scene.from_dict(chain(), source="chains/my scene.toml")
    assert Scene.from_dict({**chain(), "name": "my-scene"}, source="chains/my scene.toml").name == "my-scene"


@pytest.mark.parametrize("system", [
    {"builder": "linear_chain", "n": 6, "frozen_sites": [0, 0, 5], "frozen_dofs": [5, 2]},
    {"builder": "beaded_string", "n": 5, "frozen_sites": [4], "frozen_dofs": [0, 1, 3]},
    {"builder": "diatomic_chain", "n_cells": 3, "masses": [1.0, 2.0], "frozen_dofs": [1]},
    {"builder": "springs", "positions": [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], "masses": 1.0,
     "springs": [[0, 1], [0, 2]], "stiffness": 1.0, "frozen_sites": [2], "frozen_dofs": [0, 5]},
    {"builder": "co2", "dims": 1, "frozen_dofs": [0]},
    {"builder": "h2o", "frozen_sites": [0], "frozen_dofs": [0, 3]},
])
def test_schema_dof_count_matches_the_built_system(system: dict[str, object]) -> None:
    # Truth: the System that vibra.system builds. n_modes = its dof count must pass the schema
    # check and one more must fail it, naming that count.
    from vibra.pipeline.plan import build_system

    kind = "molecule" if system["builder"] in ("co2", "h2o") else "chain"
    n_dof = build_system(Scene.from_dict({"kind": kind, "system": system}, source="s.toml")).n_dof
    Scene.from_dict({"kind": kind, "system": system, "compute": {"n_modes": n_dof}}, source="s.toml")
    with pytest.raises(SceneError, match=rf"compute\.n_modes: is {n_dof + 1}; the system has only {n_dof} "):
        Scene.from_dict({"kind": kind, "system": system, "compute": {"n_modes": n_dof + 1}}, source="s.toml")


def test_name_required_without_a_file() -> None:
    with pytest.raises(SceneError, match=r"name: is required when the scene has no file name"):
        Scene.from_dict(chain())


def test_valid_variants_of_every_kind() -> None:
    # Each variant is accepted and its values arrive normalised: lists as tuples, integers
    # as floats where a number is asked, defaults of the kind filled in.
    osc = Scene.from_dict({"kind": "oscillator", "system": {"builder": "oscillator", "w0": 1.0,
                                                            "gamma": [0.5, 1, 2, 4]},
                           "draw": {"response": True}}, source="osc.toml")
    assert (osc.kind, osc.units, osc.name) == ("oscillator", "SI", "osc")
    assert osc.system.parameters["gamma"] == (0.5, 1.0, 2.0, 4.0)
    assert all(isinstance(g, float) for g in osc.system.parameters["gamma"])
    assert osc.system.parameters["m"] == 1.0 and osc.draw.response
    gen = Scene.from_dict({"kind": "generalized", "system": {"builder": "matrices", "M": [[2.0, 1.0], [1.0, 2.0]],
                                                              "K": [[1.0, 0.0], [0.0, 1.0]],
                                                              "coordinates": ["a", "b"]}},
                          source="gen.toml")
    assert gen.system.parameters["M"] == ((2.0, 1.0), (1.0, 2.0))
    assert gen.system.parameters["coordinates"] == ("a", "b") and gen.units == "SI"
    co = Scene.from_dict({"kind": "molecule", "system": {"builder": "springs", "positions": [[0, 0, 0], [1.1, 0, 0]],
                                                         "masses": [12.0, 16.0], "springs": [[0, 1]],
                                                         "stiffness": 50.0, "symbols": ["C", "O"]}},
                         source="co.toml")
    assert co.units == "ASE" and co.system.parameters["springs"] == ((0, 1),)
    assert co.system.parameters["positions"] == ((0.0, 0.0, 0.0), (1.1, 0.0, 0.0))
    assert co.system.parameters["symbols"] == ("C", "O") and co.system.parameters["anchors"] is None


def test_find_scene_files_expands_folders(tmp_path: Path) -> None:
    (tmp_path / "b.toml").write_text("")
    (tmp_path / "a.toml").write_text("")
    (tmp_path / "notes.txt").write_text("")
    found = find_scene_files([tmp_path, tmp_path / "missing.toml"])
    assert [p.name for p in found] == ["a.toml", "b.toml", "missing.toml"]


def test_unreadable_text(tmp_path: Path) -> None:
    path = tmp_path / "binary.toml"
    path.write_bytes(b"\xff\xfe\x00kind")
    with pytest.raises(SceneError, match=r"binary\.toml: not UTF-8 text"):
        load_scene(path)
