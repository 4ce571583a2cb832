"""Tests of vibra/crystals/infrared.py (and its chart, vibra/charts/infrared.py).

Truth comes from the rigid-ion diatomic cubic crystal in closed form, from phonopy (its LO-TO
split at q -> Gamma with the same force constants and charges), and from the textbook selection
rules of the point groups of phonopy's example crystals.
"""

from __future__ import annotations

import dataclasses
import warnings
from functools import lru_cache

import numpy as np
import pytest
from scipy import constants

from vibra.charts.infrared import plot_infrared
from vibra.crystals import Crystal, rock_salt, springs
from vibra.crystals.infrared import InfraredResponse, coulomb_factor, infrared_response
from vibra.units import ASE

DATA = "tests/data/phonopy"

# ---------------------------------------------------------------------- the rigid-ion crystal
A = 5.64            # Angstrom
MASSES = (22.99, 35.45)  # amu
K = 1.5             # eV / Angstrom^2, nearest-neighbour central springs
Z = 1.1             # e
EPS_INF = 2.4
MU = MASSES[0] * MASSES[1] / (MASSES[0] + MASSES[1])
VOLUME = A ** 3 / 4.0  # the fcc primitive cell
F = constants.e / (4.0 * np.pi * constants.epsilon_0 * constants.angstrom)  # e^2 / (4 pi eps0) in eV Angstrom
# Each ion feels its two neighbours along the displacement (central springs): omega_TO^2 = 2 K / mu.
OMEGA_TO = np.sqrt(2.0 * K / MU)
EPS_0 = EPS_INF + 4.0 * np.pi * F * Z ** 2 / (VOLUME * MU * OMEGA_TO ** 2)
OMEGA_LO = np.sqrt(OMEGA_TO ** 2 + 4.0 * np.pi * F * Z ** 2 / (VOLUME * MU * EPS_INF))
BORN = np.array([Z * np.eye(3), -Z * np.eye(3)])

# Every closed-form comparison below is a handful of floating-point operations on numbers of
# order one against an eigen-solve of a 6 x 6 matrix: agreement to 1e-10 relative is rounding.
RTOL = 1e-10


def _ionic(units: str = "ASE", **kwargs: object) -> InfraredResponse:
    crystal = rock_salt(A, MASSES, K, units=units)
    return infrared_response(crystal, BORN, EPS_INF * np.eye(3), **kwargs)  # type: ignore[arg-type]


def test_rigid_ion_modes_and_strengths() -> None:
    response = _ionic()
    optical = ~response.acoustic
    assert response.acoustic.sum() == 3
    np.testing.assert_allclose(response.omega[response.acoustic], 0.0, atol=1e-6 * OMEGA_TO)
    np.testing.assert_allclose(response.omega[optical], OMEGA_TO, rtol=RTOL)   # one triply degenerate TO
    assert len(set(response.levels[optical].tolist())) == 1
    # S summed over the level is Z^2 / mu times the identity; each mode's charge is Z / sqrt(mu)
    np.testing.assert_allclose(response.strengths[optical].sum(axis=0), Z ** 2 / MU * np.eye(3), rtol=RTOL,
                               atol=RTOL * Z ** 2 / MU)
    np.testing.assert_allclose(np.linalg.norm(response.mode_charges[optical], axis=1), Z / np.sqrt(MU), rtol=RTOL)
    np.testing.assert_allclose(response.mode_charges[response.acoustic], 0.0, atol=RTOL)
    assert response.volume == pytest.approx(VOLUME, rel=RTOL)
    assert set(response.irreps) == {"T1u"} and response.point_group == "m-3m"
    assert response.ir_active.all() and not response.raman_active.any()


