"""Tests of vibra.molecules.symmetry and character_tables: point groups, character tables, species.

Truth comes from textbook character tables typed in below (F. A. Cotton, "Chemical Applications
of Group Theory", 3rd ed., Wiley 1990, appendix IIA; the same tables are in P. W. Atkins and
J. de Paula, "Physical Chemistry", resource section), from the textbook symmetry species of the
fundamentals (G. Herzberg, "Molecular Spectra and Molecular Structure II: Infrared and Raman
Spectra of Polyatomic Molecules", Van Nostrand 1945; T. Shimanouchi, "Tables of Molecular
Vibrational Frequencies, Consolidated Volume I", NSRDS-NBS 39 (1972), as listed in the NIST
CCCBDB, https://cccbdb.nist.gov, "vibrations" pages), from ASE's molecule geometries, from the
intensity-based IR and Raman activity of vibra.spectra (a different computation: dipole and
polarisability derivatives), and from invariants (orthogonality of characters, invariance under
rotation, relabelling of atoms and rotation inside a degenerate subspace).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections import Counter

import numpy as np
import pytest
from ase import Atoms
from ase.build import molecule

from vibra import molecules as mol
from vibra.spectra import electronegativity_charges, ir_spectrum, raman_spectrum

PHI = (1 + np.sqrt(5)) / 2


# ------------------------------------------------------------------ matrices built independently
def rot(axis: list[float], degrees: float) -> np.ndarray:
    """Proper rotation (Rodrigues), built here independently of vibra."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(degrees)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * k + (1 - np.cos(t)) * k @ k


def refl(normal: list[float]) -> np.ndarray:
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    return np.eye(3) - 2 * np.outer(n, n)


def improper(axis: list[float], degrees: float) -> np.ndarray:
    return refl(axis) @ rot(axis, degrees)


INV = -np.eye(3)
Z, X, Y = [0, 0, 1], [1, 0, 0], [0, 1, 0]


def systems() -> dict[str, object]:
    """The oracle molecules at their valence-force-field equilibrium (symmetric Hessians)."""
    return {
        "CO2": mol.co2(), "H2O": mol.h2o(), "NH3": mol.from_atoms(molecule("NH3")),
        "CH4": mol.from_atoms(molecule("CH4")), "C2H4": mol.from_atoms(molecule("C2H4"), torsion=0.3),
        "C6H6": mol.from_atoms(molecule("C6H6"), torsion=0.3),
    }


@pytest.fixture(scope="module")
def analyses() -> dict[str, mol.VibrationalAnalysis]:
    return {name: mol.vibrational_analysis(system) for name, system in systems().items()}  # type: ignore[arg-type]


def octahedron() -> Atoms:
    d = 1.56
    return Atoms("SF6", positions=[[0, 0, 0], [d, 0, 0], [-d, 0, 0], [0, d, 0], [0, -d, 0], [0, 0, d], [0, 0, -d]])


# ------------------------------------------------------------------ textbook character tables
# Each: (molecule giving the group, order, classes as representative operations in the standard
# frame, {species: (characters per class, IR active, Raman active)}), from Cotton appendix IIA.
C2V = (molecule("H2O"), 4, [np.eye(3), rot(Z, 180), refl(Y), refl(X)], {
    "A1": ([1, 1, 1, 1], True, True), "A2": ([1, 1, -1, -1], False, True),
    "B1": ([1, -1, 1, -1], True, True), "B2": ([1, -1, -1, 1], True, True)})
C3V = (molecule("NH3"), 6, [np.eye(3), rot(Z, 120), refl(Y)], {
    "A1": ([1, 1, 1], True, True), "A2": ([1, 1, -1], False, False), "E": ([2, -1, 0], True, True)})
