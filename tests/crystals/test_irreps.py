"""Irreducible representations of the Gamma modes, and their labels on band charts.

Truth: phonopy's own ``set_irreps`` at Gamma on its example crystals (its labels and degenerate
sets), the textbook labels of the optical modes of diamond (T2g, O_h) and zincblende (T2, T_d)
(Cardona and Yu, Fundamentals of Semiconductors, 4th ed., table 3.2 and section 3.3.2), and the
LO frequencies of the infrared response (`vibra.crystals.infrared`, itself tested against
phonopy's NAC in tests/crystals/test_infrared.py).
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import matplotlib
import numpy as np
import pytest

from vibra import crystals
from vibra.charts.crystals import LEVEL_RTOL, gamma_labels, plot_bands_dos
from vibra.crystals import Crystal, infrared_response
from vibra.crystals.irreps import GammaModes, NotPrimitiveError, gamma_modes

matplotlib.use("Agg")

DATA = "tests/data/phonopy"
EXAMPLES = ("NaCl", "MgO", "ZnO", "SnO2")


@lru_cache(maxsize=None)
def _example(name: str) -> tuple[Crystal, object, dict]:
    """(crystal with phonopy's force constants, phonopy without NAC, phonopy's nac_params)."""
    import phonopy

    folder = f"{DATA}/{name}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # phonopy's primitive_matrix='auto' notice
        phonon = phonopy.load(f"{folder}/phonopy_disp.yaml", force_sets_filename=f"{folder}/FORCE_SETS",
                              born_filename=f"{folder}/BORN", log_level=0)
    nac = dict(phonon.nac_params)
    phonon.nac_params = None
    return Crystal.from_phonopy(phonon, name=name), phonon, nac


@pytest.mark.parametrize("name", EXAMPLES)
def test_labels_are_phonopys(name: str) -> None:
    crystal, phonon, _ = _example(name)
    modes = gamma_modes(crystal)
    (phonon.run_irreps if hasattr(phonon, "run_irreps") else phonon.set_irreps)([0.0, 0.0, 0.0])
    theirs = phonon.irreps
    # the same degenerate sets, in the same order
    assert [len(s) for s in theirs._degenerate_sets] == np.bincount(modes.levels).tolist()
    for ours, label in zip(modes.level_labels(), theirs._ir_labels):
        if label is None:  # phonopy leaves a reducible level (the acoustic one of a polar crystal) unnamed
            assert "+" in ours
        else:
            assert ours == label
    assert modes.point_group == phonon.symmetry.dataset.pointgroup.strip()
    assert len(modes) == 3 * crystal.n_atoms


@pytest.mark.parametrize(("masses", "optical", "group"), [(28.09, "T2g", "m-3m"), ([28.09, 12.01], "T2", "-43m")])
def test_textbook_optical_labels(masses: object, optical: str, group: str) -> None:
    crystal = crystals.diamond(5.43, masses, 10.0, units="ASE")
    modes = gamma_modes(crystal)
    assert modes.point_group == group
    assert modes.level_labels()[-1] == optical
    assert modes.ir_active[-1] == (optical == "T2") and modes.raman_active[-1]  # T2g Raman only; T2 both


def test_conventional_cube_is_refused() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", crystals.ForceConstantsWarning)
        # phonopy's MgO yaml names no primitive matrix: the user's 8-atom conventional cube is kept
        cube = crystals.read_phonopy(f"{DATA}/MgO/phonopy_disp.yaml", force_sets=f"{DATA}/MgO/FORCE_SETS")
    assert cube.n_atoms == 8
    with pytest.raises(NotPrimitiveError, match="not a primitive cell"):
        gamma_modes(cube)
    assert issubclass(NotPrimitiveError, ValueError)


def test_bad_symprec() -> None:
    crystal = crystals.diamond(5.43, 28.09, 10.0, units="ASE")
    with pytest.raises(ValueError, match="symprec"):
        gamma_modes(crystal, symprec=0.0)


def test_result_protocol() -> None:
    modes = gamma_modes(crystals.diamond(5.43, 28.09, 10.0, units="ASE"))
    assert isinstance(modes, GammaModes)
    text = repr(modes)
    assert "\n" not in text and "m-3m" in text and len(text) < 200
    assert not modes.omega.flags.writeable
    np.testing.assert_allclose(modes.level_frequencies()[-1], modes.omega[-1], rtol=1e-12)


# ---------------------------------------------------------------------- labels on the band chart
def test_polar_band_labels_mark_lo_at_the_infrared_frequency() -> None:
    crystal, _, nac = _example("NaCl")
    polar = crystal.with_nac(nac["born"], nac["dielectric"], factor=nac["factor"])
    bands = polar.band_structure([["GAMMA", "X"], ["L", "GAMMA"]], npoints=21)
    modes = gamma_modes(polar)
    marks = gamma_labels(bands, modes, "cm^-1")
    assert sorted(label for _, _, label in marks) == ["LO", "LO", "T1u", "T1u"]  # two Gamma points
    response = infrared_response(crystal, nac["born"], nac["dielectric"], factor=nac["factor"])
    lo = float(response.lo_wavenumbers_cm1([1.0, 0.0, 0.0])[-1])
    to = float(crystal.units.omega_to_cm1(modes.omega[-1]))
    for _, value, label in marks:
        # the band's own Gamma value against the independent route (zeros of q.eps.q); both
        # are the same physics to rounding, 1e-9 leaves room for the unit conversions
        np.testing.assert_allclose(value, lo if label == "LO" else to, rtol=1e-9)


def test_analytic_bands_have_no_lo_label() -> None:
    crystal, _, _ = _example("ZnO")
    bands = crystal.band_structure(None, npoints=60)
    marks = gamma_labels(bands, gamma_modes(crystal), "THz")
    labels = {label for _, _, label in marks}
    assert "LO" not in labels and labels <= {"E2", "B1", "A1", "E1"}
    # every optical level of D(0) is marked at each Gamma of the path
    gammas = {x for x, _, _ in marks}
    assert len(marks) == 6 * len(gammas)
    assert 0 < LEVEL_RTOL < 1e-2


def test_chart_draws_the_labels() -> None:
    crystal = crystals.diamond(5.43, 28.09, 10.0, units="ASE")
    bands = crystal.band_structure(None, npoints=60)
    figure = plot_bands_dos(bands, None, unit="cm^-1", gamma=gamma_modes(crystal))
    texts = [t.get_text() for t in figure.axes[0].texts]
    assert texts and set(texts) == {"T2g"}
    plain = plot_bands_dos(bands, None, unit="cm^-1")
    assert not plain.axes[0].texts
