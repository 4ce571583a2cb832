"""The continuum limit in three dimensions: sound velocities from the acoustic slopes at Gamma.

Along a Cartesian direction n the three acoustic branches leave Gamma as omega = v k with
corrections of order k^3, so the slope omega(k n) / k tends to the sound velocity v with an
error O(k^2). `acoustic_slopes` gives the raw slopes at chosen steps (for the measured order of
convergence); `sound_velocities` takes two steps, h and h/2, and removes the k^2 term by
Richardson extrapolation, (4 s(h/2) - s(h)) / 3, leaving O(h^4). The slope method needs no
elastic-constant model and includes the internal relaxation of crystals with a basis
(diamond, rock salt). The truth it is tested against is the Christoffel equation
det(C_ijkl n_j n_l - rho v^2 delta_ik) = 0 with the closed-form elastic constants of the
spring models (tests/test_crystals_continuum.py).

Rounding: the acoustic eigenvalues at step k are ~(k a)^2 ||D||, and LAPACK's absolute error
eps ||D|| becomes eps / (k a)^2 relative, 1e-11 at the default step k a ~ 6e-3.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen, short_repr
from vibra.crystals.dynamical import phonons, unit_direction
from vibra.units import UnitSystem

if TYPE_CHECKING:
    from vibra.crystals.force_constants import CrystalLike as Crystal  # the protocol: no import cycle

__all__ = ["SoundVelocities", "sound_velocities", "acoustic_slopes", "DEFAULT_STEP"]

#: Default step, as a fraction of the shortest reciprocal lattice vector.
DEFAULT_STEP = 1e-3


@dataclass(frozen=True, eq=False)
class SoundVelocities(Frozen):
    """Sound velocities along one direction.

    Attributes
    ----------
    direction : (3,) ndarray
        Unit Cartesian direction.
    velocities : (3,) ndarray
        The three acoustic velocities, ascending, in length per time unit of `units` (m/s in SI).
    error : (3,) ndarray
        |extrapolated - slope at h/2|: what the extrapolation removed (an upper estimate of the
        error of the slope alone; the extrapolated value is far closer), in the same unit.
    step : float
        The larger step h, in rad / length.
    units : UnitSystem
        The crystal's units.
    """

    direction: NDArray[np.float64]
    velocities: NDArray[np.float64]
    error: NDArray[np.float64]
    step: float
    units: UnitSystem

    def __repr__(self) -> str:
        direction = ", ".join(f"{x:.4g}" for x in self.direction)
        velocities = ", ".join(f"{v:.6g}" for v in self.velocities)
        unit = "m/s" if self.units.name == "SI" else f"{self.units.length} per time unit"
        return short_repr(self, f"direction ({direction})", f"velocities {velocities} {unit}",
                          f"error <= {float(np.max(self.error)):.2g}", f"{self.units.name} units")


def _direction(direction: ArrayLike, crystal: Crystal) -> NDArray[np.float64]:
    n = unit_direction(direction)
    for axis in range(3):
        if not crystal.periodic[axis] and abs(float(n @ crystal.reciprocal[axis])) > 1e-12 * np.linalg.norm(
                crystal.reciprocal[axis]):
            raise ValueError(f"direction {np.round(n, 6).tolist()} leaves the periodic plane (vacuum axis {axis}); "
                             "sound travels along the periodic directions only")
    return n


def acoustic_slopes(crystal: Crystal, direction: ArrayLike, steps: ArrayLike) -> NDArray[np.float64]:
    """(n_steps, 3) slopes omega(k n) / k of the three lowest branches at each step k (rad / length).

    Raises
    ------
    ValueError
        A zero direction, one out of the periodic plane of a 2-D crystal, non-positive steps.
    """
    n = _direction(direction, crystal)
    k = _validate.real_array(steps, "steps", ndim=1)
    _validate.positive(k, "steps", "step")
    q = (k[:, None] * n[None, :]) @ crystal.cell.T / (2.0 * np.pi)  # fractional q of the Cartesian k n
    omega = phonons(crystal, q).omega[:, :3]
    return omega / k[:, None]


def sound_velocities(crystal: Crystal, direction: ArrayLike, *, step: float | None = None) -> SoundVelocities:
    """The three sound velocities along a Cartesian `direction` (module docstring).

    Parameters
    ----------
    crystal : Crystal
        With force constants.
    direction : (3,) array_like
        Cartesian direction of propagation (normalised here).
    step : float, optional
        The larger step h, in rad / length; default DEFAULT_STEP times the shortest reciprocal
        lattice vector.

    Raises
    ------
    ValueError
        As `acoustic_slopes`; a non-positive step.
    """
    n = _direction(direction, crystal)
    periodic = np.array(crystal.periodic)
    h = (DEFAULT_STEP * float(np.linalg.norm(crystal.reciprocal[periodic], axis=1).min()) if step is None
         else _validate.positive_scalar(step, "step", "step"))
    slopes = acoustic_slopes(crystal, n, [h, h / 2.0])
    velocities = (4.0 * slopes[1] - slopes[0]) / 3.0
    return SoundVelocities(direction=n, velocities=velocities, error=np.abs(velocities - slopes[1]), step=h,
                           units=crystal.units)
