"""Spectroscopy from normal modes: IR and Raman activity, broadened spectra, harmonic
thermochemistry and isotope shifts.

Everything here starts from a `vibra.System` of sites in ASE units (amu, Angstrom, eV) and
its `vibra.Modes`. The mode shapes u_k are M-orthonormal Cartesian displacements (seed 003
eq. 151), so a displacement along mode k by the normal coordinate Q_k is u = u_k Q_k, with
Q_k in Angstrom * sqrt(amu).

Models (see docs/spectra.md):

- IR, point charges: mu = sum_i q_i r_i, so dmu/dQ_k = sum_i q_i u_k[i] (e / sqrt(amu)).
  From a calculator: dmu_a/dx_ib by central differences of ``atoms.get_dipole_moment()``,
  projected on the modes. Intensity |dmu/dQ_k|^2 in e^2/amu; times
  N_A / (12 epsilon_0 c^2) it is the integrated absorption coefficient in km/mol.
- Raman, bond polarisabilities: each bond adds
  alpha_b = alpha_par e e^T + alpha_perp (I - e e^T) (e the unit bond vector), whose two
  values depend on the bond length. The mode's polarisability derivative alpha'_k collects
  the bond stretch and the bond rotation terms; the activity is 45 a'^2 + 7 g'^2 with the
  isotropic invariant a' = tr(alpha')/3 and the anisotropy g'^2 (Long, "The Raman Effect").
- Thermochemistry of independent harmonic oscillators, with the same formulas as ASE's
  ``HarmonicThermo``.

Rigid-body modes (|omega| <= zero_rtol * max|omega|, or within the mode's own error, and,
when a `vibra.molecules.VibrationalAnalysis` is passed as the modes, every mode it matched to
a translation or rotation) are skipped everywhere; imaginary modes are skipped with a
RuntimeWarning.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Mapping, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra import _validate
from vibra.modes import Modes
from vibra.molecules import ISOTOPE_MASSES as _ISOTOPE_TABLE
from vibra.molecules import VibrationalAnalysis
from vibra._frozen import _freeze_arrays
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = [
    "ZERO_RTOL", "KM_PER_MOL_PER_E2_AMU", "BOLTZMANN_EV_PER_K", "ISOTOPE_MASSES",
    "PAULING_ELECTRONEGATIVITY",
    "IRSpectrum", "RamanSpectrum", "StickSpectrum", "BroadenedSpectrum", "Thermochemistry",
    "IsotopeShifts",
    "ir_spectrum", "raman_spectrum", "dipole_derivatives", "electronegativity_charges",
    "broadened_spectrum", "thermochemistry", "isotope_shifts",
]

#: Default relative threshold for rigid-body modes: |omega| <= ZERO_RTOL * max|omega|
#: (0.35 cm^-1 when the highest mode is at 3500 cm^-1). Modes within their own computed
#: error of zero are skipped too. Finite-difference Hessians from a calculator leave
#: rotations at up to tens of cm^-1, which no threshold separates safely from soft
#: vibrations: pass ``vibra.molecules.vibrational_analysis(system)`` as the modes instead.
ZERO_RTOL = 1e-4

#: N_A / (12 epsilon_0 c^2), converting |dmu/dQ|^2 in e^2/amu to an integrated absorption
#: coefficient in km/mol (about 974.88).
KM_PER_MOL_PER_E2_AMU = (
    constants.N_A * constants.e**2
    / (12.0 * constants.epsilon_0 * constants.c**2 * constants.atomic_mass) / constants.kilo
)

#: Boltzmann's constant in eV/K (CODATA 2018 via scipy; ase.units.kB is CODATA 2014 and
#: differs by 3.4e-7 relative).
BOLTZMANN_EV_PER_K = constants.k / constants.e

#: E = h c nu~ : eV per cm^-1.
_EV_PER_CM1 = constants.h * constants.c / constants.centi / constants.e

#: Isotope label -> mass in amu (``"13C"``, ``"18O"``, ``"D"``, ...): the table of
#: `vibra.molecules` (NIST/AME values), accepted by `isotope_shifts` in place of a number.
ISOTOPE_MASSES: Mapping[str, float] = _ISOTOPE_TABLE

#: Pauling electronegativities (CRC Handbook of Chemistry and Physics) used by
#: `electronegativity_charges`.
PAULING_ELECTRONEGATIVITY: Mapping[str, float] = {
    "H": 2.20, "Li": 0.98, "B": 2.04, "C": 2.55, "N": 3.04, "O": 3.44, "F": 3.98,
    "Na": 0.93, "Mg": 1.31, "Al": 1.61, "Si": 1.90, "P": 2.19, "S": 2.58, "Cl": 3.16,
    "K": 0.82, "Br": 2.96, "I": 2.66,
}

_SHAPES = ("lorentzian", "gaussian")
_BLOCK = 1 << 20   # entries of one profile block in broadened_spectrum (8 MiB)
_IR_UNITS = ("km/mol", "e^2/amu")


# ---------------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class StickSpectrum:
    """Line positions and strengths, degenerate lines merged.

    Attributes
    ----------
    wavenumbers : (n_lines,) ndarray
        Line positions, ascending, in cm^-1.
    intensities : (n_lines,) ndarray
        Line strengths (summed over the modes of a degenerate line), in `unit`.
    unit : str
        Unit of the intensities (``"km/mol"``, ``"e^2/amu"``, ``"Angstrom^4/amu"``).
    kind : str
        ``"IR"``, ``"Raman"`` or a free label; charts use it for titles and axis direction.
    """

    wavenumbers: NDArray[np.float64]
    intensities: NDArray[np.float64]
    unit: str
    kind: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def broadened(self, grid: ArrayLike, width: float,
                  shape: Literal["lorentzian", "gaussian"] = "lorentzian") -> BroadenedSpectrum:
        """These lines broadened on `grid` (see `broadened_spectrum`)."""
        return broadened_spectrum(self.wavenumbers, self.intensities, grid, width, shape=shape,
                                  unit=self.unit, kind=self.kind)


@dataclass(frozen=True, eq=False)
class BroadenedSpectrum:
    """A spectrum on a wavenumber grid: each line a unit-area profile times its intensity.

    Attributes
    ----------
    grid : (n_points,) ndarray
        Wavenumbers, in cm^-1.
    values : (n_points,) ndarray
        Spectral density, in `unit` per cm^-1: its integral over all wavenumbers is the sum
        of the line intensities.
    width : float
        Full width at half maximum of every line, in cm^-1.
    shape : str
        ``"lorentzian"`` or ``"gaussian"``.
    unit : str
        Unit of the line intensities.
    kind : str
        ``"IR"``, ``"Raman"`` or a free label.
    """

    grid: NDArray[np.float64]
    values: NDArray[np.float64]
    width: float
    shape: str
    unit: str
    kind: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)


@dataclass(frozen=True, eq=False)
class IRSpectrum:
    """IR activity of the vibrational modes of one system.

    Attributes
    ----------
    mode_indices : (n_vib,) ndarray of int
        Index of each vibrational mode in the `Modes` it came from (rigid-body and imaginary
        modes are left out).
    wavenumbers : (n_vib,) ndarray
        Mode wavenumbers, ascending, in cm^-1.
    dipole_derivatives : (n_vib, 3) ndarray
        dmu/dQ_k, the dipole change per unit normal coordinate, in e / sqrt(amu)
        (e Angstrom per Angstrom sqrt(amu)).
    intensities : (n_vib,) ndarray
        |dmu/dQ_k|^2, in e^2/amu.
    model : str
        ``"point charges"`` or ``"dipole derivatives"``.
    """

    mode_indices: NDArray[np.intp]
    wavenumbers: NDArray[np.float64]
    dipole_derivatives: NDArray[np.float64]
    intensities: NDArray[np.float64]
    model: str

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def intensities_km_per_mol(self) -> NDArray[np.float64]:
        """(n_vib,) integrated absorption coefficients, in km/mol."""
        return self.intensities * KM_PER_MOL_PER_E2_AMU

    def active(self, rtol: float = 1e-8) -> NDArray[np.bool_]:
        """(n_vib,) True where the intensity exceeds `rtol` times the strongest line.

        A symmetry-forbidden line comes out at rounding level (about 1e-30 of the strongest),
        so the default threshold separates allowed from forbidden lines with a wide margin.
        """
        return _active(self.intensities, rtol)

    def sticks(self, *, unit: Literal["km/mol", "e^2/amu"] = "km/mol",
               merge_cm1: float = 0.01) -> StickSpectrum:
        """Stick spectrum; lines closer than `merge_cm1` (cm^-1) are merged and summed."""
        _validate.choice(unit, "unit", _IR_UNITS)
        values = self.intensities_km_per_mol() if unit == "km/mol" else self.intensities
        return _sticks(self.wavenumbers, values, merge_cm1, unit, "IR")

    def table(self) -> str:
        """Text table: mode, wavenumber (cm^-1), intensity (km/mol, e^2/amu), IR active."""
        active = self.active()
        lines = [f"IR ({self.model})", " mode  wavenumber/cm^-1   I/(km/mol)    I/(e^2/amu)  active"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{self.mode_indices[k]:5d}  {self.wavenumbers[k]:16.2f}  "
                f"{self.intensities_km_per_mol()[k]:11.4g}  {self.intensities[k]:13.4g}  "
                f"{'yes' if active[k] else 'no':>6}"
            )
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class RamanSpectrum:
    """Raman activity of the vibrational modes in the bond-polarisability model.

    Attributes
    ----------
    mode_indices : (n_vib,) ndarray of int
        Index of each vibrational mode in its `Modes`.
    wavenumbers : (n_vib,) ndarray
        Mode wavenumbers, ascending, in cm^-1.
    polarizability_derivatives : (n_vib, 3, 3) ndarray
        d alpha / dQ_k, symmetric, in Angstrom^3 / (Angstrom sqrt(amu)) = Angstrom^2/sqrt(amu).
    isotropic : (n_vib,) ndarray
        a'_k = tr(d alpha / dQ_k) / 3, in Angstrom^2/sqrt(amu).
    anisotropy : (n_vib,) ndarray
        g'_k >= 0 with g'^2 = 1/2 [(xx-yy)^2 + (yy-zz)^2 + (zz-xx)^2 + 6 (xy^2+yz^2+zx^2)],
        in Angstrom^2/sqrt(amu).
    activities : (n_vib,) ndarray
        45 a'^2 + 7 g'^2, in Angstrom^4/amu.
    """

    mode_indices: NDArray[np.intp]
    wavenumbers: NDArray[np.float64]
    polarizability_derivatives: NDArray[np.float64]
    isotropic: NDArray[np.float64]
    anisotropy: NDArray[np.float64]
    activities: NDArray[np.float64]

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def active(self, rtol: float = 1e-8) -> NDArray[np.bool_]:
        """(n_vib,) True where the activity exceeds `rtol` times the strongest line."""
        return _active(self.activities, rtol)

    def sticks(self, *, merge_cm1: float = 0.01) -> StickSpectrum:
        """Stick spectrum of the activities (Angstrom^4/amu), degenerate lines summed."""
        return _sticks(self.wavenumbers, self.activities, merge_cm1, "Angstrom^4/amu", "Raman")

    def table(self) -> str:
        """Text table: mode, wavenumber (cm^-1), a', g', activity, Raman active."""
        active = self.active()
        lines = ["Raman (bond polarisability)",
                 " mode  wavenumber/cm^-1        a'          g'   activity/(A^4/amu)  active"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{self.mode_indices[k]:5d}  {self.wavenumbers[k]:16.2f}  {self.isotropic[k]:10.4g}  "
                f"{self.anisotropy[k]:10.4g}  {self.activities[k]:19.4g}  "
                f"{'yes' if active[k] else 'no':>6}"
            )
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class Thermochemistry:
    """Harmonic vibrational thermochemistry at several temperatures.

    Energies are measured from the bottom of the potential well (as ASE's HarmonicThermo
    does with potentialenergy=0) unless stated otherwise.

    Attributes
    ----------
    temperatures : (n_T,) ndarray
        Temperatures, in K.
    wavenumbers : (n_vib,) ndarray
        Wavenumbers of the modes counted, ascending, in cm^-1.
    vibrational_energies : (n_vib,) ndarray
        Quanta hbar omega_k = h c nu~_k, in eV.
    zero_point_energy : float
        sum_k hbar omega_k / 2, in eV.
    log_partition_function : (n_T,) ndarray
        ln q_ZPE = -sum_k ln(1 - exp(-x_k)), x_k = hbar omega_k / kT: the partition function
        with energies counted from the ground state (the zero-point level); q_ZPE -> 1 as
        T -> 0. Kept as a logarithm so that its tiny low-T values keep their digits
        (`partition_function` gives q_ZPE itself).
    log_partition_function_bottom : (n_T,) ndarray
        ln q_BOT = ln q_ZPE - ZPE / kT: energies counted from the bottom of the well (q_BOT
        itself underflows at low T).
    internal_energy : (n_T,) ndarray
        U = ZPE + sum_k hbar omega_k / (exp(x_k) - 1), in eV.
    heat_capacity : (n_T,) ndarray
        C_v = k sum_k x_k^2 e^x_k / (e^x_k - 1)^2, in eV/K.
    entropy : (n_T,) ndarray
        S = k sum_k [x_k / (e^x_k - 1) - ln(1 - e^-x_k)], in eV/K.
    helmholtz_energy : (n_T,) ndarray
        F = U - T S = ZPE + kT sum_k ln(1 - e^-x_k) = -kT ln q_BOT, in eV.
    n_imaginary : int
        Imaginary modes left out.
    """

    temperatures: NDArray[np.float64]
    wavenumbers: NDArray[np.float64]
    vibrational_energies: NDArray[np.float64]
    zero_point_energy: float
    log_partition_function: NDArray[np.float64]
    log_partition_function_bottom: NDArray[np.float64]
    internal_energy: NDArray[np.float64]
    heat_capacity: NDArray[np.float64]
    entropy: NDArray[np.float64]
    helmholtz_energy: NDArray[np.float64]
    n_imaginary: int

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    @property
    def partition_function(self) -> NDArray[np.float64]:
        """(n_T,) q_ZPE = exp(log_partition_function), dimensionless."""
        return np.exp(self.log_partition_function)

    def heat_capacity_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) C_v per mole, in J/(mol K)."""
        return self.heat_capacity * constants.e * constants.N_A

    def entropy_j_per_mol_k(self) -> NDArray[np.float64]:
        """(n_T,) S per mole, in J/(mol K)."""
        return self.entropy * constants.e * constants.N_A

    def table(self) -> str:
        """Text table: T (K), U (eV), C_v and S (J/(mol K)), F (eV), q_ZPE."""
        lines = [
            f"harmonic vibrations: {len(self.wavenumbers)} modes, ZPE = {self.zero_point_energy:.6f} eV"
            + (f", {self.n_imaginary} imaginary mode(s) left out" if self.n_imaginary else ""),
            "      T/K        U/eV   Cv/(J/mol/K)    S/(J/mol/K)        F/eV        q_ZPE",
        ]
        cv, s = self.heat_capacity_j_per_mol_k(), self.entropy_j_per_mol_k()
        for i, t in enumerate(self.temperatures):
            lines.append(
                f"{t:9.2f}  {self.internal_energy[i]:10.6f}  {cv[i]:13.5f}  {s[i]:13.5f}  "
                f"{self.helmholtz_energy[i]:10.6f}  {self.partition_function[i]:11.6g}"
            )
        return "\n".join(lines)