TD = (molecule("CH4"), 24, [np.eye(3), rot([1, 1, 1], 120), rot(Z, 180), improper(Z, 90), refl([1, -1, 0])], {
    "A1": ([1, 1, 1, 1, 1], False, True), "A2": ([1, 1, 1, -1, -1], False, False),
    "E": ([2, -1, 2, 0, 0], False, True), "T1": ([3, 0, -1, 1, -1], False, False),
    "T2": ([3, 0, -1, -1, 1], True, True)})
D2H = (molecule("C2H4"), 8,
       [np.eye(3), rot(Z, 180), rot(Y, 180), rot(X, 180), INV, refl(Z), refl(Y), refl(X)], {
           "Ag": ([1, 1, 1, 1, 1, 1, 1, 1], False, True), "B1g": ([1, 1, -1, -1, 1, 1, -1, -1], False, True),
           "B2g": ([1, -1, 1, -1, 1, -1, 1, -1], False, True), "B3g": ([1, -1, -1, 1, 1, -1, -1, 1], False, True),
           "Au": ([1, 1, 1, 1, -1, -1, -1, -1], False, False), "B1u": ([1, 1, -1, -1, -1, -1, 1, 1], True, False),
           "B2u": ([1, -1, 1, -1, -1, 1, -1, 1], True, False), "B3u": ([1, -1, -1, 1, -1, 1, 1, -1], True, False)})
# D6h: E 2C6 2C3 C2 3C2' 3C2'' i 2S3 2S6 sigma_h 3sigma_d 3sigma_v; C2' along x (through atoms),
# C2'' at 30 degrees; sigma_d contains C2'', sigma_v contains C2'.
D6H = (molecule("C6H6"), 24,
       [np.eye(3), rot(Z, 60), rot(Z, 120), rot(Z, 180), rot(X, 180), rot([np.cos(np.pi / 6), 0.5, 0], 180), INV,
        improper(Z, 120), improper(Z, 60), refl(Z), refl([-0.5, np.cos(np.pi / 6), 0]), refl(Y)], {
           "A1g": ([1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1], False, True),
           "A2g": ([1, 1, 1, 1, -1, -1, 1, 1, 1, 1, -1, -1], False, False),
           "B1g": ([1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1], False, False),
           "B2g": ([1, -1, 1, -1, -1, 1, 1, -1, 1, -1, -1, 1], False, False),
           "E1g": ([2, 1, -1, -2, 0, 0, 2, 1, -1, -2, 0, 0], False, True),
           "E2g": ([2, -1, -1, 2, 0, 0, 2, -1, -1, 2, 0, 0], False, True),
           "A1u": ([1, 1, 1, 1, 1, 1, -1, -1, -1, -1, -1, -1], False, False),
           "A2u": ([1, 1, 1, 1, -1, -1, -1, -1, -1, -1, 1, 1], True, False),
           "B1u": ([1, -1, 1, -1, 1, -1, -1, 1, -1, 1, -1, 1], False, False),
           "B2u": ([1, -1, 1, -1, -1, 1, -1, 1, -1, 1, 1, -1], False, False),
           "E1u": ([2, 1, -1, -2, 0, 0, -2, -1, 1, 2, 0, 0], True, False),
           "E2u": ([2, -1, -1, 2, 0, 0, -2, 1, 1, -2, 0, 0], False, False)})
