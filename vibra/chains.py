"""Chain builders (monatomic, diatomic, beaded string) and their closed-form spectra.

Seed 003 section 5.3 (eqs. 159-165): N masses m joined by springs kappa, Omega = sqrt(kappa/m).
Every builder returns a `vibra.System` that keeps the spring factorisation K = B^T diag(w) B,
so ``system.modes(accuracy="high")`` takes the relative-accuracy path, and every builder has
a closed form beside it so that users and tests can compare:

=====================  =================================================================
`linear_chain`         `monatomic_frequencies`: free 2 Omega sin(k pi / 2N), k = 0..N-1;
                       fixed 2 Omega sin(k pi / 2(N+1)), k = 1..N; periodic
                       2 Omega |sin(pi j / N)|, j = 0..N-1.
`diatomic_chain`       `diatomic_branches` (acoustic and optical omega(q)),
                       `diatomic_frequencies` (periodic ends, exact), `diatomic_band_edges`.
`beaded_string`        `beaded_string_frequencies` (spring constant tension / spacing).
mass defect            `montroll_potts_frequency`, `montroll_potts_decay`.
=====================  =================================================================

`periodic_modes` diagonalises a uniform or diatomic ring exactly with Fourier (Bloch)
modes, in O(N log N) for the frequencies and O(N) per requested mode vector.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra.modes import Modes
from vibra.system import System
from vibra.units import UnitSystem

__all__ = [
    "ENDS",
    "linear_chain",
    "diatomic_chain",
    "beaded_string",
    "monatomic_frequencies",
    "monatomic_shapes",
    "diatomic_branches",
    "diatomic_frequencies",
    "diatomic_band_edges",
    "beaded_string_frequencies",
    "montroll_potts_frequency",
    "montroll_potts_decay",
    "periodic_modes",
]

Ends = Literal["free", "fixed", "periodic"]
#: The end conditions every chain builder accepts.
ENDS: tuple[str, ...] = ("free", "fixed", "periodic")
EPS = float(np.finfo(float).eps)


# ---------------------------------------------------------------------- validation helpers
def _site_count(n: object, name: str, low: int) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"{name} must be an int, got {type(n).__name__}")
    if n < low:
        raise ValueError(f"{name} is {n}; a chain needs {name} >= {low}")
    return int(n)


_positive_scalar = _validate.positive_scalar


def _values(value: object, name: str) -> NDArray[np.float64]:
    """One real number (as a 0-d array) or a 1-D array; a bad scalar is named without an index."""
    if np.ndim(value) == 0:  # type: ignore[arg-type]
        return np.asarray(_validate.real_scalar(value, name))
    return _validate.real_array(value, name, ndim=1)


_positive_array = _validate.positive


def _per_site(value: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    array = _values(value, name)
    if array.ndim == 0:
        array = np.full(n, float(array))
    elif array.shape[0] != n:
        raise ValueError(f"{name} must have {n} entries (one per site), got {array.shape[0]}")
    _positive_array(array, name, "mass")
    return array


def _bond_count(n: int, ends: str) -> int:
    return {"free": n - 1, "fixed": n + 1, "periodic": n}[ends]


def _per_bond(value: ArrayLike, n: int, ends: str, name: str, what: str = "spring constant"
              ) -> NDArray[np.float64]:
    n_bonds = _bond_count(n, ends)
    array = _values(value, name)
    if array.ndim == 0:
        array = np.full(n_bonds, float(array))
    elif array.shape[0] != n_bonds:
        rule = {"free": "n - 1", "fixed": "n + 1, walls included", "periodic": "n"}[ends]
        raise ValueError(
            f"{name} must have {n_bonds} entries for {n} sites with {ends} ends ({rule}), "
            f"got {array.shape[0]}"
        )
    _positive_array(array, name, what)
    return array


def _pair(value: ArrayLike, name: str, what: str) -> tuple[float, float]:
    array = _values(value, name)
    if array.ndim == 0:
        array = np.array([float(array), float(array)])
    if array.shape != (2,):
        raise ValueError(f"{name} must be one value or a pair (first, second), got shape {array.shape}")
    _positive_array(array, name, what)
    return float(array[0]), float(array[1])


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
    """A chain of n masses joined by springs, moving along the chain (seed 003 eq. 159).

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
    n = _site_count(n, "n", 2)
    masses = _per_site(mass, n, "mass")
    _validate.choice(ends, "ends", ENDS)
    k = _per_bond(stiffness, n, ends, "stiffness")
    a = _positive_scalar(spacing, "spacing", "spacing")
    positions = np.arange(n) * a
    label = name if name is not None else f"linear chain (n={n}, {ends} ends)"
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
    """
    n_cells = _site_count(n_cells, "n_cells", 1)
    m1, m2 = _pair(masses, "masses", "mass")
    k1, k2 = _pair(stiffness, "stiffness", "spring constant")
    _validate.choice(ends, "ends", ENDS)
    _positive_scalar(spacing, "spacing", "spacing")
    n = 2 * n_cells
    site_masses = np.tile([m1, m2], n_cells)
    inner = np.tile([k1, k2], n_cells)[: n - 1]  # bonds (i, i+1): k1, k2, ..., k1
    bond_k = {"free": inner, "periodic": np.append(inner, k2), "fixed": np.concatenate([[k2], inner, [k2]])}[ends]
    label = name if name is not None else f"diatomic chain (n_cells={n_cells}, {ends} ends)"
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
    """
    n = _site_count(n, "n", 2)
    masses = _per_site(mass, n, "mass")
    T = _positive_scalar(tension, "tension", "tension")
    a = _positive_scalar(spacing, "spacing", "spacing")
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
    label = name if name is not None else f"beaded string (n={n}, {ends} ends)"
    return System.from_terms(positions, masses, coupling, weights, frozen_dofs=2 * np.arange(n),
                             units=units, name=label)


