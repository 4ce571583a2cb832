"""What the spectra share: the system and its modes checked, Cartesian mode shapes, which modes
are vibrations (rigid-body and imaginary modes left out), bond lists and thresholds."""

from __future__ import annotations

import warnings
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.modes import Modes
from vibra.molecules import VibrationalAnalysis
from vibra.system import System, Vibrating

__all__ = ["ZERO_RTOL", "system_and_modes", "cartesian_shapes", "vibrational_mask", "active_lines",
           "bond_pairs", "nonnegative_float"]

#: Default relative threshold for rigid-body modes: |omega| <= ZERO_RTOL * max|omega|
#: (0.35 cm^-1 when the highest mode is at 3500 cm^-1). Modes within their own computed
#: error of zero are skipped too. Finite-difference Hessians from a calculator leave
#: rotations at up to tens of cm^-1, which no threshold separates safely from soft
#: vibrations: pass ``vibra.molecules.vibrational_analysis(system)`` as the modes instead.
ZERO_RTOL = 1e-4


def system_and_modes(system: System, modes: Modes | VibrationalAnalysis | None
                     ) -> tuple[System, Modes, NDArray[np.bool_] | None]:
    """The system, its modes, and the rigid-body flags of a `VibrationalAnalysis` (or None)."""
    if not isinstance(system, Vibrating):
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


def cartesian_shapes(system: System, modes: Modes) -> NDArray[np.float64]:
    """(n_sites, 3, n_modes) mode shapes, zero along frozen dofs and missing axes."""
    shapes = cast(NDArray[np.float64], modes.shapes)  # checked by system_and_modes
    full = system.expand(shapes).reshape(system.n_sites, system.dim, modes.n_modes)
    out = np.zeros((system.n_sites, 3, modes.n_modes))
    out[:, : system.dim] = full
    return out



def vibrational_mask(modes: Modes, zero_rtol: float, where: str,
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



def finite_lines(values: NDArray[np.float64], wavenumbers: NDArray[np.float64], what: str, inputs: str) -> NDArray[np.float64]:
    """`values` (one per line) when finite; else a ValueError naming the first line that is not
    (its wavenumber) and the inputs whose scale overflowed, where it appears (issue 44: no silent
    inf in a spectrum)."""
    with np.errstate(over="ignore", invalid="ignore"):
        bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"the {what} of the line at {float(wavenumbers[k]):.6g} cm^-1 is {float(values[k])!r}: "
                         f"{inputs} too large for floating point; expected values on the scale of the model's units")
    return values


def active_lines(values: NDArray[np.float64], rtol: float) -> NDArray[np.bool_]:
    rtol = nonnegative_float(rtol, "rtol")
    scale = float(values.max()) if values.size else 0.0
    return values > rtol * scale



def bond_pairs(bonds: ArrayLike, n_sites: int) -> NDArray[np.intp]:
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



def nonnegative_float(value: object, name: str) -> float:
    number = _validate.real_scalar(value, name)
    if not number >= 0:
        raise ValueError(f"{name} is {value!r}; it must be >= 0 and finite")
    return number
