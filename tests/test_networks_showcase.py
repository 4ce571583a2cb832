"""The protein showcase (issue 48, item 1): network scenes choose their sites as `from_pdb` does,
B-factors are fitted one way (ProDy's) in the library and the report, and the bundled ubiquitin
scene draws the fold's motions rather than a flapping tail.

Truth from outside the code under test: ProDy 2.6 (its own ANM of the same C-alpha atoms and
cutoff, its ``calcTempFactors`` and ``calcSqFlucts``, its atom selections), and the
crystallographic B-factors of the PDB file 1UBI.

Measured on 1UBI (ANM, cutoff 15 Å, the six slowest non-rigid modes), for the record:

- all 76 residues: 78-93 % of each mode's squared amplitude lies on the tail Arg72-Gly76;
  participation ratios (1 / sum_i a_i^4, a_i^2 a residue's share, over the 76 residues)
  0.016, 0.018, 0.047, 0.021, 0.058, 0.055; 85-93 % of each mode on its 5 largest residues.
- residues 1-71: 0.022, 0.176, 0.034, 0.064, 0.162, 0.207 (of 71); 50-86 % on 5 residues.
  Trimming the tail does not make ubiquitin's slowest modes collective: they move to the
  least-packed loops (the beta1-beta2 hairpin Leu8-Gly10, the Ala46-Gly47 turn), where the
  crystal's B-factors are largest too. No cutoff from 8 to 20 Å nor stiffer backbone springs
  make all six collective while keeping 6 rigid-body modes and the B-factor correlation.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from vibra import networks
from vibra.pipeline.plan import build_system, validate
from vibra.pipeline.plan.analysis import network_fluctuations
from vibra.pipeline.plan.build import network_structure
from vibra.pipeline.scene import SceneError, load_scene

prody = pytest.importorskip("prody")
prody.confProDy(verbosity="none")

ROOT = Path(__file__).resolve().parent.parent
UBIQUITIN = ROOT / "networks" / "ubiquitin"
PDB = UBIQUITIN / "1ubi.pdb"
#: vibra's and ProDy's eigensolvers on the same Hessian agree to ~1e-14 in the fitted B-factors
#: (measured); 1e-9 leaves room for another LAPACK.
RTOL = 1e-9


def prody_anm(selection: str, n_modes: int = 20) -> tuple[object, object]:
    """ProDy's ANM (cutoff 15 Å, gamma 1) of the atoms of 1UBI that `selection` picks."""
    atoms = prody.parsePDB(str(PDB)).select(selection)
    anm = prody.ANM("1ubi")
    anm.buildHessian(atoms, cutoff=15.0, gamma=1.0)
    anm.calcModes(n_modes)
    return atoms, anm


def scene_file(folder: Path, system: str = "", compute: str = "[compute]\nn_modes = 26\n") -> Path:
    shutil.copy(PDB, folder / "1ubi.pdb")
    path = folder / "anm.toml"
    path.write_text(f'kind = "network"\n[system]\nbuilder = "anm"\npdb = "1ubi.pdb"\n{system}\n{compute}')
    return path


def residue_numbers(labels: tuple[str, ...]) -> np.ndarray:
    return np.array([int("".join(c for c in label.split(":")[1] if c.isdigit())) for label in labels])


def slow_shares(positions: np.ndarray, count: int = 6) -> np.ndarray:
    """(n_sites, count): each residue's share of the squared amplitude of the `count` slowest
    non-rigid ANM modes (cutoff 15 Å)."""
    modes = networks.anm(positions, cutoff=15.0).modes(n_modes=6 + count)
    moving = np.flatnonzero(~modes.zero_modes(1e-6))[:count]
    vectors = modes.vectors[:, moving].reshape(len(positions), 3, count)
    shares = (vectors**2).sum(axis=1)
    return shares / shares.sum(axis=0)


# ---------------------------------------------------------------------- one B-factor convention
def test_fitted_b_factors_equal_prodys_calc_temp_factors_on_its_own_anm() -> None:
    atoms, anm = prody_anm("calpha and resnum 1 to 71")
    structure = networks.from_pdb(PDB, residues=(1, 71))
    modes = networks.anm(structure.positions, cutoff=15.0).modes(n_modes=26)  # 6 rigid + ProDy's 20
    fit = networks.fit_bfactors(modes, structure.b_factors)
    assert fit.method == "sum"  # ProDy's convention is the default
    np.testing.assert_allclose(fit.predicted, prody.calcTempFactors(anm, atoms), rtol=RTOL)
    flucts, betas = prody.calcSqFlucts(anm), atoms.getBetas()
    squares = networks.fit_bfactors(modes, structure.b_factors, method="least_squares")
    np.testing.assert_allclose(squares.predicted, (flucts @ betas / (flucts @ flucts)) * flucts, rtol=RTOL)
    assert fit.correlation == pytest.approx(np.corrcoef(flucts, betas)[0, 1], abs=1e-9)
    assert fit.predicted.sum() == pytest.approx(betas.sum(), rel=1e-12)  # ProDy's: the same sum


