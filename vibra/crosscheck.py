"""Cross-check of a molecule's normal modes: vibra against ASE `Vibrations` and phonopy.

One call, `crosscheck(atoms, ...)`, computes the wavenumbers three ways with the same masses
(set explicitly everywhere: the packages' default mass tables differ at 1e-5):

- **vibra**: the analytic valence-force-field Hessian K = B^T diag(w) B (or, when a
  calculator is given, vibra's own finite-difference Hessian) and vibra's eigensolver, with
  translations and rotations projected out (Eckart) unless ``project=False``;
- **ASE** `Vibrations` with a calculator that evaluates the same force field
  (`vibra.molecules.ValenceForceField`) or the given calculator, run in a temporary cache
  directory that is always removed;
- **phonopy**: the molecule in a cubic box as a 1x1x1 supercell, every atom displaced by
  +-delta along x, y and z (``is_symmetry=False``, ``is_plusminus=True``: the same 2-point
  stencil as ASE's ``nfree=2``), forces from the same calculator on the isolated molecule,
  ``produce_force_constants()`` with no force-constant symmetrisation and no sum rule
  imposed, frequencies at Gamma (THz, negative = imaginary) converted to cm^-1 here.

Rigid-body modes are matched by their overlap with the rigid-body subspace (not by position in
the list), vibrations by ascending wavenumber. The finite-difference error that explains the
differences is estimated by vibra's `finite_difference_hessian` with the same step and stencil
(Richardson extrapolation + round-off from the calculator's force noise, probed and measured
by default), propagated to each mode to first order.

ASE and phonopy are imported inside the functions (STYLE.md: they stay at the edge).
"""

from __future__ import annotations

import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra import molecules
from vibra.molecules.checks import check_atoms, nonnegative_scalar
from vibra._core.frozen import Frozen
from vibra.units import ASE

if TYPE_CHECKING:
    from ase import Atoms
    from ase.calculators.calculator import BaseCalculator

    from vibra.molecules.valence import ValenceModel

__all__ = ["CrossCheck", "CrossCheckRow", "crosscheck", "CO2_FUNDAMENTALS_CM1", "H2O_FUNDAMENTALS_CM1"]

#: Experimental CO2 fundamentals, cm^-1, ascending (bend twice: it is doubly degenerate):
#: nu2 = 667, nu1 = 1333, nu3 = 2349 (Herzberg; NIST CCCBDB). nu1 is not observed directly: it is
#: in Fermi resonance with 2 nu2 and appears as the dyad 1285/1388 cm^-1.
CO2_FUNDAMENTALS_CM1 = (667.0, 667.0, 1333.0, 2349.0)
#: Experimental H2O fundamentals, cm^-1, ascending: nu2 = 1595, nu1 = 3657, nu3 = 3756 (NIST CCCBDB).
H2O_FUNDAMENTALS_CM1 = (1595.0, 3657.0, 3756.0)

_HARMONIC_NOTE = ("experimental values are fundamentals (anharmonic); harmonic wavenumbers of a "
                  "first-principles potential lie above them, typically by 1-5 %, more for X-H "
                  "stretches; a force field fitted to fundamentals (vibra's defaults) sits on either side")
_FERMI_NOTE = ("CO2: the symmetric stretch nu1 is in Fermi resonance with the bend overtone 2 nu2; "
               "the observed pair 1285/1388 cm^-1 shares their character, which a harmonic model "
               "(one mode per frequency, no coupling between modes) cannot show")

# THz to cm^-1 (phonopy reports THz): 1e12 Hz / (c in cm/s)
_THZ_TO_CM1 = constants.tera / (constants.c / constants.centi)
# eV to cm^-1 (ASE's VibrationsData.get_energies() gives hbar omega in eV)
_EV_TO_CM1 = constants.electron_volt / (constants.h * constants.c / constants.centi)