# Oh: E 8C3 6C2 6C4 3C2(=C4^2) i 6S4 8S6 3sigma_h 6sigma_d
OH = (octahedron(), 48,
      [np.eye(3), rot([1, 1, 1], 120), rot([1, 1, 0], 180), rot(Z, 90), rot(Z, 180), INV, improper(Z, 90),
       improper([1, 1, 1], 60), refl(Z), refl([1, -1, 0])], {
          "A1g": ([1, 1, 1, 1, 1, 1, 1, 1, 1, 1], False, True),
          "A2g": ([1, 1, -1, -1, 1, 1, -1, 1, 1, -1], False, False),
          "Eg": ([2, -1, 0, 0, 2, 2, 0, -1, 2, 0], False, True),
          "T1g": ([3, 0, -1, 1, -1, 3, 1, 0, -1, -1], False, False),
          "T2g": ([3, 0, 1, -1, -1, 3, -1, 0, -1, 1], False, True),
          "A1u": ([1, 1, 1, 1, 1, -1, -1, -1, -1, -1], False, False),
          "A2u": ([1, 1, -1, -1, 1, -1, 1, -1, -1, 1], False, False),
          "Eu": ([2, -1, 0, 0, 2, -2, 0, 1, -2, 0], False, False),
          "T1u": ([3, 0, -1, 1, -1, -3, -1, 0, 1, 1], True, False),
          "T2u": ([3, 0, 1, -1, -1, -3, 1, 0, 1, -1], False, False)})


# D3h: E 2C3 3C2 sigma_h 2S3 3sigma_v (BF3, C2 along a B-F bond)
D3H = (molecule("BF3"), 12, [np.eye(3), rot(Z, 120), rot(X, 180), refl(Z), improper(Z, 120), refl(Y)], {
    "A1'": ([1, 1, 1, 1, 1, 1], False, True), "A2'": ([1, 1, -1, 1, 1, -1], False, False),
    "E'": ([2, -1, 0, 2, -1, 0], True, True), "A1''": ([1, 1, 1, -1, -1, -1], False, False),
    "A2''": ([1, 1, -1, -1, -1, 1], True, False), "E''": ([2, -1, 0, -2, 1, 0], False, True)})


def icosahedron() -> Atoms:
    """12 vertices: cyclic permutations of (0, +-1, +-phi), Angstrom."""
    points = [np.roll([0.0, a, b * PHI], k) for k in range(3) for a in (1, -1) for b in (1, -1)]
    return Atoms("B12", positions=np.array(points))


# T (in the test): E 4C3 4C3^2 3C2; Cotton's complex pair {E} summed into one real E
# Ih: E 12C5 12C5^2 20C3 15C2 i 12S10 12S10^3 20S6 15sigma (C5 through the vertex (0, 1, phi))
C5_AXIS = [0, 1, PHI]
IH = (icosahedron(), 120,
      [np.eye(3), rot(C5_AXIS, 72), rot(C5_AXIS, 144), rot([1, 1, 1], 120), rot(Z, 180), INV,
       improper(C5_AXIS, 36), improper(C5_AXIS, 108), improper([1, 1, 1], 60), refl(Z)], {
          "Ag": ([1, 1, 1, 1, 1, 1, 1, 1, 1, 1], False, True),
          "T1g": ([3, PHI, 1 - PHI, 0, -1, 3, 1 - PHI, PHI, 0, -1], False, False),
          "T2g": ([3, 1 - PHI, PHI, 0, -1, 3, PHI, 1 - PHI, 0, -1], False, False),
          "Gg": ([4, -1, -1, 1, 0, 4, -1, -1, 1, 0], False, False),
          "Hg": ([5, 0, 0, -1, 1, 5, 0, 0, -1, 1], False, True),
          "Au": ([1, 1, 1, 1, 1, -1, -1, -1, -1, -1], False, False),
          "T1u": ([3, PHI, 1 - PHI, 0, -1, -3, PHI - 1, -PHI, 0, 1], True, False),
          "T2u": ([3, 1 - PHI, PHI, 0, -1, -3, -PHI, PHI - 1, 0, 1], False, False),
          "Gu": ([4, -1, -1, 1, 0, -4, 1, 1, -1, 0], False, False),
          "Hu": ([5, 0, 0, -1, 1, -5, 0, 0, 1, -1], False, False)})


def chiral_tetrahedral() -> Atoms:
    points = orbit(tetrahedral_rotations(), [0.3, 0.7, 1.9])
    return Atoms(f"C{len(points)}", positions=points)


