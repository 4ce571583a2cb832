"""Dispersion of chains and their continuum limit, the wave equation (seed 003 eqs. 162-165).

A uniform chain of masses m, springs kappa and spacing dx obeys (eq. 162)
u_i'' = Omega^2 (u_{i+1} - 2 u_i + u_{i-1}), Omega = sqrt(kappa / m). As dx -> 0 with
c = Omega dx fixed (eq. 164) this becomes the wave equation u_tt = c^2 u_xx (eq. 165).
This module gives

- dispersion omega(q), group velocity and band edges of monatomic and diatomic chains,
  and the assignment of a finite chain's modes to wavenumbers;
- the continuum rod / string modes for each end condition and a convergence study of the
  chain's lowest modes towards them, with the order fitted from the data;
- a Gaussian pulse on a long uniform chain, propagated exactly in the chain's own Fourier
  basis (FFT, DCT or DST), against d'Alembert's solution, showing dispersive spreading.

Lengths, times and frequencies are in any consistent unit system (the chains' own).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
import scipy.fft
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra.chains import (ENDS, _bloch_eigenvalues, _bloch_root, _pair, _positive_scalar, _site_count,
                          _values, diatomic_band_edges)
from vibra.modes import Modes
from vibra._frozen import _freeze_arrays

__all__ = [
    "dispersion",
    "group_velocity",
    "band_edges",
    "wave_speed",
    "assign_wavenumbers",
    "continuum_frequencies",
    "continuum_length",
    "ConvergenceStudy",
    "convergence_study",
    "PulseResult",
    "gaussian_pulse",
    "PulseStudy",
    "pulse_study",
]

Ends = Literal["free", "fixed", "periodic"]


def _chain_parameters(masses: ArrayLike, stiffness: ArrayLike) -> tuple[int, float, float, float, float]:
    """(n_branches, m1, m2, k1, k2) from one value (monatomic) or pairs (diatomic)."""
    mass_array = _values(masses, "masses")
    k_array = _values(stiffness, "stiffness")
    diatomic = (mass_array.ndim == 1 and mass_array.shape[0] != 1) or (k_array.ndim == 1 and k_array.shape[0] != 1)
    if not diatomic:
        m = _positive_scalar(mass_array.reshape(()), "masses", "mass")
        k = _positive_scalar(k_array.reshape(()), "stiffness", "spring constant")
        return 1, m, m, k, k
    m1, m2 = _pair(mass_array, "masses", "mass")
    k1, k2 = _pair(k_array, "stiffness", "spring constant")
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
    """
    q_array = np.atleast_1d(_values(q, "q"))
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    a = _positive_scalar(spacing, "spacing", "spacing")
    if n_branches == 1:
        return (2.0 * np.sqrt(k1 / m1) * np.abs(np.sin(0.5 * q_array * a)))[None, :]
    low, high = _bloch_eigenvalues(2.0 * a * q_array, m1, m2, k1, k2)
    return np.sqrt(np.stack([low, high]))


