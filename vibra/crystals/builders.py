"""Builders of the textbook lattices with nearest-neighbour (or more) springs.

Every builder takes ``(a, mass(es), stiffness, *, shells=1, transverse=0.0, units="SI")`` like
the chain builders take units, and returns a `Crystal` on its primitive cell with spring force
constants (`vibra.crystals.springs`): `stiffness` and `transverse` are one value or one per
shell. `a` is the conventional lattice constant (the cube edge for the cubic lattices, the
cell edge for the square and honeycomb ones: graphene's a = sqrt(3) times the bond length).

The 2-D lattices (`square`, `honeycomb`) are 3-D cells with a vacuum axis along z of length
`vacuum` (default 10 a, ``periodic=(True, True, False)``): atoms move in three dimensions, the
in-plane branches are the 2-D lattice's, and the out-of-plane (flexural) branch comes from the
transverse stiffness alone (zero with central springs).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from vibra._core import validate as _validate
from vibra.crystals.crystal import Crystal
from vibra.crystals.springs import springs
from vibra.units import UnitSystem

__all__ = ["simple_cubic", "bcc", "fcc", "diamond", "rock_salt", "square", "honeycomb"]

_FCC = 0.5 * np.array([[0.0, 1.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 0.0]])
_BCC = 0.5 * np.array([[-1.0, 1.0, 1.0], [1.0, -1.0, 1.0], [1.0, 1.0, -1.0]])


def _build(name: str, a: float, cell: np.ndarray, fractional: list[list[float]], masses: ArrayLike,
           stiffness: ArrayLike, shells: int, transverse: ArrayLike, units: str | UnitSystem,
           periodic: tuple[bool, bool, bool] = (True, True, True), symbols: tuple[str, ...] | None = None
           ) -> Crystal:
    a = _validate.positive_scalar(a, "a", "lattice constant")
    mass = _validate.real_array(masses, "mass" if len(fractional) == 1 else "masses", ndim=(0, 1))
    if mass.ndim == 1 and mass.shape[0] != len(fractional):
        raise ValueError(f"masses must have {len(fractional)} entries (one per atom of the {name} basis), "
                         f"got {mass.shape[0]}")
    crystal = Crystal.from_cell(a * cell, fractional, mass, fractional=True, symbols=symbols, periodic=periodic,
                                units=units, name=name)
    return springs(crystal, shells=shells, stiffness=stiffness, transverse=transverse)


def simple_cubic(a: float, mass: ArrayLike, stiffness: ArrayLike, *, shells: int = 1,
                 transverse: ArrayLike = 0.0, units: str | UnitSystem = "SI") -> Crystal:
    """Simple cubic lattice of edge `a`, one atom of `mass` per cell (6 nearest neighbours at a)."""
    return _build("simple cubic", a, np.eye(3), [[0.0, 0.0, 0.0]], mass, stiffness, shells, transverse, units)


def bcc(a: float, mass: ArrayLike, stiffness: ArrayLike, *, shells: int = 1, transverse: ArrayLike = 0.0,
        units: str | UnitSystem = "SI") -> Crystal:
    """Body-centred cubic, cube edge `a`, primitive cell a/2 (-1,1,1), ... (8 neighbours at a sqrt(3)/2)."""
    return _build("bcc", a, _BCC, [[0.0, 0.0, 0.0]], mass, stiffness, shells, transverse, units)


def fcc(a: float, mass: ArrayLike, stiffness: ArrayLike, *, shells: int = 1, transverse: ArrayLike = 0.0,
        units: str | UnitSystem = "SI") -> Crystal:
    """Face-centred cubic, cube edge `a`, primitive cell a/2 (0,1,1), ... (12 neighbours at a / sqrt(2)).

    Examples
    --------
    >>> argon = fcc(1.0, 1.0, 2.0)          # omega at X: sqrt(4k/m) twice, sqrt(8k/m)
    >>> argon.frequencies([[0.5, 0.0, 0.5]]).round(12).tolist()
    [[2.828427124746, 2.828427124746, 4.0]]
    """
    return _build("fcc", a, _FCC, [[0.0, 0.0, 0.0]], mass, stiffness, shells, transverse, units)


def diamond(a: float, masses: ArrayLike, stiffness: ArrayLike, *, shells: int = 1, transverse: ArrayLike = 0.0,
            units: str | UnitSystem = "SI") -> Crystal:
    """Diamond: fcc with atoms at 0 and a/4 (1,1,1) (4 neighbours at a sqrt(3)/4); one mass or two."""
    return _build("diamond", a, _FCC, [[0.0, 0.0, 0.0], [0.25, 0.25, 0.25]], masses, stiffness, shells,
                  transverse, units)


def rock_salt(a: float, masses: ArrayLike, stiffness: ArrayLike, *, shells: int = 1,
              transverse: ArrayLike = 0.0, units: str | UnitSystem = "SI") -> Crystal:
    """Rock salt: fcc with atoms at 0 and a/2 (1,1,1) (6 unlike neighbours at a/2); two masses."""
    return _build("rock salt", a, _FCC, [[0.0, 0.0, 0.0], [0.5, 0.5, 0.5]], masses, stiffness, shells,
                  transverse, units, symbols=("A", "B"))


def _planar(a: float, vacuum: float | None, in_plane: np.ndarray) -> np.ndarray:
    depth = 10.0 if vacuum is None else _validate.positive_scalar(vacuum, "vacuum", "vacuum length") / a
    cell = np.zeros((3, 3))
    cell[:2, :2] = in_plane
    cell[2, 2] = depth
    return cell


def square(a: float, mass: ArrayLike, stiffness: ArrayLike, *, shells: int = 1, transverse: ArrayLike = 0.0,
           vacuum: float | None = None, units: str | UnitSystem = "SI") -> Crystal:
    """Square lattice of edge `a` in the xy plane (4 neighbours at a), vacuum along z."""
    a = _validate.positive_scalar(a, "a", "lattice constant")
    cell = _planar(a, vacuum, np.eye(2))
    return _build("square", a, cell, [[0.0, 0.0, 0.0]], mass, stiffness, shells, transverse, units,
                  periodic=(True, True, False))


def honeycomb(a: float, masses: ArrayLike, stiffness: ArrayLike, *, shells: int = 1,
              transverse: ArrayLike = 0.0, vacuum: float | None = None, units: str | UnitSystem = "SI") -> Crystal:
    """Honeycomb (graphene) lattice, cell edge `a` (bond a / sqrt(3)), two atoms, vacuum along z."""
    a = _validate.positive_scalar(a, "a", "lattice constant")
    cell = _planar(a, vacuum, np.array([[1.0, 0.0], [0.5, np.sqrt(3.0) / 2.0]]))
    return _build("honeycomb", a, cell, [[1 / 3, 1 / 3, 0.0], [2 / 3, 2 / 3, 0.0]], masses, stiffness, shells,
                  transverse, units, periodic=(True, True, False))