@dataclass(frozen=True)
class CrossCheckRow:
    """One mode of a `CrossCheck` table; wavenumbers in cm^-1 (imaginary as negative).

    Attributes
    ----------
    index : int
        Mode index in vibra's ascending order.
    kind : str
        ``"rigid"`` or ``"vibration"``.
    vibra_cm1, ase_cm1, phonopy_cm1 : float
        The three wavenumbers of the matched mode.
    fd_error_cm1 : float
        Estimated error of a finite-difference Hessian with ASE's step and stencil, on this mode.
    phonopy_fd_error_cm1 : float
        The same for phonopy's 2-point stencil.
    experimental_cm1 : float or None
        Experimental fundamental of this vibration, if given.
    """

    index: int
    kind: str
    vibra_cm1: float
    ase_cm1: float
    phonopy_cm1: float
    fd_error_cm1: float
    phonopy_fd_error_cm1: float
    experimental_cm1: float | None


@dataclass(frozen=True, eq=False)
class CrossCheck(Frozen):
    """vibra, ASE and phonopy wavenumbers of one molecule, side by side.

    Attributes
    ----------
    name : str
        The molecule (Hill formula or given name).
    source : str
        Where vibra's Hessian came from (analytic force field or finite differences).
    vibra_cm1 : (n_dof,) ndarray
        vibra's signed wavenumbers, ascending, cm^-1.
    ase_cm1 : (n_dof,) ndarray
        ASE's wavenumbers matched to vibra's modes, cm^-1.
    phonopy_cm1 : (n_dof,) ndarray
        phonopy's wavenumbers at Gamma matched to vibra's modes, cm^-1.
    rigid : (n_dof,) ndarray of bool
        Rigid-body modes (translations, rotations).
    ase_rigid_overlap : (n_dof,) ndarray
        Weight of each matched ASE mode in the rigid-body subspace (near 1 for rigid rows).
    phonopy_rigid_overlap : (n_dof,) ndarray
        The same for phonopy's eigenvectors.
    fd_error_cm1 : (n_dof,) ndarray
        First-order bound of the wavenumber change caused by the estimated error of a
        finite-difference Hessian with ASE's step and stencil, cm^-1.
    phonopy_fd_error_cm1 : (n_dof,) ndarray
        The same for phonopy's 2-point stencil with the same step, cm^-1.
    experimental_cm1 : (n_vibrations,) ndarray or None
        Experimental fundamentals of the vibrations, ascending, cm^-1.
    delta : float
        Displacement of ASE and phonopy, Angstrom.
    nfree : int
        ASE's stencil (2 or 4 points).
    n_rigid : int
        Number of rigid-body modes.
    residual_force : float
        Largest force norm at the reference geometry, eV / Angstrom (0 at an exact
        equilibrium; finite differences of a non-equilibrium geometry mix in rotations).
    force_noise : float
        Noise of one force component in the round-off part of `fd_error_cm1`, eV / Angstrom
        (`FiniteDifferenceHessian.force_noise`).
    noise_source : str
        Where it came from: ``"measured"``, ``"probed"``, ``"analytic"``, ``"given"`` or
        ``"rounding"`` (`FiniteDifferenceHessian.noise_source`).
    notes : tuple of str
        What the comparison does not show (anharmonicity, Fermi resonance).
    """

    name: str
    source: str
    vibra_cm1: NDArray[np.float64]
    ase_cm1: NDArray[np.float64]
    phonopy_cm1: NDArray[np.float64]
    rigid: NDArray[np.bool_]
    ase_rigid_overlap: NDArray[np.float64]
    phonopy_rigid_overlap: NDArray[np.float64]
    fd_error_cm1: NDArray[np.float64]
    phonopy_fd_error_cm1: NDArray[np.float64]
    experimental_cm1: NDArray[np.float64] | None
    delta: float
    nfree: int
    n_rigid: int
    residual_force: float
    force_noise: float
    noise_source: str
    notes: tuple[str, ...]

    @property
    def ase_difference_cm1(self) -> NDArray[np.float64]:
        """(n_dof,) ASE minus vibra, cm^-1."""
        return self.ase_cm1 - self.vibra_cm1

    @property
    def phonopy_difference_cm1(self) -> NDArray[np.float64]:
        """(n_dof,) phonopy minus vibra, cm^-1."""
        return self.phonopy_cm1 - self.vibra_cm1

    def within_error(self, rtol: float = 2e-7) -> bool:
        """True when every vibration's ASE and phonopy differences lie within the fd error.

        The allowance ``rtol * |vibra_cm1|`` covers the packages' unit constants: phonopy's
        THz factor differs from vibra's CODATA 2018 one by 1.2e-7 relative, ASE's (CODATA
        2014) by 4e-9; eigensolver round-off is far smaller (1e-12 relative).
        """
        vib = ~self.rigid
        floor = rtol * np.abs(self.vibra_cm1[vib])
        return bool(
            np.all(np.abs(self.ase_difference_cm1[vib]) <= self.fd_error_cm1[vib] + floor)
            and np.all(np.abs(self.phonopy_difference_cm1[vib]) <= self.phonopy_fd_error_cm1[vib] + floor)
        )

    def rows(self) -> tuple[CrossCheckRow, ...]:
        """One `CrossCheckRow` per mode, in vibra's ascending order."""
        experimental = iter(self.experimental_cm1.tolist()) if self.experimental_cm1 is not None else None
        out = []
        for i in range(self.vibra_cm1.shape[0]):
            rigid = bool(self.rigid[i])
            out.append(CrossCheckRow(
                index=i, kind="rigid" if rigid else "vibration", vibra_cm1=float(self.vibra_cm1[i]),
                ase_cm1=float(self.ase_cm1[i]), phonopy_cm1=float(self.phonopy_cm1[i]),
                fd_error_cm1=float(self.fd_error_cm1[i]),
                phonopy_fd_error_cm1=float(self.phonopy_fd_error_cm1[i]),
                experimental_cm1=None if rigid or experimental is None else float(next(experimental)),
            ))
        return tuple(out)

    def table(self) -> str:
        """Plain-text side-by-side table (cm^-1; an ``i`` marks an imaginary wavenumber)."""
        def wave(value: float) -> str:
            return f"{abs(value):10.3f}{'i' if value < 0 else ' '}"

        has_exp = self.experimental_cm1 is not None
        columns = [("mode", 4), ("kind", 9), ("vibra", 11), ("ASE", 11), ("phonopy", 11), ("ASE - vibra", 11),
                   ("phonopy - vibra", 15), ("ASE fd error", 12), ("phonopy fd error", 16)]
        columns += [("observed", 8)] if has_exp else []
        header = "  ".join(f"{name:<{width}}" if name == "kind" else f"{name:>{width}}" for name, width in columns)
        lines = [
            f"{self.name}: wavenumbers in cm^-1; vibra: {self.source}; ASE Vibrations delta={self.delta:g} A, "
            f"nfree={self.nfree}; phonopy 1x1x1 supercell, +-{self.delta:g} A; residual force "
            f"{self.residual_force:.2g} eV/A; force noise {self.force_noise:.2g} eV/A ({self.noise_source})",
            header,
        ]
        for row in self.rows():
            text = "  ".join((f"{row.index:>4}", f"{row.kind:<9}", wave(row.vibra_cm1), wave(row.ase_cm1),
                              wave(row.phonopy_cm1), f"{row.ase_cm1 - row.vibra_cm1:11.2e}",
                              f"{row.phonopy_cm1 - row.vibra_cm1:15.2e}", f"{row.fd_error_cm1:12.2e}",
                              f"{row.phonopy_fd_error_cm1:16.2e}"))
            if has_exp:
                text += "  " + (f"{row.experimental_cm1:8.0f}" if row.experimental_cm1 is not None else f"{'':>8}")
            lines.append(text.rstrip())
        lines.append("an 'i' marks an imaginary wavenumber; fd error: estimated finite-difference error of the "
                     "Hessian on each mode (Richardson + round-off, first order); rigid modes matched by overlap "
                     "with translations/rotations")
        lines.extend(f"note: {note}" for note in self.notes)
        return "\n".join(lines)


