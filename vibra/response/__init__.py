"""Forced, damped response: the single oscillator and multi-dof frequency response.

The single oscillator u'' + gamma u' + w0^2 u = F(t) / m (Kneller, Mécanique analytique, section 5.1, eqs.
114-131) is `Oscillator`, in forms that keep their digits at the extremes (see
`vibra.response.oscillator`).

For many degrees of freedom, M u'' + (C + G) u' + K u = Re{f exp(i w t)} (C symmetric
positive semi-definite damping, proportional or not; G an optional skew gyroscopic matrix,
keyword ``G=``) has the steady state Re{x(w) exp(i w t)} with the receptance response
x(w) = (K - w^2 M + i w (C + G))^-1 f.
`frf` returns it as an (n_freq, n_dof) complex array; `frequency_response` returns a
`FrequencyResponse` with the method, the solver and the estimated truncation error.
Three methods:

- ``"direct"``: one factorisation per frequency, tridiagonal (LAPACK gttrf/gttrs) or banded
  (gbtrf/gbtrs) when K, M and C are, sparse LU otherwise, dense LU for small dense input.
- ``"modal"``: superposition of the lowest `n_modes` normal modes (`vibra.normal_modes`),
  for damping that the modes diagonalise (friction C = eta M, Kneller, Mécanique analytique, eq. 66; Rayleigh
  C = a M + b K; modal damping ratios) and no G. The error of the dropped modes is estimated,
  and a residual (static) correction for them is offered.
- ``"state_space"``: complex modes of the first-order form, for any C and G (dense; all
  modes).

`transient_response` gives the motion of a multi-dof system under a harmonic (or constant)
force from given initial conditions: by modal superposition, each normal coordinate moving as
one `Oscillator`, when C is proportional and there is no G; otherwise by exact exponential
integration of the first-order form (`Transient.method` says which).

`system_frequency_response` and `system_transient_response` take a `vibra.System` as it is:
a generalised system (`System.generalized(M, K, C=..., G=...)`, `lagrangian.linearize`,
`vibra.mechanics.gyroscopic`) brings its C and G (`system_matrices`).

Free structures (rigid-body modes, omega_k = 0): their receptance -1/w^2 is unbounded as
w -> 0, so w = 0 is refused with an error naming the frequency; for w > 0 the rigid-body
terms are included. The residual correction uses the static response of the flexible modes
only (the pseudo-inverse of K on the M-orthogonal complement of the rigid-body modes).

Where each piece lives: `oscillator.py` (the single oscillator), `damping.py` (friction,
Rayleigh and modal damping), `frf.py` (`frequency_response`, `frf`) with its methods in
`direct.py` (direct, state space) and `modal.py`, `transient.py` (`transient_response`) with
its state-space method in `state_space.py`, `systems.py` (the `System` entry points),
`matrices.py` (input checks and matrix storage shared by the methods).

Units: every quantity is in the unit system of K, M and C (rad per time unit for
frequencies; force / stiffness = length for the response).
"""

from __future__ import annotations

from vibra.response.damping import (
    MODAL_DIAGONAL_RTOL, friction_damping, rayleigh_coefficients, rayleigh_damping, rayleigh_damping_ratio,
)
from vibra.response.direct import BANDED_MAX_HALF_WIDTH
from vibra.response.frf import METHODS, FrequencyResponse, frequency_response, frf
from vibra.response.oscillator import Oscillator
from vibra.response.systems import (
    SystemMatrices, system_frequency_response, system_matrices, system_transient_response,
)
from vibra.response.transient import TRANSIENT_METHODS, Transient, transient_response

__all__ = [
    "Oscillator", "FrequencyResponse", "Transient", "frf", "frequency_response",
    "transient_response", "friction_damping", "rayleigh_damping", "rayleigh_damping_ratio",
    "rayleigh_coefficients", "METHODS", "BANDED_MAX_HALF_WIDTH", "MODAL_DIAGONAL_RTOL",
    "SystemMatrices", "system_matrices", "system_frequency_response", "system_transient_response",
    "TRANSIENT_METHODS",
]
