"""What a crystal's finite differences cost, from sizes alone, before any force call (issue 44).

One place for the cost of `finite_difference_force_constants` (and `from_ase` with a
calculator): the number of force calls, the peak memory, and, for a closed-form calculator
(`vibra.molecules.noise.DETERMINISTIC_CALCULATORS`), the seconds of those calls; the choice of
``symmetry="auto"`` weighs the same figures. The memory is checked against the same limit as a
solve (`vibra.solvers.budget.MEMORY_LIMIT`, else the memory available) before phonopy builds
the supercell, and a refusal names the largest supercell that would fit.

The memory model, measured with tracemalloc on fcc Al with EMT (supercells of 64 to 1,000
atoms; the model is within 10 % of every peak): phonopy's full supercell force constants take
72 n^2 bytes for n supercell atoms, and a run holds about eight such arrays at once (the fit at
h and at 2h, the projection, the truncation and the entry errors, phonopy's own copies); the
symmetry search adds phonopy's atomic permutations, 8 bytes per (operation x cell x supercell
atom); the forces take 24 n bytes per force call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from vibra.solvers.budget import ResourceLimitError, describe_bytes, describe_seconds, memory_limit

__all__ = ["ForceConstantsCost", "force_constants_cost", "check_memory", "symmetry_pays",
           "SYMMETRY_FIXED_SECONDS", "SYMMETRY_SECONDS", "FORCE_SECONDS", "FULL_ARRAYS"]

#: phonopy's symmetry set-up: a fixed part (its Symmetry of the cell and of the supercell) and
#: seconds per (space-group operation x cell x supercell atom), its atomic permutations. Measured:
#: ASE's Al test (48 operations x 343 cells x 343 atoms) 6.2 s; ZnS on 3x3x3 (24 x 27 x 54) 0.15 s.
SYMMETRY_FIXED_SECONDS = 0.1
SYMMETRY_SECONDS = 1.1e-6
#: One force call of a closed-form calculator, seconds per supercell atom: the cheapest listed
#: (Lennard-Jones, ~2e-5; EMT measured 2e-4), since the choice only weighs those. As a time
#: estimate it is a lower bound.
FORCE_SECONDS = 2e-5
#: Full (n, n, 3, 3) force-constant arrays a run holds at its peak (measured 7.3-7.7 with symmetry
#: off on 216-1,000 atoms; the symmetry search's permutations are counted on their own).
FULL_ARRAYS = 8


@dataclass(frozen=True)
class ForceConstantsCost:
    """The cost of one finite-difference run, from sizes.

    Attributes
    ----------
    n_supercell_atoms : int
    n_force_calls : int
        Force calls (the reference supercell included; without the noise probe). Before the
        displacements are generated, an upper bound: six per unit-cell atom and step.
    exact_calls : bool
        Whether `n_force_calls` is the count of the generated displacements or the bound.
    memory : float
        Peak bytes.
    seconds : float or None
        The force calls of a closed-form calculator at `FORCE_SECONDS` (a lower bound), plus the
        symmetry search; None for any other calculator, whose force call costs what it costs.
    """

    n_supercell_atoms: int
    n_force_calls: int
    exact_calls: bool
    memory: float
    seconds: float | None

    def describe(self) -> str:
        """One line: '13 force calls of a 512-atom supercell, ~250 MiB of memory, >= 0.1 s'."""
        calls = f"{'' if self.exact_calls else 'at most '}{self.n_force_calls} force calls"
        time = "" if self.seconds is None else f", at least {describe_seconds(self.seconds)}"
        return (f"{calls} of a {self.n_supercell_atoms}-atom supercell, ~{describe_bytes(self.memory)} "
                f"of memory{time}")


def _memory(n_super: int, n_calls: int, n_ops: int, cells: int, symmetry: bool) -> float:
    permutations = 8.0 * n_ops * cells * n_super if symmetry else 0.0
    return FULL_ARRAYS * 72.0 * n_super * n_super + permutations + 24.0 * n_super * n_calls


def force_constants_cost(n_unit: int, cells: int, *, n_ops: int, symmetry: bool, steps: int,
                         deterministic: bool, n_moves: int | None = None) -> ForceConstantsCost:
    """The cost of finite differences on `cells` copies of an `n_unit`-atom cell.

    `steps` is 1 (h) or 2 (h and 2h, the error estimate); `n_moves` the displacements generated
    (None: the bound without symmetry, +-x, +-y, +-z of every unit-cell atom); `n_ops` the space
    group's operations (the symmetry search's permutations).
    """
    n_super = n_unit * cells  # Python integers: no wrap-around
    exact = n_moves is not None
    moves = n_moves if n_moves is not None else 6 * n_unit
    n_calls = 1 + steps * moves
    seconds = None
    if deterministic:
        seconds = n_calls * n_super * FORCE_SECONDS
        if symmetry:
            seconds += SYMMETRY_FIXED_SECONDS + SYMMETRY_SECONDS * n_ops * cells * n_super
    return ForceConstantsCost(n_supercell_atoms=n_super, n_force_calls=n_calls, exact_calls=exact,
                              memory=_memory(n_super, n_calls, n_ops, cells, symmetry), seconds=seconds)


def symmetry_pays(n_unit: int, cells: int, n_ops: int, deterministic: bool) -> bool:
    """symmetry="auto": True unless a closed-form calculator's extra force calls cost less than the symmetry search."""
    if not deterministic:
        return True
    n_super = cells * n_unit
    search = SYMMETRY_FIXED_SECONDS + SYMMETRY_SECONDS * n_ops * cells * n_super
    saved = 6 * n_unit * n_super * FORCE_SECONDS  # without symmetry: +-x, +-y, +-z of every atom
    return search < saved


def _largest_cells(n_unit: int, n_ops: int, symmetry: bool, steps: int, limit: float) -> int:
    """The most cells whose run fits in `limit` bytes (0 when not even one does)."""
    low, high = 0, 1
    while _memory(n_unit * high, 1 + steps * 6 * n_unit, n_ops, high, symmetry) <= limit:
        low, high = high, high * 2
    while high - low > 1:
        middle = (low + high) // 2
        if _memory(n_unit * middle, 1 + steps * 6 * n_unit, n_ops, middle, symmetry) <= limit:
            low = middle
        else:
            high = middle
    return low


def check_memory(cost: ForceConstantsCost, *, supercell: Sequence[int], n_unit: int, n_ops: int, symmetry: bool,
                 steps: int, max_memory: float | None) -> None:
    """Raise `ResourceLimitError` if `cost` needs more memory than `max_memory` (None: the
    solvers' `MEMORY_LIMIT`, else the memory available; ``float("inf")``: no limit), naming the
    number of cells that would fit."""
    known = memory_limit(max_memory)
    if known is None:
        return
    source, limit = known
    if cost.memory <= limit:
        return
    cells = _largest_cells(n_unit, n_ops, symmetry, steps, limit)
    fits = (f"at most {cells} cells ({math.floor(cells ** (1 / 3) + 1e-9)} along each of three axes)"
            if cells else "no supercell of this cell")
    raise ResourceLimitError(
        f"supercell {list(supercell)}: {cost.describe()}, more than the {describe_bytes(limit)} {source}; "
        f"{fits} would fit; or pass max_memory= (float('inf')) to run it anyway")
