"""Phonon density of states on a mesh: linear tetrahedron (default) or Gaussian smearing.

Linear tetrahedron method (Lehmann and Taut; Bloechl et al.): every cell of the Gamma-centred
grid is cut into 6 tetrahedra along its shortest main diagonal (in Cartesian terms, as phonopy
does), omega is interpolated linearly inside each, and each tetrahedron contributes the DOS of
that linear interpolation in closed form. Frequencies are computed at the irreducible points
of the mesh (spglib) and spread to the whole grid through its mapping. The integration is
written here (about 40 lines) rather than borrowed: phonopy's tetrahedron weights are reached
only through its own mesh and grid objects, and spglib has no tetrahedron method; our total DOS
is the same function as phonopy's full-mesh DOS (same tetrahedra, same linear interpolation),
checked in the tests to 1e-6. phonopy's default on a reduced mesh sums the 24 tetrahedra around
each irreducible point times its weight, which equals the full sum only when the tetrahedra
respect the point group (true for the fcc-based primitive cells; 10% off for the 8-atom
diamond cube at 12^3, benchmarks/bench_crystals.py).

The DOS is per unit cell and integrates to 3 n_atoms over omega. `projected` (per atom) weights
each tetrahedron by the mean over its corners of sum_a |e_{i a}|^2; it needs every grid point
with its own eigenvectors (an equivalent point's eigenvector belongs to a permuted atom), so
it runs on the full mesh. Gaussian smearing: sum_{q, nu} w_q exp(-(omega - omega_q nu)^2 / 2 sigma^2)
/ (sqrt(2 pi) sigma), on the irreducible points with their weights.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import freeze_arrays
from vibra.crystals.dynamical import phonons
from vibra.crystals.mesh import Mesh, grid_index, mesh_points
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.crystal import Crystal

__all__ = ["DensityOfStates", "dos", "METHODS", "tetrahedra"]

#: The ways `dos` integrates over the zone.
METHODS: tuple[str, ...] = ("tetrahedron", "gaussian")
#: Default number of frequency points.
DEFAULT_POINTS = 201
#: Entries per chunk of the (tetrahedra x frequency points) work arrays.
CHUNK_ENTRIES = 1 << 22

# the 6 tetrahedra of the unit cube along its (1, 1, 1) diagonal: 0 -> e_a -> e_a + e_b -> (1, 1, 1)
_UNIT = np.eye(3, dtype=np.int64)
_CUBE_TETRAHEDRA = np.array([[[0, 0, 0], _UNIT[a], _UNIT[a] + _UNIT[b], [1, 1, 1]]
                             for a in range(3) for b in range(3) if a != b], dtype=np.int64)
_DIAGONALS = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1]], dtype=np.int64)


@dataclass(frozen=True, eq=False)
class DensityOfStates:
    """Phonon density of states of a crystal, per unit cell.

    Attributes
    ----------
    omega : (n_points,) ndarray
        Angular frequencies where the DOS is given, in rad per time unit.
    dos : (n_points,) ndarray
        States per unit cell per unit of omega (integrates to 3 n_atoms).
    projected : (n_atoms, n_points) ndarray or None
        The share of each atom (sums to `dos`), when asked.
    method : str
        ``"tetrahedron"`` or ``"gaussian"``.
    mesh : (3,) ndarray of int
        The mesh it was computed on.
    sigma : float or None
        Gaussian width, in rad per time unit (None for the tetrahedron method).
    units : UnitSystem
        The crystal's units.
    """

    omega: NDArray[np.float64]
    dos: NDArray[np.float64]
    projected: NDArray[np.float64] | None
    method: str
    mesh: NDArray[np.int64]
    sigma: float | None
    units: UnitSystem

    def __post_init__(self) -> None:
        freeze_arrays(self)

    def frequencies_thz(self) -> NDArray[np.float64]:
        """(n_points,) ordinary frequencies of `omega`, in THz."""
        return self.units.omega_to_thz(self.omega)

    def dos_per_thz(self) -> NDArray[np.float64]:
        """(n_points,) states per unit cell per THz (phonopy's unit): dos * d omega / d f."""
        return self.dos / self.units.omega_to_thz(1.0)


def tetrahedra(crystal: Crystal, size: NDArray[np.int64]) -> NDArray[np.intp]:
    """(6 n_points, 4) grid indices of the tetrahedra, cut along the cells' shortest main diagonal."""
    micro = crystal.reciprocal / size[:, None]  # rows: the grid steps as Cartesian vectors
    lengths = np.linalg.norm(_DIAGONALS @ micro, axis=1)
    signs = _DIAGONALS[int(np.argmin(lengths))]
    corners = _CUBE_TETRAHEDRA * signs  # (6, 4, 3): the cube toward the chosen diagonal
    index = np.arange(int(np.prod(size)))
    grid = np.stack([index % size[0], (index // size[0]) % size[1], index // (size[0] * size[1])], axis=1)
    return grid_index(grid[:, None, None, :] + corners[None, :, :, :], size).reshape(-1, 4)


def _tetrahedron_dos(corners: NDArray[np.float64], omega: NDArray[np.float64],
                     weights: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """sum over tetrahedra (rows of `corners`, (m, 4) omega at the corners) of their linear DOS at `omega`.

    Each tetrahedron's DOS integrates to 1; `weights` (m, k) gives k weighted sums instead of one.
    Only the frequency points strictly inside a tetrahedron's range (e1, e4) are evaluated: the
    (tetrahedron, point) pairs are listed with searchsorted and summed with bincount, so the
    work is the number of such pairs, not m times the number of points.
    """
    order = np.argsort(omega, kind="stable")
    points = omega[order]
    columns = 1 if weights is None else weights.shape[1]
    out = np.zeros((columns, omega.size))
    e = np.sort(corners, axis=1)
    chunk = max(1, CHUNK_ENTRIES // 8)
    tiny = np.finfo(float).tiny
    for start in range(0, e.shape[0], chunk):
        part = e[start:start + chunk]
        first = np.searchsorted(points, part[:, 0], side="right")  # first point > e1
        stop = np.searchsorted(points, part[:, 3], side="left")    # first point >= e4
        count = np.maximum(stop - first, 0)
        if not count.any():
            continue
        tetra = np.repeat(np.arange(part.shape[0]), count)
        index = np.arange(tetra.size) - np.repeat(np.cumsum(count) - count, count) + first[tetra]
        w = points[index]
        a1, a2, a3, a4 = (part[tetra, k] for k in range(4))
        with np.errstate(all="ignore"):  # np.where evaluates every branch; the unused ones may overflow
            low = 3 * (w - a1) ** 2 / np.maximum((a2 - a1) * (a3 - a1) * (a4 - a1), tiny)
            x = w - a2
            middle = (3 * (a2 - a1) + 6 * x - 3 * (a3 - a1 + a4 - a2) * x ** 2
                      / np.maximum((a3 - a2) * (a4 - a2), tiny)) / np.maximum((a3 - a1) * (a4 - a1), tiny)
            high = 3 * (a4 - w) ** 2 / np.maximum((a4 - a1) * (a4 - a2) * (a4 - a3), tiny)
        g = np.where(w <= a2, low, np.where(w <= a3, middle, high))
        if weights is None:
            out[0] += np.bincount(index, weights=g, minlength=omega.size)
        else:
            share = weights[start:start + chunk][tetra]
            for column in range(columns):
                out[column] += np.bincount(index, weights=g * share[:, column], minlength=omega.size)
    result = np.empty_like(out)
    result[:, order] = out
    return result


def _omega_points(values: NDArray[np.float64], omega: ArrayLike | None, margin: float) -> NDArray[np.float64]:
    if omega is not None:
        points = _validate.real_array(omega, "omega", ndim=1)
        if points.size == 0:
            raise ValueError("omega must hold at least one frequency point")
        return points
    low, high = float(values.min()), float(values.max())
    span = max(high - low, 1e-300)
    return np.linspace(low - margin * span, high + margin * span, DEFAULT_POINTS)


def dos(crystal: Crystal, mesh: Any, *, method: str = "tetrahedron", sigma: float | None = None,
        omega: ArrayLike | None = None, projected: bool = False, symmetry: bool = True) -> DensityOfStates:
    """Phonon density of states on a Gamma-centred `mesh` (module docstring).

    Parameters
    ----------
    crystal : Crystal
        With force constants.
    mesh : int or 3 ints
        Points along each reciprocal lattice vector (one int: that many along each periodic axis).
    method : {"tetrahedron", "gaussian"}
        Linear tetrahedron (default) or Gaussian smearing (needs `sigma`).
    sigma : float, optional
        Gaussian width, in rad per time unit.
    omega : (n_points,) array_like, optional
        Frequency points, in rad per time unit; by default 201 across the spectrum.
    projected : bool
        Also the DOS projected on each atom (computed on the full mesh).
    symmetry : bool
        Reduce the mesh by the crystal's symmetry (spglib); the force constants must have it.

    Raises
    ------
    ValueError
        A mesh size below 1 (or not 1 along a vacuum axis); an unknown method; a missing or
        non-positive sigma for the Gaussian, or a sigma given to the tetrahedron method.
    """
    crystal.require_force_constants()
    method = _validate.choice(method, "method", METHODS)
    if method == "gaussian":
        if sigma is None:
            raise ValueError("method='gaussian' needs sigma, the Gaussian width in rad per time unit")
        width = _validate.positive_scalar(sigma, "sigma", "Gaussian width")
    elif sigma is not None:
        raise ValueError("sigma is for method='gaussian'; the tetrahedron method takes none")
    points = mesh_points(crystal, mesh, symmetry=symmetry and not projected)
    result = phonons(crystal, points.qpoints, vectors=projected)
    n_points = points.grid.shape[0]
    if method == "gaussian":
        frequencies = _omega_points(result.omega, omega, 0.05)
        weights = points.weights / n_points
        shape = np.exp(-0.5 * ((frequencies[None, None, :] - result.omega[:, :, None]) / width) ** 2)
        shape /= np.sqrt(2.0 * np.pi) * width
        total = np.einsum("q,qbk->k", weights, shape)
        share = None
        if projected:
            projection = _projections(result.vectors, crystal.n_atoms)  # (n_q, n_bands, n_atoms)
            share = np.einsum("q,qba,qbk->ak", weights, projection, shape)
        return DensityOfStates(omega=frequencies, dos=total, projected=share, method=method, mesh=points.size,
                               sigma=width, units=crystal.units)
    full = _full_grid(points, result.omega)  # (n_points, n_bands)
    frequencies = _omega_points(result.omega, omega, 0.02)
    corners = tetrahedra(crystal, points.size)  # (6 n_points, 4)
    scale = 1.0 / (6.0 * n_points)
    projection = _projections(result.vectors, crystal.n_atoms) if projected else None  # full mesh
    share = np.zeros((crystal.n_atoms, frequencies.size)) if projected else None
    total = np.zeros(frequencies.size)
    n_bands = full.shape[1]
    step = max(1, CHUNK_ENTRIES // (4 * n_bands * (crystal.n_atoms + 1)))  # bounded memory per chunk
    for start in range(0, corners.shape[0], step):
        part = corners[start:start + step]
        by_band = full[part].transpose(0, 2, 1).reshape(-1, 4)  # (n_tetra * n_bands, 4)
        if projection is not None and share is not None:
            mean = projection[part].mean(axis=1).reshape(-1, crystal.n_atoms)  # (n_tetra * n_bands, n_atoms)
            share += _tetrahedron_dos(by_band, frequencies, mean) * scale
        else:
            total += _tetrahedron_dos(by_band, frequencies)[0] * scale
    if share is not None:
        total = share.sum(axis=0)
    return DensityOfStates(omega=frequencies, dos=total, projected=share, method=method, mesh=points.size,
                           sigma=None, units=crystal.units)


def _full_grid(points: Mesh, omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_points, n_bands) omega on every grid point, from the irreducible ones."""
    position = np.empty(points.grid.shape[0], dtype=np.intp)
    position[points.irreducible] = np.arange(points.irreducible.size)
    return omega[position[points.mapping]]


def _projections(vectors: NDArray[np.complex128] | None, n_atoms: int) -> NDArray[np.float64]:
    """(n_q, n_bands, n_atoms) sum over axes of |e_{3i+a}|^2 for each branch."""
    if vectors is None:
        raise RuntimeError("projected DOS needs eigenvectors")
    weight = np.abs(vectors) ** 2  # (n_q, 3n, n_bands)
    return weight.reshape(vectors.shape[0], n_atoms, 3, -1).sum(axis=2).transpose(0, 2, 1)
