"""The internal coordinates of a valence force field, found from bonds and geometry.

Angles: every pair of bonds sharing an atom, except inside a three-membered ring (a triangle of
bonds is rigid in its plane); one within the linear tolerance of 180 degrees is a linear bend.
Torsions: along every torsion axis, a bond j-k or a straight chain j-c1-...-k through linear
two-bonded atoms (allene's C=C=C, 2-butyne's C-C#C-C), one dihedral i-j-k-l for each neighbour i
of j and l of k off the axis. Out-of-plane (wag) terms: at every atom with exactly three bonds
lying in the plane of its neighbours a, b, c (within the planar tolerance: the carbons of
ethylene, formaldehyde and benzene, boron in BF3, chlorine in ClF3), the improper dihedrals
(centre, a, b, c), (centre, b, c, a), (centre, c, a, b), each about an axis between two
neighbours (one whose neighbours are nearly in line through the centre, as the two axial
fluorines of T-shaped ClF3, is left out).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vibra._core.frozen import Frozen
from vibra.molecules.coordinates import bond_angle

__all__ = ["InternalTerms", "internal_terms", "PLANAR_TOLERANCE_DEG", "AXIS_ANGLE_MARGIN_DEG"]

#: A three-bonded atom within sin(PLANAR_TOLERANCE_DEG) times its mean bond length of the plane
#: of its neighbours is planar and gets out-of-plane terms (ammonia, 22 degrees, is not).
PLANAR_TOLERANCE_DEG = 10.0
#: An improper's axis runs between two neighbours whose angle at the centre is at least this
#: many degrees short of straight.
AXIS_ANGLE_MARGIN_DEG = 30.0


@dataclass(frozen=True, eq=False)
class InternalTerms(Frozen):
    """Index lists of a molecule's internal coordinates (see the module docstring).

    Attributes
    ----------
    angles : (n_angles, 3) ndarray of int
        Bent angles (i, j, k), vertex j.
    linear_angles : (n_linear, 3) ndarray of int
        Straight angles (i, j, k), vertex j.
    torsions : (n_torsions, 4) ndarray of int
        Dihedrals (i, j, k, l) about the axis j-k.
    torsion_axis : (n_torsions,) ndarray of int
        Index into `axes` of the axis of each torsion.
    axes : tuple of tuple of int
        The torsion axes: the atoms j, c1, ..., k of each (two for a plain bond).
    out_of_plane : (n_out_of_plane, 4) ndarray of int
        Improper dihedrals (centre, a, b, c) of planar three-bonded centres, up to three per centre.
    out_of_plane_centre_count : (n_out_of_plane,) ndarray of int
        Number of impropers of the centre of each improper (they share the centre's constant).
    """

    angles: NDArray[np.intp]
    linear_angles: NDArray[np.intp]
    torsions: NDArray[np.intp]
    torsion_axis: NDArray[np.intp]
    axes: tuple[tuple[int, ...], ...]
    out_of_plane: NDArray[np.intp]
    out_of_plane_centre_count: NDArray[np.intp]


def internal_terms(positions: NDArray[np.float64], bonds: NDArray[np.intp], *, linear_tolerance_deg: float,
                   planar_tolerance_deg: float = PLANAR_TOLERANCE_DEG) -> InternalTerms:
    """The angles, linear bends, torsions and out-of-plane terms of a molecule with these bonds."""
    n = len(positions)
    neighbours: list[list[int]] = [[] for _ in range(n)]
    for i, j in bonds:
        neighbours[i].append(int(j))
        neighbours[j].append(int(i))
    angles: list[tuple[int, int, int]] = []
    linear: list[tuple[int, int, int]] = []
    bonded = {(int(a), int(b)) for a, b in bonds} | {(int(b), int(a)) for a, b in bonds}
    for j in range(n):
        for p, i in enumerate(neighbours[j]):
            for k in neighbours[j][p + 1:]:
                if (i, k) in bonded:        # a three-membered ring: its bonds already fix the angle
                    continue
                theta = bond_angle(positions, np.array([[i, j, k]]))[0]
                (linear if np.degrees(np.pi - theta) < linear_tolerance_deg else angles).append((i, j, k))
    straight = {t for t in linear} | {t[::-1] for t in linear}
    # an atom with two bonds in a straight line continues a torsion axis through itself
    through = {j for (_, j, _) in linear if len(neighbours[j]) == 2}

    def extend(previous: int, atom: int) -> list[int]:
        chain = [atom]
        while atom in through:
            following = next(a for a in neighbours[atom] if a != previous)
            if following in chain:      # a closed loop of straight angles: not a geometry
                break
            previous, atom = atom, following
            chain.append(atom)
        return chain

    quads: list[tuple[int, int, int, int]] = []
    owner: list[int] = []
    axes: list[tuple[int, ...]] = []
    seen: set[tuple[int, ...]] = set()
    for a, b in bonds:
        a, b = int(a), int(b)
        axis = tuple(extend(b, a)[::-1] + extend(a, b))
        if axis in seen or axis[::-1] in seen:
            continue
        seen.add(axis)
        j, k = axis[0], axis[-1]
        before, after = axis[1], axis[-2]
        found = [(i, j, k, m) for i in neighbours[j] if i != before for m in neighbours[k] if m != after
                 and i != m and (i, j, before) not in straight and (after, k, m) not in straight and i != k and m != j]
        if found:
            axes.append(axis)
            quads.extend(found)
            owner.extend([len(axes) - 1] * len(found))
    planar: list[tuple[int, int, int, int]] = []
    for c in range(n):
        if len(neighbours[c]) != 3:
            continue
        a, b, d = neighbours[c]
        normal = np.cross(positions[b] - positions[a], positions[d] - positions[a])
        height = abs(float(np.dot(positions[c] - positions[a], normal))) / float(np.linalg.norm(normal))
        reach = float(np.mean(np.linalg.norm(positions[[a, b, d]] - positions[c], axis=1)))
        if height > np.sin(np.radians(planar_tolerance_deg)) * reach:
            continue
        # an axis through two neighbours nearly in line with the centre (T-shaped ClF3) is left out
        for p, q, r in ((a, b, d), (b, d, a), (d, a, b)):
            if np.degrees(bond_angle(positions, np.array([[p, c, q]]))[0]) < 180.0 - AXIS_ANGLE_MARGIN_DEG:
                planar.append((c, p, q, r))
    return InternalTerms(
        angles=np.array(angles, dtype=np.intp).reshape(-1, 3),
        linear_angles=np.array(linear, dtype=np.intp).reshape(-1, 3),
        torsions=np.array(quads, dtype=np.intp).reshape(-1, 4),
        torsion_axis=np.array(owner, dtype=np.intp),
        axes=tuple(axes),
        out_of_plane=(wags := np.array(planar, dtype=np.intp).reshape(-1, 4)),
        out_of_plane_centre_count=np.bincount(wags[:, 0], minlength=n)[wags[:, 0]].astype(np.intp),
    )
