"""Polar crystals end to end (issue 42, item 4): files in, phonopy's LO-TO physics out.

Truth: phonopy itself on its own example data (tests/data/phonopy: FORCE_SETS and BORN of NaCl,
MgO, ZnO, SnO2, with phonopy's licence), loaded with ``phonopy.load(..., born_filename=...)`` and
run through its own ``run_qpoints``, ``run_band_structure``, ``run_mesh`` + ``run_total_dos`` and
``run_thermal_properties``; the Lyddane-Sachs-Teller relation as an invariant. The matrices
themselves are tested against phonopy's in tests/crystals/test_nac.py; here the paths a user
takes: `read_phonopy(born=)`, `from_phonopy`, `frequencies(q_direction=)`, bands, DOS, thermal.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from phonopy.physical_units import get_physical_units

from vibra import crystals
from vibra.crystals import Crystal

DATA = Path(__file__).parents[1] / "data" / "phonopy"
TO_THZ = get_physical_units().DefaultToTHz
# both sides solve the same Hermitian D(q) with LAPACK: a few eps ||D|| absolute
RTOL = 1e-10
Q = np.array([[0.1, 0.2, 0.3], [0.5, 0.0, 0.5], [0.25, 0.25, 0.0], [0.01, 0.0, 0.0], [0.0, 0.0, 0.0]])


def _phonopy(name: str, method: str = "gonze", factor: float | None = None):
    import phonopy

    folder = DATA / name
    phonon = phonopy.load(folder / "phonopy_disp.yaml", force_sets_filename=folder / "FORCE_SETS",
                          born_filename=folder / "BORN", log_level=0)
    # phonopy's default factor (for a BORN file without one) is its Hartree x Bohr, 4e-7 from
    # CODATA's e^2 / (4 pi eps0), which vibra takes: give phonopy vibra's, so arithmetic alone differs
    params = {**phonon.nac_params, "method": method}
    if factor is not None:
        params["factor"] = factor
    phonon.nac_params = params
    return phonon


def _ours(name: str, method: str = "gonze") -> Crystal:
    folder = DATA / name
    return crystals.read_phonopy(folder / "phonopy_disp.yaml", force_sets=folder / "FORCE_SETS",
                                 born=folder / "BORN", nac=method, primitive="auto")


def _eigen(omega: np.ndarray) -> np.ndarray:
    return np.sign(omega) * omega ** 2


@pytest.mark.parametrize("method", ["gonze", "wang"])
@pytest.mark.parametrize("name", ["NaCl", "MgO", "ZnO", "SnO2"])
def test_read_phonopy_with_a_born_file_gives_phonopys_frequencies(name: str, method: str) -> None:
    crystal = _ours(name, method)
    assert crystal.nac is not None and crystal.nac.method == method
    phonon = _phonopy(name, method, crystal.nac.factor)
    # away from Gamma without a direction (phonopy's Rust backend would apply a direction to
    # every q for Wang, its C kernels and docs only at Gamma: tests/crystals/test_nac.py), Gamma with one
    phonon.run_qpoints(Q[:-1])
    theirs = phonon.qpoints.frequencies / TO_THZ
    ours = crystal.frequencies(Q[:-1])
    away = np.abs(theirs) > 1e-3 * np.abs(theirs).max()
    assert np.abs(ours[away] / theirs[away] - 1.0).max() < RTOL
    for direction in ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 0.0]):
        phonon.run_qpoints(Q[-1:], nac_q_direction=direction)
        theirs = phonon.qpoints.frequencies / TO_THZ
        ours = crystal.frequencies(Q[-1:], q_direction=direction)
        # at Gamma the acoustic omega is the square root of rounding: eigenvalues there
        assert np.abs(_eigen(ours) - _eigen(theirs)).max() < RTOL * (theirs ** 2).max()


def test_the_lo_to_split_depends_on_the_direction_of_approach() -> None:
    crystal = _ours("ZnO")  # wurtzite: uniaxial, so the LO of the c axis differs from the basal one's
    gamma = [[0.0, 0.0, 0.0]]
    along_c = crystal.frequencies(gamma, q_direction=[0.0, 0.0, 1.0])[0]
    along_a = crystal.frequencies(gamma, q_direction=[1.0, 0.0, 0.0])[0]
    analytic = crystal.frequencies(gamma)[0]                        # no direction: no correction at Gamma
    # an LO rises from a TO in each direction, a different one: the spectra differ from the analytic one and
    # from each other (ZnO's highest mode is an LO along c, not along a)
    assert np.abs(along_c - analytic).max() > 1e-3 * analytic.max()
    assert np.abs(along_a - analytic).max() > 1e-3 * analytic.max()
    assert abs(along_c.max() - along_a.max()) > 1e-3 * along_c.max()
    # the limit is the limit: a small step along c gives the c-axis value
    # (1e-4 of c*: |k| above phonopy's 1e-5 / Angstrom, below which q counts as Gamma itself; the
    # optical branches move by O((k a)^2) ~ 1e-8 there)
    near = crystal.frequencies([[0.0, 0.0, 1e-4]])[0]
    assert np.abs(near[3:] - along_c[3:]).max() < 1e-5 * along_c.max()


def test_bands_take_the_direction_of_the_path_at_gamma_as_phonopy() -> None:
    crystal = _ours("NaCl")
    bands = crystal.band_structure(npoints=60)
    phonon = _phonopy("NaCl", factor=crystal.nac.factor)
    paths = [bands.qpoints[first:last + 1] for first, last in bands.segments]
    phonon.run_band_structure(paths, with_eigenvectors=False, with_group_velocities=False, labels=None)
    theirs = np.vstack(phonon.band_structure.frequencies) / TO_THZ
    ours = np.vstack([bands.omega[first:last + 1] for first, last in bands.segments])
    away = np.abs(theirs) > 1e-3 * np.abs(theirs).max()
    assert np.abs(np.sort(ours, axis=1)[away] / np.sort(theirs, axis=1)[away] - 1.0).max() < RTOL
    start = bands.segments[0][0]
    assert np.allclose(bands.qpoints[start], 0.0)          # the path starts at Gamma: LO above TO there
    top = np.sort(bands.omega[start])
    assert top[-1] > 1.4 * top[-2]


def test_dos_and_thermal_properties_with_the_correction_match_phonopy(codata_phonopy: None) -> None:
    crystal = _ours("NaCl")
    to_thz = crystal.units.omega_to_thz(1.0)
    phonon = _phonopy("NaCl", factor=crystal.nac.factor)
    phonon.run_mesh([10, 10, 10], is_gamma_center=True)
    phonon.run_total_dos(use_tetrahedron_method=True)
    points, reference = phonon.total_dos.frequency_points, phonon.total_dos.dos
    ours = crystal.dos([10, 10, 10], omega=points / to_thz)
    # the same tetrahedra over the same (corrected) frequencies: rounding only (the 1e-6 of the maximum)
    np.testing.assert_allclose(ours.dos_per_thz(), reference, atol=1e-6 * reference.max())
    temperatures = np.array([0.0, 10.0, 100.0, 300.0, 1000.0])
    phonon.run_thermal_properties(temperatures=temperatures, exclude_gamma_acoustic=True)
    _, free, entropy, heat = phonon.thermal_properties.thermal_properties
    thermal = crystal.thermal_properties(temperatures, mesh=[10, 10, 10])
    # F passes through zero between 100 and 300 K: 1e-8 of its largest magnitude (the target)
    np.testing.assert_allclose(thermal.free_energy_kj_mol(), free, rtol=0.0, atol=1e-8 * np.abs(free).max())
    np.testing.assert_allclose(thermal.entropy_j_k_mol()[1:], entropy[1:], rtol=1e-8)
    np.testing.assert_allclose(thermal.heat_capacity_j_k_mol()[1:], heat[1:], rtol=1e-8)


def test_group_velocities_of_a_polar_crystal_follow_the_corrected_bands() -> None:
    crystal = _ours("MgO")
    q = np.array([[0.1, 0.05, 0.0], [0.3, 0.2, 0.1]])
    direction = np.array([1.0, 0.0, 0.0])
    velocity = crystals.group_velocities(crystal, q, direction)
    # truth: the corrected frequencies themselves, differenced by hand along the Cartesian direction
    step = 1e-6 * np.linalg.norm(crystal.reciprocal, axis=1).min()
    dq = step * (crystal.cell @ direction) / (2 * np.pi)
    slope = (crystal.frequencies(q + dq) - crystal.frequencies(q - dq)) / (2 * step)
    # central differences of omega: truncation (step / |k|)^2 ~ 1e-10 (the correction varies on |k|'s scale,
    # |k| ~ 0.1 |b| here), rounding eps omega / step ~ 1e-10 relative; away from crossings
    assert np.abs(velocity - slope).max() < 1e-7 * np.abs(slope).max()


def test_the_infrared_response_reads_the_crystals_own_charges_and_meets_lyddane_sachs_teller() -> None:
    crystal = _ours("NaCl")
    response = crystals.infrared_response(crystal)
    direction = [1.0, 0.0, 0.0]
    product, ratio = response.lyddane_sachs_teller(direction)
    assert product == pytest.approx(ratio, rel=1e-10)
    lo = response.lo_frequencies(direction)
    # the zero of eps(omega) is the LO of the corrected crystal at Gamma, approached along the field
    corrected = crystal.frequencies([[0.0, 0.0, 0.0]], q_direction=direction)[0]
    assert lo.max() == pytest.approx(corrected.max(), rel=1e-5)


def test_polar_inputs_are_refused_in_one_line(tmp_path: Path) -> None:
    folder = DATA / "NaCl"
    with pytest.raises(ValueError, match=r"born: .*missing: no such file"):
        crystals.read_phonopy(folder / "phonopy_disp.yaml", force_sets=folder / "FORCE_SETS", born=tmp_path / "missing")
    with pytest.raises(ValueError, match=r"nac is 'ewald'; expected 'gonze' .*'wang' or None"):
        crystals.read_phonopy(folder / "phonopy_disp.yaml", force_sets=folder / "FORCE_SETS", born=folder / "BORN",
                              nac="ewald")
    other = tmp_path / "BORN"
    text = (folder / "BORN").read_text()
    other.write_text(text + text.splitlines()[-1] + "\n")  # a third charge line for NaCl's two independent atoms
    with pytest.raises(ValueError, match=r"BORN: line 5: more charge lines than the 2 symmetry-independent atoms"):
        crystals.read_phonopy(folder / "phonopy_disp.yaml", force_sets=folder / "FORCE_SETS", born=other)
    plain = crystals.rock_salt(5.64, [22.99, 35.45], 2.0, units="ASE")
    with pytest.raises(ValueError, match=r"dielectric .*positive definite"):
        plain.with_nac(np.array([np.eye(3), -np.eye(3)]), -np.eye(3))
    with pytest.raises(ValueError, match=r"method .*'gonze'.*'wang'"):
        plain.with_nac(np.array([np.eye(3), -np.eye(3)]), np.eye(3), method="ewald")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        polar = plain.with_nac(np.array([np.eye(3), -np.eye(3)]), 2.0 * np.eye(3))
    assert "LO-TO by Gonze-Lee" in repr(polar)
    assert polar.with_force_constants(plain.force_constants).nac is None   # the correction goes with its force constants


@pytest.mark.parametrize("method", ["gonze", "wang"])
def test_a_polar_crystal_is_periodic_in_q(method: str) -> None:
    # the truncated sums over G are not periodic in q: D(q) is formed in the first zone (reviewer's find:
    # q + (3, -2, 5) gave imaginary modes)
    crystal = _ours("NaCl", method)
    q = np.array([[0.1, 0.2, 0.3]])
    base = crystal.frequencies(q)
    for shift in ([3.0, -2.0, 5.0], [10.0, 0.0, 0.0], [1.0, 0.0, 0.0]):
        assert np.abs(crystal.frequencies(q + np.array(shift)) - base).max() < 1e-12 * base.max()


def test_a_gamma_point_inside_a_segment_takes_the_segments_direction() -> None:
    crystal = _ours("NaCl")
    points = {"A": [-0.5, 0.0, -0.5], "B": [0.5, 0.0, 0.5]}   # X to X through Gamma
    bands = crystal.band_structure([["A", "B"]], npoints=21, points=points)
    middle = int(np.argmin(np.abs(bands.qpoints).max(axis=1)))
    assert np.allclose(bands.qpoints[middle], 0.0)
    along = crystal.frequencies([[0.0, 0.0, 0.0]], q_direction=[1.0, 0.0, 1.0])[0]
    ours, theirs = np.sort(bands.omega[middle]), np.sort(along)
    # the three acoustic modes at Gamma are zero: each side's omega is the signed square root of
    # omega^2's rounding (~n eps ||D||), so |omega| <= sqrt(100 n eps) omega_max on any LAPACK build and
    # thread count (1e-8 omega_max, as before, is below that: two builds gave -2.4e-9 and +3.5e-9 there);
    # the optical ones agree to 1e-10 relative
    zero = np.sqrt(100 * len(along) * np.finfo(float).eps) * along.max()
    assert np.all(np.abs(ours[:3]) <= zero) and np.all(np.abs(theirs[:3]) <= zero)
    assert np.allclose(ours[3:], theirs[3:], rtol=1e-10, atol=0.0)
    assert np.sort(bands.omega[middle])[-1] > 1.4 * np.sort(bands.omega[middle])[-2]   # the LO above the TO


def test_a_method_without_charges_is_refused() -> None:
    folder = DATA / "NaCl"
    with pytest.raises(ValueError, match=r"nac is 'wang' but .* has no Born charges .*born="):
        crystals.read_phonopy(folder / "phonopy_disp.yaml", force_sets=folder / "FORCE_SETS", nac="wang")
