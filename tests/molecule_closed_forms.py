"""Closed-form harmonic wavenumbers of vibra's CO2 and H2O force fields, for the tests.

Independent of vibra's solvers and unit tables: masses from ``ase.data``, unit conversion with
``scipy.constants``, formulas from seed 003 (eq. 157), Herzberg (linear XY2 bend) and Wilson's
GF method (bent XY2).
"""

from __future__ import annotations

import numpy as np
from ase.data import atomic_masses, atomic_numbers
from numpy.typing import ArrayLike
from scipy import constants

M_O, M_C, M_H = (float(atomic_masses[atomic_numbers[s]]) for s in "OCH")

# Experimental fundamentals, cm^-1 (NIST CCCBDB, "Vibrational frequencies"; Herzberg, Molecular
# Spectra and Molecular Structure II): CO2 nu2 = 667, nu1 = 1333, nu3 = 2349; H2O nu2 = 1595,
# nu1 = 3657, nu3 = 3756.
CO2_EXPERIMENT = (667.0, 1333.0, 2349.0)
H2O_EXPERIMENT = (1595.0, 3657.0, 3756.0)


def cm1_from_eigenvalue(lam: ArrayLike) -> np.ndarray:
    """omega^2 in eV / (Angstrom^2 amu) to wavenumbers in cm^-1, with scipy.constants only."""
    omega = np.sqrt(np.asarray(lam, dtype=float) * constants.e / constants.angstrom**2 / constants.atomic_mass)
    return omega / (2 * np.pi * constants.c / constants.centi)


def co2_closed_form_cm1(stretch: float, bend: float, bond_length: float) -> np.ndarray:
    """Linear O=C=O, ascending cm^-1: the doubly degenerate bend, then the two stretches.

    Stretches: seed 003 eq. 157, omega^2 = kappa / m_O and kappa (1/m_O + 2/m_C). Bend (linear
    XY2, Herzberg): omega^2 = k_delta (2/m_O + 4/m_C) / L^2.
    """
    b = bend * (2 / M_O + 4 / M_C) / bond_length**2
    return cm1_from_eigenvalue([b, b, stretch / M_O, stretch * (1 / M_O + 2 / M_C)])


def h2o_closed_form_cm1(stretch: float, bend: float, bond_length: float, angle_deg: float) -> np.ndarray:
    """Bent XY2 with a simple valence force field (no interaction constants), ascending cm^-1.

    Wilson's GF method (Wilson, Decius & Cross, Molecular Vibrations, 1955; Herzberg II): with
    symmetry coordinates S1 = (r1 + r2)/sqrt2, S2 = theta (A1) and S3 = (r1 - r2)/sqrt2 (B2),
    G11 = 1/m_H + (1 + cos)/m_O, G22 = 2 (1/m_H + (1 - cos)/m_O) / r^2, G12 = -sqrt2 sin / (m_O r),
    G33 = 1/m_H + (1 - cos)/m_O; F = diag(k_r, k_theta, k_r).
    """
    theta = np.radians(angle_deg)
    g11 = 1 / M_H + (1 + np.cos(theta)) / M_O
    g22 = 2 * (1 / M_H + (1 - np.cos(theta)) / M_O) / bond_length**2
    g12 = -np.sqrt(2) * np.sin(theta) / (M_O * bond_length)
    g33 = 1 / M_H + (1 - np.cos(theta)) / M_O
    trace = stretch * g11 + bend * g22
    det = stretch * bend * (g11 * g22 - g12**2)
    root = np.sqrt(trace**2 - 4 * det)
    return np.sort(cm1_from_eigenvalue([(trace - root) / 2, (trace + root) / 2, stretch * g33]))