@pytest.mark.parametrize("case", [C2V, C3V, TD, D2H, D6H, OH, D3H, IH, "T"],
                         ids=["C2v", "C3v", "Td", "D2h", "D6h", "Oh", "D3h", "Ih", "T"])
def test_character_table_matches_cotton(case: tuple | str) -> None:
    if case == "T":
        case = (chiral_tetrahedral(), 12, [np.eye(3), rot([1, 1, 1], 120), rot([1, 1, 1], 240), rot(Z, 180)], {
            "A": ([1, 1, 1, 1], False, True), "E": ([2, -1, -1, 2], False, True), "T": ([3, 0, 0, -1], True, True)})
    atoms, order, classes, expected = case
    group = mol.point_group(atoms)
    table = group.table
    assert group.n_operations == order
    assert sorted(table.labels) == sorted(expected)
    standard = group.standard_operations
    for k, representative in enumerate(classes):
        hits = [g for g in range(order) if np.allclose(standard[g], representative, atol=1e-8)]
        assert len(hits) == 1, f"class {k} of {group.name} not found among the operations"
        for label, (characters, ir, raman) in expected.items():
            assert table.characters[table.index(label), hits[0]] == pytest.approx(characters[k], abs=1e-9), (label, k)
    for label, (_, ir, raman) in expected.items():
        assert table.is_ir_active(label) is ir and table.is_raman_active(label) is raman, label


@pytest.mark.parametrize("name, atoms", [("Dinfh", molecule("CO2")), ("Cinfv", molecule("HCN"))])
def test_linear_groups_match_cotton_with_generic_angles(name: str, atoms: Atoms) -> None:
    """C_inf_v and D_inf_h (Cotton): chi(C(phi)) = 2 cos(Lambda phi); sigma_v: +-1 or 0; for
    D_inf_h also i, S(phi) = sigma_h C(phi) and C2' (perpendicular), checked at every rotation
    angle of the finite subgroup (45, 90, 135, 180 degrees)."""
    group = mol.point_group(atoms)
    assert group.name == name and group.is_linear
    axis = group.axes[2]
    assert np.allclose(np.abs(np.cross(atoms.positions[1] - atoms.positions[0], axis)), 0, atol=1e-9)
    lam = {"Sigma": 0, "Pi": 1, "Delta": 2, "Phi": 3}
    table = group.table
    standard = group.standard_operations
    expected_labels = ({"Sigma+", "Sigma-", "Pi", "Delta", "Phi"} if name == "Cinfv" else
                       {f"{s}_{p}{sign}" for s in ["Sigma"] for p in "gu" for sign in "+-"}
                       | {f"{s}_{p}" for s in ["Pi", "Delta", "Phi"] for p in "gu"})
    assert set(table.labels) == expected_labels
    for label in table.labels:
        kind = label.split("_")[0].rstrip("+-")
        parity = 1 if "_g" in label or name == "Cinfv" else -1
        row = table.characters[table.index(label)]
        minus = label.endswith("-")
        for degrees in (45, 90, 135, 180):
            phi = np.radians(degrees)
            chi_rot = 1.0 if lam[kind] == 0 else 2 * np.cos(lam[kind] * phi)
            g = next(g for g in range(group.n_operations) if np.allclose(standard[g], rot(Z, degrees)))
            assert row[g] == pytest.approx(chi_rot, abs=1e-9)
            sigma_v = next(g for g in range(group.n_operations) if np.allclose(standard[g], refl(Y)))
            assert row[sigma_v] == pytest.approx(0 if lam[kind] else (-1 if minus else 1), abs=1e-9)
            if name == "Dinfh":
                s_phi = next(g for g in range(group.n_operations) if np.allclose(standard[g], improper(Z, degrees)))
                # S(phi) = i C(phi + pi): chi = parity * chi(C(phi + pi))
                chi_s = parity * (1.0 if lam[kind] == 0 else 2 * np.cos(lam[kind] * (phi + np.pi)))
                assert row[s_phi] == pytest.approx(chi_s, abs=1e-9)
                inversion = next(g for g in range(group.n_operations) if np.allclose(standard[g], INV))
                assert row[inversion] == pytest.approx(parity * row[0])
                c2 = next(g for g in range(group.n_operations) if np.allclose(standard[g], rot(X, 180)))
                assert row[c2] == pytest.approx(0 if lam[kind] else parity * (-1 if minus else 1), abs=1e-9)
    ir = {"Dinfh": {"Sigma_u+", "Pi_u"}, "Cinfv": {"Sigma+", "Pi"}}[name]
    raman = {"Dinfh": {"Sigma_g+", "Pi_g", "Delta_g"}, "Cinfv": {"Sigma+", "Pi", "Delta"}}[name]
    assert {label for label in table.labels if table.is_ir_active(label)} == ir
    assert {label for label in table.labels if table.is_raman_active(label)} == raman


