"""Tests of vibra/crystals/nac.py: the non-analytic (LO-TO) correction.

Truth: phonopy itself on its own example data (tests/data/phonopy/, licence there), both
methods, with and without symmetrised force constants; the closed form of the rigid-ion
diatomic cubic crystal; and every validation message.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import phonopy
import pytest
from phonopy.harmonic.dynamical_matrix import get_dynamical_matrices_at_qpoints
from phonopy.physical_units import get_physical_units

import vibra.crystals.nac as nac_module
from vibra.crystals import Crystal, rock_salt
from vibra.crystals.dynamical import dynamical_matrices
from vibra.crystals.born import nac_from_phonopy, read_born
from vibra.crystals.nac import FACTOR_ASE, FACTOR_SI, METHODS, NonAnalytic, nac_dynamical_matrices, non_analytic

DATA = Path(__file__).parents[1] / "data" / "phonopy"
CRYSTALS = ("NaCl", "MgO", "ZnO", "SnO2")
THZ = get_physical_units().DefaultToTHz  # sqrt(eV / Angstrom^2 / amu) / 2 pi in THz

#: Points away from Gamma: random ones, zone-boundary ones and one outside the first zone.
AWAY = np.vstack([np.random.default_rng(7).uniform(-0.5, 0.5, (10, 3)),
                  [[0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.25, -0.5, 0.5], [1.3, -0.2, 0.4]]])
#: Gamma and points near it (the last is below phonopy's 1e-5 / Angstrom: Gamma itself).
NEAR = np.array([[0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [2e-4, 1e-4, -3e-4], [1e-7, 0.0, 0.0]])
DIRECTION = np.array([0.3, 0.1, 0.2])

#: Frequencies away from Gamma, relative per mode: both sides sum the same force-constant terms
#: in another order (~1e-15 relative in D, measured), and no mode is near zero there.
FREQUENCY_RTOL = 1e-10
#: At and near Gamma, signed squared frequencies (the eigenvalues of D) absolute relative to the
#: largest: LAPACK gives them to ~n eps ||D|| on both sides (3e-15 measured). Frequencies there
#: are not compared directly: at Gamma omega = sqrt(~eps ||D||) is rounding noise of size
#: sqrt(eps) omega_max (5e-8 measured); the bound implies |omega - omega'| <= 1e-6 omega_max.
GAMMA_ATOL = 1e-12
#: D(q) entries relative to the largest: rounding of sums of ~10^3 terms (2e-15 measured).
MATRIX_RTOL = 1e-12


def _load(name: str, symmetrize: bool) -> phonopy.Phonopy:
    folder = DATA / name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return phonopy.load(folder / "phonopy_disp.yaml", force_sets_filename=folder / "FORCE_SETS",
                            born_filename=folder / "BORN", symmetrize_fc=symmetrize, log_level=0)


@pytest.fixture(scope="module")
def polar() -> dict:
    """(name, symmetrize_fc) -> (phonopy object with nac_params, crystal from it, nac arguments)."""
    cache: dict = {}

    def get(name: str, symmetrize: bool):
        if (name, symmetrize) not in cache:
            phonon = _load(name, symmetrize)
            params = phonon.nac_params
            args = nac_from_phonopy(phonon)
            phonon.nac_params = None  # Crystal.from_phonopy reads the force constants alone
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                crystal = Crystal.from_phonopy(phonon)
            phonon.nac_params = params
            cache[name, symmetrize] = (phonon, crystal, args)
        return cache[name, symmetrize]

    return get


def _phonopy_frequencies(phonon, method: str, q, direction=None, lang=None):
    """phonopy's frequencies in THz: run_qpoints (its default backend), or its C kernels with lang="C"."""
    params = dict(phonon.nac_params)
    params["method"] = method
    phonon.nac_params = params
    if lang is None:
        phonon.run_qpoints(q, nac_q_direction=direction)
        return phonon.qpoints.frequencies
    return _frequencies(get_dynamical_matrices_at_qpoints(phonon.dynamical_matrix, np.asarray(q, dtype=float),
                                                          direction, lang=lang))


def _frequencies(matrices):
    values = np.linalg.eigvalsh(matrices)
    return np.sign(values) * np.sqrt(np.abs(values)) * THZ


def _squared(frequencies):
    return np.sign(frequencies) * frequencies ** 2


