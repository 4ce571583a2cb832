"""Tests of vibra.molecules.export: ASE VibrationsData round trip, Molden normal-mode files
parsed back against the format's definition (www.theochem.ru.nl/molden/molden_format.html),
mode trajectories read back with ase.io, and phonopy force constants read back by phonopy.
Truth: ASE (VibrationsData, its frequencies, ase.io), phonopy (parse_FORCE_CONSTANTS, its
Gamma-point frequencies), CODATA's bohr radius, and invariants (M-orthogonality of modes)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from ase.io import read
from ase.vibrations import VibrationsData
from scipy import constants

from vibra import System
from vibra import molecules as mol
from vibra.chains import linear_chain
from vibra.spectra import electronegativity_charges, ir_spectrum

BOHR = constants.physical_constants["Bohr radius"][0] * 1e10   # Angstrom


def _parse_molden(text: str) -> dict[str, list[str]]:
    """Sections of a Molden file: header line -> the lines below it, in file order."""
    sections: dict[str, list[str]] = {}
    current = None
    for line in text.splitlines():
        if line.startswith("["):
            current = line.split("]")[0] + "]"
            assert current not in sections, f"section {current} twice"
            sections[current] = []
        else:
            assert current is not None, "text before the first section"
            sections[current].append(line)
    return sections


def _unit_cartesian(analysis: mol.VibrationalAnalysis, masses: np.ndarray) -> np.ndarray:
    d = np.asarray(analysis.modes.vectors)[:, analysis.vibrations]
    u = d / np.sqrt(np.repeat(masses, 3))[:, None]      # seed 003 eq. 151: u = M^-1/2 d
    return u / np.linalg.norm(u, axis=0)


# ----------------------------------------------------------------- Molden
@pytest.mark.parametrize("build", [mol.co2, mol.h2o, lambda: mol.molecule("NH3")])
def test_molden_file_parsed_back_field_by_field(tmp_path: Path, build) -> None:
    system = build()
    analysis = mol.vibrational_analysis(system)
    symbols = mol.symbols_from_masses(system.masses)
    path = mol.write_molden(tmp_path / "out" / "mode.molden", system, analysis)
    text = path.read_text(encoding="ascii")
    assert text.splitlines()[0] == "[Molden Format]"
    sections = _parse_molden(text)
    assert list(sections) == ["[Molden Format]", "[FREQ]", "[FR-COORD]", "[FR-NORM-COORD]"]
    assert sections["[Molden Format]"] == []
    n_vib, n_atoms = analysis.n_vibrations, system.n_sites
    freq = np.array([float(line) for line in sections["[FREQ]"]])
    np.testing.assert_allclose(freq, analysis.vibration_wavenumbers_cm1(), rtol=0, atol=1e-6)
    coord = [line.split() for line in sections["[FR-COORD]"]]
    assert [row[0] for row in coord] == list(symbols)
    bohr = np.array([[float(v) for v in row[1:]] for row in coord])
    np.testing.assert_allclose(bohr * BOHR, system.positions, rtol=0, atol=1e-9)
    lines = sections["[FR-NORM-COORD]"]
    assert len(lines) == n_vib * (n_atoms + 1)
    expected = _unit_cartesian(analysis, np.asarray(system.masses))
    vectors = []
    for k in range(n_vib):
        block = lines[k * (n_atoms + 1):(k + 1) * (n_atoms + 1)]
        assert block[0].split() == ["vibration", str(k + 1)]
        vector = np.array([[float(v) for v in row.split()] for row in block[1:]]).ravel()
        assert np.linalg.norm(vector) == pytest.approx(1.0, abs=1e-9)
        vectors.append(vector)
    vectors_array = np.array(vectors).T
    # same Cartesian displacements up to a rotation inside each degenerate set: the projector
    # onto the span of each set of equal frequencies agrees
    for w in np.unique(np.round(freq, 3)):
        chosen = np.flatnonzero(np.round(freq, 3) == w)
        a, b = vectors_array[:, chosen], expected[:, chosen]
        np.testing.assert_allclose(a @ np.linalg.pinv(a), b @ np.linalg.pinv(b), atol=1e-8)
    # physical meaning: mass-weighted, the written normal coordinates are orthogonal
    weighted = vectors_array * np.sqrt(np.repeat(np.asarray(system.masses), 3))[:, None]
    gram = weighted.T @ weighted
    assert np.abs(gram - np.diag(np.diag(gram))).max() < 1e-8


def test_molden_int_section_from_vibra_spectra(tmp_path: Path) -> None:
    system = mol.co2()
    analysis = mol.vibrational_analysis(system)
    symbols = ["O", "C", "O"]
    spectrum = ir_spectrum(system, analysis, charges=electronegativity_charges(symbols, [[0, 1], [1, 2]]))
    intensities = spectrum.intensities_km_per_mol()
    path = mol.write_molden(tmp_path / "co2.molden", system, analysis, symbols=symbols, intensities=intensities)
    sections = _parse_molden(path.read_text())
    # [INT] right after [FREQ]: Open Babel's reader skips it anywhere after [FR-NORM-COORD]
    assert list(sections) == ["[Molden Format]", "[FREQ]", "[INT]", "[FR-COORD]", "[FR-NORM-COORD]"]
    np.testing.assert_allclose([float(v) for v in sections["[INT]"]], intensities, rtol=1e-7, atol=1e-8)


def test_molden_with_plain_modes_leaves_out_rigid_motion(tmp_path: Path) -> None:
    system = mol.h2o()
    path = mol.write_molden(tmp_path / "h2o.molden", system, system.modes())
    assert len(_parse_molden(path.read_text())["[FREQ]"]) == 3


def test_symbols_of_isotopes_are_their_elements(tmp_path: Path) -> None:
    system = mol.co2(isotopes=["18O", "13C", None])   # 18O is nearer F's standard mass
    path = mol.write_molden(tmp_path / "x.molden", system, mol.vibrational_analysis(system))
    sections = _parse_molden(path.read_text())
    assert [line.split()[0] for line in sections["[FR-COORD]"]] == ["O", "C", "O"]


# ----------------------------------------------------------------- ASE VibrationsData
@pytest.mark.parametrize("build", [mol.co2, mol.h2o, lambda: mol.molecule("CH4", isotopes={1: "D"})])
def test_vibrations_data_round_trip(build) -> None:
    system = build()
    data = mol.to_vibrations_data(system)
    assert isinstance(data, VibrationsData)
    back = mol.from_vibrations_data(data)
    K, K_back = system.hessian().toarray(), back.hessian().toarray()
    assert np.abs(K_back - K).max() <= 1e-12 * np.abs(K).max()
    np.testing.assert_allclose(back.positions, system.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.masses, system.masses, rtol=1e-12)


def test_vibrations_data_from_analysis_gives_ase_the_same_frequencies() -> None:
    system = mol.molecule("NH3")
    analysis = mol.vibrational_analysis(system)
    data = mol.to_vibrations_data(system, analysis)
    ase_cm1 = np.sort(data.get_frequencies().real)         # ASE's own diagonalisation
    vib = analysis.vibration_wavenumbers_cm1()
    # 1e-8: ASE converts with CODATA 2014 constants, vibra with scipy's (a 4.6e-9 offset)
    np.testing.assert_allclose(ase_cm1[-len(vib):], vib, rtol=1e-8)
    assert np.abs(ase_cm1[:-len(vib)]).max() < 1e-4          # translations and rotations at zero


def test_vibrations_data_of_a_partly_frozen_molecule() -> None:
    system = mol.h2o().freeze(sites=[0])
    data = mol.to_vibrations_data(system)
    assert data.get_indices().tolist() == [1, 2]
    back = mol.from_vibrations_data(data)
    assert back.frozen.tolist() == system.frozen.tolist()
    assert np.abs(back.hessian().toarray() - system.hessian().toarray()).max() <= 1e-12


# ----------------------------------------------------------------- trajectories
@pytest.mark.parametrize("suffix", [".traj", ".xyz"])
def test_mode_trajectory_read_back_by_ase(tmp_path: Path, suffix: str) -> None:
    system = mol.h2o()
    analysis = mol.vibrational_analysis(system)
    path = mol.write_mode_trajectory(tmp_path / f"bend{suffix}", system, analysis, 0, n_frames=12, amplitude=0.2)
    frames = read(path, ":")
    assert len(frames) == 12
    shape = _unit_cartesian(analysis, np.asarray(system.masses))[:, 0].reshape(3, 3)
    shape /= np.linalg.norm(shape, axis=1).max()
    sign = np.sign(np.sum((frames[3].get_positions() - system.positions) * shape))   # a mode's sign is free
    atol = 1e-12 if suffix == ".traj" else 1e-7     # extxyz stores 8 decimals
    for f, frame in enumerate(frames):
        assert frame.get_chemical_symbols() == ["O", "H", "H"]
        displacement = frame.get_positions() - system.positions
        expected = sign * 0.2 * np.sin(2 * np.pi * f / 12) * shape
        assert np.abs(displacement - expected).max() < atol
    largest = max(np.linalg.norm(frame.get_positions() - system.positions, axis=1).max() for frame in frames)
    assert largest == pytest.approx(0.2, abs=atol)
    if suffix == ".xyz":
        assert frames[1].info["wavenumber_cm1"] == pytest.approx(analysis.vibration_wavenumbers_cm1()[0])


# ----------------------------------------------------------------- phonopy
def test_force_constants_read_back_by_phonopy(tmp_path: Path) -> None:
    from phonopy import Phonopy
    from phonopy.file_IO import parse_FORCE_CONSTANTS
    from phonopy.structure.atoms import PhonopyAtoms

    system = mol.molecule("NH3")
    path = mol.write_force_constants(tmp_path / "FORCE_CONSTANTS", system)
    fc = parse_FORCE_CONSTANTS(str(path))
    n = system.n_sites
    assert fc.shape == (n, n, 3, 3)
    K = system.hessian().toarray()
    assert np.abs(fc.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n) - K).max() < 1e-9 * np.abs(K).max()
    box = 20.0
    cell = PhonopyAtoms(symbols=["N", "H", "H", "H"], masses=system.masses,
                        positions=np.asarray(system.positions) + box / 2, cell=np.eye(3) * box)
    phonon = Phonopy(cell, supercell_matrix=np.eye(3, dtype=int), primitive_matrix="P", is_symmetry=False)
    phonon.force_constants = fc
    phonon.run_qpoints([[0, 0, 0]])
    thz = np.sort(phonon.qpoints.frequencies[0])
    phonopy_cm1 = thz * 1e12 / (constants.c * 100)
    vibra_cm1 = mol.vibrational_analysis(system).vibration_wavenumbers_cm1()
    # 1e-6: phonopy's THz factor is built from its own (older) constants, a 1.2e-7 offset
    np.testing.assert_allclose(phonopy_cm1[-6:], vibra_cm1, rtol=1e-6)


# ----------------------------------------------------------------- bad input
def test_export_refuses_non_molecular_systems(tmp_path: Path) -> None:
    chain = linear_chain(4)
    with pytest.raises(ValueError, match="units is 'SI'.*units 'ASE'"):
        mol.to_vibrations_data(chain)
    axial = mol.co2(dims=1)
    with pytest.raises(ValueError, match="1-D sites"):
        mol.write_molden(tmp_path / "a.molden", axial, axial.modes())
    generalized = System.generalized(np.eye(2), np.eye(2), units="ASE")
    with pytest.raises(TypeError, match="generalised"):
        mol.write_force_constants(tmp_path / "FC", generalized)
    with pytest.raises(TypeError, match="must be a vibra System"):
        mol.write_force_constants(tmp_path / "FC", "CO2")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="frozen"):
        mol.write_molden(tmp_path / "f.molden", mol.h2o().freeze(sites=[0]), mol.h2o().freeze(sites=[0]).modes())
    with pytest.raises(ValueError, match="some but not all"):
        mol.to_vibrations_data(mol.h2o().freeze(dofs=[0]))


def test_export_refuses_bad_modes_index_and_options(tmp_path: Path) -> None:
    system = mol.co2()
    analysis = mol.vibrational_analysis(system)
    with pytest.raises(ValueError, match=r"index is 4; the 4 vibrations are numbered 0 to 3"):
        mol.write_mode_trajectory(tmp_path / "m.traj", system, analysis, 4)
    with pytest.raises(ValueError, match=r"index is -1"):
        mol.write_mode_trajectory(tmp_path / "m.traj", system, analysis, -1)
    with pytest.raises(ValueError, match=r"index is 9; the 9 modes"):
        mol.write_mode_trajectory(tmp_path / "m.traj", system, system.modes(), 9)
    with pytest.raises(ValueError, match=r"'\.pdb'"):
        mol.write_mode_trajectory(tmp_path / "m.pdb", system, analysis, 0)
    with pytest.raises(ValueError, match="n_frames"):
        mol.write_mode_trajectory(tmp_path / "m.traj", system, analysis, 0, n_frames=1)
    with pytest.raises(ValueError, match="amplitude"):
        mol.write_mode_trajectory(tmp_path / "m.traj", system, analysis, 0, amplitude=0.0)
    with pytest.raises(ValueError, match="modes of this system"):
        mol.write_molden(tmp_path / "m.molden", system, mol.h2o().freeze(sites=[0]).modes())
    with pytest.raises(ValueError, match="intensities must give 4 values"):
        mol.write_molden(tmp_path / "m.molden", system, analysis, intensities=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"symbols\[1\] is 'Xx'"):
        mol.write_molden(tmp_path / "m.molden", system, analysis, symbols=["O", "Xx", "O"])
    with pytest.raises(ValueError, match="holds 4 of the 9 modes"):
        mol.to_vibrations_data(system, dataclasses.replace(
            analysis.modes, omega=analysis.modes.omega[5:], vectors=analysis.modes.vectors[:, 5:],
            shapes=analysis.modes.shapes[:, 5:], omega_error=analysis.modes.omega_error[5:]))


def test_unwritable_path_raises_and_leaves_nothing(tmp_path: Path) -> None:
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("a file where a folder should be")
    system = mol.h2o()
    with pytest.raises(OSError):
        mol.write_molden(blocker / "h2o.molden", system, mol.vibrational_analysis(system))
    with pytest.raises(OSError):
        mol.write_force_constants(blocker / "FORCE_CONSTANTS", system)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["not_a_folder"]


def test_a_failed_write_keeps_the_old_file(tmp_path: Path) -> None:
    system = mol.h2o()
    target = tmp_path / "h2o.molden"
    target.write_text("old")
    with pytest.raises(ValueError):
        mol.write_molden(target, system, mol.vibrational_analysis(system), intensities=[-1.0, 0.0, 0.0])
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["h2o.molden"]
