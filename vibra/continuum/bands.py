"""Dispersion of infinite chains and the continuum rod or string (Kneller, Mécanique analytique, eqs. 162-165).

A uniform chain of masses m, springs kappa and spacing dx obeys (eq. 162)
u_i'' = Omega^2 (u_{i+1} - 2 u_i + u_{i-1}), Omega = sqrt(kappa / m). As dx -> 0 with
c = Omega dx fixed (eq. 164) this becomes the wave equation u_tt = c^2 u_xx (eq. 165).
Here: dispersion omega(q), group velocity and band edges of monatomic and diatomic chains,
the assignment of a finite chain's modes to wavenumbers (`dispersion_curves` gathers all
of it for a chart), and the rod / string modes for each end condition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.chains import ENDS, diatomic_band_edges, diatomic_eigenvalues, diatomic_half_splitting
from vibra.chains.builders import Ends
from vibra.modes import Modes
from vibra.units import DIMENSIONLESS, UnitSystem, unit_system

__all__ = [
    "dispersion",
    "group_velocity",
    "band_edges",
    "wave_speed",
    "assign_wavenumbers",
    "continuum_frequencies",
    "continuum_length",
    "DispersionCurves",
    "dispersion_curves",
]

_site_count = _validate.min_count


def _chain_parameters(masses: ArrayLike, stiffness: ArrayLike) -> tuple[int, float, float, float, float]:
    """(n_branches, m1, m2, k1, k2) from one value (monatomic) or pairs (diatomic)."""
    mass_array = _validate.real_values(masses, "masses")
    k_array = _validate.real_values(stiffness, "stiffness")
    diatomic = (mass_array.ndim == 1 and mass_array.shape[0] != 1) or (k_array.ndim == 1 and k_array.shape[0] != 1)
    if not diatomic:
        m = _validate.positive_scalar(mass_array.reshape(()), "masses", "mass")
        k = _validate.positive_scalar(k_array.reshape(()), "stiffness", "spring constant")
        return 1, m, m, k, k
    m1, m2 = _validate.positive_pair(mass_array, "masses", "mass")
    k1, k2 = _validate.positive_pair(k_array, "stiffness", "spring constant")
    return 2, m1, m2, k1, k2


def dispersion(q: ArrayLike, *, masses: ArrayLike = 1.0, stiffness: ArrayLike = 1.0, spacing: float = 1.0
               ) -> NDArray[np.float64]:
    """Branches omega(q) of an infinite chain, in rad per time unit.

    Monatomic (one mass, one stiffness): omega = 2 Omega |sin(q dx / 2)|. Diatomic (a pair
    of masses and/or a pair of stiffnesses, sites `spacing` apart, cell length 2 spacing):
    the acoustic and optical branches of `vibra.chains.diatomic_branches`.

    Parameters
    ----------
    q : float or (n_q,) array_like
        Wavenumbers, in rad per length unit.
    masses : float or (2,) array_like
        m, or (m1, m2).
    stiffness : float or (2,) array_like
        kappa, or (k1, k2) (intra-cell, inter-cell).
    spacing : float
        Distance between neighbouring sites, in length units.

    Returns
    -------
    (n_branches, n_q) ndarray
        One row (monatomic) or two (acoustic, optical).

    Examples
    --------
    >>> import numpy as np
    >>> np.round(dispersion([0.0, np.pi / 2, np.pi]), 12)  # 2 |sin(q / 2)|
    array([[0.        , 1.41421356, 2.        ]])
    """
    q_array = np.atleast_1d(_validate.real_values(q, "q"))
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    if n_branches == 1:
        return (2.0 * np.sqrt(k1 / m1) * np.abs(np.sin(0.5 * q_array * a)))[None, :]
    low, high = diatomic_eigenvalues(2.0 * a * q_array, m1, m2, k1, k2)
    return np.sqrt(np.stack([low, high]))


def group_velocity(q: ArrayLike, *, masses: ArrayLike = 1.0, stiffness: ArrayLike = 1.0, spacing: float = 1.0
                   ) -> NDArray[np.float64]:
    """(n_branches, n_q) group velocities d omega / d q, in length per time unit.

    Analytic derivative of `dispersion`; at q = 0 the acoustic branch gives its right
    derivative, the sound speed (Omega dx for a monatomic chain,
    2 dx sqrt(k1 k2 / ((k1 + k2)(m1 + m2))) for a diatomic one).

    Examples
    --------
    >>> import numpy as np
    >>> np.round(group_velocity([0.0, np.pi]), 12)  # the sound speed Omega dx, then 0 at the zone edge
    array([[1., 0.]])
    """
    q_array = np.atleast_1d(_validate.real_values(q, "q"))
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    sign = np.where(q_array >= 0, 1.0, -1.0)
    if n_branches == 1:
        return (np.sqrt(k1 / m1) * a * np.cos(0.5 * q_array * a) * sign)[None, :]
    cell = 2.0 * a
    half = 0.5 * q_array * cell
    total = (k1 + k2) * (m1 + m2) / (m1 * m2)
    coupling = 4.0 * k1 * k2 / (m1 * m2)
    root = diatomic_half_splitting(q_array * cell, m1, m2, k1, k2)
    upper = 0.5 * total + root
    d_product = coupling * np.sin(half) * np.cos(half) * cell
    # lambda_+ = S/2 + sqrt(S^2/4 - P): d lambda_+ / dq = -P' / (2 root). Where the gap
    # closes (m1 = m2 and k1 = k2: a folded monatomic chain) root and P' vanish together at
    # the zone boundary; the left derivative there is -sqrt(coupling) cell / 2 (|root| =
    # sqrt(coupling) |cos(half)|).
    with np.errstate(divide="ignore", invalid="ignore"):
        d_upper = np.where(root > 0, -d_product / (2.0 * np.where(root > 0, root, 1.0)),
                           -0.5 * np.sqrt(coupling) * cell * np.abs(np.sin(half)))
    # omega_- = sqrt(coupling) |sin(half)| / sqrt(upper): differentiate without 0/0 at q = 0.
    d_acoustic = np.sqrt(coupling) * (0.5 * cell * np.cos(half) * sign / np.sqrt(upper)
                                      - np.abs(np.sin(half)) * d_upper / (2.0 * upper ** 1.5))
    d_optical = d_upper / (2.0 * np.sqrt(upper))
    return np.stack([d_acoustic, d_optical])


def band_edges(*, masses: ArrayLike = 1.0, stiffness: ArrayLike = 1.0) -> NDArray[np.float64]:
    """(n_branches, 2) [lowest, highest] omega of each branch, in rad per time unit.

    Monatomic [[0, 2 Omega]]; diatomic [[0, acoustic max], [optical min, optical max]],
    the gap being ``edges[1, 0] - edges[0, 1]``.

    Examples
    --------
    >>> import numpy as np
    >>> np.round(band_edges(masses=(1.0, 2.0)) ** 2, 12)
    array([[0., 1.],
           [2., 3.]])
    """
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    if n_branches == 1:
        return np.array([[0.0, 2.0 * np.sqrt(k1 / m1)]])
    return diatomic_band_edges((m1, m2), (k1, k2))


def wave_speed(mass: float, stiffness: float, spacing: float) -> float:
    """c = Omega dx = sqrt(stiffness / mass) * spacing (eq. 164), in length per time unit.

    Examples
    --------
    >>> wave_speed(1.0, 4.0, 0.5)
    1.0
    """
    m = _validate.positive_scalar(mass, "mass", "mass")
    k = _validate.positive_scalar(stiffness, "stiffness", "spring constant")
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    return float(np.sqrt(k / m) * a)


def continuum_length(n: int, spacing: float, *, ends: Ends = "free") -> float:
    """Length L of the rod or string a chain of n sites stands for.

    Free and periodic ends L = n dx (each site owns one spacing); fixed ends L = (n + 1) dx
    (the walls are one spacing beyond the end masses).

    Examples
    --------
    >>> continuum_length(10, 0.1), continuum_length(10, 0.1, ends="fixed")
    (1.0, 1.1)
    """
    n = _site_count(n, "n", low=2, what="a chain")
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    _validate.choice(ends, "ends", ENDS)
    return (n + 1) * a if ends == "fixed" else n * a


def continuum_frequencies(n_modes: int, *, length: float = 1.0, wave_speed: float = 1.0, ends: Ends = "free"
                          ) -> NDArray[np.float64]:
    """(n_modes,) lowest normal frequencies of a rod or string u_tt = c^2 u_xx, ascending.

    Free-free omega_k = k pi c / L (k = 0, 1, ...), fixed-fixed k pi c / L (k = 1, 2, ...),
    periodic 2 pi j c / L with j = 0, 1, 1, 2, 2, ... (cos and sin pairs).

    Examples
    --------
    >>> import numpy as np
    >>> np.round(continuum_frequencies(4, ends="periodic") / np.pi, 12)
    array([0., 2., 2., 4.])
    """
    count = _validate.count(n_modes, "n_modes", low=1, high=np.iinfo(np.int64).max)
    L = _validate.positive_scalar(length, "length", "length")
    c = _validate.positive_scalar(wave_speed, "wave_speed", "speed")
    _validate.choice(ends, "ends", ENDS)
    index = np.arange(count)
    if ends == "free":
        k = index
    elif ends == "fixed":
        k = index + 1
    else:
        k = 2 * ((index + 1) // 2)
    return (k * np.pi * c / L).astype(np.float64)


def _sign_changes(shapes: NDArray[np.float64], periodic: bool) -> NDArray[np.intp]:
    """Sign changes down each column, ignoring entries below 1e-8 of the column's max."""
    counts = np.empty(shapes.shape[1], dtype=np.intp)
    for column in range(shapes.shape[1]):
        values = shapes[:, column]
        # Nodes that fall on a site are exact zeros in theory and ~1e-16 in practice.
        signs = np.sign(values[np.abs(values) > 1e-8 * np.abs(values).max()])
        changes = int(np.count_nonzero(signs[1:] != signs[:-1]))
        if periodic and signs.size > 1 and signs[0] != signs[-1]:
            changes += 1
        counts[column] = changes
    return counts


