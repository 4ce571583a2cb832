"""Isotope shifts: the wavenumbers of a system before and after changing some masses."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
from numpy.typing import NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import span
from vibra._results import Result, stored
from vibra.molecules.isotopes import ISOTOPE_MASSES, substituted_masses
from vibra.solvers.accuracy import LEVELS as ACCURACY_LEVELS, Accuracy
from vibra.spectra.common import ZERO_RTOL, nonnegative_float, vibrational_mask
from vibra.system import System, Vibrating

__all__ = ["ISOTOPE_MASSES", "IsotopeShifts", "isotope_shifts"]

@dataclass(frozen=True, eq=False, repr=False)
class IsotopeShifts(Result):
    """Wavenumbers of the vibrational modes before and after an isotopic substitution (a
    `vibra._results.Result` over the modes; `path` says how they are paired).

    Modes are paired by shape, not by rank: each original vibration with the substituted
    vibration whose physical shape overlaps it most, one to one (`vibra.compare.match_modes`
    with ``weighted=False``, degenerate sets compared as subspaces). Where the substitution keeps
    the point group, vibrations of different symmetry species have zero overlap, so pairs keep
    their species; where two vibrations of one species cross in frequency (a heavy atom moving
    one of them below the other), each keeps its partner and the shifted wavenumbers are not
    ascending.

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
        Wavenumbers after substitution, in cm^-1: entry k is the partner of original mode k.
    overlap : (n_vib,) ndarray
        |cos| between the physical shapes of each pair (the group overlap for degenerate sets;
        dimensionless, 1 for an unchanged shape).
    ambiguous : (n_vib,) ndarray of bool
        Pairs `match_modes` could not tell apart (two candidates of similar overlap).
    """

    STORED = {"sites": stored(("n_sub",), kind="int"), "original_masses": stored(("n_sub",)),  # (vibra._results)
              "new_masses": stored(("n_sub",)), "wavenumbers": stored(("n_vib",)),
              "shifted_wavenumbers": stored(("n_vib",)), "overlap": stored(("n_vib",)),
              "ambiguous": stored(("n_vib",), kind="bool")}
    AXIS, NOUNS, SIZED, PATH = "n_vib", ("mode", "modes"), {"labels": "n_sub"}, "paired by shape"

    sites: NDArray[np.intp]
    original_masses: NDArray[np.float64]
    new_masses: NDArray[np.float64]
    labels: tuple[str, ...]
    wavenumbers: NDArray[np.float64]
    shifted_wavenumbers: NDArray[np.float64]
    overlap: NDArray[np.float64]
    ambiguous: NDArray[np.bool_]

    def _repr_parts(self) -> tuple[str, ...]:
        return (self._size(), f"{self.sites.size} substituted", f"shifts {span(self.shifts, 'cm^-1')}",
                f"{int(self.ambiguous.sum())} ambiguous" if self.ambiguous.any() else "")

    @property
    def shifts(self) -> NDArray[np.float64]:
        """(n_vib,) shifted minus original wavenumbers, in cm^-1 (negative: red shift)."""
        return self.shifted_wavenumbers - self.wavenumbers

    @property
    def ratios(self) -> NDArray[np.float64]:
        """(n_vib,) shifted / original wavenumbers (dimensionless)."""
        return self.shifted_wavenumbers / self.wavenumbers

    def table(self) -> str:
        """Text table: mode, original and shifted wavenumbers, shift (cm^-1), ratio, overlap of the pair."""
        what = ", ".join(f"site {s}: {lab} ({m0:.6g} -> {m1:.6g})" for s, lab, m0, m1 in zip(
            self.sites, self.labels, self.original_masses, self.new_masses))
        lines = [f"isotope shifts [{what}]",
                 " mode   original/cm^-1   shifted/cm^-1   shift/cm^-1      ratio   overlap"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{k:5d}  {self.wavenumbers[k]:15.2f}  {self.shifted_wavenumbers[k]:14.2f}  "
                f"{self.shifts[k]:12.2f}  {self.ratios[k]:9.6f}  {self.overlap[k]:8.4f}"
                + ("  (ambiguous)" if self.ambiguous[k] else "")
            )
        return "\n".join(lines)



def isotope_shifts(
    system: System,
    substitutions: Mapping[int, float | str],
    *,
    zero_rtol: float = ZERO_RTOL,
    accuracy: Accuracy = "high",
) -> IsotopeShifts:
    """Vibrational wavenumbers before and after replacing the masses of some sites.

    The potential (K) is unchanged; only M changes (`System.with_masses`). Modes are paired
    by the overlap of their physical shapes (see `IsotopeShifts`), not by rank.

    Parameters
    ----------
    system : System
        A system of sites in physical units (isotope names need ASE units: amu).
    substitutions : mapping of int to float or str
        Site index -> new mass (in the mass unit of the system) or an isotope name from
        `ISOTOPE_MASSES` (``"13C"``, ``"18O"``, ``"D"``, ...).
    zero_rtol : float
        Relative threshold of the rigid-body modes left out.
    accuracy : {"high", "fast", "certified"}
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

    Examples
    --------
    >>> from vibra import molecules
    >>> shifts = isotope_shifts(molecules.co2(dims=1), {1: "13C"})
    >>> [round(float(s), 1) for s in shifts.shifts]          # 13C moves only the asymmetric stretch
    [0.0, -68.9]
    """
    if not isinstance(system, Vibrating):
        raise TypeError(f"system must be a vibra.System, got {type(system).__name__}")
    if system.is_generalized:
        raise TypeError("system must be a system of sites; this one is in generalised coordinates")
    if system.units.time_s is None:
        raise ValueError("system is dimensionless; isotope shifts need units 'SI' or 'ASE' (cm^-1)")
    if not isinstance(substitutions, Mapping):
        raise TypeError(f"substitutions must be a mapping of site -> mass, got {type(substitutions).__name__}")
    if not substitutions:
        raise ValueError("substitutions is empty; give at least one site -> new mass")
    zero_rtol = nonnegative_float(zero_rtol, "zero_rtol")
    _validate.choice(accuracy, "accuracy", ACCURACY_LEVELS)
    masses, labels = substituted_masses(system, substitutions)
    sites = [int(site) for site in substitutions]
    old, new = [float(system.masses[site]) for site in sites], [float(masses[site]) for site in sites]
    before = system.modes(accuracy=accuracy)
    after = system.with_masses(masses).modes(accuracy=accuracy)
    keep_before = vibrational_mask(before, zero_rtol, "isotope_shifts")
    keep_after = vibrational_mask(after, zero_rtol, "isotope_shifts")
    if keep_before.sum() != keep_after.sum():
        raise RuntimeError(
            f"the substituted system has {int(keep_after.sum())} vibrational modes, the original "
            f"{int(keep_before.sum())}; adjust zero_rtol")
    from vibra.compare import match_modes

    original, substituted = before[keep_before], after[keep_after]
    match = match_modes(original, substituted, weighted=False)
    partner = match.pairs[np.argsort(match.pairs[:, 0]), 1]
    return IsotopeShifts(
        sites=np.array(sites, dtype=np.intp), original_masses=np.array(old),
        new_masses=np.array(new), labels=tuple(labels),
        wavenumbers=original.wavenumbers_cm1(),
        shifted_wavenumbers=substituted.wavenumbers_cm1()[partner],
        overlap=np.asarray(match.group_overlap, dtype=float)[np.argsort(match.pairs[:, 0])],
        ambiguous=np.asarray(match.ambiguous)[np.argsort(match.pairs[:, 0])],
    )
