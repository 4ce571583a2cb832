"""Internal coordinates of a valence force field and their Wilson gradients (B-matrix rows).

Every function takes positions x (n_atoms, 3) in Angstrom and an integer index array (one row
per coordinate) and returns the coordinate values with their gradients with respect to the
Cartesian positions of the atoms involved (Angstrom^-1 for angles, dimensionless for lengths).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["bond_stretch", "bond_angle", "angle_bend", "linear_bend_rows", "linear_bend_vector",
           "dihedral", "wrap_angle"]


def bond_stretch(x: NDArray[np.float64], pairs: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bond lengths (n,) and gradients (n, 2, 3)."""
    v = x[pairs[:, 1]] - x[pairs[:, 0]]
    r = np.linalg.norm(v, axis=1)
    e = v / r[:, None]
    return r, np.stack([-e, e], axis=1)


def bond_angle(x: NDArray[np.float64], triples: NDArray[np.intp]) -> NDArray[np.float64]:
    """Angles i-j-k (n,) in rad."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    # arctan2 of |u x v| and u . v keeps full accuracy near 0 and pi (arccos does not)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.sum(u * v, axis=1))


def angle_bend(x: NDArray[np.float64], triples: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Angles i-j-k (n,) in rad and their Wilson gradients (n, 3, 3) (singular at 0 and pi)."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)
    lv = np.linalg.norm(v, axis=1)
    eu, ev = u / lu[:, None], v / lv[:, None]
    cos = np.sum(eu * ev, axis=1)
    sin = np.linalg.norm(np.cross(eu, ev), axis=1)
    theta = np.arctan2(sin, cos)
    gi = (cos[:, None] * eu - ev) / (lu * sin)[:, None]
    gk = (cos[:, None] * ev - eu) / (lv * sin)[:, None]
    return theta, np.stack([gi, -gi - gk, gk], axis=1)


def _perpendiculars(axis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors perpendicular to each (n, 3) unit axis and to each other."""
    trial = np.zeros_like(axis)
    smallest = np.argmin(np.abs(axis), axis=1)
    trial[np.arange(len(axis)), smallest] = 1.0
    n1 = trial - np.sum(trial * axis, axis=1)[:, None] * axis
    n1 /= np.linalg.norm(n1, axis=1)[:, None]
    return n1, np.cross(axis, n1)


def linear_bend_rows(x: NDArray[np.float64], triples: NDArray[np.intp]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The two linear-bend B rows (n, 3 atoms, 3) at a straight geometry.

    Coordinate a = n_a . (e_ji + e_jk) (radians of deflection towards n_a); its gradient is
    n_a / |r_ji| on i, n_a / |r_jk| on k and minus their sum on j.
    """
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)[:, None]
    lv = np.linalg.norm(v, axis=1)[:, None]
    axis = (u / lu - v / lv)
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    out = []
    for n in _perpendiculars(axis):
        out.append(np.stack([n / lu, -n / lu - n / lv, n / lv], axis=1))
    return out[0], out[1]


def linear_bend_vector(x: NDArray[np.float64], triples: NDArray[np.intp]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """s = e_ji + e_jk (n, 3) and the gradient of 1/2 |s|^2 (n, 3 atoms, 3)."""
    u = x[triples[:, 0]] - x[triples[:, 1]]
    v = x[triples[:, 2]] - x[triples[:, 1]]
    lu = np.linalg.norm(u, axis=1)[:, None]
    lv = np.linalg.norm(v, axis=1)[:, None]
    eu, ev = u / lu, v / lv
    s = eu + ev
    gi = (s - np.sum(s * eu, axis=1)[:, None] * eu) / lu
    gk = (s - np.sum(s * ev, axis=1)[:, None] * ev) / lv
    return s, np.stack([gi, -gi - gk, gk], axis=1)


def dihedral(x: NDArray[np.float64], quads: NDArray[np.intp]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Dihedrals i-j-k-l (n,) in rad, IUPAC sign, and their gradients (n, 4, 3).

    Blondel & Karplus, J. Comput. Chem. 17, 1132 (1996): F = r_i - r_j, G = r_j - r_k,
    H = r_l - r_k, A = F x G, B = H x G.
    """
    f = x[quads[:, 0]] - x[quads[:, 1]]
    g = x[quads[:, 1]] - x[quads[:, 2]]
    h = x[quads[:, 3]] - x[quads[:, 2]]
    a = np.cross(f, g)
    b = np.cross(h, g)
    lg = np.linalg.norm(g, axis=1)
    a2 = np.sum(a * a, axis=1)
    b2 = np.sum(b * b, axis=1)
    phi = np.arctan2(np.sum(np.cross(b, a) * g, axis=1) / lg, np.sum(a * b, axis=1))
    fg = np.sum(f * g, axis=1)
    hg = np.sum(h * g, axis=1)
    gi = -(lg / a2)[:, None] * a
    gl = (lg / b2)[:, None] * b
    gj = (lg / a2 + fg / (a2 * lg))[:, None] * a - (hg / (b2 * lg))[:, None] * b
    gk = -(lg / b2 - hg / (b2 * lg))[:, None] * b - (fg / (a2 * lg))[:, None] * a
    return phi, np.stack([gi, gj, gk, gl], axis=1)


def wrap_angle(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    return (angle + np.pi) % (2.0 * np.pi) - np.pi
