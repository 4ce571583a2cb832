"""Tests of vibra.crosscheck: vibra against ASE Vibrations and phonopy on CO2 and H2O.

ASE and phonopy are required dependencies (never skipped); tblite is the optional extra
``xtb`` and its tests skip only when it cannot be imported."""

from __future__ import annotations

import dataclasses
import tempfile

import numpy as np
import pytest
from ase import Atoms
from ase import units as ase_units
from phonopy.physical_units import get_physical_units
from scipy import constants

from vibra import crosscheck as cc
from vibra import molecules as mol

from molecule_closed_forms import co2_closed_form_cm1, h2o_closed_form_cm1

# Each package converts omega to its unit with its own constants; the crosscheck turns their
# results into cm^-1 with scipy's. The relative offsets, computed here from the packages'
# constants (not measured on results): ASE's VibrationsData gives hbar omega with
# s = _hbar * m / sqrt(_e * _amu) (ase.units, CODATA 2014); phonopy's THz are
# sqrt(omega^2) * DefaultToTHz (its CODATA).
_S_SCIPY = constants.hbar / constants.angstrom / np.sqrt(constants.e * constants.atomic_mass)
ASE_UNIT_BIAS = ase_units._hbar * ase_units.m / np.sqrt(ase_units._e * ase_units._amu) / _S_SCIPY - 1
PHONOPY_UNIT_BIAS = get_physical_units().DefaultToTHz / (
    np.sqrt(constants.e / constants.atomic_mass) / constants.angstrom / (2 * np.pi) / constants.tera) - 1
# Round-off of a difference quotient: positions carry eps * |x| with |x| up to box / 2 = 10 A
# in phonopy's cell, so each Hessian entry (and a wavenumber, half as much) is good to about
# eps * (box / 2) / delta relative; 16 times that covers the eigensolvers' few-eps round-off.
DELTA = 0.01
ROUNDOFF_RTOL = 16 * np.finfo(float).eps * 10.0 / DELTA


def _model(atoms: Atoms, name: str) -> mol.ValenceModel:
    if name == "CO2":
        return mol.valence_model(atoms, bonds=np.array([[0, 1], [1, 2]]), stretch=mol.CO2_STRETCH, bend=mol.CO2_BEND)
    return mol.valence_model(atoms, bonds=np.array([[0, 1], [0, 2]]), stretch=mol.H2O_STRETCH, bend=mol.H2O_BEND)


MOLECULES = {"CO2": mol.co2_atoms, "H2O": mol.h2o_atoms}


def _closed_form_cm1(name: str) -> np.ndarray:
    """Exact harmonic wavenumbers of the builders' force fields, ascending, cm^-1."""
    if name == "CO2":
        return co2_closed_form_cm1(mol.CO2_STRETCH, mol.CO2_BEND, mol.CO2_BOND_LENGTH)
    return h2o_closed_form_cm1(mol.H2O_STRETCH, mol.H2O_BEND, mol.H2O_BOND_LENGTH, mol.H2O_ANGLE_DEG)


@pytest.mark.parametrize("nfree", [2, 4])
@pytest.mark.parametrize("name", ["CO2", "H2O"])
def test_agrees_with_ase_and_phonopy_within_their_own_fd_error(name: str, nfree: int) -> None:
    atoms = MOLECULES[name]()
    result = cc.crosscheck(atoms, model=_model(atoms, name), delta=DELTA, nfree=nfree)
    coarse = cc.crosscheck(atoms, model=_model(atoms, name), delta=2 * DELTA, nfree=nfree)
    vib = ~result.rigid
    assert result.n_rigid == (5 if name == "CO2" else 6) and vib.sum() == (4 if name == "CO2" else 3)
    exact = _closed_form_cm1(name)
    # vibra's side is the analytic force field: the closed forms (eigen round-off ~1e-15)
    np.testing.assert_allclose(result.vibra_cm1[vib], exact, rtol=1e-12)
    floor = ROUNDOFF_RTOL * exact
    for fine, crude, bias, order, reported in [
        (result.ase_cm1, coarse.ase_cm1, ASE_UNIT_BIAS, 2 if nfree == 2 else 4, result.fd_error_cm1),
        (result.phonopy_cm1, coarse.phonopy_cm1, PHONOPY_UNIT_BIAS, 2, result.phonopy_fd_error_cm1),
    ]:
        # each package's truncation error, from its own results at delta and 2 delta
        # (Richardson: e(h) = (x(h) - x(2h)) / (2^p - 1) to leading order, the next order
        # smaller by (h / 1 Angstrom)^2 ~ 1e-4); the unit offsets are divided out first
        fine_cm1, crude_cm1 = fine[vib] / (1 + bias), crude[vib] / (1 + bias)
        estimate = np.abs(fine_cm1 - crude_cm1) / (2**order - 1)
        actual = np.abs(fine_cm1 - exact)
        assert np.all(actual <= 1.1 * estimate + floor)
        # vibra's reported fd error (a first-order bound) covers that independently found error
        assert np.all(actual <= reported[vib] + floor)
    assert result.within_error()
    # the estimate is informative, not a blanket: below 0.5 cm^-1 (~1e-4 relative) at 0.01 A
    assert np.all(result.fd_error_cm1[vib] < 0.5)
    # rigid-body rows are matched by overlap: the matched ASE and phonopy modes lie in the
    # rigid-body subspace up to the fd contamination (error / gap ~ 1e-3 here)
    assert np.all(result.ase_rigid_overlap[result.rigid] > 0.99)
    assert np.all(result.phonopy_rigid_overlap[result.rigid] > 0.99)
    assert np.all(result.ase_rigid_overlap[vib] < 0.01)


