"""Elastic network models of proteins: ANM and GNM builders, fluctuations and B-factors.

Both models join every pair of sites (usually C-alpha atoms) closer than a cutoff by a
spring whose rest length is their distance in the structure:

- `anm` — anisotropic network model: 3-D springs, K = sum_ij gamma_ij e_ij e_ij^T blocks
  (`System.from_springs`), ProDy's ``ANM.buildHessian``. 6 rigid-body zero modes for a
  connected network (5 for two sites; 2 n + 1 for n > 2 collinear sites).
- `gnm` — Gaussian network model: one scalar dof per site, the Kirchhoff matrix
  Gamma_ij = -gamma_ij, Gamma_ii = sum_j gamma_ij (ProDy's ``GNM.buildKirchhoff``).

Units: positions in Å, gamma in energy / Å^2 (any energy unit; kcal/mol/Å^2 when a
`temperature` in kelvin is given), masses dimensionless (1 by default, as in ProDy). The
systems carry the ``"dimensionless"`` unit system: omega^2 is in gamma / mass units.

Thermal fluctuations (classical equipartition, rigid modes left out):

    <u_i^2> = kT sum_k |u_k(i)|^2 / omega_k^2,        B_i = 8 pi^2 / 3 <|Delta R_i|^2>,

with u_k the M-orthonormal shapes (`Modes.shapes`): the sum over all non-rigid modes is
kT diag(M^-1/2 pinv(K~) M^-1/2), so masses only set the rigid-body frame left out. For the
scalar GNM, <|Delta R_i|^2> = 3 <u_i^2> (isotropic), so B_i = 8 pi^2 <u_i^2>.

Structures come from `vibra.networks.pdb.from_pdb` (re-exported by `vibra.networks`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Literal, Union

import numpy as np
import scipy.constants
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.modes import Modes
from vibra.system import System, Vibrating

__all__ = [
    "Fluctuations", "contact_pairs", "anm", "gnm", "fluctuations", "square_fluctuations", "predicted_b_factors",
    "b_factor_correlation", "BOLTZMANN_KCAL_PER_MOL", "RIGID_RTOL",
]

#: Boltzmann's constant in kcal/mol/K (R / 4184 J/kcal), for `temperature=` with gamma in
#: kcal/mol/Å^2.
BOLTZMANN_KCAL_PER_MOL = scipy.constants.R / (1000.0 * scipy.constants.calorie)

#: A mode is rigid (a zero mode) when omega^2 <= RIGID_RTOL * max diag(K~): far above the
#: rounding of a solver (~1e-13 relative) and far below the softest real mode of a protein
#: network (~1e-3 relative for 2,000 C-alpha sites).
RIGID_RTOL = 1e-8

#: gamma: one stiffness, one per pair of `contact_pairs`, or a function gamma(i, j, distance).
Gamma = Union[float, ArrayLike, Callable[[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]], ArrayLike]]

# ---------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class Fluctuations(Frozen):
    """Thermal mean-square fluctuations of the sites of a network, and predicted B-factors.

    Attributes
    ----------
    square : (n_sites,) ndarray
        <u_i^2> = kT sum_k |u_k(i)|^2 / omega_k^2 over the modes used, summed over the
        modelled dofs of site i (3 for ANM, 1 for GNM), in Å^2 (0 at frozen sites).
    b_factors : (n_sites,) ndarray
        Predicted B-factors 8 pi^2 / 3 <|Delta R|^2>, in Å^2 (`predicted_b_factors`).
    eigenvalues : (n_used,) ndarray
        omega^2 of the non-rigid modes summed, ascending, in gamma / mass units.
    n_rigid : int
        Rigid (zero) modes found and left out.
    kT : float
        The thermal energy used, in the energy unit of gamma.
    complete : bool
        True when every non-rigid mode was summed; False for a truncated sum (lowest modes
        only), which underestimates <u^2> by the omitted stiff modes' share.
    """

    square: NDArray[np.float64]
    b_factors: NDArray[np.float64]
    eigenvalues: NDArray[np.float64]
    n_rigid: int
    kT: float
    complete: bool

    def correlation(self, experimental: ArrayLike) -> float:
        """Pearson correlation of `b_factors` with measured B-factors (`b_factor_correlation`)."""
        return b_factor_correlation(self.b_factors, experimental)


# ---------------------------------------------------------------------- builders
def contact_pairs(positions: ArrayLike, cutoff: float) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Site pairs closer than `cutoff`, from a k-d tree (O(n_sites) for a protein).

    Parameters
    ----------
    positions : (n_sites, dim) array_like
        Coordinates, in Å (dim 1, 2 or 3).
    cutoff : float
        Largest distance of a contact, in Å (> 0); a pair at exactly `cutoff` is a contact.

    Returns
    -------
    pairs, distances : (n_pairs, 2) ndarray of int, (n_pairs,) ndarray
        Pairs (i, j), i < j, sorted by i then j, and their distances in Å.

    Raises
    ------
    ValueError
        positions not (n_sites, dim), n_sites >= 2, finite; cutoff <= 0; coincident sites.
    """
    coordinates = _site_positions(positions)
    radius = _validate.positive_scalar(cutoff, "cutoff", "cutoff distance")
    pairs = cKDTree(coordinates).query_pairs(radius, output_type="ndarray").astype(np.intp)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if pairs.size else np.zeros((0, 2), np.intp)
    distances = np.linalg.norm(coordinates[pairs[:, 1]] - coordinates[pairs[:, 0]], axis=1)
    scale = max(float(np.abs(coordinates).max()), 1.0)
    same = distances <= 1e-12 * scale
    if same.any():
        i, j = (int(x) for x in pairs[int(np.argmax(same))])
        raise ValueError(f"positions[{i}] and positions[{j}] coincide; every site needs its own position")
    return pairs, distances


