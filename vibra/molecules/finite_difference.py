"""Hessians of any ASE calculator by central differences of its forces, with an error estimate
(Richardson extrapolation for the truncation, force noise / step for the round-off)."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra._core.frozen import Frozen
from vibra.cluster import ClientOnDemand, ClientOption, ProgressOption, check_client
from vibra.modes import Modes
from vibra.molecules.displacement_symmetry import Reduction, reduction
from vibra.molecules.displacements import (CalculatorOption, Displacement, ForceCache, GatheredForces, calculator_of,
                                           calculator_source, displaced_positions, displacement_plan, gather_forces)
from vibra.molecules.noise import ForceNoise, rounding_noise, run_noise
from vibra.molecules.property_derivatives import (PropertyDerivatives, central_difference, check_properties,
                                                  property_derivatives)
from vibra.molecules.checks import check_atoms, masses_or_default, molecule_name, nonnegative_scalar
from vibra.system import System

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["FiniteDifferenceHessian", "finite_difference_hessian", "from_calculator"]


@dataclass(frozen=True, eq=False)
class FiniteDifferenceHessian(Frozen):
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
    force_noise : float
        Noise of one force component behind `roundoff`, eV / Angstrom: the measured or given
        value, or the rounding level (8 machine epsilons of the largest force).
    noise_source : str
        Where `force_noise` came from: ``"measured"`` (the calculator was probed and found
        noisy), ``"probed"`` (probed, no noise above rounding), ``"analytic"`` (a listed
        closed-form calculator, not probed), ``"given"`` (a number passed as `force_noise`)
        or ``"rounding"`` (``force_noise=None``: not checked). See `vibra.molecules.noise`.
    n_noise_calls : int
        Force calls spent on the noise probe (0 analytic, 2 probed, 6 measured; not in
        `n_force_calls`).
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
        Calculator force evaluations spent in this run, including the reference geometry.
    n_cached : int
        Geometries whose forces were read from the cache instead (0 without a cache).
    n_full_plan : int
        Geometries the full Cartesian plan would take (``n_force_calls + n_cached`` when the
        plan was not symmetry-reduced).
    symmetry : str
        How the plan used the point group, in words (`vibra.molecules.displacement_symmetry`):
        the group and the atoms and directions displaced, or why every Cartesian displacement ran.
    derivatives : PropertyDerivatives or None
        The dipole and polarisability derivatives from the same geometries, with their error
        estimates, when `finite_difference_hessian` was asked for ``properties``.
    """

    hessian: NDArray[np.float64]
    error: NDArray[np.float64]
    truncation: NDArray[np.float64]
    roundoff: float
    force_noise: float
    noise_source: str
    n_noise_calls: int
    asymmetry: float
    residual_force: float
    positions: NDArray[np.float64]
    masses: NDArray[np.float64]
    numbers: NDArray[np.int_]
    step: float
    stencil: int
    error_method: str
    n_force_calls: int
    n_cached: int = 0
    derivatives: PropertyDerivatives | None = None
    n_full_plan: int = 0
    symmetry: str = ""

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

    @property
    def noise_measured(self) -> bool:
        """Whether the calculator's force noise was measured here (it showed noise above rounding)."""
        return self.noise_source == "measured"

    def noise_share(self, modes: Modes) -> NDArray[np.float64]:
        """(n_modes,) share of each mode's error bound that comes from the force noise, 0 to 1.

        The part of delta omega_k^2 in `omega_errors` due to `roundoff` over the whole of it
        (both are linear in the Hessian error); 0 for a mode without any estimated error.
        """
        total = _weighted(self.error, self.masses, modes)
        noise = _weighted(np.full(self.error.shape, self.roundoff), self.masses, modes)
        return np.divide(noise, total, out=np.zeros_like(total), where=total > 0)


def _omega_bound(error: NDArray[np.float64], masses: NDArray[np.float64], modes: Modes) -> NDArray[np.float64]:
    lam = _weighted(error, masses, modes)
    return np.minimum(lam / np.maximum(2.0 * np.abs(modes.omega), 1e-300), np.sqrt(lam))


def _weighted(error: NDArray[np.float64], masses: NDArray[np.float64], modes: Modes) -> NDArray[np.float64]:
    """(n_modes,) d_k^T W d_k: the bound on |delta omega_k^2| from a Hessian error `error`."""
    if modes.vectors is None:
        raise ValueError("modes has no vectors; compute the modes with vectors=True")
    scale = 1.0 / np.sqrt(np.repeat(masses, 3))
    weighted = np.abs(error) * scale[:, None] * scale[None, :]
    d = np.abs(modes.vectors)
    if d.shape[0] != weighted.shape[0]:
        raise ValueError(f"modes has {d.shape[0]} dofs; the Hessian has {weighted.shape[0]}")
    return np.asarray(np.sum(d * (weighted @ d), axis=0))  # d_k^T W d_k for every k, one matrix product


