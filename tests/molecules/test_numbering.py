"""One numbering of vibrations (issue 48, item 6): Herzberg's, checked against Shimanouchi's tables.

Truth: the numbering of the observed fundamentals in T. Shimanouchi, *Tables of Molecular
Vibrational Frequencies*, NSRDS-NBS 39 (1972), which follows Herzberg (1945): for the 53
molecules of ASE's g2 collection in tests/data/shimanouchi_g2_fundamentals.csv, and for the
bundled molecule scenes the entries of `vibra.molecules.experimental` (CO2, H2O, D2O, CH4).

The species-by-number sequence does not depend on the force field (only on how many
vibrations each species has, which symmetry fixes), so it is compared exactly. Two labelling
conventions are not numbering: which axes carry B1, B2, B3 in C2v and D2h (Shimanouchi puts a
planar C2v molecule in the xz plane: H2O's antisymmetric stretch is his b1, our B2), so B
labels are compared up to a permutation of the axes; and a C2v molecule with both B1 and B2
vibrations is numbered by its own axes, so there only the counts are compared (his B1 block is
our B2 block or the same block).
"""

from __future__ import annotations

import csv
import itertools
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from vibra import molecules as mol
from vibra.molecules.numbering import herzberg_numbers
from vibra.pipeline.plan import build_system
from vibra.pipeline.plan.analysis import molecule_symmetry
from vibra.pipeline.plan.tables import frequency_lines, mode_names
from vibra.pipeline.scene import load_scene

DATA = Path(__file__).parents[1] / "data" / "shimanouchi_g2_fundamentals.csv"
ROOT = Path(__file__).parents[2]


def _species(text: str, primed_group: bool) -> str:
    """Shimanouchi's lower-case label in ours: a1 -> A1, f2 -> T2, Sigmag+ -> Sigma_g+, a'1 -> A1'.
    The transcription lost the double prime of a'' (a Cs molecule's a'' reads "a")."""
    linear = re.fullmatch(r"(Sigma|Pi)([gu]?)([+-]?)", text)
    if linear:
        return linear.group(1) + (f"_{linear.group(2)}" if linear.group(2) else "") + linear.group(3)
    letter, before, digit, after, parity = re.fullmatch(r"([abef])('*)(\d?)('*)([gu]?)", text).groups()
    primes = before + after or ("''" if primed_group else "")
    return {"f": "T"}.get(letter, letter.upper()) + digit + parity + primes


def _shimanouchi() -> dict[str, dict[int, str]]:
    """Molecule -> {Herzberg number: species} as Shimanouchi lists them."""
    rows = list(csv.DictReader(line for line in DATA.read_text().splitlines() if not line.startswith("#")))
    table: dict[str, list[dict[str, str]]] = {}
    for row in rows:
        table.setdefault(row["molecule"], []).append(row)
    out = {}
    for name, entries in table.items():
        primed = any("'" in row["species"] for row in entries)
        out[name] = {int(row["mode"][2:]): _species(row["species"], primed) for row in entries}
    return out


SHIMANOUCHI = _shimanouchi()


def _ours(name: str) -> tuple[str, dict[int, str]]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a soft-mode warning is not what is tested here
        analysis = mol.vibrational_analysis(mol.molecule(name))
    return analysis.point_group.name, dict(zip(analysis.numbers, analysis.species))


def _axes_relabelled(label: str, permutation: dict[str, str]) -> str:
    return re.sub(r"B(\d)", lambda m: "B" + permutation[m.group(1)], label)