# ---------------------------------------------------------------------- closed forms
def monatomic_frequencies(n: int, mass: float = 1.0, stiffness: float = 1.0, *, ends: Ends = "free"
                          ) -> NDArray[np.float64]:
    """(n,) exact normal frequencies of a uniform chain, ascending, in rad per time unit.

    With Omega = sqrt(stiffness / mass): free ends 2 Omega sin(k pi / 2n), k = 0..n-1;
    fixed ends 2 Omega sin(k pi / 2(n+1)), k = 1..n; periodic 2 Omega |sin(pi j / n)|,
    j = 0..n-1 (pairs j, n - j degenerate). Each value is computed to a few ulps relative.

    Raises
    ------
    ValueError
        n < 2, mass or stiffness not positive, unknown ends.

    Examples
    --------
    >>> monatomic_frequencies(3, ends="free") ** 2
    array([0., 1., 3.])
    """
    n = _site_count(n, "n", 2)
    m = _positive_scalar(mass, "mass", "mass")
    k = _positive_scalar(stiffness, "stiffness", "spring constant")
    _validate.choice(ends, "ends", ENDS)
    two_omega = 2.0 * np.sqrt(k / m)
    if ends == "free":
        return two_omega * np.sin(np.arange(n) * np.pi / (2 * n))
    if ends == "fixed":
        return two_omega * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1)))
    j = np.arange(n)
    return np.sort(two_omega * np.sin(np.minimum(j, n - j) * np.pi / n))


def monatomic_shapes(n: int, *, ends: Ends = "free", modes: ArrayLike | None = None) -> NDArray[np.float64]:
    """(n, n_modes) exact mode shapes of a uniform chain, unit 2-norm columns, ascending omega.

    Free ends cos(k pi (i + 1/2) / n), fixed ends sin(k pi (i + 1) / (n + 1)); periodic ends
    the real pair cos(2 pi j i / n), sin(2 pi j i / n) in the order of
    `monatomic_frequencies`. `modes` picks columns by ascending index (all by default).
    """
    n = _site_count(n, "n", 2)
    _validate.choice(ends, "ends", ENDS)
    index = np.arange(n) if modes is None else np.asarray(modes)
    if index.ndim != 1 or not (np.issubdtype(index.dtype, np.integer) or index.size == 0) or (
            (index < 0) | (index >= n)).any():
        raise ValueError(f"modes must be 1-D mode indices in [0, {n - 1}] (ints), got {modes!r}")
    index = index.astype(np.intp)
    i = np.arange(n)[:, None]
    if ends == "free":
        shapes = np.cos(index[None, :] * np.pi * (i + 0.5) / n)
    elif ends == "fixed":
        shapes = np.sin((index[None, :] + 1) * np.pi * (i + 1) / (n + 1))
    else:
        j = (index + 1) // 2  # 0, 1, 1, 2, 2, ...
        angle = 2.0 * np.pi * ((j[None, :] * i) % n) / n
        odd = (index % 2 == 1)[None, :]
        shapes = np.where(odd | (j == 0)[None, :] | (2 * j == n)[None, :], np.cos(angle), np.sin(angle))
    return shapes / np.linalg.norm(shapes, axis=0)