def group_velocity(q: ArrayLike, *, masses: ArrayLike = 1.0, stiffness: ArrayLike = 1.0, spacing: float = 1.0
                   ) -> NDArray[np.float64]:
    """(n_branches, n_q) group velocities d omega / d q, in length per time unit.

    Analytic derivative of `dispersion`; at q = 0 the acoustic branch gives its right
    derivative, the sound speed (Omega dx for a monatomic chain,
    2 dx sqrt(k1 k2 / ((k1 + k2)(m1 + m2))) for a diatomic one).
    """
    q_array = np.atleast_1d(_values(q, "q"))
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    a = _positive_scalar(spacing, "spacing", "spacing")
    sign = np.where(q_array >= 0, 1.0, -1.0)
    if n_branches == 1:
        return (np.sqrt(k1 / m1) * a * np.cos(0.5 * q_array * a) * sign)[None, :]
    cell = 2.0 * a
    half = 0.5 * q_array * cell
    total = (k1 + k2) * (m1 + m2) / (m1 * m2)
    coupling = 4.0 * k1 * k2 / (m1 * m2)
    root = _bloch_root(q_array * cell, m1, m2, k1, k2)
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
    """
    n_branches, m1, m2, k1, k2 = _chain_parameters(masses, stiffness)
    if n_branches == 1:
        return np.array([[0.0, 2.0 * np.sqrt(k1 / m1)]])
    return diatomic_band_edges((m1, m2), (k1, k2))


def wave_speed(mass: float, stiffness: float, spacing: float) -> float:
    """c = Omega dx = sqrt(stiffness / mass) * spacing (eq. 164), in length per time unit."""
    m = _positive_scalar(mass, "mass", "mass")
    k = _positive_scalar(stiffness, "stiffness", "spring constant")
    a = _positive_scalar(spacing, "spacing", "spacing")
    return float(np.sqrt(k / m) * a)


def continuum_length(n: int, spacing: float, *, ends: Ends = "free") -> float:
    """Length L of the rod or string a chain of n sites stands for.

    Free and periodic ends L = n dx (each site owns one spacing); fixed ends L = (n + 1) dx
    (the walls are one spacing beyond the end masses).
    """
    n = _site_count(n, "n", 2)
    a = _positive_scalar(spacing, "spacing", "spacing")
    _validate.choice(ends, "ends", ENDS)
    return (n + 1) * a if ends == "fixed" else n * a


def continuum_frequencies(n_modes: int, *, length: float = 1.0, wave_speed: float = 1.0, ends: Ends = "free"
                          ) -> NDArray[np.float64]:
    """(n_modes,) lowest normal frequencies of a rod or string u_tt = c^2 u_xx, ascending.

    Free-free omega_k = k pi c / L (k = 0, 1, ...), fixed-fixed k pi c / L (k = 1, 2, ...),
    periodic 2 pi j c / L with j = 0, 1, 1, 2, 2, ... (cos and sin pairs).
    """
    count = _validate.count(n_modes, "n_modes", low=1, high=np.iinfo(np.int64).max)
    L = _positive_scalar(length, "length", "length")
    c = _positive_scalar(wave_speed, "wave_speed", "speed")
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
    """
    _validate.choice(ends, "ends", ENDS)
    a = _positive_scalar(spacing, "spacing", "spacing")
    per_cell = _validate.count(sites_per_cell, "sites_per_cell", low=1, high=2)
    if isinstance(modes, Modes):
        n = modes.n_dof
        count = modes.n_modes
        nodes = _sign_changes(modes.shapes, ends == "periodic") if modes.shapes is not None else None
    else:
        omega = _validate.real_array(modes, "modes", ndim=1)
        if n_sites is None:
            raise ValueError("n_sites is required when modes is an array of frequencies")
        n = _site_count(n_sites, "n_sites", 2)
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


# ---------------------------------------------------------------------- convergence study
@dataclass(frozen=True, eq=False)
class ConvergenceStudy:
    """The lowest modes of uniform chains of N sites against the continuum, L fixed.

    Attributes
    ----------
    modes : (n_k,) ndarray of int
        Continuum mode labels k (free and fixed ends: omega = k pi c / L; periodic:
        omega = 2 pi k c / L).
    n_sites : (n_N,) ndarray of int
        The chain sizes N.
    ends : str
        End conditions.
    length : float
        L, in length units.
    wave_speed : float
        c = Omega dx, in length per time unit.
    omega_chain : (n_N, n_k) ndarray
        The chains' frequencies, in rad per time unit.
    omega_continuum : (n_k,) ndarray
        The continuum frequencies, in rad per time unit.
    errors : (n_N, n_k) ndarray
        Signed relative errors omega_chain / omega_continuum - 1 (dimensionless).
    order : (n_k,) ndarray
        p from a least-squares fit log|error| = log C - p log(L / dx) (expected: 2), where
        L / dx is N (free, periodic) or N + 1 (fixed).
    coefficient : (n_k,) ndarray
        C of that fit (free and fixed ends: expected (k pi)^2 / 24).
    solver : str
        How the chains were solved: the `Modes.solver` of the runs, or "closed form".
    """

    modes: NDArray[np.int64]
    n_sites: NDArray[np.int64]
    ends: str
    length: float
    wave_speed: float
    omega_chain: NDArray[np.float64]
    omega_continuum: NDArray[np.float64]
    errors: NDArray[np.float64]
    order: NDArray[np.float64]
    coefficient: NDArray[np.float64]
    solver: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def expected_coefficient(self) -> NDArray[np.float64]:
        """(n_k,) leading coefficient of |error| N^2 from the small-angle expansion.

        Free and fixed ends (k pi)^2 / 24, periodic (2 k pi)^2 / 24, from
        sin(x) / x - 1 = -x^2 / 6 + ...; shown beside the measured `coefficient`.
        """
        factor = 2.0 if self.ends == "periodic" else 1.0
        return ((factor * self.modes * np.pi) ** 2 / 24.0).astype(np.float64)

    def n_for_error(self, target: float) -> NDArray[np.int64]:
        """(n_k,) smallest N the fit predicts for |error| <= target (dimensionless)."""
        goal = _positive_scalar(target, "target", "error")
        resolution = np.ceil((self.coefficient / goal) ** (1.0 / self.order)).astype(np.int64)
        return resolution - (1 if self.ends == "fixed" else 0)