def anm(positions: ArrayLike, cutoff: float = 15.0, gamma: Gamma = 1.0, masses: ArrayLike | None = None,
        *, name: str = "anm") -> System:
    """Anisotropic network model: a 3-D spring of stiffness gamma between sites within `cutoff`.

    Parameters
    ----------
    positions : (n_sites, 3) array_like
        Site coordinates (C-alpha atoms, say), in Å; (n_sites, 2) builds a planar network.
    cutoff : float
        Contact distance, in Å (ProDy's default 15 Å).
    gamma : float, (n_pairs,) array_like or callable
        Spring constants, in energy / Å^2: one for all springs, one per pair of
        `contact_pairs(positions, cutoff)` in its order, or a function ``gamma(i, j, distance)``
        of the pair arrays returning (n_pairs,) stiffnesses.
    masses : (n_sites,) array_like, optional
        Site masses (dimensionless; 1 by default, as in ProDy). They change the frequencies
        and the rigid-body frame of the fluctuations.
    name : str
        Name used in reports.

    Raises
    ------
    ValueError
        Bad positions (shape, fewer than 2 sites, not finite, coincident sites); cutoff <= 0;
        gamma <= 0, not finite or of the wrong length; masses not positive; no pair of
        sites within the cutoff.

    Examples
    --------
    >>> from vibra import networks
    >>> tetrahedron = [[0, 0, 0], [3.8, 0, 0], [1.9, 3.3, 0], [1.9, 1.1, 3.1]]
    >>> int((networks.anm(tetrahedron).modes().omega ** 2 < 1e-9).sum())
    6
    """
    coordinates = _site_positions(positions)
    if coordinates.shape[1] not in (2, 3):
        raise ValueError(f"positions must be (n_sites, 3) (or (n_sites, 2)) for an ANM, got shape {coordinates.shape}")
    pairs, distances = contact_pairs(coordinates, cutoff)
    stiffness = _pair_stiffness(gamma, pairs, distances, cutoff)
    site_masses = 1.0 if masses is None else masses
    return System.from_springs(coordinates, site_masses, pairs, stiffness, units="dimensionless", name=name)


