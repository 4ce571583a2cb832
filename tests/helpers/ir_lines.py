"""A stand-in IR spectrum for the experiment comparison and its chart: what
`vibra.spectra.compare_with_experiment` reads (wavenumbers in cm^-1, intensities in e^2/amu, the
level of theory), made from intensities in km/mol."""

from __future__ import annotations

import dataclasses

import numpy as np

from vibra.spectra.ir import KM_PER_MOL_PER_E2_AMU


@dataclasses.dataclass
class Lines:
    wavenumbers: np.ndarray
    intensities: np.ndarray
    level: str

    def intensities_km_per_mol(self) -> np.ndarray:
        return self.intensities * KM_PER_MOL_PER_E2_AMU


def ir_lines(wavenumbers: list[float], km_per_mol: list[float], level: str) -> Lines:
    """Lines at `wavenumbers` (cm^-1) of `km_per_mol` intensities, computed at `level`."""
    return Lines(np.array(wavenumbers, float), np.array(km_per_mol, float) / KM_PER_MOL_PER_E2_AMU, level)