def _chain_sizes(n_sites: object) -> NDArray[np.int64]:
    """(n_N,) strictly increasing int chain sizes, at least two (a fit needs two distinct N)."""
    sizes = np.asarray(n_sites)
    if sizes.ndim != 1 or sizes.size < 2 or not np.issubdtype(sizes.dtype, np.integer):
        raise ValueError(f"n_sites must be a 1-D sequence of at least two int sizes, got {n_sites!r}")
    _increasing(sizes, "n_sites", "sizes")
    return sizes


def _increasing(values: NDArray[np.generic], name: str, what: str) -> None:
    """Raise naming the first entry of `values` that is not above the one before it."""
    step = np.diff(values)
    if (step <= 0).any():
        i = int(np.argmax(step <= 0)) + 1
        raise ValueError(f"{name}[{i}] is {values[i].item()!r} <= {name}[{i - 1}] = {values[i - 1].item()!r}; "
                         f"{what} must increase")


def _fit_power(n_sites: NDArray[np.float64], errors: NDArray[np.float64]) -> tuple[float, float]:
    """(p, C) of |error| = C N^-p by least squares in log-log."""
    x = np.log(n_sites)
    y = np.log(np.abs(errors))
    slope, intercept = np.polyfit(x, y, 1)
    return float(-slope), float(np.exp(intercept))


def convergence_study(
    modes: Sequence[int] | ArrayLike,
    n_sites: Sequence[int] | ArrayLike,
    *,
    ends: Ends = "free",
    length: float = 1.0,
    wave_speed: float = 1.0,
    method: Literal["modes", "closed form"] = "modes",
    accuracy: Literal["high", "fast"] = "high",
) -> ConvergenceStudy:
    """Error of a chain's lowest modes against the rod or string as N grows, L fixed.

    For each N the chain has spacing dx = L / N (free, periodic) or L / (N + 1) (fixed),
    Omega = c / dx and unit masses; its frequencies are computed by
    ``linear_chain(...).modes(n_modes, accuracy=accuracy)`` (free, fixed) or
    `vibra.chains.periodic_modes` (periodic), or by the closed form with
    ``method="closed form"``. The order is then fitted, not assumed.

    Parameters
    ----------
    modes : (n_k,) sequence of int
        Continuum mode labels k >= 1 (the zero mode of free and periodic chains has no
        relative error).
    n_sites : (n_N,) sequence of int
        Chain sizes, each >= 2 and large enough to hold mode k.
    ends : {"free", "fixed", "periodic"}
        End conditions of the chain and of the continuum.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    method : {"modes", "closed form"}
        Solve the chains, or evaluate `vibra.chains.monatomic_frequencies`.
    accuracy : {"high", "fast"}
        Passed to `System.modes` for free and fixed chains.

    Returns
    -------
    ConvergenceStudy

    Raises
    ------
    ValueError
        A mode label < 1, fewer than two sizes, a size too small for the modes, bad length,
        speed, ends or method.
    """
    from vibra import chains

    ks = np.asarray(modes)
    if ks.ndim != 1 or ks.size == 0 or not np.issubdtype(ks.dtype, np.integer):
        raise ValueError(f"modes must be a 1-D sequence of int mode labels, got {modes!r}")
    if (ks < 1).any():
        i = int(np.argmax(ks < 1))
        raise ValueError(f"modes[{i}] is {ks[i]}; mode labels start at 1 (the zero mode has no relative error)")
    sizes = _chain_sizes(n_sites)
    _validate.choice(ends, "ends", ENDS)
    L = _positive_scalar(length, "length", "length")
    c = _positive_scalar(wave_speed, "wave_speed", "speed")
    _validate.choice(method, "method", ("modes", "closed form"))
    _validate.choice(accuracy, "accuracy", ("high", "fast"))
    # Position of continuum mode k in the chain's ascending spectrum.
    position = 2 * ks - 1 if ends == "periodic" else (ks if ends == "free" else ks - 1)
    small = sizes < max(int(position.max()) + 1, 2)
    if small.any():
        i = int(np.argmax(small))
        raise ValueError(f"n_sites[{i}] is {sizes[i]}; it must be >= {max(int(position.max()) + 1, 2)} "
                         "to hold the requested modes")
    omega_continuum = ks * np.pi * c / L * (2.0 if ends == "periodic" else 1.0)
    omega_chain = np.empty((sizes.size, ks.size))
    solvers: set[str] = set()
    for row, n in enumerate(sizes):
        n = int(n)
        dx = L / (n + 1) if ends == "fixed" else L / n
        stiffness = (c / dx) ** 2  # unit masses: Omega = c / dx
        wanted = int(position.max()) + 1
        if method == "closed form":
            omega = chains.monatomic_frequencies(n, 1.0, stiffness, ends=ends)[:wanted]
            solvers.add("closed form")
        else:
            system = chains.linear_chain(n, mass=1.0, stiffness=stiffness, spacing=dx, ends=ends,
                                         units="dimensionless")
            if ends == "periodic":
                result = chains.periodic_modes(system, n_modes=wanted, vectors=False)
            else:
                result = system.modes(n_modes=wanted, accuracy=accuracy, vectors=False)
            omega = result.omega
            solvers.add(result.solver)
        omega_chain[row] = omega[position]
    errors = omega_chain / omega_continuum[None, :] - 1.0
    resolution = sizes.astype(float) + (1.0 if ends == "fixed" else 0.0)  # L / dx
    fits = [_fit_power(resolution, errors[:, i]) for i in range(ks.size)]
    return ConvergenceStudy(
        modes=ks.astype(np.int64), n_sites=sizes.astype(np.int64), ends=ends, length=L, wave_speed=c,
        omega_chain=omega_chain, omega_continuum=omega_continuum, errors=errors,
        order=np.array([f[0] for f in fits]), coefficient=np.array([f[1] for f in fits]),
        solver=", ".join(sorted(solvers)),
    )


