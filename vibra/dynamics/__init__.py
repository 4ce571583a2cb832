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

Modules: `integrate` (validation and the run), `kernels` (compiled loops, numba), `schemes`,
`thermostats`, `trajectory`, `fput`.
"""

from vibra.dynamics.fput import BondForces, fput
from vibra.dynamics.integrate import highest_omega, integrate, stable_dt
from vibra.dynamics.schemes import INTEGRATORS, STABLE_OMEGA_DT
from vibra.dynamics.thermostats import Isokinetic, NoseHoover
from vibra.dynamics.trajectory import Trajectory

__all__ = ["BondForces", "INTEGRATORS", "Isokinetic", "NoseHoover", "STABLE_OMEGA_DT", "Trajectory", "fput",
           "highest_omega", "integrate", "stable_dt"]
