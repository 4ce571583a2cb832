"""Tests of vibra/networks/models.py: ANM and GNM against ProDy on its shipped test proteins.

Truth comes from ProDy (Hessian / Kirchhoff assembly, calcModes, calcSqFlucts, its own PDB
and mmCIF readers), from numpy (pseudo-inverses, eigenvalue counts, Pearson's r) and from
rigid-body mechanics (zero-mode counts); never from vibra's own output.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import prody
import pytest
import scipy.constants
from scipy.spatial.distance import pdist, squareform

import vibra
from vibra import networks
from vibra.networks import pdb

prody.confProDy(verbosity="none")

DATA = Path(prody.__file__).parent / "tests" / "datafiles"
#: C-alpha counts 76, 345 (with alternate locations), 436 (1,308 dofs: dense path) and 730
#: (2,190 dofs: the sparse shift-invert path).
PROTEINS = ["pdb1ubi.pdb", "1pwc.pdb", "pdb3enl.pdb", "pdb3hsy.pdb"]


def _prody_calpha(name: str) -> prody.AtomGroup:
    parse = prody.parseMMCIF if name.endswith(".cif") else prody.parsePDB
    return parse(str(DATA / name)).select("calpha")


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) / np.asarray(b) - 1.0)))


@pytest.fixture(scope="module", params=PROTEINS)
def protein(request: pytest.FixtureRequest) -> tuple[networks.Structure, prody.AtomGroup]:
    return networks.from_pdb(DATA / request.param), _prody_calpha(request.param)


# ---------------------------------------------------------------------- reader
@pytest.mark.parametrize("name", ["pdb1ubi.pdb", "1pwc.pdb", "pdb3mht.pdb", "pdb1ejg.pdb", "pdb2k39_ca.pdb",
                                  "mmcif_3o21.cif"])
def test_from_pdb_matches_prody_calpha(name: str) -> None:
    """Same C-alpha atoms, coordinates and B-factors as ProDy's reader ("calpha").

    1pwc and 1ejg have alternate locations (the first, A, is kept), 3mht a ligand (SAH) with
    an atom named CA that is no amino acid, 2k39_ca many models (the first is read), and
    3o21 is mmCIF.
    """
    structure = networks.from_pdb(DATA / name)
    reference = _prody_calpha(name)
    assert structure.n_sites == reference.numAtoms()
    np.testing.assert_allclose(structure.positions, reference.getCoords(), rtol=0, atol=1e-6)
    np.testing.assert_allclose(structure.b_factors, reference.getBetas(), rtol=0, atol=1e-6)
    assert structure.labels[0] == f"{reference.getChids()[0]}:{reference.getResnames()[0]}" \
        f"{reference.getResnums()[0]}:CA"


def test_from_pdb_all_atoms_match_prody() -> None:
    """selection="all": every atom of the first model, first alternate location, as ProDy."""
    structure = networks.from_pdb(str(DATA / "pdb1ejg.pdb"), selection="all")
    reference = prody.parsePDB(str(DATA / "pdb1ejg.pdb"))
    assert structure.selection == "all"
    assert structure.n_sites == reference.numAtoms()
    np.testing.assert_allclose(structure.positions, reference.getCoords(), atol=1e-6)
    np.testing.assert_allclose(structure.b_factors, reference.getBetas(), atol=1e-6)


# ---------------------------------------------------------------------- ANM against ProDy
def _both_models(protein: tuple[networks.Structure, prody.AtomGroup], kind: str
                 ) -> tuple[prody.ANM | prody.GNM, vibra.System, networks.Fluctuations]:
    """ProDy's model (20 modes) and vibra's with the same cutoff and gamma = 1."""
    structure, reference = protein
    if kind == "anm":
        model, system = prody.ANM(), networks.anm(structure.positions, cutoff=15.0)
        model.buildHessian(reference.getCoords(), cutoff=15.0, gamma=1.0)
    else:  # ProDy's GNM cutoff defaults to 10 Å; the classic 7.3 Å is given to both
        model, system = prody.GNM(), networks.gnm(structure.positions, cutoff=7.3)
        model.buildKirchhoff(reference.getCoords(), cutoff=7.3, gamma=1.0)
    model.calcModes(n_modes=20)
    return model, system, networks.fluctuations(system, n_modes=20)


@pytest.fixture(scope="module")
def anm_pair(protein: tuple[networks.Structure, prody.AtomGroup]
             ) -> tuple[prody.ANM, vibra.System, networks.Fluctuations]:
    """ProDy's ANM and vibra's, built once per protein."""
    return _both_models(protein, "anm")  # type: ignore[return-value]


@pytest.fixture(scope="module")
def gnm_pair(protein: tuple[networks.Structure, prody.AtomGroup]
             ) -> tuple[prody.GNM, vibra.System, networks.Fluctuations]:
    """ProDy's GNM and vibra's, built once per protein."""
    return _both_models(protein, "gnm")  # type: ignore[return-value]


def test_anm_hessian_is_prodys(anm_pair: tuple[prody.ANM, vibra.System, networks.Fluctuations]) -> None:
    model, system, _ = anm_pair
    K = system.hessian().toarray()
    np.testing.assert_allclose(K, model.getHessian(), rtol=0, atol=1e-12 * np.abs(K).max())


def test_anm_eigenvalues_match_prody(anm_pair: tuple[prody.ANM, vibra.System, networks.Fluctuations]) -> None:
    """The 20 lowest non-rigid eigenvalues to 1e-7 relative; 6 rigid modes skipped."""
    model, _, result = anm_pair
    assert result.n_rigid == 6 and not result.complete
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7


def test_anm_square_fluctuations_match_prody(anm_pair: tuple[prody.ANM, vibra.System, networks.Fluctuations]
                                             ) -> None:
    """Square fluctuations of the 20 lowest non-rigid modes to 1e-6 relative (prody.calcSqFlucts)."""
    model, _, result = anm_pair
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


def test_anm_high_accuracy_path_matches_prody() -> None:
    """The spring-factor ("high") path gives ProDy's eigenvalues too (1ubi)."""
    structure = networks.from_pdb(DATA / "pdb1ubi.pdb")
    model = prody.ANM()
    model.buildHessian(structure.positions)
    model.calcModes(n_modes=20)
    result = networks.fluctuations(networks.anm(structure.positions), accuracy="high")
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