def gnm(positions: ArrayLike, cutoff: float = 7.3, gamma: Gamma = 1.0, *, name: str = "gnm") -> System:
    """Gaussian network model: the Kirchhoff matrix of the contacts within `cutoff`, one dof per site.

    A 1-D `System` of unit masses whose Hessian is the Kirchhoff matrix; its `positions` are
    the site indices 0, 1, ... (the scalar model keeps no geometry beyond the contacts).

    Parameters
    ----------
    positions : (n_sites, dim) array_like
        Site coordinates, in Å.
    cutoff : float
        Contact distance, in Å (7.3 Å, Bahar et al.'s; ProDy's buildKirchhoff defaults to 10 Å).
    gamma : float, (n_pairs,) array_like or callable
        Spring constants, in energy / Å^2, as for `anm`.
    name : str
        Name used in reports.

    Raises
    ------
    ValueError
        As for `anm`.

    Examples
    --------
    >>> from vibra import networks
    >>> chain = [[0, 0, 0], [3.8, 0, 0], [7.6, 0, 0]]
    >>> networks.gnm(chain, cutoff=4.0).hessian().toarray()
    array([[ 1., -1.,  0.],
           [-1.,  2., -1.],
           [ 0., -1.,  1.]])
    """
    coordinates = _site_positions(positions)
    pairs, distances = contact_pairs(coordinates, cutoff)
    stiffness = _pair_stiffness(gamma, pairs, distances, cutoff)
    index = np.arange(coordinates.shape[0], dtype=float)  # 1-D springs: rows -1, +1 (i < j)
    return System.from_springs(index, 1.0, pairs, stiffness, units="dimensionless", name=name)


def _site_positions(positions: ArrayLike) -> NDArray[np.float64]:
    coordinates = _validate.real_array(positions, "positions", ndim=2)
    if coordinates.shape[1] not in (1, 2, 3):
        raise ValueError(f"positions must be (n_sites, dim) with dim 1, 2 or 3, got shape {coordinates.shape}")
    if coordinates.shape[0] < 2:
        raise ValueError(f"positions must hold at least 2 sites for a network, got {coordinates.shape[0]}")
    return coordinates


def _pair_stiffness(gamma: Gamma, pairs: NDArray[np.intp], distances: NDArray[np.float64],
                    cutoff: float) -> NDArray[np.float64]:
    if pairs.shape[0] == 0:
        raise ValueError(f"no pair of sites lies within cutoff={cutoff!r} Å; the network has no springs")
    n_pairs = pairs.shape[0]
    if callable(gamma):
        values = _validate.real_array(gamma(pairs[:, 0], pairs[:, 1], distances), "gamma(i, j, distance)",
                                      ndim=(0, 1))
        name = "gamma(i, j, distance)"
    else:
        values = _validate.real_array(gamma, "gamma", ndim=(0, 1))
        name = "gamma"
    if values.ndim == 0:
        values = np.full(n_pairs, float(values))
    if values.shape[0] != n_pairs:
        raise ValueError(f"{name} must give one spring constant per contact pair ({n_pairs} within "
                         f"cutoff={cutoff!r} Å), got {values.shape[0]}")
    _validate.positive(values, name, "spring constant")
    return values


# ---------------------------------------------------------------------- reader
# ---------------------------------------------------------------------- fluctuations
def square_fluctuations(system: System, modes: Modes, *, kT: float | None = None,
                        temperature: float | None = None, rigid_rtol: float = RIGID_RTOL) -> NDArray[np.float64]:
    """(n_sites,) <u_i^2> = kT sum_k |u_k(i)|^2 / omega_k^2 over the non-rigid modes in `modes`.

    A truncated `modes` gives a truncated sum; `fluctuations` says whether it is complete.

    Parameters
    ----------
    system : System
        The network the modes belong to (its sites and frozen dofs).
    modes : Modes
        Modes of `system` with shapes (``system.modes(...)``).
    kT : float, optional
        Thermal energy, in the energy unit of gamma (1 by default, as in ProDy).
    temperature : float, optional
        Temperature in K instead of kT, with gamma in kcal/mol/Å^2:
        kT = `BOLTZMANN_KCAL_PER_MOL` * temperature.
    rigid_rtol : float
        Modes with omega^2 <= rigid_rtol * max diag(K~) are rigid and left out.

    Returns
    -------
    (n_sites,) ndarray
        Summed over each site's dofs, in Å^2; 0 at frozen sites.

    Raises
    ------
    ValueError
        modes without shapes or of another size than system; kT or temperature <= 0, or
        both given; an unstable mode (omega^2 < 0 beyond the rigid tolerance).
    """
    thermal = _thermal_energy(kT, temperature)
    tolerance = _validate.positive_scalar(rigid_rtol, "rigid_rtol")
    square, _, _ = _mode_sums(system, modes, thermal, tolerance)
    return square


