"""Molecule scenes of issue 12: the 'molecule' builder (ASE name or .xyz beside the scene), isotopes,
D/T symbols, and ``vibra modes --molden``.

Truth from outside the code under test: ASE's molecule collection and its XYZ writer, the
isotope masses of NIST (vibra.molecules.ISOTOPE_MASSES, checked in test_isotopes), and the
Molden format's sections (www.theochem.ru.nl/molden/molden_format.html).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vibra.pipeline.plan import build_system, validate
from vibra.pipeline.scene import Scene, SceneError, load_scene

ROOT = Path(__file__).resolve().parents[2]


def molecule_scene(folder: Path, body: str, name: str = "m.toml") -> Path:
    path = folder / name
    path.write_text('kind = "molecule"\n[system]\n' + body)
    return path


def test_molecule_by_name_builds_ase_geometry(tmp_path: Path) -> None:
    from ase.build import molecule

    system = build_system(load_scene(molecule_scene(tmp_path, 'builder = "molecule"\nname = "CH4"\n')))
    reference = molecule("CH4")
    assert system.symbols == tuple(reference.get_chemical_symbols())
    assert np.allclose(system.positions, reference.get_positions(), atol=1e-6)
    assert np.allclose(system.masses, reference.get_masses())


def test_molecule_from_xyz_beside_the_scene(tmp_path: Path) -> None:
    from ase.build import molecule
    from ase.io import write

    write(tmp_path / "ammonia.xyz", molecule("NH3"))
    scene = load_scene(molecule_scene(tmp_path, 'builder = "molecule"\nxyz = "ammonia.xyz"\n'))
    system = validate(scene)
    assert system.symbols == ("N", "H", "H", "H")
    assert system.n_dof == 12


@pytest.mark.parametrize("isotopes, masses", [
    ('["", "D", "D"]', lambda m: [m["O"], m["D"], m["D"]]),
    ('["18O", "", "T"]', lambda m: [m["18O"], 1.008, m["T"]]),
])
def test_isotopes_in_h2o_scenes(tmp_path: Path, isotopes: str, masses: object) -> None:
    from vibra.molecules import ISOTOPE_MASSES

    table = {**ISOTOPE_MASSES, "O": 15.999}
    system = build_system(load_scene(molecule_scene(tmp_path, f'builder = "h2o"\nisotopes = {isotopes}\n')))
    assert np.allclose(system.masses, masses(table))  # type: ignore[operator]


def test_isotopes_in_co2_and_molecule_scenes(tmp_path: Path) -> None:
    from vibra.molecules import ISOTOPE_MASSES

    co2 = build_system(load_scene(molecule_scene(tmp_path, 'builder = "co2"\nisotopes = ["", "13C", ""]\n')))
    assert co2.masses[1] == ISOTOPE_MASSES["13C"]
    cd4 = build_system(load_scene(molecule_scene(
        tmp_path, 'builder = "molecule"\nname = "CH4"\nisotopes = ["", "D", "D", "D", "D"]\n', "cd4.toml")))
    assert np.allclose(cd4.masses[1:], ISOTOPE_MASSES["D"])


def test_deuterium_as_a_symbol_in_a_springs_scene(tmp_path: Path) -> None:
    body = ('builder = "springs"\npositions = [[0.0, 0, 0], [0.96, 0, 0], [-0.24, 0.93, 0]]\n'
            'masses = [15.999, 2.014, 2.014]\nsymbols = ["O", "D", "D"]\nsprings = [[0, 1], [0, 2], [1, 2]]\n'
            'stiffness = [50.0, 50.0, 5.0]\n[draw]\nmodes = true\n')
    validate(load_scene(molecule_scene(tmp_path, body)))


@pytest.mark.parametrize("body, message", [
    ('builder = "molecule"\n', r"system\.name: give the molecule as name"),
    ('builder = "molecule"\nname = "CH4"\nxyz = "a.xyz"\n', r"system\.name: give the molecule as name"),
    ('builder = "molecule"\nname = "CH4"\nisotopes = ["", "D", "", "", ""]\nmasses = [12.0, 2.0, 1.0, 1.0, 1.0]\n',
     r"system\.masses: give isotopes \(labels\) or masses"),
    ('builder = "molecule"\nxyz = "../outside.xyz"\n', r"system\.xyz: '\.\./outside\.xyz' leads outside the scene's folder"),
    ('builder = "molecule"\nxyz = "/etc/hosts"\n', r"system\.xyz: is '/etc/hosts'; give a file name relative"),
    ('builder = "molecule"\nxyz = "missing.xyz"\n', r"system\.xyz: 'missing\.xyz': file not found"),
    ('builder = "h2o"\nisotopes = "D"\n', r"system\.isotopes: expected a list"),
    ('builder = "h2o"\nisotopes = [1, 2, 3]\n', r"system\.isotopes: \[0\] expected a string"),
])
def test_molecule_scene_refusals(tmp_path: Path, body: str, message: str) -> None:
    (tmp_path / "scenes").mkdir()
    (tmp_path / "outside.xyz").write_text("2\n\nH 0 0 0\nH 0 0 0.74\n")
    with pytest.raises(SceneError, match=message):
        load_scene(molecule_scene(tmp_path / "scenes", body))


def test_symlink_out_of_the_scene_folder_is_refused(tmp_path: Path) -> None:
    (tmp_path / "scenes").mkdir()
    (tmp_path / "secret.xyz").write_text("2\n\nH 0 0 0\nH 0 0 0.74\n")
    os.symlink(tmp_path / "secret.xyz", tmp_path / "scenes" / "inside.xyz")
    with pytest.raises(SceneError, match=r"system\.xyz: 'inside\.xyz' leads outside the scene's folder"):
        load_scene(molecule_scene(tmp_path / "scenes", 'builder = "molecule"\nxyz = "inside.xyz"\n'))


@pytest.mark.parametrize("body, message", [
    ('builder = "molecule"\nname = "CH5"\n', r"system\.name: molecule name 'CH5' is not in ASE's molecule collection"),
    ('builder = "h2o"\nisotopes = ["", "13C", ""]\n', r"system\.isotopes: isotopes\[1\] is '13C' \(C\) but atom 1 is 'H'"),
    ('builder = "h2o"\nisotopes = ["", "X", ""]\n', r"system\.isotopes: isotopes\[1\] is 'X', not an isotope label"),
    ('builder = "h2o"\nisotopes = ["", "D"]\n', r"system\.isotopes: isotopes must give 3 labels"),
])
def test_molecule_builder_refusals_are_scene_errors(tmp_path: Path, body: str, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        validate(load_scene(molecule_scene(tmp_path, body)))


def test_bad_xyz_file_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "bad.xyz").write_text("not a number\n")
    with pytest.raises(SceneError, match=r"system\.xyz: 'bad\.xyz': line 1: is 'not a number'; an XYZ file starts "
                                         "with its number of atoms"):
        validate(load_scene(molecule_scene(tmp_path, 'builder = "molecule"\nxyz = "bad.xyz"\n')))


def _vibra(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vibra", *args], capture_output=True, text=True, cwd=ROOT,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})


def test_modes_molden_writes_a_molden_file(tmp_path: Path) -> None:
    target = tmp_path / "ch4.molden"
    run = _vibra("modes", "molecules/ch4.toml", "--molden", str(target))
    assert run.returncode == 0, run.stderr
    assert "species (Td)" in run.stdout and "Molden file written" in run.stdout
    lines = target.read_text().splitlines()
    sections = [line for line in lines if line.startswith("[")]
    assert sections == ["[Molden Format]", "[FREQ]", "[FR-COORD]", "[FR-NORM-COORD]"]
    frequencies = lines[lines.index("[FREQ]") + 1: lines.index("[FR-COORD]")]
    assert len(frequencies) == 9  # 3N - 6 vibrations of CH4
    assert sum(line.startswith("vibration ") for line in lines) == 9
    coordinates = lines[lines.index("[FR-COORD]") + 1: lines.index("[FR-NORM-COORD]")]
    assert [line.split()[0] for line in coordinates] == ["C", "H", "H", "H", "H"]


@pytest.mark.parametrize("scene, target, message", [
    ("chains/diatomic.toml", "x.molden", "--molden writes molecules only"),
    ("molecules/co2-axial.toml", "x.molden", "--molden writes molecules only"),
    ("molecules/h2o.toml", "blocker/x.molden", "blocker is a regular file, not a folder"),
])
def test_modes_molden_errors_are_one_line(tmp_path: Path, scene: str, target: str, message: str) -> None:
    (tmp_path / "blocker").write_text("a file where a folder should be")
    run = _vibra("modes", scene, "--molden", str(tmp_path / target))
    assert run.returncode == 1
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert "Traceback" not in run.stderr


def test_bundled_molecule_scenes_show_species() -> None:
    run = _vibra("modes", "molecules/d2o.toml")
    assert run.returncode == 0, run.stderr
    assert "species (C2v)" in run.stdout and ("ν3 2788" in run.stdout or "nu3 2788" in run.stdout)  # ASCII where stdout needs it
    scene = Scene.from_dict({"kind": "molecule", "system": {"builder": "molecule", "name": "CH4"}}, source="x.toml")
    assert scene.system.parameters["name"] == "CH4"
