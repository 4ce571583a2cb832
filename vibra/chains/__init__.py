"""Chain builders (monatomic, diatomic, beaded string) and their closed-form spectra.

Seed 003 section 5.3 (eqs. 159-165): N masses m joined by springs kappa, Omega = sqrt(kappa/m).
Every builder returns a `vibra.System` that keeps the spring factorisation K = B^T diag(w) B,
so ``system.modes(accuracy="high")`` takes the relative-accuracy path, and every builder has
a closed form beside it so that users and tests can compare:

=====================  =================================================================
`linear_chain`         `monatomic_frequencies`: free 2 Omega sin(k pi / 2N), k = 0..N-1;
                       fixed 2 Omega sin(k pi / 2(N+1)), k = 1..N; periodic
                       2 Omega |sin(pi j / N)|, j = 0..N-1.
`diatomic_chain`       `diatomic_branches` (acoustic and optical omega(q)),
                       `diatomic_frequencies` (periodic ends, exact), `diatomic_band_edges`;
                       the Bloch problem itself: `diatomic_eigenvalues`,
                       `diatomic_half_splitting`.
`beaded_string`        `beaded_string_frequencies` (spring constant tension / spacing).
mass defect            `montroll_potts_frequency`, `montroll_potts_decay`.
=====================  =================================================================

`periodic_modes` diagonalises a uniform or diatomic ring exactly with Fourier (Bloch)
modes, in O(N log N) for the frequencies and O(N) per requested mode vector.

Layout: `vibra.chains.builders` (the builders and `ENDS`), `vibra.chains.closed_forms`,
`vibra.chains.fourier` (`periodic_modes`); every public name is importable from
`vibra.chains` itself.
"""

from __future__ import annotations

from vibra.chains import builders, closed_forms, fourier
from vibra.chains.builders import ENDS, beaded_string, diatomic_chain, linear_chain
from vibra.chains.closed_forms import (beaded_string_frequencies, diatomic_band_edges, diatomic_branches,
                                       diatomic_eigenvalues, diatomic_frequencies, diatomic_half_splitting,
                                       monatomic_frequencies, monatomic_shapes, montroll_potts_decay,
                                       montroll_potts_frequency)
from vibra.chains.fourier import periodic_modes

__all__ = [*builders.__all__, *closed_forms.__all__, *fourier.__all__]
