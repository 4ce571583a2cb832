"""Isotope masses and isotopic substitution on the same force field."""

from __future__ import annotations

import re
from types import MappingProxyType
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate
from vibra.system import System
from vibra.units import ASE

__all__ = ["ISOTOPE_MASSES", "isotope_mass", "isotope_masses", "substitute_isotopes", "substituted_masses"]

# Isotope masses in amu: NIST "Atomic Weights and Isotopic Compositions" (AME2012/AME2016
# values; the AME2020 evaluation moved them by at most 1.2e-9 relative, 3.4e-9 amu for 3H,
# far below what any wavenumber resolves). ase.data has no isotope table offline
# (ase.data.isotopes downloads it), hence this table; vibra.spectra uses the same one.
_ISOTOPES: dict[str, float] = {
    "1H": 1.00782503223, "2H": 2.01410177812, "3H": 3.0160492779,
    "12C": 12.0, "13C": 13.00335483507, "14C": 14.0032419884,
    "14N": 14.00307400443, "15N": 15.00010889888,
    "16O": 15.99491461957, "17O": 16.99913175650, "18O": 17.99915961286,
    "32S": 31.9720711744, "34S": 33.967867004,
    "35Cl": 34.968852682, "37Cl": 36.965902602,
}
_ISOTOPE_ALIASES = {"D": "2H", "T": "3H"}
#: Isotope label -> mass in amu (``"13C"``, ``"18O"``, ``"D"`` = ``"2H"``, ...), read-only; the
#: one table behind `isotope_mass`, `substitute_isotopes` and `vibra.spectra.isotope_shifts`.
ISOTOPE_MASSES: Mapping[str, float] = MappingProxyType(
    {**_ISOTOPES, **{alias: _ISOTOPES[key] for alias, key in _ISOTOPE_ALIASES.items()}})



def isotope_mass(label: str) -> float:
    """Mass in amu of an isotope label such as ``"13C"``, ``"18O"``, ``"D"`` or ``"2H"``.

    Masses from NIST's "Atomic Weights and Isotopic Compositions" (table in this module).

    Examples
    --------
    >>> isotope_mass("13C"), isotope_mass("D") == isotope_mass("2H")
    (13.00335483507, True)
    """
    if not isinstance(label, str):
        raise TypeError(f"label must be a str such as '13C', got {type(label).__name__}")
    key = _ISOTOPE_ALIASES.get(label, label)
    if key not in _ISOTOPES:
        match = re.fullmatch(r"(\d+)([A-Z][a-z]?)", key)
        from ase.data import chemical_symbols

        if match is None or match.group(2) not in chemical_symbols[1:]:
            raise ValueError(f"label is {label!r}; expected an isotope like '13C', '18O', 'D' or '2H'")
        known = ", ".join(sorted(_ISOTOPES) + sorted(_ISOTOPE_ALIASES))
        raise ValueError(f"label is {label!r}: isotope not in vibra's table (known: {known}); pass a mass in amu")
    return _ISOTOPES[key]


def _isotope_element(label: str) -> str:
    key = _ISOTOPE_ALIASES.get(label, label)
    return re.fullmatch(r"\d+([A-Z][a-z]?)", key).group(1)  # type: ignore[union-attr]


def substitute_isotopes(
    system: System,
    substitutions: Mapping[int, float | str],
    *,
    symbols: list[str] | tuple[str, ...] | None = None,
) -> System:
    """The same force field with some atoms replaced by isotopes (K is not recomputed).

    Parameters
    ----------
    system : System
        A molecule in ASE units (masses in amu).
    substitutions : mapping of int to float or str
        Atom index -> new mass in amu, or an isotope label (``"13C"``, ``"18O"``, ``"D"``).
    symbols : sequence of str, optional
        Chemical symbols of the atoms; when given, a label must name the atom's element.

    Raises
    ------
    TypeError
        Not a System of sites in ASE units, or a substitution of the wrong kind.
    ValueError
        An index out of range, a non-positive mass, an unknown label, or a label of another
        element than `symbols` gives.

    Examples
    --------
    >>> from vibra.molecules import h2o, vibrational_analysis
    >>> d2o = substitute_isotopes(h2o(), {1: "D", 2: "D"}, symbols=["O", "H", "H"])
    >>> [round(float(w)) for w in vibrational_analysis(d2o).vibration_wavenumbers_cm1()]
    [1163, 2664, 2736]
    """
    if not isinstance(system, System):
        raise TypeError(f"system must be a vibra System, got {type(system).__name__}")
    if system.units is not ASE and system.units.name != "ASE":
        raise TypeError(f"system must be in ASE units (amu) for isotope masses, got {system.units.name!r}")
    if not isinstance(substitutions, Mapping):
        raise TypeError(f"substitutions must be a mapping index -> mass or label, got {type(substitutions).__name__}")
    if symbols is not None and len(symbols) != system.n_sites:
        raise ValueError(f"symbols must name {system.n_sites} atoms, got {len(symbols)}")
    masses, _ = substituted_masses(system, substitutions, symbols=symbols, what="atom")
    return system.with_masses(masses)


