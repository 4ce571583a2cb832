"""Spectroscopy from normal modes: IR and Raman activity, broadened spectra, harmonic
thermochemistry and isotope shifts.

Everything here starts from a `vibra.System` of sites in ASE units (amu, Angstrom, eV) and
its `vibra.Modes`. The mode shapes u_k are M-orthonormal Cartesian displacements
(Kneller, Mécanique analytique, eq. 151), so a displacement along mode k by the normal
coordinate Q_k is u = u_k Q_k, with
Q_k in Angstrom * sqrt(amu).

Models (see docs/spectra.md):

- IR, point charges: mu = sum_i q_i r_i, so dmu/dQ_k = sum_i q_i u_k[i] (e / sqrt(amu)).
  From a calculator: dmu_a/dx_ib by central differences of ``atoms.get_dipole_moment()``,
  projected on the modes. Intensity |dmu/dQ_k|^2 in e^2/amu; times
  N_A / (12 epsilon_0 c^2) it is the integrated absorption coefficient in km/mol.
- IR and Raman from electronic structure (`electronic.py`): the dipole and polarisability
  derivatives of an engine (`vibra.molecules.engines`, e.g. PySCF's Hartree-Fock and DFT)
  projected on the modes: intensities in km/mol, activities in Angstrom^4/amu, depolarisation
  ratios and differential cross sections, each labelled with the level of theory.
- Raman, bond polarisabilities: each bond adds
  alpha_b = alpha_par e e^T + alpha_perp (I - e e^T) (e the unit bond vector), whose two
  values depend on the bond length. The mode's polarisability derivative alpha'_k collects
  the bond stretch and the bond rotation terms; the activity is 45 a'^2 + 7 g'^2 with the
  isotropic invariant a' = tr(alpha')/3 and the anisotropy g'^2 (Long, "The Raman Effect").
- Thermochemistry of independent harmonic oscillators, with the same formulas as ASE's
  ``HarmonicThermo``; ideal-gas thermochemistry (translation, rotation, vibration, spin: H, S,
  G, C_p at any T and p), as ASE's ``IdealGasThermo``.

Rigid-body modes (|omega| <= zero_rtol * max|omega|, or within the mode's own error, and,
when a `vibra.molecules.VibrationalAnalysis` is passed as the modes, every mode it matched to
a translation or rotation) are skipped everywhere; imaginary modes are skipped with a
RuntimeWarning.

Modules: `ir.py`, `raman.py`, `electronic.py`, `experiment.py` (computed against observed fundamentals), `broadening.py` (stick and broadened spectra), `thermochemistry.py`, `ideal_gas.py`,
`isotopes.py` (isotope shifts), and `common.py` (mode selection and checks they share).
"""

from __future__ import annotations

from vibra.modes import Modes
from vibra.molecules import VibrationalAnalysis
from vibra.spectra.broadening import BroadenedSpectrum, StickSpectrum, broadened_spectrum
from vibra.spectra.common import ZERO_RTOL
from vibra.spectra.electronic import electronic_ir_spectrum, electronic_raman_spectrum
from vibra.spectra.experiment import ExperimentComparison, compare_with_experiment
from vibra.spectra.ideal_gas import (STANDARD_PRESSURE, IdealGasThermochemistry, ThermoContribution,
                                     ideal_gas_thermochemistry)
from vibra.spectra.ir import (KM_PER_MOL_PER_E2_AMU, PAULING_ELECTRONEGATIVITY, IRSpectrum, dipole_derivatives,
                              electronegativity_charges, ir_spectrum)
from vibra.spectra.isotopes import ISOTOPE_MASSES, IsotopeShifts, isotope_shifts
from vibra.spectra.raman import RamanSpectrum, raman_spectrum
from vibra.spectra.scale_factors import SCALE_FACTORS, fundamental_scale_factor
from vibra.spectra.thermochemistry import BOLTZMANN_EV_PER_K, Thermochemistry, thermochemistry
from vibra.system import System

__all__ = [
    "ZERO_RTOL", "KM_PER_MOL_PER_E2_AMU", "BOLTZMANN_EV_PER_K", "ISOTOPE_MASSES",
    "PAULING_ELECTRONEGATIVITY", "SCALE_FACTORS",
    "IRSpectrum", "RamanSpectrum", "StickSpectrum", "BroadenedSpectrum", "Thermochemistry",
    "IsotopeShifts",
    "ir_spectrum", "raman_spectrum", "dipole_derivatives", "electronegativity_charges",
    "broadened_spectrum", "thermochemistry", "isotope_shifts", "electronic_ir_spectrum", "electronic_raman_spectrum",
    "STANDARD_PRESSURE", "IdealGasThermochemistry", "ThermoContribution", "ideal_gas_thermochemistry",
    "ExperimentComparison", "compare_with_experiment", "fundamental_scale_factor",
]

# re-exported from the stages below, as the single-module vibra.spectra did
_REEXPORTED = (Modes, System, VibrationalAnalysis)
