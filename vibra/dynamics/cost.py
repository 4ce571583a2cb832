"""What an integration costs, estimated from sizes before any step (never from the clock).

One estimate serves three decisions: `integrate` refuses a run whose estimate exceeds its
``max_seconds`` (`vibra.solvers.budget.TIME_LIMIT_S`, 600 s, by default), the compiled loop
returns to Python every `CHUNK_SECONDS` of estimated work (so that Ctrl-C stops it), and a
dynamics scene's ``vibra validate`` line and time limit
(`vibra.pipeline.scene.limits.dynamics_estimate`) add up the same figures.

A step of a scheme evaluates the forces `forces_per_step` times (velocity Verlet 1,
``"yoshida4"`` 3, ``"blanes-moan"`` 6; a Nosé-Hoover run one per sub-step). Each evaluation
costs, in the compiled loop (harmonic springs and `fput`'s bonds),
`SECONDS_PER_FORCE` + `SECONDS_PER_DOF_FORCE` n_dof + `SECONDS_PER_THERMOSTAT_FORCE` M
+ `SECONDS_PER_NONZERO_FORCE` nnz (M the Nosé-Hoover chain length, 0 otherwise; nnz the
entries of the part of K that no spring bond carries, a sparse product: 0 for a 1-D spring
system, all of K for a dense Hessian); measured on the project's 2-core machine (one thread,
shared): 1.2e-7 to 3e-7 s a step for one Nosé-Hoover thermostat on one oscillator, 2.9e-7 to
8e-7 for a chain of 4, 1.9e-7 isokinetic in 3-D, 1.2e-6 for a 255-site FPUT chain (velocity
Verlet), 1.2e-9 s per entry of a dense K of 100 to 400 dofs; loading the cached compiled
kernels takes `START_SECONDS` once per process. A force function numba cannot call runs in a
Python loop at `PYTHON_SECONDS_PER_FORCE` + `PYTHON_SECONDS_PER_DOF_FORCE` n_dof (+ the same
nnz term, all of K) an evaluation (18-44 us measured for 5 to 200 dofs), not counting the
function's own time: for such forces the estimate is a lower bound.

>>> integration_seconds(31, 500_000, "verlet")        # 0.17 s measured (FPUT, 31 masses)
0.1775
>>> steps_within(600.0, 31, "verlet")
1690140845
"""

from __future__ import annotations

import math

from vibra.dynamics.schemes import SCHEMES

__all__ = ["SECONDS_PER_FORCE", "SECONDS_PER_DOF_FORCE", "SECONDS_PER_THERMOSTAT_FORCE", "SECONDS_PER_NONZERO_FORCE",
           "START_SECONDS",
           "PYTHON_SECONDS_PER_FORCE", "PYTHON_SECONDS_PER_DOF_FORCE", "CHUNK_SECONDS", "forces_per_step",
           "step_seconds", "integration_seconds", "steps_within", "chunk_steps"]

#: Seconds of one force evaluation (a kick) of the compiled loop: a fixed part ...
SECONDS_PER_FORCE = 2e-7
#: ... a part per degree of freedom ...
SECONDS_PER_DOF_FORCE = 5e-9
#: ... a part per Nosé-Hoover thermostat of the chain ...
SECONDS_PER_THERMOSTAT_FORCE = 1.2e-7
#: ... and a part per entry of K that runs as a sparse product (in either loop).
SECONDS_PER_NONZERO_FORCE = 1.5e-9
#: Seconds to load the cached compiled kernels, once per process.
START_SECONDS = 0.5
#: Seconds of one force evaluation in the Python loop (a force function numba cannot call),
#: without the function's own time: a fixed part and a part per degree of freedom.
PYTHON_SECONDS_PER_FORCE = 2e-5
PYTHON_SECONDS_PER_DOF_FORCE = 1e-8
#: Estimated seconds of work between two returns of the compiled loop to Python (where a
#: KeyboardInterrupt is raised and the state is checked).
CHUNK_SECONDS = 0.5


def forces_per_step(integrator: str, nose_hoover: bool = False) -> int:
    """Force evaluations in one step of `integrator` (its sub-steps under a Nosé-Hoover chain).

    >>> forces_per_step("blanes-moan"), forces_per_step("yoshida4", nose_hoover=True)
    (6, 3)
    """
    scheme = SCHEMES[integrator]
    return int((scheme.weights if nose_hoover else scheme.drifts).size)


def step_seconds(n_dof: int, integrator: str, *, chain: int = 0, compiled: bool = True, nonzeros: int = 0) -> float:
    """Estimated seconds of one step of `n_dof` dofs with `integrator`; `chain` the Nosé-Hoover
    chain length (0: no Nosé-Hoover thermostat); `compiled` False for the Python loop; `nonzeros`
    the entries of K that run as a sparse product."""
    if compiled:
        per_force = SECONDS_PER_FORCE + SECONDS_PER_DOF_FORCE * n_dof + SECONDS_PER_THERMOSTAT_FORCE * chain
    else:
        per_force = PYTHON_SECONDS_PER_FORCE + PYTHON_SECONDS_PER_DOF_FORCE * n_dof
    per_force += SECONDS_PER_NONZERO_FORCE * nonzeros
    return per_force * forces_per_step(integrator, nose_hoover=chain > 0)


def integration_seconds(n_dof: int, n_steps: int, integrator: str, *, chain: int = 0, compiled: bool = True,
                        nonzeros: int = 0) -> float:
    """Estimated seconds of `n_steps` steps (`step_seconds` each), in s; `START_SECONDS` not included."""
    return float(n_steps) * step_seconds(n_dof, integrator, chain=chain, compiled=compiled, nonzeros=nonzeros)


def steps_within(seconds: float, n_dof: int, integrator: str, *, chain: int = 0, compiled: bool = True,
                 nonzeros: int = 0) -> int:
    """The most steps whose estimate fits in `seconds` (at least 0; 2**63 - 1 for an infinite time)."""
    if math.isinf(seconds):
        return 2**63 - 1
    return max(0, int(seconds / step_seconds(n_dof, integrator, chain=chain, compiled=compiled, nonzeros=nonzeros)))


def chunk_steps(n_dof: int, integrator: str, *, chain: int = 0, nonzeros: int = 0) -> int:
    """Steps of the compiled loop between two returns to Python: `CHUNK_SECONDS` of estimated work (>= 1)."""
    return max(1, steps_within(CHUNK_SECONDS, n_dof, integrator, chain=chain, nonzeros=nonzeros))