def substituted_masses(
    system: System,
    substitutions: Mapping[int, float | str],
    *,
    symbols: Sequence[str] | None = None,
    what: str = "site",
) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """The site masses of `system` after `substitutions`, and a label of each substitution.

    The one reading of a substitution mapping (`substitute_isotopes`, `vibra.spectra.isotope_shifts`):
    site index -> a mass in the system's mass unit, positive and finite, or an isotope label of
    `ISOTOPE_MASSES`, which needs masses in amu (units ``"ASE"``); with `symbols`, a label must
    name the atom's element. A label is the isotope's, or the mass (``f"{mass:g}"``); `what`
    names an index in the messages (``"atom"``, ``"site"``).

    Raises
    ------
    TypeError
        A key not an int, a value neither a number nor a str.
    ValueError
        A key out of range, an unknown label or one outside ASE units, a mass not positive and
        finite, a label of another element than `symbols` gives.
    """
    masses = np.array(system.masses, dtype=float)
    labels = []
    for site, value in substitutions.items():
        if isinstance(site, bool) or not isinstance(site, (int, np.integer)):
            raise TypeError(f"substitutions key {site!r} must be an int {what} index")
        if not 0 <= site < system.n_sites:
            raise ValueError(f"substitutions[{site}]: {what} index out of range 0..{system.n_sites - 1}")
        if isinstance(value, str):
            if value not in ISOTOPE_MASSES:
                raise ValueError(f"substitutions[{site}] is {value!r}; known isotopes: {', '.join(ISOTOPE_MASSES)}")
            if system.units.name != "ASE":
                raise ValueError(
                    f"substitutions[{site}] is the isotope name {value!r}, which needs masses in amu "
                    f"(units 'ASE'); this system is in {system.units.name!r}: give the mass instead")
            if symbols is not None and _isotope_element(value) != symbols[site]:
                raise ValueError(f"substitutions[{site}] is {value!r} but atom {site} is {symbols[site]!r}")
            mass, label = float(ISOTOPE_MASSES[value]), value
        elif isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
            mass = float(value)
            if not (np.isfinite(mass) and mass > 0):
                raise ValueError(f"substitutions[{site}] is {value!r}; a mass must be positive and finite")
            label = f"{mass:g}"
        else:
            raise TypeError(
                f"substitutions[{site}] must be a mass or an isotope name, got {type(value).__name__}")
        masses[site] = mass
        labels.append(label)
    return masses, tuple(labels)


def isotope_masses(
    symbols: Sequence[str],
    masses: ArrayLike,
    *,
    isotopes: Sequence[str | None] | Mapping[int, str] | None = None,
) -> NDArray[np.float64]:
    """(n_atoms,) masses in amu with some atoms replaced by labelled isotopes.

    Parameters
    ----------
    symbols : sequence of str
        Chemical symbols, one per atom; a label must name the atom's element.
    masses : (n_atoms,) array_like
        Masses in amu of the atoms not relabelled (standard atomic weights, usually).
    isotopes : sequence of (str or None) or mapping of int to str, optional
        Per atom an isotope label (``"D"``, ``"T"``, ``"13C"``, ``"18O"``, any key of
        `ISOTOPE_MASSES`) or None to keep its mass; or a mapping atom index -> label.

    Raises
    ------
    TypeError
        `isotopes` neither a sequence nor a mapping; a label that is not a str; a key that is
        not an int.
    ValueError
        A sequence of the wrong length, an index out of range, a label vibra does not know
        (the message lists the valid ones) or a label of another element than the atom's.

    Examples
    --------
    >>> isotope_masses(["O", "H", "H"], [15.999, 1.008, 1.008], isotopes=[None, "D", "D"]).round(4).tolist()
    [15.999, 2.0141, 2.0141]
    >>> isotope_masses(["O", "C", "O"], [15.999, 12.011, 15.999], isotopes={1: "13C"}).round(4).tolist()
    [15.999, 13.0034, 15.999]
    """
    names = list(symbols)
    values = np.array(_validate.real_array(masses, "masses", ndim=1))
    if values.shape[0] != len(names):
        raise ValueError(f"masses must have {len(names)} entries (one per atom), got {values.shape[0]}")
    if isotopes is None:
        return values
    if isinstance(isotopes, Mapping):
        items = list(isotopes.items())
        for index, _ in items:
            if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
                raise TypeError(f"isotopes key {index!r} must be an int atom index")
            if not 0 <= index < len(names):
                raise ValueError(f"isotopes[{index}]: atom index out of range 0..{len(names) - 1}")
    elif isinstance(isotopes, Sequence) and not isinstance(isotopes, str):
        if len(isotopes) != len(names):
            raise ValueError(f"isotopes must give {len(names)} labels or None (one per atom), got {len(isotopes)}")
        items = [(i, label) for i, label in enumerate(isotopes) if label is not None]
    else:
        raise TypeError("isotopes must be a sequence of labels (None to keep an atom) or a mapping "
                        f"index -> label, got {type(isotopes).__name__}")
    for index, label in items:
        if not isinstance(label, str):
            raise TypeError(f"isotopes[{index}] must be an isotope label (str) such as 'D' or '13C', "
                            f"got {type(label).__name__}")
        if label not in ISOTOPE_MASSES:
            known = ", ".join(sorted(ISOTOPE_MASSES, key=lambda key: (_isotope_element(key), key)))
            raise ValueError(f"isotopes[{index}] is {label!r}, not an isotope label vibra knows; "
                             f"valid labels: {known}")
        element = _isotope_element(label)
        if element != names[index]:
            same = ", ".join(key for key in sorted(ISOTOPE_MASSES) if _isotope_element(key) == names[index])
            raise ValueError(f"isotopes[{index}] is {label!r} ({element}) but atom {index} is {names[index]!r}"
                             + (f"; labels for {names[index]}: {same}" if same else ""))
        values[int(index)] = ISOTOPE_MASSES[label]
    return values
