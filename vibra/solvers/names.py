"""The solver names a caller may pass, in a module that imports nothing.

`normal_modes(solver=...)`, `System.modes(solver=...)` and scene files accept `SOLVER_NAMES`;
``"auto"`` lets the registry (`vibra.solvers.registry.PATHS`) choose a path. A scene check reads
the names from here without importing numpy or the solvers (`vibra validate` on a refused scene).

>>> SOLVER_NAMES[0]
'auto'
"""

from __future__ import annotations

__all__ = ["SOLVER_NAMES"]

#: The solver names that `normal_modes(solver=...)`, `System.modes(solver=...)` and scene
#: files accept; ``"auto"`` chooses one of the paths (`vibra.solvers.registry.PATHS`).
SOLVER_NAMES: tuple[str, ...] = ("auto", "dense", "tridiagonal", "banded", "sparse", "accurate", "pencil", "slepc",
                                   "iterative")