@dataclass(frozen=True, eq=False)
class IsotopeShifts:
    """Wavenumbers of the vibrational modes before and after an isotopic substitution.

    Modes are paired in ascending order of wavenumber (the k-th vibrational mode of one
    system with the k-th of the other).

    Attributes
    ----------
    sites : (n_sub,) ndarray of int
        Substituted sites.
    original_masses, new_masses : (n_sub,) ndarray
        Their masses before and after, in the mass unit of the system (amu for ASE units).
    labels : tuple of str
        The substitution as given for each site (an isotope name or the mass as text).
    wavenumbers : (n_vib,) ndarray
        Original wavenumbers, ascending, in cm^-1.
    shifted_wavenumbers : (n_vib,) ndarray
        Wavenumbers after substitution, ascending, in cm^-1.
    """

    sites: NDArray[np.intp]
    original_masses: NDArray[np.float64]
    new_masses: NDArray[np.float64]
    labels: tuple[str, ...]
    wavenumbers: NDArray[np.float64]
    shifted_wavenumbers: NDArray[np.float64]

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    @property
    def shifts(self) -> NDArray[np.float64]:
        """(n_vib,) shifted minus original wavenumbers, in cm^-1 (negative: red shift)."""
        return self.shifted_wavenumbers - self.wavenumbers

    @property
    def ratios(self) -> NDArray[np.float64]:
        """(n_vib,) shifted / original wavenumbers (dimensionless)."""
        return self.shifted_wavenumbers / self.wavenumbers

    def table(self) -> str:
        """Text table: mode, original and shifted wavenumbers, shift (cm^-1), ratio."""
        what = ", ".join(f"site {s}: {lab} ({m0:.6g} -> {m1:.6g})" for s, lab, m0, m1 in zip(
            self.sites, self.labels, self.original_masses, self.new_masses))
        lines = [f"isotope shifts [{what}]",
                 " mode   original/cm^-1   shifted/cm^-1   shift/cm^-1      ratio"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{k:5d}  {self.wavenumbers[k]:15.2f}  {self.shifted_wavenumbers[k]:14.2f}  "
                f"{self.shifts[k]:12.2f}  {self.ratios[k]:9.6f}"
            )
        return "\n".join(lines)