def _signed(omega_squared_or_complex: NDArray[Any]) -> NDArray[np.float64]:
    values = np.asarray(omega_squared_or_complex)
    return np.where(np.abs(values.imag) > np.abs(values.real), -np.abs(values.imag), values.real)


def _match(wavenumbers: NDArray[np.float64], vectors: NDArray[np.float64], t: NDArray[np.float64],
           rigid: NDArray[np.bool_]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reorder another package's modes onto vibra's: rigid by overlap, vibrations by wavenumber.

    vectors are mass-weighted unit columns. Returns (wavenumbers, overlaps) in vibra's order.
    """
    overlap = np.sum((t.T @ vectors) ** 2, axis=0)
    n_rigid = int(rigid.sum())
    by_overlap = np.argsort(-overlap, kind="stable")
    theirs_rigid = by_overlap[:n_rigid]
    theirs_vib = by_overlap[n_rigid:]
    theirs_rigid = theirs_rigid[np.argsort(wavenumbers[theirs_rigid], kind="stable")]
    theirs_vib = theirs_vib[np.argsort(wavenumbers[theirs_vib], kind="stable")]
    order = np.empty(len(wavenumbers), dtype=np.intp)
    order[np.flatnonzero(rigid)] = theirs_rigid
    order[np.flatnonzero(~rigid)] = theirs_vib
    return wavenumbers[order], overlap[order]


def _run_ase(atoms: Any, calculator: Any, delta: float, nfree: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """ASE Vibrations in a temporary cache directory; (wavenumbers cm^-1, mass-weighted vectors)."""
    from ase.vibrations import Vibrations

    work = atoms.copy()
    work.calc = calculator
    with tempfile.TemporaryDirectory(prefix="vibra-ase-") as folder:
        vib = Vibrations(work, name=str(Path(folder) / "vib"), delta=delta, nfree=nfree)
        vib.run()
        for key in sorted(vib.cache.keys()):
            forces = np.asarray(vib.cache[key]["forces"], dtype=float)
            if not np.all(np.isfinite(forces)):
                raise RuntimeError(
                    f"ASE Vibrations got non-finite forces from the calculator at displacement "
                    f"{key!r}; the temporary cache is removed"
                )
        energies, modes = vib.get_vibrations().get_energies_and_modes()
    masses = work.get_masses()
    wavenumbers = _signed(energies) * _EV_TO_CM1
    vectors = modes.reshape(len(energies), -1).T * np.sqrt(np.repeat(masses, 3))[:, None]
    vectors /= np.linalg.norm(vectors, axis=0)
    return wavenumbers, vectors


def _run_phonopy(atoms: Any, calculator: Any, delta: float, box: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """phonopy at Gamma for the molecule in a cubic box; (wavenumbers cm^-1, vectors)."""
    from phonopy import Phonopy
    from phonopy.structure.atoms import PhonopyAtoms

    positions = atoms.get_positions()
    offset = np.full(3, box / 2.0) - positions.mean(axis=0)
    unitcell = PhonopyAtoms(symbols=atoms.get_chemical_symbols(), masses=atoms.get_masses(),
                            positions=positions + offset, cell=np.eye(3) * box)
    phonon = Phonopy(unitcell, supercell_matrix=np.eye(3, dtype=int), primitive_matrix="P",
                     is_symmetry=False)
    phonon.generate_displacements(distance=delta, is_plusminus=True)
    work = atoms.copy()
    work.pbc = False
    work.calc = calculator
    forces = []
    for cell in phonon.supercells_with_displacements or []:
        work.set_positions(np.asarray(cell.positions) - offset)
        values = np.asarray(work.get_forces(), dtype=float)
        if not np.all(np.isfinite(values)):
            raise RuntimeError("phonopy: the calculator returned non-finite forces for a displaced molecule")
        forces.append(values)
    phonon.forces = np.array(forces)
    phonon.produce_force_constants(show_drift=False)
    qpoints = phonon.run_qpoints([[0.0, 0.0, 0.0]], with_eigenvectors=True)
    frequencies = np.asarray(qpoints.frequencies)[0]
    vectors = np.real(np.asarray(qpoints.eigenvectors)[0])
    norms = np.linalg.norm(vectors, axis=0)
    vectors = vectors / np.where(norms > 0, norms, 1.0)
    return frequencies * _THZ_TO_CM1, vectors


def crosscheck(
    atoms: Atoms,
    calculator: BaseCalculator | None = None,
    *,
    model: ValenceModel | None = None,
    delta: float = 0.01,
    nfree: Literal[2, 4] = 2,
    box: float = 20.0,
    project: bool = True,
    experimental_cm1: ArrayLike | None = None,
    force_noise: float | Literal["auto"] | None = "auto",
    force_tolerance: float | None = 1e-3,
    name: str | None = None,
) -> CrossCheck:
    """vibra's wavenumbers beside ASE `Vibrations` and phonopy's, with the fd error explaining them.

    Parameters
    ----------
    atoms : ase.Atoms
        The molecule at equilibrium (Angstrom); its masses (amu) are used by all three.
    calculator : ase Calculator, optional
        Without it, the valence force field `model` is used: vibra's Hessian is analytic and
        ASE/phonopy get `ValenceForceField(model)`. With it (e.g. tblite's GFN2-xTB), vibra's
        Hessian is its own finite difference with ASE's step and stencil.
    model : ValenceModel, optional
        The force field (default: ``valence_model(atoms)``); not allowed with `calculator`.
    delta : float
        Displacement of ASE and phonopy, Angstrom.
    nfree : {2, 4}
        ASE's stencil; phonopy always uses the 2-point one.
    box : float
        Edge of phonopy's cubic cell, Angstrom (only a container: forces come from the
        isolated molecule).
    project : bool
        Project translations and rotations out of vibra's Hessian (Eckart).
    experimental_cm1 : (n_vibrations,) array_like, optional
        Experimental fundamentals, ascending, shown in the table (e.g.
        `CO2_FUNDAMENTALS_CM1`); adds notes on what the harmonic model misses.
    force_noise : "auto", float or None
        Noise of one force component of `calculator`, eV / Angstrom, for the round-off part of
        the error estimate, as in `finite_difference_hessian`: ``"auto"`` (default) probes a
        calculator that is not a listed closed-form one (2 force calls) and measures its noise
        when it shows some (6 in all); a number gives it; None takes rounding alone. With
        ``nfree=4`` the second estimate (phonopy's 2-point stencil) reuses what the first found.
    force_tolerance : float or None
        Largest residual force (eV / Angstrom) accepted from `calculator` at `atoms`: the
        frequencies of a geometry that is not an equilibrium mean nothing (relax it first).
        None skips the check. (A valence force field is always checked, at 1e-4 eV / Angstrom,
        by `from_atoms`.)
    name : str, optional
        Name in the table (the Hill formula by default).

    Returns
    -------
    CrossCheck

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms; both `model` and `calculator` given.
    ValueError
        Bad delta, nfree, box, force_tolerance or experimental values (checked before any
        force call); unknown elements, overlapping atoms; a geometry that is not an
        equilibrium (residual force reported).
    RuntimeError
        The calculator returned non-finite forces; no file is left behind.

    Examples
    --------
    >>> from vibra import molecules
    >>> result = crosscheck(molecules.h2o_atoms())    # valence force field guessed from the geometry
    >>> result.n_rigid, int((~result.rigid).sum()), result.within_error()
    (6, 3, True)
    """
    from ase import Atoms as _Atoms

    if not isinstance(atoms, _Atoms):
        raise TypeError(f"atoms must be an ase.Atoms, got {type(atoms).__name__}")
    if calculator is not None and model is not None:
        raise TypeError("give either model (valence force field) or calculator, not both")
    step = _validate.real_scalar(delta, "delta")
    if not step > 0:
        raise ValueError(f"delta is {step!r}; the displacement must be positive (Angstrom)")
    if isinstance(nfree, bool) or nfree not in (2, 4):
        raise ValueError(f"nfree is {nfree!r}; expected 2 or 4 (ASE's stencils)")
    edge = _validate.real_scalar(box, "box")
    positions, masses = check_atoms(atoms)
    extent = float(np.ptp(positions, axis=0).max())
    if not edge > extent + 2.0:
        raise ValueError(f"box is {edge!r} Angstrom; it must exceed the molecule's extent ({extent:.3g}) by 2 Angstrom")
    t = molecules.rigid_body_vectors(positions, masses)
    experimental = None
    if experimental_cm1 is not None:
        experimental = _validate.real_array(experimental_cm1, "experimental_cm1", ndim=1)
        n_vibrations = t.shape[0] - t.shape[1]
        if experimental.shape[0] != n_vibrations:
            raise ValueError(f"experimental_cm1 must have {n_vibrations} values (one per vibration), "
                             f"got {experimental.shape[0]}")
    tolerance = None if force_tolerance is None else nonnegative_scalar(
        force_tolerance, "force_tolerance", "eV/Angstrom")
    label = name if name is not None else atoms.get_chemical_formula(mode="hill")
    work = atoms.copy()
    work.set_masses(masses)  # explicit masses for all three packages

    if calculator is None:
        if model is None:
            model = molecules.valence_model(work)
        system = molecules.from_atoms(work, model, name=label)
        calc: BaseCalculator = molecules.ValenceForceField(model)
        estimate = molecules.finite_difference_hessian(work, calc, step=step, stencil=nfree,
                                                       force_noise=force_noise, symmetry=False)
        source = "analytic valence force field B^T W B"
    else:
        calc = calculator
        estimate = molecules.finite_difference_hessian(work, calc, step=step, stencil=nfree,
                                                       force_noise=force_noise, force_tolerance=tolerance,
                                                       symmetry=False)  # the peers' Cartesian plan
        system = estimate.system(name=label)
        source = f"finite differences ({nfree}-point, step {step:g} A) of {type(calculator).__name__}"
    # the 2-point estimate for phonopy: the noise the first run found or was given (no second probe)
    found = estimate.force_noise if estimate.noise_source in ("measured", "given") else None
    phonopy_estimate = estimate if nfree == 2 else molecules.finite_difference_hessian(
        work, calc, step=step, stencil=2, force_noise=found, symmetry=False)

    with warnings.catch_warnings():
        # an imaginary mode is kept and flagged in the table, not raised
        warnings.simplefilter("ignore", RuntimeWarning)
        analysis = molecules.vibrational_analysis(system, project=project)
    modes = analysis.modes
    rigid = np.asarray(analysis.rigid)

    ase_cm1, ase_vectors = _run_ase(work, calc, step, nfree)
    phonopy_cm1, phonopy_vectors = _run_phonopy(work, calc, step, edge)
    ase_matched, ase_overlap = _match(ase_cm1, ase_vectors, t, rigid)
    phonopy_matched, phonopy_overlap = _match(phonopy_cm1, phonopy_vectors, t, rigid)

    notes: list[str] = []
    if experimental is not None:
        notes.append(_HARMONIC_NOTE)
        if atoms.get_chemical_formula(mode="hill") == "CO2":
            notes.append(_FERMI_NOTE)
    to_cm1 = ASE.omega_to_cm1
    return CrossCheck(
        name=label, source=source, vibra_cm1=modes.wavenumbers_cm1(), ase_cm1=ase_matched,
        phonopy_cm1=phonopy_matched, rigid=rigid, ase_rigid_overlap=ase_overlap,
        phonopy_rigid_overlap=phonopy_overlap,
        fd_error_cm1=to_cm1(estimate.omega_errors(modes)),
        phonopy_fd_error_cm1=to_cm1(phonopy_estimate.omega_errors(modes)),
        experimental_cm1=experimental, delta=step, nfree=int(nfree), n_rigid=analysis.n_rigid,
        residual_force=estimate.residual_force, force_noise=estimate.force_noise,
        noise_source=estimate.noise_source, notes=tuple(notes),
    )