def _bloch_root(phase: NDArray[np.float64], m1: float, m2: float, k1: float, k2: float
                ) -> NDArray[np.float64]:
    """sqrt(S^2/4 - 4 k1 k2 sin^2(phase/2) / (m1 m2)) without cancellation.

    With sin^2 = 1 - cos^2 the radicand is G + 4 k1 k2 cos^2(phase/2) / (m1 m2), where
    G = S^2/4 - 4 k1 k2 / (m1 m2) >= 0 is the squared half-gap at the zone boundary,
    written as a sum of non-negative terms ((k1 + k2)(m1 + m2) - 4 sqrt(k1 k2 m1 m2) =
    2 sqrt(k1 k2)(sqrt m1 - sqrt m2)^2 + 2 sqrt(m1 m2)(sqrt k1 - sqrt k2)^2
    + (sqrt k1 - sqrt k2)^2 (sqrt m1 - sqrt m2)^2). The radicand is thus accurate to a few
    ulps near the zone boundary, where the two branches meet when the gap closes.
    """
    dm, dk = (np.sqrt(m1) - np.sqrt(m2)) ** 2, (np.sqrt(k1) - np.sqrt(k2)) ** 2
    geometric = 4.0 * np.sqrt(k1 * k2 * m1 * m2)
    excess = 2.0 * np.sqrt(k1 * k2) * dm + 2.0 * np.sqrt(m1 * m2) * dk + dk * dm
    gap = excess * ((k1 + k2) * (m1 + m2) + geometric) / (4.0 * (m1 * m2) ** 2)
    return np.sqrt(gap + 4.0 * k1 * k2 * np.cos(0.5 * phase) ** 2 / (m1 * m2))


def _bloch_eigenvalues(phase: NDArray[np.float64], m1: float, m2: float, k1: float, k2: float
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lambda_minus, lambda_plus) = omega^2 of the 2x2 Bloch problem at phase q * cell."""
    total = (k1 + k2) * (m1 + m2) / (m1 * m2)
    product = 4.0 * k1 * k2 * np.sin(0.5 * phase) ** 2 / (m1 * m2)
    upper = 0.5 * total + _bloch_root(phase, m1, m2, k1, k2)
    # lambda_minus = det / lambda_plus keeps the acoustic branch accurate near q = 0.
    return product / upper, upper


def diatomic_branches(q: ArrayLike, m1: float, m2: float, k1: float, k2: float, *, cell_length: float = 1.0
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Acoustic and optical omega(q) of an infinite diatomic chain.

    omega^2 = S/2 -+ sqrt(S^2/4 - 4 k1 k2 sin^2(q a / 2) / (m1 m2)), S = (k1 + k2)(m1 + m2)/(m1 m2),
    a = cell_length (the Bloch 2x2 problem of the cell m1 -k1- m2 -k2-).

    Parameters
    ----------
    q : float or (n_q,) array_like
        Wavenumbers, in rad per length unit.
    m1, m2 : float
        The two masses.
    k1, k2 : float
        Intra-cell and inter-cell spring constants.
    cell_length : float
        Cell length a (twice the site spacing of `diatomic_chain`), in length units.

    Returns
    -------
    acoustic, optical : (n_q,) ndarray
        Angular frequencies in rad per time unit (the acoustic branch to a few ulps relative).
    """
    q_array = _values(q, "q")
    m1 = _positive_scalar(m1, "m1", "mass")
    m2 = _positive_scalar(m2, "m2", "mass")
    k1 = _positive_scalar(k1, "k1", "spring constant")
    k2 = _positive_scalar(k2, "k2", "spring constant")
    a = _positive_scalar(cell_length, "cell_length", "length")
    low, high = _bloch_eigenvalues(q_array * a, m1, m2, k1, k2)
    return np.sqrt(low), np.sqrt(high)


