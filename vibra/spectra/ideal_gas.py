"""Ideal-gas thermochemistry of a molecule: translation, rigid rotation, harmonic vibrations and
electronic spin degeneracy, at any temperature and pressure (the model of ASE's
``IdealGasThermo``; McQuarrie, "Statistical Mechanics", chapters 5 and 8).

Per molecule, with k Boltzmann's constant, h Planck's, m the mass, I the principal moments of
inertia, sigma the rotational symmetry number and S the total electron spin:

- translation: H = 5/2 kT (3/2 kT of motion plus pV = kT), C_p = 5/2 k,
  S = k [ln((2 pi m kT / h^2)^(3/2) kT / p) + 5/2] (Sackur-Tetrode);
- rotation, linear: H = kT, C_p = k, S = k [ln(8 pi^2 I kT / (sigma h^2)) + 1];
  nonlinear: H = 3/2 kT, C_p = 3/2 k,
  S = k [ln(sqrt(pi I_A I_B I_C) / sigma (8 pi^2 kT / h^2)^(3/2)) + 3/2]; a single atom: 0;
- vibration: the harmonic oscillators of `thermochemistry` (H = ZPE + sum hbar omega / (e^x - 1),
  S, C_p = C_v), the same code, not a copy of its formulas;
- electronic: S = k ln(2S + 1), H = C_p = 0 (one spin multiplet, no excited states).

Energies are counted from the bottom of the potential well (ASE's ``potentialenergy = 0``), so
H includes the zero-point energy; G = H - T S. Constants from `scipy.constants` (k and h exact
since 2019; ASE's defaults are CODATA 2014, whose k differs by 3.5e-7 relative).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.modes import Modes
from vibra.molecules import VibrationalAnalysis, vibrational_analysis
from vibra.molecules.checks import check_atoms
from vibra.molecules.rigid_body import is_linear, principal_moments
from vibra.spectra.thermochemistry import (BOLTZMANN_EV_PER_K, LowModes, check_finite, thermochemistry,
                                          warn_negative_entropy)
from vibra.system import System, Vibrating

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["STANDARD_PRESSURE", "ThermoContribution", "IdealGasThermochemistry", "ideal_gas_thermochemistry"]

#: The standard pressure p° = 1 bar, in Pa.
STANDARD_PRESSURE = constants.bar

#: J/(mol K) per eV/K (per molecule), and kJ/mol per eV.
_J_PER_MOL_PER_EV = constants.e * constants.N_A

Shape = Literal["monatomic", "linear", "nonlinear"]


@dataclass(frozen=True, eq=False, repr=False)
class ThermoContribution(Result):
    """One part (translation, rotation, vibration or electronic) of the ideal-gas functions (a
    `vibra._results.Result` over the temperatures).

    Attributes
    ----------
    enthalpy : (n_T,) ndarray
        H of this part, in eV per molecule.
    entropy : (n_T,) ndarray
        S of this part, in eV/K per molecule.
    gibbs : (n_T,) ndarray
        H - T S of this part, in eV per molecule.
    heat_capacity : (n_T,) ndarray
        C_p of this part, in eV/K per molecule.
    """

    STORED = dict.fromkeys(("enthalpy", "entropy", "gibbs", "heat_capacity"), stored(("n_T",)))  # (vibra._results)
    AXIS, NOUNS, PATH = "n_T", ("temperature", "temperatures"), "ideal gas"

    enthalpy: NDArray[np.float64]
    entropy: NDArray[np.float64]
    gibbs: NDArray[np.float64]
    heat_capacity: NDArray[np.float64]


def _part(temperatures: NDArray[np.float64], enthalpy: ArrayLike, entropy: ArrayLike,
          heat_capacity: ArrayLike) -> ThermoContribution:
    h, s, c = (np.broadcast_to(np.asarray(v, dtype=float), temperatures.shape).copy()
               for v in (enthalpy, entropy, heat_capacity))
    return ThermoContribution(enthalpy=h, entropy=s, gibbs=h - temperatures * s, heat_capacity=c)


@dataclass(frozen=True, eq=False, repr=False)
class IdealGasThermochemistry(LowModes, Result):
    """Enthalpy, entropy, Gibbs energy and heat capacity of an ideal gas of one molecule (a
    `vibra._results.Result` over the temperatures, its parts sliced with it and stored as
    ``"translational.enthalpy"``, ...; `path` is the treatment of the low modes, ``"harmonic"``
    when none).

    Attributes
    ----------
    temperatures : (n_T,) ndarray
        Temperatures, in K.
    pressure : float
        Pressure, in Pa.
    enthalpy : (n_T,) ndarray
        H = sum of the parts, from the bottom of the well (ZPE included), in eV per molecule.
    entropy : (n_T,) ndarray
        S, in eV/K per molecule.
    gibbs : (n_T,) ndarray
        G = H - T S, in eV per molecule.
    heat_capacity : (n_T,) ndarray
        C_p, in eV/K per molecule.
    translational, rotational, vibrational, electronic : ThermoContribution
        The parts; pV = kT is counted in the translational enthalpy (k in its C_p).
    zero_point_energy : float
        sum_k hbar omega_k / 2 over the vibrations, in eV.
    mass : float
        Molecular mass, in amu.
    moments_of_inertia : (3,) ndarray
        Principal moments, ascending, in amu Angstrom^2.
    shape : {"monatomic", "linear", "nonlinear"}
        Which rotational model was used.
    symmetry_number : int
        Rotational symmetry number sigma (1 for a single atom).
    spin : float
        Total electron spin S (multiplicity 2S + 1).
    n_imaginary : int
        Imaginary modes left out of the vibrational part.
    low_frequency : {None, "grimme", "truhlar"}
        The treatment of the soft modes (`thermochemistry`); None: harmonic.
    scale_factor : float
        The factor every frequency was multiplied by.
    enthalpy_error, entropy_error, gibbs_error : (n_T,) ndarray
        Bounds propagated from each frequency's bound (`Thermochemistry`'s errors: only the
        vibrational part depends on the frequencies), eV and eV/K per molecule.
    """

    STORED = {**dict.fromkeys(("temperatures", "enthalpy", "entropy", "gibbs", "heat_capacity"), stored(("n_T",))),
              "moments_of_inertia": stored((3,)),  # how save / load check them (vibra._results)
              **dict.fromkeys(("enthalpy_error", "entropy_error", "gibbs_error"), stored(("n_T",), optional=True))}
    NESTED = dict.fromkeys(("translational", "rotational", "vibrational", "electronic"), ThermoContribution)
    AXIS, NOUNS = "n_T", ("temperature", "temperatures")

    temperatures: NDArray[np.float64]
    pressure: float
    enthalpy: NDArray[np.float64]
    entropy: NDArray[np.float64]
    gibbs: NDArray[np.float64]
    heat_capacity: NDArray[np.float64]
    translational: ThermoContribution
    rotational: ThermoContribution
    vibrational: ThermoContribution
    electronic: ThermoContribution
    zero_point_energy: float
    mass: float
    moments_of_inertia: NDArray[np.float64]
    shape: Shape
    symmetry_number: int
    spin: float
    n_imaginary: int
    low_frequency: str | None = None
    scale_factor: float = 1.0
    enthalpy_error: NDArray[np.float64] | None = None
    entropy_error: NDArray[np.float64] | None = None
    gibbs_error: NDArray[np.float64] | None = None

    def _repr_parts(self) -> tuple[str, ...]:
        return (f"{self._size()} {span(self.temperatures, 'K')}", f"{self.pressure:g} Pa", f"{self.shape}",
                f"symmetry number {self.symmetry_number}", f"mass {self.mass:.6g} amu")

    def entropy_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) S per mole, in J/(mol K)."""
        return self.entropy * _J_PER_MOL_PER_EV

    def heat_capacity_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) C_p per mole, in J/(mol K)."""
        return self.heat_capacity * _J_PER_MOL_PER_EV

    def enthalpy_kj_per_mol(self) -> NDArray[np.float64]:
        """(n_T,) H per mole, in kJ/mol."""
        return self.enthalpy * _J_PER_MOL_PER_EV / 1e3

    def gibbs_kj_per_mol(self) -> NDArray[np.float64]:
        """(n_T,) G per mole, in kJ/mol."""
        return self.gibbs * _J_PER_MOL_PER_EV / 1e3

    def table(self) -> str:
        """Text table: T (K), H and G (kJ/mol), S and C_p (J/(mol K)), with the parts of S."""
        parts = (self.translational, self.rotational, self.vibrational, self.electronic)
        lines = [f"ideal gas, {self.shape}, sigma = {self.symmetry_number}, spin = {self.spin:g}, "
                 f"p = {self.pressure:g} Pa, ZPE = {self.zero_point_energy:.6f} eV",
                 "      T/K     H/(kJ/mol)   S/(J/mol/K)  Cp/(J/mol/K)     G/(kJ/mol)   "
                 "S_trans   S_rot   S_vib  S_elec"]
        h, s, cp, g = (self.enthalpy_kj_per_mol(), self.entropy_j_per_mol_k(),
                       self.heat_capacity_j_per_mol_k(), self.gibbs_kj_per_mol())
        for i, t in enumerate(self.temperatures):
            split = "".join(f"{part.entropy[i] * _J_PER_MOL_PER_EV:8.2f}" for part in parts)
            lines.append(f"{t:9.2f}  {h[i]:13.5f}  {s[i]:12.4f}  {cp[i]:12.4f}  {g[i]:13.5f} {split}")
        return "\n".join(lines)


def _geometry(geometry: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Positions (Angstrom) and masses (amu) of a System or an ase.Atoms."""
    if isinstance(geometry, Vibrating):
        if geometry.is_generalized or geometry.units.name != "ASE" or geometry.dim != 3:
            raise ValueError("geometry must be a molecule: 3-D sites in units 'ASE' (amu, Angstrom), got "
                             f"{geometry.dim}-D sites in units {geometry.units.name!r}")
        return np.asarray(geometry.positions), np.asarray(geometry.masses)
    try:
        return check_atoms(geometry, "geometry")
    except TypeError:
        raise TypeError(f"geometry must be a vibra System or an ase.Atoms, got {type(geometry).__name__}") from None


