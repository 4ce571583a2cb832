"""Closed-form spectra of chains: monatomic, diatomic (Bloch), beaded string, mass defect.

Seed 003 section 5.3 (eqs. 159-165). The diatomic chain's 2x2 Bloch problem is solved by
`diatomic_eigenvalues` (both branches' omega^2 at a phase q a) and `diatomic_half_splitting`
(half the distance between them, without cancellation); `vibra.continuum` and
`periodic_modes` build on these two.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.chains.builders import ENDS, Ends

__all__ = [
    "monatomic_frequencies",
    "monatomic_shapes",
    "diatomic_eigenvalues",
    "diatomic_half_splitting",
    "diatomic_branches",
    "diatomic_frequencies",
    "diatomic_band_edges",
    "beaded_string_frequencies",
    "montroll_potts_frequency",
    "montroll_potts_decay",
]

_site_count = _validate.min_count
_positive_scalar = _validate.positive_scalar

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
    n = _site_count(n, "n", low=2, what="a chain")
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

    Examples
    --------
    >>> np.round(monatomic_shapes(2, ends="free") ** 2, 12)  # rigid translation, then opposition
    array([[0.5, 0.5],
           [0.5, 0.5]])
    """
    n = _site_count(n, "n", low=2, what="a chain")
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


def _branch_parameters(m1: float, m2: float, k1: float, k2: float) -> tuple[float, float, float, float]:
    return (_positive_scalar(m1, "m1", "mass"), _positive_scalar(m2, "m2", "mass"),
            _positive_scalar(k1, "k1", "spring constant"), _positive_scalar(k2, "k2", "spring constant"))


def diatomic_half_splitting(phase: ArrayLike, m1: float, m2: float, k1: float, k2: float
                            ) -> NDArray[np.float64]:
    """Half the distance between the two Bloch eigenvalues of a diatomic chain, in omega^2 units.

    sqrt(S^2/4 - 4 k1 k2 sin^2(phase/2) / (m1 m2)), S = (k1 + k2)(m1 + m2)/(m1 m2), computed
    without cancellation: with sin^2 = 1 - cos^2 the radicand is
    G + 4 k1 k2 cos^2(phase/2) / (m1 m2), where G = S^2/4 - 4 k1 k2 / (m1 m2) >= 0 is the
    squared half-gap at the zone boundary, written as a sum of non-negative terms
    ((k1 + k2)(m1 + m2) - 4 sqrt(k1 k2 m1 m2) = 2 sqrt(k1 k2)(sqrt m1 - sqrt m2)^2
    + 2 sqrt(m1 m2)(sqrt k1 - sqrt k2)^2 + (sqrt k1 - sqrt k2)^2 (sqrt m1 - sqrt m2)^2). It is
    thus accurate to a few ulps near the zone boundary, where the branches meet when the gap
    closes.

    Parameters
    ----------
    phase : float or (n_q,) array_like
        Bloch phase q a across one cell (a = cell length), in rad.
    m1, m2 : float
        The two masses of the cell.
    k1, k2 : float
        Intra-cell and inter-cell spring constants.

    Returns
    -------
    (n_q,) ndarray (0-d for a scalar phase)
        (lambda_plus - lambda_minus) / 2, in (rad per time unit)^2.

    Raises
    ------
    ValueError
        A phase not finite, a mass or spring constant not positive and finite.

    Examples
    --------
    >>> round(float(diatomic_half_splitting(np.pi, 1.0, 2.0, 1.0, 1.0)), 12)  # half the gap in omega^2
    0.5
    """
    phase_array = _validate.real_values(phase, "phase")
    m1, m2, k1, k2 = _branch_parameters(m1, m2, k1, k2)
    dm, dk = (np.sqrt(m1) - np.sqrt(m2)) ** 2, (np.sqrt(k1) - np.sqrt(k2)) ** 2
    geometric = 4.0 * np.sqrt(k1 * k2 * m1 * m2)
    excess = 2.0 * np.sqrt(k1 * k2) * dm + 2.0 * np.sqrt(m1 * m2) * dk + dk * dm
    gap = excess * ((k1 + k2) * (m1 + m2) + geometric) / (4.0 * (m1 * m2) ** 2)
    return np.asarray(np.sqrt(gap + 4.0 * k1 * k2 * np.cos(0.5 * phase_array) ** 2 / (m1 * m2)))