def orbit(operations: list[np.ndarray], point: list[float]) -> np.ndarray:
    out: list[np.ndarray] = []
    for r in operations:
        v = r @ np.asarray(point, float)
        if not any(np.allclose(v, w) for w in out):
            out.append(v)
    return np.array(out)


def tetrahedral_rotations() -> list[np.ndarray]:
    """The 12 rotations of T: cyclic permutation matrices times diagonal sign matrices of det +1."""
    perms = [np.eye(3)[list(c)] for c in [(0, 1, 2), (1, 2, 0), (2, 0, 1)]]
    return [p @ np.diag(s) for p in perms for s in itertools.product((1, -1), repeat=3) if np.prod(s) > 0]


def group_molecules() -> list[tuple[str, Atoms, float]]:
    t_points = orbit(tetrahedral_rotations(), [0.3, 0.7, 1.9])
    th_points = orbit(tetrahedral_rotations() + [-r for r in tetrahedral_rotations()], [0.0, 1.0, 1.6])
    return [
        ("C1", molecule("CH3CH2OH")[:-1], 0.01), ("Cs", molecule("CH3OH"), 0.01), ("C2", molecule("H2O2"), 0.01),
        ("C2h", molecule("trans-butane"), 0.01), ("D3h", molecule("BF3"), 0.01), ("D3d", molecule("C2H6"), 0.01),
        ("D2d", molecule("C3H4_D2d"), 0.01), ("C3v", molecule("CH3Cl"), 0.01), ("T", Atoms(f"C{len(t_points)}", t_points), 0.01),
        ("Th", Atoms(f"C{len(th_points)}", th_points), 0.01), ("Oh", octahedron(), 0.01),
        ("Ih", molecule("C60"), 0.05), ("Cinfv", molecule("HCN"), 0.01),
    ]


@pytest.mark.parametrize("name, atoms, tolerance", group_molecules(), ids=[g[0] for g in group_molecules()])
def test_group_found_and_its_table_is_orthogonal(name: str, atoms: Atoms, tolerance: float) -> None:
    """The group of textbook molecules (Herzberg; Cotton) and the great orthogonality theorem:
    sum_R chi_i(R) chi_j(R) = 0 for i != j; sum of squared dimensions = order (a real E made of
    a complex pair counts 2 and has sum_R chi^2 = 2h)."""
    group = mol.point_group(atoms, tolerance)
    assert group.name == name
    chi = group.table.characters
    gram = chi @ chi.T / group.n_operations
    assert np.allclose(gram - np.diag(np.diag(gram)), 0, atol=1e-9)
    assert set(np.round(np.diag(gram), 9)) <= {1.0, 2.0}
    if not group.is_linear:
        assert np.sum(chi[:, 0] ** 2 / np.diag(gram)) == pytest.approx(group.n_operations)
    # every operation is orthogonal and maps the molecule onto itself with its permutation
    x = atoms.positions - group.center
    numbers = atoms.numbers
    for r, perm in zip(group.operations, group.permutations):
        assert np.allclose(r @ r.T, np.eye(3), atol=1e-9)
        assert np.all(numbers[perm] == numbers)
        assert np.abs(x @ r.T - x[perm]).max() <= 3 * tolerance
    assert group.symmetry_number == {"C1": 1, "Cs": 1, "C2": 2, "C2h": 2, "D3h": 6, "D3d": 6, "D2d": 4, "C3v": 3,
                                     "T": 12, "Th": 12, "Oh": 24, "Ih": 60, "Cinfv": 1}[name]


