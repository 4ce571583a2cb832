"""Dispersion of chains and their continuum limit, the wave equation (Kneller, Mécanique analytique, eqs. 162-165).

A uniform chain of masses m, springs kappa and spacing dx obeys (eq. 162)
u_i'' = Omega^2 (u_{i+1} - 2 u_i + u_{i-1}), Omega = sqrt(kappa / m). As dx -> 0 with
c = Omega dx fixed (eq. 164) this becomes the wave equation u_tt = c^2 u_xx (eq. 165).
This subpackage gives

- `vibra.continuum.bands`: dispersion omega(q), group velocity and band edges of
  monatomic and diatomic chains, the assignment of a finite chain's modes to wavenumbers,
  `dispersion_curves` (all of it over the Brillouin zone, for a chart), and the continuum
  rod / string modes for each end condition;
- `vibra.continuum.convergence`: a convergence study of the chain's lowest modes towards
  the continuum, with the order fitted from the data (`power_law_fit`);
- `vibra.continuum.pulses`: a Gaussian pulse on a long uniform chain, propagated exactly in
  the chain's own Fourier basis (FFT, DCT or DST), against d'Alembert's solution, showing
  dispersive spreading.

Every public name is importable from `vibra.continuum` itself. Lengths, times and
frequencies are in any consistent unit system (the chains' own).
"""

from __future__ import annotations

from vibra.continuum import bands, convergence, pulses
from vibra.continuum.convergence import ConvergenceStudy, convergence_study, power_law_fit
from vibra.continuum.bands import (DispersionCurves, assign_wavenumbers, band_edges, continuum_frequencies,
                                        continuum_length, dispersion, dispersion_curves, group_velocity,
                                        wave_speed)
from vibra.continuum.pulses import PulseResult, PulseStudy, gaussian_pulse, pulse_study

__all__ = [*bands.__all__, *convergence.__all__, *pulses.__all__]