# ---------------------------------------------------------------------- pulses
@dataclass(frozen=True, eq=False)
class PulseResult:
    """A Gaussian pulse on a uniform chain against d'Alembert's solution of eq. 165.

    Attributes
    ----------
    x : (n_sites,) ndarray
        Site positions in the continuum's frame [0, L], in length units.
    t : (n_t,) ndarray
        Times, in time units.
    chain : (n_t, n_sites) ndarray
        Displacements of the chain (exact modal propagation), in the pulse's amplitude unit.
    continuum : (n_t, n_sites) ndarray
        d'Alembert's solution at the sites (images for the ends).
    error : (n_t,) ndarray
        max |chain - continuum| / amplitude at each time (dimensionless).
    spacing : float
        dx, in length units.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    width : float
        Standard deviation sigma of the Gaussian, in length units.
    center : float
        Initial centre x0, in length units.
    amplitude : float
        Peak displacement at t = 0.
    ends : str
        End conditions.
    """

    x: NDArray[np.float64]
    t: NDArray[np.float64]
    chain: NDArray[np.float64]
    continuum: NDArray[np.float64]
    error: NDArray[np.float64]
    spacing: float
    length: float
    wave_speed: float
    width: float
    center: float
    amplitude: float
    ends: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    @property
    def n_sites(self) -> int:
        """Number of sites of the chain."""
        return int(self.x.shape[0])


def _gaussian(y: NDArray[np.float64], width: float) -> NDArray[np.float64]:
    return np.exp(-0.5 * (y / width) ** 2)


def _images(x: NDArray[np.float64], shift: float, center: float, width: float, L: float, ends: str
            ) -> NDArray[np.float64]:
    """d'Alembert's right-moving pulse f(x - c t) with the images that enforce the ends."""
    period = L if ends == "periodic" else 2.0 * L
    total = np.zeros_like(x)
    for m in range(-2, 3):  # a pulse of width <= L / 10 needs only the nearest images
        total += _gaussian(x - shift - center + m * period, width)
        if ends != "periodic":
            mirror = _gaussian(-x - shift - center + m * period, width)
            total += mirror if ends == "free" else -mirror
    return total