def test_symmetry_numbers_of_every_family() -> None:
    """Rotational symmetry numbers (e.g. McQuarrie, "Statistical Mechanics", table 8-?; the
    standard list in the brief: Cn, Cnv, Cnh: n; Dn, Dnd, Dnh: 2n; S2n: n; T: 12; O: 24; I: 60)."""
    expected = {"C1": 1, "Ci": 1, "Cs": 1, "C2": 2, "C3v": 3, "C4h": 4, "D2": 4, "D2d": 4, "D3h": 6, "D6h": 12,
                "S4": 2, "S6": 3, "T": 12, "Td": 12, "Th": 12, "O": 24, "Oh": 24, "I": 60, "Ih": 60,
                "Cinfv": 1, "Dinfh": 2}
    assert {name: mol.symmetry_number(name) for name in expected} == expected
    with pytest.raises(ValueError, match="point-group symbol"):
        mol.symmetry_number("X3")


# ------------------------------------------------------------------ oracles: species of the fundamentals
def test_co2_species(analyses: dict) -> None:
    """CO2 (Herzberg): bend Pi_u (667, twice), symmetric stretch Sigma_g+ (1333), antisymmetric
    stretch Sigma_u+ (2349); the model keeps that order."""
    a = analyses["CO2"]
    assert a.point_group.name == "Dinfh"
    assert a.species == ("Pi_u", "Pi_u", "Sigma_g+", "Sigma_u+")


def test_h2o_species_in_the_standard_orientation(analyses: dict) -> None:
    """H2O (Herzberg; CCCBDB): bend A1 (1595), symmetric stretch A1 (3657), antisymmetric stretch
    B2 (3756), molecule in the yz plane (Mulliken 1955)."""
    a = analyses["H2O"]
    assert a.point_group.name == "C2v"
    assert a.species == ("A1", "A1", "B2")
    x_axis = a.point_group.axes[0]
    assert np.allclose((a.system.positions - a.point_group.center) @ x_axis, 0, atol=1e-12)  # in yz


def test_nh3_and_ch4_species(analyses: dict) -> None:
    """NH3 (C3v): nu2 A1 950, nu4 E 1627, nu1 A1 3337, nu3 E 3444. CH4 (Td): nu4 T2 1306,
    nu2 E 1534, nu1 A1 2917, nu3 T2 3019 (Herzberg; CCCBDB). The models keep these orders."""
    assert analyses["NH3"].point_group.name == "C3v"
    assert analyses["NH3"].species == ("A1", "E", "E", "A1", "E", "E")
    assert analyses["CH4"].point_group.name == "Td"
    assert analyses["CH4"].species == ("T2",) * 3 + ("E",) * 2 + ("A1",) + ("T2",) * 3


def test_c2h4_species_count(analyses: dict) -> None:
    """C2H4 (D2h, 12 fundamentals; Shimanouchi NSRDS-NBS 39 / NIST CCCBDB, axes x along C=C,
    z perpendicular to the plane): 3 Ag + Au + 2 B1g + B1u + B2g + 2 B2u + 2 B3u."""
    a = analyses["C2H4"]
    assert a.point_group.name == "D2h"
    assert Counter(a.species) == {"Ag": 3, "Au": 1, "B1g": 2, "B1u": 1, "B2g": 1, "B2u": 2, "B3u": 2}
    positions = a.system.positions - a.point_group.center
    assert np.allclose(positions @ a.point_group.axes[2], 0, atol=1e-9)                  # z normal to the plane
    carbons = positions[a.system.masses > 10]
    assert abs(abs((carbons[1] - carbons[0]) @ a.point_group.axes[0]) - np.linalg.norm(carbons[1] - carbons[0])) < 1e-9


