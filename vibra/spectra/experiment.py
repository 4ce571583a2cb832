"""Computed IR spectra beside experiment: scaled harmonic fundamentals and intensities against the
observed ones of `vibra.molecules.experimental`, with the deviations.

`compare_with_experiment(ir, species, entry)` pairs each observed fundamental with the computed
vibrations of its symmetry species (`vibra.molecules.match_fundamentals`: lowest with lowest
within a species, a degenerate set as one fundamental), scales the computed wavenumbers with the
level's fundamental factor (`fundamental_scale_factor`: 0.974 x its ZPE factor in
`SCALE_FACTORS`; 1, said so, for a level not in the table) and sums the computed intensities of a
degenerate set, as an observed band holds all of them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np
from numpy.typing import NDArray

from vibra._core.frozen import Frozen
from vibra.spectra.scale_factors import FUNDAMENTAL_TO_ZPE, fundamental_scale_factor

if TYPE_CHECKING:
    from vibra.molecules.experimental import ExperimentalFundamentals
    from vibra.spectra.ir import IRSpectrum

__all__ = ["ExperimentComparison", "compare_with_experiment"]


@dataclass(frozen=True, eq=False)
class ExperimentComparison(Frozen):
    """Computed (scaled) against observed fundamentals of one molecule.

    Attributes
    ----------
    molecule : str
        The molecule (``"H2O"``).
    level : str
        The level of theory of the computed values.
    scale_factor : float
        The factor the harmonic wavenumbers were multiplied by (1 when none is known).
    scale_source : str
        Where the factor comes from, in words.
    names, species : tuple of str
        Per fundamental its name (``"nu1"``) and symmetry species.
    harmonic_cm1, computed_cm1, observed_cm1 : (n,) ndarray
        Harmonic, scaled and observed wavenumbers, in cm^-1.
    computed_km_per_mol : (n,) ndarray
        Computed IR intensity of each fundamental (its degenerate set summed), in km/mol.
    observed_km_per_mol : (n,) ndarray
        Observed gas-phase intensity, in km/mol (NaN where none is sourced).
    frequency_source, intensity_source : str
        The sources of the observed values (``""`` for no intensities).
    """

    molecule: str
    level: str
    scale_factor: float
    scale_source: str
    names: tuple[str, ...]
    species: tuple[str, ...]
    harmonic_cm1: NDArray[np.float64]
    computed_cm1: NDArray[np.float64]
    observed_cm1: NDArray[np.float64]
    computed_km_per_mol: NDArray[np.float64]
    observed_km_per_mol: NDArray[np.float64]
    frequency_source: str
    intensity_source: str

    def __len__(self) -> int:
        return len(self.names)

    def __repr__(self) -> str:
        return (f"ExperimentComparison({self.molecule}, {self.level}, {len(self)} fundamentals, scale "
                f"{self.scale_factor:g}, largest deviation {self.largest_deviation_percent():.1f} %)")

    def deviation_cm1(self) -> NDArray[np.float64]:
        """(n,) scaled computed minus observed wavenumber, in cm^-1."""
        return self.computed_cm1 - self.observed_cm1

    def deviation_percent(self) -> NDArray[np.float64]:
        """(n,) (scaled computed - observed) / observed, in percent."""
        return 100.0 * self.deviation_cm1() / self.observed_cm1

    def largest_deviation_percent(self) -> float:
        """Largest |deviation_percent| over the fundamentals."""
        return float(np.max(np.abs(self.deviation_percent()), initial=0.0))

    def intensity_ratio(self) -> NDArray[np.float64]:
        """(n,) computed / observed intensity (NaN where no observed intensity, or it is 0)."""
        observed = self.observed_km_per_mol
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(observed > 0, self.computed_km_per_mol / observed, np.nan)

    def table(self) -> str:
        """The comparison as text: one row per fundamental."""
        lines = [f"{self.molecule}, {self.level}, harmonic x {self.scale_factor:g} ({self.scale_source})",
                 f"{'':5s} {'species':9s} {'harm.':>7s} {'scaled':>7s} {'obs.':>7s} {'dev.':>7s} {'dev. %':>7s} "
                 f"{'calc km/mol':>11s} {'obs km/mol':>10s}"]
        for i, name in enumerate(self.names):
            observed = self.observed_km_per_mol[i]
            lines.append(f"{name:5s} {self.species[i]:9s} {self.harmonic_cm1[i]:7.0f} {self.computed_cm1[i]:7.0f} "
                         f"{self.observed_cm1[i]:7.0f} {self.deviation_cm1()[i]:+7.0f} "
                         f"{self.deviation_percent()[i]:+7.1f} {self.computed_km_per_mol[i]:11.1f} "
                         f"{'-' if np.isnan(observed) else f'{observed:.1f}':>10s}")
        lines.append(f"observed wavenumbers: {self.frequency_source}")
        if self.intensity_source:
            lines.append(f"observed intensities: {self.intensity_source}")
        return "\n".join(lines)


def compare_with_experiment(ir: IRSpectrum, species: Sequence[str], entry: ExperimentalFundamentals, *,
                            scale_factor: float | None = None) -> ExperimentComparison:
    """Set an IR spectrum's fundamentals beside the observed ones.

    Parameters
    ----------
    ir : IRSpectrum
        Computed lines (`vibra.spectra.electronic_ir_spectrum` or `ir_spectrum`); its ``level``
        chooses the scale factor.
    species : sequence of str
        The symmetry species of each line of `ir` (``len(ir.wavenumbers)`` labels, as
        `vibra.molecules.VibrationalAnalysis.species` gives them).
    entry : ExperimentalFundamentals
        The observed values (`vibra.molecules.experimental_fundamentals`).
    scale_factor : float, optional
        The factor to use instead of the level's (`fundamental_scale_factor`).

    Returns
    -------
    ExperimentComparison

    Raises
    ------
    TypeError
        `ir` without wavenumbers and intensities, `entry` not an `ExperimentalFundamentals`.
    ValueError
        `species` of the wrong length; no observed fundamental matches a computed vibration;
        a scale factor that is not positive and finite.
    """
    from vibra.molecules.experimental import ExperimentalFundamentals, match_fundamentals

    if not hasattr(ir, "wavenumbers") or not hasattr(ir, "intensities_km_per_mol"):
        raise TypeError(f"ir must be an IRSpectrum, got {type(ir).__name__}")
    if not isinstance(entry, ExperimentalFundamentals):
        raise TypeError(f"entry must be a vibra.molecules.ExperimentalFundamentals, got {type(entry).__name__}")
    wavenumbers = np.asarray(ir.wavenumbers, dtype=float)
    species = [str(s) for s in species]
    if len(species) != len(wavenumbers):
        raise ValueError(f"species has {len(species)} labels; expected one per line of ir ({len(wavenumbers)})")
    level = getattr(ir, "level", "") or ""
    if scale_factor is not None:
        factor, source = float(scale_factor), "given"
        if not (np.isfinite(factor) and factor > 0):
            raise ValueError(f"scale_factor is {scale_factor!r}; expected a positive, finite number")
    else:
        found = fundamental_scale_factor(level) if level else None
        if found is None:
            factor, source = 1.0, f"no factor for {level or 'this model'!r} in vibra.spectra.SCALE_FACTORS: unscaled"
        else:
            factor = found
            source = (f"{FUNDAMENTAL_TO_ZPE} x the ZPE factor of {level} in SCALE_FACTORS (Alecu, Zheng, Zhao and "
                      "Truhlar, J. Chem. Theory Comput. 6, 2872 (2010))")
    matched = match_fundamentals(entry, species, wavenumbers)
    intensities = np.asarray(ir.intensities_km_per_mol(), dtype=float)
    rows = []
    for fundamental in entry.fundamentals:
        members = [k for k, f in enumerate(matched) if f is fundamental]
        if not members:
            continue
        observed = fundamental.intensity_km_per_mol
        rows.append((fundamental.name, fundamental.species, float(np.mean(wavenumbers[members])),
                     fundamental.wavenumber_cm1, float(np.sum(intensities[members])),
                     np.nan if observed is None else float(observed)))
    if not rows:
        raise ValueError(f"no observed fundamental of {entry.name} matches a computed vibration by species "
                         f"(computed species: {sorted(set(species))})")
    rows.sort(key=lambda row: (len(row[0]), row[0]))  # nu1, nu2, ..., nu10
    harmonic = np.array([row[2] for row in rows])
    return ExperimentComparison(
        molecule=entry.name, level=level or "model", scale_factor=factor, scale_source=source,
        names=tuple(row[0] for row in rows), species=tuple(row[1] for row in rows), harmonic_cm1=harmonic,
        computed_cm1=factor * harmonic, observed_cm1=np.array([row[3] for row in rows]),
        computed_km_per_mol=np.array([row[4] for row in rows]),
        observed_km_per_mol=np.array([row[5] for row in rows]), frequency_source=entry.source,
        intensity_source=entry.intensity_source or "")