def diatomic_band_edges(masses: ArrayLike = (1.0, 2.0), stiffness: ArrayLike = 1.0) -> NDArray[np.float64]:
    """(2, 2) band edges [[0, acoustic max], [optical min, optical max]] in rad per time unit.

    The acoustic maximum and optical minimum are at the zone boundary q = pi / a, the
    optical maximum sqrt(S) at q = 0; the gap is ``edges[1, 0] - edges[0, 1]``.
    """
    m1, m2 = _pair(masses, "masses", "mass")
    k1, k2 = _pair(stiffness, "stiffness", "spring constant")
    low_pi, high_pi = _bloch_eigenvalues(np.array([np.pi]), m1, m2, k1, k2)
    _, high_0 = _bloch_eigenvalues(np.array([0.0]), m1, m2, k1, k2)
    return np.sqrt(np.array([[0.0, low_pi[0]], [high_pi[0], high_0[0]]]))


def diatomic_frequencies(n_cells: int, masses: ArrayLike = (1.0, 2.0), stiffness: ArrayLike = 1.0, *,
                         ends: Ends = "periodic") -> NDArray[np.float64]:
    """(2 n_cells,) exact frequencies of a periodic diatomic ring, ascending, rad per time unit.

    Both branches of `diatomic_branches` at the n_cells allowed phases q a = 2 pi j / n_cells.
    Only ``ends="periodic"`` has this closed form; free and fixed diatomic chains have none
    as simple (compare them with `diatomic_band_edges`, or a dense eigensolver).

    Raises
    ------
    ValueError
        n_cells < 1, bad masses or stiffness, or ends other than "periodic".
    """
    n_cells = _site_count(n_cells, "n_cells", 1)
    m1, m2 = _pair(masses, "masses", "mass")
    k1, k2 = _pair(stiffness, "stiffness", "spring constant")
    _validate.choice(ends, "ends", ENDS)
    if ends != "periodic":
        raise ValueError(
            f"ends is {ends!r}; diatomic_frequencies has a closed form for ends='periodic' only "
            "(use diatomic_band_edges or system.modes() for free and fixed chains)"
        )
    j = np.arange(n_cells)
    low, high = _bloch_eigenvalues(2.0 * np.pi * np.minimum(j, n_cells - j) / n_cells, m1, m2, k1, k2)
    return np.sort(np.sqrt(np.concatenate([low, high])))


def beaded_string_frequencies(n: int, mass: float = 1.0, tension: float = 1.0, spacing: float = 1.0, *,
                              ends: Ends = "fixed") -> NDArray[np.float64]:
    """(n,) exact transverse frequencies of n equal beads on a string, ascending.

    The beaded string is a monatomic chain of spring constant tension / spacing: for fixed
    ends omega_k = 2 sqrt(T / (m d)) sin(k pi / 2(n+1)), k = 1..n (Lagrange's result).
    """
    T = _positive_scalar(tension, "tension", "tension")
    d = _positive_scalar(spacing, "spacing", "spacing")
    return monatomic_frequencies(n, mass, T / d, ends=ends)


def montroll_potts_frequency(omega_max: float, mass: float, defect_mass: float) -> float:
    """Frequency of the mode localised on one light mass in an infinite uniform chain.

    omega_loc = omega_max / sqrt(1 - eps^2), eps = (m - m') / m (Montroll and Potts 1955),
    with omega_max = 2 sqrt(k / m) the top of the band. Only a lighter defect (m' < m) has a
    mode above the band.

    Raises
    ------
    ValueError
        A non-positive argument, or defect_mass >= mass.
    """
    w = _positive_scalar(omega_max, "omega_max", "frequency")
    m = _positive_scalar(mass, "mass", "mass")
    md = _positive_scalar(defect_mass, "defect_mass", "mass")
    if md >= m:
        raise ValueError(
            f"defect_mass is {md!r} >= mass {m!r}; only a lighter defect has a localised mode above the band"
        )
    eps = (m - md) / m
    return w / np.sqrt((1.0 - eps) * (1.0 + eps))


