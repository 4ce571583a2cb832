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
  Brüschweiler's collectivity kappa of the same six: 0.05, 0.36, 0.08, 0.15, 0.34, 0.36.

The second network scene, networks/glua3-ntd (PDB 3O21 chain A, 374 C-alpha atoms, from
ProDy's test data), is a two-lobed clamshell whose three slowest modes move the lobes as
near-rigid bodies: kappa 0.63, 0.71, 0.56, 0.32, 0.35, 0.23 for the six slowest, B-factor
r = 0.555 (its README). Those figures are checked here against ProDy's own ANM of ProDy's own
copy of the entry, so the trimmed file, vibra's solver and vibra's analysis are all outside
the truth.
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

ROOT = Path(__file__).resolve().parents[2]
UBIQUITIN = ROOT / "networks" / "ubiquitin"
PDB = UBIQUITIN / "1ubi.pdb"
GLUA3 = ROOT / "networks" / "glua3-ntd"
PRODY_3O21 = Path(prody.__file__).parent / "tests" / "datafiles" / "pdb3o21.pdb"  # the whole entry, 4 chains
#: The six slowest non-rigid modes' collectivity as networks/glua3-ntd/README.md states it (two
#: decimals) and the B-factor correlation (three).
GLUA3_KAPPA = (0.63, 0.71, 0.56, 0.32, 0.35, 0.23)
GLUA3_R = 0.555
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
    ('chains = "B"', r"system\.chains: .*no atoms in chain B; the model holds chain A$"),
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


def test_ubiquitins_collectivity_is_the_loops_figure_its_readme_states() -> None:
    # ProDy's calcCollectivity of its own ANM; the README's two decimals, to their rounding
    _, anm = prody_anm("calpha and resnum 1 to 71")
    kappa = [prody.calcCollectivity(anm[k]) for k in range(6)]
    np.testing.assert_allclose(kappa, [0.05, 0.36, 0.08, 0.15, 0.34, 0.36], atol=0.005)


# ---------------------------------------------------------------------- the second scene: a clamshell
@pytest.fixture(scope="module")
def glua3() -> tuple[object, object, object]:
    """ProDy's atoms (chain A of its own copy of 3O21) and its ANM (cutoff 15 Å, gamma 1, 20 modes),
    and vibra's modes of the bundled scene."""
    atoms = prody.parsePDB(str(PRODY_3O21)).select("calpha and chain A")
    anm = prody.ANM("3o21")
    anm.buildHessian(atoms, cutoff=15.0, gamma=1.0)
    anm.calcModes(20)
    scene = load_scene(GLUA3 / "glua3-ntd-anm.toml")
    return atoms, anm, build_system(scene).modes(26)


def test_the_trimmed_file_holds_chain_a_of_the_entry_as_prody_reads_it(glua3) -> None:
    atoms, _, _ = glua3
    structure = network_structure(load_scene(GLUA3 / "glua3-ntd-anm.toml"))
    assert structure.n_sites == atoms.numAtoms() == 374
    np.testing.assert_array_equal(structure.positions, atoms.getCoords())
    np.testing.assert_array_equal(structure.b_factors, atoms.getBetas())
    assert (GLUA3 / "3o21-chain-a-ca.pdb").stat().st_size < 40_000  # the entry is 1.1 MB


def test_the_clamshells_slow_modes_are_collective_as_its_readme_states(glua3) -> None:
    """kappa of ProDy's own six slowest modes is the README's figure to its rounding (0.005).

    The margin is the rounding alone: consecutive slow eigenvalues are >= 9 % apart (omega^2
    0.326, 0.435, 0.541, 0.973, 1.189, 1.307), so each mode's vector, and kappa with it, is
    fixed to ~1e-13 whatever the LAPACK; vibra's scene gives ProDy's kappa to 1e-8."""
    _, anm, modes = glua3
    kappa = np.array([prody.calcCollectivity(anm[k]) for k in range(6)])
    np.testing.assert_allclose(kappa, GLUA3_KAPPA, atol=0.005)
    assert (kappa > 0.3).sum() == 5 and (kappa[:3] > 0.55).all()
    np.testing.assert_allclose(networks.collectivity(modes)[:6], kappa, rtol=1e-8)
    gaps = anm.getEigvals()[1:6] / anm.getEigvals()[:5]
    assert gaps.min() > 1.09
    ubiquitin = networks.collectivity(networks.anm(networks.from_pdb(PDB, residues=(1, 71)).positions)
                                      .modes(n_modes=12))[:6]
    assert kappa[:3].min() > 1.5 * ubiquitin.max()  # 0.56 against ubiquitin's largest, 0.36


def test_the_clamshells_b_factors_correlate_as_its_readme_states(glua3) -> None:
    atoms, anm, modes = glua3
    r = np.corrcoef(prody.calcSqFlucts(anm), atoms.getBetas())[0, 1]
    assert r == pytest.approx(GLUA3_R, abs=5e-4)  # the stated figure, to its rounding
    structure = network_structure(load_scene(GLUA3 / "glua3-ntd-anm.toml"))
    fit = networks.fit_bfactors(modes, structure.b_factors)
    np.testing.assert_allclose(fit.predicted, prody.calcTempFactors(anm, atoms), rtol=1e-8)


def test_the_three_slowest_modes_move_two_lobes_as_rigid_bodies(glua3) -> None:
    """The README's hinge: ProDy's slowest GNM mode splits chain A by sign into two lobes
    (2-115 and 245-353 but residue 104, against the rest), and a least-squares fit of the 12 rigid-body
    motions of the two lobes (numpy, here) holds 94, 91 and 81 % of ProDy's three slowest ANM
    modes (stated to the percent: margin 0.005) and less than half of modes 4-6."""
    atoms, anm, _ = glua3
    gnm = prody.GNM("3o21")
    gnm.buildKirchhoff(atoms)
    gnm.calcModes(5)
    lobe = gnm[0].getEigvec() > 0
    numbers = atoms.getResnums()
    first = numbers[lobe if lobe[0] else ~lobe]
    assert sorted(set(first)) == [n for n in numbers if (n <= 115 or 245 <= n <= 353) and n != 104]
    coordinates = atoms.getCoords()
    basis = []
    for part in (lobe, ~lobe):
        centred = coordinates - coordinates[part].mean(axis=0)
        for axis in np.eye(3):
            shift = np.zeros_like(coordinates)
            shift[part] = axis
            turn = np.zeros_like(coordinates)
            turn[part] = np.cross(axis, centred[part])
            basis += [shift.ravel(), turn.ravel()]
    q, _ = np.linalg.qr(np.array(basis).T)
    vectors = anm.getEigvecs()[:, :6]
    held = ((q.T @ vectors) ** 2).sum(axis=0)
    np.testing.assert_allclose(held[:3], [0.94, 0.91, 0.81], atol=0.005)
    assert (held[3:] < 0.5).all()