def gaussian_pulse(
    n_sites: int,
    times: ArrayLike,
    *,
    width: float,
    center: float | None = None,
    length: float = 1.0,
    wave_speed: float = 1.0,
    amplitude: float = 1.0,
    ends: Ends = "periodic",
) -> PulseResult:
    """Launch a right-moving Gaussian pulse on a uniform chain and compare with d'Alembert.

    The chain has n_sites unit masses with dx = L / n (free, periodic) or L / (n + 1)
    (fixed) and Omega = c / dx; site i sits at x_i = i dx (periodic), (i + 1/2) dx (free) or
    (i + 1) dx (fixed) in the continuum's frame [0, L]. Initial data u_i = f(x_i),
    u_i' = -c f'(x_i) with f(x) = amplitude exp(-(x - x0)^2 / 2 sigma^2): the continuum
    solution is f(x - c t) (with mirror images at free or fixed ends). The chain is
    propagated exactly in its own normal modes (FFT for periodic ends, DCT-II for free,
    DST-I for fixed: O(N log N) per time), so the difference is the chain's dispersion,
    to leading order -(c t dx^2 / 24) f'''(x - c t) + (dx^2 / 48)(f''(x + c t) - f''(x - c t)).

    Parameters
    ----------
    n_sites : int
        Number of masses, >= 2.
    times : float or (n_t,) array_like
        Times >= 0, in time units.
    width : float
        sigma, in length units, at most L / 10 (so that its images are negligible).
    center : float, optional
        x0 in [0, L], in length units; L / 4 by default.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    amplitude : float
        Peak displacement at t = 0.
    ends : {"periodic", "free", "fixed"}
        End conditions.

    Returns
    -------
    PulseResult

    Raises
    ------
    ValueError
        n_sites < 2, negative times, width not in (0, L / 10], center outside [0, L], a
        non-positive length, speed or amplitude, unknown ends.
    """
    n = _site_count(n_sites, "n_sites", 2)
    t = np.atleast_1d(_values(times, "times"))
    if (t < 0).any():
        i = int(np.argmax(t < 0))
        raise ValueError(f"times[{i}] is {float(t[i])!r}; every time must be >= 0")
    L = _positive_scalar(length, "length", "length")
    sigma = _positive_scalar(width, "width", "width")
    if sigma > 0.1 * L:
        raise ValueError(f"width is {sigma!r}; it must be <= length / 10 = {0.1 * L!r}")
    x0 = 0.25 * L if center is None else _validate.real_scalar(center, "center")
    if not 0.0 <= x0 <= L:
        raise ValueError(f"center is {x0!r}; it must lie in [0, length] = [0, {L!r}]")
    c = _positive_scalar(wave_speed, "wave_speed", "speed")
    amp = _positive_scalar(amplitude, "amplitude", "amplitude")
    _validate.choice(ends, "ends", ENDS)
    dx = L / (n + 1) if ends == "fixed" else L / n
    offset = {"periodic": 0.0, "free": 0.5, "fixed": 1.0}[ends]
    x = ((np.arange(n) + offset) * dx).astype(np.float64)
    u0 = amp * _images(x, 0.0, x0, sigma, L, ends)
    # v0 = -c f'(x) of the same image sum: f' of a Gaussian is -(y / sigma^2) f.
    v0 = np.zeros(n)
    period = L if ends == "periodic" else 2.0 * L
    for m in range(-2, 3):
        y = x - x0 + m * period
        v0 += c * amp * y / sigma**2 * _gaussian(y, sigma)
        if ends != "periodic":
            y_mirror = -x - x0 + m * period
            # mirror image g(x) = +-f(-x) moves left: its velocity is +c g'(x) = -+c f'(-x),
            # and -c f'(-x) = c (y_mirror / sigma^2) f(-x) with y_mirror = -x - x0.
            mirror_velocity = c * amp * y_mirror / sigma**2 * _gaussian(y_mirror, sigma)
            v0 += mirror_velocity if ends == "free" else -mirror_velocity
    Omega = c / dx
    index = np.arange(n)
    if ends == "periodic":
        omega = 2.0 * Omega * np.sin(np.pi * np.minimum(index, n - index) / n)
        forward, backward = (lambda v: scipy.fft.rfft(v)), (lambda v: scipy.fft.irfft(v, n))
        omega = omega[: n // 2 + 1]
    elif ends == "free":
        omega = 2.0 * Omega * np.sin(index * np.pi / (2 * n))
        forward = lambda v: scipy.fft.dct(v, type=2, norm="ortho")  # noqa: E731
        backward = lambda v: scipy.fft.idct(v, type=2, norm="ortho")  # noqa: E731
    else:
        omega = 2.0 * Omega * np.sin((index + 1) * np.pi / (2 * (n + 1)))
        forward = lambda v: scipy.fft.dst(v, type=1, norm="ortho")  # noqa: E731
        backward = lambda v: scipy.fft.idst(v, type=1, norm="ortho")  # noqa: E731
    u_hat, v_hat = forward(u0), forward(v0)
    chain = np.empty((t.size, n))
    continuum = np.empty((t.size, n))
    for row, time in enumerate(t):
        # sin(w t) / w = t sinc(w t / pi): continuous at the zero mode.
        chain[row] = backward(u_hat * np.cos(omega * time) + v_hat * time * np.sinc(omega * time / np.pi))
        continuum[row] = amp * _images(x, c * time, x0, sigma, L, ends)
    error = np.max(np.abs(chain - continuum), axis=1) / amp
    return PulseResult(x=x, t=t, chain=chain, continuum=continuum, error=error, spacing=dx, length=L,
                       wave_speed=c, width=sigma, center=x0, amplitude=amp, ends=ends)


@dataclass(frozen=True, eq=False)
class PulseStudy:
    """Pulse error against d'Alembert for several chain sizes and pulse widths.

    Attributes
    ----------
    n_sites : (n_N,) ndarray of int
        Chain sizes.
    widths : (n_w,) ndarray
        Pulse widths sigma, in length units.
    time : float
        The time of the comparison, in time units.
    errors : (n_N, n_w) ndarray
        max |chain - continuum| / amplitude at `time` (dimensionless).
    order_in_n : (n_w,) ndarray
        p of a log-log fit error ~ N^-p at each width (expected 2).
    order_in_width : (n_N,) ndarray
        s of a log-log fit error ~ sigma^-s at each N (expected 3 while c t >> sigma).
    ends : str
        End conditions.
    """

    n_sites: NDArray[np.int64]
    widths: NDArray[np.float64]
    time: float
    errors: NDArray[np.float64]
    order_in_n: NDArray[np.float64]
    order_in_width: NDArray[np.float64]
    ends: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)


