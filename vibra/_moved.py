"""Old public module names of vibra, served as the very modules they moved to.

`MOVED` maps each formerly public module to its new place. `vibra/__init__.py` puts one
`MovedFinder` at the front of ``sys.meta_path``; it answers an old name, and any dotted name
below an old package (``vibra.scene.schema`` -> ``vibra.pipeline.scene.schema``), with a
loader whose module *is* the new one: ``sys.modules`` then holds the one module object under
both names, so ``import vibra.pencil``, ``from vibra.lagrangian import linearize``,
``monkeypatch.setattr(vibra.pencil, ...)`` and ``vibra.pencil.x`` all reach the real module.
Code inside vibra, its tests, benchmarks, notebooks and docs use the new names.

Examples
--------
>>> import vibra.pencil, vibra.solvers.structured.pencil
>>> vibra.pencil is vibra.solvers.structured.pencil
True
>>> vibra.pencil.__name__
'vibra.solvers.structured.pencil'
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
from types import ModuleType
from typing import Sequence

__all__ = ["MOVED", "MovedFinder", "new_name", "install"]

#: Old module name -> new module name (the formerly public top-level modules of vibra).
MOVED: dict[str, str] = {
    "vibra.pencil": "vibra.solvers.structured.pencil",
    "vibra.quadratic": "vibra.solvers.structured.quadratic",
    "vibra.lagrangian": "vibra.mechanics.lagrangian",
    "vibra.linearization": "vibra.mechanics.linearization",
    "vibra.pendulum": "vibra.mechanics.pendulum",
    "vibra.rigid": "vibra.mechanics.rigid",
    "vibra.gyroscopic": "vibra.mechanics.gyroscopic",
    "vibra.structures": "vibra.networks.pdb",
    "vibra.scene": "vibra.pipeline.scene",
    "vibra.plan": "vibra.pipeline.plan",
    "vibra.report": "vibra.pipeline.report",
    "vibra.render": "vibra.pipeline.render",
    "vibra.sweep": "vibra.pipeline.sweep",
}


def new_name(name: str) -> str | None:
    """The new name of module `name` (an old name, or a dotted name below one), else None."""
    for old, new in MOVED.items():
        if name == old or name.startswith(old + "."):
            return new + name[len(old):]
    return None


class _MovedLoader(importlib.abc.Loader):
    """Loads an old name as the module of its new name (imported first if need be)."""

    def __init__(self, target: str) -> None:
        self.target = target
        self.spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(self.target)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        # the import system has set module.__spec__ to the old name's spec: give back the real one
        module.__spec__ = self.spec


class MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old names of `MOVED` (and the names below them); nothing else."""

    def find_spec(self, fullname: str, path: Sequence[str] | None = None,
                  target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        new = new_name(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _MovedLoader(new))


def install() -> None:
    """Put one `MovedFinder` at the front of ``sys.meta_path`` (once, however often called)."""
    if not any(isinstance(finder, MovedFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