def test_anm_all_modes_match_prody() -> None:
    """n_modes=None sums every non-rigid mode (ProDy calcModes('all'))."""
    structure = networks.from_pdb(DATA / "pdb1ubi.pdb")
    model = prody.ANM()
    model.buildHessian(structure.positions)
    model.calcModes(n_modes="all")
    result = networks.fluctuations(networks.anm(structure.positions), n_modes=None)
    assert result.complete and result.eigenvalues.shape == (3 * 76 - 6,)
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


def test_anm_per_pair_gamma_matches_prody() -> None:
    """Stiffness per pair: gamma = 1/d^2 as a function and as an array, against ProDy's gamma(dist2, i, j)."""
    structure = networks.from_pdb(DATA / "pdb1ubi.pdb")
    model = prody.ANM()
    model.buildHessian(structure.positions, cutoff=13.0, gamma=lambda dist2, i, j: 10.0 / dist2)
    model.calcModes(n_modes=20)
    system = networks.anm(structure.positions, cutoff=13.0, gamma=lambda i, j, d: 10.0 / d**2)
    np.testing.assert_allclose(system.hessian().toarray(), model.getHessian(), atol=1e-13)
    _, distances = networks.contact_pairs(structure.positions, 13.0)
    same = networks.anm(structure.positions, cutoff=13.0, gamma=10.0 / distances**2)
    np.testing.assert_array_equal(same.hessian().toarray(), system.hessian().toarray())
    result = networks.fluctuations(system)
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


def test_contact_pairs_are_all_pairs_within_cutoff() -> None:
    """k-d tree contacts equal the brute-force distance matrix's (d <= cutoff), sorted."""
    positions = networks.from_pdb(DATA / "pdb1ubi.pdb").positions
    pairs, distances = networks.contact_pairs(positions, 7.3)
    full = squareform(pdist(positions))
    i, j = np.nonzero(np.triu(full <= 7.3, k=1))
    np.testing.assert_array_equal(pairs, np.column_stack([i, j]))
    np.testing.assert_allclose(distances, full[i, j], rtol=1e-14)


