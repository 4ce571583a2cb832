"""`electronic_structure`: the Hessian, dipole and polarisability derivatives of a molecule from an
engine, on vibra's finite-difference machinery (one displacement loop, cached, resumable, on
Dask, with its error estimates), plus the engine's analytic Hessian where it has one."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core.frozen import Frozen
from vibra.cluster import ClientOption, ProgressOption
from vibra.modes import Modes
from vibra.molecules.checks import check_atoms, masses_or_default
from vibra.molecules.displacements import CalculatorOption, is_calculator, is_factory
from vibra.molecules.engines.protocol import Engine, engine_methods
from vibra.molecules.finite_difference import FiniteDifferenceHessian, finite_difference_hessian
from vibra.molecules.property_derivatives import check_properties
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["ElectronicStructure", "electronic_structure", "HESSIAN_SOURCES"]

#: Where the Hessian of an `ElectronicStructure` may come from.
HESSIAN_SOURCES = ("auto", "analytic", "finite difference")


@dataclass(frozen=True, eq=False)
class ElectronicStructure(Frozen):
    """What an engine gave for one molecule: its Hessian, and its dipole and polarisability
    derivatives with their finite-difference error estimates.

    Attributes
    ----------
    level : str
        The engine's level of theory (``"RHF/STO-3G"``), carried on to spectra and charts.
    hessian : (3 n_atoms, 3 n_atoms) ndarray
        The Hessian the modes come from, in eV / Angstrom^2: the analytic one where the engine
        has it (and it was asked for), else the finite-difference one.
    hessian_method : str
        ``"analytic"`` or ``"finite difference"``.
    analytic_hessian : (3 n_atoms, 3 n_atoms) ndarray or None
        The engine's analytic Hessian, in eV / Angstrom^2 (None: not computed), symmetrised,
        (H + H^T) / 2: the response equations converge to a tolerance, and H_ij - H_ji is
        checked to be within the finite-difference error estimate first.
    finite_difference : FiniteDifferenceHessian
        The finite-difference run over the same geometries: its Hessian (a cross-check of the
        analytic one, with its error estimate), and in ``derivatives`` the dipole and
        polarisability derivatives with theirs.
    methods : tuple of (str, str) pairs
        How the engine computes each property (``("polarizability", "analytic response (CPHF)")``).
    symbols : tuple of str
        Chemical symbols.
    """

    level: str
    hessian: NDArray[np.float64]
    hessian_method: str
    analytic_hessian: NDArray[np.float64] | None
    finite_difference: FiniteDifferenceHessian
    methods: tuple[tuple[str, str], ...]
    symbols: tuple[str, ...]

    @property
    def positions(self) -> NDArray[np.float64]:
        """(n_atoms, 3) reference geometry, in Angstrom."""
        return self.finite_difference.positions

    @property
    def masses(self) -> NDArray[np.float64]:
        """(n_atoms,) masses, in amu."""
        return self.finite_difference.masses

    @property
    def dipole_derivatives(self) -> NDArray[np.float64] | None:
        """(3 n_atoms, 3) d mu_a / d x_ib (row 3 i + b), in e; None without the dipole."""
        derivatives = self.finite_difference.derivatives
        return None if derivatives is None else derivatives.dipole

    @property
    def polarizability_derivatives(self) -> NDArray[np.float64] | None:
        """(3 n_atoms, 3, 3) d alpha / d x_ib, in Angstrom^2; None without the polarisability."""
        derivatives = self.finite_difference.derivatives
        return None if derivatives is None else derivatives.polarizability

    @property
    def polarizability_method(self) -> str:
        """How the polarisability was computed (``""`` when it was not)."""
        return dict(self.methods).get("polarizability", "") if self.polarizability_derivatives is not None else ""

    def system(self, *, masses: ArrayLike | None = None, name: str = "molecule") -> System:
        """The molecule with `hessian` (ASE units), optionally with other masses (amu)."""
        system = System.from_hessian(self.positions, masses_or_default(masses, self.masses), self.hessian,
                                     units="ASE", name=name)
        return system.with_symbols(list(self.symbols))

    def hessian_disagreement(self) -> float:
        """Largest |analytic - finite difference| / (the finite difference's error estimate) over
        the Hessian's entries: at most 1 where the two agree within the stated error.

        Raises
        ------
        ValueError
            No analytic Hessian was computed.
        """
        if self.analytic_hessian is None:
            raise ValueError(f"{self.level}: no analytic Hessian was computed (hessian='finite difference')")
        fd = self.finite_difference
        return float(np.max(np.abs(self.analytic_hessian - fd.hessian) / fd.error))

    def omega_errors(self, modes: Modes) -> NDArray[np.float64]:
        """(n_modes,) the finite-difference Hessian's first-order bound on each omega (rad per ASE
        time unit; `FiniteDifferenceHessian.omega_errors`): the error of the modes where
        ``hessian_method`` is finite difference, a cross-check scale where it is analytic."""
        return self.finite_difference.omega_errors(modes)


def electronic_structure(
    atoms: Atoms,
    engine: Engine | CalculatorOption,
    *,
    hessian: Literal["auto", "analytic", "finite difference"] = "auto",
    properties: Sequence[str] | None = None,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    estimate_error: bool = True,
    force_tolerance: float | None = 1e-3,
    client: ClientOption = None,
    cache: str | os.PathLike[str] | None = None,
    progress: ProgressOption = None,
    n_workers: int | None = None,
    symmetry: bool = True,
) -> ElectronicStructure:
    """Hessian, dipole and polarisability derivatives of a molecule from an electronic-structure engine.

    The displaced geometries are those of `vibra.molecules.finite_difference_hessian` (central
    differences of +-`step` along every Cartesian coordinate, plus a coarser step for the
    Richardson error estimate): at each, one engine calculation gives the forces and the
    properties, so the finite-difference Hessian and the derivatives d mu / dx and
    d alpha / dx come from one loop, with the same cache, Dask fan-out and error estimates
    (truncation by Richardson extrapolation, round-off from the engine's stated noise). Where
    the engine has an analytic Hessian it is computed too and used for the modes; the
    finite-difference one is kept beside it as a cross-check (`hessian_disagreement`).

    Parameters
    ----------
    atoms : ase.Atoms
        The molecule at an equilibrium geometry of the engine (Angstrom); masses (amu) from it.
    engine : Engine or ASE calculator
        A `vibra.molecules.engines.Engine` (`PySCFEngine`, ...) or an ASE calculator or factory
        (wrapped in `AseEngine`: its dipole where it gives one).
    hessian : {"auto", "analytic", "finite difference"}
        The Hessian of the modes: ``"auto"`` the analytic one where the engine has it (else the
        finite difference); ``"analytic"`` requires it; ``"finite difference"`` skips it.
    properties : sequence of {"dipole", "polarizability"}, optional
        What to differentiate (default: every one the engine gives).
    step, stencil, estimate_error, force_tolerance, client, cache, progress, n_workers, symmetry
        As in `vibra.molecules.finite_difference_hessian` (`cache`: a folder; each geometry's
        forces and properties are one file there, so an interrupted run resumes; `symmetry`:
        displace only the symmetry-unique atoms and directions). The force noise is the
        engine's where it states one, else probed.

    Returns
    -------
    ElectronicStructure

    Raises
    ------
    TypeError
        `engine` neither an Engine nor an ASE calculator; `atoms` not an ase.Atoms.
    ValueError
        An unknown `hessian` or property, a property the engine does not give, ``"analytic"``
        for an engine without an analytic Hessian, or what `finite_difference_hessian` refuses
        (a residual force above `force_tolerance` among them).
    RuntimeError
        The engine failed at a geometry (named).
    """
    from ase.data import chemical_symbols

    from vibra.molecules.engines.ase_engine import AseEngine
    from vibra.molecules.engines.calculator import EngineCalculator

    positions, _ = check_atoms(atoms)
    if not isinstance(engine, Engine):
        if is_calculator(engine) or is_factory(engine):
            engine = AseEngine(engine)
        else:
            raise TypeError(f"engine must be a vibra.molecules.engines.Engine or an ASE calculator, got "
                            f"{type(engine).__name__}")
    if hessian not in HESSIAN_SOURCES:
        raise ValueError(f"hessian is {hessian!r}; expected one of {list(HESSIAN_SOURCES)}")
    available = [name for name in ("dipole", "polarizability") if name in engine.capabilities]
    names, _ = check_properties(available if properties is None else properties, None)
    if hessian == "analytic" and "hessian" not in engine.capabilities:
        raise ValueError(f"hessian='analytic' but engine {engine.level!r} has no analytic Hessian; "
                         "use 'auto' or 'finite difference'")
    noise: Mapping[str, float] = engine.noise
    calculator = EngineCalculator(engine, names)  # ValueError for a property the engine does not give
    fd = finite_difference_hessian(
        atoms, calculator, step=step, stencil=stencil, estimate_error=estimate_error,
        force_noise=noise.get("forces", "auto"), force_tolerance=force_tolerance, client=client, cache=cache,
        progress=progress, n_workers=n_workers, properties=names, symmetry=symmetry,
        property_noise={name: noise[name] for name in names if name in noise})
    analytic = None
    if hessian != "finite difference" and "hessian" in engine.capabilities:
        numbers = np.asarray(atoms.get_atomic_numbers())
        analytic = np.asarray(engine.hessian(numbers, positions), dtype=float)
        if analytic.shape != fd.hessian.shape or not np.all(np.isfinite(analytic)):
            raise RuntimeError(f"engine {engine.level!r} returned an analytic Hessian of shape {analytic.shape} "
                               f"(finite: {bool(np.all(np.isfinite(analytic)))}); expected finite {fd.hessian.shape}")
        # The coupled-perturbed equations converge to a tolerance, so H_ij and H_ji differ by that much
        # (6e-7 eV/Angstrom^2 for H2O at RHF/6-31G*): symmetrised where the gap is within the
        # finite-difference error estimate of the same entries, refused where it is not.
        gap = np.abs(analytic - analytic.T)
        allowed = np.maximum(fd.error, fd.error.T)
        if np.any(gap > allowed):
            i, j = np.unravel_index(int(np.argmax(gap - allowed)), gap.shape)
            raise RuntimeError(f"engine {engine.level!r} returned an analytic Hessian that is not symmetric: "
                               f"|H[{i},{j}] - H[{j},{i}]| = {gap[i, j]:.3g} eV/Angstrom^2, more than the finite-"
                               f"difference error estimate {allowed[i, j]:.3g}")
        analytic = (analytic + analytic.T) / 2.0
    symbols = tuple(chemical_symbols[int(z)] for z in atoms.get_atomic_numbers())
    return ElectronicStructure(
        level=engine.level, hessian=analytic if analytic is not None else fd.hessian,
        hessian_method="analytic" if analytic is not None else "finite difference", analytic_hessian=analytic,
        finite_difference=fd, methods=tuple(sorted(engine_methods(engine).items())), symbols=symbols)
