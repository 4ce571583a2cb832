"""A synthetic protein assembly for the iterative path's benchmark (issue 47 item 5).

`synthetic_assembly(n_sites)` packs copies of ubiquitin's 76 C-alpha atoms (the bundled
`networks/ubiquitin/1ubi.pdb`) on an orthorhombic lattice, all in the same orientation, the
spacing along each axis the smallest at which no two sites of neighbouring copies come closer
than `CONTACT` Å (`lattice_spacing`): the copies touch face to face, joined by many springs
within the ANM cutoff, one connected network (six rigid-body modes, checked in the benchmark). The copies fill the lattice in
order along x, then y, then z (a near-cube), the last one truncated to give exactly `n_sites`
sites. Pure: positions out, no files written.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: Closest approach, in Å, of two sites of neighbouring copies (the C-alpha spacing along a chain).
CONTACT = 3.8


def lattice_spacing(unit: np.ndarray, contact: float = CONTACT) -> np.ndarray:
    """(3,) the smallest shifts along x, y and z (to 0.01 Å) at which a copy of `unit` keeps every
    site at least `contact` Å from every site of the copy shifted: the copies touch face to face."""
    from scipy.spatial import cKDTree

    tree = cKDTree(unit)
    spacing = np.zeros(3)
    for axis in range(3):
        low, high = 0.0, float(np.ptp(unit[:, axis])) + contact
        while high - low > 0.01:
            middle = 0.5 * (low + high)
            shift = np.zeros(3)
            shift[axis] = middle
            low, high = (middle, high) if tree.query(unit + shift)[0].min() < contact else (low, middle)
        spacing[axis] = high
    return spacing


def ubiquitin() -> np.ndarray:
    """(76, 3) C-alpha coordinates of 1UBI, centred, in Å."""
    from vibra import networks

    coords = np.asarray(networks.from_pdb(ROOT / "networks" / "ubiquitin" / "1ubi.pdb").positions, dtype=float)
    return coords - coords.mean(axis=0)


def synthetic_assembly(n_sites: int) -> np.ndarray:
    """(n_sites, 3) positions, in Å, of copies of ubiquitin packed on a lattice (see the module)."""
    unit = ubiquitin()
    spacing = lattice_spacing(unit)
    copies = -(-n_sites // unit.shape[0])
    side = int(np.ceil(copies ** (1.0 / 3.0)))
    cells = np.stack(np.unravel_index(np.arange(copies), (side, side, side), order="F"), axis=1) * spacing
    positions = unit[None, :, :] + cells[:, None, :]
    return positions.reshape(-1, 3)[:n_sites]
