"""Frequency scale factors for thermochemistry, by level of theory: a small cited table.

Harmonic frequencies from a quantum-chemical Hessian are systematically off; thermochemistry
multiplies them by an empirical factor fitted for the level of theory (method/basis) first.
The factors below are the zero-point-energy scale factors of the Truhlar group's Database of
Frequency Scale Factors (I. M. Alecu, J. Zheng, Y. Zhao and D. G. Truhlar, J. Chem. Theory
Comput. 6, 2872 (2010), and the database's later versions), the ones GoodVibes applies by
default; NIST's CCCBDB lists comparable ones. A level not in the table is given as a number.

Fundamentals: Alecu et al. found the factors that bring harmonic frequencies to observed
fundamentals to be a fixed multiple of the ZPE factors, lambda_F = 0.974 lambda_ZPE (their
ratio over the levels of the database), so `fundamental_scale_factor(level)` gives
0.974 x the level's ZPE factor (B3LYP/6-31G(d): 0.952; HF/6-31G(d): 0.885): the factor that
`vibra.spectra.compare_with_experiment` multiplies computed harmonic wavenumbers by before
setting them beside observed fundamentals.

The rule against fundamental factors fitted directly (harmonic against observed fundamentals):

- HF/6-31G(d): 0.8982 +- 0.0230 (standard uncertainty), in the abstract of "Uncertainties in
  scaling factors for ab initio vibrational frequencies" (K. K. Irikura, R. D. Johnson III and
  R. N. Kacker, J. Phys. Chem. A 109, 8430 (2005); fitted to the NIST CCCBDB's data, more
  than 3939 vibrations of 358 molecules), which adds that such factors "have only two
  significant digits". The rule's 0.885 is 0.013 below it: within one standard uncertainty.
- B3LYP/6-31G(d): 0.9614, and HF/6-31G(d): 0.8953, from A. P. Scott and L. Radom, "Harmonic
  Vibrational Frequencies: An Evaluation of Hartree-Fock, Moller-Plesset, Quadratic
  Configuration Interaction, Density Functional Theory, and Semiempirical Scale Factors",
  J. Phys. Chem. 100, 16502 (1996) (1066 vibrations), as quoted with that citation by the VMD
  QMtool plugin and the Tonto documentation. The rule's 0.952 is 0.0094 (1.0 %) below 0.9614;
  its 0.885 is 0.010 below 0.8953.

So the rule lands within the one published uncertainty read here (HF/6-31G(d)), and its
B3LYP/6-31G(d) difference is smaller than that uncertainty; a comparison scaled with it carries
an uncertainty of that size, about 2.5 % (0.023 / 0.898), in every scaled wavenumber.

Level names are matched loosely: case, spaces, hyphens, brackets and commas do not matter,
``*`` is ``(d)`` and ``**`` is ``(d,p)``, and ``RHF`` is ``HF`` (what `PySCFEngine.level` writes:
``"RHF/6-31G*"`` is ``"HF/6-31G(d)"``).

`scale_factor(value)` turns ``scale_factor=`` of `vibra.spectra.thermochemistry` and
`ideal_gas_thermochemistry` into a number: a positive number as it is, or a level name
(``"B3LYP/6-31G(d)"``; case, spaces, hyphens and the brackets of the basis do not matter).
"""

from __future__ import annotations

import difflib

__all__ = ["SCALE_FACTORS", "FUNDAMENTAL_TO_ZPE", "scale_factor", "fundamental_scale_factor"]

#: ZPE scale factors of common levels of theory (Alecu, Zheng, Zhao and Truhlar 2010; the
#: Truhlar group's database), as "method/basis" -> factor.
SCALE_FACTORS: dict[str, float] = {
    "HF/6-31G(d)": 0.909,
    "B3LYP/6-31G(d)": 0.977,
    "B3LYP/def2-TZVP": 0.985,
    "B3LYP/aug-cc-pVTZ": 0.985,
    "PBE/def2-TZVP": 1.011,
    "M06-2X/6-31+G(d,p)": 0.968,
    "M06-2X/def2-TZVP": 0.971,
    "wB97X-D/def2-TZVP": 0.975,
    "CCSD(T)/aug-cc-pVTZ": 0.987,
}


#: lambda_F / lambda_ZPE (Alecu, Zheng, Zhao and Truhlar 2010): fundamentals from ZPE factors.
FUNDAMENTAL_TO_ZPE = 0.974


def _key(level: str) -> str:
    text = level.upper().replace("**", "(D,P)").replace("*", "(D)")
    method, _, basis = text.partition("/")
    if method.strip() == "RHF":
        method = "HF"
    return "".join(ch for ch in f"{method}/{basis}" if ch not in " -_(),")


_BY_KEY = {_key(level): factor for level, factor in SCALE_FACTORS.items()}


def scale_factor(value: float | str) -> float:
    """The factor for ``scale_factor=``: a number as given, or a level of theory's from
    `SCALE_FACTORS`.

    Raises
    ------
    ValueError
        A level not in the table (the message lists the closest and says to give the number).

    Examples
    --------
    >>> scale_factor("B3LYP/6-31G(d)"), scale_factor("b3lyp/631g(d)"), scale_factor(0.96)
    (0.977, 0.977, 0.96)
    """
    if not isinstance(value, str):
        return value  # type: ignore[return-value]  (a number: validated where it is used)
    found = _BY_KEY.get(_key(value))
    if found is not None:
        return found
    close = difflib.get_close_matches(value, list(SCALE_FACTORS), n=3, cutoff=0.5)
    hint = f"; closest: {', '.join(close)}" if close else ""
    raise ValueError(f"scale_factor is {value!r}: not a level of theory in vibra.spectra.SCALE_FACTORS{hint}; "
                     f"give the factor published for your level as a number (e.g. from NIST's CCCBDB)")


def fundamental_scale_factor(level: str) -> float | None:
    """The factor that brings harmonic wavenumbers of `level` to observed fundamentals:
    `FUNDAMENTAL_TO_ZPE` x the level's ZPE factor in `SCALE_FACTORS`, or None for a level not
    in the table.

    Examples
    --------
    >>> fundamental_scale_factor("RHF/6-31G*"), fundamental_scale_factor("GFN2-xTB")
    (0.885, None)
    """
    if not isinstance(level, str):
        raise TypeError(f"level must be a str, got {type(level).__name__}")
    found = _BY_KEY.get(_key(level))
    return None if found is None else round(FUNDAMENTAL_TO_ZPE * found, 3)
