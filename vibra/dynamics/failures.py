"""How a run fails, and how it says so: `IntegrationError` (the state or a force left the finite
numbers, with the step), the check of a state (numpy, as the compiled loop's own), the first entry
that is not finite in words, the drift warning, and the hint of what usually causes each.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray

import vibra.dynamics.kernels as kernels
from vibra.dynamics.fput import BondForces
from vibra.dynamics.trajectory import Trajectory, relative_changes

__all__ = ["IntegrationError", "has_potential", "failure_hint", "finite_state", "first_bad", "check_drift"]


class IntegrationError(RuntimeError):
    """A run that failed while it ran: its state (or energy) left the finite numbers, or the force
    function returned a value that is not a finite force.

    Attributes
    ----------
    step : int
        The step at which it was found (1-based; for an energy, the first record's step).
    time : float
        That step's time, step * dt, in the time unit.
    trajectory : Trajectory or None
        The records before `step` (the initial state at least), None where the records cannot
        make one.
    """

    def __init__(self, message: str, step: int, time: float, trajectory: Trajectory | None) -> None:
        super().__init__(message)
        self.step = step
        self.time = time
        self.trajectory = trajectory


def has_potential(force_function: object) -> bool:
    """Whether `Trajectory.potential` includes the forces' energy (otherwise it is NaN, documented)."""
    return force_function is None or isinstance(force_function, BondForces) or callable(
        getattr(force_function, "potential", None))


def failure_hint(force_function: object, kind: int, *, drift: bool = False) -> str:
    """What usually makes a run of this kind leave the finite numbers (or drift), and the way out."""
    if force_function is not None and not (isinstance(force_function, BondForces)
                                           and not (np.any(force_function.alpha) or np.any(force_function.beta))):
        return ("the dt check sees only the harmonic omega_max, and anharmonic forces stiffen the system (or let a "
                "large amplitude escape an unbounded potential): lower dt or the amplitude")
    if drift and kind == kernels.NOSE_HOOVER:
        return ("the thermostat's own frequency grows as the kinetic energy exceeds n_dof k_B T / 2 over Q = k_B T "
                "tau^2: lower dt, or bring temperature and tau to the system's energies and periods")
    if drift:
        return "dt is stable for omega_max but coarse (the error grows towards its bound): lower dt"
    if kind == kernels.NOSE_HOOVER:
        return ("the Nosé-Hoover variables outgrew the motion: a temperature or tau far from the system's "
                "energies and periods; lower dt or bring them closer")
    if kind == kernels.ISOKINETIC:
        return "forces far larger than the velocities carry at this temperature: lower dt or raise the temperature"
    return "a state too large for floating point (x0, v0, masses or springs far from 1), or dt near its bound"


def finite_state(x: NDArray[np.float64], v: NDArray[np.float64], force: NDArray[np.float64],
                  masses: NDArray[np.float64], xi: NDArray[np.float64], eta: NDArray[np.float64]) -> bool:
    """`kernels._finite_state` in numpy: x, v, the forces, each dof's m v^2 and x F, xi and eta finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(np.isfinite(masses * v * v).all() and np.isfinite(x * force).all() and np.isfinite(x).all()
                    and np.isfinite(force).all() and np.isfinite(xi).all() and np.isfinite(eta).all())


def first_bad(x: NDArray[np.float64], v: NDArray[np.float64], force: NDArray[np.float64],
               masses: NDArray[np.float64], xi: NDArray[np.float64], eta: NDArray[np.float64]) -> str:
    """The first entry of the state that is not finite, in words (``"v[3] = nan"``, ``"m v^2 of dof 0 = inf"``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        for name, values in (("x", x), ("v", v), ("force", force), ("m v^2 of dof ", masses * v * v),
                             ("x F of dof ", x * force), ("xi", xi), ("eta", eta)):
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                index = int(bad[0])
                label = (f"{name}{index + 1}" if name in ("xi", "eta") else
                         f"{name}{index}" if name.endswith(" ") else f"{name}[{index}]")
                return f"{label} = {float(values[index])!r}"
    return "every entry finite"


def check_drift(run: Trajectory, kind: int, tolerance: float, record_every: int, hint: str) -> None:
    """A RuntimeWarning naming the first record where `conserved` moved beyond `tolerance` of its scale."""
    changes, scales = relative_changes(run.conserved, run.kinetic, run.potential)
    beyond = changes > tolerance
    if not beyond.any():
        return
    row = int(np.argmax(beyond))
    what = {kernels.ISOKINETIC: "kinetic energy", kernels.NOSE_HOOVER: "extended energy"}.get(kind, "energy")
    unit = "" if run.units.energy == "1" else f" {run.units.energy}"
    warnings.warn(f"integrate: the {what} went from {float(run.conserved[0]):.6g} to {float(run.conserved[row]):.6g}"
                  f"{unit} by step {row * record_every} (t = {float(run.t[row]):.6g}), a change of {changes[row]:.3g} "
                  f"of its scale {scales[row]:.3g}, beyond drift_tolerance={tolerance:g}: {hint}; or pass "
                  "drift_tolerance=", RuntimeWarning, stacklevel=4)