# ---------------------------------------------------------------------- phonopy
@pytest.mark.parametrize("symmetrize", [False, True])
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", CRYSTALS)
def test_frequencies_match_phonopy(polar, name, method, symmetrize):
    phonon, crystal, args = polar(name, symmetrize)
    nac = non_analytic(crystal, args["born"], args["dielectric"], factor=args["factor"], method=method,
                       phonon=phonon)
    truth = _phonopy_frequencies(phonon, method, AWAY)
    ours = _frequencies(nac_dynamical_matrices(crystal, nac, AWAY))
    assert (np.abs(ours - truth) <= FREQUENCY_RTOL * np.abs(truth)).all()
    top = np.abs(truth).max() ** 2
    for direction in (None, DIRECTION):
        ours = _squared(_frequencies(nac_dynamical_matrices(crystal, nac, NEAR, q_direction=direction)))
        # phonopy's C kernels use q_direction only where q is Gamma, as its docs say; its Rust
        # backend (phonors 0.8, the default) uses it at every q for Wang: compare with C there,
        # and with the default backend at Gamma itself (rows 0 and 3).
        truth = _squared(_phonopy_frequencies(phonon, method, NEAR, direction, lang="C"))
        assert np.abs(ours - truth).max() <= GAMMA_ATOL * top, direction
        truth = _squared(_phonopy_frequencies(phonon, method, NEAR, direction))
        rows = [0, 3] if method == "wang" and direction is not None else slice(None)
        assert np.abs(ours - truth)[rows].max() <= GAMMA_ATOL * top, direction


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", CRYSTALS)
def test_matrices_match_phonopy(polar, name, method):
    phonon, crystal, args = polar(name, False)
    nac = non_analytic(crystal, args["born"], args["dielectric"], factor=args["factor"], method=method,
                       phonon=phonon)
    params = dict(phonon.nac_params)
    params["method"] = method
    phonon.nac_params = params
    points = np.vstack([AWAY[:4], NEAR])
    for direction in (None, DIRECTION):
        ours = nac_dynamical_matrices(crystal, nac, points, q_direction=direction)
        # phonopy's batched builder (what run_qpoints uses), C kernels: the documented use of
        # q_direction (only where q is Gamma; see test_frequencies_match_phonopy)
        truth = get_dynamical_matrices_at_qpoints(phonon.dynamical_matrix, points, direction, lang="C")
        assert np.abs(ours - truth).max() <= MATRIX_RTOL * np.abs(truth).max()
    # the per-q DynamicalMatrix.run, its default backend, away from Gamma (near it, without a
    # direction, run() falls back to the full force constants where the batched path sums the
    # short-range ones and the Ewald sum: the two differ by O(|q|) there)
    ours = nac_dynamical_matrices(crystal, nac, AWAY)
    truth = []
    for q in AWAY:
        phonon.dynamical_matrix.run(q)
        truth.append(phonon.dynamical_matrix.dynamical_matrix)
    assert np.abs(ours - np.array(truth)).max() <= MATRIX_RTOL * np.abs(truth).max()


def test_splitting_needs_a_direction_at_gamma(polar):
    phonon, crystal, args = polar("NaCl", False)
    nac = non_analytic(crystal, args["born"], args["dielectric"], factor=args["factor"], phonon=phonon)
    plain = _frequencies(nac_dynamical_matrices(crystal, nac, [[0, 0, 0]]))[0]
    split = _frequencies(nac_dynamical_matrices(crystal, nac, [[0, 0, 0]], q_direction=[1, 0, 0]))[0]
    assert plain[5] - plain[3] < 1e-6 * plain[5]  # three degenerate optical modes
    assert split[5] - split[4] > 0.1 * split[5]  # LO above the two TO


def test_supercell_comes_from_to_phonopy_without_phonon():
    """Without a phonopy object the supercell is to_phonopy's (or the one given): the same
    correction as with that phonopy object, and the closed-form splitting at Gamma in any supercell."""
    crystal, _ = _diatomic("ASE")
    born, eps = np.array([np.eye(3), -np.eye(3)]), 2.0 * np.eye(3)
    q = np.vstack([AWAY[:3], [[0.0, 0.0, 0.0]]])
    for method in METHODS:
        alone = non_analytic(crystal, born, eps, method=method)
        given = non_analytic(crystal, born, eps, method=method, phonon=crystal.to_phonopy())
        assert np.array_equal(alone.supercell, given.supercell)
        first = nac_dynamical_matrices(crystal, alone, q, q_direction=[1, 0, 0])
        second = nac_dynamical_matrices(crystal, given, q, q_direction=[1, 0, 0])
        assert np.abs(first - second).max() <= 1e-14 * np.abs(first).max()
        larger = non_analytic(crystal, born, eps, method=method, supercell=(3, 3, 3))
        assert abs(round(np.linalg.det(larger.supercell))) == 27
        gamma = np.linalg.eigvalsh(nac_dynamical_matrices(crystal, larger, q[-1:], q_direction=[1, 0, 0]))
        assert np.abs(gamma - np.linalg.eigvalsh(second[-1:])).max() <= 1e-12 * gamma.max()


