"""`vibra.assembly.refuse_wrapped`: networks with long springs are built, wrapped supercells refused.

The bug: `System.from_springs` refused the ANM of ubiquitin at cutoffs of 30 Å and more, and a
12-site random cloud at cutoff 12, as "wrapped around a periodic box": its first rule (a spring
longer than half the extent of the sites along it and than twice the median spring) also holds
for the longest springs of any network whose cutoff nears its size (a complete graph's longest
spring is 2-3.5 times its median). The rule now asks a third mark, which no network chosen by
distance has: at each of its two sites, the spring passes a nearer site that site is not joined to.

Truth from outside the code: ProDy's ANM (its Hessian and eigenvalues on the same coordinates),
the pairs within the cutoff counted by scipy's `pdist`, supercells built by hand with springs by
minimum image (scipy's periodic k-d tree), and the rule as the docstring states it, transcribed
here as an O(n^2) loop over all pairs of sites.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist

from vibra import System, networks
from vibra.assembly import WRAPPED_SPRING_RATIO, refuse_wrapped

ROOT = Path(__file__).resolve().parent.parent
PDB = ROOT / "networks" / "ubiquitin" / "1ubi.pdb"
FCC = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]])


def inverse_square(i: np.ndarray, j: np.ndarray, distance: np.ndarray) -> np.ndarray:
    return 1.0 / distance**2


def supercell(basis: np.ndarray, n: int, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions of n x n x n unit cubes holding `basis`, the pairs within `radius` by minimum
    image, and the supercell's (cubic) cell."""
    cells = np.array(list(itertools.product(range(n), repeat=3)), dtype=float)
    positions = (cells[:, None, :] + basis[None, :, :]).reshape(-1, 3)
    pairs = np.array(sorted(cKDTree(positions, boxsize=float(n)).query_pairs(radius)))
    return positions, pairs, n * np.eye(3)


# ---------------------------------------------------------------------- the bug: long springs built
@pytest.mark.parametrize("gamma", [1.0, inverse_square], ids=["gamma-1", "inverse-square"])
def test_the_anm_of_ubiquitin_builds_at_every_cutoff_from_7_to_40(gamma: object) -> None:
    positions = networks.from_pdb(PDB).positions
    distances = pdist(positions)
    for cutoff in range(7, 41):  # 40 Å joins 2,841 of the 2,850 pairs: nearly a complete graph
        system = networks.anm(positions, cutoff=float(cutoff), gamma=gamma)  # type: ignore[arg-type]
        assert system.n_dof == 3 * 76
        assert system.coupling.shape[0] == int((distances <= cutoff).sum())


def test_ubiquitin_at_cutoff_30_has_prodys_anm_frequencies() -> None:
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    positions = networks.from_pdb(PDB).positions
    system = networks.anm(positions, cutoff=30.0, gamma=1.0)
    reference = prody.ANM("1ubi")
    reference.buildHessian(positions, cutoff=30.0, gamma=1.0)
    np.testing.assert_allclose(system.hessian().toarray(), reference.getHessian(), rtol=0, atol=1e-12 * 76 * 30)
    reference.calcModes(n_modes=20)
    omega = system.modes(n_modes=26).omega  # unit masses: omega^2 are the Hessian's eigenvalues
    assert np.all(np.abs(omega[:6]) ** 2 < 1e-8 * reference.getEigvals()[0])  # 6 rigid-body modes
    np.testing.assert_allclose(omega[6:] ** 2, reference.getEigvals(), rtol=1e-8)


def test_a_random_cloud_at_a_cutoff_near_its_size_has_prodys_anm() -> None:
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    positions = np.random.default_rng(1).normal(size=(12, 3)) * 4  # the docstrings' cloud, seed 1
    system = networks.anm(positions, cutoff=12.0)  # refused before the fix (springs[46])
    reference = prody.ANM("cloud")
    reference.buildHessian(positions, cutoff=12.0)
    reference.calcModes(n_modes=None, zeros=True)
    expected = reference.getEigvals()  # 7 zero modes: a site on 2 springs turns freely about them
    omega2 = np.sign(system.modes().omega) * system.modes().omega ** 2
    np.testing.assert_allclose(omega2, expected, rtol=1e-8, atol=1e-12 * expected.max())


@pytest.mark.parametrize("name", ["rod", "two-blobs", "nearest-6", "plane"])
def test_networks_chosen_by_distance_keep_their_long_springs(name: str) -> None:
    rng = np.random.default_rng(7)
    if name == "rod":        # complete graph on a rod: the longest spring ~3.4 times the median
        positions = rng.normal(size=(40, 3)) * [30.0, 1.0, 1.0]
        pairs = np.array(list(itertools.combinations(range(40), 2)))
    elif name == "two-blobs":  # 30 and 5 sites 50 apart, every pair joined (a cutoff past their distance)
        positions = np.r_[rng.normal(size=(30, 3)), rng.normal(size=(5, 3)) + [50.0, 0.0, 0.0]]
        pairs = np.array(list(itertools.combinations(range(35), 2)))
    elif name == "nearest-6":  # each site to its 6 nearest, in a cloud with a few far sites
        positions = np.r_[rng.normal(size=(60, 3)), rng.normal(size=(4, 3)) * 40.0]
        _, nearest = cKDTree(positions).query(positions, k=7)
        pairs = np.unique(np.sort(np.c_[np.repeat(np.arange(64), 6), nearest[:, 1:].ravel()], axis=1), axis=0)
    else:                    # 2-D sites on a 40 x 3 strip, within a cutoff of 35
        positions = rng.uniform(0.0, 1.0, size=(30, 2)) * [40.0, 3.0]
        i, j = np.nonzero(np.triu(np.linalg.norm(positions[:, None] - positions[None], axis=2) < 35.0, k=1))
        pairs = np.c_[i, j]
    lengths = np.linalg.norm(positions[pairs[:, 1]] - positions[pairs[:, 0]], axis=1)
    assert lengths.max() > WRAPPED_SPRING_RATIO * np.median(lengths)  # the first rule would refuse it
    System.from_springs(positions, 1.0, pairs, 1.0)