def fluctuations(system: System, n_modes: int | None = 20, *, kT: float | None = None,
                 temperature: float | None = None, rigid_rtol: float = RIGID_RTOL,
                 accuracy: Literal["high", "fast"] = "fast") -> Fluctuations:
    """Mean-square fluctuations and predicted B-factors from the lowest `n_modes` non-rigid modes.

    Parameters
    ----------
    system : System
        A network from `anm` or `gnm` (any `System` of sites works).
    n_modes : int or None
        Non-rigid modes summed (ProDy's default 20: the softest carry most of the fluctuation);
        None (or n_modes >= n_dof) sums all (a dense solve). Rigid modes are skipped, asking the solver
        for more modes until `n_modes` non-rigid ones are in hand.
    kT, temperature, rigid_rtol
        As for `square_fluctuations`.
    accuracy : {"fast", "high"}
        Passed to `System.modes`. "fast" (the default) solves K~ directly: eigenvalues to an
        absolute error ~ n eps max diag(K~), ~1e-11 relative for the softest mode of a
        2,000-site protein network, which is what ProDy computes. "high" uses the spring factor
        (relative accuracy for very soft modes) and costs more.

    Returns
    -------
    Fluctuations

    Raises
    ------
    ValueError
        n_modes < 1; kT or temperature as in `square_fluctuations`.
    """
    scale = _stiffness_scale(system)
    n_dof = system.n_dof
    wanted = None if n_modes is None else min(n_dof, _validate.count(n_modes, "n_modes", low=1, high=2**62))
    thermal = _thermal_energy(kT, temperature)
    rigid_rtol = _validate.positive_scalar(rigid_rtol, "rigid_rtol")
    if wanted is None:
        modes = system.modes(accuracy=accuracy)
    else:
        ask = min(n_dof, wanted + system.dim * (system.dim + 1) // 2)  # + rigid modes of a connected network
        while True:
            modes = system.modes(ask, accuracy=accuracy)
            n_rigid = int(_rigid(modes, scale, rigid_rtol).sum())
            if ask - n_rigid >= wanted or ask == n_dof:
                break
            ask = min(n_dof, wanted + n_rigid + 6)
    square, eigenvalues, n_rigid = _mode_sums(system, modes, thermal, rigid_rtol, keep=n_modes, scale=scale)
    complete = n_rigid + eigenvalues.shape[0] == n_dof
    return Fluctuations(square=square, b_factors=predicted_b_factors(square, dofs_per_site=system.dim),
                        eigenvalues=eigenvalues, n_rigid=n_rigid, kT=thermal, complete=complete)


def predicted_b_factors(square: ArrayLike, *, dofs_per_site: int = 3) -> NDArray[np.float64]:
    """(n_sites,) B = 8 pi^2 / 3 <|Delta R|^2>, in Å^2 for <u^2> in Å^2.

    Parameters
    ----------
    square : (n_sites,) array_like
        Mean-square fluctuations summed over the modelled dofs of each site, in Å^2.
    dofs_per_site : {1, 2, 3}
        Dofs modelled per site: 3 for ANM (<|Delta R|^2> = square); 1 for the scalar GNM,
        whose fluctuation is taken as isotropic (<|Delta R|^2> = 3 square, so B = 8 pi^2
        square); 2 for a planar network (<|Delta R|^2> = 3/2 square).

    Raises
    ------
    ValueError
        square not 1-D, negative or not finite; dofs_per_site not 1, 2 or 3.
    """
    values = _validate.real_array(square, "square", ndim=1)
    _validate.nonnegative(values, "square", "mean-square fluctuation")
    dofs = _validate.count(dofs_per_site, "dofs_per_site", low=1, high=3)
    return 8.0 * np.pi**2 / 3.0 * (3.0 / dofs) * values


def b_factor_correlation(predicted: ArrayLike, experimental: ArrayLike) -> float:
    """Pearson correlation coefficient of predicted and measured B-factors (dimensionless).

    Raises
    ------
    ValueError
        Not 1-D, of different lengths, fewer than 2 sites, not finite, or constant (the
        correlation is undefined).
    """
    left = _validate.real_array(predicted, "predicted", ndim=1)
    right = _validate.real_array(experimental, "experimental", ndim=1)
    if left.shape != right.shape:
        raise ValueError(f"predicted has {left.shape[0]} sites but experimental has {right.shape[0]}")
    if left.shape[0] < 2:
        raise ValueError(f"a correlation needs at least 2 sites, got {left.shape[0]}")
    left = left - left.mean()
    right = right - right.mean()
    for values, name in ((left, "predicted"), (right, "experimental")):
        if not np.any(values):
            raise ValueError(f"{name} is constant; its correlation is undefined")
    return float(left @ right / np.sqrt((left @ left) * (right @ right)))


def _thermal_energy(kT: float | None, temperature: float | None) -> float:
    if kT is not None and temperature is not None:
        raise ValueError("give kT or temperature, not both")
    if temperature is not None:
        return float(BOLTZMANN_KCAL_PER_MOL * _validate.positive_scalar(temperature, "temperature", "temperature"))
    return 1.0 if kT is None else _validate.positive_scalar(kT, "kT", "thermal energy")


def _stiffness_scale(system: System) -> float:
    """max diag(K~) = max K_ii / m_i, in omega^2 units."""
    if not isinstance(system, Vibrating):
        raise TypeError(f"system must be a vibra System, got {type(system).__name__}")
    if system.is_generalized:
        raise ValueError("fluctuations need a system of sites, not one in generalised coordinates")
    return float((system.hessian().diagonal() / system.mass_matrix()).max())


def _rigid(modes: Modes, scale: float, rigid_rtol: float) -> NDArray[np.bool_]:
    """(n_modes,) True for modes with omega^2 <= rigid_rtol * scale (scale = max diag(K~))."""
    squared = modes.omega_squared
    if (squared < -rigid_rtol * scale).any():
        k = int(np.argmax(squared < -rigid_rtol * scale))
        raise ValueError(f"mode {k} is unstable (omega^2 = {squared[k]:.3g}); fluctuations need a stable network")
    return np.asarray(squared <= rigid_rtol * scale)


def _mode_sums(system: System, modes: Modes, kT: float, rigid_rtol: float, keep: int | None = None,
               scale: float | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """(<u^2> per site, omega^2 of the modes summed, number of rigid modes)."""
    if scale is None:
        scale = _stiffness_scale(system)
    if not isinstance(modes, Modes):
        raise TypeError(f"modes must be a vibra Modes, got {type(modes).__name__}")
    if modes.shapes is None:
        raise ValueError("modes have no shapes; compute them with vectors=True")
    if modes.n_dof != system.n_dof:
        raise ValueError(f"modes have {modes.n_dof} dofs but the system has {system.n_dof} free dofs")
    rigid = _rigid(modes, scale, rigid_rtol)
    used = np.flatnonzero(~rigid)
    if keep is not None:
        used = used[:keep]
    eigenvalues = modes.omega_squared[used]
    shapes = system.expand(modes.shapes[:, used])  # (n_sites * dim, n_used), 0 at frozen dofs
    per_dof = (shapes * shapes) @ (kT / eigenvalues)
    square = per_dof.reshape(system.n_sites, system.dim).sum(axis=1)
    return square, np.array(eigenvalues), int(rigid.sum())