def _symmetry_number(geometry: System | Atoms) -> int:
    """sigma from the point group of `geometry` (`vibra.molecules.point_group`)."""
    from vibra.molecules import point_group

    return int(point_group(geometry).symmetry_number)


def _spin(spin: Any) -> float:
    value = _validate.real_scalar(spin, "spin")
    if value < 0 or not float(2 * value).is_integer():
        raise ValueError(f"spin is {value!r}; the total electron spin S is 0, 1/2, 1, 3/2, ...")
    return value


def ideal_gas_thermochemistry(
    analysis: System | VibrationalAnalysis | Modes | ArrayLike,
    temperatures: ArrayLike,
    pressure: float = STANDARD_PRESSURE,
    *,
    spin: float = 0.0,
    symmetry_number: int | None = None,
    geometry: System | Atoms | None = None,
    low_frequency: str | None = None,
    cutoff: float = 100.0,
    scale_factor: float = 1.0,
) -> IdealGasThermochemistry:
    """H, S, G and C_p of a molecule as an ideal gas (translation, rotation, vibration, spin).

    Parameters
    ----------
    analysis : System or VibrationalAnalysis or Modes or (n_vibrations,) array_like
        The vibrations: a molecule (analysed here with `vibrational_analysis`), its analysis,
        its modes (rigid-body modes left out by `thermochemistry`'s threshold), or wavenumbers
        in cm^-1 (e.g. experimental fundamentals, a degenerate mode listed once per component).
    temperatures : float or (n_T,) array_like
        Temperatures, in K (> 0).
    pressure : float
        Pressure, in Pa (> 0); default 1 bar.
    spin : float
        Total electron spin S (0 closed shell, 1/2 radical, 1 triplet O2): S_el = k ln(2S + 1).
    symmetry_number : int, optional
        Rotational symmetry number sigma (CO2 2, H2O 2, NH3 3, CH4 12, C6H6 12); by default
        from the point group of the geometry (`vibra.molecules.point_group`).
    geometry : System or ase.Atoms, optional
        Positions (Angstrom) and masses (amu) for the mass and moments of inertia; by default
        the System `analysis` is or was computed from (a `VibrationalAnalysis` carries it);
        required for bare modes or wavenumbers.
    low_frequency, cutoff, scale_factor
        The soft modes' treatment (quasi-RRHO ``"grimme"``, ``"truhlar"``) and the frequency
        scale factor, as `thermochemistry` takes them.

    Returns
    -------
    IdealGasThermochemistry

    Raises
    ------
    TypeError
        `analysis` or `geometry` of the wrong kind; a non-integer symmetry number.
    ValueError
        No geometry; a geometry that is not a 3-D molecule in ASE units; modes of another
        atom count; a number of vibrations (real plus imaginary) other than 3N-6 (3N-5 linear,
        0 for one atom); a pressure or temperature not positive; a spin not a multiple of 1/2;
        a symmetry number < 1; a temperature at which a result is not a finite float (the message
        names it).

    Warns
    -----
    RuntimeWarning
        The entropy comes out negative (the classical translation and rotation do not hold that
        cold: below ~1 K for light molecules at 1 bar), naming the temperatures and the part.

    Examples
    --------
    >>> from vibra.molecules import co2
    >>> gas = ideal_gas_thermochemistry(co2(), 298.15, symmetry_number=2)
    >>> gas.shape, round(float(gas.entropy_j_per_mol_k()[0]), 1)    # tables: 213.8
    ('linear', 213.8)
    """
    if isinstance(analysis, Vibrating):
        geometry = analysis if geometry is None else geometry
        analysis = vibrational_analysis(analysis)
    if geometry is None and isinstance(analysis, VibrationalAnalysis):
        geometry = analysis.system
    if geometry is None:
        raise ValueError("geometry is required (the System or ase.Atoms the vibrations belong to) unless "
                         "analysis is a System or its VibrationalAnalysis: the moments of inertia need "
                         "positions and masses")
    positions, masses = _geometry(geometry)
    n_atoms = len(masses)
    n_dof = analysis.modes.n_dof if isinstance(analysis, VibrationalAnalysis) else (
        analysis.n_dof if isinstance(analysis, Modes) else None)
    if n_dof is not None and n_dof != 3 * n_atoms:
        raise ValueError(f"analysis has {n_dof} degrees of freedom but geometry has {n_atoms} atom(s) "
                         f"({3 * n_atoms} degrees of freedom); pass the geometry of the same molecule")
    vibrations = thermochemistry(analysis, temperatures, low_frequency=low_frequency, cutoff=cutoff,
                                 scale_factor=scale_factor)
    temps = vibrations.temperatures
    p = _validate.positive_scalar(pressure, "pressure", "pressure (Pa)")
    spin = _spin(spin)
    shape: Shape = "monatomic" if n_atoms == 1 else (
        "linear" if is_linear(positions, masses) else "nonlinear")
    expected = {"monatomic": 0, "linear": 3 * n_atoms - 5, "nonlinear": 3 * n_atoms - 6}[shape]
    found = len(vibrations.wavenumbers) + vibrations.n_imaginary
    if found != expected:
        raise ValueError(f"analysis gives {found} vibrations; a {shape} molecule of {n_atoms} atoms has "
                         f"{expected} (list a degenerate mode once per component)")
    if shape == "monatomic":
        sigma = 1
    elif symmetry_number is None:
        sigma = _symmetry_number(geometry)
    else:
        sigma = _validate.count(symmetry_number, "symmetry_number", low=1, high=1000)

    k = BOLTZMANN_EV_PER_K
    k_si = constants.k
    log_t = np.log(temps)              # logarithms of products of T: the products underflow at a tiny T
    mass_kg = float(np.sum(masses)) * constants.m_u
    translational = _part(
        temps, 2.5 * k * temps,
        k * (1.5 * (np.log(2 * np.pi * mass_kg * k_si / constants.h**2) + log_t) + np.log(k_si / p) + log_t + 2.5),
        2.5 * k)
    moments = principal_moments(positions, masses)
    inertia_si = moments * constants.m_u * constants.angstrom**2
    if shape == "monatomic":
        rotational = _part(temps, 0.0, 0.0, 0.0)
    elif shape == "linear":
        rotational = _part(temps, k * temps,
                           k * (np.log(8 * np.pi**2 * inertia_si[-1] * k_si / (sigma * constants.h**2)) + log_t + 1.0),
                           k)
    else:
        rotational = _part(
            temps, 1.5 * k * temps,
            k * (0.5 * np.log(np.pi * np.prod(inertia_si)) - np.log(sigma)
                 + 1.5 * (np.log(8 * np.pi**2 * k_si / constants.h**2) + log_t) + 1.5), 1.5 * k)
    vibrational = _part(temps, vibrations.internal_energy, vibrations.entropy, vibrations.heat_capacity)
    electronic = _part(temps, 0.0, k * np.log(2 * spin + 1), 0.0)
    parts = (translational, rotational, vibrational, electronic)
    enthalpy = sum((part.enthalpy for part in parts), np.zeros_like(temps))
    entropy = sum((part.entropy for part in parts), np.zeros_like(temps))
    with np.errstate(over="ignore", invalid="ignore"):
        gibbs = enthalpy - temps * entropy
    check_finite("ideal_gas_thermochemistry", temps, vibrations.wavenumbers, per_mode={},
                 totals={"enthalpy": enthalpy, "entropy": entropy, "gibbs": gibbs})
    warn_negative_entropy("ideal_gas_thermochemistry", temps, entropy, {
        "translation (Sackur-Tetrode, a classical gas)": translational.entropy,
        "rigid rotation (a classical rotor)": rotational.entropy, "the vibrations": vibrational.entropy})
    return IdealGasThermochemistry(
        temperatures=temps, pressure=p, enthalpy=enthalpy, entropy=entropy,
        gibbs=gibbs,
        heat_capacity=sum((part.heat_capacity for part in parts), np.zeros_like(temps)),
        translational=translational, rotational=rotational, vibrational=vibrational, electronic=electronic,
        zero_point_energy=vibrations.zero_point_energy, mass=float(np.sum(masses)),
        moments_of_inertia=moments, shape=shape, symmetry_number=sigma, spin=spin,
        n_imaginary=vibrations.n_imaginary, low_frequency=low_frequency, scale_factor=vibrations.scale_factor,
        enthalpy_error=vibrations.internal_energy_error, entropy_error=vibrations.entropy_error,
        gibbs_error=vibrations.helmholtz_energy_error,
    )
