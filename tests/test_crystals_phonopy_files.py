"""phonopy files both ways (issue 30, item 1): ``phonopy.yaml`` and ``FORCE_CONSTANTS``.

Truth: phonopy's own readers (``phonopy.load``, ``phonopy.file_IO.parse_FORCE_CONSTANTS``) and
its D(q) on what they read; round trips give back the crystal's frequencies to rounding (the
text files hold 15 significant digits: 1e-12 relative is what they allow).
"""

from __future__ import annotations

import numpy as np
import phonopy
import pytest
from phonopy.file_IO import parse_FORCE_CONSTANTS

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
    with pytest.raises(ValueError, match="bad.yaml: phonopy could not read it"):
        crystals.read_phonopy(bad)
    good = crystals.write_phonopy(silicon(), tmp_path / "phonopy.yaml", force_constants=False)
    with pytest.raises(ValueError, match="force_constants: .*nope"):
        crystals.read_phonopy(good, force_constants=tmp_path / "nope")