def montroll_potts_decay(mass: float, defect_mass: float) -> float:
    """Amplitude ratio |u_{i+1} / u_i| of the localised mode away from the defect, (1 - eps)/(1 + eps).

    The mode alternates in sign and decays as ((1 - eps)/(1 + eps))^|i - i_defect|,
    eps = (m - m') / m; the ratio equals m' / (2 m - m').
    """
    m = _positive_scalar(mass, "mass", "mass")
    md = _positive_scalar(defect_mass, "defect_mass", "mass")
    if md >= m:
        raise ValueError(
            f"defect_mass is {md!r} >= mass {m!r}; only a lighter defect has a localised mode above the band"
        )
    return md / (2.0 * m - md)


# ---------------------------------------------------------------------- Fourier modes
def _ring_parameters(system: System) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Masses (n,) and bond stiffnesses (n,), bond i joining i and i + 1 mod n, of a ring."""
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    factor = system.spring_factor()
    if factor is None or system.is_generalized:
        raise ValueError("system must be a ring of springs (K = B^T W B); this one has a Hessian given directly")
    coupling, weights = factor
    n = system.n_dof
    coo = sp.coo_matrix(coupling)
    counts = np.bincount(coo.row, minlength=coupling.shape[0])
    if n < 2 or coupling.shape[0] != n or (counts != 2).any() or not np.allclose(np.abs(coo.data), 1.0, rtol=0, atol=0):
        raise ValueError(
            "system is not a periodic chain: periodic_modes needs n springs, each joining two "
            "degrees of freedom with unit weight and no anchors (build it with ends='periodic')"
        )
    order = np.argsort(coo.row, kind="stable")
    cols = coo.col[order].reshape(-1, 2)
    signs = coo.data[order].reshape(-1, 2)
    low, high = cols.min(axis=1), cols.max(axis=1)
    if (signs.sum(axis=1) != 0).any():
        raise ValueError("system is not a periodic chain: a spring does not measure a difference of two dofs")
    bond = np.where(high == low + 1, low, np.where((low == 0) & (high == n - 1), n - 1, -1))
    if n == 2:
        bond = np.array([0, 1])  # both springs join 0 and 1
    if (bond < 0).any() or np.bincount(bond, minlength=n).max() != 1:
        raise ValueError("system is not a periodic chain: its springs do not join i to i + 1 around a ring")
    stiffness = np.empty(n)
    stiffness[bond] = weights
    free = system.free_dofs
    masses = np.repeat(np.asarray(system.masses), system.dim)[free]
    return masses, stiffness


def periodic_modes(system: System, n_modes: int | None = None, *, vectors: bool = True) -> Modes:
    """Exact normal modes of a uniform or diatomic ring by Fourier (Bloch) modes.

    The ring's masses and spring constants must repeat with period 1 (monatomic) or 2
    (diatomic, n even). For each allowed wavenumber q a = 2 pi j / n_cells the Bloch problem
    (1x1 or 2x2) is solved in closed form; the complex Bloch mode and its conjugate give two
    real, degenerate modes (the cos and sin parts). Frequencies cost O(N log N) (a sort);
    each requested mode vector costs O(N), so the lowest few modes of a 10^6-site ring are
    cheap.

    Parameters
    ----------
    system : System
        A periodic chain, e.g. ``linear_chain(n, ends="periodic")``, ``diatomic_chain(...,
        ends="periodic")`` or ``beaded_string(n, ends="periodic")``.
    n_modes : int, optional
        Number of lowest modes (all by default). A cut through a degenerate pair keeps the
        cos member.
    vectors : bool
        False returns frequencies only.

    Returns
    -------
    Modes
        solver ``"fourier"``; omega_error = 4 eps |omega|; residual and orthogonality
        measured on the returned vectors; mass = the masses.

    Raises
    ------
    TypeError
        system not a System.
    ValueError
        system not a periodic spring ring, or its masses / springs repeat with a period
        other than 1 or 2; n_modes out of range.

    Examples
    --------
    >>> modes = periodic_modes(linear_chain(4, ends="periodic"), n_modes=3)
    >>> np.round(modes.omega ** 2, 12)
    array([0., 2., 2.])
    """
    masses, stiffness = _ring_parameters(system)
    n = masses.shape[0]
    if n_modes is not None:
        n_modes = _validate.count(n_modes, "n_modes", low=1, high=n)
    if (masses == masses[0]).all() and (stiffness == stiffness[0]).all():
        m1 = m2 = float(masses[0])
        k1 = k2 = float(stiffness[0])
        period = 1
    elif n % 2 == 0 and (masses[0::2] == masses[0]).all() and (masses[1::2] == masses[1]).all() and (
            stiffness[0::2] == stiffness[0]).all() and (stiffness[1::2] == stiffness[1]).all():
        m1, m2 = float(masses[0]), float(masses[1])
        k1, k2 = float(stiffness[0]), float(stiffness[1])
        period = 2
    else:
        raise ValueError(
            "system's masses and springs must repeat with period 1 or 2 for Fourier modes; "
            "use system.modes() for other rings"
        )
    n_cells = n // period
    j = np.arange(n_cells // 2 + 1)
    parts = np.where((j == 0) | (2 * j == n_cells), 1, 2)
    phase = 2.0 * np.pi * j / n_cells
    if period == 1:
        branches = [4.0 * (k1 / m1) * np.sin(0.5 * phase) ** 2]
    else:
        branches = list(_bloch_eigenvalues(phase, m1, m2, k1, k2))
    # One row per real mode: (lambda, branch, j, part).
    lam = np.concatenate([np.repeat(b, parts) for b in branches])
    branch = np.concatenate([np.full(parts.sum(), b) for b in range(period)])
    jj = np.tile(np.repeat(j, parts), period)
    starts = np.cumsum(parts) - parts
    part = np.tile(np.arange(parts.sum()) - np.repeat(starts, parts), period)
    if n_modes is not None and n_modes < n:
        # O(N) preselection: every mode at or below the n_modes-th smallest value (ties kept).
        cutoff = np.partition(lam, n_modes - 1)[n_modes - 1]
        candidates = np.flatnonzero(lam <= cutoff)
        order = candidates[np.lexsort((part[candidates], jj[candidates], branch[candidates],
                                       lam[candidates]))][:n_modes]
    else:
        order = np.lexsort((part, jj, branch, lam))
    lam_max = float(max(b.max() for b in branches))
    lam, branch, jj, part = lam[order], branch[order], jj[order], part[order]
    omega = np.sqrt(lam)
    omega_error = 4.0 * EPS * omega
    if not vectors:
        return Modes(omega=omega, vectors=None, shapes=None, mass=masses, omega_error=omega_error,
                     residual=float("nan"), orthogonality=float("nan"), solver="fourier", units=system.units)
    cell = np.arange(n_cells)[:, None]
    angle = 2.0 * np.pi * ((jj[None, :] * cell) % n_cells) / n_cells  # (n_cells, k)
    wave = np.exp(1j * angle)
    scale = np.where((jj == 0) | (2 * jj == n_cells), 1.0, np.sqrt(2.0)) / np.sqrt(n_cells)
    if period == 1:
        amplitude = np.ones((1, len(order)), dtype=complex)
    else:
        theta = 2.0 * np.pi * jj / n_cells
        d1, d2 = (k1 + k2) / m1, (k1 + k2) / m2
        h = (k1 + k2 * np.exp(-1j * theta)) / np.sqrt(m1 * m2)
        first = np.stack([h, d1 - lam])
        second = np.stack([d2 - lam + 0j, np.conj(h)])
        use_first = np.linalg.norm(first, axis=0) >= np.linalg.norm(second, axis=0)
        amplitude = np.where(use_first[None, :], first, second)
        amplitude /= np.linalg.norm(amplitude, axis=0)
    d = np.empty((n, len(order)))
    for site in range(period):
        bloch = wave * amplitude[site][None, :]
        d[site::period] = np.where(part[None, :] == 0, bloch.real, bloch.imag) * scale[None, :]
    # Re / Im of a Bloch mode at j = 0 or n_cells / 2 is real already; normalise exactly.
    d /= np.linalg.norm(d, axis=0)
    root_mass = np.sqrt(masses)[:, None]
    K = system.hessian()
    applied = (K @ (d / root_mass)) / root_mass
    residual = float(np.max(np.linalg.norm(applied - d * lam[None, :], axis=0)) / lam_max)
    gram = d.T @ d
    orthogonality = float(np.max(np.abs(gram - np.eye(gram.shape[0]))))
    return Modes(omega=omega, vectors=d, shapes=d / root_mass, mass=masses, omega_error=omega_error,
                 residual=residual, orthogonality=orthogonality, solver="fourier", units=system.units)
