"""IR and Raman spectra from electronic structure: dipole and polarisability derivatives of an
engine (`vibra.molecules.engines.electronic_structure`) projected on the normal modes, with the
level of theory on the result and error bounds from the finite-difference estimates.

IR: dmu/dQ_k = sum_ib (dmu/dx_ib) u_k[i, b] (u_k the M-orthonormal Cartesian shape, Q_k in
Angstrom sqrt(amu)), A_k = N_A / (12 epsilon_0 c^2) |dmu/dQ_k|^2 in km/mol (the Gaussian-units
N_A pi / (3 c^2) |dmu/dQ_k|^2). Raman: alpha'_k = sum_ib (d alpha / dx_ib) u_k[i, b], activity
S_k = 45 a'^2 + 7 g'^2 in Angstrom^4/amu, depolarisation ratios and differential cross sections
from `RamanSpectrum`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vibra.modes import Modes
from vibra.molecules import VibrationalAnalysis, vibrational_analysis
from vibra.molecules.engines import ElectronicStructure
from vibra.spectra.common import (ZERO_RTOL, cartesian_shapes, finite_lines, nonnegative_float, system_and_modes,
                                  vibrational_mask)
from vibra.spectra.ir import IRSpectrum, ir_spectrum
from vibra.spectra.raman import RamanSpectrum, raman_invariants

__all__ = ["electronic_ir_spectrum", "electronic_raman_spectrum"]

#: The largest (45 a'^2 + 7 g'^2) / |T|_F^2 over symmetric 3 x 3 tensors T (an isotropic one).
_ACTIVITY_NORM = 15.0


def _modes(electronic: Any, modes: Any) -> tuple[Any, Modes | VibrationalAnalysis]:
    if not isinstance(electronic, ElectronicStructure):
        raise TypeError(f"electronic must be a vibra.molecules.engines.ElectronicStructure, got "
                        f"{type(electronic).__name__}")
    system = electronic.system()
    return system, vibrational_analysis(system) if modes is None else modes


def electronic_ir_spectrum(electronic: ElectronicStructure, modes: Modes | VibrationalAnalysis | None = None, *,
                           zero_rtol: float = ZERO_RTOL) -> IRSpectrum:
    """IR intensities from an engine's dipole derivatives, labelled with its level of theory.

    Parameters
    ----------
    electronic : ElectronicStructure
        From `vibra.molecules.engines.electronic_structure`, with the dipole.
    modes : VibrationalAnalysis or Modes, optional
        The modes of ``electronic.system()`` (default: its `vibrational_analysis`, which leaves
        the translations and rotations out exactly).
    zero_rtol : float
        As in `ir_spectrum`.

    Returns
    -------
    IRSpectrum
        ``model`` "dipole derivatives", ``level`` the engine's, and ``intensity_errors`` (e^2/amu)
        from the finite-difference error estimate of the derivatives (first order; the modes
        are taken as exact).

    Raises
    ------
    TypeError
        `electronic` not an ElectronicStructure.
    ValueError
        No dipole derivatives (the engine gives no dipole, or it was not asked for); modes of
        another system.
    """
    system, modes = _modes(electronic, modes)
    derivatives = electronic.finite_difference.derivatives
    if derivatives is None or derivatives.dipole is None or derivatives.dipole_error is None:
        raise ValueError(f"{electronic.level}: no dipole derivatives (the engine gives no dipole, or "
                         "properties left it out)")
    spectrum = ir_spectrum(system, modes, dipole_derivatives=derivatives.dipole, zero_rtol=zero_rtol)
    shapes = _shapes(system, modes, spectrum.mode_indices)                  # (3 n_atoms, n_vib)
    bound = np.abs(shapes).T @ derivatives.dipole_error                     # (n_vib, 3)
    errors = np.sum(2.0 * np.abs(spectrum.dipole_derivatives) * bound + bound**2, axis=1)
    finite_lines(errors, spectrum.wavenumbers, "intensity error", "the dipole derivatives' error estimate")
    return dataclasses.replace(spectrum, level=electronic.level, intensity_errors=errors)


def electronic_raman_spectrum(electronic: ElectronicStructure, modes: Modes | VibrationalAnalysis | None = None, *,
                              zero_rtol: float = ZERO_RTOL) -> RamanSpectrum:
    """Raman activities from an engine's polarisability derivatives, labelled with its level of theory.

    alpha'_k = sum_ib (d alpha / dx_ib) u_k[i, b] in Angstrom^2/sqrt(amu); the activity
    45 a'^2 + 7 g'^2 is in Angstrom^4/amu (the unit quantum-chemistry programs print);
    `RamanSpectrum.depolarization_ratios` and `RamanSpectrum.cross_sections_cm2_per_sr` follow.

    Parameters
    ----------
    electronic : ElectronicStructure
        From `vibra.molecules.engines.electronic_structure`, with the polarisability.
    modes : VibrationalAnalysis or Modes, optional
        As in `electronic_ir_spectrum`.
    zero_rtol : float
        Relative threshold of the rigid-body modes left out.

    Returns
    -------
    RamanSpectrum
        ``model`` "polarizability derivatives", ``level`` the engine's, ``activity_errors``
        (Angstrom^4/amu) from the derivatives' error estimate.

    Raises
    ------
    TypeError
        `electronic` not an ElectronicStructure.
    ValueError
        No polarisability derivatives; modes of another system.
    """
    system, modes = _modes(electronic, modes)
    derivatives = electronic.finite_difference.derivatives
    if derivatives is None or derivatives.polarizability is None or derivatives.polarizability_error is None:
        raise ValueError(f"{electronic.level}: no polarizability derivatives (the engine gives no polarizability, "
                         "or properties left it out)")
    system, bare, rigid = system_and_modes(system, modes)
    zero_rtol = nonnegative_float(zero_rtol, "zero_rtol")
    keep = vibrational_mask(bare, zero_rtol, "electronic_raman_spectrum", rigid)
    indices = np.flatnonzero(keep)
    shapes = _shapes(system, bare, indices)                                  # (3 n_atoms, n_vib)
    tensor = np.einsum("iac,ik->kac", derivatives.polarizability, shapes)
    delta = np.einsum("iac,ik->kac", derivatives.polarizability_error, np.abs(shapes))
    isotropic, anisotropy, activities = raman_invariants(tensor)
    wavenumbers = bare.wavenumbers_cm1()[keep]
    finite_lines(activities, wavenumbers, "activity", "the polarizability derivatives")
    size = np.sqrt(np.sum(tensor**2, axis=(1, 2)))
    spread = np.sqrt(np.sum(delta**2, axis=(1, 2)))
    errors = _ACTIVITY_NORM * (2.0 * size * spread + spread**2)
    return RamanSpectrum(mode_indices=indices, wavenumbers=wavenumbers, polarizability_derivatives=tensor,
                         isotropic=isotropic, anisotropy=anisotropy, activities=activities,
                         model="polarizability derivatives", level=electronic.level, activity_errors=errors)


def _shapes(system: Any, modes: Any, indices: NDArray[np.intp]) -> NDArray[np.float64]:
    bare = modes.modes if isinstance(modes, VibrationalAnalysis) else modes
    full = cartesian_shapes(system, bare)[:, :, indices]                    # (n_atoms, 3, n_vib)
    return full.reshape(-1, len(indices))