def test_four_point_stencil_is_closer_to_analytic() -> None:
    atoms = mol.h2o_atoms()
    two = cc.crosscheck(atoms, model=_model(atoms, "H2O"), nfree=2)
    four = cc.crosscheck(atoms, model=_model(atoms, "H2O"), nfree=4)
    vib = ~two.rigid
    # O(h^2) against O(h^4) truncation at h = 0.01 A: at least 100 times smaller
    assert np.abs(four.ase_difference_cm1[vib]).max() * 100 < np.abs(two.ase_difference_cm1[vib]).max()
    # phonopy stays 2-point whatever ASE's stencil
    np.testing.assert_allclose(four.phonopy_cm1, two.phonopy_cm1, rtol=1e-12, atol=1e-9)


def test_table_and_rows() -> None:
    atoms = mol.co2_atoms()
    result = cc.crosscheck(atoms, model=_model(atoms, "CO2"), experimental_cm1=cc.CO2_FUNDAMENTALS_CM1)
    rows = result.rows()
    assert len(rows) == 9 and sum(row.kind == "rigid" for row in rows) == 5
    assert [row.experimental_cm1 for row in rows if row.kind == "vibration"] == list(cc.CO2_FUNDAMENTALS_CM1)
    text = result.table()
    assert "vibra" in text and "ASE" in text and "phonopy" in text and "cm^-1" in text
    assert "Fermi resonance" in text
    assert len(text.splitlines()) == 2 + 9 + 1 + len(result.notes)
    # the valence force field is a listed closed-form calculator: rounding alone, never probed
    assert result.noise_source == "analytic" and f"force noise {result.force_noise:.2g} eV/A (analytic)" in text


def test_default_model_is_guessed() -> None:
    result = cc.crosscheck(mol.h2o_atoms())
    assert result.within_error() and result.n_rigid == 6


class _CountingNaN(mol.ValenceForceField):
    """Valence forces for the first `good` calls, NaN afterwards."""

    def __init__(self, model: mol.ValenceModel, good: int) -> None:
        super().__init__(model)
        self.good = good
        self.calls = 0

    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        self.calls += 1
        if self.calls > self.good:
            self.results["forces"] = np.full((len(self.atoms), 3), np.nan)


