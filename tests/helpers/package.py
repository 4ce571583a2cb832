"""Shared test helpers: package."""

from __future__ import annotations

#: The folders the README's first command renders.
BUNDLED_FOLDERS = ("chains", "molecules", "networks", "crystals", "dynamics")


#: What ``import vibra`` never imports (issue 45): each is loaded by the code that uses it only.
HEAVY = ("pyvista", "ase", "phonopy", "matplotlib", "numba", "llvmlite", "sympy", "mpmath", "yaml")
