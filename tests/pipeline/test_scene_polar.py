"""The polar crystal scene (crystals/nacl-polar.toml): LO-TO split, ε(ω) and the reflectivity.

Truth: phonopy itself for the scene's crystal (phonopy.load of the same files with the BORN
file, its frequencies at Gamma approached along [1, 0, 0]); the Lyddane-Sachs-Teller relation
(an invariant of the oscillator model); the images the plan writes (size, not blank); and
one-line errors naming each bad infrared key.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vibra.pipeline.plan import execute, make_plan, validate
from vibra.pipeline.scene import Scene, SceneError, load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "crystals" / "nacl-polar.toml"
DATA = ROOT / "crystals" / "nacl"


def nacl(**changes: object) -> dict:
    """The bundled scene's tables, with `changes` merged into its sections (a section None: removed)."""
    data = tomllib.loads(SCENE.read_text())
    data["compute"] = {"npoints": 60, "mesh": [6, 6, 6]}   # small: the test is the wiring, not the sums
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values} if isinstance(values, dict) else values
    for section, values in list(data.items()):
        if isinstance(values, dict):
            data[section] = {key: value for key, value in values.items() if value is not None}
    return data


def test_the_scene_reads_phonopy_s_nacl_with_its_born_charges() -> None:
    scene = load_scene(SCENE)
    params = scene.system.parameters
    assert scene.name == "nacl-polar" and scene.kind == "crystal" and params["born_file"] == "nacl/BORN"
    assert params["infrared_damping"] == 8.0 and params["infrared_direction"] == (1.0, 0.0, 0.0)
    for name in ("BORN", "FORCE_SETS", "phonopy_disp.yaml", "LICENSE"):  # phonopy's files, with its licence
        assert (DATA / name).read_bytes() == (ROOT / "tests" / "data" / "phonopy" /
                                              ("LICENSE" if name == "LICENSE" else f"NaCl/{name}")).read_bytes()


def test_the_scene_s_split_is_phonopy_s() -> None:
    import phonopy

    crystal = validate(load_scene(SCENE))
    assert crystal.nac is not None and crystal.nac.method == "gonze"
    phonon = phonopy.load(DATA / "phonopy_disp.yaml", force_sets_filename=DATA / "FORCE_SETS",
                          born_filename=DATA / "BORN", log_level=0)
    phonon.run_qpoints([[0.0, 0.0, 0.0]], nac_q_direction=[1.0, 0.0, 0.0])
    theirs = phonon.qpoints.frequencies[0]                     # THz: 3 acoustic, 2 TO, 1 LO
    ours = crystal.units.omega_to_thz(crystal.frequencies([[0.0, 0.0, 0.0]], q_direction=[1.0, 0.0, 0.0])[0])
    np.testing.assert_allclose(ours[3:], theirs[3:], rtol=1e-6)
    cm1 = crystal.units.omega_to_cm1(crystal.frequencies([[0.0, 0.0, 0.0]], q_direction=[1.0, 0.0, 0.0])[0])
    assert cm1[3] == pytest.approx(154.0, abs=0.5) and cm1[5] == pytest.approx(247.0, abs=0.5)  # the comment's


def test_validate_prints_the_infrared_cost() -> None:
    run = subprocess.run([sys.executable, "-m", "vibra", "validate", str(SCENE)], capture_output=True, text=True,
                         cwd=ROOT)
    assert run.returncode == 0, run.stdout + run.stderr
    line = next(text for text in run.stdout.splitlines() if "nacl-polar" in text)
    assert "2 atoms per cell, 6 branches" in line and "infrared: Gamma modes" in line and "D(q) solves ~" in line


def test_only_a_polar_crystal_plans_the_infrared_steps() -> None:
    polar = make_plan(Scene.from_dict(nacl(), source=str(SCENE)))
    assert polar.step_names == ("build", "crystal-bands", "chart-bands", "crystal-infrared", "chart-infrared")
    bare = nacl(system={"born_file": None, "infrared_damping": None, "infrared_direction": None})
    assert make_plan(Scene.from_dict(bare, source=str(SCENE))).step_names == ("build", "crystal-bands",
                                                                               "chart-bands")


def test_report_draws_the_split_bands_and_the_infrared_chart(tmp_path: Path) -> None:
    scene = Scene.from_dict(nacl(), source=str(SCENE))
    work = tmp_path / "work"
    work.mkdir()
    result = execute(make_plan(scene), tmp_path, work)
    assert result.outputs == ("nacl-polar_bands.png", "nacl-polar_view.json", "nacl-polar_infrared.png")
    for name in (n for n in result.outputs if n.endswith(".png")):
        with Image.open(tmp_path / name) as image:
            picture = np.asarray(image.convert("RGB"))
        assert picture.shape[1] >= 600 and picture.std() > 5.0        # a chart, not blank
    bands, _, infrared = result.captions  # the middle one: the interactive view's data
    assert "the LO branch splits from the TO at Gamma" in bands
    assert "reststrahlen band" in infrared and "damping 8 cm^-1" in infrared and "154 to 247 cm^-1" in infrared
    record = next(r for r in result.records if r.name == "crystal-infrared")
    assert "TO 154 / LO 246.7 cm^-1" in record.accuracy
    lst = float(record.accuracy.rsplit("off by ", 1)[1])
    assert lst < 1e-12                                                  # Lyddane-Sachs-Teller, as it must