def test_correction_goes_with_the_crystals_force_constants(polar):
    """A crystal whose force constants were symmetrised, with the raw phonopy object: at Gamma
    without a direction (no correction) D is the crystal's own D(Gamma), not the raw one."""
    phonon, _, args = polar("ZnO", False)
    params = phonon.nac_params
    phonon.nac_params = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        symmetric = Crystal.from_phonopy(phonon, symmetrize=True)
    phonon.nac_params = params
    for method in METHODS:
        nac = non_analytic(symmetric, args["born"], args["dielectric"], method=method, phonon=phonon)
        ours = nac_dynamical_matrices(symmetric, nac, [[0, 0, 0]])
        own = dynamical_matrices(symmetric, [[0, 0, 0]])
        assert np.abs(ours - own).max() <= MATRIX_RTOL * np.abs(own).max()
        assert np.abs(np.linalg.eigvalsh(ours)[0, :3]).max() <= 1e-12 * np.abs(own).max()  # acoustic sum rule kept


def test_read_born_expands_like_phonopy(polar):
    for name in CRYSTALS:
        phonon, crystal, _ = polar(name, False)
        born, dielectric, factor = read_born(DATA / name / "BORN", crystal)
        params = phonon.nac_params
        assert np.array_equal(born, params["born"]) and np.array_equal(dielectric, params["dielectric"])
        assert factor == (None if name == "SnO2" else 14.4)


def test_nac_from_phonopy(polar):
    phonon, _, _ = polar("NaCl", False)
    args = nac_from_phonopy(phonon)
    assert sorted(args) == ["born", "dielectric", "factor", "method"]
    assert args["factor"] == 14.4 and args["born"].shape == (2, 3, 3)
    params = dict(phonon.nac_params)
    params["method"] = "wang"
    phonon.nac_params = params
    assert nac_from_phonopy(phonon)["method"] == "wang"


def test_sum_rule_is_imposed_and_reported(polar):
    _, crystal, args = polar("ZnO", False)
    nac = non_analytic(crystal, args["born"], args["dielectric"], factor=args["factor"])
    assert nac.sum_rule == pytest.approx(np.abs(args["born"].sum(axis=0)).max(), rel=1e-12)
    assert np.abs(nac.born.sum(axis=0)).max() < 1e-14
    kept = non_analytic(crystal, args["born"], args["dielectric"], sum_rule="keep")
    assert np.array_equal(kept.born, args["born"])


# ---------------------------------------------------------------------- closed form
def _diatomic(units: str):
    a, masses, k = {"ASE": (5.64, (22.99, 35.45), 1.5), "SI": (5.64e-10, (3.8e-26, 5.9e-26), 24.0),
                    "dimensionless": (1.0, (1.0, 3.0), 1.0)}[units]
    return rock_salt(a, masses, k, units=units), masses


@pytest.mark.parametrize("units", ["ASE", "SI", "dimensionless"])
@pytest.mark.parametrize("method", METHODS)
def test_rigid_ion_lo_to_splitting(units, method):
    """omega_LO^2 - omega_TO^2 = 4 pi factor Z^2 / (eps V mu) along any direction: LO along q^, TO across."""
    crystal, masses = _diatomic(units)
    charge, eps = 1.1, 2.4
    born = np.array([charge * np.eye(3), -charge * np.eye(3)])
    factor = 2.0 if units == "dimensionless" else None
    nac = non_analytic(crystal, born, eps * np.eye(3), method=method, factor=factor)
    assert nac.factor == {"ASE": FACTOR_ASE, "SI": FACTOR_SI, "dimensionless": 2.0}[units]
    mu = masses[0] * masses[1] / (masses[0] + masses[1])
    expected = 4 * np.pi * nac.factor * charge ** 2 / (eps * crystal.volume * mu)
    for cartesian in ([1.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.3, -0.2, 0.7]):
        unit = np.array(cartesian) / np.linalg.norm(cartesian)
        values, vectors = np.linalg.eigh(
            nac_dynamical_matrices(crystal, nac, [[0, 0, 0]], q_direction=unit @ crystal.cell.T)[0])
        # 6 x 6 eigenvalues to ~10 eps ||D||, and the splitting is of the size of ||D||
        assert values[5] - values[3] == pytest.approx(expected, rel=1e-12)
        assert values[4] - values[3] <= 1e-12 * values[5]
        for branch in (3, 4, 5):
            u = vectors[:3, branch]
            along = abs(np.vdot(unit, u))
            if branch == 5:
                assert np.linalg.norm(u - np.vdot(unit, u) * unit) <= 1e-10 * np.linalg.norm(u)
            else:
                assert along <= 1e-10 * np.linalg.norm(u)


