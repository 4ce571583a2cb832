"""Solver paths that run past one process: ``slepc`` (SLEPc over MPI, a separate program).

- `slepc`: this side of the path (hand-off files, the launch, the checks) and `slepc_path`
- ``slepc_worker.py``: the MPI program, run by path under a Python with slepc4py
"""

from __future__ import annotations

from vibra.solvers.distributed.slepc import INSTALL, SlepcUnavailableError, ranks, slepc_path, unavailable

__all__ = ["INSTALL", "SlepcUnavailableError", "ranks", "slepc_path", "unavailable"]
