"""System.from_springs(..., cell=) and the crystal's D(q) (issue 30, item 8 of the issue; item 6 of the brief).

Truth: Bloch's theorem. The Gamma-point modes of an n x n x n periodic supercell are the modes
of the crystal at the n^3 wave vectors commensurate with it, q = (i, j, k) / n; the supercell is
built here by hand (replicated positions, springs by minimum image), independently of the
crystal's force constants.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from vibra import System, crystals
from vibra.crystals import Crystal


def supercell_springs(crystal: Crystal, n: int, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Positions, masses, site pairs within `radius` by minimum image, and the supercell's cell."""
    cells = np.array(list(itertools.product(range(n), repeat=3)), dtype=float)
    positions = (cells[:, None, :] @ crystal.cell + crystal.positions[None, :, :]).reshape(-1, 3)
    masses = np.tile(crystal.masses, len(cells))
    big = n * crystal.cell
    delta = positions[None, :, :] - positions[:, None, :]
    frac = delta @ np.linalg.inv(big)
    delta = (frac - np.round(frac)) @ big
    distance = np.linalg.norm(delta, axis=2)
    i, j = np.nonzero(np.triu((distance > 0) & (distance < radius), k=1))
    return positions, masses, np.stack([i, j], axis=1), big


@pytest.mark.parametrize(("crystal", "radius"), [
    (crystals.fcc(1.0, 1.3, 0.7), 0.8),                         # nearest neighbours at 0.707
    (crystals.diamond(1.0, [1.0, 2.5], 1.1), 0.5),              # nearest neighbours at 0.433
], ids=["fcc", "diamond"])
def test_gamma_modes_of_a_supercell_are_the_crystal_on_the_commensurate_mesh(crystal: Crystal, radius: float) -> None:
    n = 3
    positions, masses, pairs, big = supercell_springs(crystal, n, radius)
    stiffness = crystal.springs.longitudinal[0] if crystal.springs is not None else np.nan
    system = System.from_springs(positions, masses, pairs, stiffness, cell=big)
    omega = system.modes(accuracy="fast").omega
    mesh = np.array(list(itertools.product(range(n), repeat=3)), dtype=float) / n
    expected = np.sort(crystal.frequencies(mesh).ravel())
    # both are LAPACK eigenvalues of O(1) matrices: absolute eps-level; the zero modes to sqrt(eps)
    np.testing.assert_allclose(np.sort(np.abs(omega)), np.sort(np.abs(expected)), atol=1e-7)
    assert np.sort(omega)[-1] == pytest.approx(np.abs(expected).max(), rel=1e-12)


def test_without_cell_a_wrapped_supercell_is_refused_naming_cell_and_crystals() -> None:
    crystal = crystals.fcc(1.0, 1.0, 1.0)
    positions, masses, pairs, big = supercell_springs(crystal, 4, 0.8)  # even n: X is on the mesh
    with pytest.raises(ValueError, match=r"springs\[\d+\] joins sites .* looks wrapped around a periodic box.*"
                                         r"cell=.*vibra.crystals"):
        System.from_springs(positions, masses, pairs, 1.0)
    # the wrong answer, had it been accepted: omega_max 3.32 where sqrt(8k/m) = 2.83
    system = System.from_springs(positions, masses, pairs, 1.0, cell=big)
    assert system.modes(accuracy="fast").omega.max() == pytest.approx(np.sqrt(8.0), rel=1e-12)


def test_a_cell_too_small_for_a_spring_names_the_size_needed() -> None:
    positions = [[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.5, 0.5]]
    with pytest.raises(ValueError, match=r"springs\[0\] joins sites 0 and 1 .* two of its periodic images are "
                                         r"equally near \(0.5\).*exceed twice it, 1.*supercell about 2 times larger"):
        System.from_springs(positions, 1.0, [[0, 1]], 1.0, cell=np.eye(2))
    with pytest.raises(ValueError, match=r"cell must be 2 x 2"):
        System.from_springs(positions, 1.0, [[0, 1]], 1.0, cell=np.eye(3))
    with pytest.raises(ValueError, match=r"cell is singular"):
        System.from_springs(positions, 1.0, [[0, 1]], 1.0, cell=[[1.0, 0.0], [2.0, 0.0]])


def test_legitimate_long_springs_are_kept() -> None:
    # a diatomic, an elastic network's tetrahedron, a 1-D ring: springs between the outermost sites
    System.from_springs([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0]], 1.0, [[0, 1]], 1.0)
    tetrahedron = [[0, 0, 0], [3.8, 0, 0], [1.9, 3.3, 0], [1.9, 1.1, 3.1]]
    System.from_springs(tetrahedron, 1.0, [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], 1.0)
    System.from_springs([0.0, 1.0, 2.0, 3.0], 1.0, [[0, 1], [1, 2], [2, 3], [3, 0]], 1.0)
