"""Phonon density of states on a mesh: linear tetrahedron (default) or Gaussian smearing.

Linear tetrahedron method (Lehmann and Taut; Bloechl et al.): every cell of the Gamma-centred
grid is cut into 6 tetrahedra along its shortest main diagonal (in Cartesian terms, as phonopy
does), omega is interpolated linearly inside each, and each tetrahedron contributes the DOS of
that linear interpolation in closed form (a numba kernel). Frequencies are computed at the
irreducible points of the mesh (spglib) and spread to the whole grid through its mapping. The
integration is written here (about 40 lines) rather than borrowed: phonopy's tetrahedron weights are reached
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
from typing import TYPE_CHECKING, Sequence

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import frequency_span
from vibra._results import Result, stored
from vibra.crystals.dynamical import phonons
from vibra.crystals.mesh import Mesh, grid_index, mesh_points
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["DensityOfStates", "dos", "METHODS", "tetrahedra"]

#: The ways `dos` integrates over the zone.
METHODS: tuple[str, ...] = ("tetrahedron", "gaussian")
#: Default number of frequency points.
DEFAULT_POINTS = 201
#: Grid points whose tetrahedra are built and summed at a time (their corner table and its
#: temporaries take ~1.5 MiB), so that a 40^3 mesh's DOS needs no 100 MiB table of every corner.
#: 8192 (6 MiB of corners) ran no faster on phonopy's NaCl and ZnO at 20^3 (issue 42's memory).
TETRAHEDRA_CHUNK = 2048

# the 6 tetrahedra of the unit cube along its (1, 1, 1) diagonal: 0 -> e_a -> e_a + e_b -> (1, 1, 1)
_UNIT = np.eye(3, dtype=np.int64)
_CUBE_TETRAHEDRA = np.array([[[0, 0, 0], _UNIT[a], _UNIT[a] + _UNIT[b], [1, 1, 1]]
                             for a in range(3) for b in range(3) if a != b], dtype=np.int64)
_DIAGONALS = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1]], dtype=np.int64)


@dataclass(frozen=True, eq=False, repr=False)
class DensityOfStates(Result):
    """Phonon density of states of a crystal, per unit cell (a `vibra._results.Result` over its points;
    `path` is the method).

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

    STORED = {"omega": stored(("n_points",)), "dos": stored(("n_points",)),  # how save / load check them
              "projected": stored(("n_atoms", "n_points"), optional=True), "mesh": stored((3,), kind="int")}
    AXIS, NOUNS, PATH_FIELD = "n_points", ("point", "points"), "method"

    omega: NDArray[np.float64]
    dos: NDArray[np.float64]
    projected: NDArray[np.float64] | None
    method: str
    mesh: NDArray[np.int64]
    sigma: float | None
    units: UnitSystem

    def _repr_parts(self) -> tuple[str, ...]:
        mesh = "x".join(str(int(n)) for n in self.mesh)
        return (f"{self._size()} on a {mesh} mesh", frequency_span(self.omega, self.units),
                "" if self.sigma is None else f"sigma {self.sigma:.3g}",
                "" if self.projected is None else f"projected on {self.projected.shape[0]} atoms")

    def frequencies_thz(self) -> NDArray[np.float64]:
        """(n_points,) ordinary frequencies of `omega`, in THz."""
        return self.units.omega_to_thz(self.omega)

    def dos_per_thz(self) -> NDArray[np.float64]:
        """(n_points,) states per unit cell per THz (phonopy's unit): dos * d omega / d f."""
        return self.dos / self.units.omega_to_thz(1.0)