def test_the_light_direction_is_drawn() -> None:
    from vibra.pipeline.plan.crystal import light_direction

    scene = Scene.from_dict(nacl(system={"infrared_direction": [0.0, 3.0, 4.0]}), source=str(SCENE))
    np.testing.assert_allclose(light_direction(scene), [0.0, 0.6, 0.8])
    default = Scene.from_dict(nacl(system={"infrared_direction": None}), source=str(SCENE))
    np.testing.assert_allclose(light_direction(default), [1.0, 0.0, 0.0])


@pytest.mark.parametrize("system, message", [
    ({"infrared_damping": -1.0}, r"nacl-polar\.toml: system\.infrared_damping: must be >= 0, got -1\.0"),
    ({"infrared_damping": "8 cm^-1"}, r"system\.infrared_damping: expected a number, got a string"),
    ({"infrared_damping": float("inf")}, r"system\.infrared_damping: expected a finite number"),
    ({"infrared_direction": [0.0, 0.0, 0.0]}, r"system\.infrared_direction: is \[0\.0, 0\.0, 0\.0\]; the light's "
                                              r"polarisation needs a direction"),
    ({"infrared_direction": [1.0, 0.0]}, r"system\.infrared_direction: needs 3 values, got 2"),
    ({"infrared_directon": [1.0, 0.0, 0.0]}, r"system\.infrared_directon: unknown key; did you mean "
                                             r"'infrared_direction'\?"),
    ({"born_file": None}, r"system\.infrared_damping: is set, but this crystal has no Born charges"),
])
def test_bad_infrared_key_is_refused_naming_the_key(system: dict, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        validate(Scene.from_dict(nacl(system=system), source=str(SCENE)))


def test_a_lattice_builder_has_no_infrared_keys() -> None:
    argon = {"kind": "crystal", "system": {"builder": "fcc", "a": 5.397, "mass": 39.948, "stiffness": 0.05141,
                                           "infrared_damping": 8.0}}
    with pytest.raises(SceneError, match=r"system\.infrared_damping: unknown key"):
        Scene.from_dict(argon, source="argon.toml")


def test_cli_refuses_a_bad_damping_in_one_line(tmp_path: Path) -> None:
    shutil.copytree(DATA, tmp_path / "nacl")
    text = SCENE.read_text().replace("infrared_damping = 8.0", "infrared_damping = -8.0")
    (tmp_path / "bad.toml").write_text(text)
    run = subprocess.run([sys.executable, "-m", "vibra", "validate", str(tmp_path / "bad.toml")],
                         capture_output=True, text=True, cwd=ROOT)
    assert run.returncode != 0 and "Traceback" not in run.stderr
    assert "bad.toml: system.infrared_damping: must be >= 0, got -8.0" in run.stdout + run.stderr


def test_a_yaml_with_its_own_born_charges_gets_the_infrared_chart(tmp_path: Path) -> None:
    """phonopy's own ``phonopy.save`` of the scene's crystal (force sets and the nac section in one
    yaml) plans and draws the infrared response as the BORN file does, to the same numbers."""
    import phonopy

    phonon = phonopy.load(DATA / "phonopy_disp.yaml", force_sets_filename=DATA / "FORCE_SETS",
                          born_filename=DATA / "BORN", log_level=0)
    phonon.save(tmp_path / "phonopy_params.yaml")  # phonopy writes the Born charges in its nac section
    assert "born_effective_charge" in (tmp_path / "phonopy_params.yaml").read_text()
    data = nacl(system={"file": "phonopy_params.yaml", "force_sets_file": None, "born_file": None})
    scene = Scene.from_dict(data, source=str(tmp_path / "own.toml"))
    plan = make_plan(scene)
    assert plan.step_names == ("build", "crystal-bands", "chart-bands", "crystal-infrared", "chart-infrared")
    out = tmp_path / "out"
    out.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    result = execute(plan, out, work)
    assert result.outputs == ("own_bands.png", "own_view.json", "own_infrared.png")
    record = next(r for r in result.records if r.name == "crystal-infrared")
    assert "TO 154 / LO 246.7 cm^-1" in record.accuracy  # the BORN file's figures (the same charges)
    # without the nac section the same yaml is a plain crystal: no infrared steps, and the keys refused
    phonon.nac_params = None
    phonon.save(tmp_path / "plain.yaml")
    plain = nacl(system={"file": "plain.yaml", "force_sets_file": None, "born_file": None,
                         "infrared_damping": None, "infrared_direction": None})
    assert make_plan(Scene.from_dict(plain, source=str(tmp_path / "plain.toml"))).step_names == (
        "build", "crystal-bands", "chart-bands")
    with pytest.raises(SceneError, match=r"system\.infrared_damping: is set, but this crystal has no Born charges"):
        validate(Scene.from_dict(nacl(system={"file": "plain.yaml", "force_sets_file": None, "born_file": None}),
                                 source=str(tmp_path / "plain.toml")))