def test_rigid_ion_static_dielectric_and_lyddane_sachs_teller() -> None:
    response = _ionic()
    np.testing.assert_allclose(response.static_dielectric(), EPS_0 * np.eye(3), rtol=RTOL, atol=RTOL)
    for direction in ([1, 0, 0], [0, 1, 0], [1, 1, 1], [0.3, -0.2, 0.9]):  # cubic: every direction alike
        np.testing.assert_allclose(response.lo_frequencies(direction), [OMEGA_LO], rtol=RTOL)
        np.testing.assert_allclose(response.to_frequencies(direction), [OMEGA_TO], rtol=RTOL)
        product, ratio = response.lyddane_sachs_teller(direction)
        assert product == pytest.approx(EPS_0 / EPS_INF, rel=RTOL)
        assert ratio == pytest.approx(EPS_0 / EPS_INF, rel=RTOL)
    # epsilon crosses zero at omega_LO: |eps| there is rounding of terms of size eps_0
    assert abs(response.dielectric([OMEGA_LO])[0, 0, 0]) < 1e-9 * EPS_0
    below, above = response.dielectric([0.99 * OMEGA_LO, 1.01 * OMEGA_LO])[:, 0, 0].real
    assert below < 0 < above
    assert response.reflectivity(response.omega[-1:], [1, 0, 0])[0] == 1.0  # the undamped pole itself
    # the cm^-1 entry point is the same function
    cm1 = ASE.omega_to_cm1(np.array([0.5 * OMEGA_TO, 1.2 * OMEGA_LO]))
    np.testing.assert_allclose(response.dielectric_cm1(cm1), response.dielectric(ASE.cm1_to_omega(cm1)), rtol=1e-12)


def test_rigid_ion_reflectivity() -> None:
    inside = np.linspace(OMEGA_TO, OMEGA_LO, 52)[1:-1]
    undamped = _ionic()
    # gamma = 0: eps < 0 in the band, sqrt(eps) imaginary, |r| = 1 up to rounding
    np.testing.assert_allclose(undamped.reflectivity(inside, [1, 0, 0]), 1.0, atol=1e-12)
    outside = np.array([0.5 * OMEGA_TO, 2.0 * OMEGA_LO])
    assert (undamped.reflectivity(outside, [0, 0, 1]) < 0.5).all()
    # small damping: the closed-form Lorentz oscillator, and R close to 1 in mid-band
    gamma = 0.01 * OMEGA_TO
    damped = _ionic(damping=gamma)
    omega = np.linspace(0.2 * OMEGA_TO, 2.0 * OMEGA_LO, 400)
    eps = EPS_INF + 4.0 * np.pi * F * Z ** 2 / (VOLUME * MU * (OMEGA_TO ** 2 - omega ** 2 - 1j * gamma * omega))
    root = np.sqrt(eps)
    np.testing.assert_allclose(damped.dielectric(omega)[:, 1, 1], eps, rtol=RTOL)
    np.testing.assert_allclose(damped.reflectivity(omega, [0, 1, 0]), np.abs((root - 1) / (root + 1)) ** 2, rtol=1e-9)
    assert (damped.dielectric(omega)[:, 0, 0].imag > 0).all()  # passive medium
    # Small damping inside the band: eps = -x + i y with y << x, sqrt(eps) = i sqrt(x) + y / (2 sqrt(x)) + O(y^2),
    # so 1 - R = 2 y / (sqrt(x) (1 + x)) to first order in y / x (below 0.02 here: 5% covers the rest).
    slight = _ionic(damping=1e-3 * OMEGA_TO)
    middle = np.linspace(1.05 * OMEGA_TO, 0.95 * OMEGA_LO, 20)
    eps = slight.dielectric(middle)[:, 0, 0]
    first_order = 2.0 * eps.imag / (np.sqrt(-eps.real) * (1.0 - eps.real))
    np.testing.assert_allclose(1.0 - slight.reflectivity(middle, [1, 0, 0]), first_order, rtol=0.05)
    assert (slight.reflectivity(middle, [1, 0, 0]) > 0.98).all()