# _CountingNaN is a subclass, not a listed closed-form class: force_noise="auto" probes it with 2
# calls (a perturbed geometry, then the reference) after vibra's 37 and finds no noise
@pytest.mark.parametrize(("good", "pattern"), [
    (3, r"non-finite forces at atom 0 displaced"),   # caught by vibra's own finite differences
    (37, r"failed while measuring its force noise: .*non-finite forces at a perturbed start"),  # the probe
    (37 + 2, r"ASE Vibrations got non-finite forces"),   # vibra's 37 + 2 calls pass, ASE's cache gets NaN
    (37 + 2 + 19, r"phonopy: the calculator returned non-finite forces"),  # then ASE's 1 + 18 pass
])
def test_nan_calculator_raises_and_leaves_no_cache(good: int, pattern: str, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    atoms = mol.co2_atoms()
    calc = _CountingNaN(_model(atoms, "CO2"), good)
    with pytest.raises(RuntimeError, match=pattern):
        cc.crosscheck(atoms, calc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tmp"]
    assert list(scratch.iterdir()) == []


def test_arguments_checked_before_any_force_call() -> None:
    # a calculator that fails on its first call: a bad argument must be reported instead
    atoms = mol.co2_atoms()
    calc = _CountingNaN(_model(atoms, "CO2"), good=0)
    with pytest.raises(ValueError, match=r"experimental_cm1 must have 4 values \(one per vibration\), got 3"):
        cc.crosscheck(atoms, calc, experimental_cm1=cc.H2O_FUNDAMENTALS_CM1)
    with pytest.raises(ValueError, match=r"force_tolerance is -0\.1; it must be >= 0 \(eV/Angstrom\)"):
        cc.crosscheck(atoms, calc, force_tolerance=-0.1)
    assert calc.calls == 0


def test_calculator_geometry_must_be_an_equilibrium() -> None:
    # with a calculator, a stretched CO2 (C=O 1.20 A against the model's 1.16 A) is refused with
    # its residual force kappa * 0.04 A = 3.85 eV/A on an O atom; force_tolerance=None runs it
    model = _model(mol.co2_atoms(), "CO2")
    stretched = mol.co2_atoms(bond_length=1.20)
    with pytest.raises(ValueError, match=r"not an equilibrium of the calculator: residual force 3\.85 eV/Angstrom"):
        cc.crosscheck(stretched, mol.ValenceForceField(model))
    result = cc.crosscheck(stretched, mol.ValenceForceField(model), force_tolerance=None)
    assert result.residual_force == pytest.approx(mol.CO2_STRETCH * 0.04, rel=1e-12)
    assert "residual force 3.8 eV/A" in result.table().splitlines()[0]


def _bad_inputs():
    co2 = mol.co2_atoms()
    model = _model(co2, "CO2")
    calc = mol.ValenceForceField(model)
    return [
        (lambda: cc.crosscheck("CO2"), TypeError, r"atoms must be an ase\.Atoms, got str"),
        (lambda: cc.crosscheck(co2, calc, model=model), TypeError, r"either model .* or calculator"),
        (lambda: cc.crosscheck(co2, model=model, delta=-0.01), ValueError, r"delta is -0\.01"),
        (lambda: cc.crosscheck(co2, model=model, nfree=3), ValueError, r"nfree is 3; expected 2 or 4"),
        (lambda: cc.crosscheck(co2, model=model, box=3.0), ValueError, r"box is 3\.0 Angstrom; it must exceed"),
        (lambda: cc.crosscheck(co2, model=model, experimental_cm1=[667.0, 1333.0]), ValueError,
         r"experimental_cm1 must have 4 values \(one per vibration\), got 2"),
        (lambda: cc.crosscheck(Atoms(numbers=[8, 0]), model=model), ValueError, r"atoms\.numbers\[1\] is 0"),
        (lambda: cc.crosscheck(Atoms("CO", positions=[(0, 0, 0), (0, 0, 0.01)])), ValueError,
         r"atoms 0 and 1 overlap"),
        (lambda: cc.crosscheck(mol.co2_atoms(bond_length=1.25), model=model), ValueError,
         r"not an equilibrium of the force field: residual force"),
    ]


@pytest.mark.parametrize("case", range(len(_bad_inputs())))
def test_bad_input_messages(case: int) -> None:
    call, error, pattern = _bad_inputs()[case]
    with pytest.raises(error, match=pattern):
        call()


def test_results_are_frozen() -> None:
    atoms = mol.h2o_atoms()
    result = cc.crosscheck(atoms, model=_model(atoms, "H2O"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.vibra_cm1 = np.zeros(9)  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        result.ase_cm1[0] = 1.0
    row = result.rows()[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        row.vibra_cm1 = 1.0  # type: ignore[misc]


# ----------------------------------------------------------------- GFN2-xTB (optional extra)
def _xtb_atoms(name: str):
    try:
        from tblite.ase import TBLite
    except ImportError:  # the optional extra "xtb" is not installed
        pytest.skip("tblite (vibra[xtb]) is not installed")
    from ase.optimize import BFGS

    atoms = MOLECULES[name]()
    atoms.calc = TBLite(method="GFN2-xTB", verbosity=0)
    BFGS(atoms, logfile=None).run(fmax=1e-5)
    return atoms


@pytest.mark.slow  # ~8 s each: about 75 GFN2-xTB force calls on 2 shared cores
@pytest.mark.parametrize(("name", "experimental"), [("CO2", cc.CO2_FUNDAMENTALS_CM1),
                                                     ("H2O", cc.H2O_FUNDAMENTALS_CM1)])
def test_gfn2_xtb_vibra_equals_ase(name: str, experimental) -> None:
    atoms = _xtb_atoms(name)
    result = cc.crosscheck(atoms, atoms.calc, delta=DELTA, experimental_cm1=experimental)
    coarse = cc.crosscheck(atoms, atoms.calc, delta=2 * DELTA)
    vib = ~result.rigid
    # vibra's finite-difference Hessian (same step and stencil) + vibra's eigensolver against
    # ASE and phonopy: vibra must lie within each package's own fd error, estimated from that
    # package's results at delta and 2 delta (Richardson, 2-point: (x(h) - x(2h)) / 3; it
    # carries the SCF noise of the forces too), unit offsets divided out
    floor = ROUNDOFF_RTOL * np.abs(result.vibra_cm1[vib])
    for fine, crude, bias in [(result.ase_cm1, coarse.ase_cm1, ASE_UNIT_BIAS),
                              (result.phonopy_cm1, coarse.phonopy_cm1, PHONOPY_UNIT_BIAS)]:
        estimate = np.abs(fine[vib] - crude[vib]) / (1 + bias) / 3
        assert np.all(np.abs(fine[vib] / (1 + bias) - result.vibra_cm1[vib]) <= estimate + floor)
    # GFN2-xTB harmonic wavenumbers are within 15 % of the experimental fundamentals
    # (GFN2's published mean absolute deviation for small molecules is ~ 5-10 %)
    np.testing.assert_allclose(result.vibra_cm1[vib], experimental, rtol=0.15)
    text = result.table()
    assert "exp" in text and "anharmonic" in text
    assert ("Fermi resonance" in text) == (name == "CO2")
