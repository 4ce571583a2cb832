"""The Fermi-Pasta-Ulam-Tsingou chain (1955): the harmonic chain of Kneller, Mécanique analytique, §5.3 with
anharmonic springs, V = sum_b [k d_b^2 / 2 + alpha d_b^3 / 3 + beta d_b^4 / 4], d_b the
elongation of bond b.

`fput` returns the harmonic `System` (its normal modes are the chain's, eq. 159) and the
anharmonic part of the forces as a `BondForces`, which `integrate` runs in its compiled loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.chains.builders import ENDS, linear_chain
from vibra.system import System
from vibra.units import UnitSystem

__all__ = ["BondForces", "fput"]


@dataclass(frozen=True, eq=False)
class BondForces(Frozen):
    """Anharmonic forces of bonds between dofs: V_b(d) = alpha_b d^3 / 3 + beta_b d^4 / 4,
    d = u[j_b] - u[i_b] (an index -1 is a wall at rest). Added to -K u by `integrate`.

    Attributes
    ----------
    first, second : (n_bonds,) ndarray of int
        i_b and j_b, free-dof indices (-1 for a wall).
    alpha : (n_bonds,) ndarray
        Cubic coefficients, in energy / length^3.
    beta : (n_bonds,) ndarray
        Quartic coefficients, in energy / length^4.
    n_dof : int
        Number of dofs the forces act on.

    Examples
    --------
    >>> system, forces = fput(4, alpha=0.25, ends="fixed")
    >>> forces(np.array([0.0, 1.0, 0.0, 0.0])).tolist()   # bond 0-1 stretched, 1-2 compressed
    [0.25, 0.0, -0.25, 0.0]
    """

    first: NDArray[np.intp]
    second: NDArray[np.intp]
    alpha: NDArray[np.float64]
    beta: NDArray[np.float64]
    n_dof: int

    def _elongation(self, u: NDArray[np.float64]) -> NDArray[np.float64]:
        padded = np.append(np.asarray(u, dtype=float), 0.0)      # index -1: the wall at rest
        return padded[self.second] - padded[self.first]

    def __call__(self, u: ArrayLike) -> NDArray[np.float64]:
        """(n_dof,) anharmonic force at displacements u, in the force unit."""
        d = self._elongation(np.asarray(u, dtype=float))
        slope = (self.alpha + self.beta * d) * d * d
        out = np.zeros(self.n_dof + 1)
        np.add.at(out, self.first, slope)
        np.add.at(out, self.second, -slope)
        return out[:-1]

    def potential(self, u: ArrayLike) -> float:
        """The anharmonic potential energy at displacements u, in the energy unit."""
        d = self._elongation(np.asarray(u, dtype=float))
        return float(np.sum(self.alpha * d**3 / 3.0 + self.beta * d**4 / 4.0))

    def potentials(self, positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """(n_records,) the anharmonic energy of each row of an (n_records, n_dof) array."""
        padded = np.hstack([positions, np.zeros((positions.shape[0], 1))])
        d = padded[:, self.second] - padded[:, self.first]
        return np.sum(self.alpha * d**3 / 3.0 + self.beta * d**4 / 4.0, axis=1)


def fput(
    n: int,
    alpha: float = 0.0,
    beta: float = 0.0,
    ends: Literal["fixed", "periodic", "free"] = "fixed",
    *,
    mass: float = 1.0,
    stiffness: float = 1.0,
    units: str | UnitSystem = "dimensionless",
) -> tuple[System, BondForces]:
    """An alpha- / beta-FPUT chain of n moving masses: its harmonic `System` and anharmonic forces.

    ``ends="fixed"`` ties both end masses to walls at rest (FPUT's u_0 = u_{N+1} = 0, n + 1
    bonds); ``"periodic"`` closes the ring (n bonds); ``"free"`` leaves the ends free (n - 1).
    The equation of motion of an inner site is FPUT's
    m u_i'' = k (u_{i+1} - 2 u_i + u_{i-1}) + alpha [(u_{i+1} - u_i)^2 - (u_i - u_{i-1})^2]
    + beta [(u_{i+1} - u_i)^3 - (u_i - u_{i-1})^3].

    Parameters
    ----------
    n : int
        Number of moving masses, n >= 2 (FPUT's N - 1 for N intervals with fixed ends).
    alpha, beta : float
        Cubic and quartic coefficients of each bond's potential, in energy / length^3 and
        energy / length^4 (FPUT's alpha = 1/4 for the alpha chain).
    ends : {"fixed", "periodic", "free"}
        End conditions.
    mass, stiffness : float
        Site mass and harmonic spring constant k (positive).
    units : str or UnitSystem
        ``"dimensionless"`` (default: k_B = 1) or ``"SI"`` / ``"ASE"``.

    Returns
    -------
    (System, BondForces)
        The harmonic chain (`vibra.chains.linear_chain`) and the anharmonic forces to pass to
        ``integrate(..., forces=...)``.

    Raises
    ------
    ValueError
        n < 2, unknown ends, a non-finite alpha or beta, a mass or stiffness not positive.

    Examples
    --------
    >>> system, forces = fput(32, alpha=0.25)
    >>> system.n_dof, forces.alpha.shape   # 32 masses, 33 bonds with the walls
    (32, (33,))
    """
    n = _validate.min_count(n, "n", low=2, what="an FPUT chain")
    alpha = _validate.real_scalar(alpha, "alpha")
    beta = _validate.real_scalar(beta, "beta")
    _validate.choice(ends, "ends", ENDS)
    mass = _validate.positive_scalar(mass, "mass", "mass")
    stiffness = _validate.positive_scalar(stiffness, "stiffness", "spring constant")
    system = linear_chain(n, mass=mass, stiffness=stiffness, ends=ends, units=units,
                          name=f"FPUT chain (n={n}, alpha={alpha:g}, beta={beta:g}, {ends} ends)")
    left = np.arange(n - 1)
    first, second = left, left + 1
    if ends == "fixed":
        first = np.concatenate([[-1], first, [n - 1]])
        second = np.concatenate([[0], second, [-1]])
    elif ends == "periodic":
        first = np.append(first, n - 1)
        second = np.append(second, 0)
    n_bonds = first.size
    forces = BondForces(first=first.astype(np.intp), second=second.astype(np.intp),
                        alpha=np.full(n_bonds, alpha), beta=np.full(n_bonds, beta), n_dof=n)
    return system, forces