def test_benzene_species_count(analyses: dict) -> None:
    """C6H6 (D6h; Herzberg, Wilson-Decius-Cross): 30 modes in 20 fundamentals,
    2A1g + A2g + 2B2g + E1g + 4E2g + A2u + 2B1u + 2B2u + 3E1u + 2E2u."""
    a = analyses["C6H6"]
    assert a.point_group.name == "D6h" and a.n_vibrations == 30
    modes = Counter(a.species)
    fundamentals = {label: count // (2 if label.startswith("E") else 1) for label, count in modes.items()}
    assert fundamentals == {"A1g": 2, "A2g": 1, "B2g": 2, "E1g": 1, "E2g": 4, "A2u": 1, "B1u": 2, "B2u": 2,
                            "E1u": 3, "E2u": 2}
    assert sum(fundamentals.values()) == 20


# ------------------------------------------------------------------ invariances
@pytest.mark.parametrize("name", ["NH3", "CH4", "C6H6", "CO2"])
def test_rotation_inside_degenerate_subspaces_keeps_labels(name: str, analyses: dict) -> None:
    a = analyses[name]
    vib = a.vibrations
    shapes = np.array(a.modes.shapes[:, vib])
    omega = np.asarray(a.modes.omega[vib])
    rng = np.random.default_rng(3)
    for group in a.modes.degenerate_groups(1e-6):
        members = [int(np.flatnonzero(vib == k)[0]) for k in group if k in vib]
        q, _ = np.linalg.qr(rng.normal(size=(len(members), len(members))))
        shapes[:, members] = shapes[:, members] @ q
    assert mol.mode_species(a.point_group, shapes, omega) == a.species


@pytest.mark.parametrize("name, torsion", [("NH3", None), ("CH4", None), ("C2H4", 0.3), ("C6H6", 0.3)])
def test_random_orientation_and_atom_order_give_same_group_and_labels(name: str, torsion: float | None,
                                                                      analyses: dict) -> None:
    atoms = molecule(name)
    rng = np.random.default_rng(11)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))
    order = rng.permutation(len(atoms))
    moved = Atoms(np.array(atoms.get_chemical_symbols())[order].tolist(),
                  positions=atoms.positions[order] @ q.T + rng.normal(size=3))
    kwargs = {} if torsion is None else {"torsion": torsion}
    a = mol.vibrational_analysis(mol.from_atoms(moved, **kwargs))
    assert a.point_group.name == analyses[name].point_group.name
    assert a.species == analyses[name].species
    assert mol.point_group(moved).name == a.point_group.name      # ASE Atoms input too


# ------------------------------------------------------------------ tolerance
def test_distorted_molecule_lower_group_at_tight_tolerance() -> None:
    """NH3 with one H moved 0.02 Angstrom along the C3 axis keeps only the mirror through it."""
    atoms = molecule("NH3")
    atoms.positions[1, 2] += 0.02
    assert mol.point_group(atoms, tolerance=0.001).name == "Cs"
    assert mol.point_group(atoms, tolerance=0.1).name == "C3v"
    system = mol.from_atoms(atoms)
    a = mol.vibrational_analysis(system)
    loose = mol.point_group(system, 0.1)
    assert loose.deviation > 0.001
    labels = mol.mode_species(loose, a.modes.shapes[:, a.vibrations], a.modes.omega[a.vibrations])
    assert labels == ("A1", "E", "E", "A1", "E", "E")          # the split E pairs keep their parent label
    assert set(mol.point_group(system, 0.001).table.labels) == {"A'", "A''"}


