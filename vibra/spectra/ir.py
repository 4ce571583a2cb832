"""IR intensities from point charges or dipole derivatives, in e^2/amu and km/mol."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Mapping

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

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["KM_PER_MOL_PER_E2_AMU", "PAULING_ELECTRONEGATIVITY", "IRSpectrum", "ir_spectrum",
           "dipole_derivatives", "electronegativity_charges"]

#: N_A / (12 epsilon_0 c^2), converting |dmu/dQ|^2 in e^2/amu to an integrated absorption
#: coefficient in km/mol (about 974.88).
KM_PER_MOL_PER_E2_AMU = (
    constants.N_A * constants.e**2
    / (12.0 * constants.epsilon_0 * constants.c**2 * constants.atomic_mass) / constants.kilo
)

#: Pauling electronegativities (CRC Handbook of Chemistry and Physics) used by
#: `electronegativity_charges`.
PAULING_ELECTRONEGATIVITY: Mapping[str, float] = {
    "H": 2.20, "Li": 0.98, "B": 2.04, "C": 2.55, "N": 3.04, "O": 3.44, "F": 3.98,
    "Na": 0.93, "Mg": 1.31, "Al": 1.61, "Si": 1.90, "P": 2.19, "S": 2.58, "Cl": 3.16,
    "K": 0.82, "Br": 2.96, "I": 2.66,
}


_IR_UNITS = ("km/mol", "e^2/amu")



@dataclass(frozen=True, eq=False, repr=False)
class IRSpectrum(Result):
    """IR activity of the vibrational modes of one system (a `vibra._results.Result` over the
    modes; `path` is the model).

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
    level : str
        The level of theory of the dipole derivatives (``"RHF/STO-3G"``; ``""`` for the point
        charges and for derivatives given as numbers); charts show it.
    intensity_errors : (n_vib,) ndarray or None
        First-order bound on each intensity's error from the error estimate of the dipole
        derivatives, in e^2/amu (None where none was given): sum_a 2 |dmu_a/dQ_k| d_a + d_a^2,
        d_a = sum_ib |error_iba| |u_k[i, b]|.
    """

    STORED = {"mode_indices": stored(("n_vib",), kind="int"), "wavenumbers": stored(("n_vib",)),  # (vibra._results)
              "dipole_derivatives": stored(("n_vib", 3)), "intensities": stored(("n_vib",)),
              "intensity_errors": stored(("n_vib",), optional=True)}
    AXIS, NOUNS, PATH_FIELD = "n_vib", ("mode", "modes"), "model"

    mode_indices: NDArray[np.intp]
    wavenumbers: NDArray[np.float64]
    dipole_derivatives: NDArray[np.float64]
    intensities: NDArray[np.float64]
    model: str
    level: str = ""
    intensity_errors: NDArray[np.float64] | None = None

    def _repr_parts(self) -> tuple[str, ...]:
        return (self._size(), span(self.wavenumbers, "cm^-1"), f"intensities {span(self.intensities)} e^2/amu",
                f"{int(self.active().sum())} active")

    def intensities_km_per_mol(self) -> NDArray[np.float64]:
        """(n_vib,) integrated absorption coefficients, in km/mol."""
        return self.intensities * KM_PER_MOL_PER_E2_AMU

    def intensity_errors_km_per_mol(self) -> NDArray[np.float64] | None:
        """(n_vib,) `intensity_errors` in km/mol (None where there are none)."""
        return None if self.intensity_errors is None else self.intensity_errors * KM_PER_MOL_PER_E2_AMU

    def active(self, rtol: float = 1e-8) -> NDArray[np.bool_]:
        """(n_vib,) True where the intensity exceeds `rtol` times the strongest line.

        A symmetry-forbidden line comes out at rounding level (about 1e-30 of the strongest),
        so the default threshold separates allowed from forbidden lines with a wide margin.
        """
        return active_lines(self.intensities, rtol)

    def sticks(self, *, unit: Literal["km/mol", "e^2/amu"] = "km/mol",
               merge_cm1: float = 0.01) -> StickSpectrum:
        """Stick spectrum; lines closer than `merge_cm1` (cm^-1) are merged and summed."""
        _validate.choice(unit, "unit", _IR_UNITS)
        values = self.intensities_km_per_mol() if unit == "km/mol" else self.intensities
        return stick_spectrum(self.wavenumbers, values, merge_cm1, unit, "IR", self.level)

    def table(self) -> str:
        """Text table: mode, wavenumber (cm^-1), intensity (km/mol, e^2/amu), IR active."""
        active = self.active()
        lines = [f"IR ({self.model}{', ' + self.level if self.level else ''})", " mode  wavenumber/cm^-1   I/(km/mol)    I/(e^2/amu)  active"]
        for k in range(len(self.wavenumbers)):
            lines.append(
                f"{self.mode_indices[k]:5d}  {self.wavenumbers[k]:16.2f}  "
                f"{self.intensities_km_per_mol()[k]:11.4g}  {self.intensities[k]:13.4g}  "
                f"{'yes' if active[k] else 'no':>6}"
            )
        return "\n".join(lines)



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

    Examples
    --------
    >>> from vibra import molecules
    >>> system = molecules.co2()
    >>> ir = ir_spectrum(system, molecules.vibrational_analysis(system), charges=[-0.3, 0.6, -0.3])
    >>> [round(float(w)) for w in ir.wavenumbers], ir.active().tolist()   # symmetric stretch is IR-silent
    ([667, 667, 1279, 2448], [True, True, False, True])
    """
    system, modes, rigid = system_and_modes(system, modes)
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
    zero_rtol = nonnegative_float(zero_rtol, "zero_rtol")
    keep = vibrational_mask(modes, zero_rtol, "ir_spectrum", rigid)
    shapes = cartesian_shapes(system, modes)[:, :, keep]  # (n_sites, 3, n_vib)
    with np.errstate(over="ignore", invalid="ignore"):
        dmu_dq = np.einsum("iba,ibk->ka", derivatives, shapes)
        intensities = np.sum(dmu_dq**2, axis=1)
    wavenumbers = modes.wavenumbers_cm1()[keep]
    finite_lines(intensities, wavenumbers, "intensity", "charges" if model == "point charges" else "dipole_derivatives")
    return IRSpectrum(
        mode_indices=np.flatnonzero(keep), wavenumbers=wavenumbers,
        dipole_derivatives=dmu_dq, intensities=intensities, model=model,
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
    step = _validate.positive_scalar(step, "step")
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

    Examples
    --------
    >>> electronegativity_charges(["O", "C", "O"], [[0, 1], [1, 2]]).round(3).tolist()
    [-0.178, 0.356, -0.178]
    """
    names = [str(s) for s in np.atleast_1d(np.asarray(symbols, dtype=object))]
    chi = np.empty(len(names))
    for i, name in enumerate(names):
        if name not in PAULING_ELECTRONEGATIVITY:
            known = ", ".join(PAULING_ELECTRONEGATIVITY)
            raise ValueError(f"symbols[{i}] is {name!r}; known elements: {known}")
        chi[i] = PAULING_ELECTRONEGATIVITY[name]
    pairs = bond_pairs(bonds, len(names))
    transfer = _validate.positive_scalar(transfer, "transfer")
    charges = np.zeros(len(names))
    moved = transfer * (chi[pairs[:, 1]] - chi[pairs[:, 0]])
    np.add.at(charges, pairs[:, 0], moved)
    np.add.at(charges, pairs[:, 1], -moved)
    return charges
