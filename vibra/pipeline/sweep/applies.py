"""What a sweep applies to: the scene kinds without one list of normal modes (refused at the
kind), the keys that change no point of the table (refused naming the key), and a sweep whose
points all came out the same (`SweepWarning`).
"""

from __future__ import annotations

import warnings
from typing import Any, Sequence

import numpy as np

from vibra.pipeline.scene import SceneError

__all__ = ["SOLVE_KEYS", "NOT_SWEPT", "check_swept_keys", "SweepWarning", "warn_if_constant"]


#: The scene keys outside ``[system]`` that change a sweep's table: the units and what `_solve_scene`
#: reads of ``[compute]``. Any other key (a dynamics scene's time step, a chart's setting) changes
#: no point: sweeping it is refused up front (`check_swept_keys`).
SOLVE_KEYS = ("units", "compute.n_modes", "compute.accuracy", "compute.band", "compute.solver")
#: Scene kinds a sweep does not apply to, and why (one line each).
NOT_SWEPT = {
    "oscillator": "an oscillator scene has no normal modes to sweep",
    "crystal": "a crystal scene has phonon branches over the wave vector, not one list of normal modes: vibra sweep "
               "does not apply to it (vary the crystal in a script and tabulate Crystal.frequencies at the q you want)",
}


def check_swept_keys(keys: Sequence[str], source: str, kind: str) -> None:
    """Refuse a swept key that changes no point of the table (a key outside ``[system]`` and `SOLVE_KEYS`)."""
    for key in keys:
        if key.startswith("system.") or key in SOLVE_KEYS:
            continue
        what = "only a dynamics scene's run" if kind == "dynamics" and key.startswith("compute.") else "no solve"
        raise SceneError(source, key, f"changes {what}: a sweep tabulates the normal modes of the scene's system, "
                         f"so every point would be the same; vary a key of [system] or one of {', '.join(SOLVE_KEYS)}")


class SweepWarning(UserWarning):
    """A sweep whose points all gave the same table row: the swept keys change no normal mode."""


def warn_if_constant(rows: Sequence[tuple[Any, Any]], keys: Sequence[str], name: str) -> None:
    """Warn when every point gave the same frequencies and derived values, bit for bit (e.g. a
    dynamics scene's anharmonic coefficient: its normal modes are the harmonic system's)."""
    if len(rows) < 2:
        return
    first = rows[0][0]
    if all(np.array_equal(row.omega, first.omega) and row.derived == first.derived for row, _ in rows[1:]):
        warnings.warn(f"{name}: all {len(rows)} points of {', '.join(keys)} gave the same frequencies: the swept "
                      "key(s) change no normal mode of the system (a dynamics scene's anharmonic terms, for "
                      "one, do not enter its harmonic modes)", SweepWarning, stacklevel=3)