def finite_difference_hessian(
    atoms: Atoms,
    calculator: CalculatorOption | None = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    estimate_error: bool = True,
    force_noise: float | Literal["auto"] | None = "auto",
    force_tolerance: float | None = None,
    client: ClientOption = None,
    cache: str | os.PathLike[str] | None = None,
    calculator_key: str | None = None,
    progress: ProgressOption = None,
    n_workers: int | None = None,
    timeout: float = 10.0,
    properties: Sequence[str] = (),
    property_noise: Mapping[str, float] | None = None,
    symmetry: bool = True,
) -> FiniteDifferenceHessian:
    """Hessian of any ASE calculator by central differences of its forces.

    H_ij = -dF_j/dx_i; 2-point: D(h) = (F(-h) - F(+h)) / 2h, error O(h^2); 4-point:
    (4 D(h) - D(2h)) / 3, error O(h^4); the result is symmetrised, (D + D^T) / 2. With
    `estimate_error` one more step size is evaluated (2h for the 2-point stencil, 4h for the
    4-point one) and the truncation error is estimated by Richardson extrapolation:
    |D(h) - D(2h)| / 3, or |R(h) - R(2h)| / 15 for the 4-point result R. The round-off error is
    ~ force_noise / h.

    Each geometry is one force call: serially in this process (``client=None``), or one task
    each on a Dask cluster (`vibra.cluster`). The forces are gathered first and the Hessian is
    then assembled in one fixed order, so a run on any number of workers gives the serial
    result bit for bit, provided no force call depends on the ones before it: a factory starts
    every call from scratch; an instance is used as it is serially and copied fresh for every
    call on a worker (see `vibra.molecules.displacements`). With `cache`, each geometry's
    forces are written to their own file as they arrive; a killed run started again computes
    only what is missing. The force-noise probe (`force_noise`) runs after them, where they
    ran (one task on the cluster), and is never cached.

    Parameters
    ----------
    atoms : ase.Atoms
        Reference geometry, Angstrom; masses (amu) are read from it. Not modified.
    calculator : ase Calculator or callable, optional
        Evaluates the forces; ``atoms.calc`` by default. Or a factory: a class or a callable
        with no arguments that returns a new calculator (for calculators that cannot be
        pickled or that carry state from one call to the next, e.g.
        ``functools.partial(TBLite, method="GFN2-xTB")``). On a cluster the
        calculator (or the factory) is pickled and sent to the workers, which must have vibra
        and the calculator's package installed.
    step : float
        Displacement h, Angstrom.
    stencil : {2, 4}
        Points per degree of freedom.
    estimate_error : bool
        Spend 6 n_atoms extra force calls on the Richardson truncation estimate.
    force_noise : "auto", float or None
        Noise of one force component, eV / Angstrom, for the round-off part of the error.
        ``"auto"`` (default): found out after the displaced forces, where they ran (here or
        as one task on the cluster; `vibra.molecules.noise.probe_force_noise`): a listed
        closed-form calculator (vibra's valence force field, ASE's EMT, Lennard-Jones, Morse,
        ...) is not called again; any other is evaluated at a perturbed geometry and then at
        the reference (2 force calls), and if that differs from the first reference forces
        by more than rounding, its noise is measured (4 calls more: 6 in all; tblite's
        GFN2-xTB at its default accuracy, ~2e-4 eV/Angstrom on CO2). A number: that noise
        (``0.0`` leaves the round-off out). None: not checked, 8 machine epsilons of the
        largest force (right for a deterministic calculator only). The result says which
        (`noise_source`, `force_noise`, `n_noise_calls`, `noise_share`).
    force_tolerance : float, optional
        Raise if the largest force at the reference geometry exceeds this (eV / Angstrom): the
        Hessian of a non-equilibrium geometry gives meaningless frequencies. None: no check.
    client : None, "local", str or distributed.Client
        Where the force calls run (`vibra.cluster.connect`): None in this process; ``"local"``
        a local cluster of worker processes started and closed here; a scheduler address
        (``"tcp://host:8786"``) or an open ``distributed.Client``. Needs ``vibra[distributed]``.
    cache : path-like, optional
        Folder of per-geometry force files (``<key>.npy``, keyed by geometry, step, stencil
        and calculator settings; see `vibra.molecules.displacements`). Files found there are
        verified and reused instead of calling the calculator; the client writes each new
        result as it arrives, so the folder need not be shared with the workers.
    calculator_key : str, optional
        The calculator's settings, spelled out for the cache key (default: the pickled bytes
        of the calculator or factory). Needed for a calculator that cannot be pickled.
    progress : None, bool, "dask" or callable
        A line per finished geometry on stderr (True), ``dask.distributed.progress`` (a widget
        in a notebook), or ``callable(done, total, label)``.
    n_workers : int, optional
        Worker processes of ``client="local"`` (default: the usable cores).
    timeout : float
        Seconds to wait for a scheduler address to answer.
    properties : sequence of {"dipole", "polarizability"}
        Also differentiate these, read from the same calculation at every geometry (the dipole
        ``atoms.get_dipole_moment()`` in e Angstrom, the polarisability
        ``calc.get_property("polarizability")`` in Angstrom^3), with the same stencil, cache
        and error estimate: `FiniteDifferenceHessian.derivatives`
        (`vibra.molecules.property_derivatives`).
    property_noise : mapping, optional
        Noise of one component of a property (e Angstrom, Angstrom^3) for its round-off part;
        a property left out gets the rounding level (the force probe does not measure it).
    symmetry : bool
        Displace only the symmetry-unique atoms and directions of the point group and rebuild
        the other rows (forces, dipole, polarisability) with its operations
        (`vibra.molecules.displacement_symmetry`), where the geometry has a group beyond C1 to
        within what `step` tolerates (h^2 / 6 Angstrom); else, or with False, every Cartesian
        displacement. The result says which (`symmetry`, `n_full_plan`).

    Returns
    -------
    FiniteDifferenceHessian

    Raises
    ------
    TypeError
        `atoms` is not an ase.Atoms, or no calculator; a calculator that cannot be pickled
        with a `client` (pass a factory) or a `cache` (pass `calculator_key`).
    ValueError
        Bad step, stencil or noise; unknown elements or overlapping atoms; a residual force
        above `force_tolerance` (reported); a malformed `client`.
    RuntimeError
        The calculator raised, or returned forces that are not finite or of the wrong shape:
        every such geometry is named (atom, sign, step multiple, axis); or it failed during
        the force-noise probe (said so). The forces that were computed stay in `cache`;
        nothing else is written anywhere.
    ImportError
        `client` given but Dask is not installed (the message names ``vibra[distributed]``).
    vibra.cluster.ClusterError
        No scheduler answered at the address within `timeout`.

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, h2o_atoms, valence_model
    >>> atoms = h2o_atoms()
    >>> result = finite_difference_hessian(atoms, ValenceForceField(valence_model(atoms)))
    >>> result.hessian.shape, result.n_force_calls, result.n_full_plan, result.error_method
    ((9, 9), 25, 37, 'richardson')
    >>> result.noise_source, result.n_noise_calls       # a closed-form force field: not probed
    ('analytic', 0)
    """
    positions, masses = check_atoms(atoms)
    calc = calculator_of(atoms, calculator)
    h = _validate.real_scalar(step, "step")
    if not h > 0:
        raise ValueError(f"step is {h!r}; the displacement must be positive (Angstrom)")
    if isinstance(stencil, bool) or stencil not in (2, 4):
        raise ValueError(f"stencil is {stencil!r}; expected 2 or 4 (points per degree of freedom)")
    if isinstance(force_noise, str):
        if force_noise != "auto":
            raise ValueError(f"force_noise is {force_noise!r}; expected a number (eV/Angstrom), 'auto' or None")
        given: float | str | None = "auto"
    else:
        given = None if force_noise is None else nonnegative_scalar(force_noise, "force_noise", "eV/Angstrom")
    tolerance = None if force_tolerance is None else nonnegative_scalar(force_tolerance, "force_tolerance",
                                                                   "eV/Angstrom")
    names, given_noise = check_properties(properties, property_noise)
    check_client(client)
    if not isinstance(symmetry, (bool, np.bool_)):
        raise TypeError(f"symmetry must be True or False, got {type(symmetry).__name__}")
    source = calculator_source(calc, calculator_key, client)
    template = atoms.copy()
    template.calc = None
    store = None if cache is None else ForceCache(cache, template, h, source.digest(), names)
    n = len(template)
    # step multiples evaluated: the stencil's own, plus one coarser for the Richardson estimate
    multiples = [1] if stencil == 2 else [1, 2]
    if estimate_error:
        multiples.append(2 if stencil == 2 else 4)
    reduced = reduction(template, h, bool(symmetry))
    plan = displacement_plan(n, multiples, reduced.dofs)
    with contextlib.ExitStack() as stack:
        cluster = ClientOnDemand(client, stack, n_workers, timeout)
        forces = gather_forces(plan, template, source, lambda d: displaced_positions(positions, d, h), store,
                               cluster, progress, properties=names,
                               check_reference=lambda reference: _check_reference(reference, tolerance))
        floor = rounding_noise(max(float(np.abs(values[:n]).max()) for values in forces.forces))
        noise = run_noise(given, template, source, calc, forces.forces[0][:n], floor, cluster)
    derivatives = None if not names else property_derivatives(
        [values[n:] for values in forces.forces], plan, multiples, h, int(stencil), names, given_noise, estimate_error,
        reduced)
    return _assemble(forces, plan, multiples, h, int(stencil), noise, floor, positions, masses,
                     template.get_atomic_numbers(), estimate_error, derivatives, reduced)