# ---------------------------------------------------------------------- GNM against ProDy
def test_gnm_kirchhoff_modes_and_fluctuations_match_prody(
        gnm_pair: tuple[prody.GNM, vibra.System, networks.Fluctuations],
        protein: tuple[networks.Structure, prody.AtomGroup]) -> None:
    model, system, result = gnm_pair
    assert system.dim == 1 and system.n_dof == protein[0].n_sites
    np.testing.assert_array_equal(system.hessian().toarray(), model.getKirchhoff())
    assert result.n_rigid == 1
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


def test_gnm_all_modes_match_prody() -> None:
    structure = networks.from_pdb(DATA / "1pwc.pdb")
    model = prody.GNM()
    model.buildKirchhoff(structure.positions, cutoff=7.3)
    model.calcModes(n_modes="all")
    result = networks.fluctuations(networks.gnm(structure.positions), n_modes=None)
    assert result.complete
    assert _relative(result.eigenvalues, model.getEigvals()) < 1e-7
    assert _relative(result.square, prody.calcSqFlucts(model)) < 1e-6


# ---------------------------------------------------------------------- B-factors
@pytest.mark.parametrize("pair", ["anm_pair", "gnm_pair"])
def test_b_factor_correlation_reproduces_prodys(pair: str, protein: tuple[networks.Structure, prody.AtomGroup],
                                                request: pytest.FixtureRequest) -> None:
    """r(predicted, file B-factors) equals numpy's r of ProDy's calcSqFlucts and ProDy's betas to 1e-6."""
    structure, reference = protein
    model, _, result = request.getfixturevalue(pair)
    expected = np.corrcoef(prody.calcSqFlucts(model), reference.getBetas())[0, 1]
    assert abs(result.correlation(structure.b_factors) - expected) < 1e-6
    assert abs(networks.b_factor_correlation(result.b_factors, structure.b_factors) - expected) < 1e-6


def test_predicted_b_factors_closed_form() -> None:
    square = np.array([0.5, 1.0, 2.0])
    np.testing.assert_allclose(networks.predicted_b_factors(square), 8 * np.pi**2 / 3 * square, rtol=1e-15)
    np.testing.assert_allclose(networks.predicted_b_factors(square, dofs_per_site=1), 8 * np.pi**2 * square,
                               rtol=1e-15)


def test_b_factor_correlation_is_pearsons() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.random(50), rng.random(50)
    assert networks.b_factor_correlation(a, b) == pytest.approx(np.corrcoef(a, b)[0, 1], rel=1e-13)


def test_temperature_gives_kT_in_kcal_per_mol() -> None:
    """temperature=T uses kT = k_B N_A T / 4184 J/kcal; <u^2> scales with kT."""
    system = networks.anm(networks.from_pdb(DATA / "pdb1ubi.pdb").positions)
    unit = networks.fluctuations(system)
    warm = networks.fluctuations(system, temperature=300.0)
    kT = scipy.constants.k * scipy.constants.Avogadro * 300.0 / 4184.0
    assert warm.kT == pytest.approx(kT, rel=1e-12)
    np.testing.assert_allclose(warm.square, kT * unit.square, rtol=1e-12)
    np.testing.assert_allclose(networks.fluctuations(system, kT=2.5).square, 2.5 * unit.square, rtol=1e-12)


def test_fluctuations_with_masses_are_the_mass_weighted_pseudo_inverse() -> None:
    """Sum over all non-rigid modes = kT diag(M^-1/2 pinv(K~) M^-1/2), per site (numpy truth)."""
    rng = np.random.default_rng(7)
    positions = rng.random((12, 3)) * 12.0
    masses = rng.uniform(0.5, 3.0, 12)
    system = networks.anm(positions, cutoff=9.0, masses=masses)
    K = system.hessian().toarray()
    root = 1.0 / np.sqrt(np.repeat(masses, 3))
    covariance = root[:, None] * np.linalg.pinv(root[:, None] * K * root[None, :], rcond=1e-10) * root[None, :]
    expected = 0.7 * np.diag(covariance).reshape(12, 3).sum(axis=1)
    result = networks.fluctuations(system, n_modes=None, kT=0.7)
    np.testing.assert_allclose(result.square, expected, rtol=1e-9)
    modes = system.modes()
    np.testing.assert_allclose(networks.square_fluctuations(system, modes, kT=0.7), expected, rtol=1e-9)