def pulse_study(n_sites: Sequence[int] | ArrayLike, widths: Sequence[float] | ArrayLike, *, time: float,
                length: float = 1.0, wave_speed: float = 1.0, ends: Ends = "periodic") -> PulseStudy:
    """`gaussian_pulse` error at one time for every (N, width), with fitted orders.

    Parameters
    ----------
    n_sites : (n_N,) sequence of int
        Chain sizes, at least two, strictly increasing.
    widths : (n_w,) array_like
        Pulse widths sigma, at least two, strictly increasing, each <= length / 10, in
        length units.
    time : float
        Time of the comparison, > 0, in time units.
    length : float
        L, in length units.
    wave_speed : float
        c, in length per time unit.
    ends : {"periodic", "free", "fixed"}
        End conditions.

    Returns
    -------
    PulseStudy

    Raises
    ------
    ValueError
        Fewer than two sizes or two widths, sizes or widths not increasing, time not
        positive, or any argument `gaussian_pulse` rejects.
    """
    sizes = _chain_sizes(n_sites)
    sigma = _validate.real_array(widths, "widths", ndim=1)
    if sigma.size < 2:
        raise ValueError(f"widths must hold at least two widths, got {sigma.size}")
    _increasing(sigma, "widths", "widths")
    time = _positive_scalar(time, "time", "comparison time")  # the error at t = 0 is 0: no fit
    errors = np.array([[gaussian_pulse(int(n), [time], width=float(s), length=length, wave_speed=wave_speed,
                                       ends=ends).error[0] for s in sigma] for n in sizes])
    order_n = np.array([_fit_power(sizes.astype(float), errors[:, j])[0] for j in range(sigma.size)])
    order_w = np.array([_fit_power(sigma, errors[i, :])[0] for i in range(sizes.size)])
    return PulseStudy(n_sites=sizes.astype(np.int64), widths=sigma, time=float(time), errors=errors,
                      order_in_n=order_n, order_in_width=order_w, ends=ends)
