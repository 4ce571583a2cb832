"""The noise of a calculator's forces, measured: repeated evaluations from perturbed starting guesses.

A self-consistent calculator (tblite's GFN2-xTB, any SCF code) stops iterating at a
convergence threshold, so its forces at one geometry depend on where the iterations started:
the differences between such evaluations are the noise a finite difference divides by its
step. `measure_force_noise` evaluates the forces at the reference geometry once from scratch
and then `repeats` more times, each right after a nearby geometry (a random displacement of
`jitter` Angstrom), so that every repeat starts from another guess; the noise is the largest
spread of one force component over the evaluations. A deterministic
calculator (an analytic force field) gives 0.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from vibra import _validate
from vibra.molecules.displacements import CalculatorSource

if TYPE_CHECKING:
    from ase import Atoms

__all__ = ["measure_force_noise", "NOISE_REPEATS"]

#: Evaluations after perturbed starts used by `finite_difference_hessian(force_noise="auto")`.
NOISE_REPEATS = 3


def measure_force_noise(atoms: Atoms, calculator: Any = None, *, repeats: int = NOISE_REPEATS,
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

    Examples
    --------
    >>> from vibra.molecules import ValenceForceField, co2_atoms, valence_model
    >>> atoms = co2_atoms()
    >>> measure_force_noise(atoms, ValenceForceField(valence_model(atoms)))   # analytic: no noise
    0.0
    """
    calc = calculator if calculator is not None else atoms.calc
    if calc is None:
        raise TypeError("calculator is None and atoms has no calculator attached; pass calculator=")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats is {repeats!r}; expected an integer >= 1")
    size = _validate.real_scalar(jitter, "jitter")
    if not size > 0:
        raise ValueError(f"jitter is {size!r}; the perturbation must be positive (Angstrom)")
    work = atoms.copy()
    work.calc = CalculatorSource(calc).make()
    reference = work.get_positions().copy()
    rng = np.random.default_rng(seed)
    samples = [np.asarray(work.get_forces(), dtype=float).copy()]
    for _ in range(int(repeats)):
        work.set_positions(reference + size * rng.standard_normal(reference.shape) / np.sqrt(3.0))
        work.get_forces()
        work.set_positions(reference)
        samples.append(np.asarray(work.get_forces(), dtype=float).copy())
    stacked = np.stack(samples)
    return float(np.ptp(stacked, axis=0).max())