def assign_wavenumbers(modes: Modes | ArrayLike, *, ends: Ends = "free", spacing: float = 1.0,
                       sites_per_cell: int = 1, n_sites: int | None = None) -> NDArray[np.float64]:
    """Wavenumber of each mode of a finite 1-D chain, in rad per length unit.

    A chain's mode with nu sign changes (nodes between sites) is the standing wave of
    extended wavenumber q = nu pi / L (L from `continuum_length`; nu counted around the ring
    for periodic ends). By Sturm's oscillation theorem the i-th mode from the bottom of a
    free chain has nu = i nodes (fixed: i, with q = (i + 1) pi / L), so without shapes the
    index is used. With two sites per cell, q is folded into the first Brillouin zone
    [0, pi / (2 dx)]: modes beyond it belong to the optical branch. For a uniform chain
    this is exact; for a diatomic or disordered chain it is the usual labelling.

    Parameters
    ----------
    modes : Modes or (n_modes,) array_like
        Modes of the chain (lowest first; with shapes, nodes are counted), or their omega.
    ends : {"free", "fixed", "periodic"}
        End conditions of the chain.
    spacing : float
        Site spacing dx, in length units.
    sites_per_cell : {1, 2}
        2 for a diatomic chain.
    n_sites : int, optional
        Number of sites; required when `modes` is an array (it is ``modes.n_dof`` otherwise).

    Returns
    -------
    (n_modes,) ndarray
        q >= 0 of each mode, in rad per length unit.

    Examples
    --------
    >>> import numpy as np
    >>> from vibra.chains import linear_chain
    >>> np.round(assign_wavenumbers(linear_chain(4).modes()) / np.pi, 12)  # nu pi / (4 dx)
    array([0.  , 0.25, 0.5 , 0.75])
    """
    _validate.choice(ends, "ends", ENDS)
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    per_cell = _validate.count(sites_per_cell, "sites_per_cell", low=1, high=2)
    if isinstance(modes, Modes):
        n = modes.n_dof
        count = modes.n_modes
        nodes = _sign_changes(modes.shapes, ends == "periodic") if modes.shapes is not None else None
    else:
        omega = _validate.real_array(modes, "modes", ndim=1)
        if n_sites is None:
            raise ValueError("n_sites is required when modes is an array of frequencies")
        n = _site_count(n_sites, "n_sites", low=2, what="a chain")
        count = omega.shape[0]
        nodes = None
    if nodes is None:
        index = np.arange(count)
        nodes = 2 * ((index + 1) // 2) if ends == "periodic" else index
    L = continuum_length(n, a, ends=ends)
    q = (nodes + (1 if ends == "fixed" else 0)) * np.pi / L
    if per_cell == 2:
        zone = np.pi / (2.0 * a)
        q = np.where(q > zone, 2.0 * zone - q, q)
    return np.abs(q)


@dataclass(frozen=True, eq=False)
class DispersionCurves(Frozen):
    """Dispersion branches over the first Brillouin zone, with a finite chain's modes on them.

    Attributes
    ----------
    q : (n_q,) ndarray
        Wavenumbers from 0 to `zone_edge`, in rad per length unit.
    omega : (n_branches, n_q) ndarray
        omega(q) of each branch (monatomic: one; diatomic: acoustic, optical), in rad per
        time unit.
    band_edges : (n_branches, 2) ndarray
        [lowest, highest] omega of each branch, in rad per time unit.
    zone_edge : float
        pi / (n_branches * spacing), in rad per length unit.
    spacing : float
        Site spacing dx, in length units.
    mode_wavenumbers : (n_modes,) ndarray or None
        Wavenumbers of the finite chain's modes (`assign_wavenumbers`), in rad per length unit.
    mode_omega : (n_modes,) ndarray or None
        Their angular frequencies, in rad per time unit.
    n_sites : int or None
        Number of sites of that finite chain.
    ends : str
        Its end conditions.
    units : UnitSystem
        Units of every quantity above.
    """

    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    band_edges: NDArray[np.float64]
    zone_edge: float
    spacing: float
    mode_wavenumbers: NDArray[np.float64] | None
    mode_omega: NDArray[np.float64] | None
    n_sites: int | None
    ends: str
    units: UnitSystem

    @property
    def n_branches(self) -> int:
        """1 (monatomic) or 2 (diatomic)."""
        return int(self.omega.shape[0])

    @property
    def gap(self) -> float:
        """Width of the band gap between the branches (0 for one branch), in rad per time unit."""
        if self.n_branches == 1:
            return 0.0
        return float(self.band_edges[1, 0] - self.band_edges[0, 1])


def dispersion_curves(*, masses: ArrayLike = 1.0, stiffness: ArrayLike = 1.0, spacing: float = 1.0,
                      modes: Modes | None = None, ends: Ends = "free", n_q: int = 400,
                      units: str | UnitSystem | None = None) -> DispersionCurves:
    """`dispersion` sampled over the first Brillouin zone, with a finite chain's modes placed on it.

    Parameters
    ----------
    masses, stiffness : float or (2,) array_like
        As in `dispersion` (a pair gives the diatomic branches).
    spacing : float
        Site spacing dx, in length units.
    modes : Modes, optional
        Modes of a finite chain with these parameters, placed at the wavenumbers of
        `assign_wavenumbers`.
    ends : {"free", "fixed", "periodic"}
        End conditions of that chain.
    n_q : int
        Number of wavenumbers, >= 2, from 0 to the zone edge.
    units : str or UnitSystem, optional
        Units of the result (those of `modes` by default, else dimensionless).

    Returns
    -------
    DispersionCurves

    Raises
    ------
    ValueError
        As `dispersion` and `assign_wavenumbers`; n_q < 2; unknown units.

    Examples
    --------
    >>> curves = dispersion_curves(masses=(1.0, 2.0), n_q=3)
    >>> curves.n_branches, round(curves.zone_edge, 6), round(curves.gap, 6)
    (2, 1.570796, 0.414214)
    """
    edges = band_edges(masses=masses, stiffness=stiffness)
    a = _validate.positive_scalar(spacing, "spacing", "spacing")
    if modes is not None and not isinstance(modes, Modes):
        raise TypeError(f"modes must be a vibra.Modes, got {type(modes).__name__}")
    _validate.choice(ends, "ends", ENDS)
    count = _validate.count(n_q, "n_q", low=2, high=10**8)
    unit = unit_system(units) if units is not None else (modes.units if modes is not None else DIMENSIONLESS)
    n_branches = edges.shape[0]
    zone = float(np.pi / (n_branches * a))
    q = np.linspace(0.0, zone, count)
    omega = dispersion(q, masses=masses, stiffness=stiffness, spacing=a)
    mode_q = mode_omega = None
    n_sites = None
    if modes is not None:
        mode_q = assign_wavenumbers(modes, ends=ends, spacing=a, sites_per_cell=n_branches)
        mode_omega = np.asarray(modes.omega)
        n_sites = int(modes.n_dof)
    return DispersionCurves(q=q, omega=omega, band_edges=edges, zone_edge=zone, spacing=a,
                            mode_wavenumbers=mode_q, mode_omega=mode_omega, n_sites=n_sites, ends=ends,
                            units=unit)
