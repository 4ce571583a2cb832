"""Chain builders: monatomic and diatomic spring chains and the beaded string.

Seed 003 section 5.3 (eq. 159): N masses m joined by springs kappa. Every builder returns a
`vibra.System` that keeps the spring factorisation K = B^T diag(w) B, so
``system.modes(accuracy="high")`` takes the relative-accuracy path; the closed forms beside
them are in `vibra.chains.closed_forms`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.system import System
from vibra.units import UnitSystem

__all__ = ["ENDS", "linear_chain", "diatomic_chain", "beaded_string"]

Ends = Literal["free", "fixed", "periodic"]
#: The end conditions every chain builder accepts.
ENDS: tuple[str, ...] = ("free", "fixed", "periodic")


# ---------------------------------------------------------------------- validation helpers
def _per_site(value: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    array = _validate.per_entry(value, n, name, "site")
    _validate.positive(array, name, "mass")
    return array


def _per_bond(value: ArrayLike, n: int, ends: str, name: str, what: str = "spring constant"
              ) -> NDArray[np.float64]:
    n_bonds = {"free": n - 1, "fixed": n + 1, "periodic": n}[ends]
    array = _validate.real_values(value, name)
    if array.ndim == 0:
        array = np.full(n_bonds, float(array))
    elif array.shape[0] != n_bonds:
        rule = {"free": "n - 1", "fixed": "n + 1, walls included", "periodic": "n"}[ends]
        raise ValueError(
            f"{name} must have {n_bonds} entries for {n} sites with {ends} ends ({rule}), "
            f"got {array.shape[0]}"
        )
    _validate.positive(array, name, what)
    return array


def _bonds(n: int, ends: str) -> NDArray[np.intp]:
    """(n_springs, 2) site pairs between neighbours (the ring bond (n-1, 0) last)."""
    left = np.arange(n - 1)
    pairs = np.stack([left, left + 1], axis=1)
    if ends == "periodic":
        pairs = np.vstack([pairs, [[n - 1, 0]]])
    return pairs


# ---------------------------------------------------------------------- builders
def linear_chain(
    n: int,
    *,
    mass: ArrayLike = 1.0,
    stiffness: ArrayLike = 1.0,
    spacing: float = 1.0,
    ends: Ends = "free",
    units: str | UnitSystem = "SI",
    name: str | None = None,
) -> System:
    """A chain of n masses joined by springs, moving along the chain (Kneller, Mécanique analytique, eq. 159).

    One degree of freedom per site: the longitudinal displacement u_i. Sites sit at
    x_i = i * spacing. With ``ends="fixed"`` the end masses are tied to walls at
    x = -spacing and x = n * spacing by two more springs; ``"periodic"`` closes the ring
    with a spring between sites n - 1 and 0.

    Parameters
    ----------
    n : int
        Number of moving masses, n >= 2.
    mass : float or (n,) array_like
        Site masses (kg in SI); an array gives impurities or disorder.
    stiffness : float or (n_bonds,) array_like
        Spring constants (N/m in SI), in bond order: free ends n - 1 bonds (i, i+1);
        fixed ends n + 1 bonds [wall-0, 0-1, ..., (n-2)-(n-1), (n-1)-wall];
        periodic ends n bonds, (n-1)-0 last.
    spacing : float
        Equilibrium distance between neighbours (m in SI).
    ends : {"free", "fixed", "periodic"}
        End conditions.
    units : str or UnitSystem
        ``"SI"`` (default) or ``"dimensionless"`` (or ``"ASE"``).
    name : str, optional
        Name used in reports.

    Returns
    -------
    System
        n_dof = n, K = B^T diag(stiffness) B with B the incidence matrix of the springs.

    Raises
    ------
    TypeError
        n not an int.
    ValueError
        n < 2; a mass, stiffness or spacing not positive and finite; a mass or stiffness
        array whose length does not match n and the ends; unknown ends.

    Examples
    --------
    >>> import numpy as np
    >>> chain = linear_chain(3, mass=1.0, stiffness=1.0)
    >>> chain.hessian().toarray()
    array([[ 1., -1.,  0.],
           [-1.,  2., -1.],
           [ 0., -1.,  1.]])
    """
    n = _validate.min_count(n, "n", low=2, what="a chain")
    masses = _per_site(mass, n, "mass")
    _validate.choice(ends, "ends", ENDS)
    k = _per_bond(stiffness, n, ends, "stiffness")
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    positions = np.arange(n) * a
    label = _validate.text(name, "name") if name is not None else f"linear chain (n={n}, {ends} ends)"
    if ends == "fixed":
        return System.from_springs(
            positions, masses, _bonds(n, "free"), k[1:-1], anchors=np.array([0, n - 1]),
            anchor_stiffness=np.array([k[0], k[-1]]), units=units, name=label,
        )
    return System.from_springs(positions, masses, _bonds(n, ends), k, units=units, name=label)


def diatomic_chain(
    n_cells: int,
    *,
    masses: ArrayLike = (1.0, 2.0),
    stiffness: ArrayLike = 1.0,
    spacing: float = 1.0,
    ends: Ends = "free",
    units: str | UnitSystem = "SI",
    name: str | None = None,
) -> System:
    """A chain of n_cells two-atom cells: m1 -k1- m2 -k2- m1 -k1- m2 ...

    Site 2c holds m1 and site 2c + 1 holds m2 (c = 0..n_cells-1), at x_i = i * spacing, so
    the cell length is 2 * spacing. Spring k1 joins the two atoms of a cell and k2 joins
    neighbouring cells. Free ends: 2 n_cells - 1 springs, ending on k1. Periodic: 2 n_cells
    springs, the ring spring (2 n_cells - 1, 0) being a k2. Fixed: the free chain plus a
    k2 spring from each end mass to a wall (wall -k2- m1 ... m2 -k2- wall).

    Parameters
    ----------
    n_cells : int
        Number of cells, >= 1 (2 n_cells sites).
    masses : (2,) array_like or float
        (m1, m2), in kg in SI.
    stiffness : (2,) array_like or float
        (k1, k2), in N/m in SI; one value sets k1 = k2.
    spacing : float
        Distance between neighbouring sites (half the cell length), in m in SI.
    ends : {"free", "fixed", "periodic"}
        End conditions.
    units : str or UnitSystem
        Unit system.
    name : str, optional
        Name used in reports.

    Returns
    -------
    System
        n_dof = 2 n_cells.

    Raises
    ------
    TypeError
        n_cells not an int.
    ValueError
        n_cells < 1, masses or stiffness not one positive value or a pair of them,
        spacing not positive, unknown ends.

    Examples
    --------
    >>> chain = diatomic_chain(2, masses=(1.0, 2.0), ends="periodic")
    >>> chain.n_dof, chain.mass_matrix().tolist()
    (4, [1.0, 2.0, 1.0, 2.0])
    """
    n_cells = _validate.min_count(n_cells, "n_cells", low=1, what="a chain")
    m1, m2 = _validate.positive_pair(masses, "masses", "mass")
    k1, k2 = _validate.positive_pair(stiffness, "stiffness", "spring constant")
    _validate.choice(ends, "ends", ENDS)
    _validate.positive_scalar(spacing, "spacing", "spacing")
    n = 2 * n_cells
    site_masses = np.tile([m1, m2], n_cells)
    inner = np.tile([k1, k2], n_cells)[: n - 1]  # bonds (i, i+1): k1, k2, ..., k1
    bond_k = {"free": inner, "periodic": np.append(inner, k2), "fixed": np.concatenate([[k2], inner, [k2]])}[ends]
    label = _validate.text(name, "name") if name is not None else f"diatomic chain (n_cells={n_cells}, {ends} ends)"
    return linear_chain(n, mass=site_masses, stiffness=bond_k, spacing=spacing, ends=ends,
                        units=units, name=label)


def beaded_string(
    n: int,
    *,
    mass: ArrayLike = 1.0,
    tension: float = 1.0,
    spacing: float = 1.0,
    ends: Ends = "fixed",
    units: str | UnitSystem = "SI",
    name: str | None = None,
) -> System:
    """n beads on a taut string, moving transversally (small displacements).

    The beads sit at (i * spacing, 0) in 2-D; the moving coordinate of bead i is its
    transverse displacement y_i (label ``"iy"``), the x coordinates are frozen. A segment
    of length `spacing` under tension T stores T (y_j - y_i)^2 / (2 spacing), so each
    segment acts as a spring of constant T / spacing on the y's. ``"fixed"`` (the default)
    pins the string at walls (-spacing, 0) and (n * spacing, 0): n + 1 segments;
    ``"free"`` lets the ends slide on frictionless rods (n - 1 segments); ``"periodic"``
    closes the string into a loop (n segments).

    Parameters
    ----------
    n : int
        Number of beads, >= 2.
    mass : float or (n,) array_like
        Bead masses (kg in SI).
    tension : float
        String tension (N in SI).
    spacing : float
        Distance between beads along the string (m in SI).
    ends : {"fixed", "free", "periodic"}
        End conditions.
    units : str or UnitSystem
        Unit system.
    name : str, optional
        Name used in reports.

    Returns
    -------
    System
        n_sites = n, dim = 2, n_dof = n (the y coordinates), K = B^T (T / spacing) B.

    Raises
    ------
    TypeError
        n not an int.
    ValueError
        n < 2; mass, tension or spacing not positive and finite; a mass array of the wrong
        length; unknown ends.

    Examples
    --------
    >>> string = beaded_string(3, tension=2.0, spacing=0.5)
    >>> string.n_dof, string.free_dofs.tolist()  # the y coordinate of each bead
    (3, [1, 3, 5])
    """
    n = _validate.min_count(n, "n", low=2, what="a chain")
    masses = _per_site(mass, n, "mass")
    T = _validate.positive_scalar(tension, "tension", "tension")
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    _validate.choice(ends, "ends", ENDS)
    positions = np.stack([np.arange(n) * a, np.zeros(n)], axis=1)
    y = 2 * np.arange(n) + 1  # flat index of each bead's y coordinate
    pairs = _bonds(n, "free" if ends == "fixed" else ends)
    n_pairs = len(pairs)
    rows = [np.repeat(np.arange(n_pairs), 2)]
    cols = [y[pairs].ravel()]
    data = [np.tile([-1.0, 1.0], n_pairs)]
    if ends == "fixed":
        rows.append(np.array([n_pairs, n_pairs + 1]))
        cols.append(np.array([y[0], y[-1]]))
        data.append(np.array([1.0, 1.0]))
    coupling = sp.csr_matrix(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
        shape=(n_pairs + (2 if ends == "fixed" else 0), 2 * n),
    )
    weights = np.full(coupling.shape[0], T / a)
    label = _validate.text(name, "name") if name is not None else f"beaded string (n={n}, {ends} ends)"
    return System.from_terms(positions, masses, coupling, weights, frozen_dofs=2 * np.arange(n),
                             units=units, name=label)