def test_rigid_ion_units_agree() -> None:
    """The same crystal in SI units (m, kg, N/m, charges in e) has the same dimensionless eps."""
    si = rock_salt(A * constants.angstrom, np.array(MASSES) * constants.atomic_mass,
                   K * constants.electron_volt / constants.angstrom ** 2, units="SI")
    response = infrared_response(si, BORN, EPS_INF * np.eye(3))
    assert response.factor == pytest.approx(constants.e ** 2 / (4 * np.pi * constants.epsilon_0), rel=1e-15)
    np.testing.assert_allclose(response.static_dielectric(), EPS_0 * np.eye(3), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(response.lo_wavenumbers_cm1([1, 0, 0]), ASE.omega_to_cm1(OMEGA_LO), rtol=1e-9)


def test_dimensionless_crystal_takes_factor() -> None:
    crystal = rock_salt(2.0, (1.0, 3.0), 1.0, units="dimensionless")
    with pytest.raises(ValueError, match="dimensionless units.*pass factor="):
        infrared_response(crystal, np.array([np.eye(3), -np.eye(3)]), np.eye(3))
    response = infrared_response(crystal, np.array([np.eye(3), -np.eye(3)]), np.eye(3), factor=1.0)
    mu, volume = 0.75, 2.0 ** 3 / 4.0
    expected = 1.0 + 4.0 * np.pi / (volume * mu * (2.0 / mu))
    np.testing.assert_allclose(response.static_dielectric(), expected * np.eye(3), rtol=RTOL, atol=RTOL)
    assert "rad/time unit" in repr(response)


def test_ase_factor_is_phonopys_hartree_bohr() -> None:
    from phonopy.physical_units import get_physical_units

    units = get_physical_units()
    # phonopy's CODATA differs from scipy's in the 7th digit
    assert coulomb_factor(ASE) == pytest.approx(units.Hartree * units.Bohr, rel=1e-6)


def test_result_is_frozen_with_one_line_repr() -> None:
    response = _ionic(damping=0.01)
    with pytest.raises(dataclasses.FrozenInstanceError):
        response.factor = 1.0  # type: ignore[misc]
    for name in ("omega", "strengths", "mode_charges", "damping", "epsilon_inf", "ir_active"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(response, name)[0] = 0
    text = repr(response)
    assert "\n" not in text and text.startswith("InfraredResponse(point group m-3m") and "1 optical" not in text
    assert len(response) == 6
    np.testing.assert_allclose(response.damping, np.where(response.acoustic, 0.0, 0.01))


# ---------------------------------------------------------------------- phonopy's examples
@lru_cache(maxsize=None)
def _example(name: str) -> tuple[Crystal, dict, object]:
    """(crystal with phonopy's own force constants, nac_params, the Phonopy object with NAC)."""
    import phonopy

    folder = f"{DATA}/{name}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # phonopy's primitive_matrix='auto' notice
        phonon = phonopy.load(f"{folder}/phonopy_disp.yaml", force_sets_filename=f"{folder}/FORCE_SETS",
                              born_filename=f"{folder}/BORN", log_level=0)
    nac = dict(phonon.nac_params)
    phonon.nac_params = None
    crystal = Crystal.from_phonopy(phonon, name=name)  # D(q) exactly phonopy's
    # charges made neutral once, and the same ones given to phonopy and to vibra
    nac["born"] = nac["born"] - nac["born"].mean(axis=0)
    phonon.nac_params = nac
    return crystal, nac, phonon


def _phonopy_gamma(phonon: object, crystal: Crystal, direction: list[float] | None) -> np.ndarray:
    """phonopy's Gamma wavenumbers (cm^-1), approached along the Cartesian `direction` (None: no NAC)."""
    # nac_q_direction is in fractional reciprocal coordinates: q_frac = cell @ q_cart
    q = None if direction is None else crystal.cell @ np.asarray(direction, dtype=float)
    phonon.run_qpoints([[0.0, 0.0, 0.0]], nac_q_direction=q)  # type: ignore[attr-defined]
    thz = phonon.qpoints.frequencies[0]  # type: ignore[attr-defined]
    return thz * constants.tera / (constants.c / constants.centi)


# Same D(0), same Z*, same factor: the LO frequencies are the eigenvalues of the same matrix
# (phonopy's D + its NAC term, ours the rank-one update in the mode basis), equal to rounding
# (1e-12). What is left is the unit conversion: phonopy's sqrt(eV / Angstrom^2 / amu) -> THz comes
# from its own constants, 1.2e-7 relative from scipy's CODATA ones. 1e-6 covers that and stays far
# below any modelling difference (a changed factor or charge residual moves the LO by 1e-5 to 1e-4).
PHONOPY_RTOL = 1e-6


@pytest.mark.parametrize("name, directions", [("NaCl", ([1, 0, 0], [1, 1, 0])), ("MgO", ([1, 0, 0],)),
                                              ("ZnO", ([1, 0, 0], [0, 0, 1])), ("SnO2", ([1, 0, 0], [0, 0, 1]))])
def test_lo_frequencies_match_phonopy_nac(name: str, directions: tuple[list[int], ...]) -> None:
    crystal, nac, phonon = _example(name)
    response = infrared_response(crystal, nac["born"], nac["dielectric"], factor=nac["factor"])
    phonon.nac_params = None  # type: ignore[attr-defined]
    transverse = _phonopy_gamma(phonon, crystal, None)
    phonon.nac_params = nac
    np.testing.assert_allclose(response.wavenumbers_cm1()[3:], transverse[3:], rtol=PHONOPY_RTOL)
    for direction in directions:
        longitudinal = _phonopy_gamma(phonon, crystal, direction)
        lo = response.lo_wavenumbers_cm1(direction)
        to = response.units.omega_to_cm1(response.to_frequencies(direction))
        assert lo.size >= 1
        for value in lo:  # each zero of q.eps.q is one of phonopy's q -> Gamma frequencies
            assert np.min(np.abs(longitudinal - value)) <= PHONOPY_RTOL * value
        # phonopy's q -> Gamma spectrum is the TO one with one mode of each active level moved to its LO
        expected = list(transverse)
        for value in to:
            expected.pop(int(np.argmin(np.abs(np.array(expected) - value))))
        np.testing.assert_allclose(np.sort(expected + list(lo))[3:], np.sort(longitudinal)[3:], rtol=PHONOPY_RTOL)
        # Lyddane-Sachs-Teller with phonopy's LO and TO against our static eps
        product, ratio = response.lyddane_sachs_teller(direction)
        assert product == pytest.approx(ratio, rel=1e-9)


def test_nacl_lo_with_everyday_inputs() -> None:
    """NaCl as a user reads it: symmetrized force constants, raw charges, vibra's own factor."""
    import phonopy

    folder = f"{DATA}/NaCl"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        phonon = phonopy.load(f"{folder}/phonopy_disp.yaml", force_sets_filename=f"{folder}/FORCE_SETS",
                              born_filename=f"{folder}/BORN", log_level=0)
    nac = phonon.nac_params
    phonon.nac_params = None
    crystal = Crystal.from_phonopy(phonon, symmetrize=True)
    phonon.nac_params = nac
    response = infrared_response(crystal, nac["born"], nac["dielectric"])
    lo = float(response.lo_wavenumbers_cm1([1, 0, 0])[0])
    to = float(response.units.omega_to_cm1(response.to_frequencies([1, 0, 0]))[0])
    reference = _phonopy_gamma(phonon, crystal, [1, 0, 0])
    # The inputs differ from phonopy's by: the factor (14.4 in BORN vs 14.39965: 2.5e-5), the charge
    # residual removed (|sum Z*| / |Z*| = 3e-4 e / 1.09 e, entering Z^2 twice) and the symmetrization
    # of the force constants (TO within 1e-3 cm^-1). omega_LO^2 - omega_TO^2 scales with f Z^2, so
    # delta omega_LO <= (LO^2 - TO^2) / (2 LO) * (2.5e-5 + 2 * 3e-4 / 1.09) + 1e-3 cm^-1 = 0.04 cm^-1.
    residual = float(np.abs(nac["born"].sum(axis=0)).max()) / float(np.abs(nac["born"]).max())
    bound = (lo ** 2 - to ** 2) / (2 * lo) * (abs(nac["factor"] / response.factor - 1) + 2 * residual) + 1e-3
    assert abs(lo - reference[-1]) <= bound
    assert abs(to - reference[3]) <= 1e-3
    assert 246.0 < lo < 247.5 and 153.5 < to < 154.5  # phonopy's example: 153.99 and 246.71 cm^-1


# Selection rules from the character tables (Cotton, "Chemical Applications of Group Theory",
# 3rd ed., appendix IIA; the Bilbao Crystallographic Server's POINT): IR active iff the irrep
# transforms as x, y or z; Raman iff as a quadratic form.
#   Oh (m-3m), rock salt: optical T1u, IR only.
#   C6v (6mm), wurtzite ZnO: optical A1 + 2B1 + E1 + 2E2 (Damen, Porto & Tell, Phys. Rev. 142, 570
#   (1966)); A1 and E1 both, E2 Raman only, B1 silent.
#   D4h (4/mmm), rutile SnO2: optical A1g + A2g + B1g + B2g + Eg + A2u + 2B1u + 3Eu (Traylor et al.,
#   Phys. Rev. B 3, 3457 (1971)); A2u and Eu IR, A1g, B1g, B2g, Eg Raman, A2g and B1u silent.
RULES = {
    "m-3m": {"T1u": (True, False)},
    "6mm": {"A1": (True, True), "E1": (True, True), "E2": (False, True), "B1": (False, False),
            "B2": (False, False)},
    "4/mmm": {"A2u": (True, False), "Eu": (True, False), "A1g": (False, True), "B1g": (False, True),
              "B2g": (False, True), "Eg": (False, True), "A2g": (False, False), "B1u": (False, False)},
}
OPTICAL = {"NaCl": {"T1u": 1}, "MgO": {"T1u": 1}, "ZnO": {"A1": 1, "B1": 2, "E1": 1, "E2": 2},
           "SnO2": {"A1g": 1, "A2g": 1, "B1g": 1, "B2g": 1, "Eg": 1, "A2u": 1, "B1u": 2, "Eu": 3}}
GROUPS = {"NaCl": "m-3m", "MgO": "m-3m", "ZnO": "6mm", "SnO2": "4/mmm"}


@pytest.mark.parametrize("name", ["NaCl", "MgO", "ZnO", "SnO2"])
def test_irreps_and_selection_rules(name: str) -> None:
    crystal, nac, _ = _example(name)
    response = infrared_response(crystal, nac["born"], nac["dielectric"])
    assert response.point_group == GROUPS[name]
    optical = ~response.acoustic
    counts: dict[str, int] = {}
    for level in np.unique(response.levels[optical]):
        members = np.flatnonzero((response.levels == level) & optical)
        label = response.irreps[members[0]]
        counts[label] = counts.get(label, 0) + 1
        ir, raman = RULES[response.point_group][label]
        assert response.ir_active[members].all() == ir and response.raman_active[members].all() == raman, label
        charge = np.abs(response.mode_charges[members]).max()
        if ir:  # an IR-active level carries charge; a symmetry zero is rounding (Z* ~ 1 e / sqrt(amu))
            assert charge > 1e-3
        else:
            assert charge < 1e-8
    assert counts == OPTICAL[name]
    assert sum(int(response.ir_active[k]) for k in np.flatnonzero(response.acoustic)) == 3  # acoustic: vector rep


@pytest.mark.parametrize("name", ["NaCl", "MgO"])
def test_rock_salt_examples_dielectric(name: str) -> None:
    crystal, nac, _ = _example(name)
    response = infrared_response(crystal, nac["born"], nac["dielectric"])
    eps0 = response.static_dielectric()
    np.testing.assert_allclose(eps0, eps0[0, 0] * np.eye(3), atol=1e-9 * eps0[0, 0])  # cubic
    product, ratio = response.lyddane_sachs_teller([1, 0, 0])
    assert product == pytest.approx(ratio, rel=1e-10)
    # eps0 / eps_inf of the examples (experiment: NaCl 5.9 / 2.34 = 2.5, MgO 9.8 / 2.95 = 3.3)
    assert {"NaCl": (2.4, 2.7), "MgO": (3.0, 3.4)}[name][0] < ratio < {"NaCl": (2.4, 2.7), "MgO": (3.0, 3.4)}[name][1]


# ---------------------------------------------------------------------- bad inputs
def test_refuses_a_crystal_without_force_constants() -> None:
    bare = Crystal.from_cell(A / 2 * (np.ones((3, 3)) - np.eye(3)), [[0, 0, 0], [0.5, 0.5, 0.5]], MASSES,
                             fractional=True, units="ASE")
    with pytest.raises(ValueError, match="has no force constants"):
        infrared_response(bare, BORN, np.eye(3))


def test_refuses_what_is_not_a_crystal() -> None:
    with pytest.raises(TypeError, match="crystal must be a vibra.crystals.Crystal, got dict"):
        infrared_response({}, BORN, np.eye(3))  # type: ignore[arg-type]


def test_refuses_born_of_the_wrong_shape() -> None:
    crystal = rock_salt(A, MASSES, K, units="ASE")
    with pytest.raises(ValueError, match=r"born must have shape \(2, 3, 3\).*got \(3, 3, 3\)"):
        infrared_response(crystal, np.zeros((3, 3, 3)), np.eye(3))


def test_refuses_born_breaking_the_sum_rule() -> None:
    crystal = rock_salt(A, MASSES, K, units="ASE")
    with pytest.raises(ValueError, match=r"charge neutrality: \|sum_i born\[i,0,0\]\| = 0.5 e > born_sum_atol=0.1"):
        infrared_response(crystal, np.array([(Z + 0.5) * np.eye(3), -Z * np.eye(3)]), np.eye(3))
    loose = infrared_response(crystal, np.array([(Z + 0.5) * np.eye(3), -Z * np.eye(3)]), np.eye(3),
                              born_sum_atol=1.0)
    np.testing.assert_allclose(loose.born_residual, 0.5 * np.eye(3))
    np.testing.assert_allclose(loose.born.sum(axis=0), 0.0, atol=1e-15)


@pytest.mark.parametrize("dielectric, message", [
    (np.eye(2), r"dielectric must be the 3 x 3 tensor eps_inf, dimensionless; got shape \(2, 2\)"),
    (np.eye(3) + np.diag([0.1, 0.0], 1), r"dielectric is not symmetric: \|dielectric\[0,1\] - dielectric\[1,0\]\|"),
    (np.diag([2.0, 2.0, -1.0]), r"dielectric is not positive definite \(lowest eigenvalue -1\)"),
])
def test_refuses_a_bad_dielectric_tensor(dielectric: np.ndarray, message: str) -> None:
    crystal = rock_salt(A, MASSES, K, units="ASE")
    with pytest.raises(ValueError, match=message):
        infrared_response(crystal, BORN, dielectric)


@pytest.mark.parametrize("damping, message", [
    (-0.1, r"damping\[0\] is -0.1; every damping rate must be >= 0"),
    ([0.1, 0.1], r"damping must be one value or 6 \(one per Gamma mode\), got 2"),
    ([0, 0, 0, 0.1, 0.1, 0.2], r"damping\[3\] and damping\[5\] differ but belong to one degenerate level"),
])
def test_refuses_bad_damping(damping: object, message: str) -> None:
    crystal = rock_salt(A, MASSES, K, units="ASE")
    with pytest.raises(ValueError, match=message):
        infrared_response(crystal, BORN, np.eye(3), damping=damping)  # type: ignore[arg-type]


def test_refuses_bad_factor_and_symprec() -> None:
    crystal = rock_salt(A, MASSES, K, units="ASE")
    with pytest.raises(ValueError, match=r"factor is -1.0; a Coulomb factor must be positive"):
        infrared_response(crystal, BORN, np.eye(3), factor=-1.0)
    with pytest.raises(ValueError, match=r"symprec is 0.0; a symmetry tolerance must be positive"):
        infrared_response(crystal, BORN, np.eye(3), symprec=0.0)


def test_refuses_a_cell_that_is_not_primitive() -> None:
    cube = Crystal.from_cell(A * np.eye(3), [[0, 0, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 0.5, 0],
                                             [0.5, 0.5, 0.5], [0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]],
                             [MASSES[0]] * 4 + [MASSES[1]] * 4, fractional=True, symbols=["Na"] * 4 + ["Cl"] * 4,
                             units="ASE")
    cube = springs(cube, shells=1, stiffness=K)
    born = np.array([Z * np.eye(3)] * 4 + [-Z * np.eye(3)] * 4)
    with pytest.raises(ValueError, match="is not a primitive cell"):
        infrared_response(cube, born, np.eye(3))


def test_refuses_a_bad_direction() -> None:
    response = _ionic()
    with pytest.raises(ValueError, match="direction is the zero vector"):
        response.lo_frequencies([0, 0, 0])
    with pytest.raises(ValueError, match=r"direction must hold 3 Cartesian components, got shape \(2,\)"):
        response.reflectivity([1.0], [1, 0])


# ---------------------------------------------------------------------- chart
def test_plot_infrared_writes_a_png(tmp_path: object) -> None:
    from matplotlib.image import imread

    crystal, nac, _ = _example("NaCl")
    response = infrared_response(crystal, nac["born"], nac["dielectric"], damping=crystal.units.cm1_to_omega(6.0))
    path = plot_infrared(response, tmp_path / "nacl.png", title="NaCl")  # type: ignore[operator]
    image = imread(path)
    assert image.shape[:2] == (840, 960)  # 8 x 7 inches at savefig.dpi = 120
    assert image[..., :3].std() > 0.05
    undamped = plot_infrared(_ionic(), tmp_path / "ionic.png", direction=(1, 1, 0))  # type: ignore[operator]
    assert imread(undamped)[..., :3].std() > 0.05
    with pytest.raises(TypeError, match="response must be an InfraredResponse"):
        plot_infrared(crystal, tmp_path / "x.png")  # type: ignore[arg-type, operator]