@pytest.mark.parametrize("tolerance, error", [(0.0, ValueError), (-0.01, ValueError), (float("nan"), ValueError),
                                              ("0.1", TypeError)])
def test_tolerance_must_be_positive(tolerance: object, error: type) -> None:
    with pytest.raises(error, match="tolerance"):
        mol.point_group(molecule("H2O"), tolerance=tolerance)  # type: ignore[arg-type]


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(TypeError, match="ase.Atoms or a vibra System"):
        mol.point_group(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="two or more atoms"):
        mol.point_group(Atoms("He"))
    with pytest.raises(ValueError, match="dim=1"):
        mol.point_group(mol.co2(dims=1))
    group = mol.point_group(molecule("H2O"))
    with pytest.raises(ValueError, match="9 rows"):
        mol.mode_species(group, np.zeros((6, 1)), [1.0])
    with pytest.raises(ValueError, match="omega has 2 entries for 1 modes"):
        mol.mode_species(group, np.zeros((9, 1)), [1.0, 2.0])
    with pytest.raises(ValueError, match="not a species of C2v"):
        group.table.index("E")


def test_isotopes_lower_the_symmetry() -> None:
    """HDO is Cs, not C2v: atoms of different mass are not equivalent."""
    atoms = molecule("H2O")
    atoms.set_masses([15.999, 2.014, 1.008])
    assert mol.point_group(atoms).name == "Cs"
    assert mol.point_group(mol.substitute_isotopes(mol.h2o(), {1: "D"})).name == "Cs"


def test_results_are_frozen() -> None:
    group = mol.point_group(molecule("NH3"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        group.name = "C1"  # type: ignore[misc]
    for array in (group.operations, group.permutations, group.table.characters, group.table.ir_active):
        assert not array.flags.writeable


# ------------------------------------------------------------------ selection rules vs intensities
@pytest.mark.parametrize("name", ["CO2", "H2O", "NH3", "CH4", "C2H4", "C6H6"])
def test_symmetry_selection_rules_match_intensity_based_activity(name: str, analyses: dict) -> None:
    """IR activity by symmetry (species transforms like x, y, z) equals the point-charge
    dipole-derivative activity of vibra.spectra.ir_spectrum; Raman activity by symmetry
    (quadratic forms) equals the bond-polarisability activity of raman_spectrum."""
    a = analyses[name]
    system = a.system
    symbols = mol.symbols_from_masses(system.masses)
    bonds = mol.bonds_from_distances(system.positions, symbols)
    ir = ir_spectrum(system, a, charges=electronegativity_charges(symbols, bonds))
    raman = raman_spectrum(system, a, bonds=bonds)
    table = a.point_group.table
    assert ir.active(1e-6).tolist() == [table.is_ir_active(s) for s in a.species]
    assert raman.active(1e-6).tolist() == [table.is_raman_active(s) for s in a.species]


def test_accidental_degeneracy_gets_each_species_once() -> None:
    """Two stretches of H2O (A1 and B2) made degenerate and mixed by 30 degrees: the set reduces
    to A1 + B2 (a sum, not one species), so each species is given once, to the mode with the
    larger projection on it; mixed by 60 degrees the two labels swap."""
    a = mol.vibrational_analysis(mol.h2o())
    shapes = np.array(a.modes.shapes[:, a.vibrations])
    omega = np.array(a.modes.omega[a.vibrations])
    omega[2] = omega[1]
    for degrees, expected in ((30, ("A1", "A1", "B2")), (60, ("A1", "B2", "A1"))):
        c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
        mixed = shapes.copy()
        mixed[:, 1], mixed[:, 2] = c * shapes[:, 1] + s * shapes[:, 2], -s * shapes[:, 1] + c * shapes[:, 2]
        assert mol.mode_species(a.point_group, mixed, omega) == expected
