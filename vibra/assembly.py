"""Sparse assembly of the factor B of K = B^T diag(w) B, and of user Hessian blocks (pure).

Each row of B is the gradient of one internal coordinate with respect to the displacements
(n_sites * dim columns, site-major): a spring's row holds -e and +e on its two sites (e the
unit vector along it), an anchor's row the anchor direction on its site. `vibra.system`
stacks these into the `System`'s coupling; nothing here reads files or keeps state. Periodic
supercells (``System.from_springs(..., cell=)``) take each bond by minimum image
(`periodic_bonds`); without a cell, springs that look wrapped around a periodic box are refused.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import read_only


def pair_rows(pairs: NDArray[np.intp], unit: NDArray[np.float64], n_sites: int, dim: int) -> sp.coo_matrix:
    """(n_pairs, n_sites * dim) rows of B for springs `pairs` along the unit vectors `unit`."""
    n = len(pairs)
    axis = np.arange(dim)
    rows = np.repeat(np.arange(n), 2 * dim)
    cols = np.concatenate([pairs[:, :1] * dim + axis, pairs[:, 1:] * dim + axis], axis=1).ravel()
    data = np.concatenate([-unit, unit], axis=1).ravel()
    return sp.coo_matrix((data, (rows, cols)), shape=(n, n_sites * dim))


def single_rows(sites: NDArray[np.intp], direction: NDArray[np.float64], n_sites: int, dim: int) -> sp.coo_matrix:
    """(n_sites_anchored, n_sites * dim) rows of B for anchors on `sites` along `direction`."""
    n = len(sites)
    rows = np.repeat(np.arange(n), dim)
    cols = (sites[:, None] * dim + np.arange(dim)).ravel()
    return sp.coo_matrix((direction.ravel(), (rows, cols)), shape=(n, n_sites * dim))


def stack_terms(rows: list[sp.coo_matrix], weights: list[NDArray[np.float64]], n_full: int
                ) -> tuple[sp.csr_matrix, NDArray[np.float64]]:
    """B (CSR, explicit zeros dropped) and w from lists of row blocks and their weights."""
    if not rows:
        return sp.csr_matrix((0, n_full)), np.zeros(0)
    b = sp.vstack(rows, format="csr")
    b.eliminate_zeros()  # axis-aligned springs have zero components
    return b, np.concatenate(weights)


def hessian(coupling: sp.spmatrix, weights: NDArray[np.float64], extra: sp.spmatrix | None,
            free: NDArray[np.intp] | None) -> sp.csr_matrix:
    """K = B^T diag(w) B (+ the user's Hessian blocks `extra`) over the `free` dofs (all where None),
    CSR in canonical form, its arrays read-only (`vibra.System` keeps it)."""
    b = coupling
    K = (b.T @ sp.diags(weights) @ b).tocsr() if b.shape[0] else sp.csr_matrix((b.shape[1], b.shape[1]))
    if extra is not None:
        K = (K + extra).tocsr()
    if free is not None:
        K = K[free][:, free].tocsr()
    K.sum_duplicates()
    return read_only(K)


def hessian_blocks(blocks: Sequence[tuple[ArrayLike, ArrayLike]], n_sites: int, dim: int) -> sp.csr_matrix:
    """Sum user Hessian blocks into one sparse (n_sites * dim)^2 matrix."""
    rows: list[NDArray[np.intp]] = []
    cols: list[NDArray[np.intp]] = []
    data: list[NDArray[np.float64]] = []
    for b, block in enumerate(blocks):
        try:
            sites, matrix = block
        except (TypeError, ValueError):
            raise TypeError(f"blocks[{b}] must be a pair (sites, H)") from None
        index = _validate.indices(sites, f"blocks[{b}] sites", n_sites, shape=(-1,))
        dofs = (index[:, None] * dim + np.arange(dim)).ravel()
        H = _validate.real_array(matrix, f"blocks[{b}] H", ndim=2)
        if H.shape != (dofs.size, dofs.size):
            raise ValueError(f"blocks[{b}] H must be ({dofs.size}, {dofs.size}) for {index.size} sites in {dim}-D, "
                             f"got {H.shape}")
        _validate.symmetric(H, f"blocks[{b}] H")
        rows.append(np.repeat(dofs, dofs.size))
        cols.append(np.tile(dofs, dofs.size))
        data.append(H.ravel())
    size = n_sites * dim
    if not data:
        return sp.csr_matrix((size, size))
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=(size, size))


#: Without `cell`, a spring (in 2 or 3 dimensions) is refused as wrapped around a periodic box
#: only when it shows all three marks of a bond joined by minimum image but read in raw positions
#: (`refuse_wrapped`): longer than half the extent of the sites along its own direction, longer
#: than this many times the median spring, and skipping, at each of its two sites, a nearer site
#: that site is not joined to. Twice the median alone (the first rule) refused networks with
#: long springs: a complete graph's longest spring is 2-3.5 times its median.
WRAPPED_SPRING_RATIO = 2.0


def periodic_bonds(bond: NDArray[np.float64], positions: NDArray[np.float64], pairs: NDArray[np.intp],
                   cell: ArrayLike | None) -> NDArray[np.float64]:
    """(n_springs, dim) bond vectors: with `cell`, each one's minimum image (`minimum_images`); without it,
    the raw ones, after `refuse_wrapped` (2-D and 3-D only: in 1-D e e^T = 1 whichever way a bond points,
    so periodic chains and GNM contacts keep their long springs)."""
    if cell is not None:
        return minimum_images(bond, periodic_cell(cell, positions.shape[1]), pairs)
    if positions.shape[1] >= 2:
        refuse_wrapped(bond, positions, pairs)
    return bond


def periodic_cell(cell: ArrayLike, dim: int) -> NDArray[np.float64]:
    """(dim, dim) lattice vectors (rows) of a periodic supercell, refused when singular or misshapen."""
    lattice = _validate.real_array(cell, "cell", ndim=2)
    if lattice.shape != (dim, dim):
        raise ValueError(f"cell must be {dim} x {dim} (lattice vectors as rows) for {dim}-D positions, got shape "
                         f"{lattice.shape}")
    det = float(np.linalg.det(lattice))
    if abs(det) <= 1e-10 * float(np.prod(np.linalg.norm(lattice, axis=1))):
        raise ValueError(f"cell is singular (det = {det:.3g}); a periodic supercell needs {dim} independent "
                         "lattice vectors")
    return lattice


def minimum_images(bond: NDArray[np.float64], cell: NDArray[np.float64], pairs: NDArray[np.intp]
                    ) -> NDArray[np.float64]:
    """(n, dim) the shortest of each bond's periodic images; refused when two are equally short."""
    dim = cell.shape[0]
    frac = bond @ np.linalg.inv(cell)
    frac -= np.round(frac)
    grid = np.stack(np.meshgrid(*[np.arange(-1, 2)] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    images = (frac[:, None, :] + grid[None, :, :]) @ cell  # (n, 3^dim, dim)
    length = np.linalg.norm(images, axis=2)
    order = np.argsort(length, axis=1)
    first = np.take_along_axis(length, order[:, :1], axis=1)[:, 0]
    second = np.take_along_axis(length, order[:, 1:2], axis=1)[:, 0]
    tie = second <= first * (1.0 + 1e-8)
    if tie.any():
        s = int(np.argmax(tie))
        widths = 1.0 / np.linalg.norm(np.linalg.inv(cell), axis=0)  # distances between opposite faces
        factor = int(np.ceil(2.0 * first[s] / widths.min() * (1.0 + 1e-8)))
        raise ValueError(
            f"springs[{s}] joins sites {pairs[s, 0]} and {pairs[s, 1]} across the cell, but two of its periodic "
            f"images are equally near ({first[s]:.6g}): the cell is too small for a spring this long; every width "
            f"of the cell must exceed twice it, {2 * first[s]:.6g} (the narrowest is {widths.min():.6g}: a "
            f"supercell about {max(factor, 2)} times larger)")
    return np.take_along_axis(images, order[:, :1, None], axis=1)[:, 0, :]


def refuse_wrapped(bond: NDArray[np.float64], positions: NDArray[np.float64], pairs: NDArray[np.intp]) -> None:
    """Refuse a spring that looks wrapped around a periodic box, naming cell=.

    A supercell's springs chosen by minimum image (all images within r_c) but given without
    `cell` include bonds between opposite faces, ~L long in the raw positions where the others
    are ~r_c. Spring s is refused when it has all three marks of such a bond:

    1. longer than `WRAPPED_SPRING_RATIO` times the median spring;
    2. each of its two sites has a site nearer to it than the other end that it is not joined
       to: the spring skips over the supercell's second, third ... neighbours;
    3. longer than half the extent of the sites along its own direction (it crosses the box).

    Mark 2 is what no network chosen by distance has: springs between all sites within a
    cutoff (ANM, GNM, any cutoff, any gamma), a complete graph, or each site to its k nearest
    (one end of every spring is joined to all sites nearer than the other end). These are
    accepted however long their springs. A wrapped spring has it in any supercell whose
    springs are shorter than its second neighbours. A deliberate long tether that has all three
    marks is refused too; add it as a Hessian block (``blocks=``) instead.

    Costs O(n_springs log n_sites) for networks chosen by distance (few springs pass marks 1
    and 2); the projection of mark 3 runs only on springs that pass both.
    """
    length = np.linalg.norm(bond, axis=1)
    if length.size < 2:
        return
    median = float(np.median(length))
    candidates = np.nonzero(length > WRAPPED_SPRING_RATIO * median)[0]  # usually none: O(n_springs) only
    if candidates.size == 0:
        return
    sites = np.unique(pairs[candidates])
    unjoined = np.full(positions.shape[0], np.inf)
    unjoined[sites] = _nearest_unjoined(positions, pairs, sites)
    reach = length[candidates] * (1.0 - 1e-9)  # strictly nearer, past rounding
    candidates = candidates[(unjoined[pairs[candidates, 0]] < reach) & (unjoined[pairs[candidates, 1]] < reach)]
    chunk = max(1, (1 << 22) // max(1, positions.shape[0]))
    for start in range(0, candidates.size, chunk):
        part = candidates[start:start + chunk]
        along = positions @ (bond[part] / length[part, None]).T  # sites projected on each spring's axis
        extent = along.max(axis=0) - along.min(axis=0)
        wrapped = length[part] > 0.5 * extent * (1.0 + 1e-9)
        if wrapped.any():
            k = int(np.argmax(wrapped))
            s = int(part[k])
            raise ValueError(
                f"springs[{s}] joins sites {pairs[s, 0]} and {pairs[s, 1]} over {length[s]:.6g}, more than half the "
                f"extent of the sites along it ({extent[k]:.6g}) and {length[s] / median:.3g} times the median "
                "spring, past nearer sites that neither end is joined to: it looks wrapped around a periodic box, "
                "and its axis would come from the raw positions; pass cell= (the supercell's lattice vectors) "
                "for minimum-image bonds, or use vibra.crystals for a crystal")


def _nearest_unjoined(positions: NDArray[np.float64], pairs: NDArray[np.intp], sites: NDArray[np.intp]
                      ) -> NDArray[np.float64]:
    """(n,) for each of `sites`, the distance to the nearest other site no spring joins it to
    (inf when it is joined to every site)."""
    n_sites = positions.shape[0]
    ones = np.ones(2 * len(pairs))
    adjacency = sp.csr_matrix((ones, (pairs.ravel(), pairs[:, ::-1].ravel())), shape=(n_sites, n_sites))
    adjacency.sum_duplicates()  # each site's distinct partners, sorted
    from scipy.spatial import cKDTree   # here: scipy.spatial costs ~0.15 s to import, a chain never needs it

    tree = cKDTree(positions)
    distance = np.full(len(sites), np.inf)
    for k, site in enumerate(sites):
        partners = adjacency.indices[adjacency.indptr[site]:adjacency.indptr[site + 1]]
        if partners.size >= n_sites - 1:
            continue
        # among its partners.size + 2 nearest (itself included), one at least is not a partner,
        # and the first such is the nearest of all
        near, index = tree.query(positions[site], k=partners.size + 2)
        other = (index != site) & ~np.isin(index, partners, assume_unique=True)
        distance[k] = near[np.argmax(other)]
    return distance
