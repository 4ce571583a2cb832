"""What `vibra validate` checks on a built system, and how a failing step becomes a `SceneError`.

`check_plan(scene, system)` runs, on the system the builder returned, the cheap checks of
what the later steps would refuse: a solver that cannot serve the system's structure, and a
response grid that meets a pole of an undamped (or free) system. `step_error(scene, step,
error)` turns what a library function refused while a step ran into a `SceneError` at the
scene key that controls that step, so the command line prints one line, never a traceback.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.sparse as sp

from vibra.scene import Scene, SceneError
from vibra.solvers import DENSE_ALL_LIMIT

__all__ = ["check_plan", "step_error", "STEP_KEYS", "REFUSALS", "SPECTRUM_CHECK_LIMIT"]

#: A response grid is checked against the system's frequencies up to this many dofs (a fast
#: frequencies-only solve); larger systems are checked when the response step runs.
SPECTRUM_CHECK_LIMIT = 2000

#: step name -> the scene key that controls it (named in the error of a failing step).
STEP_KEYS = {
    "build": "system", "modes": "compute", "crosscheck": "compute.crosscheck", "response": "compute.response",
    "continuum": "compute.continuum", "dispersion": "draw.dispersion", "structure": "system",
    "render-modes": "draw.modes", "render-gif": "draw.gif", "chart-spectrum": "draw.spectrum",
    "chart-dispersion": "draw.dispersion", "chart-response": "draw.response",
    "chart-convergence": "draw.convergence",
}

#: What a library function raises when it refuses a request or a solve fails (`LinAlgError` is
#: a ValueError, ARPACK's errors are RuntimeErrors); anything else is a bug, not a scene error.
REFUSALS = (ValueError, TypeError, ArithmeticError, RuntimeError, MemoryError)


def step_error(scene: Scene, step: str, error: BaseException) -> SceneError:
    """The `SceneError` for `error` raised by `step`, at the scene key that controls the step."""
    if isinstance(error, SceneError):
        return error
    key = STEP_KEYS.get(step, "")
    if step == "modes" and scene.compute.solver != "auto":
        key = "compute.solver"
    text = " ".join(str(error).split()) or type(error).__name__
    if not isinstance(error, (ValueError, TypeError)) or type(error).__name__ == "LinAlgError":
        text = f"{type(error).__name__}: {text}"
    if len(text) > 300:
        text = text[:297] + "..."
    return SceneError(scene.source, key, f"the {step} step failed: {text}")


def _solver(scene: Scene, system: Any) -> None:
    solver = scene.compute.solver
    if solver == "auto":
        return
    n_dof = system.n_dof
    diagonal_masses = np.ndim(system.mass_matrix()) == 1
    if solver == "accurate" and system.spring_factor() is None:
        raise SceneError(scene.source, "compute.solver", f"'accurate' needs a spring system (K = B^T W B); the "
                         f"{scene.system.builder!r} builder gives none; use 'auto' or 'dense'")
    if solver in ("tridiagonal", "banded") and not diagonal_masses:
        raise SceneError(scene.source, "compute.solver", f"{solver!r} needs diagonal masses; this system has a "
                         "full mass matrix; use 'auto' or 'dense'")
    if solver == "tridiagonal":
        K = sp.coo_matrix(system.hessian())
        width = int(np.max(np.abs(K.row - K.col), initial=0))
        if width > 1:
            raise SceneError(scene.source, "compute.solver", f"'tridiagonal' needs a tridiagonal K; this K couples "
                             f"dofs {width} apart (a periodic or 2-D/3-D system); use 'banded' or 'auto'")
    wanted = scene.compute.n_modes is None and scene.compute.band is None
    if solver == "dense" and wanted and n_dof > DENSE_ALL_LIMIT:
        raise SceneError(scene.source, "compute.solver", f"'dense' on {n_dof} dofs would need "
                         f"{8 * n_dof * n_dof / 2**30:.1f} GiB; give compute.n_modes or use 'auto'")


def _response(scene: Scene, system: Any) -> None:
    r = scene.compute.response
    if r is None or scene.kind == "oscillator" or system.n_dof > SPECTRUM_CHECK_LIMIT:
        return
    omega = np.asarray(system.modes(vectors=False, accuracy="fast").omega, dtype=float)
    top = float(np.max(np.abs(omega), initial=0.0))
    zero = np.abs(omega) <= 1e-6 * top
    if r.omega_min == 0.0 and zero.any():
        raise SceneError(scene.source, "compute.response.omega_min", "is 0, where this free system (it has "
                         f"{int(zero.sum())} rigid-body modes) has an unbounded static response; start the grid "
                         "above 0 or hold the system (frozen_sites, anchors, fixed ends)")
    if r.alpha > 0.0 or (r.beta > 0.0 and not zero.any()):
        return
    grid = np.linspace(r.omega_min, r.omega_max, r.n_points)
    tolerance = 16 * system.n_dof * np.finfo(float).eps * max(top, r.omega_max) ** 2
    moving = omega[~zero] if r.beta > 0.0 else omega
    for w in grid:
        hit = np.abs(moving ** 2 - w * w) <= tolerance
        if hit.any():
            raise SceneError(scene.source, "compute.response", f"the frequency grid meets the undamped resonance "
                             f"omega = {float(moving[hit][0]):.6g}, where the response is infinite; add damping "
                             "(alpha or beta) or change omega_min, omega_max or n_points")


def check_plan(scene: Scene, system: Any) -> None:
    """Check, on the built `system`, what the plan's later steps would refuse (cheap checks only).

    Raises
    ------
    SceneError
        A solver that cannot serve this system (``compute.solver``), or a response grid on
        a pole: omega = 0 for a free system, an undamped resonance (``compute.response``).
    """
    if scene.kind == "oscillator":
        return
    try:
        _solver(scene, system)
        _response(scene, system)
    except REFUSALS as error:
        raise step_error(scene, "modes", error) from error