# ---------------------------------------------------------------------- IR
def ir_spectrum(
    system: System,
    modes: Modes | None = None,
    *,
    charges: ArrayLike | None = None,
    dipole_derivatives: ArrayLike | None = None,
    zero_rtol: float = ZERO_RTOL,
) -> IRSpectrum:
    """IR intensities of the vibrational modes, from point charges or dipole derivatives.

    With point charges q_i the dipole is mu = sum_i q_i r_i and dmu/dQ_k = sum_i q_i u_k[i]
    (u_k the M-orthonormal Cartesian shape of mode k). With dipole derivatives
    Z[i, b, a] = dmu_a / dx_ib (e.g. from `dipole_derivatives`),
    dmu_a/dQ_k = sum_ib Z[i, b, a] u_k[i, b]. The intensity is |dmu/dQ_k|^2.

    Parameters
    ----------
    system : System
        A system of sites in ASE units (amu, Angstrom, eV), in 1, 2 or 3 dimensions (the
        missing Cartesian components are zero).
    modes : Modes or VibrationalAnalysis, optional
        Its normal modes with shapes (default: ``system.modes()``). For a molecule pass
        ``vibra.molecules.vibrational_analysis(system)``: its Eckart-matched rigid-body modes
        are left out exactly, even where a finite-difference Hessian puts rotations at tens
        of cm^-1 (beyond any `zero_rtol`).
    charges : (n_sites,) array_like, optional
        Point charges, in e.
    dipole_derivatives : (3 n_sites, 3) or (n_sites, 3, 3) array_like, optional
        dmu_a / dx_ib, row 3 i + b (site i, axis b), column a; in e. Give exactly one of
        `charges` and `dipole_derivatives`.
    zero_rtol : float
        Modes with |omega| <= zero_rtol * max|omega| are rigid-body modes and left out.

    Returns
    -------
    IRSpectrum

    Raises
    ------
    TypeError
        `system` not a System of sites, `modes` not a Modes or VibrationalAnalysis.
    ValueError
        Units other than ASE; modes without shapes or of another size; both or neither of
        `charges` and `dipole_derivatives`; wrong shapes or non-finite values.
    """
    system, modes, rigid = _system_and_modes(system, modes)
    if (charges is None) == (dipole_derivatives is None):
        raise ValueError("give exactly one of charges and dipole_derivatives")
    n_sites = system.n_sites
    if charges is not None:
        q = _validate.real_array(charges, "charges", ndim=1)
        if q.shape[0] != n_sites:
            raise ValueError(f"charges must have {n_sites} entries (one per site), got {q.shape[0]}")
        derivatives = q[:, None, None] * np.eye(3)[None, :, :]
        model = "point charges"
    else:
        derivatives = _validate.real_array(dipole_derivatives, "dipole_derivatives", ndim=(2, 3))
        if derivatives.shape == (3 * n_sites, 3):
            derivatives = derivatives.reshape(n_sites, 3, 3)
        elif derivatives.shape != (n_sites, 3, 3):
            raise ValueError(
                f"dipole_derivatives must have shape ({3 * n_sites}, 3) or ({n_sites}, 3, 3), "
                f"got {derivatives.shape}"
            )
        model = "dipole derivatives"
    zero_rtol = _nonnegative_float(zero_rtol, "zero_rtol")
    keep = _vibrational(modes, zero_rtol, "ir_spectrum", rigid)
    shapes = _cartesian_shapes(system, modes)[:, :, keep]  # (n_sites, 3, n_vib)
    dmu_dq = np.einsum("iba,ibk->ka", derivatives, shapes)
    return IRSpectrum(
        mode_indices=np.flatnonzero(keep), wavenumbers=modes.wavenumbers_cm1()[keep],
        dipole_derivatives=dmu_dq, intensities=np.sum(dmu_dq**2, axis=1), model=model,
    )


