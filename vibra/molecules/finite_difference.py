"""Hessians of any ASE calculator by central differences of its forces, with an error estimate
(Richardson extrapolation for the truncation, force noise / step for the round-off)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra import _validate
from vibra._frozen import _freeze_arrays
from vibra.modes import Modes
from vibra.molecules.checks import check_atoms, masses_or_default, molecule_name, nonnegative_scalar
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["FiniteDifferenceHessian", "finite_difference_hessian", "from_calculator"]


@dataclass(frozen=True, eq=False)
class FiniteDifferenceHessian:
    """A Hessian from central differences of forces, with its own error estimate.

    Attributes
    ----------
    hessian : (3 n_atoms, 3 n_atoms) ndarray
        Symmetrised (D + D^T) / 2 of the difference quotients D, in eV / Angstrom^2.
    error : (3 n_atoms, 3 n_atoms) ndarray
        Estimated absolute error of each entry (truncation + round-off), eV / Angstrom^2.
    truncation : (3 n_atoms, 3 n_atoms) ndarray
        Truncation part: Richardson estimate from a second step 2h (or, without it, the
        asymmetry |D - D^T| / 2, a weaker indicator), eV / Angstrom^2.
    roundoff : float
        Round-off part, ~ force_noise / step, eV / Angstrom^2.
    asymmetry : float
        Largest |D_ij - D_ji| / 2 before symmetrisation, eV / Angstrom^2.
    residual_force : float
        Largest force norm at the reference geometry, eV / Angstrom.
    positions : (n_atoms, 3) ndarray
        Reference geometry, Angstrom.
    masses : (n_atoms,) ndarray
        Masses, amu.
    numbers : (n_atoms,) ndarray of int
        Atomic numbers.
    step : float
        Displacement h, Angstrom.
    stencil : int
        2 (+-h) or 4 (+-h, +-2h) points per degree of freedom.
    error_method : str
        ``"richardson"`` or ``"asymmetry"``.
    n_force_calls : int
        Calculator force evaluations spent, including the reference geometry.
    """

    hessian: NDArray[np.float64]
    error: NDArray[np.float64]
    truncation: NDArray[np.float64]
    roundoff: float
    asymmetry: float
    residual_force: float
    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    numbers: NDArray[np.int_]
    step: float
    stencil: int
    error_method: str
    n_force_calls: int

    def __post_init__(self) -> None:
        _freeze_arrays(self)

    def system(self, *, masses: ArrayLike | None = None, name: str = "molecule") -> System:
        """The `System` with this Hessian (ASE units), optionally with other masses (amu)."""
        from ase.data import chemical_symbols

        system = System.from_hessian(self.positions, masses_or_default(masses, self.masses), self.hessian,
                                     units="ASE", name=name)
        return system.with_symbols([chemical_symbols[int(z)] for z in self.numbers])

    def omega_errors(self, modes: Modes) -> NDArray[np.float64]:
        """(n_modes,) first-order bound on how far each omega moves under `error`.

        |delta omega_k^2| <= sum_ij |d_ki| E_ij / sqrt(m_i m_j) |d_kj| with d_k the mass-weighted
        vectors of `modes`; delta omega = min(delta omega^2 / (2 |omega|), sqrt(delta omega^2)),
        in rad per ASE time unit.

        First order only: where modes lie closer together (in omega^2) than the error couples
        them, second-order mixing dominates and this underestimates. Measured on a 300-atom
        valence-force-field chain (h = 0.01 Angstrom, bench_hessian.py): 19 of 894 vibrations,
        the soft torsions at 7-70 cm^-1 and two near 190 cm^-1, moved up to 4 times further.
        CO2 and H2O stay well within it.
        """
        return _omega_bound(self.error, self.masses, modes)


def _omega_bound(error: NDArray[np.float64], masses: NDArray[np.float64], modes: Modes) -> NDArray[np.float64]:
    if modes.vectors is None:
        raise ValueError("modes has no vectors; compute the modes with vectors=True")
    scale = 1.0 / np.sqrt(np.repeat(masses, 3))
    weighted = np.abs(error) * scale[:, None] * scale[None, :]
    d = np.abs(modes.vectors)
    if d.shape[0] != weighted.shape[0]:
        raise ValueError(f"modes has {d.shape[0]} dofs; the Hessian has {weighted.shape[0]}")
    lam = np.sum(d * (weighted @ d), axis=0)      # d_k^T W d_k for every k, one matrix product
    return np.minimum(lam / np.maximum(2.0 * np.abs(modes.omega), 1e-300), np.sqrt(lam))


def finite_difference_hessian(
    atoms: Atoms,
    calculator: Any = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    estimate_error: bool = True,
    force_noise: float | None = None,
    force_tolerance: float | None = None,
) -> FiniteDifferenceHessian:
    """Hessian of any ASE calculator by central differences of its forces.

    H_ij = -dF_j/dx_i; 2-point: D(h) = (F(-h) - F(+h)) / 2h, error O(h^2); 4-point:
    (4 D(h) - D(2h)) / 3, error O(h^4); the result is symmetrised, (D + D^T) / 2. With
    `estimate_error` one more step size is evaluated (2h for the 2-point stencil, 4h for the
    4-point one) and the truncation error is estimated by Richardson extrapolation:
    |D(h) - D(2h)| / 3, or |R(h) - R(2h)| / 15 for the 4-point result R. The round-off error is
    ~ force_noise / h. Everything stays in memory (no cache files).

    Parameters
    ----------
    atoms : ase.Atoms
        Reference geometry, Angstrom; masses (amu) are read from it. Not modified.
    calculator : ase Calculator, optional
        Evaluates the forces; ``atoms.calc`` by default.
    step : float
        Displacement h, Angstrom.
    stencil : {2, 4}
        Points per degree of freedom.
    estimate_error : bool
        Spend 6 n_atoms extra force calls on the Richardson truncation estimate.
    force_noise : float, optional
        Absolute noise of one force component, eV / Angstrom (e.g. the SCF convergence of a
        quantum-chemistry calculator). Default: 8 machine epsilons of the largest force seen.
    force_tolerance : float, optional
        Raise if the largest force at the reference geometry exceeds this (eV / Angstrom): the
        Hessian of a non-equilibrium geometry gives meaningless frequencies. None: no check.

    Returns
    -------
    FiniteDifferenceHessian

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms, or no calculator.
    ValueError
        Bad step, stencil or noise; unknown elements or overlapping atoms; a residual force
        above `force_tolerance` (reported).
    RuntimeError
        The calculator returned forces that are not finite or of the wrong shape (the
        displacement is named); nothing is written anywhere.

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, h2o_atoms, valence_model
    >>> atoms = h2o_atoms()
    >>> result = finite_difference_hessian(atoms, ValenceForceField(valence_model(atoms)))
    >>> result.hessian.shape, result.n_force_calls, result.error_method
    ((9, 9), 37, 'richardson')
    """
    positions, masses = check_atoms(atoms)
    calc = calculator if calculator is not None else atoms.calc
    if calc is None:
        raise TypeError("calculator is None and atoms has no calculator attached; pass calculator=")
    if not hasattr(calc, "get_forces") and not hasattr(calc, "get_property"):
        raise TypeError(f"calculator must be an ASE calculator, got {type(calc).__name__}")
    h = _validate.real_scalar(step, "step")
    if not h > 0:
        raise ValueError(f"step is {h!r}; the displacement must be positive (Angstrom)")
    if isinstance(stencil, bool) or stencil not in (2, 4):
        raise ValueError(f"stencil is {stencil!r}; expected 2 or 4 (points per degree of freedom)")
    noise = None if force_noise is None else nonnegative_scalar(force_noise, "force_noise", "eV/Angstrom")
    tolerance = None if force_tolerance is None else nonnegative_scalar(force_tolerance, "force_tolerance",
                                                                   "eV/Angstrom")
    work = atoms.copy()
    work.calc = calc
    n = len(work)
    n_dof = 3 * n
    calls = 0
    largest = 0.0

    def forces_at(shift: NDArray[np.float64] | None, where: str) -> NDArray[np.float64]:
        nonlocal calls, largest
        work.set_positions(positions if shift is None else positions + shift)
        calls += 1
        values = np.asarray(work.get_forces(), dtype=float)
        if values.shape != (n, 3):
            raise RuntimeError(f"calculator returned forces of shape {values.shape} at {where}; expected ({n}, 3)")
        bad = ~np.isfinite(values)
        if bad.any():
            a, c = (int(v) for v in np.argwhere(bad)[0])
            raise RuntimeError(
                f"calculator returned non-finite forces at {where}: forces[{a},{c}] = {values[a, c]!r}"
            )
        largest = max(largest, float(np.abs(values).max()))
        return values.ravel()

    reference = forces_at(None, "the reference geometry").reshape(n, 3)
    residual = float(np.linalg.norm(reference, axis=1).max())
    if tolerance is not None:
        if residual > tolerance:
            worst = int(np.argmax(np.linalg.norm(reference, axis=1)))
            raise ValueError(
                f"atoms is not an equilibrium of the calculator: residual force {residual:.3g} eV/Angstrom "
                f"on atom {worst} (force_tolerance={tolerance:g}); relax the geometry first"
            )
    # step multiples evaluated: the stencil's own, plus one coarser for the Richardson estimate
    multiples = [1] if stencil == 2 else [1, 2]
    if estimate_error:
        multiples.append(2 if stencil == 2 else 4)
    quotient = {m: np.empty((n_dof, n_dof)) for m in multiples}
    axes = "xyz"
    for i in range(n_dof):
        for m in multiples:
            shift = np.zeros((n, 3))
            shift.flat[i] = m * h
            where = f"atom {i // 3} displaced by {{}}{m}h along {axes[i % 3]}"
            plus = forces_at(shift, where.format("+"))
            minus = forces_at(-shift, where.format("-"))
            quotient[m][i] = (minus - plus) / (2.0 * m * h)
    if stencil == 2:
        raw = quotient[1]
        truncation_raw = np.abs(quotient[1] - quotient[2]) / 3.0 if estimate_error else None
        noise_gain = np.sqrt(2.0) / 2.0
    else:
        raw = (4.0 * quotient[1] - quotient[2]) / 3.0
        truncation_raw = None
        if estimate_error:
            coarse = (4.0 * quotient[2] - quotient[4]) / 3.0
            truncation_raw = np.abs(raw - coarse) / 15.0
        noise_gain = np.sqrt(2.0 * 64.0 + 2.0) / 12.0
    asymmetry_matrix = np.abs(raw - raw.T) / 2.0
    hessian = (raw + raw.T) / 2.0
    if truncation_raw is not None:
        truncation = (truncation_raw + truncation_raw.T) / 2.0 + asymmetry_matrix
        method = "richardson"
    else:
        truncation = asymmetry_matrix
        method = "asymmetry"
    sigma = noise if noise is not None else 8.0 * np.finfo(float).eps * largest
    roundoff = float(noise_gain * sigma / h)
    return FiniteDifferenceHessian(
        hessian=hessian, error=truncation + roundoff, truncation=truncation, roundoff=roundoff,
        asymmetry=float(asymmetry_matrix.max()), residual_force=residual, positions=positions,
        masses=masses, numbers=atoms.get_atomic_numbers(), step=h, stencil=int(stencil),
        error_method=method, n_force_calls=calls,
    )


def from_calculator(
    atoms: Atoms,
    calculator: Any = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    force_tolerance: float | None = 1e-3,
    masses: ArrayLike | None = None,
    name: str | None = None,
) -> System:
    """A molecule whose Hessian is a finite difference of any ASE calculator's forces.

    See `finite_difference_hessian` (which also returns the error estimate); this runs it
    without the extra Richardson step and returns the `System` (ASE units).

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, co2_atoms, valence_model
    >>> atoms = co2_atoms()
    >>> from_calculator(atoms, ValenceForceField(valence_model(atoms))).n_dof
    9
    """
    result = finite_difference_hessian(atoms, calculator, step=step, stencil=stencil,
                                       estimate_error=False, force_tolerance=force_tolerance)
    return result.system(masses=masses, name=molecule_name(atoms, name))
