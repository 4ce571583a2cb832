"""vibra.crystals refuses bad input with one line that names it (issue 30, item 7)."""

from __future__ import annotations

import numpy as np
import pytest

from vibra import crystals
from vibra.crystals import Crystal

CUBE = np.eye(3)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"cell": [[1, 0, 0], [0, 1, 0], [1, 1, 0]]}, r"cell is singular: det = .* \(they lie in one plane\)"),
    ({"cell": [[1, 0, 0], [0, 1, 0], [0, 0, 0]]}, r"cell is singular: lattice vector cell\[2\] is zero"),
    ({"cell": [[0, 1, 0], [1, 0, 0], [0, 0, 1]]}, r"cell is left-handed \(det = -1 < 0\).*left_handed=True"),
    ({"positions": [[0.0, 0, 0], [1.2, 0.5, 0.5]]}, r"positions\[1\] is outside the cell.*\[1.2, 0.5, 0.5\].*wrap=True"),
    ({"positions": [[0.0, 0, 0], [0.0, 0, 1e-9]]}, r"positions\[0\] and positions\[1\] overlap"),
    ({"positions": [[0.0, 0, 0], [0.5, 0.5, 0.999999999999]]}, None),  # on the face: wraps to 0, no error
    ({"masses": [1.0, -2.0]}, r"masses\[1\] is -2.0"),
    ({"masses": [1.0, 2.0, 3.0]}, r"masses must have 2 entries"),
])
def test_structure_checks_name_the_input(kwargs: dict, message: str | None) -> None:
    args = {"cell": CUBE, "positions": [[0.0, 0, 0], [0.5, 0.5, 0.5]], "masses": [1.0, 2.0]} | kwargs
    if message is None:
        Crystal.from_cell(**args)
        return
    with pytest.raises(ValueError, match=message):
        Crystal.from_cell(**args)


def test_declared_left_handed_cells_and_wrapping_are_accepted() -> None:
    crystal = Crystal.from_cell([[0, 1, 0], [1, 0, 0], [0, 0, 1]], [[0.0, 0, 0]], 1.0, left_handed=True)
    assert np.linalg.det(crystal.cell) < 0
    wrapped = Crystal.from_cell(CUBE, [[1.25, -0.5, 0.0]], 1.0, wrap=True)
    np.testing.assert_allclose(wrapped.fractional, [[0.25, 0.5, 0.0]])
    # an overlap across the periodic boundary is still an overlap
    with pytest.raises(ValueError, match=r"overlap \(distance .* between periodic images\)"):
        Crystal.from_cell(CUBE, [[0.0, 0, 0], [1.0 - 1e-9, 0, 0]], 1.0, wrap=True)


def test_spring_and_phonon_inputs() -> None:
    bare = Crystal.from_cell(CUBE, [[0.0, 0, 0]], 1.0)
    with pytest.raises(ValueError, match=r"crystal 'crystal' has no force constants; attach some with vibra.crystals.springs"):
        bare.frequencies([[0, 0, 0]])
    with pytest.raises(ValueError, match=r"stiffness has 2 entries but the springs join 3 neighbour shells"):
        crystals.springs(bare, shells=3, stiffness=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"cutoff is 0.5; no two atoms are that close"):
        crystals.springs(bare, cutoff=0.5)
    with pytest.raises(ValueError, match=r"give cutoff or shells, not both"):
        crystals.springs(bare, cutoff=1.0, shells=1)
    with pytest.raises(ValueError, match=r"transverse\[0\] is -1.0"):
        crystals.springs(bare, shells=1, transverse=-1.0)
    molecule = Crystal.from_cell(CUBE * 10, [[0.0, 0, 0], [1.0, 0, 0]], 1.0, periodic=(False, False, False))
    with pytest.raises(ValueError, match=r"shells is 2, but the atoms of 'crystal' \(no periodic axis\) have only 1 "):
        crystals.springs(molecule, shells=2)
    crystal = crystals.springs(bare, cutoff=1.0)
    with pytest.raises(ValueError, match=r"qpoints must have shape \(n_q, 3\)"):
        crystal.frequencies([[0.0, 0.0]])
    with pytest.raises(ValueError, match=r"qpoints\[0, 1\] is nan|qpoints.*finite|qpoints.*nan"):
        crystal.frequencies([[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match=r"phase"):
        crystal.phonons([[0.0, 0.0, 0.0]], phase="atoms")
    with pytest.raises(ValueError, match=r"q must hold 3 fractional coordinates"):
        crystal.modes_at([0.0, 0.0])
    with pytest.raises(ValueError, match=r"direction is the zero vector"):
        crystals.group_velocities(crystal, [[0.1, 0, 0]], [0, 0, 0])


def test_builders_check_their_arguments() -> None:
    with pytest.raises(ValueError, match=r"a is -1.0; a lattice constant must be positive"):
        crystals.fcc(-1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"masses must have 2 entries \(one per atom of the diamond basis\), got 3"):
        crystals.diamond(1.0, [1.0, 2.0, 3.0], 1.0)
    with pytest.raises(ValueError, match=r"stiffness\[0\] is 0.0"):
        crystals.bcc(1.0, 1.0, 0.0)
