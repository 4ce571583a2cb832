"""What a sweep holds in memory, from sizes, before any point is solved (issue 44).

A sweep keeps one row per point (its frequencies, branches and a few numbers) and, while it
tracks branches, mode vectors: in one process only the last point of each grid line (the
tracker's reference, `vibra.pipeline.sweep.tracking`), on a cluster every point's until all
have come back (points finish in any order, and a line must be followed in its own). Each
process also holds one solve at a time (the solver registry's memory estimate, the one
``vibra validate`` prints). So, for `count` points of `n_dof` dofs and `n_modes` modes:

    rows     count x (ROW_BYTES + MODE_BYTES n_modes)
    vectors  8 n_dof n_modes x (lines in one process, count on a cluster)
    solve    the registry's estimate of one point

`sweep` refuses a sweep whose total exceeds the memory left (the solvers' `MEMORY_LIMIT`, else
the memory available) before any point is solved, naming the count that would fit and that
``track=False`` drops the vectors.
"""

from __future__ import annotations

from dataclasses import dataclass

from vibra._core.text import counted
from vibra.solvers.budget import ResourceLimitError, describe_bytes, memory_limit

__all__ = ["SweepMemory", "sweep_memory", "check_sweep_memory", "ROW_BYTES", "MODE_BYTES"]

#: One row's fixed part (the row object, its parameters and numbers, its arrays' headers) and its
#: part per mode (frequencies and branches), bytes: tracemalloc measured 1.7 kB for rows of 50
#: modes and 8.7 kB for rows of 400 (a chain swept along its stiffness), under this model.
ROW_BYTES = 1000
MODE_BYTES = 24


@dataclass(frozen=True)
class SweepMemory:
    """Bytes a sweep holds at its peak, by part (see the module)."""

    rows: float
    vectors: float
    solve: float

    @property
    def total(self) -> float:
        return self.rows + self.vectors + self.solve

    def describe(self) -> str:
        parts = [f"rows {describe_bytes(self.rows)}"]
        if self.vectors:
            parts.append(f"tracked vectors {describe_bytes(self.vectors)}")
        parts.append(f"one solve {describe_bytes(self.solve)}")
        return f"~{describe_bytes(self.total)} ({', '.join(parts)})"


def sweep_memory(count: int, *, n_dof: int, n_modes: int, solve: float, track: bool, lines: int,
                 distributed: bool) -> SweepMemory:
    """The memory of a sweep of `count` points (Python integers: no wrap-around)."""
    rows = float(count) * (ROW_BYTES + MODE_BYTES * n_modes)
    held = (count if distributed else lines) if track else 0
    return SweepMemory(rows=rows, vectors=8.0 * n_dof * n_modes * held, solve=float(solve))


def check_sweep_memory(count: int, *, n_dof: int, n_modes: int, solve: float, track: bool, lines: int,
                       distributed: bool, max_memory: float | None = None) -> SweepMemory:
    """The sweep's `SweepMemory`; `ResourceLimitError` when it exceeds the limit, naming the
    points that would fit (and ``track=False`` when the vectors are what does not fit)."""
    memory = sweep_memory(count, n_dof=n_dof, n_modes=n_modes, solve=solve, track=track, lines=lines,
                          distributed=distributed)
    limit = memory_limit(max_memory)
    if limit is None or memory.total <= limit[1]:
        return memory
    source, room = limit
    per_point = (memory.rows + memory.vectors) / max(count, 1)  # a smaller grid of the same shape: lines shrink too
    fits = max(int((room - memory.solve) // per_point), 0) if per_point > 0 else 0
    untracked = sweep_memory(count, n_dof=n_dof, n_modes=n_modes, solve=solve, track=False, lines=lines,
                             distributed=distributed)
    ways = [f"sweep at most {fits:,} points" if fits else "sweep a smaller system"]
    if track and memory.vectors and untracked.total <= room:
        ways.append("track=False (branches by rank; no vectors held)")
    raise ResourceLimitError(
        f"{counted(count, 'point', thousands=True)} of {counted(n_dof, 'dof')} and {counted(n_modes, 'mode')} would "
        f"hold {memory.describe()}, more than the "
        f"{describe_bytes(room)} {source}; {' or '.join(ways)}")
