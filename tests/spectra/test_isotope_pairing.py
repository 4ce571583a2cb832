"""Isotope shifts pair modes by shape (issue 31, item 2), not by rank.

Truth: closed forms of two oscillators on their own springs (sites 0 and 1, k0 and k1, no
coupling): each mode is one site's, omega = sqrt(k / m) (rad/s, SI); making site 0 four times
lighter moves its mode above the other's, so rank pairing would swap them.
"""

from __future__ import annotations

import numpy as np
import pytest

from vibra import System, molecules, spectra
from vibra.units import SI

K0, K1, M = 1.0e3, 1.5e3, 1.0e-3      # N/m, N/m, kg


def two_oscillators() -> System:
    return System.from_hessian([0.0, 1.0], M, np.diag([K0, K1]), units="SI")


def wavenumber(k: float, m: float) -> float:
    return float(SI.omega_to_cm1(np.sqrt(k / m)))


def test_a_mode_that_moves_past_another_keeps_its_partner() -> None:
    shifts = spectra.isotope_shifts(two_oscillators(), {0: M / 4})
    np.testing.assert_allclose(shifts.wavenumbers, [wavenumber(K0, M), wavenumber(K1, M)], rtol=1e-12)
    # site 0's mode doubles its frequency (now the higher one); site 1's does not move
    np.testing.assert_allclose(shifts.shifted_wavenumbers, [wavenumber(K0, M / 4), wavenumber(K1, M)], rtol=1e-12)
    np.testing.assert_allclose(shifts.ratios, [2.0, 1.0], rtol=1e-12)
    np.testing.assert_allclose(shifts.overlap, 1.0, atol=1e-12)
    assert not shifts.ambiguous.any()
    assert "overlap" in shifts.table()


def test_pairs_keep_their_symmetry_species() -> None:
    # 13C in CO2 keeps D-inf-h: the bend pair (Pi_u) stays degenerate and paired with itself, the
    # symmetric stretch (Sigma_g+, carbon at rest) does not move, the antisymmetric one falls
    shifts = spectra.isotope_shifts(molecules.co2(), {1: "13C"})
    assert shifts.shifts[2] == pytest.approx(0.0, abs=1e-6)
    assert shifts.shifts[0] == pytest.approx(shifts.shifts[1], rel=1e-9) and shifts.shifts[0] < 0
    assert np.all(shifts.overlap > 0.99) and not shifts.ambiguous.any()


def test_a_symmetry_breaking_substitution_is_flagged() -> None:
    # HDO: the symmetric and antisymmetric OH stretches of H2O become one OD and one OH stretch,
    # each half of both: neither pairing is clearly the one
    shifts = spectra.isotope_shifts(molecules.h2o(), {1: "D"})
    assert shifts.ambiguous.tolist() == [False, True, True]
    with pytest.raises(ValueError):
        shifts.overlap[0] = 0.0