def test_cell_phase_is_the_positions_phase_turned(polar):
    phonon, crystal, args = polar("ZnO", False)
    for method in METHODS:
        nac = non_analytic(crystal, args["born"], args["dielectric"], method=method, phonon=phonon)
        q = AWAY[:5]
        positions = nac_dynamical_matrices(crystal, nac, q)
        cell = nac_dynamical_matrices(crystal, nac, q, phase="cell")
        turn = np.exp(2j * np.pi * q @ crystal.fractional.T).repeat(3, axis=1)
        expected = turn[:, :, None] * positions * turn.conj()[:, None, :]
        assert np.abs(cell - expected).max() <= 1e-14 * np.abs(positions).max()
        assert np.abs(cell - np.conj(np.swapaxes(cell, 1, 2))).max() == 0.0


def test_chunks_do_not_change_the_result(polar, monkeypatch):
    phonon, crystal, args = polar("NaCl", False)
    q = np.random.default_rng(3).uniform(-0.5, 0.5, (40, 3))
    for method in METHODS:
        nac = non_analytic(crystal, args["born"], args["dielectric"], method=method, phonon=phonon)
        whole = nac_dynamical_matrices(crystal, nac, q)
        with monkeypatch.context() as patch:
            patch.setattr(nac_module, "CHUNK_ENTRIES", 1)
            patch.setattr(nac_module, "EWALD_ENTRIES", 1)
            pieces = nac_dynamical_matrices(crystal, nac, q)
        assert np.abs(whole - pieces).max() <= 1e-14 * np.abs(whole).max()


def test_result_is_frozen(polar):
    phonon, crystal, args = polar("NaCl", False)
    nac = non_analytic(crystal, args["born"], args["dielectric"], phonon=phonon)
    with pytest.raises(dataclasses.FrozenInstanceError):
        nac.method = "wang"  # type: ignore[misc]
    for array in (nac.born, nac.dielectric, nac.g_vectors, nac.dd_q0):
        with pytest.raises(ValueError):
            array[0] = 0  # type: ignore[index]
    assert "\n" not in repr(nac) and repr(nac).startswith("NonAnalytic('gonze', 2 atoms")


# ---------------------------------------------------------------------- bad inputs
@pytest.fixture(scope="module")
def salt():
    crystal, _ = _diatomic("ASE")
    return crystal, np.array([np.eye(3), -np.eye(3)]), 2.0 * np.eye(3)


def test_bad_born(salt):
    crystal, born, eps = salt
    with pytest.raises(ValueError, match=r"born must have shape \(2, 3, 3\)"):
        non_analytic(crystal, born[:1], eps)
    bad = born.copy()
    bad[1, 0, 0] = np.nan
    with pytest.raises(ValueError, match=r"born"):
        non_analytic(crystal, bad, eps)


def test_bad_dielectric(salt):
    crystal, born, _ = salt
    with pytest.raises(ValueError, match=r"dielectric must be the 3 x 3 tensor eps_inf"):
        non_analytic(crystal, born, np.eye(2))
    with pytest.raises(ValueError, match=r"dielectric is not symmetric: \|dielectric\[0,1\] - dielectric\[1,0\]\|"):
        non_analytic(crystal, born, [[2, 0.5, 0], [0, 2, 0], [0, 0, 2]])
    with pytest.raises(ValueError, match=r"dielectric is not positive definite \(lowest eigenvalue"):
        non_analytic(crystal, born, np.diag([2.0, -1.0, 2.0]))


def test_bad_method_factor_sum_rule(salt):
    crystal, born, eps = salt
    with pytest.raises(ValueError, match=r"method is 'ewald'; expected one of 'gonze', 'wang'"):
        non_analytic(crystal, born, eps, method="ewald")
    with pytest.raises(ValueError, match=r"factor"):
        non_analytic(crystal, born, eps, factor=-1.0)
    plain, _ = _diatomic("dimensionless")
    with pytest.raises(ValueError, match=r"dimensionless: give factor="):
        non_analytic(plain, born, eps)
    with pytest.raises(ValueError, match=r"sum_rule is 'maybe'"):
        non_analytic(crystal, born, eps, sum_rule="maybe")
    off = born.copy()
    off[0] *= 1.2  # misses the rule by 0.2 e
    with pytest.raises(ValueError, match=r"acoustic sum rule: \|sum_i Z\*_i\[0\]\[0\]\| = 0.2 e > 0.1 e"):
        non_analytic(crystal, off, eps)
    assert non_analytic(crystal, off, eps, sum_rule="force").sum_rule == pytest.approx(0.2)