def dipole_derivatives(atoms: Atoms, *, step: float = 0.01) -> NDArray[np.float64]:
    """dmu_a/dx_ib by central differences of ``atoms.get_dipole_moment()``.

    Each atom is moved by +-`step` along x, y and z on a copy of `atoms` that shares its
    calculator; the error is O(step^2) times the third derivative of the dipole.

    Parameters
    ----------
    atoms : ase.Atoms
        Atoms at equilibrium with a calculator that provides ``dipole`` (in e Angstrom).
    step : float
        Displacement, in Angstrom (> 0).

    Returns
    -------
    (3 n_atoms, 3) ndarray
        Row 3 i + b: derivative of the dipole (x, y, z) with respect to x_ib, in e.

    Raises
    ------
    TypeError
        `atoms` not an ase.Atoms or without a calculator.
    ValueError
        `step` not positive and finite.
    """
    from ase import Atoms as AseAtoms

    if not isinstance(atoms, AseAtoms):
        raise TypeError(f"atoms must be an ase.Atoms, got {type(atoms).__name__}")
    if atoms.calc is None:
        raise TypeError("atoms has no calculator; attach one that provides the dipole moment")
    step = _positive_float(step, "step")
    work = atoms.copy()
    work.calc = atoms.calc
    reference = atoms.get_positions()
    result = np.empty((3 * len(atoms), 3))
    for i in range(len(atoms)):
        for b in range(3):
            moved = reference.copy()
            moved[i, b] += step
            work.set_positions(moved)
            plus = np.asarray(work.get_dipole_moment(), dtype=float)
            moved[i, b] -= 2.0 * step
            work.set_positions(moved)
            minus = np.asarray(work.get_dipole_moment(), dtype=float)
            result[3 * i + b] = (plus - minus) / (2.0 * step)
    return result


def electronegativity_charges(symbols: ArrayLike, bonds: ArrayLike, *,
                              transfer: float = 0.2) -> NDArray[np.float64]:
    """Crude partial charges from Pauling electronegativities, bond by bond.

    Each bond (i, j) moves ``transfer * (chi_j - chi_i)`` electrons from site i to site j
    (towards the more electronegative atom), so the charges sum to zero. Good enough to tell
    IR-active from inactive modes and to rank intensities roughly; give charges from a
    quantum-chemistry population analysis, or dipole derivatives, for numbers.

    Parameters
    ----------
    symbols : (n_sites,) sequence of str
        Chemical symbols, keys of `PAULING_ELECTRONEGATIVITY`.
    bonds : (n_bonds, 2) array_like of int
        Bonded site pairs.
    transfer : float
        Electrons moved per unit of electronegativity difference (> 0).

    Returns
    -------
    (n_sites,) ndarray
        Partial charges, in e.
    """
    names = [str(s) for s in np.atleast_1d(np.asarray(symbols, dtype=object))]
    chi = np.empty(len(names))
    for i, name in enumerate(names):
        if name not in PAULING_ELECTRONEGATIVITY:
            known = ", ".join(PAULING_ELECTRONEGATIVITY)
            raise ValueError(f"symbols[{i}] is {name!r}; known elements: {known}")
        chi[i] = PAULING_ELECTRONEGATIVITY[name]
    pairs = _bond_pairs(bonds, len(names))
    transfer = _positive_float(transfer, "transfer")
    charges = np.zeros(len(names))
    moved = transfer * (chi[pairs[:, 1]] - chi[pairs[:, 0]])
    np.add.at(charges, pairs[:, 0], moved)
    np.add.at(charges, pairs[:, 1], -moved)
    return charges


