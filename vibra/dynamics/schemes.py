"""The time-stepping schemes of `vibra.dynamics.integrate`: their coefficients, orders and stability.

A scheme is a symmetric composition of kicks (v += b h F / m, or the isokinetic kick) and
drifts (x += a h v): K(b_0 h) D(a_0 h) K(b_1 h) ... D(a_{s-1} h) K(b_s h). Each is symplectic
(volume-preserving with a thermostat), time-reversible, and needs s force evaluations a step.

- ``"verlet"``: velocity Verlet, order 2, one force a step.
- ``"yoshida4"``: Yoshida's (1990) / Forest and Ruth's (1990) triple jump of velocity Verlet,
  order 4, 3 forces a step; its large inner weights (1.35, -1.70) give it a large error constant.
- ``"blanes-moan"``: Blanes and Moan's (2002) SRKN_6^b, order 4, 6 forces a step, with an
  error constant about 1000x smaller than the triple jump's: the better 4th-order choice for the
  same work on an oscillator chain.

The Nosé-Hoover chain has three flows (kick, drift, thermostat); it runs the symmetric
velocity-Verlet step wrapped in thermostat half steps, and ``"yoshida4"`` as its triple jump.
``"blanes-moan"`` splits two flows only and is refused there.

`STABLE_OMEGA_DT[name]` is the largest omega dt for which the scheme stays bounded on a harmonic
oscillator of angular frequency omega (2 for velocity Verlet), computed here from the
coefficients: a time step is stable for a system when omega_max dt is below it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["Scheme", "SCHEMES", "INTEGRATORS", "STABLE_OMEGA_DT"]


@dataclass(frozen=True, eq=False)
class Scheme:
    """One composition scheme.

    Attributes
    ----------
    name : str
        What `Trajectory.integrator` reports.
    order : int
        Order of accuracy (the global error goes as dt**order).
    kicks : (s + 1,) ndarray
        Kick coefficients b_i (they sum to 1).
    drifts : (s,) ndarray
        Drift coefficients a_i (they sum to 1).
    weights : (k,) ndarray
        Weights of the symmetric velocity-Verlet sub-steps used with the Nosé-Hoover chain
        (empty when the scheme cannot run it).
    """

    name: str
    order: int
    kicks: NDArray[np.float64]
    drifts: NDArray[np.float64]
    weights: NDArray[np.float64]


def _triple_jump() -> tuple[float, float]:
    w1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    return w1, 1.0 - 2.0 * w1


def _blanes_moan() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    # SRKN_6^b of Blanes & Moan, J. Comput. Appl. Math. 142 (2002) 313: kicks b_1..b_4,
    # drifts a_1..a_3, mirrored.
    b1, b2, b3 = 0.0829844064174052, 0.396309801498368, -0.0390563049223486
    a1, a2 = 0.245298957184271, 0.604872665711080
    a3 = 0.5 - (a1 + a2)
    b4 = 1.0 - 2.0 * (b1 + b2 + b3)
    return np.array([b1, b2, b3, b4, b3, b2, b1]), np.array([a1, a2, a3, a3, a2, a1])


def _schemes() -> dict[str, Scheme]:
    w1, w0 = _triple_jump()
    bm_kicks, bm_drifts = _blanes_moan()
    return {
        "verlet": Scheme("verlet", 2, np.array([0.5, 0.5]), np.array([1.0]), np.array([1.0])),
        "yoshida4": Scheme("yoshida4", 4, np.array([w1 / 2, (w1 + w0) / 2, (w0 + w1) / 2, w1 / 2]),
                           np.array([w1, w0, w1]), np.array([w1, w0, w1])),
        "blanes-moan": Scheme("blanes-moan", 4, bm_kicks, bm_drifts, np.zeros(0)),
    }


#: The schemes by name (`integrate(integrator=...)`).
SCHEMES: dict[str, Scheme] = _schemes()
#: The accepted integrator names, in the order the docs list them.
INTEGRATORS: tuple[str, ...] = tuple(SCHEMES)


def _trace(scheme: Scheme, x: float) -> float:
    """Half the trace of the one-step map of (q, p) for q'' = -q over a step x."""
    step = np.eye(2)
    kick = lambda b: np.array([[1.0, 0.0], [-b * x, 1.0]])   # noqa: E731
    drift = lambda a: np.array([[1.0, a * x], [0.0, 1.0]])   # noqa: E731
    for b, a in zip(scheme.kicks[:-1], scheme.drifts):
        step = drift(a) @ kick(b) @ step
    step = kick(scheme.kicks[-1]) @ step
    return 0.5 * float(np.trace(step))


def _stability_limit(scheme: Scheme) -> float:
    """The first omega dt where |trace| / 2 reaches 1 (the map stops being a rotation)."""
    grid = np.linspace(1e-3, 6.0, 6000)
    bad = np.array([abs(_trace(scheme, x)) >= 1.0 for x in grid])
    k = int(np.argmax(bad))
    low, high = grid[k - 1], grid[k]
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if abs(_trace(scheme, mid)) < 1.0 else (low, mid)
    return float(low)


#: Largest stable omega dt of each scheme on a harmonic oscillator (verlet: 2).
STABLE_OMEGA_DT: dict[str, float] = {name: _stability_limit(s) for name, s in SCHEMES.items()}
