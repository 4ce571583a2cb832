"""Gamma-centred q-point meshes and their reduction by symmetry (spglib).

A mesh (n1, n2, n3) holds the wave vectors q = (i1 / n1, i2 / n2, i3 / n3) (fractional
reciprocal coordinates, Gamma included, as phonopy's default mesh). spglib's
``get_ir_reciprocal_mesh`` maps every grid point to an irreducible one under the crystal's
point group and time reversal; frequencies are computed at the irreducible points only and
weighted by how many grid points each stands for. The reduction assumes the force constants
have the structure's symmetry (true for `springs` and for symmetrised phonopy force constants);
``symmetry=False`` computes every point.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core.frozen import Frozen, short_repr

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["point_rotations", "species_numbers", "Mesh", "mesh_points", "check_mesh", "grid_index", "MAX_MESH_POINTS"]

#: Most grid points a mesh may hold (a bound before any allocation).
MAX_MESH_POINTS = 8_000_000


@dataclass(frozen=True, eq=False)
class Mesh(Frozen):
    """A Gamma-centred mesh and its irreducible points.

    Attributes
    ----------
    size : (3,) ndarray of int
        Points along each reciprocal lattice vector.
    grid : (n_points, 3) ndarray of int
        Integer address of every grid point (q = grid / size, folded into [-1/2, 1/2)).
    mapping : (n_points,) ndarray of int
        Index (into `grid`) of the irreducible point each grid point is equivalent to.
    irreducible : (n_irreducible,) ndarray of int
        Indices into `grid` of the irreducible points.
    weights : (n_irreducible,) ndarray of int
        How many grid points each irreducible point stands for (sum = n_points).
    """

    size: NDArray[np.int64]
    grid: NDArray[np.int64]
    mapping: NDArray[np.intp]
    irreducible: NDArray[np.intp]
    weights: NDArray[np.int64]

    def __repr__(self) -> str:
        mesh = "x".join(str(int(n)) for n in self.size)
        return short_repr(self, f"{mesh}", f"{self.grid.shape[0]} points", f"{self.irreducible.size} irreducible")

    @property
    def qpoints(self) -> NDArray[np.float64]:
        """(n_irreducible, 3) fractional wave vectors of the irreducible points."""
        return self.grid[self.irreducible] / self.size


def grid_index(address: NDArray[np.int64], size: NDArray[np.int64]) -> NDArray[np.intp]:
    """Index of the grid point at integer `address` (any integers: taken modulo the mesh), spglib's order."""
    a = np.mod(address, size)
    return (a[..., 0] + size[0] * (a[..., 1] + size[1] * a[..., 2])).astype(np.intp)


def check_mesh(mesh: ArrayLike, crystal: Crystal) -> NDArray[np.int64]:
    """(3,) mesh sizes: positive integers (1 along a vacuum axis), at most MAX_MESH_POINTS in all."""
    raw = np.asarray(mesh)
    if raw.ndim == 0:
        raw = np.repeat(raw, 3)
        raw[~np.array(crystal.periodic)] = 1
    if raw.shape != (3,) or not np.issubdtype(raw.dtype, np.integer):
        raise ValueError(f"mesh must be 3 integers (points along each reciprocal lattice vector), got {mesh!r}")
    for axis in range(3):
        if raw[axis] < 1:
            raise ValueError(f"mesh[{axis}] is {int(raw[axis])}; each mesh size must be a positive integer")
        if not crystal.periodic[axis] and raw[axis] != 1:
            raise ValueError(f"mesh[{axis}] is {int(raw[axis])} along a vacuum axis; it must be 1")
    points = math.prod(int(n) for n in raw)  # Python integers: three large sizes cannot wrap around to a small product
    if points > MAX_MESH_POINTS:
        raise ValueError(f"mesh {raw.tolist()} holds {points} points, over the limit {MAX_MESH_POINTS}")
    return raw.astype(np.int64)


def symmetry_cell(crystal: Crystal) -> NDArray[np.float64]:
    """The cell scaled to a unit cube root of its volume per periodic axis: spglib's and
    SeeK-path's tolerances (symprec 1e-5) are lengths, so a cell in metres (5e-10) would
    look like one point to them. Symmetry does not change with the scale."""
    scale = float(np.prod(np.linalg.norm(crystal.cell, axis=1)[crystal.periodic])) ** (1.0 / max(int(np.sum(crystal.periodic)), 1))
    return np.asarray(crystal.cell, dtype=float) / scale


def species_numbers(crystal: Crystal) -> list[int]:
    """One integer per atom for spglib: atoms are one species when both symbol and mass agree
    (an isotope breaks a symmetry its element keeps). The one place this is decided."""
    kinds: dict[tuple[str, float], int] = {}
    return [kinds.setdefault((s, float(m)), len(kinds) + 1) for s, m in zip(crystal.symbols, crystal.masses)]


def point_rotations(crystal: Crystal) -> NDArray[np.int32] | None:
    """(n_ops, 3, 3) the rotations of the crystal's space group (spglib's, fractional), or None.

    The symmetry search is most of a mesh's cost (33 ms of 35 for a 20^3 mesh of rock salt):
    `Crystal.point_rotations` keeps it per crystal, as phonopy keeps its symmetry per object.
    """
    import spglib  # at the edge: spglib only for a symmetry-reduced mesh

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # spglib's notice about its error handling
        found = spglib.get_symmetry((symmetry_cell(crystal), crystal.fractional, species_numbers(crystal)))
    return None if found is None else np.asarray(found["rotations"], dtype=np.int32)


def mesh_points(crystal: Crystal, mesh: int | Sequence[int], *, symmetry: bool = True) -> Mesh:
    """The Gamma-centred `mesh` of `crystal`, reduced by symmetry with spglib unless ``symmetry=False``.

    The same mesh as spglib's ``get_ir_reciprocal_mesh`` (its ``get_stabilized_reciprocal_mesh``
    with the crystal's rotations, kept per crystal: `point_rotations`).
    """
    size = check_mesh(mesh, crystal)
    if symmetry:
        import spglib

        kept = hasattr(type(crystal), "point_rotations")  # a Crystal keeps them; anything else searches now
        rotations = crystal.point_rotations if kept else point_rotations(crystal)  # type: ignore[attr-defined]
        if rotations is None:
            raise RuntimeError(f"spglib found no symmetry for {crystal.name!r} (pass symmetry=False for the full mesh)")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            found = spglib.get_stabilized_reciprocal_mesh(size, rotations, is_shift=[0, 0, 0], is_time_reversal=True)
        if found is None:
            raise RuntimeError(f"spglib found no symmetry for {crystal.name!r} (pass symmetry=False for the full mesh)")
        mapping, grid = found
        mapping = np.asarray(mapping, dtype=np.intp)
        grid = np.asarray(grid, dtype=np.int64)
    else:
        index = np.arange(int(np.prod(size)))
        grid = np.stack([index % size[0], (index // size[0]) % size[1], index // (size[0] * size[1])], axis=1)
        grid = np.where(grid > size // 2, grid - size, grid)
        mapping = np.arange(len(grid), dtype=np.intp)
    irreducible, weights = np.unique(mapping, return_counts=True)
    return Mesh(size=size, grid=grid, mapping=mapping, irreducible=irreducible.astype(np.intp),
                weights=weights.astype(np.int64))