@pytest.mark.parametrize("name", sorted(SHIMANOUCHI))
def test_numbering_names_the_g2_fundamentals_as_shimanouchi_does(name: str) -> None:
    group, ours = _ours(name)
    theirs = SHIMANOUCHI[name]
    both_b = group == "C2v" and {"B1", "B2"} <= set(ours.values())
    if both_b:  # numbered by each one's axes: the blocks agree up to the B1 <-> B2 swap
        counts = {label: sum(s == label for s in ours.values()) for label in ("A1", "A2", "B1", "B2")}
        listed = {label: sum(s == label for s in theirs.values()) for label in ("A1", "A2", "B1", "B2")}
        assert (counts["A1"], counts["A2"]) == (listed["A1"], listed["A2"]), (name, ours, theirs)
        assert {counts["B1"], counts["B2"]} == {listed["B1"], listed["B2"]}, (name, ours, theirs)
        return
    permutations = [dict(zip("123", p)) for p in itertools.permutations("123")] if group in ("C2v", "D2h") \
        else [{"1": "1", "2": "2", "3": "3"}]
    assert any(all(ours.get(k) == _axes_relabelled(label, p) for k, label in theirs.items()) for p in permutations), \
        (name, group, [ours.get(k) for k in sorted(theirs)], [theirs[k] for k in sorted(theirs)])


def test_the_axis_dependent_molecules_are_few() -> None:
    """The exception above covers only the C2v molecules with both B1 and B2 modes (9 of 53, counted)."""
    exempt = []
    for name in SHIMANOUCHI:
        group, ours = _ours(name)
        if group == "C2v" and {"B1", "B2"} <= set(ours.values()):
            exempt.append(name)
    assert len(exempt) == 9 and "H2O" not in exempt and "CH4" not in exempt, exempt


@pytest.mark.parametrize("scene", ["co2.toml", "co2-axial.toml", "h2o.toml", "d2o.toml", "ch4.toml"])
def test_bundled_scenes_name_each_vibration_as_its_observed_fundamental(scene: str) -> None:
    """The table's name, the renders' name and the observed fundamental's name of every mode agree."""
    loaded = load_scene(ROOT / "molecules" / scene)
    system = build_system(loaded)
    modes = system.modes(vectors=True)
    symmetry = molecule_symmetry(system, modes)
    names = mode_names(loaded, modes, symmetry, ascii=True)
    observed = [f for f in symmetry.experimental if f is not None]
    assert observed, scene
    for k, fundamental in enumerate(symmetry.experimental):
        if fundamental is not None:
            assert names[k] == fundamental.name and symmetry.species[k] == fundamental.species, (scene, k)
    lines = frequency_lines(loaded, modes, symmetry, ascii=True)
    rows = [line.split() for line in lines[1:] if line.split() and line.split()[0].startswith("nu")]
    assert all(row[0] == row[3] for row in rows), lines  # vibration and observed columns name the same nu
    assert [row[0] for row in rows] == sorted({row[0] for row in rows}, key=lambda n: int(n[2:]))  # nu1 first, once
    titled = mode_names(loaded, modes, symmetry, species=True)
    assert all(titled[k].startswith(names[k].replace("nu", "ν") + " (") for k in names), titled


def test_linear_triatomic_bend_is_nu2_even_when_the_model_lacks_it() -> None:
    # CO2 along its axis (no bend): Sigma_g+ is nu1 and Sigma_u+ nu3, as Shimanouchi names them
    assert herzberg_numbers(mol.point_group(mol.co2_atoms()).table.labels, ["", "Sigma_u+", "Sigma_g+"],
                            [0.0, 2349.0, 1333.0], linear=True, n_atoms=3) == (0, 3, 1)


def test_degenerate_sets_count_once_and_c1_falls_back_to_decreasing_frequency() -> None:
    numbers = herzberg_numbers(("A1", "A2", "E"), ["E", "E", "A1", "E", "E", ""], [900.0, 900.0, 3000.0, 1500.0,
                                                                                     1500.0, 0.0])
    assert numbers == (3, 3, 1, 2, 2, 0)
    rng = np.random.default_rng(48)
    values = rng.uniform(100.0, 3000.0, 7)
    c1 = herzberg_numbers(("A",), ["A"] * 7, values)
    assert [values[list(c1).index(n)] for n in range(1, 8)] == sorted(values, reverse=True)


def test_numbers_need_one_label_per_mode() -> None:
    with pytest.raises(ValueError, match=r"species has 2 labels but wavenumbers has 3"):
        herzberg_numbers(("A",), ["A", "A"], [1.0, 2.0, 3.0])