def tetrahedra(crystal: Crystal, size: NDArray[np.int64], start: int = 0, stop: int | None = None
               ) -> NDArray[np.intp]:
    """(6 (stop - start), 4) grid indices of the tetrahedra of grid points start .. stop - 1 (default:
    all), cut along the cells' shortest main diagonal; tetrahedron 6 p + k belongs to grid point p."""
    micro = crystal.reciprocal / size[:, None]  # rows: the grid steps as Cartesian vectors
    lengths = np.linalg.norm(_DIAGONALS @ micro, axis=1)
    signs = _DIAGONALS[int(np.argmin(lengths))]
    corners = _CUBE_TETRAHEDRA * signs  # (6, 4, 3): the cube toward the chosen diagonal
    index = np.arange(start, int(np.prod(size)) if stop is None else stop)
    grid = np.stack([index % size[0], (index // size[0]) % size[1], index // (size[0] * size[1])], axis=1)
    return grid_index(grid[:, None, None, :] + corners[None, :, :, :], size).reshape(-1, 4)


@numba.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")
def _tetrahedron_kernel(full: NDArray[np.float64], corners: NDArray[np.intp], points: NDArray[np.float64],
                        projection: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover
    """The linear-tetrahedron DOS of every tetrahedron and band at the sorted `points`, summed into out[c, k].

    For corners e1 <= e2 <= e3 <= e4 the DOS of the linear interpolation (integral 1) is
    3 (w - e1)^2 / ((e2 - e1)(e3 - e1)(e4 - e1)) on (e1, e2],
    [3 (e2 - e1) + 6 x - 3 (e3 - e1 + e4 - e2) x^2 / ((e3 - e2)(e4 - e2))] / ((e3 - e1)(e4 - e1)),
    x = w - e2, on (e2, e3], and 3 (e4 - w)^2 / ((e4 - e1)(e4 - e2)(e4 - e3)) on (e3, e4); only the
    points inside (e1, e4) are visited (binary search). Compiled with numba (no fast-math),
    cached on disk after the first call (~1 s).

    full (n_points, n_bands) omega on the grid; corners (n_tetra, 4) grid indices; points sorted;
    projection (n_points, n_bands, n_columns) the weights at the grid points (the tetrahedron
    takes their mean over its corners), or shape (1, 1, 0) for the total DOS into out[0].
    """
    tiny = 2.2250738585072014e-308
    n_bands = full.shape[1]
    n_columns = projection.shape[2]
    e = np.empty(4)
    for t in range(corners.shape[0]):
        for b in range(n_bands):
            for c in range(4):
                e[c] = full[corners[t, c], b]
            for c in range(1, 4):  # insertion sort of 4 values
                v = e[c]
                d = c - 1
                while d >= 0 and e[d] > v:
                    e[d + 1] = e[d]
                    d -= 1
                e[d + 1] = v
            a1, a2, a3, a4 = e[0], e[1], e[2], e[3]
            first = np.searchsorted(points, a1, side="right")
            stop = np.searchsorted(points, a4, side="left")
            for k in range(first, stop):
                w = points[k]
                if w <= a2:
                    g = 3.0 * (w - a1) ** 2 / max((a2 - a1) * (a3 - a1) * (a4 - a1), tiny)
                elif w <= a3:
                    x = w - a2
                    g = (3.0 * (a2 - a1) + 6.0 * x - 3.0 * (a3 - a1 + a4 - a2) * x * x
                         / max((a3 - a2) * (a4 - a2), tiny)) / max((a3 - a1) * (a4 - a1), tiny)
                else:
                    g = 3.0 * (a4 - w) ** 2 / max((a4 - a1) * (a4 - a2) * (a4 - a3), tiny)
                if n_columns == 0:
                    out[0, k] += g
                else:
                    for column in range(n_columns):
                        mean = 0.25 * (projection[corners[t, 0], b, column] + projection[corners[t, 1], b, column]
                                       + projection[corners[t, 2], b, column] + projection[corners[t, 3], b, column])
                        out[column, k] += g * mean


def _omega_points(values: NDArray[np.float64], omega: ArrayLike | None, margin: float) -> NDArray[np.float64]:
    if omega is not None:
        points = _validate.real_array(omega, "omega", ndim=1)
        if points.size == 0:
            raise ValueError("omega must hold at least one frequency point")
        return points
    low, high = float(values.min()), float(values.max())
    span = max(high - low, 1e-300)
    return np.linspace(low - margin * span, high + margin * span, DEFAULT_POINTS)


def dos(crystal: Crystal, mesh: int | Sequence[int], *, method: str = "tetrahedron", sigma: float | None = None,
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
    scale = 1.0 / (6.0 * n_points)
    order = np.argsort(frequencies, kind="stable")
    projection = (_projections(result.vectors, crystal.n_atoms) if projected  # full mesh: (n_points, n_bands, n_atoms)
                  else np.zeros((1, 1, 0)))
    summed = np.zeros((max(1, projection.shape[2]), frequencies.size))
    full, sorted_points, projection = (np.ascontiguousarray(x) for x in (full, frequencies[order], projection))
    for start in range(0, n_points, TETRAHEDRA_CHUNK):  # in grid order: the sums are those of one call
        corners = tetrahedra(crystal, points.size, start, min(n_points, start + TETRAHEDRA_CHUNK))
        _tetrahedron_kernel(full, corners, sorted_points, projection, summed)
    unsorted = np.empty_like(summed)
    unsorted[:, order] = summed * scale
    share = unsorted if projected else None
    total = unsorted.sum(axis=0)
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
