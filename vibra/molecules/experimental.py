"""Experimental vibrational fundamentals of the bundled molecules, each with its source.

Values in cm^-1 (gas phase, observed fundamentals), from T. Shimanouchi, *Tables of Molecular
Vibrational Frequencies, Consolidated Volume I*, NSRDS-NBS 39, National Bureau of Standards
(1972), as listed by the NIST Computational Chemistry Comparison and Benchmark Database
(CCCBDB, https://cccbdb.nist.gov, "Experimental vibrational frequencies") and the NIST
Chemistry WebBook. Each entry names the fundamental (nu1, nu2, ...), its symmetry species in
the labels of `vibra.molecules.mode_species` and its wavenumber.

CO2's nu1 (Sigma_g+) is in Fermi resonance with 2 nu2; Shimanouchi's 1333 cm^-1 is the
unperturbed value between the observed 1285 and 1388 cm^-1 doublet.

Gas-phase IR intensities (integrated band intensities, km/mol), where a value could be
sourced (each read in a stored copy of its source, the public web-page corpus this project
searches, not recalled):

- H2O, all three: the NIST CCCBDB page "Experimental data for H2O (Water)" (Release 18,
  October 2016, https://cccbdb.nist.gov/exp2x.asp?casno=7732185, "Vibrational levels") lists
  2.9 (nu1) and 62.5 (nu2) km/mol with the reference it codes 1992Cul/Lie:502, and 41.7 (nu3).
- CH4, nu4 (T2) only: D. E. Jennings and A. G. Robiette, "Determination of the nu4 band strength
  of 12CH4 from diode laser line strength measurements", J. Mol. Spectrosc. 94, 369-379 (1982),
  whose abstract gives the integrated band strength S = 127 +- 4 cm^-2 atm^-1 at 295.7 K. In
  km/mol that is S times the molar volume at 1 atm and that temperature, R T / p0 (R =
  8.314462618 J mol^-1 K^-1, exact in the 2019 SI; p0 = 101325 Pa; 24264 cm^3/mol), then
  cm -> km: 127 x 24264 cm^3/mol = 3.082e6 cm/mol = 30.8 +- 1.0 km/mol. The same abstract says
  published nu4 band strengths spread from 103 to 168 cm^-2 atm^-1 at 300 K (25 to 41 km/mol),
  most within 132-147: read 30.8 km/mol as good to about 10 %, not 3 %.

CO2's intensities, and CH4's nu3, are left out (None): no copy of a source could be read here,
and a value without a readable source is not written down. CH4's nu1 (A1) and nu2 (E) and CO2's
nu1 (Sigma_g+) are IR-forbidden by symmetry; they stay None too (nothing was measured).
`intensity_source` names the source of an entry's intensities.

`experimental_fundamentals(symbols, masses)` finds the entry of a molecule from its symbols
and masses (a hydrogen of mass near 2.014 amu counts as D), and `match_fundamentals` pairs
the entry with computed vibrations by species (lowest with lowest within a species).

>>> experimental_fundamentals(["O", "H", "H"], [15.999, 2.014, 2.014]).name
'D2O'
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from vibra.molecules.isotopes import ISOTOPE_MASSES

__all__ = ["Fundamental", "ExperimentalFundamentals", "EXPERIMENTAL", "SHIMANOUCHI_1972", "CCCBDB_H2O_INTENSITIES",
           "JENNINGS_ROBIETTE_1982_CH4_NU4", "experimental_fundamentals", "match_fundamentals"]

#: The source of every value in `EXPERIMENTAL`.
SHIMANOUCHI_1972 = ("T. Shimanouchi, Tables of Molecular Vibrational Frequencies, Consolidated Vol. I, "
                    "NSRDS-NBS 39 (1972), via NIST CCCBDB")
#: The source of H2O's IR intensities.
CCCBDB_H2O_INTENSITIES = ("NIST CCCBDB, Release 18 (October 2016), Experimental data for H2O, vibrational levels "
                          "(https://cccbdb.nist.gov/exp2x.asp?casno=7732185): nu1 and nu2 intensities from its "
                          "reference 1992Cul/Lie:502, nu3 as listed there")
#: The source of CH4's nu4 intensity, and its conversion to km/mol.
JENNINGS_ROBIETTE_1982_CH4_NU4 = ("D. E. Jennings and A. G. Robiette, J. Mol. Spectrosc. 94, 369 (1982): nu4, "
                                  "127 +- 4 cm^-2 atm^-1 at 295.7 K = 30.8 km/mol (published: 25-41)")


@dataclass(frozen=True)
class Fundamental:
    """One observed fundamental: its name (``"nu1"``), symmetry species, wavenumber in cm^-1 and
    gas-phase IR intensity in km/mol (the whole degenerate set; None where none is sourced)."""

    name: str
    species: str
    wavenumber_cm1: float
    intensity_km_per_mol: float | None = None


@dataclass(frozen=True)
class ExperimentalFundamentals:
    """The observed fundamentals of one molecule (isotopologue) and where they come from."""

    name: str
    fundamentals: tuple[Fundamental, ...]
    source: str
    intensity_source: str | None = None

    @property
    def has_intensities(self) -> bool:
        """Whether any fundamental carries an observed IR intensity."""
        return any(f.intensity_km_per_mol is not None for f in self.fundamentals)


def _entry(name: str, *values: tuple[str, str, float] | tuple[str, str, float, float],
           intensity_source: str | None = None) -> ExperimentalFundamentals:
    return ExperimentalFundamentals(name, tuple(Fundamental(*v) for v in values), SHIMANOUCHI_1972,
                                    intensity_source)


#: Formula (isotopes as D) -> observed fundamentals.
EXPERIMENTAL: dict[str, ExperimentalFundamentals] = {
    "CO2": _entry("CO2", ("nu1", "Sigma_g+", 1333.0), ("nu2", "Pi_u", 667.0), ("nu3", "Sigma_u+", 2349.0)),
    "H2O": _entry("H2O", ("nu1", "A1", 3657.0, 2.9), ("nu2", "A1", 1595.0, 62.5), ("nu3", "B2", 3756.0, 41.7),
                  intensity_source=CCCBDB_H2O_INTENSITIES),
    "D2O": _entry("D2O", ("nu1", "A1", 2671.0), ("nu2", "A1", 1178.0), ("nu3", "B2", 2788.0)),
    "CH4": _entry("CH4", ("nu1", "A1", 2917.0), ("nu2", "E", 1534.0), ("nu3", "T2", 3019.0),
                  ("nu4", "T2", 1306.0, 30.8), intensity_source=JENNINGS_ROBIETTE_1982_CH4_NU4),
}

# A hydrogen within this many amu of an isotope's mass is that isotope.
_MASS_MATCH_AMU = 0.01


def _formula(symbols: Sequence[str], masses: ArrayLike) -> str:
    labels = []
    for symbol, mass in zip(symbols, np.asarray(masses, dtype=float)):
        if symbol in ("H", "D", "T"):
            symbol = "D" if abs(mass - ISOTOPE_MASSES["D"]) < _MASS_MATCH_AMU else \
                "T" if abs(mass - ISOTOPE_MASSES["T"]) < _MASS_MATCH_AMU else "H"
        labels.append(symbol)
    counts = Counter(labels)
    order = sorted(counts, key=lambda s: (s != "C", s))  # C first, then alphabetical (Hill, isotopes as D, T)
    return "".join(f"{s}{counts[s] if counts[s] > 1 else ''}" for s in order)


def experimental_fundamentals(symbols: Sequence[str], masses: ArrayLike) -> ExperimentalFundamentals | None:
    """The observed fundamentals of the molecule with these symbols and masses (amu), or None."""
    return EXPERIMENTAL.get(_formula(symbols, masses))


def match_fundamentals(entry: ExperimentalFundamentals, species: Sequence[str],
                       wavenumbers: ArrayLike) -> list[Fundamental | None]:
    """The observed fundamental of each computed vibration (None where none matches).

    Vibrations of one species are grouped into degenerate sets (equal label, wavenumbers
    within 1e-6 relative) and paired, lowest first, with the fundamentals of that species,
    lowest first.
    """
    values = np.asarray(wavenumbers, dtype=float)
    out: list[Fundamental | None] = [None] * len(species)
    for label in set(species):
        indices = sorted((i for i, s in enumerate(species) if s == label), key=lambda i: values[i])
        sets: list[list[int]] = []
        for i in indices:
            if sets and abs(values[i] - values[sets[-1][0]]) <= 1e-6 * max(abs(values[i]), 1.0):
                sets[-1].append(i)
            else:
                sets.append([i])
        observed = sorted((f for f in entry.fundamentals if f.species == label), key=lambda f: f.wavenumber_cm1)
        for members, fundamental in zip(sets, observed):
            for i in members:
                out[i] = fundamental
    return out
