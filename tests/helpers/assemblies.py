"""Shared test helpers: the iterative path's benchmark assembly."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from vibra import networks
from vibra.system import System


def synthetic_assembly(n_sites: int) -> System:
    """The benchmark's synthetic assembly (benchmarks/assembly_builder.py: copies of ubiquitin packed face
    to face), ANM at 15 Å: its low spectrum is the tight cluster of one soft mode per copy."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "assembly_builder.py"
    spec = importlib.util.spec_from_file_location("assembly_builder", path)
    assert spec is not None and spec.loader is not None
    builder = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(builder)
    return networks.anm(builder.synthetic_assembly(n_sites), cutoff=15.0)