# ---------------------------------------------------------------------- what the check is for
@pytest.mark.parametrize(("basis", "n", "radius"), [
    (FCC, 2, 0.8), (FCC, 3, 0.8), (FCC, 4, 0.8),      # nearest neighbours at 0.707, second at 1
    (FCC, 5, 1.1),                                     # first and second neighbours
    (np.r_[FCC, FCC + 0.25], 3, 0.5),                  # diamond: nearest at 0.433
], ids=["fcc-2", "fcc-3", "fcc-4", "fcc-5-second", "diamond-3"])
def test_a_supercell_joined_by_minimum_image_is_refused_without_its_cell(basis: np.ndarray, n: int,
                                                                          radius: float) -> None:
    positions, pairs, cell = supercell(basis, n, radius)
    with pytest.raises(ValueError, match=r"springs\[\d+\] joins sites \d+ and \d+ over .* past nearer sites that "
                                         r"neither end is joined to: it looks wrapped around a periodic box.*cell="):
        System.from_springs(positions, 1.0, pairs, 1.0)
    System.from_springs(positions, 1.0, pairs, 1.0, cell=cell)


def test_a_long_tether_with_every_mark_is_refused_and_goes_in_as_a_block() -> None:
    # a zig-zag chain of 20 sites with a spring from one end to the other: the documented limit
    positions = np.c_[np.arange(20.0), 0.5 * (np.arange(20) % 2), np.zeros(20)]
    chain = np.c_[np.arange(19), np.arange(1, 20)]
    with pytest.raises(ValueError, match=r"springs\[19\] joins sites 0 and 19 .*looks wrapped"):
        System.from_springs(positions, 1.0, np.r_[chain, [[0, 19]]], 1.0)
    e = (positions[19] - positions[0]) / np.linalg.norm(positions[19] - positions[0])
    tether = np.block([[np.outer(e, e), -np.outer(e, e)], [-np.outer(e, e), np.outer(e, e)]])  # k e e^T
    with_block = System.from_springs(positions, 1.0, chain, 1.0, blocks=[([0, 19], tether)])
    expected = System.from_springs(positions, 1.0, chain, 1.0).hessian().toarray()
    dofs = np.r_[0:3, 57:60]
    expected[np.ix_(dofs, dofs)] += tether
    np.testing.assert_allclose(with_block.hessian().toarray(), expected, atol=1e-15)


def marked(positions: np.ndarray, pairs: np.ndarray) -> list[int]:
    """The springs that have the docstring's three marks, by brute force over all sites."""
    bond = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    length = np.linalg.norm(bond, axis=1)
    joined = {frozenset(map(int, p)) for p in pairs}
    distance = np.linalg.norm(positions[:, None] - positions[None], axis=2)
    found = []
    for s, (i, j) in enumerate(pairs):
        nearer = length[s] * (1.0 - 1e-9)
        skips = [any(k != a and distance[a, k] < nearer and frozenset((a, k)) not in joined
                     for k in range(len(positions))) for a in (i, j)]
        along = positions @ (bond[s] / length[s])
        if (length[s] > WRAPPED_SPRING_RATIO * np.median(length) and all(skips)
                and length[s] > 0.5 * np.ptp(along) * (1.0 + 1e-9)):
            found.append(s)
    return found


def test_the_refusal_is_exactly_the_three_marks_on_random_networks() -> None:
    rng = np.random.default_rng(11)
    refused = 0
    for _ in range(150):
        n = int(rng.integers(3, 16))
        positions = rng.normal(size=(n, int(rng.integers(2, 4))))
        every = np.array(list(itertools.combinations(range(n), 2)))
        pairs = every[rng.choice(len(every), int(rng.integers(2, len(every) + 1)), replace=False)]
        pairs = np.r_[pairs, pairs[:2, ::-1]]  # a spring given twice, reversed, joins one partner
        expected = marked(positions, pairs)
        bond = positions[pairs[:, 1]] - positions[pairs[:, 0]]
        if expected:
            refused += 1
            with pytest.raises(ValueError, match=rf"^springs\[{expected[0]}\] "):
                refuse_wrapped(bond, positions, pairs)
        else:
            refuse_wrapped(bond, positions, pairs)
    assert 10 < refused < 140  # both outcomes are exercised
