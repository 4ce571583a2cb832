"""Finite-difference noise (issue 15, item 7): the calculator's force noise measured and carried.

Truth: the valence force field's analytic Hessian (`from_atoms`), a synthetic calculator whose
noise is known by construction, and ASE `Vibrations` with tblite's GFN2-xTB.
"""

from __future__ import annotations

import numpy as np
import pytest

from vibra import crosscheck as cc
from vibra import molecules as mol
from vibra.molecules.finite_difference import finite_difference_hessian
from vibra.molecules.noise import measure_force_noise


class _Noisy:
    """The valence force field plus uniform noise of half-width `sigma` on every force component."""

    def __init__(self, model, sigma: float, seed: int = 1) -> None:
        self.inner = mol.ValenceForceField(model)
        self.sigma = sigma
        self.rng = np.random.default_rng(seed)

    def get_forces(self, atoms):
        exact = np.asarray(self.inner.get_forces(atoms), dtype=float)
        return exact + self.sigma * self.rng.uniform(-1.0, 1.0, exact.shape)


def test_deterministic_calculator_has_no_noise() -> None:
    atoms = mol.h2o_atoms()
    assert measure_force_noise(atoms, mol.ValenceForceField(mol.valence_model(atoms)), repeats=2) == 0.0


@pytest.mark.parametrize("sigma", [1e-6, 1e-4])
def test_measured_noise_is_of_the_size_put_in(sigma: float) -> None:
    atoms = mol.co2_atoms()
    measured = measure_force_noise(atoms, _Noisy(mol.valence_model(atoms), sigma), repeats=5)
    assert 0.5 * sigma <= measured <= 2.0 * sigma  # spread of uniform noise of half-width sigma


@pytest.mark.parametrize("sigma", [1e-5, 1e-3])
def test_auto_noise_error_estimate_covers_the_analytic_hessian(sigma: float) -> None:
    atoms = mol.co2_atoms()
    model = mol.valence_model(atoms)
    exact = mol.from_atoms(atoms, model).hessian().toarray()  # analytic; eV / Angstrom^2
    noisy = _Noisy(model, sigma)
    plain = finite_difference_hessian(atoms, noisy, estimate_error=True)
    auto = finite_difference_hessian(atoms, _Noisy(model, sigma), estimate_error=True, force_noise="auto")
    assert auto.roundoff > 100 * plain.roundoff  # the noise is in the estimate, by default of "auto"
    assert np.all(np.abs(auto.hessian - exact) <= auto.error)
    assert not np.all(np.abs(plain.hessian - exact) <= plain.error)  # without it the estimate is too small


def test_force_noise_string_other_than_auto_is_refused() -> None:
    atoms = mol.h2o_atoms()
    with pytest.raises(ValueError, match="force_noise is 'measure'; expected a number"):
        finite_difference_hessian(atoms, mol.ValenceForceField(mol.valence_model(atoms)), force_noise="measure")


def test_measure_force_noise_validates() -> None:
    atoms = mol.h2o_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    with pytest.raises(ValueError, match="repeats is 0"):
        measure_force_noise(atoms, calc, repeats=0)
    with pytest.raises(ValueError, match="jitter is"):
        measure_force_noise(atoms, calc, jitter=0.0)
    with pytest.raises(TypeError, match="calculator is None"):
        measure_force_noise(mol.h2o_atoms())


@pytest.mark.slow  # ~10 s: GFN2-xTB at two SCF accuracies
@pytest.mark.parametrize("accuracy", [1.0, 0.01])
def test_tblite_noise_estimate_covers_ase_versus_vibra(accuracy: float) -> None:
    tblite = pytest.importorskip("tblite.ase")
    from ase.optimize import BFGS

    atoms = mol.co2_atoms()
    atoms.calc = tblite.TBLite(method="GFN2-xTB", verbosity=0, accuracy=accuracy)
    BFGS(atoms, logfile=None).run(fmax=1e-5)
    noise = measure_force_noise(atoms, atoms.calc)
    assert noise > 0.0  # an SCF calculator is noisy
    result = cc.crosscheck(atoms, atoms.calc, delta=0.01, force_noise=noise)
    vib = ~result.rigid
    assert np.all(np.abs(result.ase_cm1[vib] - result.vibra_cm1[vib]) <= result.fd_error_cm1[vib])
