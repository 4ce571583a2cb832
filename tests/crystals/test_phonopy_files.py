"""phonopy files both ways (issue 30, item 1): ``phonopy.yaml`` and ``FORCE_CONSTANTS``.

Truth: phonopy's own readers (``phonopy.load``, ``phonopy.file_IO.parse_FORCE_CONSTANTS``) and
its D(q) on what they read; round trips give back the crystal's frequencies to rounding (the
text files hold 15 significant digits: 1e-12 relative is what they allow).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import phonopy
import pytest
from phonopy.file_IO import parse_FORCE_CONSTANTS

from helpers.phonopy_files import write_force_sets
from vibra import crystals

Q = np.random.default_rng(31).random((40, 3))
RTOL = 1e-10


def silicon():
    return crystals.diamond(5.43, 28.09, 10.0, shells=2, transverse=[1.0, 0.5], units="ASE")


def test_yaml_round_trip_and_phonopy_reads_it(tmp_path) -> None:
    crystal = silicon()
    path = crystals.write_phonopy(crystal, tmp_path / "phonopy.yaml")
    back = crystals.read_phonopy(path)
    np.testing.assert_allclose(back.frequencies(Q), crystal.frequencies(Q), rtol=RTOL)
    phonon = phonopy.load(path, log_level=0)            # phonopy itself, with its own defaults
    phonon.run_qpoints(Q)
    ours = crystal.phonons(Q).frequencies_thz()
    np.testing.assert_allclose(ours, phonon.qpoints.frequencies, rtol=1e-6)  # phonopy's older constants


def test_force_constants_file_round_trip(tmp_path) -> None:
    crystal = silicon()
    structure = crystals.write_phonopy(crystal, tmp_path / "phonopy.yaml", force_constants=False)
    fc_path = crystals.write_force_constants(crystal, tmp_path / "FORCE_CONSTANTS")
    written = parse_FORCE_CONSTANTS(fc_path)
    assert np.array_equal(written.shape[2:], (3, 3))
    np.testing.assert_allclose(written, crystal.to_phonopy().force_constants, atol=1e-14)
    back = crystals.read_phonopy(structure, force_constants=fc_path)
    np.testing.assert_allclose(back.frequencies(Q), crystal.frequencies(Q), rtol=RTOL)


def test_symmetrize_imposes_the_acoustic_sum_rule(tmp_path) -> None:
    phonon = silicon().to_phonopy()
    # a sum-rule error as finite differences leave it: translation-invariant (the same for every
    # supercell copy of an atom), here in the self terms, symmetric so the index symmetry holds
    rng = np.random.default_rng(5)
    error = rng.normal(size=(2, 3, 3)) * 1e-3
    error = error + error.transpose(0, 2, 1)
    noisy = np.array(phonon.force_constants)
    atom = [phonon.primitive.p2p_map[s] for s in phonon.primitive.s2p_map]
    for s, a in enumerate(atom):
        noisy[s, s] += error[a]
    phonon.force_constants = noisy
    raw = crystals.from_phonopy(phonon)
    fixed = crystals.from_phonopy(phonon, symmetrize=True)
    gamma = [[0.0, 0.0, 0.0]]
    assert np.abs(raw.frequencies(gamma)[0, :3]).max() > 1e-3     # the noise breaks the rule...
    assert np.abs(fixed.frequencies(gamma)[0, :3]).max() < 1e-6   # ...the projection restores it
    assert np.array_equal(phonon.force_constants, noisy)           # phonopy's object untouched


def test_bad_files_name_the_file(tmp_path) -> None:
    with pytest.raises(ValueError, match="no such phonopy yaml file"):
        crystals.read_phonopy(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("this: [is not phonopy\n")
    with pytest.raises(ValueError, match=r"bad.yaml: line 2: not valid YAML \(.*\); the file looks cut or damaged"):
        crystals.read_phonopy(bad)
    bad.write_text("this: is not phonopy\n")
    with pytest.raises(ValueError, match="bad.yaml: holds no unit_cell section"):
        crystals.read_phonopy(bad)
    good = crystals.write_phonopy(silicon(), tmp_path / "phonopy.yaml", force_constants=False)
    with pytest.raises(ValueError, match="force_constants: .*nope"):
        crystals.read_phonopy(good, force_constants=tmp_path / "nope")


# ---------------------------------------------------------------------- issue 34: whole files
@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """phonopy's own files for the silicon model: yaml with force constants, structure alone,
    FORCE_CONSTANTS, and a displacement yaml with its FORCE_SETS (forces -Phi u from phonopy's
    own force constants: exact for springs)."""
    folder = tmp_path_factory.mktemp("phonopy")
    crystal = silicon()
    out = {"yaml": crystals.write_phonopy(crystal, folder / "phonopy.yaml"),
           "structure": folder / "structure.yaml", "FORCE_CONSTANTS": folder / "FORCE_CONSTANTS"}
    dataset = write_force_sets(crystal, folder)
    with_forces = crystal.to_phonopy()
    with_forces.dataset = dataset
    with_forces.save(str(folder / "phonopy_params.yaml"))
    out.update(FORCE_SETS=folder / "FORCE_SETS", disp=folder / "phonopy_disp.yaml", params=folder / "phonopy_params.yaml")
    return out


def test_every_whole_file_reads_back_the_crystal(files: dict[str, Path]) -> None:
    reference = silicon().frequencies(Q)
    for crystal, rtol in ((crystals.read_phonopy(files["yaml"]), RTOL),
                          (crystals.read_phonopy(files["structure"], force_constants=files["FORCE_CONSTANTS"]), RTOL),
                          (crystals.read_phonopy(files["params"]), 1e-8),  # force constants from forces: 15 digits
                          (crystals.read_phonopy(files["disp"], force_sets=files["FORCE_SETS"]), 1e-8)):
        np.testing.assert_allclose(crystal.frequencies(Q), reference, rtol=rtol)


def test_nothing_is_read_from_the_current_directory(files: dict[str, Path], tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    # phonopy.load reads FORCE_SETS / FORCE_CONSTANTS / BORN from the current directory when the
    # yaml lacks them: the same call gave a crystal in one folder and an error in another
    monkeypatch.chdir(files["yaml"].parent)  # FORCE_SETS and FORCE_CONSTANTS lie here
    with pytest.raises(ValueError, match=r"phonopy_disp.yaml: holds no force constants and no forces; give the "
                                         r"FORCE_CONSTANTS file \(force_constants=\) or the FORCE_SETS file"):
        crystals.read_phonopy(files["disp"])
    (tmp_path / "BORN").write_text("14.4\n1 0 0 0 1 0 0 0 1\n")
    monkeypatch.chdir(tmp_path)
    crystal = crystals.read_phonopy(files["yaml"])  # no BORN is read: no refusal for nac_params
    np.testing.assert_allclose(crystal.frequencies(Q), silicon().frequencies(Q), rtol=RTOL)


def _cut(path: Path, target: Path, fraction: float, at_line: bool) -> Path:
    text = path.read_text()
    n = int(len(text) * fraction) if fraction > 0 else len(text) + int(fraction)  # < 0: drop that many characters
    if at_line:
        n = text.rfind("\n", 0, n) + 1
    target.write_text(text[:n])
    return target


#: (file, where it is cut (fraction of its characters, or minus the characters dropped from the end),
#: whether at a line end, fragment of the refusal)
CUTS = [
    ("yaml", 0.3, False, r"line \d+: not valid YAML \(did not find expected ',' or '\]'\); the file looks cut"),
    ("yaml", 0.5, True, r"line 281: force_constants has shape \[54, 54\] \(2916 blocks\) but holds \d+; the file looks cut"),
    ("yaml", 0.999, True, r"line 281: force_constants has shape \[54, 54\] \(2916 blocks\) but holds 2913; the file looks cut"),
    ("params", 0.3, True, r"line 58: the supercell section holds 14 points; the unit cell's 2 atoms and the matrices "
                          r"give 54; the file looks cut"),
    ("params", 0.999, True, r"line 281: displacement 1 of 1 has 53 force rows; the supercell has 54 atoms"),
    ("FORCE_CONSTANTS", 0.3, True, r"line 3507: block 877 of 2916 stops after 2 of its 4 lines; the header \(line 1\) "
                                   r"announces 54 x 54 blocks; the file looks cut"),
    ("FORCE_CONSTANTS", 0.7, False, r"line 8169: is '-4.749999999999999     0.000000000000000'; a force-constant row "
                                    r"reads 3 numbers; the file looks cut"),
    ("FORCE_CONSTANTS", -5, False, r"line 11665: the last line has no line break, so its last number may be cut"),
    ("FORCE_SETS", 0.5, True, r"line 31: the file ends within displacement 1 of 1 \(line 2 announces them; 26 of its "
                              r"54 force rows read\); the file looks cut"),
    ("FORCE_SETS", -5, False, r"line 59: the last line has no line break"),
]


@pytest.mark.parametrize("name, fraction, at_line, fragment", CUTS,
                         ids=[f"{c[0]}-{c[1]}{'-line' if c[2] else ''}" for c in CUTS])
def test_a_cut_file_is_refused_naming_it_and_what_is_missing(name: str, fraction: float, at_line: bool, fragment: str,
                                                            files: dict[str, Path], tmp_path: Path) -> None:
    source = files[name]
    cut = _cut(source, tmp_path / source.name, fraction, at_line)
    with pytest.raises(ValueError, match=f"^{re.escape(str(cut))}: {fragment}") as raised:
        if name == "FORCE_CONSTANTS":
            crystals.read_phonopy(files["structure"], force_constants=cut)
        elif name == "FORCE_SETS":
            crystals.read_phonopy(files["disp"], force_sets=cut)
        else:
            crystals.read_phonopy(cut)
    assert "\n" not in str(raised.value)


def test_files_of_another_supercell_and_other_refusals(files: dict[str, Path], tmp_path: Path) -> None:
    lines = files["FORCE_CONSTANTS"].read_text().splitlines(keepends=True)
    more = tmp_path / "FORCE_CONSTANTS"
    more.write_text("".join(lines) + lines[1] + "".join(lines[2:5]))
    with pytest.raises(ValueError, match=r"the file holds 2917 whole blocks; the header \(line 1\) announces 54 x 54 = 2916"):
        crystals.read_phonopy(files["structure"], force_constants=more)
    other = crystals.write_force_constants(silicon(), tmp_path / "FC_OTHER", supercell=(4, 4, 4))
    with pytest.raises(ValueError, match=r"FC_OTHER: line 1: holds 128 x 128 blocks; the supercell of the yaml has 54 atoms"):
        crystals.read_phonopy(files["structure"], force_constants=other)
    with pytest.raises(ValueError, match="give force_constants= or force_sets=, not both"):
        crystals.read_phonopy(files["disp"], force_constants=files["FORCE_CONSTANTS"], force_sets=files["FORCE_SETS"])
    nac = tmp_path / "nac.yaml"
    phonon = silicon().to_phonopy()  # phonopy's own yaml with Born charges and the dielectric tensor
    phonon.nac_params = {"born": np.zeros((2, 3, 3)), "dielectric": np.eye(3) * 11.7, "factor": 14.4}
    phonon.save(str(nac))
    polar = crystals.read_phonopy(nac)          # the yaml's nac section is read (issue 42), not refused
    assert polar.nac is not None and polar.nac.method == "gonze" and np.allclose(polar.nac.dielectric, 11.7 * np.eye(3))


def test_from_phonopy_refuses_born_charges_off_the_sum_rule_in_one_line() -> None:
    phonon = silicon().to_phonopy()
    phonon.nac_params = {"born": np.array([np.eye(3)] * 2), "dielectric": np.eye(3), "factor": 14.4}
    with pytest.raises(ValueError, match=r"^born misses the acoustic sum rule: \|sum_i Z\*_i\[0\]\[0\]\| = 2 e > 0.1 e") as raised:
        crystals.from_phonopy(phonon)
    assert "\n" not in str(raised.value) and "sum_rule='force'" in str(raised.value)
    assert crystals.from_phonopy(phonon, nac=False).nac is None    # the force constants alone


# ---------------------------------------------------------------------- phonopy's own FORCE_CONSTANTS writer
REAL = Path(__file__).resolve().parents[1] / "data" / "phonopy" / "NaCl"


@pytest.fixture(scope="module")
def phonopy_written(tmp_path_factory) -> dict[str, Path]:
    """NaCl's force constants written by phonopy's own write_FORCE_CONSTANTS, full and compact
    (phonopy ends these files without a line break)."""
    import warnings

    from phonopy.file_IO import write_FORCE_CONSTANTS

    folder = tmp_path_factory.mktemp("phonopy_fc")
    files = {}
    for compact in (False, True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            phonon = phonopy.load(REAL / "phonopy_disp.yaml", force_sets_filename=REAL / "FORCE_SETS",
                                  is_compact_fc=compact, is_nac=False, log_level=0)
        path = folder / ("FORCE_CONSTANTS_compact" if compact else "FORCE_CONSTANTS_full")
        write_FORCE_CONSTANTS(phonon.force_constants, str(path),
                              p2s_map=phonon.primitive.p2s_map if compact else None)
        files["compact" if compact else "full"] = path
        files["phonon"] = phonon  # type: ignore[assignment]  (the two hold the same force constants)
    return files


@pytest.mark.parametrize("kind", ["full", "compact"])
def test_phonopy_s_own_force_constants_file_is_read(phonopy_written: dict, kind: str) -> None:
    path = phonopy_written[kind]
    assert not path.read_text().endswith("\n")  # phonopy's writer: "\n".join(lines), no final break
    crystal = crystals.read_phonopy(REAL / "phonopy_disp.yaml", force_constants=path, symmetrize=False)
    phonon = phonopy_written["phonon"]
    q = [[0.1, 0.2, 0.3], [0.5, 0.0, 0.5]]
    phonon.run_qpoints(q)
    from phonopy.physical_units import get_physical_units

    # the same force constants in both codes: equal to rounding (1e-10 relative away from Gamma, issue 42)
    # in phonopy's own unit conversion (its CODATA differs from scipy's by 1.2e-7)
    np.testing.assert_allclose(crystal.frequencies(q) * get_physical_units().DefaultToTHz,
                               phonon.qpoints.frequencies, rtol=1e-10)


@pytest.mark.parametrize("line, text, message", [
    (9, "1 7", r"line 10: block 3 is the pair '1 7'; phonopy's order puts '1 3' there"),
    (257, "1 1", r"line 258: block 65 is the pair '1 1'; its first atom should be above 1 \(line 2\)"),
    (21, "1.5 6", r"line 22: block 6 is the pair '1\.5 6'; an atom pair is two whole atom numbers"),
    (5, "2 2", r"line 6: block 2 is the pair '2 2'; phonopy's order puts '1 2' there \(its row starts with atom 1 "
               r"at line 2"),
])
def test_a_block_out_of_place_is_refused(phonopy_written: dict, tmp_path: Path, line: int, text: str,
                                         message: str) -> None:
    lines = phonopy_written["compact"].read_text().splitlines(keepends=True)
    lines[line] = text + "\n"
    bad = tmp_path / "FORCE_CONSTANTS"
    bad.write_text("".join(lines))
    with pytest.raises(ValueError, match=message):
        crystals.read_phonopy(REAL / "phonopy_disp.yaml", force_constants=bad)


def test_a_cut_last_number_of_phonopy_s_file_is_still_refused(phonopy_written: dict, tmp_path: Path) -> None:
    cut = tmp_path / "FORCE_CONSTANTS"
    cut.write_text(phonopy_written["compact"].read_text()[:-5])
    with pytest.raises(ValueError, match=r"the last line has no line break, so its last number may be cut"):
        crystals.read_phonopy(REAL / "phonopy_disp.yaml", force_constants=cut)
