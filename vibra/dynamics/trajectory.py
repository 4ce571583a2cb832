"""`Trajectory`: the frozen result of `vibra.dynamics.integrate`, with energy per normal mode (eq. 149)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vibra._core.text import counted
from vibra._results import Result, stored
from vibra.modes import Modes
from vibra.units import UnitSystem

__all__ = ["Trajectory", "relative_changes"]


def relative_changes(conserved: NDArray[np.float64], kinetic: NDArray[np.float64],
                     potential: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(n_records,) |C_r - C_0| / scale_r of a conserved quantity C, and (n_records,) the scales, in
    the energy unit.

    scale_r is the larger of |C_0| and the largest kinetic + |potential| of the records up to r
    (where the potential is NaN, unknown: the kinetic energy alone): the energy the run had
    reached by then, so that a run that starts at rest (C_0 = 0) is measured against the energy
    it gains, and a run whose energy grows is named at the first record where the change is
    a given fraction of what it has become. A record of scale 0 (nothing moved) has change 0.
    The one measure of drift behind `Trajectory.conserved_drift`, `integrate`'s warning and a
    dynamics scene's report.

    >>> relative_changes(np.array([2.0, 2.5]), np.array([1.0, 1.5]), np.array([1.0, 1.0]))[0].tolist()
    [0.0, 0.2]
    """
    size = np.abs(kinetic) + np.where(np.isnan(potential), 0.0, np.abs(potential))
    scales = np.maximum(np.abs(conserved[:1]), np.maximum.accumulate(size)) if size.size else np.zeros(0)
    changes = np.abs(conserved - conserved[:1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(scales > 0, changes / np.where(scales > 0, scales, 1.0), 0.0), scales


@dataclass(frozen=True, eq=False, repr=False)
class Trajectory(Result):
    """A recorded trajectory, in the units of its system (a `vibra._results.Result` over its records:
    ``run[::10]`` keeps every tenth record; `path` is the integrator).

    Attributes
    ----------
    t : (n_records,) ndarray
        Times of the records, in the system's time unit (t[0] = 0: the initial state).
    positions : (n_records, n_dof) ndarray
        Displacements of the free dofs from equilibrium, in the length unit.
    velocities : (n_records, n_dof) ndarray
        Their velocities, in length per time unit.
    kinetic : (n_records,) ndarray
        Kinetic energy sum m v^2 / 2, in the energy unit.
    potential : (n_records,) ndarray
        Potential energy u^T K u / 2 plus the anharmonic part, in the energy unit (NaN where the
        anharmonic forces were a plain function with no ``potential``).
    conserved : (n_records,) ndarray
        What the dynamics conserves, in the energy unit: K + V without a thermostat; the
        extended energy of a Nosé-Hoover chain (see `NoseHoover`); the kinetic energy under the
        isokinetic constraint.
    thermostat_state : (n_records, n_state) ndarray
        The thermostat's variables, named by `thermostat_labels`: ``mu`` (1 / time unit) for
        `Isokinetic`; ``xi1..xiM`` (1 / time unit) and ``eta1..etaM`` (dimensionless) for
        `NoseHoover`; no columns without a thermostat.
    thermostat_labels : tuple of str
        The names of the columns of `thermostat_state`.
    masses : (n_dof,) ndarray
        The masses of the free dofs, in the mass unit.
    dt : float
        The time step, in the time unit.
    integrator : str
        The scheme that ran (see `vibra.dynamics.INTEGRATORS`).
    compiled : bool
        True when the steps ran in the compiled loop (harmonic and `fput` forces), False when a
        Python loop called user forces.
    units : UnitSystem
        The system's units.
    """

    STORED = {"t": stored(("n_records",)), "positions": stored(("n_records", "n_dof")),  # how save / load check them
              "velocities": stored(("n_records", "n_dof")), "kinetic": stored(("n_records",)),
              "potential": stored(("n_records",)), "conserved": stored(("n_records",)),
              "thermostat_state": stored(("n_records", "n_state")), "masses": stored(("n_dof",))}
    AXIS, NOUNS, PATH_FIELD, SIZED = "n_records", ("record", "records"), "integrator", {"thermostat_labels": "n_state"}

    t: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    kinetic: NDArray[np.float64]
    potential: NDArray[np.float64]
    conserved: NDArray[np.float64]
    thermostat_state: NDArray[np.float64]
    thermostat_labels: tuple[str, ...]
    masses: NDArray[np.float64]
    dt: float
    integrator: str
    compiled: bool
    units: UnitSystem

    def _repr_parts(self) -> tuple[str, ...]:
        end = f" to t = {float(self.t[-1]):.6g}" if self.t.size else ""
        return (f"{self._size()} of {counted(self.positions.shape[1], 'dof')}{end}", f"dt = {self.dt:g}",
                "compiled" if self.compiled else "Python loop")

    @property
    def energy(self) -> NDArray[np.float64]:
        """(n_records,) total energy kinetic + potential, in the energy unit."""
        return self.kinetic + self.potential

    def conserved_drift(self) -> float:
        """The largest relative change of `conserved` over the records, max_r |C_r - C_0| / scale_r
        (`relative_changes`: scale_r is |C_0| or the largest kinetic + |potential| up to record r),
        dimensionless; NaN where `conserved` is unknown (a force function without ``potential``).

        `integrate` warns when it exceeds ``drift_tolerance`` (`vibra.dynamics.DRIFT_TOLERANCE`).
        """
        return float(np.max(relative_changes(self.conserved, self.kinetic, self.potential)[0]))

    def state(self, label: str) -> NDArray[np.float64]:
        """(n_records,) one thermostat variable by its label (``"mu"``, ``"xi1"``, ``"eta2"``, ...).

        Raises
        ------
        ValueError
            A label the thermostat does not have (the message lists those it has).
        """
        if label not in self.thermostat_labels:
            raise ValueError(f"label is {label!r}; this trajectory's thermostat variables are "
                             f"{list(self.thermostat_labels)}")
        return self.thermostat_state[:, self.thermostat_labels.index(label)]

    def mode_energies(self, modes: Modes) -> NDArray[np.float64]:
        """(n_records, n_modes) energy in each harmonic normal mode, in the energy unit.

        Normal coordinates q = D^T M^1/2 u (Kneller, Mécanique analytique, eq. 149) and their velocities
        q' = D^T M^1/2 v give E_k = q'_k^2 / 2 + omega_k^2 q_k^2 / 2. For a harmonic system these
        sum to the total energy and each is constant; anharmonic forces move energy between
        them (FPUT).

        Parameters
        ----------
        modes : Modes
            Normal modes of the same system (same free dofs and masses), with vectors.

        Raises
        ------
        TypeError
            `modes` is not a `Modes`.
        ValueError
            Modes without vectors, of another number of dofs, or of other masses.
        """
        if not isinstance(modes, Modes):
            raise TypeError(f"modes must be a vibra.Modes, got {type(modes).__name__}")
        if modes.vectors is None:
            raise ValueError("modes has no vectors (computed with vectors=False); mode energies need them")
        n_dof = self.positions.shape[1]
        if modes.vectors.shape[0] != n_dof:
            raise ValueError(f"modes has {modes.vectors.shape[0]} dofs; this trajectory has {n_dof}")
        mass = np.asarray(modes.mass)
        if mass.ndim != 1 or not np.allclose(mass, self.masses, rtol=1e-12, atol=0.0):
            raise ValueError("modes.mass differs from the trajectory's masses: the modes belong to another system")
        root = np.sqrt(self.masses)
        q = (self.positions * root) @ modes.vectors
        qdot = (self.velocities * root) @ modes.vectors
        return 0.5 * qdot**2 + 0.5 * (modes.omega**2) * q**2