def test_bad_phonon(polar, salt):
    crystal, born, eps = salt
    phonon, other, args = polar("NaCl", False)
    with pytest.raises(TypeError, match=r"phonon must be a phonopy.Phonopy, got dict"):
        non_analytic(crystal, born, eps, phonon={})
    with pytest.raises(ValueError, match=r"phonon's primitive cell .* is not the cell of crystal"):
        non_analytic(crystal, born, eps, phonon=phonon)
    zno, _, _ = polar("ZnO", False)
    with pytest.raises(ValueError, match=r"phonon's primitive cell has 4 atoms"):
        non_analytic(other, args["born"], args["dielectric"], phonon=zno)
    with pytest.raises(ValueError, match=r"give phonon or supercell, not both"):
        non_analytic(other, args["born"], args["dielectric"], phonon=phonon, supercell=(2, 2, 2))


def test_bad_dynamical_matrix_arguments(salt):
    crystal, born, eps = salt
    nac = non_analytic(crystal, born, eps)
    with pytest.raises(ValueError, match=r"q_direction must be 3 fractional .* not all zero"):
        nac_dynamical_matrices(crystal, nac, [[0, 0, 0]], q_direction=[0, 0, 0])
    with pytest.raises(ValueError, match=r"phase is 'atoms'"):
        nac_dynamical_matrices(crystal, nac, [[0, 0, 0]], phase="atoms")
    with pytest.raises(ValueError, match=r"qpoints must have shape"):
        nac_dynamical_matrices(crystal, nac, [[0, 0]])
    with pytest.raises(TypeError, match=r"nac must be a NonAnalytic"):
        nac_dynamical_matrices(crystal, {"born": born}, [[0, 0, 0]])
    single = Crystal.from_cell(np.eye(3), [[0, 0, 0]], [1.0], units="ASE")
    with pytest.raises(ValueError, match=r"nac was made for 2 atoms, crystal 'crystal' has 1"):
        nac_dynamical_matrices(single, nac, [[0, 0, 0]])


def test_bad_born_files(polar, tmp_path):
    _, crystal, _ = polar("SnO2", False)  # two independent atoms: Sn and O
    good = (DATA / "SnO2" / "BORN").read_text().splitlines()

    def write(lines) -> Path:
        path = tmp_path / "BORN"
        path.write_text("\n".join(lines) + "\n")
        return path

    with pytest.raises(ValueError, match=r"BORN: no such file"):
        read_born(tmp_path / "missing" / "BORN", crystal)
    with pytest.raises(ValueError, match=r"BORN: line 4: the charges end after 1 atom\(s\); .* 2 symmetry-independent"):
        read_born(write(good[:3]), crystal)
    with pytest.raises(ValueError, match=r"BORN: line 5: more charge lines than the 2 symmetry-independent"):
        read_born(write(good + good[2:3]), crystal)
    with pytest.raises(ValueError, match=r"BORN: line 3: 'x\.0942\d*' is not a number \(Z\* of atom 0\)"):
        read_born(write(good[:2] + ["x" + good[2].strip()[1:]] + good[3:]), crystal)
    with pytest.raises(ValueError, match=r"BORN: line 4 has 4 values; expected 9 numbers"):
        read_born(write(good[:3] + [" ".join(good[3].split()[:4])]), crystal)  # a cut file
    with pytest.raises(ValueError, match=r"BORN: line 2 has 3 values; expected 9 numbers \(eps_inf\)"):
        read_born(write(good[:1] + ["1 2 3"]), crystal)
    with pytest.raises(ValueError, match=r"BORN: line 1 is empty"):
        read_born(write([""] + good[1:]), crystal)
    with pytest.raises(ValueError, match=r"BORN: line 1 sets G_cutoff"):
        read_born(write(["14.4 0.5"] + good[1:]), crystal)


def test_nac_from_phonopy_refuses(salt):
    with pytest.raises(TypeError, match=r"phonon must be a phonopy.Phonopy"):
        nac_from_phonopy(salt[0])
    phonon = _load("ZnO", False)
    phonon.nac_params = None
    with pytest.raises(ValueError, match=r"phonon has no nac_params"):
        nac_from_phonopy(phonon)

