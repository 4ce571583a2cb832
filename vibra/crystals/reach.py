"""Does a supercell hold the calculator's range? Checked from sizes before any force call, and on the force constants after.

- `check_range_from_sizes`: an atom's own periodic images must lie farther than its nearest
  neighbours, or displacing it moves them too and every force constant vanishes (copper on a
  1x1x1 supercell gave all-zero phonons with an error bound of 1e-15): refused, naming the
  supercell needed, before any force call.
- `supercell_reach`: the blocks of pairs beyond half the supercell's shortest lattice vector
  (where pairs meet their own images and phonopy splits them) against the largest inner block;
  `warn_range` turns a large ratio into a `SupercellRangeWarning` naming the supercell that
  holds the range measured.

Used by `vibra.crystals.finite_difference`; distances in Angstrom (ASE units).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from vibra.crystals.crystal import Crystal

if TYPE_CHECKING:
    from phonopy import Phonopy

__all__ = ["EDGE_RTOL", "MAX_SUGGESTED", "SupercellRangeWarning", "SupercellReach", "check_range_from_sizes",
           "supercell_reach", "warn_range"]


#: Force-constant blocks beyond the supercell's inscribed radius (half its shortest lattice
#: vector, where a pair starts to meet its own periodic images) larger than this fraction of the
#: largest inner block draw a `SupercellRangeWarning`: the calculator's range then reaches past
#: the supercell, and phonopy's even split of those blocks over equidistant images may be wrong
#: by as much as the blocks themselves; 5e-2 keeps that below a few percent of a frequency.
#: Measured on EMT copper (primitive fcc cell): 2x2x2 holds no pair inside its radius, a
#: conventional-cube 2x2x2 supercell 0.23 (both flagged); 4x4x4 1.3e-2 at 5.1 Angstrom (the
#: fourth shell, split symmetrically: frequencies within 0.05% of 6x6x6's), 5x5x5 1e-4 (held).
#: The check is necessary, not sufficient: a range longer than the whole supercell folds onto
#: inner pairs where no edge shows it (3x3x3 measures 6e-3, yet its frequencies are 0.9% off
#: 6x6x6's at q = (0.2, 0.1, 0)); converge against a larger supercell. The edge blocks are not
#: added to `error_blocks`, which bound the finite-difference error of the supercell given.
EDGE_RTOL = 5e-2
#: The largest diagonal supercell edge `SupercellReach.needed` proposes, in cells.
MAX_SUGGESTED = 24


class SupercellRangeWarning(UserWarning):
    """The force constants reach the supercell's edge: the calculator's range may exceed it."""


@dataclass(frozen=True)
class SupercellReach:
    """How far a supercell holds the calculator's range, measured on its force constants.

    Attributes
    ----------
    inscribed : float
        Half the shortest lattice vector of the supercell (periodic axes), Angstrom: pairs farther
        apart meet their own periodic images (phonopy splits them over the equidistant ones).
    edge_ratio : float
        Largest block of a pair at or beyond `inscribed`, over the largest block of a pair inside
        it (self terms excluded); inf when the supercell holds no pair inside it.
    edge_distance : float
        Distance of the pair with that largest edge block, Angstrom (0 without one).
    needed : (3,) ndarray of int
        The smallest diagonal supercell (periodic axes grown together) whose inscribed radius
        exceeds the farthest pair whose block exceeds EDGE_RTOL of the largest: the least that
        holds the range measured here (the true range may be longer: check with a larger one).
    """

    inscribed: float
    edge_ratio: float
    edge_distance: float
    needed: NDArray[np.int64]

    @property
    def holds_range(self) -> bool:
        """True when no block at the supercell's edge exceeds EDGE_RTOL of the largest."""
        return self.edge_ratio <= EDGE_RTOL


def _shortest_supercell_vector(cell: NDArray[np.float64], size: NDArray[np.int64],
                               periodic: tuple[bool, bool, bool]) -> float:
    """Length of the shortest nonzero lattice vector of the diagonal supercell, periodic axes only, Angstrom."""
    axes = [range(-2, 3) if periodic[k] else range(0, 1) for k in range(3)]
    combos = np.array([(a, b, c) for a in axes[0] for b in axes[1] for c in axes[2] if (a, b, c) != (0, 0, 0)],
                      dtype=float)
    if combos.size == 0:
        return float("inf")
    return float(np.linalg.norm((combos * size) @ cell, axis=1).min())