# ---------------------------------------------------------------------- Raman
def raman_spectrum(
    system: System,
    modes: Modes | None = None,
    *,
    bonds: ArrayLike,
    polarizability_parallel: ArrayLike | float = 1.0,
    polarizability_perpendicular: ArrayLike | float = 0.5,
    derivative_parallel: ArrayLike | float = 2.0,
    derivative_perpendicular: ArrayLike | float = 0.5,
    zero_rtol: float = ZERO_RTOL,
) -> RamanSpectrum:
    """Raman activities in the bond-polarisability model (a qualitative hint).

    Each bond b with unit vector e and length r adds
    alpha_b = alpha_par(r) e e^T + alpha_perp(r) (I - e e^T). Along mode k, with
    Delta = u_k[j] - u_k[i] for the bond (i, j), the bond stretches by dr = e . Delta and
    turns by de = (Delta - e dr) / r, so

        d alpha_b / dQ_k = [alpha'_par e e^T + alpha'_perp (I - e e^T)] dr
                           + (alpha_par - alpha_perp) (de e^T + e de^T).

    The activity is 45 a'^2 + 7 g'^2 with a' and g' the isotropic and anisotropic invariants
    of d alpha / dQ_k. The default bond values are generic: only ratios between modes mean
    anything, and a zero activity is a symmetry statement (e.g. the mutual exclusion rule of
    centrosymmetric molecules such as CO2).

    Parameters
    ----------
    system : System
        A system of sites in ASE units, in 1, 2 or 3 dimensions.
    modes : Modes or VibrationalAnalysis, optional
        Its normal modes with shapes (default: ``system.modes()``); a `VibrationalAnalysis`
        leaves out its rigid-body modes exactly (see `ir_spectrum`).
    bonds : (n_bonds, 2) array_like of int
        Bonded site pairs.
    polarizability_parallel, polarizability_perpendicular : float or (n_bonds,) array_like
        alpha_par and alpha_perp of each bond, in Angstrom^3 (polarisability volumes).
    derivative_parallel, derivative_perpendicular : float or (n_bonds,) array_like
        Their derivatives with respect to the bond length, in Angstrom^2.
    zero_rtol : float
        Relative threshold of the rigid-body modes left out.

    Returns
    -------
    RamanSpectrum

    Raises
    ------
    TypeError
        `system` not a System of sites, `modes` not a Modes or VibrationalAnalysis, bond
        indices not integers.
    ValueError
        Units other than ASE; modes without shapes or of another size; bond indices out of
        range or a bond joining a site to itself or two coincident sites; parameter arrays
        of the wrong length or not finite.
    """
    system, modes, rigid = _system_and_modes(system, modes)
    pairs = _bond_pairs(bonds, system.n_sites)
    n_bonds = len(pairs)
    a_par = _per_bond(polarizability_parallel, n_bonds, "polarizability_parallel")
    a_perp = _per_bond(polarizability_perpendicular, n_bonds, "polarizability_perpendicular")
    d_par = _per_bond(derivative_parallel, n_bonds, "derivative_parallel")
    d_perp = _per_bond(derivative_perpendicular, n_bonds, "derivative_perpendicular")
    zero_rtol = _nonnegative_float(zero_rtol, "zero_rtol")
    positions = _cartesian_positions(system)
    vector = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    length = np.linalg.norm(vector, axis=1)
    scale = max(float(np.abs(positions).max()), 1.0)
    short = length <= 1e-12 * scale
    if short.any():
        b = int(np.argmax(short))
        raise ValueError(f"bonds[{b}] joins sites {pairs[b, 0]} and {pairs[b, 1]} at the same position")
    e = vector / length[:, None]                                    # (n_bonds, 3)
    keep = _vibrational(modes, zero_rtol, "raman_spectrum", rigid)
    shapes = _cartesian_shapes(system, modes)[:, :, keep]           # (n_sites, 3, n_vib)
    delta = shapes[pairs[:, 1]] - shapes[pairs[:, 0]]               # (n_bonds, 3, n_vib)
    stretch = np.einsum("ba,bak->bk", e, delta)                     # dr
    turn = (delta - e[:, :, None] * stretch[:, None, :]) / length[:, None, None]  # de
    eye = np.eye(3)
    projector = np.einsum("ba,bc->bac", e, e)                       # e e^T
    stretch_tensor = (d_par[:, None, None] * projector
                      + d_perp[:, None, None] * (eye[None] - projector))
    derivative = np.einsum("bac,bk->kac", stretch_tensor, stretch)
    turn_outer = np.einsum("bak,bc->bkac", turn, e)                 # de e^T, (n_bonds, n_vib, 3, 3)
    turn_outer = turn_outer + np.swapaxes(turn_outer, 2, 3)         # de e^T + e de^T
    derivative += np.einsum("b,bkac->kac", a_par - a_perp, turn_outer)
    isotropic = np.trace(derivative, axis1=1, axis2=2) / 3.0
    anisotropy = np.sqrt(np.maximum(_anisotropy_squared(derivative), 0.0))
    return RamanSpectrum(
        mode_indices=np.flatnonzero(keep), wavenumbers=modes.wavenumbers_cm1()[keep],
        polarizability_derivatives=derivative, isotropic=isotropic, anisotropy=anisotropy,
        activities=45.0 * isotropic**2 + 7.0 * anisotropy**2,
    )


