"""Unit systems and frequency conversions.

Every `System` and every result carries a `UnitSystem`. Angular frequencies are stored in
rad per time unit of that system; conversions to Hz, THz, cm^-1 and meV go through the
factors built here from `scipy.constants` and `ase.units` (never typed in by hand).

The three systems:

- ``SI``: kg, m, N/m, s. omega in rad/s.
- ``ASE`` (molecules): amu, Angstrom, eV. The time unit is Angstrom * sqrt(amu / eV)
  (about 10.18 fs), so omega is in rad per that unit.
- ``dimensionless``: no physical scale; only omega is meaningful.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.unit_names import UNIT_NAMES, UNITS_EXPECTED, canonical_unit_name

__all__ = ["UnitSystem", "SI", "ASE", "DIMENSIONLESS", "UNIT_NAMES", "UNITS_EXPECTED", "unit_system", "omega_unit_text"]


@dataclass(frozen=True)
class UnitSystem:
    """A consistent set of units for masses, lengths, energies and time.

    Attributes
    ----------
    name : str
        ``"SI"``, ``"ASE"`` or ``"dimensionless"``.
    mass : str
        Name of the mass unit (``"kg"``, ``"amu"``).
    length : str
        Name of the length unit (``"m"``, ``"Angstrom"``).
    energy : str
        Name of the energy unit (``"J"``, ``"eV"``).
    time_s : float or None
        Length of one time unit in seconds; None when the system is dimensionless.
    """

    name: str
    mass: str
    length: str
    energy: str
    time_s: float | None

    def __post_init__(self) -> None:
        for field in ("name", "mass", "length", "energy"):
            _validate.text(getattr(self, field), field)
        if self.time_s is not None:
            # a zero or negative time unit would turn every conversion into inf, NaN or a sign flip
            object.__setattr__(self, "time_s", _validate.positive_scalar(self.time_s, "time_s", "time unit"))

    @property
    def stiffness(self) -> str:
        """Name of the stiffness unit (energy per length squared)."""
        if self.time_s is None:
            return "1"
        return "N/m" if self.name == "SI" else f"{self.energy}/{self.length}^2"

    @property
    def force(self) -> str:
        """Name of the force unit (energy per length)."""
        if self.time_s is None:
            return "1"
        return "N" if self.name == "SI" else f"{self.energy}/{self.length}"

    @property
    def receptance(self) -> str:
        """Name of the unit of a displacement per unit force (a frequency response)."""
        if self.time_s is None:
            return "dimensionless"
        return "m/N" if self.name == "SI" else f"{self.length} per {self.force}"

    @property
    def omega(self) -> str:
        """Name of the angular-frequency unit."""
        if self.time_s is None:
            return "rad / time unit"
        return "rad/s" if self.time_s == 1.0 else f"rad/({self.time_s:.4g} s)"

    @property
    def boltzmann(self) -> float:
        """k_B in this system's energy per kelvin (J/K in SI, eV/K in ASE); 1 when dimensionless,
        where a temperature is given as the energy k_B T itself.

        Examples
        --------
        >>> SI.boltzmann == constants.k, DIMENSIONLESS.boltzmann
        (True, 1.0)
        """
        if self.time_s is None:
            return 1.0
        per_kelvin = {"J": constants.k, "eV": constants.k / constants.e}
        if self.energy not in per_kelvin:
            raise ValueError(f"no Boltzmann constant for the energy unit {self.energy!r}; "
                             "expected 'J', 'eV' or a dimensionless system")
        return per_kelvin[self.energy]

    def _require_physical(self, what: str) -> float:
        if self.time_s is None:
            raise ValueError(
                f"cannot express {what}: the unit system is dimensionless; "
                "build the system with units='SI' or 'ASE'"
            )
        return self.time_s

    def omega_to_rad_per_s(self, omega: ArrayLike) -> NDArray[np.float64]:
        """(n,) angular frequencies converted to rad/s."""
        return _validate.real_numbers(omega, "omega") / self._require_physical("rad/s")

    def omega_to_hz(self, omega: ArrayLike) -> NDArray[np.float64]:
        """(n,) ordinary frequencies omega / 2 pi, in Hz."""
        return self.omega_to_rad_per_s(omega) / (2.0 * np.pi)

    def omega_to_thz(self, omega: ArrayLike) -> NDArray[np.float64]:
        """(n,) ordinary frequencies in THz."""
        return self.omega_to_hz(omega) / constants.tera

    def omega_to_cm1(self, omega: ArrayLike) -> NDArray[np.float64]:
        """(n,) wavenumbers omega / (2 pi c), in cm^-1."""
        return self.omega_to_hz(omega) / (constants.c / constants.centi)

    def omega_to_mev(self, omega: ArrayLike) -> NDArray[np.float64]:
        """(n,) quantum energies hbar omega, in meV."""
        return self.omega_to_rad_per_s(omega) * constants.hbar / constants.e / constants.milli

    def cm1_to_omega(self, wavenumber: ArrayLike) -> NDArray[np.float64]:
        """(n,) wavenumbers in cm^-1 converted to omega in this system's units."""
        hz = _validate.real_numbers(wavenumber, "wavenumber") * (constants.c / constants.centi)
        return 2.0 * np.pi * hz * self._require_physical("cm^-1")


