"""Raman activities in the bond-polarisability model (and the spectrum type they share with
polarisability derivatives from electronic structure: activities, depolarisation ratios and
differential cross sections)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.modes import Modes
from vibra.spectra.broadening import StickSpectrum, stick_spectrum
from vibra.spectra.common import (ZERO_RTOL, active_lines, bond_pairs, cartesian_shapes, finite_lines, nonnegative_float,
                                  system_and_modes, vibrational_mask)
from vibra.system import System

__all__ = ["RamanSpectrum", "raman_spectrum", "raman_invariants"]


@dataclass(frozen=True, eq=False, repr=False)
class RamanSpectrum(Result):
    """Raman activity of the vibrational modes, from the bond-polarisability model or from
    polarisability derivatives (a `vibra._results.Result` over the modes; `path` is the model).

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
    model : str
        ``"bond polarisability"`` or ``"polarizability derivatives"``.
    level : str
        The level of theory of the polarisability derivatives (``""`` for the bond model).
    activity_errors : (n_vib,) ndarray or None
        First-order bound on each activity's error from the error estimate of the
        polarisability derivatives, in Angstrom^4/amu (None where none was given):
        15 (2 |alpha'_k| |delta_k| + |delta_k|^2), Frobenius norms, 15 the largest value of
        (45 a'^2 + 7 g'^2) / |alpha'|^2 (an isotropic tensor).
    """

    STORED = {"mode_indices": stored(("n_vib",), kind="int"), "wavenumbers": stored(("n_vib",)),  # (vibra._results)
              "polarizability_derivatives": stored(("n_vib", 3, 3)), "isotropic": stored(("n_vib",)),
              "anisotropy": stored(("n_vib",)), "activities": stored(("n_vib",)),
              "activity_errors": stored(("n_vib",), optional=True)}
    AXIS, NOUNS, PATH_FIELD = "n_vib", ("mode", "modes"), "model"

    mode_indices: NDArray[np.intp]
    wavenumbers: NDArray[np.float64]
    polarizability_derivatives: NDArray[np.float64]
    isotropic: NDArray[np.float64]
    anisotropy: NDArray[np.float64]
    activities: NDArray[np.float64]
    model: str = "bond polarisability"
    level: str = ""
    activity_errors: NDArray[np.float64] | None = None

    def _repr_parts(self) -> tuple[str, ...]:
        return (self._size(), span(self.wavenumbers, "cm^-1"), f"activities {span(self.activities)} Angstrom^4/amu",
                f"{int(self.active().sum())} active")

    def active(self, rtol: float = 1e-8) -> NDArray[np.bool_]:
        """(n_vib,) True where the activity exceeds `rtol` times the strongest line."""
        return active_lines(self.activities, rtol)

    def sticks(self, *, merge_cm1: float = 0.01) -> StickSpectrum:
        """Stick spectrum of the activities (Angstrom^4/amu), degenerate lines summed."""
        return stick_spectrum(self.wavenumbers, self.activities, merge_cm1, "Angstrom^4/amu", "Raman", self.level)

    def depolarization_ratios(self) -> NDArray[np.float64]:
        """(n_vib,) depolarisation ratio of each line for linearly polarised incident light,
        rho = 3 g'^2 / (45 a'^2 + 4 g'^2): 0 to 3/4, 3/4 for a line with no isotropic part (a
        non-totally-symmetric mode); NaN for a line without activity (undefined)."""
        denominator = 45.0 * self.isotropic**2 + 4.0 * self.anisotropy**2
        ratio = np.full(denominator.shape, np.nan)
        np.divide(3.0 * self.anisotropy**2, denominator, out=ratio, where=denominator > 0)
        return ratio

    def cross_sections_cm2_per_sr(self, laser_nm: float = 532.0, temperature: float = 298.15) -> NDArray[np.float64]:
        """(n_vib,) differential Raman cross sections d sigma / d Omega, in cm^2/sr.

        d sigma_k / d Omega = (2 pi)^4 / 45 (nu_0 - nu_k)^4 h / (8 pi^2 c nu_k) S_k
        / (1 - exp(-h c nu_k / k T)), nu in cm^-1 (nu_0 = 10^7 / laser_nm), S_k the activity
        (Angstrom^4/amu as cm^4/g), CGS units (P. L. Polavarapu, J. Phys. Chem. 94, 8106
        (1990); J. Neugebauer, M. Reiher, C. Kind and B. A. Hess, J. Comput. Chem. 23, 895
        (2002)): the Stokes line, linearly polarised incident light, the scattered
        light of both polarisations collected at 90 degrees; the last factor is the Bose
        population of the initial level (1 at T = 0).

        Parameters
        ----------
        laser_nm : float
            Wavelength of the exciting laser, in nm (its wavenumber must exceed every line's).
        temperature : float
            Temperature, in K (>= 0).

        Raises
        ------
        ValueError
            A wavelength that is not positive and finite or whose wavenumber does not exceed the
            highest line; a negative or non-finite temperature.
        """
        wavelength = _validate.positive_scalar(laser_nm, "laser_nm")
        temperature = nonnegative_float(temperature, "temperature")
        laser = 1e7 / wavelength                                    # cm^-1
        if self.wavenumbers.size and laser <= float(self.wavenumbers.max()):
            raise ValueError(f"laser_nm is {wavelength!r}: {laser:.6g} cm^-1, not above the highest line at "
                             f"{float(self.wavenumbers.max()):.6g} cm^-1")
        h, c, k = constants.h * 1e7, constants.c * 1e2, constants.k * 1e7        # erg s, cm/s, erg/K
        activity = self.activities * 1e-32 / (constants.atomic_mass * 1e3)       # Angstrom^4/amu -> cm^4/g
        nu = self.wavenumbers
        bose = np.ones_like(nu) if temperature == 0.0 else -np.expm1(-h * c * nu / (k * temperature))
        return np.asarray((2.0 * np.pi) ** 4 / 45.0 * (laser - nu) ** 4 * h / (8.0 * np.pi**2 * c * nu)
                          * activity / bose, dtype=float)

    def table(self) -> str:
        """Text table: mode, wavenumber (cm^-1), a', g', activity, Raman active."""
        active = self.active()
        lines = [f"Raman ({self.model}{', ' + self.level if self.level else ''})",
                 " mode  wavenumber/cm^-1        a'          g'   activity/(A^4/amu)  active"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{self.mode_indices[k]:5d}  {self.wavenumbers[k]:16.2f}  {self.isotropic[k]:10.4g}  "
                f"{self.anisotropy[k]:10.4g}  {self.activities[k]:19.4g}  "
                f"{'yes' if active[k] else 'no':>6}"
            )
        return "\n".join(lines)



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

    Examples
    --------
    >>> from vibra import molecules
    >>> system = molecules.co2()
    >>> raman = raman_spectrum(system, molecules.vibrational_analysis(system), bonds=[[0, 1], [1, 2]])
    >>> raman.active().tolist()      # mutual exclusion: only the symmetric stretch
    [False, False, True, False]
    """
    system, modes, rigid = system_and_modes(system, modes)
    pairs = bond_pairs(bonds, system.n_sites)
    n_bonds = len(pairs)
    a_par = _validate.per_entry(polarizability_parallel, n_bonds, "polarizability_parallel", "bond")
    a_perp = _validate.per_entry(polarizability_perpendicular, n_bonds, "polarizability_perpendicular", "bond")
    d_par = _validate.per_entry(derivative_parallel, n_bonds, "derivative_parallel", "bond")
    d_perp = _validate.per_entry(derivative_perpendicular, n_bonds, "derivative_perpendicular", "bond")
    zero_rtol = nonnegative_float(zero_rtol, "zero_rtol")
    positions = _cartesian_positions(system)
    vector = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    length = np.linalg.norm(vector, axis=1)
    scale = max(float(np.abs(positions).max()), 1.0)
    short = length <= 1e-12 * scale
    if short.any():
        b = int(np.argmax(short))
        raise ValueError(f"bonds[{b}] joins sites {pairs[b, 0]} and {pairs[b, 1]} at the same position")
    e = vector / length[:, None]                                    # (n_bonds, 3)
    keep = vibrational_mask(modes, zero_rtol, "raman_spectrum", rigid)
    shapes = cartesian_shapes(system, modes)[:, :, keep]           # (n_sites, 3, n_vib)
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
    isotropic, anisotropy, activities = raman_invariants(derivative)
    wavenumbers = modes.wavenumbers_cm1()[keep]
    finite_lines(activities, wavenumbers, "activity", "the bond polarisabilities or the geometry")
    return RamanSpectrum(
        mode_indices=np.flatnonzero(keep), wavenumbers=wavenumbers,
        polarizability_derivatives=derivative, isotropic=isotropic, anisotropy=anisotropy,
        activities=activities,
    )


def raman_invariants(derivative: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                                 NDArray[np.float64]]:
    """a' = tr / 3, g' >= 0 and 45 a'^2 + 7 g'^2 of each (3, 3) tensor of `derivative` (n_vib, 3, 3)."""
    with np.errstate(over="ignore", invalid="ignore"):
        isotropic = np.trace(derivative, axis1=1, axis2=2) / 3.0
        anisotropy = np.sqrt(np.maximum(_anisotropy_squared(derivative), 0.0))
        activities = 45.0 * isotropic**2 + 7.0 * anisotropy**2
    return isotropic, anisotropy, activities


def _anisotropy_squared(t: NDArray[np.float64]) -> NDArray[np.float64]:
    xx, yy, zz = t[:, 0, 0], t[:, 1, 1], t[:, 2, 2]
    xy, yz, zx = t[:, 0, 1], t[:, 1, 2], t[:, 2, 0]
    return 0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2
                  + 6.0 * (xy**2 + yz**2 + zx**2))



def _cartesian_positions(system: System) -> NDArray[np.float64]:
    out = np.zeros((system.n_sites, 3))
    out[:, : system.dim] = system.positions
    return out