def diatomic_eigenvalues(phase: ArrayLike, m1: float, m2: float, k1: float, k2: float
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lambda_minus, lambda_plus): omega^2 of both branches of the diatomic Bloch problem.

    The cell m1 -k1- m2 -k2- at Bloch phase q a has lambda = S/2 -+ h with S = (k1 + k2)(m1
    + m2)/(m1 m2) and h = `diatomic_half_splitting`. lambda_minus is computed as
    det / lambda_plus (det = 4 k1 k2 sin^2(phase/2) / (m1 m2)), which keeps the acoustic
    branch accurate to a few ulps relative near q = 0.

    Parameters
    ----------
    phase, m1, m2, k1, k2
        As in `diatomic_half_splitting`.

    Returns
    -------
    lambda_minus, lambda_plus : (n_q,) ndarray (NumPy scalars for a scalar phase)
        Acoustic and optical omega^2, in (rad per time unit)^2.

    Raises
    ------
    ValueError
        As `diatomic_half_splitting`.

    Examples
    --------
    >>> low, high = diatomic_eigenvalues(np.pi, 1.0, 2.0, 1.0, 1.0)
    >>> float(low), float(high)  # zone boundary: 2 k / m2 and 2 k / m1
    (1.0, 2.0)
    """
    phase_array = _validate.real_values(phase, "phase")
    m1, m2, k1, k2 = _branch_parameters(m1, m2, k1, k2)
    total = (k1 + k2) * (m1 + m2) / (m1 * m2)
    product = 4.0 * k1 * k2 * np.sin(0.5 * phase_array) ** 2 / (m1 * m2)
    upper = 0.5 * total + diatomic_half_splitting(phase_array, m1, m2, k1, k2)
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

    Examples
    --------
    >>> acoustic, optical = diatomic_branches([0.0, np.pi / 2], 1.0, 2.0, 1.0, 1.0, cell_length=2.0)
    >>> np.round(acoustic ** 2, 12), np.round(optical ** 2, 12)  # q = 0 and the zone edge
    (array([0., 1.]), array([3., 2.]))
    """
    q_array = _validate.real_values(q, "q")
    m1, m2, k1, k2 = _branch_parameters(m1, m2, k1, k2)
    a = _positive_scalar(cell_length, "cell_length", "length")
    low, high = diatomic_eigenvalues(q_array * a, m1, m2, k1, k2)
    return np.sqrt(low), np.sqrt(high)


def diatomic_band_edges(masses: ArrayLike = (1.0, 2.0), stiffness: ArrayLike = 1.0) -> NDArray[np.float64]:
    """(2, 2) band edges [[0, acoustic max], [optical min, optical max]] in rad per time unit.

    The acoustic maximum and optical minimum are at the zone boundary q = pi / a, the
    optical maximum sqrt(S) at q = 0; the gap is ``edges[1, 0] - edges[0, 1]``.

    Examples
    --------
    >>> np.round(diatomic_band_edges((1.0, 2.0), 1.0) ** 2, 12)
    array([[0., 1.],
           [2., 3.]])
    """
    m1, m2 = _validate.positive_pair(masses, "masses", "mass")
    k1, k2 = _validate.positive_pair(stiffness, "stiffness", "spring constant")
    low_pi, high_pi = diatomic_eigenvalues(np.array([np.pi]), m1, m2, k1, k2)
    _, high_0 = diatomic_eigenvalues(np.array([0.0]), m1, m2, k1, k2)
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

    Examples
    --------
    >>> np.round(diatomic_frequencies(2, (1.0, 2.0), 1.0) ** 2, 12)
    array([0., 1., 2., 3.])
    """
    n_cells = _site_count(n_cells, "n_cells", low=1, what="a chain")
    m1, m2 = _validate.positive_pair(masses, "masses", "mass")
    k1, k2 = _validate.positive_pair(stiffness, "stiffness", "spring constant")
    _validate.choice(ends, "ends", ENDS)
    if ends != "periodic":
        raise ValueError(
            f"ends is {ends!r}; diatomic_frequencies has a closed form for ends='periodic' only "
            "(use diatomic_band_edges or system.modes() for free and fixed chains)"
        )
    j = np.arange(n_cells)
    low, high = diatomic_eigenvalues(2.0 * np.pi * np.minimum(j, n_cells - j) / n_cells, m1, m2, k1, k2)
    return np.sort(np.sqrt(np.concatenate([low, high])))


def beaded_string_frequencies(n: int, mass: float = 1.0, tension: float = 1.0, spacing: float = 1.0, *,
                              ends: Ends = "fixed") -> NDArray[np.float64]:
    """(n,) exact transverse frequencies of n equal beads on a string, ascending.

    The beaded string is a monatomic chain of spring constant tension / spacing: for fixed
    ends omega_k = 2 sqrt(T / (m d)) sin(k pi / 2(n+1)), k = 1..n (Lagrange's result).

    Examples
    --------
    >>> np.round(beaded_string_frequencies(3, 1.0, 2.0, 0.5) ** 2, 12)  # 4 (T / m d) sin^2(k pi / 8)
    array([ 2.34314575,  8.        , 13.65685425])
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

    Examples
    --------
    >>> round(float(montroll_potts_frequency(2.0, 1.0, 0.5)) ** 2, 12)  # 4 / (1 - 1/4)
    5.333333333333
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

    Examples
    --------
    >>> montroll_potts_decay(1.0, 0.5)  # m' / (2 m - m')
    0.3333333333333333
    """
    m = _positive_scalar(mass, "mass", "mass")
    md = _positive_scalar(defect_mass, "defect_mass", "mass")
    if md >= m:
        raise ValueError(
            f"defect_mass is {md!r} >= mass {m!r}; only a lighter defect has a localised mode above the band"
        )
    return md / (2.0 * m - md)


