"""What a sweep applies to, and what it computes at each point.

A sweep computes per point what the scene computes, as numbers for one table row: the normal
modes of its system (the frequencies) and, for a scene with a ``[compute.response]`` table, the
peak of its forced response (`response_summary`: two derived columns). Which keys it may vary
follows from that, one class of key at a time (`check_swept_keys`, before any point is solved):

- keys that change the normal modes: every key of ``[system]`` and `SOLVE_KEYS` (the units and
  what the solve reads of ``[compute]``); also the response of a scene that has one;
- keys that change only the forced response: every key of ``[compute.response]`` (the damping
  ``alpha`` and ``beta``, the driven dof, the frequency grid, the method); the frequencies of
  the rows stay, the response columns move;
- keys that change only a dynamics scene's trajectory (its ``[compute]``: time step, thermostat,
  initial state; the anharmonic terms of ``[system]``, `TRAJECTORY_ONLY`): refused, naming the
  key, as a sweep integrates no trajectory (run the scene once per value instead);
- any other key (``[draw]``, ``compute.shapes``, limits): refused, naming the key.

The kinds without one list of normal modes are refused at the kind (`NOT_SWEPT`). A sweep whose
rows still all came out the same warns (`SweepWarning`).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Sequence

import numpy as np

from vibra.pipeline.scene import SCENE_KINDS, Scene, SceneError
from vibra.pipeline.sweep.tables import split_key

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from vibra.generalized import GeneralizedSystem
    from vibra.pipeline.sweep.results import SweepRow
    from vibra.system import System
    from vibra.units import UnitSystem

__all__ = ["SOLVE_KEYS", "RESPONSE_TABLE", "TRAJECTORY_ONLY", "NOT_SWEPT", "check_swept_keys", "response_summary",
           "response_columns", "SweepWarning", "warn_if_constant"]


#: The scene keys outside ``[system]`` that change the normal modes: the units and what a sweep's
#: solve reads of ``[compute]``.
SOLVE_KEYS = ("units", "compute.n_modes", "compute.accuracy", "compute.band", "compute.solver")
#: The table whose keys change only the forced response (`response_summary`).
RESPONSE_TABLE = "compute.response"
#: builder -> the ``[system]`` keys of a dynamics scene that enter only its trajectory, not its
#: normal modes (the FPUT chain's cubic and quartic terms: its modes are the harmonic chain's).
TRAJECTORY_ONLY = {"fput": ("alpha", "beta")}
#: Scene kinds a sweep does not apply to, and why (one line each: `SceneKind.no_sweep`).
NOT_SWEPT = {name: kind.no_sweep for name, kind in SCENE_KINDS.items() if kind.no_sweep is not None}
_COMPUTES = ("a sweep tabulates the normal modes of the scene's system (and the peak of its forced response, "
             "with [compute.response])")


def check_swept_keys(keys: Sequence[str], source: str, scene: Scene) -> None:
    """Refuse, naming it, a swept key that changes nothing a sweep computes (module docstring).

    Raises
    ------
    SceneError
        A dynamics scene's ``[compute]`` key or anharmonic term (a trajectory a sweep does not
        run), or a key that changes no solve.
    """
    for key in keys:
        base = ".".join(split_key(key, source)[0])
        if scene.kind == "dynamics" and _trajectory_only(base, scene):
            what = ("is an anharmonic term: it changes only the trajectory of a dynamics scene, not the normal modes "
                    "of its harmonic system" if base.startswith("system.") else "changes only a dynamics scene's run")
            raise SceneError(source, key, f"{what}: a sweep tabulates the normal modes of the scene's harmonic "
                             "system and integrates no trajectory, so every point would be the same; run the scene "
                             f"once per value of {key} (vibra report), or vary a key of [system] that changes the "
                             "harmonic system")
        if base in SOLVE_KEYS or base.startswith(("system.", RESPONSE_TABLE + ".")):
            continue
        raise SceneError(source, key, f"changes no solve: {_COMPUTES}, so every point would be the same; vary a key "
                         f"of [system], of [{RESPONSE_TABLE}], or one of {', '.join(SOLVE_KEYS)}")


def _trajectory_only(base: str, scene: Scene) -> bool:
    if base.startswith("system."):
        return base.split(".", 1)[1] in TRAJECTORY_ONLY.get(scene.system.builder, ())
    return base.startswith("compute.")


def response_columns(units: UnitSystem) -> tuple[str, str]:
    """The names of the two response columns, with their units (a `vibra.units.UnitSystem`):
    ``("peak_receptance (m/N)", "peak_omega (rad/s)")`` for an SI scene."""
    return f"peak_receptance ({units.receptance})", f"peak_omega ({units.omega})"


def response_summary(scene: Scene, system: System | GeneralizedSystem) -> tuple[tuple[str, float], ...]:
    """The peak of the scene's forced response, as a sweep row's derived columns; () without
    ``[compute.response]``.

    The response is the one ``vibra report`` draws (`vibra.pipeline.plan.checks.response_request`:
    a unit force at ``force_site``, Rayleigh damping C = alpha M + beta K, the scene's grid of
    frequencies and method); the columns are, over that grid, the largest driving-point
    receptance |x_f(omega)| (displacement of dof ``force_site`` per unit force, in length per
    force unit: m/N for SI) and the omega where it is reached (rad per time unit).
    """
    if scene.compute.response is None:
        return ()
    from vibra.pipeline.plan.checks import response_request
    from vibra.response import frequency_response

    K, M, C, G, omegas, force, method, n_modes = response_request(scene, system)
    result = frequency_response(K, M, C, omegas, force, method=method, n_modes=n_modes, units=system.units, G=G)
    amplitude = np.abs(result.response[:, scene.compute.response.force_site])
    peak = int(np.argmax(amplitude))
    names = response_columns(system.units)
    return (names[0], float(amplitude[peak])), (names[1], float(result.omegas[peak]))


class SweepWarning(UserWarning):
    """A sweep whose points all gave the same table row: the swept keys change nothing it computes."""


def warn_if_constant(rows: Sequence[tuple[SweepRow, NDArray[np.float64] | None]], keys: Sequence[str], name: str) -> None:
    """Warn when every point gave the same frequencies and derived values, bit for bit (a builder's
    keyword that its system ignores, a key whose values round to the same system)."""
    if len(rows) < 2:
        return
    first = rows[0][0]
    if all(np.array_equal(row.omega, first.omega) and row.derived == first.derived for row, _ in rows[1:]):
        warnings.warn(f"{name}: all {len(rows)} points of {', '.join(keys)} gave the same frequencies: the swept "
                      "key(s) change nothing the sweep computes", SweepWarning, stacklevel=3)
