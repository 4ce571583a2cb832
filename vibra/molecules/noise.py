"""The noise of a calculator's forces: measured, or found absent, at the cost of a few force calls.

A self-consistent calculator (tblite's GFN2-xTB, any SCF code) stops iterating at a
convergence threshold, so its forces at one geometry depend on where the iterations started:
the differences between such evaluations are the noise a finite difference divides by its
step. `measure_force_noise` evaluates the forces at the reference geometry once from scratch
and then `repeats` more times, each right after a nearby geometry (a random displacement of
`jitter` Angstrom), so that every repeat starts from another guess; the noise is the largest
spread of one force component over the evaluations. A deterministic calculator (an analytic
force field) gives 0.

`probe_force_noise` is what `finite_difference_hessian(force_noise="auto")` (its default)
runs, so that a deterministic calculator pays (almost) nothing and a noisy one is measured:

- a calculator whose class is listed in `DETERMINISTIC_CALCULATORS` (vibra's
  `ValenceForceField`, ASE's EMT, Lennard-Jones, Morse, EAM, Tersoff, TIP3P/TIP4P,
  ForceField and HarmonicCalculator: closed-form forces) is not called at all: 0 force calls.
  The class must match exactly; a subclass may add noise, so it is probed;
- any other calculator is probed: one evaluation at a perturbed geometry, then one at the
  reference, compared with the reference forces the finite difference computed first
  (2 force calls). Forces that agree to the rounding level (`rounding_noise`) mean a
  deterministic calculator: nothing more is spent;
- forces that differ mean a noisy calculator: ``NOISE_REPEATS - 1`` more such pairs
  measure the spread (2 + 2 (NOISE_REPEATS - 1) = 6 force calls in all).

Why a probe and not the finite-difference data alone: the asymmetry D_ij - D_ji of the
difference quotients and the Richardson difference D(h) - D(2h) both contain the truncation
error, whose size is not known in advance and which, for an analytic force field, lies far
above rounding (CO2's valence field at h = 0.01 Angstrom: asymmetry 1.7e-4 and Richardson
estimate 9e-4 eV/Angstrom^2, against a round-off of 1.5e-13); neither tells noise from
truncation with one pair of steps. The probe asks the calculator directly.

What the probe cannot see: a calculator that restarts every call from the same guess (a
file-based code without restart files) returns the same forces for the same geometry
whatever came before, so its convergence error looks deterministic to the probe although it
jumps from one geometry to the next. Give such a calculator's noise as a number
(``force_noise=``: about its SCF force-convergence threshold, eV / Angstrom).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.cluster import ClientOnDemand, run_tasks
from vibra.molecules.displacements import CalculatorOption, CalculatorSource, force_problem, is_factory

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["measure_force_noise", "probe_force_noise", "force_noise_task", "probe_where_run", "run_noise", "ForceNoise",
           "NOISE_REPEATS", "DETERMINISTIC_CALCULATORS", "is_deterministic_calculator", "rounding_noise",
           "ROUNDING_ULPS"]

#: Evaluations after perturbed starts: the default of `measure_force_noise`, and what the probe
#: of `finite_difference_hessian(force_noise="auto")` spends on a noisy calculator.
NOISE_REPEATS = 3

#: The force noise of a deterministic calculator: this many machine epsilons of the largest force.
ROUNDING_ULPS = 8

#: Calculator classes (``module.qualname``) whose forces are closed-form and deterministic: the
#: probe does not call them. Matched exactly, never by subclass.
DETERMINISTIC_CALCULATORS = frozenset({
    "vibra.molecules.calculator.ValenceForceField",
    "ase.calculators.emt.EMT",
    "ase.calculators.lj.LennardJones",
    "ase.calculators.morse.MorsePotential",
    "ase.calculators.eam.EAM",
    "ase.calculators.tersoff.Tersoff",
    "ase.calculators.tip3p.TIP3P",
    "ase.calculators.tip4p.TIP4P",
    "ase.calculators.ff.ForceField",
    "ase.calculators.harmonic.HarmonicCalculator",
})


@dataclass(frozen=True)
class ForceNoise:
    """What `probe_force_noise` found.

    Attributes
    ----------
    value : float
        Largest spread of one force component over the evaluations at the reference geometry,
        eV / Angstrom (0 where nothing was measured).
    source : str
        ``"analytic"``: the class is in `DETERMINISTIC_CALCULATORS`, not called;
        ``"probed"``: one evaluation after a perturbed start agreed with the reference forces
        to the rounding level, so the calculator is taken as deterministic;
        ``"measured"``: they differed, and `value` is the spread over ``1 + NOISE_REPEATS``
        evaluations.
    n_force_calls : int
        Force calls spent (0, 2 or 2 NOISE_REPEATS with the defaults).
    """

    value: float
    source: str
    n_force_calls: int

    @property
    def noisy(self) -> bool:
        """Whether the calculator showed noise above rounding (``source == "measured"``)."""
        return self.source == "measured"

    def level(self, floor: float) -> float:
        """The noise of one force component a finite difference's round-off uses, eV / Angstrom: a
        given value as it is; else the measured spread, never below the rounding level `floor`,
        or `floor` alone for a deterministic calculator."""
        if self.source == "given":
            return self.value
        return max(self.value, floor) if self.noisy else floor


def rounding_noise(largest_force: float) -> float:
    """Noise of a deterministic calculator: ROUNDING_ULPS machine epsilons of `largest_force`, eV / Angstrom."""
    return float(ROUNDING_ULPS * np.finfo(float).eps * largest_force)


def is_deterministic_calculator(calculator: object) -> bool:
    """Whether `calculator` (an instance, a class or a ``functools.partial`` of a class) is listed
    in `DETERMINISTIC_CALCULATORS` (exact class, not a subclass)."""
    target = calculator
    while isinstance(target, functools.partial):
        target = target.func
    cls = target if isinstance(target, type) else (None if is_factory(target) else type(target))
    return cls is not None and f"{cls.__module__}.{cls.__qualname__}" in DETERMINISTIC_CALCULATORS


def _forces(work: Atoms, label: str) -> NDArray[np.float64]:
    values = np.asarray(work.get_forces(), dtype=float).copy()
    problem = force_problem(values, len(work), label)
    if problem is not None:
        raise RuntimeError(problem)
    return values


def _repeats(work: Atoms, reference: NDArray[np.float64], size: float, rng: np.random.Generator,
             count: int) -> list[NDArray[np.float64]]:
    """`count` evaluations at `reference`, each right after a random geometry `size` Angstrom away."""
    samples = []
    for _ in range(count):
        work.set_positions(reference + size * rng.standard_normal(reference.shape) / np.sqrt(3.0))
        _forces(work, "a perturbed start of the force-noise measurement")
        work.set_positions(reference)
        samples.append(_forces(work, "the reference geometry (force-noise measurement)"))
    return samples


def _checked(repeats: Any, jitter: Any) -> tuple[int, float]:
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats is {repeats!r}; expected an integer >= 1")
    size = _validate.real_scalar(jitter, "jitter")
    if not size > 0:
        raise ValueError(f"jitter is {size!r}; the perturbation must be positive (Angstrom)")
    return int(repeats), size


def _calculator(atoms: Atoms, calculator: Any) -> Any:
    calc = calculator if calculator is not None else atoms.calc
    if calc is None:
        raise TypeError("calculator is None and atoms has no calculator attached; pass calculator=")
    return calc


def measure_force_noise(atoms: Atoms, calculator: CalculatorOption | None = None, *, repeats: int = NOISE_REPEATS,
                        jitter: float = 0.01, seed: int = 0) -> float:
    """Noise of one force component of `calculator` at `atoms`, eV / Angstrom (1 + 2 repeats calls).

    Parameters
    ----------
    atoms : ase.Atoms
        The geometry (not modified).
    calculator : ase Calculator or factory, optional
        As in `finite_difference_hessian` (``atoms.calc`` by default). A factory's calculator
        is made once and kept through the repeats, so that each starts from the last guess.
    repeats : int
        Evaluations at `atoms` after a perturbed start (at least 1).
    jitter : float
        Size of the random displacement visited before each repeat, Angstrom.
    seed : int
        Seed of the random displacements.

    Returns
    -------
    float
        The largest spread (max - min) of one force component over the 1 + repeats
        evaluations: what two evaluations may differ by (0 when they agree to the last bit).

    Raises
    ------
    TypeError
        No calculator.
    ValueError
        repeats < 1 or jitter <= 0.
    RuntimeError
        The calculator returned forces that are not finite or of the wrong shape.

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, co2_atoms, valence_model
    >>> atoms = co2_atoms()
    >>> measure_force_noise(atoms, ValenceForceField(valence_model(atoms)))   # analytic: no noise
    0.0
    """
    calc = _calculator(atoms, calculator)
    count, size = _checked(repeats, jitter)
    work = atoms.copy()
    work.calc = CalculatorSource(calc).make()
    reference = work.get_positions().copy()
    samples = [_forces(work, "the reference geometry (force-noise measurement)")]
    samples += _repeats(work, reference, size, np.random.default_rng(seed), count)
    return float(np.ptp(np.stack(samples), axis=0).max())


def force_noise_task(atoms: Atoms, source: CalculatorSource, reference_forces: NDArray[np.float64],
                     floor: float, repeats: int = NOISE_REPEATS, jitter: float = 0.01,
                     seed: int = 0) -> ForceNoise:
    """The probe itself (see the module docstring), as one task: here, or on a Dask worker.

    `atoms` gives the reference geometry (its calculator is ignored), `source` the calculator
    (made once and kept through the probe), `reference_forces` the forces already computed
    there (eV / Angstrom), `floor` the rounding level below which a spread is not noise.
    """
    work = atoms.copy()
    work.calc = source.make()
    reference = work.get_positions().copy()
    rng = np.random.default_rng(seed)
    samples = [np.asarray(reference_forces, dtype=float)] + _repeats(work, reference, jitter, rng, 1)
    spread = float(np.ptp(np.stack(samples), axis=0).max())
    if not spread > floor:
        return ForceNoise(spread, "probed", 2)
    samples += _repeats(work, reference, jitter, rng, repeats - 1)
    return ForceNoise(float(np.ptp(np.stack(samples), axis=0).max()), "measured", 2 * repeats)


def probe_force_noise(atoms: Atoms, calculator: CalculatorOption | None = None, *,
                      reference_forces: ArrayLike | None = None,
                      floor: float | None = None, repeats: int = NOISE_REPEATS, jitter: float = 0.01,
                      seed: int = 0) -> ForceNoise:
    """Whether `calculator` is noisy at `atoms`, and how much: 0, 2 (+ 1) or 2 repeats (+ 1) force calls.

    A listed analytic class (`DETERMINISTIC_CALCULATORS`) is not called. Any other calculator
    is evaluated at a perturbed geometry and then at `atoms`; when the forces there differ
    from `reference_forces` by more than `floor`, ``repeats - 1`` more pairs measure the
    noise (see the module docstring).

    Parameters
    ----------
    atoms : ase.Atoms
        The reference geometry (not modified).
    calculator : ase Calculator or factory, optional
        ``atoms.calc`` by default; a factory's calculator is made once.
    reference_forces : (n_atoms, 3) array_like, optional
        Forces already computed at `atoms`, eV / Angstrom (e.g. by the finite difference);
        evaluated here (one more call) when not given.
    floor : float, optional
        Spread (eV / Angstrom) that rounding alone explains; default `rounding_noise` of the
        largest reference force.
    repeats : int
        Perturbed-start evaluations of a noisy calculator (at least 1).
    jitter : float
        Size of each perturbation, Angstrom.
    seed : int
        Seed of the perturbations.

    Returns
    -------
    ForceNoise

    Raises
    ------
    TypeError
        No calculator.
    ValueError
        repeats < 1, jitter <= 0, a negative floor, or reference forces of the wrong shape.
    RuntimeError
        The calculator failed or returned forces that are not finite or of the wrong shape.

    Examples
    --------
    >>> from vibra import molecules
    >>> water = molecules.h2o_atoms()
    >>> probe_force_noise(water, molecules.ValenceForceField(molecules.valence_model(water)))  # listed: not called
    ForceNoise(value=0.0, source='analytic', n_force_calls=0)
    """
    calc = _calculator(atoms, calculator)
    count, size = _checked(repeats, jitter)
    limit = None if floor is None else _validate.nonnegative_scalar(floor, "floor")
    if is_deterministic_calculator(calc):
        return ForceNoise(0.0, "analytic", 0)
    source = CalculatorSource(calc)
    extra = 0
    if reference_forces is None:
        work = atoms.copy()
        work.calc = source.make()
        reference = _forces(work, "the reference geometry (force-noise measurement)")
        extra = 1
    else:
        reference = _validate.real_array(reference_forces, "reference_forces", ndim=2)
        if reference.shape != (len(atoms), 3):
            raise ValueError(f"reference_forces has shape {reference.shape}; expected ({len(atoms)}, 3)")
    if limit is None:
        limit = rounding_noise(float(np.abs(reference).max()))
    found = force_noise_task(atoms, source, reference, limit, count, size, seed)
    return ForceNoise(found.value, found.source, found.n_force_calls + extra)


def run_noise(force_noise: float | str | None, template: Atoms, source: CalculatorSource, calc: CalculatorOption,
              reference: NDArray[np.float64], floor: float, cluster: ClientOnDemand) -> ForceNoise:
    """The `ForceNoise` of a finite-difference run from its checked ``force_noise``: None (rounding
    only), ``"auto"`` (`probe_where_run`) or a number (given)."""
    if force_noise is None:
        return ForceNoise(0.0, "rounding", 0)
    if isinstance(force_noise, str):
        return probe_where_run(template, source, calc, reference, floor, cluster)
    return ForceNoise(float(force_noise), "given", 0)


def probe_where_run(template: Atoms, source: CalculatorSource, calc: CalculatorOption, reference: NDArray[np.float64],
                    floor: float, cluster: ClientOnDemand) -> ForceNoise:
    """force_noise="auto" of a finite-difference run (molecules' and crystals'): the probe
    (`force_noise_task`) where the run's force calls ran, at its reference geometry `template`
    with the forces `reference` already computed there; a listed calculator is not called."""
    if is_deterministic_calculator(calc):
        return ForceNoise(0.0, "analytic", 0)
    advice = " (force_noise='auto' probes the calculator; pass force_noise=<number> or None to skip it)"
    if cluster.client is None:
        try:
            return force_noise_task(template, source, reference, floor)
        except Exception as error:
            raise RuntimeError(f"calculator failed while measuring its force noise: {type(error).__name__}: "
                               f"{error}{advice}") from error
    results, failures = run_tasks(cluster.get(), force_noise_task, [(template, source, reference, floor)],
                                  labels=["the force-noise probe"], name="vibra-noise")
    if failures:
        raise RuntimeError(f"calculator failed while measuring its force noise: {failures[0].describe()}{advice}")
    return cast(ForceNoise, results[0])  # no failure: the one task returned
