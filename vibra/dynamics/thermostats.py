"""Thermostats for `vibra.dynamics.integrate`: the isokinetic (Gauss) constraint and Nosé-Hoover chains.

Temperatures are in kelvin for SI and ASE systems (k_B from `UnitSystem.boltzmann`); a
dimensionless system takes k_B = 1, so its temperature is the energy k_B T itself. Times are
in the system's time unit.
"""

from __future__ import annotations

from dataclasses import dataclass

from vibra._core import validate as _validate

__all__ = ["Isokinetic", "NoseHoover", "Thermostat"]


@dataclass(frozen=True)
class Isokinetic:
    """Gauss's isokinetic thermostat (Kneller, Mécanique analytique, §4.2, example 10): the kinetic energy is held at
    K = n_dof k_B T / 2 by the friction mu = sum F.v / sum m v^2 (for Kneller's 3-D oscillator,
    mu = -K (r . r') / (3 k_B T)).

    `integrate` scales v0 to that kinetic energy (v0 sets the direction of the velocities) and
    records mu in `Trajectory.thermostat_state`. Its kick is the exact flow of
    v' = F / m - mu v at fixed positions (Zhang, J. Chem. Phys. 106, 6102 (1997); Minary,
    Martyna and Tuckerman, J. Chem. Phys. 118, 2510 (2003)), composed with exact drifts: the
    scheme keeps K exactly in exact arithmetic and stays time-reversible, unlike a projection
    (rescaling v after a plain kick), which is only first-order accurate in the constraint force.
    Each kick ends with a rescaling to the target K that removes the rounding drift only (a
    change of a few ulps), so K stays constant to rounding over any run length.

    Parameters
    ----------
    temperature : float
        T, in K (SI, ASE) or as k_B T (dimensionless systems); positive and finite.

    Raises
    ------
    ValueError
        A temperature that is not positive and finite.

    Examples
    --------
    >>> Isokinetic(2.0).temperature
    2.0
    """

    temperature: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "temperature",
                           _validate.positive_scalar(self.temperature, "temperature", "temperature"))


@dataclass(frozen=True)
class NoseHoover:
    """A Nosé-Hoover thermostat (chain=1) or Nosé-Hoover chain (Martyna, Klein and Tuckerman,
    J. Chem. Phys. 97, 2635 (1992)): the canonical ensemble at `temperature`.

    Masses Q_1 = n_dof k_B T tau^2 and Q_j = k_B T tau^2 (j >= 2). The conserved extended
    energy K + V + sum Q_j xi_j^2 / 2 + n_dof k_B T eta_1 + k_B T sum_{j>=2} eta_j is
    `Trajectory.conserved`; the thermostat variables (xi_1..xi_M, eta_1..eta_M) are
    `Trajectory.thermostat_state`.

    Parameters
    ----------
    temperature : float
        T, in K (SI, ASE) or as k_B T (dimensionless); positive and finite.
    tau : float
        The thermostat's time scale, in the system's time unit (of the order of the periods
        being thermostatted); positive and finite.
    chain : int
        Number of thermostats M in the chain, 1 to 64.

    Raises
    ------
    ValueError
        A temperature or tau that is not positive and finite; chain outside 1..64.

    Examples
    --------
    >>> NoseHoover(1.0, tau=1.0, chain=4).chain
    4
    """

    temperature: float
    tau: float
    chain: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "temperature",
                           _validate.positive_scalar(self.temperature, "temperature", "temperature"))
        object.__setattr__(self, "tau", _validate.positive_scalar(self.tau, "tau", "time scale"))
        object.__setattr__(self, "chain", _validate.count(self.chain, "chain", low=1, high=64))


Thermostat = Isokinetic | NoseHoover