# ---------------------------------------------------------------------- rigid modes
def _zero_eigenvalues(system: vibra.System) -> int:
    K = system.hessian().toarray()
    values = np.linalg.eigvalsh(K)
    return int((values < 1e-9 * values.max()).sum())


def test_n_modes_beyond_the_system_sums_every_mode() -> None:
    """n_modes=20 on a 3-site network (3 non-rigid modes) sums them all, as ProDy does."""
    result = networks.fluctuations(networks.anm(POINTS), n_modes=20)
    assert result.complete and result.n_rigid == 6 and result.eigenvalues.shape == (3,)


def test_rigid_cluster_has_exactly_six_zero_modes() -> None:
    """Every pair within the cutoff: a rigid body, 6 zero modes (and numpy agrees)."""
    positions = np.random.default_rng(1).random((10, 3)) * 5.0
    system = networks.anm(positions, cutoff=15.0)
    result = networks.fluctuations(system, n_modes=None)
    assert result.n_rigid == 6 == _zero_eigenvalues(system)
    assert result.eigenvalues.shape == (30 - 6,)


def test_two_sites_have_five_zero_modes() -> None:
    """A linear rigid body (two sites, one spring): 3 translations + 2 rotations."""
    system = networks.anm([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0]], cutoff=5.0)
    result = networks.fluctuations(system, n_modes=None)
    assert result.n_rigid == 5 == _zero_eigenvalues(system)
    assert result.eigenvalues == pytest.approx([2.0])  # k (1/m1 + 1/m2)


def test_collinear_sites_have_2n_plus_1_zero_modes() -> None:
    """N > 2 collinear sites: central springs give no transverse stiffness (rank N - 1)."""
    positions = np.column_stack([np.arange(5.0) * 3.8, np.zeros(5), np.zeros(5)])
    system = networks.anm(positions, cutoff=15.0)
    result = networks.fluctuations(system, n_modes=None)
    assert result.n_rigid == 2 * 5 + 1 == _zero_eigenvalues(system)


def test_gnm_connected_network_has_one_zero_mode_and_disconnected_two() -> None:
    positions = np.random.default_rng(2).random((8, 3)) * 4.0
    assert networks.fluctuations(networks.gnm(positions), n_modes=None).n_rigid == 1
    apart = np.vstack([positions, positions + 100.0])
    result = networks.fluctuations(networks.gnm(apart), n_modes=None)
    assert result.n_rigid == 2 == _zero_eigenvalues(networks.gnm(apart))


def test_disconnected_anm_skips_twelve_rigid_modes_and_still_gives_n_modes() -> None:
    """Two rigid clusters: 12 zero modes; n_modes=20 still sums 20 non-rigid ones (numpy truth)."""
    cluster = np.random.default_rng(4).random((9, 3)) * 5.0
    system = networks.anm(np.vstack([cluster, cluster + 100.0]), cutoff=15.0)
    result = networks.fluctuations(system, n_modes=20)
    assert result.n_rigid == 12 == _zero_eigenvalues(system)
    values = np.linalg.eigvalsh(system.hessian().toarray())
    np.testing.assert_allclose(result.eigenvalues, values[12:32], rtol=1e-9)


def test_frozen_sites_remove_the_zero_modes() -> None:
    """Three frozen non-collinear sites pin the body: no zero mode, <u^2> = 0 there, K_ff^-1 elsewhere."""
    positions = np.random.default_rng(5).random((10, 3)) * 5.0
    system = networks.anm(positions, cutoff=15.0).freeze(sites=[0, 1, 2])
    result = networks.fluctuations(system, n_modes=None)
    assert result.n_rigid == 0 and result.complete
    np.testing.assert_array_equal(result.square[:3], 0.0)
    expected = np.diag(np.linalg.inv(system.hessian().toarray())).reshape(7, 3).sum(axis=1)
    np.testing.assert_allclose(result.square[3:], expected, rtol=1e-9)