def _anisotropy_squared(t: NDArray[np.float64]) -> NDArray[np.float64]:
    xx, yy, zz = t[:, 0, 0], t[:, 1, 1], t[:, 2, 2]
    xy, yz, zx = t[:, 0, 1], t[:, 1, 2], t[:, 2, 0]
    return 0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2
                  + 6.0 * (xy**2 + yz**2 + zx**2))


# ---------------------------------------------------------------------- broadening
def broadened_spectrum(
    wavenumbers: ArrayLike,
    intensities: ArrayLike,
    grid: ArrayLike,
    width: float,
    shape: Literal["lorentzian", "gaussian"] = "lorentzian",
    *,
    unit: str = "arb. units",
    kind: str = "IR",
) -> BroadenedSpectrum:
    """Lines broadened into a spectral density on a wavenumber grid.

    Each line k contributes I_k g(nu - nu_k) with g a unit-area profile of full width at half
    maximum `width`: the Lorentzian g = (w/2) / pi / ((nu - nu_k)^2 + (w/2)^2) or the Gaussian
    of standard deviation w / (2 sqrt(2 ln 2)). The integral of the result over all
    wavenumbers is sum_k I_k; on a finite grid the tails outside it are missing (for a
    Lorentzian a fraction of about w / (pi d) at distance d from the edge).

    Parameters
    ----------
    wavenumbers : (n_lines,) array_like
        Line positions, in cm^-1.
    intensities : (n_lines,) array_like
        Line strengths (>= 0), in `unit`.
    grid : (n_points,) array_like
        Wavenumbers at which to evaluate, in cm^-1.
    width : float
        Full width at half maximum, in cm^-1 (> 0).
    shape : {"lorentzian", "gaussian"}
        Line profile.
    unit : str
        Unit of `intensities`, carried for labels.
    kind : str
        Label of the spectrum (``"IR"``, ``"Raman"``).

    Returns
    -------
    BroadenedSpectrum
        values in `unit` per cm^-1.

    Raises
    ------
    ValueError
        Arrays of the wrong dimension or lengths, non-finite values, negative intensities,
        a width that is not positive, an unknown shape.

    Examples
    --------
    >>> import numpy as np
    >>> s = broadened_spectrum([1000.0], [2.0], np.array([1000.0]), 10.0, "lorentzian")
    >>> round(float(s.values[0] * np.pi * 5.0), 12)   # peak height 2 / (pi w/2)
    2.0
    """
    positions = _validate.real_array(wavenumbers, "wavenumbers", ndim=1)
    strengths = _validate.real_array(intensities, "intensities", ndim=1)
    if strengths.shape != positions.shape:
        raise ValueError(
            f"intensities must have {positions.shape[0]} entries (one per wavenumber), "
            f"got {strengths.shape[0]}"
        )
    _validate.nonnegative(strengths, "intensities", "intensity")
    points = _validate.real_array(grid, "grid", ndim=1)
    if points.shape[0] == 0:
        raise ValueError("grid must hold at least one wavenumber, got none")
    width = _positive_float(width, "width")
    _validate.choice(shape, "shape", _SHAPES)
    values = np.empty_like(points)
    half = 0.5 * width
    sigma = width / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    # grid chunks keep the (points x lines) profile block near _BLOCK entries in memory
    rows = max(1, _BLOCK // max(positions.shape[0], 1))
    for start in range(0, points.shape[0], rows):
        offset = points[start:start + rows, None] - positions[None, :]
        if shape == "lorentzian":
            profile = (half / np.pi) / (offset**2 + half**2)
        else:
            profile = np.exp(-0.5 * (offset / sigma) ** 2) / (sigma * np.sqrt(2.0 * np.pi))
        values[start:start + rows] = profile @ strengths
    return BroadenedSpectrum(grid=points, values=values, width=width, shape=shape,
                             unit=str(unit), kind=str(kind))


# ---------------------------------------------------------------------- thermochemistry
def thermochemistry(
    modes: Modes | VibrationalAnalysis | ArrayLike,
    temperatures: ArrayLike,
    *,
    zero_rtol: float = ZERO_RTOL,
) -> Thermochemistry:
    """Vibrational ZPE, partition function, U, C_v, S and F of independent harmonic modes.

    With x_k = hbar omega_k / kT: q_ZPE = prod 1/(1 - e^-x_k),
    U = ZPE + sum hbar omega_k / (e^x_k - 1), C_v = k sum x_k^2 e^x_k / (e^x_k - 1)^2,
    S = k sum [x_k / (e^x_k - 1) - ln(1 - e^-x_k)], F = U - T S. These are the formulas of
    ASE's HarmonicThermo (and the vibrational part of IdealGasThermo); k is CODATA 2018.

    Parameters
    ----------
    modes : Modes or VibrationalAnalysis or (n_modes,) array_like
        Normal modes in physical units, a molecule's `VibrationalAnalysis` (its rigid-body
        modes are left out exactly), or signed wavenumbers in cm^-1 (negative = imaginary).
    temperatures : float or (n_T,) array_like
        Temperatures, in K (> 0).
    zero_rtol : float
        Modes with |omega| <= zero_rtol * max|omega| (rigid-body motion) are left out.
        Imaginary modes are left out with a RuntimeWarning.

    Returns
    -------
    Thermochemistry

    Raises
    ------
    TypeError
        `modes` neither a Modes nor an array of numbers.
    ValueError
        Dimensionless modes; wavenumbers or temperatures not 1-D, not finite, or
        temperatures not positive.
    """
    zero_rtol = _nonnegative_float(zero_rtol, "zero_rtol")
    rigid = None
    if isinstance(modes, VibrationalAnalysis):
        rigid = np.asarray(modes.rigid)
        modes = modes.modes
    if isinstance(modes, Modes):
        if modes.units.time_s is None:
            raise ValueError("modes are dimensionless; thermochemistry needs units 'SI' or 'ASE'")
        keep = _vibrational(modes, zero_rtol, "thermochemistry", rigid)
        wavenumbers = modes.wavenumbers_cm1()[keep]
        skipped = modes.zero_modes(zero_rtol) | (rigid if rigid is not None else False)
        n_imaginary = int(np.sum(modes.unstable & ~skipped))
    else:
        signed = _validate.real_array(modes, "modes", ndim=1)
        keep, n_imaginary = _vibrational_values(signed, zero_rtol, "thermochemistry")
        wavenumbers = np.sort(signed[keep])
    temps = _validate.real_array(temperatures, "temperatures", ndim=(0, 1))
    temps = np.atleast_1d(temps)
    _validate.positive(temps, "temperatures", "temperature")

    energies = wavenumbers * _EV_PER_CM1                        # (n_vib,) eV
    kt = BOLTZMANN_EV_PER_K * temps                             # (n_T,) eV
    x = energies[None, :] / kt[:, None]                         # (n_T, n_vib)
    decay = np.exp(-x)
    one_minus = -np.expm1(-x)                                   # 1 - e^-x, accurate for small x
    occupation = decay / one_minus                              # 1 / (e^x - 1)
    # ln(1 - e^-x): log1p keeps the digits when e^-x is tiny, log(-expm1) when x is small
    log_one_minus = np.where(x > np.log(2.0), np.log1p(-decay), np.log(one_minus))
    zpe = 0.5 * float(np.sum(energies))
    log_q = -np.sum(log_one_minus, axis=1)
    internal = zpe + occupation @ energies
    heat_capacity = BOLTZMANN_EV_PER_K * np.sum(x**2 * decay / one_minus**2, axis=1)
    entropy = BOLTZMANN_EV_PER_K * np.sum(x * occupation - log_one_minus, axis=1)
    helmholtz = zpe + kt * np.sum(log_one_minus, axis=1)
    return Thermochemistry(
        temperatures=temps, wavenumbers=wavenumbers, vibrational_energies=energies,
        zero_point_energy=zpe, log_partition_function=log_q,
        log_partition_function_bottom=log_q - zpe / kt, internal_energy=internal,
        heat_capacity=heat_capacity, entropy=entropy, helmholtz_energy=helmholtz,
        n_imaginary=n_imaginary,
    )


# ---------------------------------------------------------------------- isotopes
def isotope_shifts(
    system: System,
    substitutions: Mapping[int, float | str],
    *,
    zero_rtol: float = ZERO_RTOL,
    accuracy: Literal["high", "fast"] = "high",
) -> IsotopeShifts:
    """Vibrational wavenumbers before and after replacing the masses of some sites.

    The potential (K) is unchanged; only M changes (`System.with_masses`). Modes are paired
    in ascending order of wavenumber.

    Parameters
    ----------
    system : System
        A system of sites in physical units (isotope names need ASE units: amu).
    substitutions : mapping of int to float or str
        Site index -> new mass (in the mass unit of the system) or an isotope name from
        `ISOTOPE_MASSES` (``"13C"``, ``"18O"``, ``"D"``, ...).
    zero_rtol : float
        Relative threshold of the rigid-body modes left out.
    accuracy : {"high", "fast"}
        Passed to `System.modes`.

    Returns
    -------
    IsotopeShifts

    Raises
    ------
    TypeError
        `system` not a System of sites; `substitutions` not a mapping, a key not an int, a
        value neither a number nor a str.
    ValueError
        Dimensionless units; an empty mapping, a site out of range, an unknown isotope
        name, an isotope name outside ASE units, a mass not positive and finite.
    RuntimeError
        The two systems do not have the same number of vibrational modes.
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError("system must be a system of sites; this one is in generalised coordinates")
    if system.units.time_s is None:
        raise ValueError("system is dimensionless; isotope shifts need units 'SI' or 'ASE' (cm^-1)")
    if not isinstance(substitutions, Mapping):
        raise TypeError(f"substitutions must be a mapping of site -> mass, got {type(substitutions).__name__}")
    if not substitutions:
        raise ValueError("substitutions is empty; give at least one site -> new mass")
    zero_rtol = _nonnegative_float(zero_rtol, "zero_rtol")
    _validate.choice(accuracy, "accuracy", ("high", "fast"))
    masses = np.array(system.masses, dtype=float)
    sites, labels, old, new = [], [], [], []
    for site, value in substitutions.items():
        if isinstance(site, bool) or not isinstance(site, (int, np.integer)):
            raise TypeError(f"substitutions key {site!r} must be an int site index")
        if not 0 <= site < system.n_sites:
            raise ValueError(f"substitutions[{site}]: site {site} is out of range 0..{system.n_sites - 1}")
        if isinstance(value, str):
            if value not in ISOTOPE_MASSES:
                raise ValueError(
                    f"substitutions[{site}] is {value!r}; known isotopes: {', '.join(ISOTOPE_MASSES)}")
            if system.units.name != "ASE":
                raise ValueError(
                    f"substitutions[{site}] is the isotope name {value!r}, which needs masses in amu "
                    f"(units 'ASE'); this system is in {system.units.name!r}: give the mass instead")
            mass = float(ISOTOPE_MASSES[value])
            label = value
        elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
            mass = float(value)
            if not (np.isfinite(mass) and mass > 0):
                raise ValueError(f"substitutions[{site}] is {value!r}; a mass must be positive and finite")
            label = f"{mass:g}"
        else:
            raise TypeError(
                f"substitutions[{site}] must be a mass or an isotope name, got {type(value).__name__}")
        sites.append(int(site))
        labels.append(label)
        old.append(float(system.masses[site]))
        new.append(mass)
        masses[site] = mass
    before = system.modes(accuracy=accuracy)
    after = system.with_masses(masses).modes(accuracy=accuracy)
    keep_before = _vibrational(before, zero_rtol, "isotope_shifts")
    keep_after = _vibrational(after, zero_rtol, "isotope_shifts")
    if keep_before.sum() != keep_after.sum():
        raise RuntimeError(
            f"the substituted system has {int(keep_after.sum())} vibrational modes, the original "
            f"{int(keep_before.sum())}; adjust zero_rtol")
    return IsotopeShifts(
        sites=np.array(sites, dtype=np.intp), original_masses=np.array(old),
        new_masses=np.array(new), labels=tuple(labels),
        wavenumbers=before.wavenumbers_cm1()[keep_before],
        shifted_wavenumbers=after.wavenumbers_cm1()[keep_after],
    )


# ---------------------------------------------------------------------- helpers
def _system_and_modes(system: Any, modes: Any) -> tuple[System, Modes, NDArray[np.bool_] | None]:
    """The system, its modes, and the rigid-body flags of a `VibrationalAnalysis` (or None)."""
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError("system must be a system of sites; this one is in generalised coordinates")
    if system.units.name != "ASE":
        raise ValueError(
            f"system.units is {system.units.name!r}; spectra need units 'ASE' (amu, Angstrom, eV)")
    rigid = None
    if isinstance(modes, VibrationalAnalysis):
        modes, rigid = modes.modes, np.asarray(modes.rigid)
    if modes is None:
        modes = system.modes()
    elif not isinstance(modes, Modes):
        raise TypeError(
            f"modes must be a vibra.Modes or a molecules.VibrationalAnalysis, got {type(modes).__name__}")
    if modes.shapes is None:
        raise ValueError("modes has no shapes (computed with vectors=False); spectra need them")
    if modes.n_dof != system.n_dof:
        raise ValueError(
            f"modes has {modes.n_dof} degrees of freedom but the system has {system.n_dof}; "
            "pass the modes of this system")
    return system, modes, rigid


def _cartesian_shapes(system: System, modes: Modes) -> NDArray[np.float64]:
    """(n_sites, 3, n_modes) mode shapes, zero along frozen dofs and missing axes."""
    shapes = cast(NDArray[np.float64], modes.shapes)  # checked by _system_and_modes
    full = system.expand(shapes).reshape(system.n_sites, system.dim, modes.n_modes)
    out = np.zeros((system.n_sites, 3, modes.n_modes))
    out[:, : system.dim] = full
    return out


def _cartesian_positions(system: System) -> NDArray[np.float64]:
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = system.positions
    return out


def _vibrational(modes: Modes, zero_rtol: float, where: str,
                 rigid: NDArray[np.bool_] | None = None) -> NDArray[np.bool_]:
    """Mask of the real, non-zero, non-rigid modes; warn about imaginary ones.

    `rigid` (from a `VibrationalAnalysis`) marks the translations and rotations matched by
    the Eckart analysis; they are left out whatever their computed omega.
    """
    zero = modes.zero_modes(zero_rtol) if modes.n_modes else np.zeros(0, dtype=bool)
    if rigid is not None:
        zero = zero | rigid
    imaginary = modes.unstable & ~zero
    if imaginary.any():
        warnings.warn(
            f"{where}: {int(imaginary.sum())} imaginary mode(s) left out "
            f"(omega = {modes.omega[imaginary].tolist()})", RuntimeWarning, stacklevel=3)
    return ~zero & ~imaginary


def _vibrational_values(signed: NDArray[np.float64], zero_rtol: float, where: str
                        ) -> tuple[NDArray[np.bool_], int]:
    scale = float(np.abs(signed).max()) if signed.size else 0.0
    zero = np.abs(signed) <= zero_rtol * scale
    imaginary = (signed < 0) & ~zero
    if imaginary.any():
        warnings.warn(
            f"{where}: {int(imaginary.sum())} imaginary mode(s) left out "
            f"(wavenumbers {signed[imaginary].tolist()} cm^-1)", RuntimeWarning, stacklevel=3)
    return ~zero & ~imaginary, int(imaginary.sum())


def _active(values: NDArray[np.float64], rtol: float) -> NDArray[np.bool_]:
    rtol = _nonnegative_float(rtol, "rtol")
    scale = float(values.max()) if values.size else 0.0
    return values > rtol * scale


def _sticks(wavenumbers: NDArray[np.float64], values: NDArray[np.float64], merge_cm1: float,
            unit: str, kind: str) -> StickSpectrum:
    merge_cm1 = _nonnegative_float(merge_cm1, "merge_cm1")
    order = np.argsort(wavenumbers, kind="stable")
    positions, strengths = wavenumbers[order], values[order]
    if positions.size == 0:
        return StickSpectrum(np.zeros(0), np.zeros(0), unit, kind)
    starts = np.concatenate([[True], np.diff(positions) > merge_cm1])
    group = np.cumsum(starts) - 1
    total = np.asarray(np.bincount(group, weights=strengths), dtype=float)
    mean = np.asarray(np.bincount(group, weights=positions), dtype=float) / np.bincount(group)
    return StickSpectrum(wavenumbers=mean, intensities=total, unit=unit, kind=kind)


def _bond_pairs(bonds: ArrayLike, n_sites: int) -> NDArray[np.intp]:
    array = np.asarray(bonds)
    if array.size == 0:
        raise ValueError("bonds is empty; give (n_bonds, 2) site index pairs")
    if not np.issubdtype(array.dtype, np.integer):
        raise TypeError(f"bonds must hold integer site indices, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(f"bonds must have shape (n_bonds, 2), got {array.shape}")
    bad = (array < 0) | (array >= n_sites)
    if bad.any():
        b, c = (int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"bonds[{b},{c}] is {array[b, c]}; site indices run from 0 to {n_sites - 1}")
    same = array[:, 0] == array[:, 1]
    if same.any():
        b = int(np.argmax(same))
        raise ValueError(f"bonds[{b}] joins site {array[b, 0]} to itself")
    return array.astype(np.intp)


def _per_bond(value: ArrayLike | float, n_bonds: int, name: str) -> NDArray[np.float64]:
    array = _validate.real_array(value, name, ndim=(0, 1))
    if array.ndim == 0:
        return np.full(n_bonds, float(array))
    if array.shape[0] != n_bonds:
        raise ValueError(f"{name} must have {n_bonds} entries (one per bond), got {array.shape[0]}")
    return array


_positive_float = _validate.positive_scalar


def _nonnegative_float(value: Any, name: str) -> float:
    number = _validate.real_scalar(value, name)
    if not number >= 0:
        raise ValueError(f"{name} is {value!r}; it must be >= 0 and finite")
    return number

