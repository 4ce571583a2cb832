"""What each accuracy level means: the one place that says it (docs/architecture.md, "Three accuracy levels").

Every solve takes ``accuracy=`` with one of `LEVELS`, and every reader (the solver paths,
`normal_modes`, `System.modes`, crystals, sweeps, scene files and their checks) takes the
levels, their targets, the default time limit and what "fast" leaves out from here:

- ``"fast"``: LAPACK/ARPACK-class solves, absolute accuracy ~eps ||K~||, with its bound. It skips
  what gives relative accuracy (`relative`): the spring factor (`uses_springs`: the standard paths
  run whether or not the springs are known) and a full mass matrix's one-sided Jacobi.
- ``"high"`` (the default): every requested frequency to `HIGH_TARGET` (1e-10) relative where the
  structure allows, with an a-posteriori bound; the steps that only tighten a bound already
  within it are left to "certified", and a bound left looser says so.
- ``"certified"``: every bound a certificate, within `CERTIFIED_OVERESTIMATE` (1000) times the
  true error or `CERTIFIED_TARGET` (1e-13) relative, at the cost it takes (estimated up front and
  refused over the time limit).

A solve whose estimate (`vibra.solvers.registry`, from sizes) exceeds `TIME_LIMIT_S` is refused
before any work unless the caller raises the limit (``max_seconds=``, a scene's
``compute.time_limit_s``).

>>> check("certified")
'certified'
>>> uses_springs("fast"), uses_springs("high")
(False, True)
"""

from __future__ import annotations

from typing import Literal

__all__ = ["Accuracy", "LEVELS", "DEFAULT", "PROMISES", "HIGH_TARGET", "CERTIFIED_TARGET", "CERTIFIED_OVERESTIMATE",
           "TIME_LIMIT_S", "relative", "uses_springs", "check"]

#: The type of an ``accuracy=`` argument.
Accuracy = Literal["fast", "high", "certified"]

#: The accuracy levels every solve takes, cheapest first.
LEVELS: tuple[str, ...] = ("fast", "high", "certified")

#: The level of a solve that names none.
DEFAULT = "high"

#: The relative bound "high" promises on every requested frequency where the structure allows.
HIGH_TARGET = 1e-10

#: "certified": each bound within this many times the true error, or within `CERTIFIED_TARGET` relative.
CERTIFIED_OVERESTIMATE = 1000.0
CERTIFIED_TARGET = 1e-13

#: Estimated seconds above which a solve is refused unless the caller raises the limit.
TIME_LIMIT_S = 600.0

#: What each level promises, in words (error messages and documentation quote it).
PROMISES: dict[str, str] = {
    "fast": "LAPACK/ARPACK-class solves, absolute accuracy ~eps ||K~||, with its bound; the spring factor is not used",
    "high": f"every requested frequency to ~{HIGH_TARGET:g} relative where the structure allows, with an "
            "a-posteriori bound",
    "certified": f"every bound a certificate, within {CERTIFIED_OVERESTIMATE:g}x the true error or "
                 f"{CERTIFIED_TARGET:g} relative, at the cost it takes",
}


def relative(level: str) -> bool:
    """Whether `level` asks for relative accuracy where the structure allows ("fast" does not)."""
    return level != "fast"


def uses_springs(level: str) -> bool:
    """Whether `level` solves through the spring factor K = B^T W B where it is known ("fast" skips it)."""
    return relative(level)


def check(level: object, *, name: str = "accuracy", offered: tuple[str, ...] = LEVELS, by: str = "") -> str:
    """`level` when it is one of `offered` (all of `LEVELS` by default).

    Raises
    ------
    ValueError
        Not a level (naming the levels), or a level `by` does not offer (naming what that level
        promises and the levels offered).

    >>> check("certified", offered=("fast", "high"), by="phonons")
    Traceback (most recent call last):
    ...
    ValueError: accuracy is 'certified' (every bound a certificate, within 1000x the true error or 1e-13 relative, at the cost it takes), which phonons does not offer; expected one of 'fast', 'high'
    """
    if level not in LEVELS:
        raise ValueError(f"{name} is {level!r}; expected one of {', '.join(repr(x) for x in offered)}")
    if level not in offered:
        raise ValueError(f"{name} is {level!r} ({PROMISES[str(level)]}), which {by or 'this function'} does not "
                         f"offer; expected one of {', '.join(repr(x) for x in offered)}")
    return str(level)