def _nearest_neighbour(unit: Crystal) -> float:
    """Shortest distance between two distinct atoms (periodic images across periodic axes), Angstrom."""
    frac = unit.fractional
    shifts = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1)], dtype=float)
    shifts = shifts[(shifts[:, ~np.array(unit.periodic)] == 0).all(axis=1)]
    delta = frac[None, :, None, :] - frac[:, None, None, :] + shifts[None, None, :, :]
    distance = np.linalg.norm(delta @ unit.cell, axis=-1)
    distance[distance < 1e-9] = np.inf  # an atom and itself
    return float(distance.min())


def _grown(unit: Crystal, size: NDArray[np.int64], radius: float) -> NDArray[np.int64]:
    """The smallest diagonal supercell from `size` (periodic axes grown together) whose half shortest vector exceeds `radius`."""
    grown = size.copy()
    periodic = np.array(unit.periodic)
    while _shortest_supercell_vector(unit.cell, grown, unit.periodic) / 2.0 <= radius * (1.0 + 1e-9):
        if grown[periodic].max() >= MAX_SUGGESTED:
            break
        grown[periodic] += 1
    return grown


def check_range_from_sizes(unit: Crystal, size: NDArray[np.int64]) -> None:
    """Refuse, before any force call, a supercell in which an atom's nearest neighbours are its own images."""
    shortest = _shortest_supercell_vector(unit.cell, size, unit.periodic)
    nearest = _nearest_neighbour(unit)
    if shortest <= nearest * (1.0 + 1e-6):
        needed = size.copy()
        periodic = np.array(unit.periodic)
        while _shortest_supercell_vector(unit.cell, needed, unit.periodic) <= nearest * (1.0 + 1e-6):
            needed[periodic] += 1
        raise ValueError(f"supercell {size.tolist()} is too small for {unit.name!r}: an atom's periodic images lie "
                         f"{shortest:.4g} Angstrom apart, no farther than its nearest neighbours ({nearest:.4g} "
                         "Angstrom), so displacing it moves its neighbours with it and the force constants vanish; "
                         f"it needs at least {needed.tolist()} (more for a calculator that reaches further)")


def supercell_reach(phonon: Phonopy, force_constants: NDArray[np.float64], unit: Crystal,
                    size: NDArray[np.int64]) -> SupercellReach:
    """Measure how far the supercell force constants reach its edge (see `SupercellReach`)."""
    primitive = phonon.primitive
    fc = np.asarray(force_constants, dtype=float)
    p2s = np.asarray(primitive.p2s_map)
    rows = fc if fc.shape[0] == len(p2s) else fc[p2s]
    svecs, multi = primitive.get_smallest_vectors()
    first = np.asarray(svecs)[multi[:, :, 1]]  # (n_s, n_p, 3): one shortest vector per pair
    distance = np.linalg.norm(first @ np.asarray(primitive.cell, dtype=float), axis=-1).T  # (n_p, n_s)
    inscribed = _shortest_supercell_vector(unit.cell, size, unit.periodic) / 2.0
    block = np.abs(rows).max(axis=(2, 3))
    inside = (distance > 1e-9) & (distance < inscribed * (1.0 - 1e-6))
    edge = distance >= inscribed * (1.0 - 1e-6)
    largest = float(block[inside].max()) if inside.any() else 0.0
    if not edge.any():
        return SupercellReach(inscribed, 0.0, 0.0, size)
    k = np.unravel_index(int(np.argmax(np.where(edge, block, -1.0))), block.shape)
    if largest == 0.0:
        ratio = float("inf") if block[k] > 0 or not inside.any() else 0.0
    else:
        ratio = float(block[k]) / largest
    scale = max(largest, float(block[k]))
    significant = (block > EDGE_RTOL * scale) & (distance > 1e-9)
    farthest = float(distance[significant].max()) if significant.any() else 0.0
    return SupercellReach(inscribed, ratio, float(distance[k]), _grown(unit, size, farthest))


def warn_range(name: str, size: NDArray[np.int64], reach: SupercellReach) -> None:
    shown = "x".join(str(int(n)) for n in size)
    ratio = "every block" if not np.isfinite(reach.edge_ratio) else f"{reach.edge_ratio:.2g} of the largest"
    warnings.warn(f"the force constants of {name!r} reach the edge of the {shown} supercell: a block at "
                  f"{reach.edge_distance:.4g} Angstrom (beyond half its shortest lattice vector, "
                  f"{reach.inscribed:.4g} Angstrom, where pairs meet their own images) is {ratio}; the calculator's "
                  f"range exceeds the supercell: use supercell={tuple(int(n) for n in reach.needed)} or larger", SupercellRangeWarning, stacklevel=3)