def _check_reference(reference: NDArray[np.float64], tolerance: float | None) -> None:
    if tolerance is None:
        return
    norms = np.linalg.norm(reference, axis=1)
    residual = float(norms.max())
    if residual > tolerance:
        raise ValueError(
            f"atoms is not an equilibrium of the calculator: residual force {residual:.3g} eV/Angstrom "
            f"on atom {int(np.argmax(norms))} (force_tolerance={tolerance:g}); relax the geometry first"
        )


def _assemble(gathered: GatheredForces, plan: tuple[Displacement, ...], multiples: list[int], h: float, stencil: int,
              noise: ForceNoise, floor: float, positions: NDArray[np.float64], masses: NDArray[np.float64],
              numbers: NDArray[np.int_], estimate_error: bool,
              derivatives: PropertyDerivatives | None = None,
              reduced: Reduction | None = None) -> FiniteDifferenceHessian:
    """The Hessian and its error estimate from the forces of every geometry, in the plan's order."""
    n_dof = positions.size
    forces = tuple(values[:positions.shape[0]] for values in gathered.forces)
    residual = float(np.linalg.norm(forces[0], axis=1).max())
    quotient = {m: np.empty((n_dof, n_dof)) for m in multiples}
    for d_plus, d_minus in zip(plan[1::2], plan[2::2]):
        m = d_plus.multiple
        plus, minus = forces[d_plus.index].ravel(), forces[d_minus.index].ravel()
        quotient[m][d_plus.dof] = (minus - plus) / (2.0 * m * h)
    if reduced is not None:  # the rows not displaced, rebuilt by the point group's operations
        quotient = {m: reduced.complete(q, "forces") for m, q in quotient.items()}
    raw, truncation_raw, noise_gain = central_difference(quotient, stencil, estimate_error)
    asymmetry_matrix = np.abs(raw - raw.T) / 2.0
    hessian = (raw + raw.T) / 2.0
    if truncation_raw is not None:
        truncation = (truncation_raw + truncation_raw.T) / 2.0 + asymmetry_matrix
        method = "richardson"
    else:
        truncation = asymmetry_matrix
        method = "asymmetry"
    sigma = noise.level(floor)  # measured noise never below rounding; a deterministic calculator: rounding alone
    roundoff = float(noise_gain * sigma / h)
    if reduced is not None:  # the operations' miss, on the rebuilt rows (vibra.molecules.displacement_symmetry)
        truncation = truncation + reduced.geometry_error(forces, plan, h)
    return FiniteDifferenceHessian(
        hessian=hessian, error=truncation + roundoff, truncation=truncation, roundoff=roundoff,
        force_noise=float(sigma), noise_source=noise.source, n_noise_calls=noise.n_force_calls,
        asymmetry=float(asymmetry_matrix.max()), residual_force=residual, positions=positions,
        masses=masses, numbers=numbers, step=h, stencil=stencil,
        error_method=method, n_force_calls=gathered.computed, n_cached=gathered.cached, derivatives=derivatives,
        n_full_plan=1 + 2 * len(multiples) * n_dof,
        symmetry=reduced.note if reduced is not None else "every Cartesian displacement",
    )


