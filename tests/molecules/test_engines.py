"""The engine protocol and the finite-difference derivatives of properties, without PySCF
(`vibra.molecules.engines`, `vibra.molecules.property_derivatives`, `vibra.spectra.electronic`).

A toy engine with closed forms: springs between every pair of atoms (forces), point charges
(mu = sum_i q_i r_i, so d mu / d x_ib = q_i e_b exactly) and a polarisability quadratic in the
positions (alpha = a0 I + sum_i c_i r_i r_i^T, so d alpha_ac / d x_ib = c_i (delta_ab r_ic +
r_ia delta_cb) exactly): central differences of both are exact up to rounding. A cubic term
beta sum_i x_i^3 in mu_x makes the 2-point step error exactly beta h^2 (the Richardson
estimate must find it). The IR intensities of a point-charge engine equal vibra's point-charge
model (`ir_spectrum(charges=...)`), computed without any engine.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Collection

import numpy as np
import pytest
from ase import Atoms
from ase import units as ase_units

from vibra import molecules as mol
from vibra import spectra
from vibra.molecules.engines import AseEngine, Engine, EngineCalculator, EngineResult, electronic_structure
from vibra.molecules.property_derivatives import check_properties

CHARGES = np.array([-0.8, 0.4, 0.4])
POLARIZABILITY_WEIGHTS = np.array([0.3, 0.1, 0.1])      # c_i, Angstrom^3 / Angstrom^2


def water() -> Atoms:
    return Atoms("OHH", positions=[(0.0, 0.0, 0.1173), (0.0, 0.7572, -0.4692), (0.0, -0.7572, -0.4692)])


@dataclasses.dataclass(frozen=True)
class ToyEngine:
    """Springs between all pairs (at rest at `rest`), point charges, a quadratic polarisability."""

    rest: tuple[tuple[float, float, float], ...]
    stiffness: float = 30.0
    cubic: float = 0.0                                  # beta of mu_x += beta sum x^3, e / Angstrom^2

    @property
    def level(self) -> str:
        return "toy"

    @property
    def capabilities(self) -> frozenset[str]:
        return frozenset({"dipole", "polarizability"})

    @property
    def noise(self) -> dict[str, float]:
        return {}

    def compute(self, numbers: np.ndarray, positions: np.ndarray, properties: Collection[str] = ()) -> EngineResult:
        r = np.asarray(positions, dtype=float)
        rest = np.asarray(self.rest)
        energy, forces = 0.0, np.zeros_like(r)
        for i in range(len(r)):
            for j in range(i + 1, len(r)):
                vector = r[j] - r[i]
                length = np.linalg.norm(vector)
                stretch = length - np.linalg.norm(rest[j] - rest[i])
                energy += 0.5 * self.stiffness * stretch**2
                push = self.stiffness * stretch * vector / length
                forces[i] += push
                forces[j] -= push
        dipole = CHARGES @ r
        dipole[0] += self.cubic * np.sum(r[:, 0] ** 3)
        alpha = np.eye(3) + np.einsum("i,ia,ic->ac", POLARIZABILITY_WEIGHTS, r, r)
        return EngineResult(energy=energy, forces=forces, dipole=dipole if "dipole" in properties else None,
                            polarizability=alpha if "polarizability" in properties else None)

    def hessian(self, numbers: np.ndarray, positions: np.ndarray) -> np.ndarray:
        raise NotImplementedError


def toy(cubic: float = 0.0) -> ToyEngine:
    return ToyEngine(rest=tuple(tuple(p) for p in water().positions), cubic=cubic)


def exact_derivatives(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(positions)
    dipole = np.kron(CHARGES[:, None], np.eye(3))                       # row 3 i + b: q_i e_b
    alpha = np.zeros((3 * n, 3, 3))
    for i in range(n):
        for b in range(3):
            e = np.eye(3)[b]
            alpha[3 * i + b] = POLARIZABILITY_WEIGHTS[i] * (np.outer(e, positions[i]) + np.outer(positions[i], e))
    return dipole, alpha


def test_the_toy_engine_follows_the_protocol() -> None:
    assert isinstance(toy(), Engine)
    assert not isinstance(3.0, Engine)


def test_derivatives_are_exact_for_linear_and_quadratic_properties() -> None:
    # mu linear and alpha quadratic in the positions: central differences exact up to rounding
    atoms = water()
    result = mol.finite_difference_hessian(atoms, EngineCalculator(toy(), ("dipole", "polarizability")),
                                           properties=("dipole", "polarizability"), symmetry=False)
    derivatives = result.derivatives
    assert derivatives is not None and derivatives.error_method == "richardson"
    assert dict(derivatives.noise_source) == {"dipole": "rounding", "polarizability": "rounding"}
    dipole, alpha = exact_derivatives(atoms.positions)
    np.testing.assert_allclose(derivatives.dipole, dipole, atol=1e-12)
    np.testing.assert_allclose(derivatives.polarizability, alpha, atol=1e-12)
    assert derivatives.dipole_error is not None and derivatives.dipole_error.max() < 1e-11
    np.testing.assert_allclose(derivatives.reference_dipole, CHARGES @ atoms.positions, atol=1e-15)
    assert result.n_force_calls == 37                   # one loop: forces and properties together


@pytest.mark.parametrize("step", [0.02, 0.01])
def test_the_richardson_estimate_finds_the_step_error(step: float) -> None:
    # d(beta x_i^3)/dx_i = 3 beta x_i^2; the 2-point quotient adds exactly beta h^2, and
    # |D(h) - D(2h)| / 3 = |beta h^2 - 4 beta h^2| / 3 = beta h^2: the estimate is the error
    beta = 0.5
    atoms = water()
    result = mol.finite_difference_hessian(atoms, EngineCalculator(toy(beta), ("dipole",)), step=step,
                                           properties=["dipole"], property_noise={"dipole": 0.0})
    derivatives = result.derivatives
    assert derivatives is not None and derivatives.dipole is not None and derivatives.dipole_error is not None
    exact, _ = exact_derivatives(atoms.positions)
    exact[0::3, 0] += 3 * beta * atoms.positions[:, 0] ** 2
    np.testing.assert_allclose(derivatives.dipole[0::3, 0] - exact[0::3, 0], beta * step**2, rtol=1e-6)
    np.testing.assert_allclose(derivatives.dipole_error[0::3, 0], beta * step**2, rtol=1e-6)
    assert dict(derivatives.noise) == {"dipole": 0.0}


def test_properties_share_the_cache_and_a_rerun_computes_nothing(tmp_path: Path) -> None:
    atoms = water()
    calculator = EngineCalculator(toy(), ("dipole",))
    first = mol.finite_difference_hessian(atoms, calculator, properties=["dipole"], cache=tmp_path, symmetry=False)
    again = mol.finite_difference_hessian(atoms, calculator, properties=["dipole"], cache=tmp_path, symmetry=False)
    assert first.n_force_calls == 37 and again.n_force_calls == 0 and again.n_cached == 37
    assert first.derivatives is not None and again.derivatives is not None
    np.testing.assert_array_equal(again.derivatives.dipole, first.derivatives.dipole)
    # forces alone are keyed apart: none of the files with a dipole row is read as forces
    alone = mol.finite_difference_hessian(atoms, calculator, cache=tmp_path, symmetry=False)
    assert alone.n_cached == 0 and alone.derivatives is None
    np.testing.assert_array_equal(alone.hessian, first.hessian)


def test_properties_on_a_dask_cluster_equal_the_serial_run_bit_for_bit(dask_client) -> None:
    # the forces and the property rows travel together as one array per geometry
    serial = electronic_structure(water(), toy(0.5))
    parallel = electronic_structure(water(), toy(0.5), client=dask_client)
    a, b = serial.finite_difference, parallel.finite_difference
    np.testing.assert_array_equal(a.hessian, b.hessian)
    assert a.derivatives is not None and b.derivatives is not None
    for name in ("dipole", "dipole_error", "polarizability", "polarizability_error"):
        np.testing.assert_array_equal(getattr(a.derivatives, name), getattr(b.derivatives, name), err_msg=name)


def test_ir_of_a_point_charge_engine_is_the_point_charge_model() -> None:
    # the same charges as vibra's point-charge model: the same intensities (the modes from
    # the same finite-difference Hessian), and a level of theory on the spectrum
    electronic = electronic_structure(water(), toy())
    assert electronic.hessian_method == "finite difference" and electronic.analytic_hessian is None
    system = electronic.system()
    analysis = mol.vibrational_analysis(system)
    ir = spectra.electronic_ir_spectrum(electronic, analysis)
    model = spectra.ir_spectrum(system, analysis, charges=CHARGES)
    np.testing.assert_allclose(ir.intensities, model.intensities, rtol=1e-9)
    assert ir.level == "toy" and ir.sticks().level == "toy" and model.level == ""
    assert ir.intensity_errors is not None and np.all(ir.intensity_errors < 1e-9 * ir.intensities.max())
    raman = spectra.electronic_raman_spectrum(electronic, analysis)
    assert raman.model == raman.path == "polarizability derivatives" and raman.level == "toy"
    assert raman.activity_errors is not None and np.all(raman.activity_errors < 1e-9 * raman.activities.max())
    # a result file keeps the new fields
    back = spectra.RamanSpectrum.from_dict(raman.to_dict())
    assert back.level == "toy" and back.model == "polarizability derivatives"
    np.testing.assert_array_equal(back.activity_errors, raman.activity_errors)
    with pytest.raises(ValueError, match=r"hessian='analytic' but engine 'toy' has no analytic Hessian"):
        electronic_structure(water(), toy(), hessian="analytic")


def test_an_ase_calculator_with_a_dipole_is_an_engine() -> None:
    # AseEngine over an ASE calculator (here the toy engine seen through EngineCalculator): the
    # dipole only, so IR and no Raman
    engine = AseEngine(EngineCalculator(toy()), level="toy via ASE")
    assert engine.capabilities == frozenset({"dipole"}) and engine.level == "toy via ASE"
    electronic = electronic_structure(water(), engine)
    assert electronic.polarizability_derivatives is None and electronic.dipole_derivatives is not None
    ir = spectra.electronic_ir_spectrum(electronic)
    assert ir.level == "toy via ASE"
    with pytest.raises(ValueError, match=r"no polarizability derivatives"):
        spectra.electronic_raman_spectrum(electronic)
    assert AseEngine(functools.partial(EngineCalculator, toy())).level == "EngineCalculator"


def test_xtb_ir_through_ase_engine_matches_ase_infrared(tmp_path: Path) -> None:
    # GFN2-xTB (tblite, the xtb extra) as an AseEngine factory: its dipoles differentiated on
    # vibra's displacements against ASE's Infrared on the same calculator, step and stencil.
    # At tblite's default accuracy ASE's one reused instance starts each SCF from the last one,
    # and that noise turns the two stretches (8 cm^-1 apart) into each other: 1.2e-2 apart in
    # intensity. At accuracy 0.01 both runs are converged: measured 3.0e-4 relative (ASE's
    # unprojected rotations, its rounded unit factor); allowed 1e-3.
    tblite = pytest.importorskip("tblite.ase")
    from ase.optimize import BFGS
    from ase.vibrations import Infrared

    factory = functools.partial(tblite.TBLite, method="GFN2-xTB", verbosity=0, accuracy=0.01)
    atoms = water()
    atoms.calc = factory()
    BFGS(atoms, logfile=None).run(fmax=1e-5)
    atoms.calc = None
    electronic = electronic_structure(atoms, AseEngine(factory))
    assert electronic.level == "GFN2-xTB" and electronic.hessian_method == "finite difference"
    ir = spectra.electronic_ir_spectrum(electronic)
    work = atoms.copy()
    work.calc = factory()
    infrared = Infrared(work, name=str(tmp_path / "ir"), delta=0.01, nfree=2)
    infrared.run()
    np.testing.assert_allclose(ir.wavenumbers, infrared.get_frequencies().real[-3:], rtol=1e-3)
    np.testing.assert_allclose(ir.intensities / ase_units.Debye**2, infrared.intensities[-3:], rtol=1e-3)


# ====================================================================== inputs
def test_property_inputs_are_checked() -> None:
    with pytest.raises(TypeError, match=r"properties must be a list or tuple"):
        check_properties("dipole", None)
    with pytest.raises(ValueError, match=r"properties\[1\] is 'dipole'; expected distinct names"):
        check_properties(["dipole", "dipole"], None)
    with pytest.raises(ValueError, match=r"properties\[0\] is 'charge'"):
        check_properties(["charge"], None)
    with pytest.raises(TypeError, match=r"property_noise must be a mapping"):
        check_properties(["dipole"], 1e-3)
    with pytest.raises(ValueError, match=r"property_noise\['polarizability'\] is given but"):
        check_properties(["dipole"], {"polarizability": 1e-3})
    with pytest.raises(ValueError, match=r"property_noise\['dipole'\] is -1"):
        check_properties(["dipole"], {"dipole": -1})
    with pytest.raises(ValueError, match=r"properties\[0\] is 'stress'"):
        mol.finite_difference_hessian(water(), EngineCalculator(toy()), properties=["stress"])


def test_engine_wrappers_check_their_inputs() -> None:
    with pytest.raises(TypeError, match=r"engine must follow the vibra.molecules.engines.Engine protocol"):
        EngineCalculator(3.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"properties asks for 'polarizability', which engine 'toy via ASE'"):
        EngineCalculator(AseEngine(EngineCalculator(toy()), level="toy via ASE"), ("polarizability",))
    with pytest.raises(TypeError, match=r"calculator must be an ASE calculator or a factory"):
        AseEngine(3.0)
    with pytest.raises(ValueError, match=r"noise\['stress'\]"):
        AseEngine(EngineCalculator(toy()), noise={"stress": 1.0})
    with pytest.raises(TypeError, match=r"engine must be a vibra.molecules.engines.Engine or an ASE calculator"):
        electronic_structure(water(), "pyscf")
    with pytest.raises(ValueError, match=r"hessian is 'exact'"):
        electronic_structure(water(), toy(), hessian="exact")  # type: ignore[arg-type]


def test_raman_ratios_and_cross_sections_check_their_inputs() -> None:
    system = mol.h2o()
    raman = spectra.raman_spectrum(system, mol.vibrational_analysis(system), bonds=[[0, 1], [0, 2]])
    assert raman.path == "bond polarisability" and raman.level == ""   # the bond model keeps its name
    with pytest.raises(ValueError, match=r"laser_nm is 3000.0: 3333.33 cm\^-1, not above the highest line"):
        raman.cross_sections_cm2_per_sr(3000.0)
    with pytest.raises(ValueError, match=r"temperature is -1"):
        raman.cross_sections_cm2_per_sr(532.0, -1.0)
    with pytest.raises(ValueError, match=r"laser_nm"):
        raman.cross_sections_cm2_per_sr(0.0)
    silent = dataclasses.replace(raman, isotropic=np.zeros(3), anisotropy=np.zeros(3), activities=np.zeros(3))
    assert np.isnan(silent.depolarization_ratios()).all()          # no activity: no ratio
