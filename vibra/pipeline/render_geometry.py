"""Geometry of the 3-D renders, without pyvista: which chain sites are drawn, where an arrow starts so
that no bond hides it, from which direction a molecule shows every atom, how many network arrows.

`vibra.pipeline.render` draws with these; they are plain numpy, tested on their own.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from vibra.system import System

__all__ = ["MAX_CHAIN_SITES", "chain_sites", "positions3", "displacements3", "molecule_symbols", "molecule_bonds",
           "arrow_start", "view_direction", "MAX_NETWORK_ARROWS", "network_arrow_step"]

#: Largest number of sites drawn in a chain row; longer chains are decimated evenly.
MAX_CHAIN_SITES = 41


def chain_sites(masses: ArrayLike) -> NDArray[np.intp]:
    """(n_shown,) indices of the chain sites drawn, for a chain of these (n_sites,) masses.

    All sites up to `MAX_CHAIN_SITES`; else every s-th site, with the smallest stride s that
    keeps at most `MAX_CHAIN_SITES`, so the drawn row stays evenly spaced. When the masses
    repeat with a short period (a diatomic chain: 2), s is made prime to that period so that
    every kind of mass still appears in the row.
    """
    values = np.asarray(masses, dtype=float)
    n_sites = len(values)
    stride = -(-n_sites // MAX_CHAIN_SITES)  # ceil
    period = next((p for p in range(1, 5) if np.array_equal(values[p:], values[:-p])), 1)
    while stride > 1 and math.gcd(stride, period) != 1:
        stride += 1
    return np.arange(0, n_sites, stride, dtype=np.intp)


def positions3(system: System) -> NDArray[np.float64]:
    positions = np.asarray(system.positions, dtype=float)
    out = np.zeros((positions.shape[0], 3))
    out[:, : positions.shape[1]] = positions
    return out


def displacements3(system: System, shape: NDArray[np.float64]) -> NDArray[np.float64]:
    """(n_sites, 3) displacement of every site (zeros at frozen dofs and unused axes)."""
    full = np.asarray(system.expand(shape)).reshape(system.n_sites, system.dim)
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = full
    return out


def molecule_symbols(system: System, symbols: Sequence[str] | None = None) -> list[str]:
    """Chemical symbols of the sites: `symbols` if given, else `vibra.molecules.symbols_from_masses`."""
    from vibra.molecules import symbols_from_masses

    return list(symbols) if symbols is not None else list(symbols_from_masses(system.masses))


def molecule_bonds(system: System, symbols: Sequence[str] | None = None,
                   springs: Sequence[Sequence[int]] | None = None) -> list[tuple[int, int]]:
    """Bonds of a molecule: the given springs, else `vibra.molecules.bonds_from_distances`."""
    from vibra.molecules import bonds_from_distances

    if springs is not None:
        return [(int(i), int(j)) for i, j in springs]
    return list(bonds_from_distances(system.positions, molecule_symbols(system, symbols)))


#: An arrow whose direction is within ~25 degrees of a bond (cosine above this) would run
#: inside that bond's tube and the neighbouring atom, hidden from view.
_ALONG_BOND = 0.9


def arrow_start(positions: NDArray[np.float64], bonds: Sequence[tuple[int, int]], i: int,
                 vector: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """Where atom i's displacement arrow starts (Angstrom) so that it stays visible.

    - pointing away from every bond: from the atom's surface outwards;
    - pointing into a bond but free behind: ending on the atom's surface (pushing it);
    - bonds on both sides (the centre of a linear molecule): lifted off the bond axis by
      1.6 radii, perpendicular to the motion, and centred over the atom.
    """
    norm = float(np.linalg.norm(vector))
    direction = vector / norm
    neighbours = [j for a, b in bonds for j, k in ((b, a), (a, b)) if k == i]
    units = [(positions[j] - positions[i]) / max(float(np.linalg.norm(positions[j] - positions[i])), 1e-300)
             for j in neighbours]

    def blocked(d: NDArray[np.float64]) -> bool:
        return any(float(u @ d) > _ALONG_BOND for u in units)

    if not blocked(direction):
        return positions[i] + radius * direction
    if not blocked(-direction):
        return positions[i] - (radius + norm) * direction
    axes = np.eye(3)[::-1]  # z first: the screen's vertical in the views used below
    lift = axes[int(np.argmin(np.abs(axes @ direction)))]
    lift = lift - (lift @ direction) * direction
    lift /= np.linalg.norm(lift)
    return positions[i] + 1.6 * radius * lift - 0.5 * vector


def view_direction(positions: ArrayLike, motions: Sequence[ArrayLike] = (), *,
                   n_directions: int = 400) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(view direction, screen-up) under which no atom hides another: the direction, among
    `n_directions` spread over the sphere, that maximises the smallest distance between two atoms
    projected on the screen. Among directions within 5% of the best, the one that shows the
    `motions` ((n_sites, 3) displacements of the drawn modes) longest on the screen is taken.
    Screen-up is perpendicular to the molecule's longest projected extent, so that it lies wide.
    """
    points = np.asarray(positions, dtype=float)
    centred = points - points.mean(axis=0)
    k = np.arange(n_directions) + 0.5  # a Fibonacci half-sphere: d and -d show the same picture
    z = k / n_directions
    phi = np.pi * (1.0 + 5.0**0.5) * k
    r = np.sqrt(1.0 - z**2)
    directions = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    pairs = np.triu_indices(len(points), 1)
    gaps = (centred[:, None, :] - centred[None, :, :])[pairs]                    # (n_pairs, 3)
    along = gaps @ directions.T                                                   # (n_pairs, n_dir)
    across = np.sqrt(np.maximum(np.sum(gaps**2, axis=1)[:, None] - along**2, 0.0))
    score = across.min(axis=0) if len(gaps) else np.zeros(n_directions)
    near = np.flatnonzero(score >= 0.95 * score.max())
    shown = np.zeros(len(near))
    for motion in motions:
        m = np.asarray(motion, dtype=float).reshape(-1, 3)
        m = m / max(float(np.abs(m).max()), 1e-300)
        flat = m @ directions[near].T                                             # (n_sites, n_near)
        shown += np.sqrt(np.maximum(np.sum(m**2, axis=1)[:, None] - flat**2, 0.0)).sum(axis=0)
    # motions first; between equal motions (a linear molecule turned about its axis) the wider gap
    merit = shown / max(float(shown.max(initial=0.0)), 1e-300) + 0.01 * score[near] / max(float(score.max()), 1e-300)
    best = directions[near[int(np.argmax(merit))]]
    flat_points = centred - np.outer(centred @ best, best)
    _, _, axes = np.linalg.svd(flat_points, full_matrices=False)
    wide = axes[0] if np.linalg.norm(flat_points) > 1e-12 else np.cross(best, [0.0, 0.0, 1.0] if abs(best[2]) < 0.9 else [1.0, 0.0, 0.0])
    up = np.cross(best, wide)
    return best, up / np.linalg.norm(up)


#: Most arrows drawn on a network's C-alpha trace (larger structures show every k-th residue).
MAX_NETWORK_ARROWS = 100


def network_arrow_step(n_sites: int) -> int:
    """k: draw an arrow on every k-th residue, so that at most `MAX_NETWORK_ARROWS` are drawn.

    >>> network_arrow_step(76), network_arrow_step(1500)
    (1, 15)
    """
    return max(1, -(-int(n_sites) // MAX_NETWORK_ARROWS))