def from_calculator(
    atoms: Atoms,
    calculator: CalculatorOption | None = None,
    *,
    step: float = 0.01,
    stencil: Literal[2, 4] = 2,
    force_tolerance: float | None = 1e-3,
    masses: ArrayLike | None = None,
    name: str | None = None,
    client: ClientOption = None,
    cache: str | os.PathLike[str] | None = None,
    calculator_key: str | None = None,
    progress: ProgressOption = None,
    symmetry: bool = True,
) -> System:
    """A molecule whose Hessian is a finite difference of any ASE calculator's forces.

    See `finite_difference_hessian` (which also returns the error estimate); this runs it
    without the extra Richardson step and without the force-noise probe (no error estimate is
    returned) and returns the `System` (ASE units); `client`, `cache`, `calculator_key`,
    `progress` and `symmetry` are passed on to it.

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, co2_atoms, valence_model
    >>> atoms = co2_atoms()
    >>> from_calculator(atoms, ValenceForceField(valence_model(atoms))).n_dof
    9
    """
    result = finite_difference_hessian(atoms, calculator, step=step, stencil=stencil, estimate_error=False,
                                       force_noise=None, force_tolerance=force_tolerance, client=client, cache=cache,
                                       calculator_key=calculator_key, progress=progress, symmetry=symmetry)
    return result.system(masses=masses, name=molecule_name(atoms, name))