def test_the_report_fits_b_factors_with_the_library_function() -> None:
    scene = load_scene(UBIQUITIN / "ubiquitin-anm.toml")
    system = build_system(scene)
    modes = system.modes(26)
    structure = network_structure(scene)
    network = network_fluctuations(structure, system, modes)
    library = networks.fit_bfactors(modes, structure.b_factors)
    assert network.fit.method == "sum" and network.fit.scale == library.scale
    np.testing.assert_array_equal(network.fit.predicted, library.predicted)
    atoms, anm = prody_anm("calpha and resnum 1 to 71")
    np.testing.assert_allclose(network.fit.predicted, prody.calcTempFactors(anm, atoms), rtol=1e-6)
    other = network_fluctuations(structure, system, modes, fit="least_squares")
    assert other.fit.method == "least_squares" and other.fit.scale < network.fit.scale
    with pytest.raises(ValueError, match="method is 'median'"):
        network_fluctuations(structure, system, modes, fit="median")


# ---------------------------------------------------------------------- scene keys of from_pdb
def test_scene_keys_select_the_sites_as_prody_does(tmp_path: Path) -> None:
    scene = load_scene(scene_file(tmp_path, 'chains = "A"\nresidues = [1, 71]\n'))
    atoms = prody.parsePDB(str(PDB)).select("calpha and chain A and resnum 1 to 71")
    structure = network_structure(scene)
    np.testing.assert_array_equal(structure.positions, atoms.getCoords())
    assert build_system(scene).n_dof == 3 * 71
    backbone = load_scene(scene_file(tmp_path, 'selection = ["N", "CA", "C"]\nresidues = [1, 71]\nchains = ["A"]\n'))
    atoms = prody.parsePDB(str(PDB)).select("name N CA C and resnum 1 to 71")
    np.testing.assert_array_equal(network_structure(backbone).positions, atoms.getCoords())
    every = load_scene(scene_file(tmp_path, 'selection = "protein"\nmodel = 1\n'))
    assert network_structure(every).n_sites == prody.parsePDB(str(PDB)).select("protein").numAtoms()


@pytest.mark.parametrize("system, message", [
    ('chains = "B"', r"system\.chains: .*no atoms in chain\(s\) B; the model holds chain\(s\) A$"),
    ("residues = [100, 200]", (r"system\.residues: .*no atoms in residues 100\.\.200; the model holds residues "
                               r"1\.\.76 \(chain A\)$")),
    ('selection = ["XX"]', r"system\.selection: .*no atoms named XX .*; they have atoms named C, CA, CB"),
    ("model = 2", r"system\.model: .*model is 2; the file has 1 model"),
    ('altloc = "B"', r"system\.altloc: .*altloc is 'B'; the model's alternate locations are none"),
], ids=["chain", "residues", "atom-names", "model", "altloc"])
def test_a_selection_that_finds_nothing_is_refused_at_its_key(tmp_path: Path, system: str, message: str) -> None:
    scene = load_scene(scene_file(tmp_path, system))
    with pytest.raises(SceneError, match=message) as caught:
        validate(scene)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("system, message", [
    ("residues = [71, 1]", r"system\.residues: is \[71, 1\]; expected \[first, last\] residue numbers"),
    ("residues = [1]", r"system\.residues: needs 2 values, got 1"),
    ('selection = "backbone"', r"system\.selection: is 'backbone'; expected \"CA\" .* or a list of atom names"),
    ('chains = ""', r"system\.chains: is ''; expected chain identifiers"),
    ('chains = ["A", " "]', r"system\.chains: \[1\] is ' '"),
    ('altloc = "AB"', r"system\.altloc: is 'AB'; expected one alternate-location character"),
    ("model = 0", r"system\.model: must be >= 1, got 0"),
    ('chain = "A"', r"system\.chain: unknown key; did you mean 'chains'\?"),
], ids=["reversed", "one-number", "selection", "empty-chain", "blank-chain", "altloc", "model", "typo"])
def test_malformed_selection_keys_are_refused_when_read(tmp_path: Path, system: str, message: str) -> None:
    with pytest.raises(SceneError, match=message):
        load_scene(scene_file(tmp_path, system))


# ---------------------------------------------------------------------- the bundled scene
def test_the_whole_chain_puts_the_slowest_modes_on_the_tail() -> None:
    # the issue, reproduced: residues 72-76 carry most of every one of the six slowest modes
    structure = networks.from_pdb(PDB)
    shares = slow_shares(structure.positions)
    tail = residue_numbers(structure.labels) >= 72
    assert (shares[tail].sum(axis=0) > 0.75).all()


def test_the_trimmed_scene_moves_the_loops_the_crystal_says_are_mobile() -> None:
    scene = load_scene(UBIQUITIN / "ubiquitin-anm.toml")
    structure = network_structure(scene)
    numbers = residue_numbers(structure.labels)
    assert numbers.min() == 1 and numbers.max() == 71 and structure.n_sites == 71
    shares = slow_shares(structure.positions)
    largest = {structure.labels[i].split(":")[1] for i in np.argmax(shares, axis=0)}
    # the beta1-beta2 hairpin and the Ala46-Gly47 turn, the fold's least-packed loops
    assert largest <= {"LEU8", "THR9", "GLY10", "GLY47"}
    # the slowest mode's largest motion is the residue with the crystal's largest B-factor
    assert np.argmax(shares[:, 0]) == np.argmax(structure.b_factors)
    assert structure.labels[int(np.argmax(structure.b_factors))] == "A:GLY10:CA"
    participation = 1.0 / (shares**2).sum(axis=0) / structure.n_sites  # measured: 0.02 to 0.21 (docstring)
    whole = networks.from_pdb(PDB)
    before = 1.0 / (slow_shares(whole.positions)**2).sum(axis=0) / whole.n_sites
    assert participation.mean() > 2.5 * before.mean()  # 0.111 against 0.036