def _ase_time_s() -> float:
    # One ASE time unit, Angstrom * sqrt(amu / eV), in seconds. Built from scipy.constants
    # (CODATA 2018+) so that `import vibra` does not import ase; ase.units uses CODATA 2014
    # by default, which differs from this by about 1e-8 relative.
    return constants.angstrom * np.sqrt(constants.atomic_mass / constants.electron_volt)


SI = UnitSystem("SI", mass="kg", length="m", energy="J", time_s=1.0)
ASE = UnitSystem("ASE", mass="amu", length="Angstrom", energy="eV", time_s=_ase_time_s())
DIMENSIONLESS = UnitSystem("dimensionless", mass="1", length="1", energy="1", time_s=None)

_BY_NAME = {system.name: system for system in (SI, ASE, DIMENSIONLESS)}


def unit_system(units: str | UnitSystem) -> UnitSystem:
    """Return the `UnitSystem` named `units` (``"SI"``, ``"ASE"``, ``"dimensionless"``, in any capitalisation).

    The one parser of unit names: the library's ``units=`` arguments and scene files' ``units``
    key both go through it.

    Examples
    --------
    >>> unit_system("SI").omega
    'rad/s'
    >>> round(float(unit_system("SI").omega_to_hz(2 * 3.141592653589793)), 12)
    1.0
    """
    if isinstance(units, UnitSystem):
        return units
    if not isinstance(units, str):
        raise TypeError(f"units must be a str or UnitSystem, got {type(units).__name__}")
    return _BY_NAME[canonical_unit_name(units)]


def omega_unit_text(units: UnitSystem, *, stiffness: str = "k", ascii: bool = False) -> str:
    """How a table or a label names omega's unit: ``"rad/s"`` for a physical system (show the values of
    `UnitSystem.omega_to_rad_per_s`), ``"√(k/m)"`` for a dimensionless one (omega in units of the square
    root of stiffness over mass; an elastic network passes ``stiffness="gamma"``: ``"√(γ/m)"``).

    Examples
    --------
    >>> omega_unit_text(SI), omega_unit_text(DIMENSIONLESS, stiffness="gamma"), omega_unit_text(DIMENSIONLESS, ascii=True)
    ('rad/s', '√(γ/m)', 'sqrt(k/m)')
    """
    if units.time_s is not None:
        return "rad/s"
    if ascii:
        return f"sqrt({stiffness}/m)"
    return f"√({stiffness.replace('gamma', 'γ')}/m)"
