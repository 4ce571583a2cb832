"""Tests of vibra/units.py: conversions against scipy.constants and ase.units, validation messages."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from ase import units as ase_units
from scipy import constants

from vibra.units import ASE, DIMENSIONLESS, SI, UnitSystem, unit_system


def test_si_conversions_against_scipy_constants() -> None:
    omega = np.array([2.0 * np.pi * 1e12, -2.0 * np.pi])  # 1 THz and an imaginary 1 Hz mode
    np.testing.assert_allclose(SI.omega_to_hz(omega), [1e12, -1.0], rtol=1e-15)
    np.testing.assert_allclose(SI.omega_to_thz(omega), [1.0, -1e-12], rtol=1e-15)
    # 1 THz is 33.356 cm^-1 (c = 299792458 m/s) and 4.1357 meV (h = 4.135667696e-15 eV s).
    np.testing.assert_allclose(SI.omega_to_cm1(omega[:1]), [1e12 / (constants.c * 100)], rtol=1e-15)
    np.testing.assert_allclose(SI.omega_to_mev(omega[:1]), [constants.h * 1e12 / constants.e * 1e3], rtol=1e-14)
    np.testing.assert_allclose(SI.cm1_to_omega(SI.omega_to_cm1(omega)), omega, rtol=1e-15)


def test_ase_time_unit_against_ase() -> None:
    # ASE's time unit is Angstrom sqrt(amu / eV); ase.units.s is how many of them make a second.
    # CODATA 2014 (ase's default) against scipy's 2018 values: ~1e-8 relative.
    assert ASE.time_s == pytest.approx(1.0 / ase_units.s, rel=1e-7)
    assert ASE.omega_to_rad_per_s(1.0) == pytest.approx(ase_units.s, rel=1e-7)


def test_unit_names() -> None:
    assert (SI.stiffness, SI.force, SI.receptance, SI.omega) == ("N/m", "N", "m/N", "rad/s")
    assert (ASE.stiffness, ASE.force) == ("eV/Angstrom^2", "eV/Angstrom")
    assert (DIMENSIONLESS.stiffness, DIMENSIONLESS.receptance) == ("1", "dimensionless")


def test_unit_system_lookup_and_immutability() -> None:
    assert unit_system("si") is SI and unit_system("ASE") is ASE and unit_system(DIMENSIONLESS) is DIMENSIONLESS
    with pytest.raises(dataclasses.FrozenInstanceError):
        SI.name = "cgs"  # type: ignore[misc]


@pytest.mark.parametrize(
    ("units", "error", "match"),
    [
        (3, TypeError, r"units must be a str or UnitSystem, got int"),
        (None, TypeError, r"units must be a str or UnitSystem, got NoneType"),
        ("cgs", ValueError, r"units is 'cgs'; expected one of 'SI', 'ASE', 'dimensionless'"),
    ],
)
def test_unit_system_validation_messages(units: object, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        unit_system(units)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("convert", "what"),
    [
        (DIMENSIONLESS.omega_to_rad_per_s, "rad/s"),
        (DIMENSIONLESS.omega_to_hz, "rad/s"),
        (DIMENSIONLESS.omega_to_cm1, "rad/s"),
        (DIMENSIONLESS.cm1_to_omega, "cm\\^-1"),
    ],
)
def test_dimensionless_conversions_are_refused(convert, what: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=rf"cannot express {what}: the unit system is dimensionless; "
                                         r"build the system with units='SI' or 'ASE'"):
        convert(1.0)
    assert isinstance(DIMENSIONLESS, UnitSystem)
