"""Time integration beyond the harmonic approximation (issue 33): thermostats and the FPUT chain.

- `integrate(system, x0, v0, dt, n_steps, *, forces, thermostat, integrator, record_every)`
  -> `Trajectory` (times, positions, velocities, energies, thermostat variables, and
  `Trajectory.mode_energies(modes)`: energy per harmonic normal mode, Kneller, Mécanique analytique, eq. 149).
- Thermostats: `Isokinetic(temperature)`, Gauss's constraint of Kneller, Mécanique analytique, §4.2 example 10;
  `NoseHoover(temperature, tau, chain=1)`, Nosé-Hoover and Nosé-Hoover chains.
- `fput(n, alpha, beta, ends)`: the Fermi-Pasta-Ulam-Tsingou chain, its harmonic `System` and
  anharmonic `BondForces`.
- Schemes (`INTEGRATORS`): velocity Verlet, Yoshida's 4th-order triple jump, Blanes-Moan's
  4th-order SRKN_6^b; `STABLE_OMEGA_DT` and `stable_dt` give the stable step from omega_max.
- Limits: a run's time estimated from its sizes (`cost`) against ``max_seconds`` (600 s by
  default), its records against `MAX_RECORD_BYTES`; a run that leaves the finite numbers raises
  `IntegrationError` at its step, one whose conserved quantity moves by more than
  `DRIFT_TOLERANCE` warns.

Modules: `integrate` (validation and the run), `cost` (the time estimate), `kernels` (compiled
loops, numba), `schemes`, `thermostats`, `trajectory`, `fput`.
"""

from vibra.dynamics.fput import BondForces, fput
from vibra.dynamics.failures import IntegrationError
from vibra.dynamics.integrate import DRIFT_TOLERANCE, integrate
from vibra.dynamics.stability import highest_omega, stable_dt
from vibra.dynamics.schemes import INTEGRATORS, STABLE_OMEGA_DT
from vibra.dynamics.thermostats import Isokinetic, NoseHoover
from vibra.dynamics.trajectory import Trajectory

__all__ = ["BondForces", "DRIFT_TOLERANCE", "INTEGRATORS", "IntegrationError", "Isokinetic", "NoseHoover",
           "STABLE_OMEGA_DT", "Trajectory", "fput", "highest_omega", "integrate", "stable_dt"]