# ---------------------------------------------------------------------- results are frozen
def test_results_are_frozen() -> None:
    structure = networks.from_pdb(DATA / "pdb1ubi.pdb")
    result = networks.fluctuations(networks.gnm(structure.positions))
    for value, field, array in ((structure, "path", structure.positions), (result, "kT", result.square)):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, field, 1)
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1.0
    assert not result.b_factors.flags.writeable and not result.eigenvalues.flags.writeable
    assert not structure.b_factors.flags.writeable


# ---------------------------------------------------------------------- validation
POINTS = [[0.0, 0.0, 0.0], [3.8, 0.0, 0.0], [1.9, 3.3, 0.0]]


@pytest.mark.parametrize("builder", [networks.anm, networks.gnm])
@pytest.mark.parametrize("cutoff", [0.0, -2.0, float("nan")])
def test_cutoff_must_be_positive(builder, cutoff: float) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match="cutoff"):
        builder(POINTS, cutoff=cutoff)


@pytest.mark.parametrize("builder", [networks.anm, networks.gnm])
def test_gamma_must_be_positive(builder) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=r"gamma\[0\] is 0.0; every spring constant must be positive"):
        builder(POINTS, gamma=0.0)
    with pytest.raises(ValueError, match=r"gamma\[1\] is -1.0"):
        builder(POINTS, gamma=[1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match=r"gamma\(i, j, distance\)\[2\] is -3.0"):
        builder(POINTS, gamma=lambda i, j, d: np.array([1.0, 1.0, -3.0]))
    with pytest.raises(ValueError, match=r"one spring constant per contact pair \(3 within cutoff"):
        builder(POINTS, gamma=[1.0, 1.0])


def test_positions_are_checked() -> None:
    with pytest.raises(ValueError, match=r"positions must be 2-D"):
        networks.anm([0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match=r"dim 1, 2 or 3, got shape \(2, 4\)"):
        networks.gnm(np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"\(n_sites, 3\) \(or \(n_sites, 2\)\) for an ANM"):
        networks.anm([[0.0], [1.0]])
    with pytest.raises(ValueError, match="at least 2 sites"):
        networks.anm([[0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"positions\[1,2\] is nan"):
        networks.anm([[0.0, 0.0, 0.0], [1.0, 0.0, np.nan]])
    with pytest.raises(ValueError, match=r"positions\[0\] and positions\[2\] coincide"):
        networks.anm([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])


def test_no_contact_within_cutoff() -> None:
    with pytest.raises(ValueError, match=r"no pair of sites lies within cutoff=2.0"):
        networks.gnm(POINTS, cutoff=2.0)


def test_masses_are_checked() -> None:
    with pytest.raises(ValueError, match=r"masses\[1\] is -1.0"):
        networks.anm(POINTS, masses=[1.0, -1.0, 1.0])


def test_from_pdb_path_checks(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="path must be a str or os.PathLike, got int"):
        networks.from_pdb(3)  # type: ignore[arg-type]
    with pytest.raises(FileNotFoundError, match="missing.pdb: no such file"):
        networks.from_pdb(tmp_path / "missing.pdb")
    with pytest.raises(ValueError, match="not a regular file"):
        networks.from_pdb(tmp_path)
    with pytest.raises(ValueError, match=r"selection is 'CB'; expected one of 'CA', 'protein', 'all'"):
        networks.from_pdb(DATA / "pdb1ubi.pdb", selection="CB")  # type: ignore[arg-type]


def test_from_pdb_size_cap(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pdb, "MAX_FILE_BYTES", 1000)  # where the reader reads it
    with pytest.raises(ValueError, match=r"pdb1ubi.pdb: 77355 bytes, more than the 1000"):
        networks.from_pdb(DATA / "pdb1ubi.pdb")


def test_from_pdb_without_calpha_names_the_file(tmp_path: Path) -> None:
    """ProDy's one-atom file (an N) has no C-alpha; a ligand whose atom is named CA is none either."""
    with pytest.raises(ValueError, match=r"pdb1ejg_oneatom.pdb: no C-alpha atoms"):
        networks.from_pdb(DATA / "pdb1ejg_oneatom.pdb")
    ligand = tmp_path / "ligand.pdb"
    ligand.write_text(
        "HETATM    1  CA  SAH A 328     -19.755  30.360  82.298  1.00  3.53           C  \n"
        "HETATM    2  CA   CA A 401       1.000   2.000   3.000  1.00 10.00          CA  \nEND\n")
    with pytest.raises(ValueError, match=r"ligand.pdb: no C-alpha atoms"):
        networks.from_pdb(ligand)
    assert networks.from_pdb(ligand, selection="all").n_sites == 2


def test_from_pdb_empty_file(tmp_path: Path) -> None:
    empty = tmp_path / "empty.pdb"
    empty.write_text("REMARK nothing here\nEND\n")
    with pytest.raises(ValueError, match=r"empty.pdb: no (C-alpha )?atoms"):
        networks.from_pdb(empty, selection="all")
    with pytest.raises(ValueError, match=r"empty.pdb: no (C-alpha )?atoms"):
        networks.from_pdb(str(empty))


def test_from_pdb_unreadable_mmcif(tmp_path: Path) -> None:
    broken = tmp_path / "broken.cif"
    broken.write_text("data_x\nloop_\n_atom_site.id\n_atom_site.Cartn_x\n1\n")
    with pytest.raises(ValueError, match=r"broken.cif"):
        networks.from_pdb(broken)


def test_fluctuation_argument_checks() -> None:
    system = networks.anm(POINTS)
    modes = system.modes()
    with pytest.raises(ValueError, match=r"kT is 0.0; a thermal energy must be positive"):
        networks.square_fluctuations(system, modes, kT=0.0)
    with pytest.raises(ValueError, match=r"temperature is -1.0"):
        networks.fluctuations(system, temperature=-1.0)
    with pytest.raises(ValueError, match="give kT or temperature, not both"):
        networks.fluctuations(system, kT=1.0, temperature=300.0)
    with pytest.raises(ValueError, match=r"rigid_rtol is 0.0"):
        networks.square_fluctuations(system, modes, rigid_rtol=0.0)
    with pytest.raises(ValueError, match=r"n_modes is 0; expected 1 <= n_modes"):
        networks.fluctuations(system, n_modes=0)
    with pytest.raises(TypeError, match=r"n_modes must be an int, got float"):
        networks.fluctuations(system, n_modes=2.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="modes have no shapes"):
        networks.square_fluctuations(system, system.modes(vectors=False))
    with pytest.raises(ValueError, match="modes have 6 dofs but the system has 9 free dofs"):
        networks.square_fluctuations(system, networks.anm(POINTS[:2]).modes())
    with pytest.raises(TypeError, match="system must be a vibra System, got list"):
        networks.fluctuations([1, 2])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="modes must be a vibra Modes, got str"):
        networks.square_fluctuations(system, "modes")  # type: ignore[arg-type]


def test_unstable_mode_is_refused() -> None:
    system = vibra.System.from_hessian([[0.0], [1.0]], 1.0, [[2.0, 0.0], [0.0, -1.0]], units="dimensionless")
    with pytest.warns(RuntimeWarning):
        modes = system.modes()
    with pytest.raises(ValueError, match=r"mode 0 is unstable \(omega\^2 = -1\)"):
        networks.square_fluctuations(system, modes)


def test_b_factor_checks() -> None:
    with pytest.raises(ValueError, match="predicted has 3 sites but experimental has 2"):
        networks.b_factor_correlation([1.0, 2.0, 3.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="at least 2 sites, got 1"):
        networks.b_factor_correlation([1.0], [2.0])
    with pytest.raises(ValueError, match="experimental is constant"):
        networks.b_factor_correlation([1.0, 2.0, 3.0], [4.0, 4.0, 4.0])
    with pytest.raises(ValueError, match=r"square\[1\] is -1.0; every mean-square fluctuation must be >= 0"):
        networks.predicted_b_factors([1.0, -1.0])
    with pytest.raises(ValueError, match=r"dofs_per_site is 4; expected 1 <= dofs_per_site <= 3"):
        networks.predicted_b_factors([1.0], dofs_per_site=4)


def test_module_imports_without_prody_or_biopython() -> None:
    """`import vibra.networks` pulls in neither ProDy nor Biopython (checked in a fresh interpreter)."""
    import subprocess
    import sys

    code = ("import sys, vibra.networks; "
            "print(any(m.split('.')[0] in ('prody', 'Bio') for m in sys.modules))")
    env = dict(os.environ, PYTHONPATH=str(Path(networks.__file__).parents[1]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == "False"


# ---------------------------------------------------------------------- issue 34: structure files that are whole
# Truth: where the test itself cut the file (line numbers counted here), and ProDy's own test files,
# which are whole and must never be refused.
PRODY_PDB = sorted(path.name for path in DATA.glob("*.pdb"))


@pytest.mark.parametrize("name", PRODY_PDB)
def test_prody_files_are_never_refused_as_cut(name: str) -> None:
    import warnings

    text = (DATA / name).read_text(encoding="latin-1")
    assert pdb.check_pdb_text(text, name) == ()
    if (DATA / name).stat().st_size < 3_000_000:
        with warnings.catch_warnings():
            warnings.simplefilter("error", networks.StructureWarning)
            try:
                networks.from_pdb(DATA / name)
            except ValueError as error:  # files without C-alpha atoms, said as such
                assert "no C-alpha atoms" in str(error)


def _atom_line_starts(text: str) -> list[int]:
    starts, offset = [], 0
    for line in text.splitlines(keepends=True):
        if line.startswith("ATOM"):
            starts.append(offset)
        offset += len(line)
    return starts


@pytest.mark.parametrize("fraction", [1 / 3, 2 / 3])
@pytest.mark.parametrize("column", [10, 40, 60])
def test_a_pdb_cut_mid_line_is_refused_naming_the_line(fraction: float, column: int, tmp_path: Path) -> None:
    # issue 34: cut at two thirds, 47 of 76 C-alpha atoms were read without a word
    text = (DATA / "pdb1ubi.pdb").read_text()
    starts = _atom_line_starts(text)
    cut = starts[int(fraction * len(starts))] + column
    path = tmp_path / "cut.pdb"
    path.write_text(text[:cut])
    line = text[:cut].count("\n") + 1
    width = len(text[cut - column:cut].rstrip())  # the cut line without trailing blanks
    with pytest.raises(ValueError, match=rf"cut.pdb: line {line}: the last ATOM record stops at column {width} "
                                         "without a line end"):
        networks.from_pdb(path)


def test_a_pdb_cut_between_lines_warns_naming_the_line(tmp_path: Path) -> None:
    text = (DATA / "pdb1ubi.pdb").read_text()
    cut = _atom_line_starts(text)[400]
    path = tmp_path / "cut.pdb"
    path.write_text(text[:cut])
    line = text[:cut].count("\n")
    with pytest.warns(networks.StructureWarning, match=rf"cut.pdb: line {line}: the file ends without an END record"):
        networks.from_pdb(path)


def test_a_model_without_its_endmdl_is_refused(tmp_path: Path) -> None:
    lines = (DATA / "pdb2k39_truncated.pdb").read_text().splitlines(keepends=True)
    endmdl = [i for i, line in enumerate(lines) if line.startswith("ENDMDL")]
    model = [i for i, line in enumerate(lines) if line.startswith("MODEL")]
    path = tmp_path / "models.pdb"
    path.write_text("".join(lines[:endmdl[1] - 5]))  # the second model cut before its end
    with pytest.raises(ValueError, match=rf"models.pdb: line {model[1] + 1}: this MODEL has no ENDMDL"):
        networks.from_pdb(path)
    path.write_text("".join(lines[:endmdl[0]] + lines[model[1]:]))  # a MODEL inside the first one
    with pytest.raises(ValueError, match=rf"line {endmdl[0] + 1}: MODEL before the ENDMDL of the MODEL at line "
                                         rf"{model[0] + 1}"):
        networks.from_pdb(path)


def test_more_calpha_than_seqres_warns(tmp_path: Path) -> None:
    path = tmp_path / "seq.pdb"
    path.write_text(
        "SEQRES   1 A    1  GLY\n"
        "ATOM      1  CA  GLY A   1       0.000   0.000   0.000  1.00 10.00           C  \n"
        "ATOM      2  CA  GLY A   2       3.800   0.000   0.000  1.00 10.00           C  \nEND\n")
    with pytest.warns(networks.StructureWarning, match=r"seq.pdb: chain A: 2 C-alpha atoms, more than the 1 residues"):
        networks.from_pdb(path)


# ---------------------------------------------------------------------- damaged mmCIF files
def _damaged_cif(kind: str) -> str:
    """ProDy's 3o21 mmCIF damaged the ways a transfer or an editor damages a file."""
    text = (DATA / "mmcif_3o21.cif").read_text()
    lines = text.splitlines(keepends=True)
    rows = [i for i, line in enumerate(lines) if line.startswith("ATOM")]
    if kind == "row_missing_fields":
        lines[rows[10]] = " ".join(lines[rows[10]].split()[:8]) + "\n"
    elif kind == "cut":
        return "".join(lines[:rows[50]]) + lines[rows[50]][:20]
    elif kind == "b_factor_unknown":  # Biopython reads B with float(): '?' fails there, naming no row
        fields = lines[rows[3]].split()
        fields[14] = "?"
        lines[rows[3]] = " ".join(fields) + "\n"
    elif kind == "coordinate":
        fields = lines[rows[5]].split()
        fields[10] = "abc"
        lines[rows[5]] = " ".join(fields) + "\n"
    elif kind == "no_atom_site":
        return "data_x\n_cell.length_a 10\n"
    elif kind == "not_cif":
        return "hello world\n"
    return "".join(lines)


@pytest.mark.parametrize("kind, message", [
    ("row_missing_fields", r"the _atom_site loop's 21 columns hold 12792 to 12793 values: the file is cut, or a row "
                           r"misses a field \(row 11 is the first whose Cartn_x is not a number\)"),
    ("b_factor_unknown", r"_atom_site row 4 \(atom id 4\): B_iso_or_equiv is '\?', not a number"),
    ("cut", r"columns hold 50 to 51 values: the file is cut"),
    ("coordinate", r"_atom_site row 6 \(atom id 6\): Cartn_x is 'abc', not a number"),
    ("no_atom_site", r"no _atom_site loop"),
    ("not_cif", r"not an mmCIF file .*expected a 'data_' block"),
])
def test_a_damaged_mmcif_is_refused_in_one_line(tmp_path: Path, kind: str, message: str) -> None:
    broken = tmp_path / f"{kind}.cif"
    broken.write_text(_damaged_cif(kind))
    with pytest.raises(ValueError, match=message) as caught:
        networks.from_pdb(broken)
    assert str(caught.value).startswith(str(broken)) and "\n" not in str(caught.value)


def test_two_copies_numbered_alike_are_named_not_silently_halved(tmp_path) -> None:
    """A file holding two copies of a chain with the same chain letter and residue numbers (as
    ProDy's pdb6fpj_Bb_fixed_solv_ions.pdb: 379 of its 758 C-alpha atoms dropped by Biopython
    without a word): a StructureWarning names the first repeated residue and the count."""
    import warnings as _warnings

    from vibra.networks import StructureWarning

    record = "ATOM  {serial:5d}  CA  {name} A{number:4d}    {x:8.3f}{y:8.3f}{z:8.3f}  1.00 10.00           C\n"
    names = ["GLY", "ALA", "SER"]
    lines = [record.format(serial=i + 1, name=names[i % 3], number=i % 3 + 1, x=3.8 * (i % 3), y=10.0 * (i // 3), z=0.0)
             for i in range(6)]
    path = tmp_path / "twice.pdb"
    path.write_text("".join(lines) + "END\n")
    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        structure = networks.from_pdb(path)
    messages = [str(w.message) for w in caught if issubclass(w.category, StructureWarning)]
    assert structure.n_sites == 3
    assert any("3 C-alpha records repeat a residue read before (the first: A:GLY1)" in m for m in messages), messages
    single = tmp_path / "once.pdb"
    single.write_text("".join(lines[:3]) + "END\n")
    with _warnings.catch_warnings():
        _warnings.simplefilter("error", StructureWarning)
        assert networks.from_pdb(single).n_sites == 3
